"""What the blend search's plans reuse or defer gives the same numbers as computing everything afresh: the
candidates' durations against fresh plans of the certified shapes, corners interleaved (ik_batch's first-point
cache must not carry one path's start over to another's), the returned shapes certified, ik_batch against a cleared
cache, and the lift's shared frames against separate Jacobian and bias calls."""

import importlib

import numpy as np
import pytest

from pathmotion.geometry import FixedOrientation, Line, TaskPath
from pathmotion.geometry.blends import g2_shape_for_tolerance
from pathmotion.planning import PlanSettings
from pathmotion.planning.blend_search import FAST, _Objective, duration_with, optimal_blends
from pathmotion.robot import fk, frame_acceleration_bias, jacobian, load_robot
from pathmotion.robot.kinematics import jacobian_and_bias
from pathmotion.robot.opw import flip_wrist

ik = importlib.import_module("pathmotion.robot.ik")  # the module (pathmotion.robot.ik is also the function)

SETTINGS = PlanSettings(start="zero", end="zero",
                        limits={"use_velocity": True, "use_acceleration": True, "use_torque": False}, grid_points=300,
                        verify=False, baselines=False)
#: Coordinates (balance, shapes, offsets [tolerance], runs [run unit]): a quintic, racing lines.
COORDINATES = (np.array([0.5, 0.7, 0.7, 0.0, 0.0, 1.0, 1.0]), np.array([0.45, 0.6, 0.8, 0.5, 0.7, 1.5, 2.0]),
               np.array([0.55, 0.9, 0.5, 0.9, 0.2, 0.8, 1.2]))


def _turn(deg: float, start) -> TaskPath:
    """Two 0.2 m lines from ``start`` [m] in a horizontal plane, turning left by ``deg``."""
    p0 = np.asarray(start, float)
    p1 = p0 + (0.2, 0.0, 0.0)
    a = np.radians(deg)
    return TaskPath((Line(p0, p1), Line(p1, p1 + 0.2 * np.array([np.cos(a), np.sin(a), 0.0]))), FixedOrientation())


def _fresh(robot, path: TaskPath, tolerance: float, objective: _Objective, x) -> float:
    """The duration of x's shape planned from nothing: certified shape, no ik_batch first point kept."""
    x = np.asarray(x, float)
    unit = objective.run_unit
    shape = g2_shape_for_tolerance(path, 0, tolerance, x[0], x[1], x[2], offsets=(x[3] * tolerance, x[4] * tolerance),
                                   runs=(x[5] * unit, x[6] * unit))
    ik._first_solution.cache_clear()
    return duration_with(robot, path, {0: shape}, SETTINGS)


def test_candidate_durations_equal_fresh_plans_on_interleaved_corners():
    robot = load_robot("irb140")
    corners = [(_turn(90.0, (0.35, -0.1, 0.45)), 0.005), (_turn(60.0, (0.40, 0.05, 0.55)), 0.001)]
    objectives = [_Objective(robot, path, {}, 0, tol, SETTINGS, None) for path, tol in corners]
    for x in COORDINATES:
        for (path, tol), objective in zip(corners, objectives):  # corner by corner: the caches hold both starts
            searched = objective(x)
            assert np.isfinite(searched)
            assert searched == pytest.approx(_fresh(robot, path, tol, objective, x), rel=1e-9, abs=0.0)


def test_candidates_carry_no_bound_and_the_shapes_returned_are_certified():
    robot = load_robot("irb140")
    path, tol = _turn(90.0, (0.35, -0.1, 0.45)), 0.005
    objective = _Objective(robot, path, {}, 0, tol, SETTINGS, None)
    objective(COORDINATES[1])
    (_, shape), = objective.cache.values()
    assert np.isnan(shape.deviation)  # the candidate: no precise bound computed
    certified = objective.certified(shape)
    bound = g2_shape_for_tolerance(path, 0, tol, 0.45, 0.6, 0.8, offsets=(0.5 * tol, 0.7 * tol),
                                   runs=(1.5 * objective.run_unit, 2.0 * objective.run_unit)).deviation
    assert certified == shape and certified.deviation == bound <= tol
    best = optimal_blends(robot, path, tol, settings=SETTINGS, search=FAST)
    assert all(np.isfinite(s.deviation) and 0.0 < s.deviation <= tol for s in best.shapes.values())


