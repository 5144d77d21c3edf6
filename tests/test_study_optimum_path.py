"""The free-shape optimum's own TCP path (pathmotion/study/optimum_path.py) against two algorithms:
pathmotion's planner along that path must reproduce the NLP's duration (the NLP's timing is one
feasible timing of the path, and the planner finds the fastest), and the path must be the NLP's TCP
positions between its nodes."""

import numpy as np
import pytest

pytest.importorskip("casadi", reason='the free-shape reference needs CasADi: pip install "pathmotion[optimal]"')

from pathmotion.lift.constraint import lift  # noqa: E402
from pathmotion.errors import PathError  # noqa: E402
from pathmotion.geometry import max_deviation  # noqa: E402
from pathmotion.planning import PlanSettings, plan  # noqa: E402
from pathmotion.robot import fk, load_robot  # noqa: E402
from pathmotion.study import free_shape as fs  # noqa: E402
from pathmotion.study.atlas import _task, corner_points  # noqa: E402
from pathmotion.study.optimum_path import optimum_task_path  # noqa: E402

DELTA = 0.005
SPANS = [(0.06, 0.06)]


@pytest.fixture(scope="module")
def robot():
    return load_robot("irb140")


def _planned(robot, pts, path) -> float:
    """pathmotion's time-optimal duration [s] along ``path``, rest to rest, v + a limits (the NLP's)."""
    settings = PlanSettings(start="zero", end="zero",
                            limits={"use_velocity": True, "use_acceleration": True, "use_torque": False},
                            baselines=False, verify=False, grid_points=2000)
    return plan(lift(robot, path, original=_task(pts)), robot, settings).profile.duration


@pytest.fixture(scope="module")
def solved(robot):
    pts = corner_points(90.0)
    opt = fs.free_shape_optimum(robot, pts, DELTA, SPANS, meshes=(25, 50))
    assert opt.success, [s.status for s in opt.solutions]
    return pts, fs.tube_phases(fs.Polyline(pts), DELTA, SPANS), opt.solutions[-1]


def test_planning_along_the_optimums_own_path_gives_its_duration(robot, solved):
    """At most the NLP's duration (+ 0.3 %: the NLP holds the tool orientation at its nodes and interval
    midpoints, the planner everywhere), and not far below it (the 50-interval NLP is within ~1 % of
    the converged optimum, so a planner much faster than it along a path in the tube would be wrong)."""
    pts, phases, sol = solved
    T = _planned(robot, pts, optimum_task_path(robot, pts, phases, sol.motion))
    assert sol.duration * 0.98 <= T <= sol.duration * 1.003, (T, sol.duration)


def test_the_path_runs_through_the_optimums_tcp_positions_and_stays_in_its_tube(robot, solved):
    pts, phases, sol = solved
    path = optimum_task_path(robot, pts, phases, sol.motion)
    m = sol.motion
    first, last = m.breaks[1], m.breaks[3] + 1  # the span's nodes
    tcp = np.atleast_2d(fk(robot, m.q[first:last + 1])[0])
    on_path = path.pose(np.linspace(*path.domain, 20001))[0]
    gaps = np.min(np.linalg.norm(tcp[:, None, :] - on_path[None, :, :], axis=2), axis=1)
    assert np.max(gaps) < 2e-5  # the 20001 samples are ~25 um apart: every node lies on the path
    # within the tube up to what the NLP allows between its tube points (its own verification)
    dev = max_deviation(path, _task(pts)).distance
    assert dev <= DELTA + max(sol.verification["max_excess_m"], 0.0) + 1e-6


def test_a_whole_tube_solution_from_rest_to_rest_is_planned_too(robot):
    """The whole tube has no line to join: its path runs from the start at rest to the end at rest,
    the first and last intervals written in the squared time (in time their speed vanishes there).
    Planned along it: the NLP's duration, like the corner-confined one."""
    pts = corner_points(90.0)
    opt = fs.free_shape_optimum(robot, pts, DELTA, meshes=(25,))
    sol = opt.solutions[-1]
    assert sol.success, sol.status
    path = optimum_task_path(robot, pts, fs.tube_phases(fs.Polyline(pts), DELTA), sol.motion)
    assert all(seg.kind == "bezier" for seg in path.segments) and len(path.segments) == len(sol.motion.u)
    np.testing.assert_allclose(path.pose(np.array(path.domain))[0], pts[[0, -1]], atol=1e-12)
    T = _planned(robot, pts, path)
    assert sol.duration * 0.98 <= T <= sol.duration * 1.003, (T, sol.duration)


def test_phases_that_do_not_match_the_motion_are_refused(robot, solved):
    pts, phases, sol = solved
    with pytest.raises(PathError, match="phases"):
        optimum_task_path(robot, pts, phases[:-1], sol.motion)