def test_ik_batch_equals_its_answer_without_the_first_point_kept():
    robot = load_robot("irb140")
    geo = robot.opw_detection[0]
    q_a = np.array([0.3, 0.2, 0.1, 0.8, 0.9, -0.4])
    q_b = flip_wrist(geo, q_a)  # the same pose on the other wrist branch
    path_q = q_a + np.linspace(0.0, 0.05, 40)[:, None]
    p, r = fk(robot, path_q)
    p_far, r_far = fk(robot, path_q + (0.2, -0.1, 0.1, 0.0, 0.0, 0.0))
    calls = [(p, r, q_a), (p, r, q_b), (p_far, r_far, q_a), (p, r, q_a)]
    kept = [ik.ik_batch(robot, *call) for call in calls]  # the first point kept from one call to the next
    for call, q in zip(calls, kept):
        ik._first_solution.cache_clear()
        np.testing.assert_array_equal(q, ik.ik_batch(robot, *call))
    assert np.max(np.abs(kept[0][0] - kept[1][0])) > 1.0  # the two references pick different wrist branches


def test_jacobian_and_bias_equal_the_separate_calls():
    robot = load_robot("irb140")
    rng = np.random.default_rng(3)
    for count in (5, 64):  # Pinocchio per point, and the serial chain's batch
        q, qd = rng.uniform(-1.0, 1.0, (2, count, robot.n))
        jac, bias_at = jacobian_and_bias(robot, q)
        np.testing.assert_array_equal(jac, jacobian(robot, q))
        np.testing.assert_array_equal(bias_at(qd), frame_acceleration_bias(robot, q, qd))


def test_the_polish_does_not_plan_its_start_again(monkeypatch):
    """The fast polish (on its own grid, the whole path) is handed its start's duration: it is that of a fresh plan
    of the start's blends on that grid, and the corner's polish with it equals the polish planning its start, one
    plan less where the start's coordinates build the start's blend."""
    import dataclasses

    from pathmotion.planning import blend_search
    from pathmotion.study.atlas import _settings, _task, corner_points

    jobs, polish_corner = [], blend_search._polish_corner

    def spied(job):
        jobs.append(job)
        return polish_corner(job)

    monkeypatch.setattr(blend_search, "_polish_corner", spied)
    robot = load_robot("irb140")
    optimal_blends(robot, _task(corner_points(150.0)), 1e-4, settings=_settings(False, verify=False, baselines=False),
                   search=FAST)
    assert jobs and all(job.start_T is not None for job in jobs)
    for job in jobs:
        assert job.start_T == duration_with(robot, job.original, job.shapes, job.settings, job.q_start)
        seeded, planned = polish_corner(job), polish_corner(dataclasses.replace(job, start_T=None))
        assert seeded[:3] == planned[:3]
        assert seeded[3] == planned[3] - 1


def test_the_path_of_a_sized_shape_reuses_its_offset_lines():
    """The racing lines a shape was sized with are those its path is built with (one computation, whichever caller
    names itself in the errors), and the path is the one built from fresh offset lines."""
    from pathmotion.geometry import blends

    robot = load_robot("irb140")
    path, tol = _turn(90.0, (0.35, -0.1, 0.45)), 0.005
    objective = _Objective(robot, path, {}, 0, tol, SETTINGS, None)
    shape = objective.shape(COORDINATES[1])
    before = blends._offset_lines.cache_info()
    built = blends.with_shaped_g2_blends(path, {0: shape})
    after = blends._offset_lines.cache_info()
    assert after.misses == before.misses and after.hits > before.hits
    blends._offset_lines.cache_clear()
    fresh = blends.with_shaped_g2_blends(path, {0: shape})
    for a, b in zip(built.segments, fresh.segments):
        np.testing.assert_array_equal(a.start_point, b.start_point)
        np.testing.assert_array_equal(a.end_point, b.end_point)
        np.testing.assert_array_equal(getattr(a, "control_points", 0.0), getattr(b, "control_points", 0.0))
