"""The re-timer (planning/retime.py): the rest of a plan from a moving state, the shortest stop, the
resume and the speed override.

Independent references: the analytic trapezoid and stop on a straight joint line (constant path velocity
and acceleration bounds: stop distance v^2 / (2 a), override a pure time scaling), the plan itself (the
re-timing from the plan's own state is the plan), and the dense time resample of every returned profile
(each active limit, every 0.5 ms).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

from pathmotion.errors import PathmotionError, StateInfeasibleError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, Retimer, plan
from pathmotion.planning.profile import Profile
from pathmotion.robot import load_robot

from planning_paths import PolylinePath

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
ROBOT = load_robot("irb140")
ROBOT = ROBOT.with_limits(replace(ROBOT.limits, acceleration=ACC))
TOL = 1e-3  # the plans' limit tolerance (defaults.LIMIT_TOLERANCE)
DT = 5e-4  # dense resample step [s]
LINE = 4.0 * np.array([0.6, -0.3, 0.4, 1.0, -0.8, 1.2])  # straight joint line q = theta LINE, theta in [0, 1]


@pytest.fixture(scope="module")
def spline_plan():
    """A torque-limited plan on a random 6-joint spline (fixed grid, certified)."""
    path = SplineJointPath.from_waypoints(np.random.default_rng(3).uniform(-1.2, 1.2, (4, 6)))
    return plan(path, ROBOT, PlanSettings(grid_points=300, limits={"use_torque": True}))


@pytest.fixture(scope="module")
def spline(spline_plan):
    return Retimer(spline_plan)


@pytest.fixture(scope="module")
def line():
    """(retimer, path velocity bound v, path acceleration bound a) on a straight joint line."""
    path = PolylinePath.through([np.zeros(6), LINE])
    res = plan(path, ROBOT, PlanSettings(grid_points=400, verify="off"))
    return Retimer(res), float(np.min(ROBOT.limits.velocity / np.abs(LINE))), float(np.min(ACC / np.abs(LINE)))


def _state(rt: Retimer, where: float, speed: float, acc: float) -> tuple[float, float, float]:
    """theta at the fraction ``where`` of the path; theta_dot the fraction ``speed`` of the controllable
    bound there (above and below the plan's own profile); theta_ddot ``acc`` [unit theta / s^2]."""
    theta = rt.grid[0] + where * (rt.grid[-1] - rt.grid[0])
    return theta, speed * rt.max_speed(theta), acc


def _feasible(rt: Retimer, profile) -> float:
    """The largest ratio of any limit on the dense resample of ``profile``."""
    return rt.dense_ratios(profile, DT).max_ratio


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.0, 0.97), speed=st.floats(0.0, 0.999), acc=st.floats(-3.0, 3.0),
       override=st.sampled_from([1.0, 1.0, 0.7, 0.3]))
@example(where=0.318359375, speed=0.0, acc=0.0, override=1.0)  # the plan's own state there lies 4e-5 above K
def test_remaining_from_random_states_is_feasible_continuous_and_ends_at_the_plans_end(spline, spline_plan, where,
                                                                                       speed, acc, override):
    theta, v, a = _state(spline, where, speed, acc)
    p = spline.remaining(theta, v, a, override)
    assert p.grid[0] == theta and np.isclose(np.sqrt(p.x[0]), v, rtol=1e-12, atol=1e-12)  # no jump in speed
    assert p.grid[-1] == spline_plan.profile.grid[-1] and p.x[-1] == 0.0
    assert _feasible(spline, p) <= 1.0 + TOL
    # above the plan's profile there; at override 1 never slower than the plan from its own state further up
    if override == 1.0 and v <= float(spline_plan.profile.theta_dot_at(theta)):
        own = spline.remaining(theta, float(spline_plan.profile.theta_dot_at(theta)),
                               float(spline_plan.profile.theta_ddot_at(theta)))
        assert p.duration >= own.duration * (1.0 - 1e-12)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.one_of(st.floats(0.0, 0.97), st.floats(0.0, 1e-6)), speed=st.floats(0.02, 0.999),
       acc=st.floats(-3.0, 3.0))
def test_stop_from_random_states_is_feasible_and_ends_at_rest_on_the_path(spline, where, speed, acc):
    # (from theta = 0 too: at the clamped spline's start Phi' = 0, the joints rest whatever theta_dot is, and the
    # stop is one short constant-deceleration interval)
    theta, v, a = _state(spline, where, speed, acc)
    s = spline.stop(theta, v, a)
    assert s.grid[0] == theta and np.isclose(np.sqrt(s.x[0]), v, rtol=1e-12, atol=1e-12)
    assert s.x[-1] == 0.0 and np.all(s.x[:-1] > 0) and s.grid[-1] <= spline.grid[-1]
    assert _feasible(spline, s) <= 1.0 + TOL
    assert spline.certify(s).within(TOL)


def test_remaining_from_the_plans_own_state_is_the_plan(spline, spline_plan):
    prof = spline_plan.profile
    assert np.array_equal(spline.remaining(prof.grid[0], 0.0).x, prof.x)
    for k in (37, 120, 250):
        p = spline.remaining(prof.grid[k], float(np.sqrt(prof.x[k])), float(prof.u[k]))
        assert np.allclose(p.x, prof.x[k:], rtol=1e-9, atol=1e-12)
    assert np.isclose(spline.resume(prof.grid[0]).duration, prof.duration, rtol=1e-12)


def test_straight_line_stop_distance_and_time_are_analytic(line):
    rt, v_max, a_max = line
    for theta, v in ((0.1, 0.5 * v_max), (0.37, 0.9 * v_max), (0.5, 0.2 * v_max)):
        s = rt.stop(theta, v)
        assert np.isclose(s.grid[-1] - theta, v * v / (2 * a_max), rtol=1e-9)
        assert np.isclose(s.duration, v / a_max, rtol=1e-9)


def test_override_is_an_exact_time_scaling(line, spline):
    rt, v_max, a_max = line
    full = rt.remaining(0.0, 0.0)
    for s in (0.8, 0.5, 0.25):
        assert np.isclose(rt.remaining(0.0, 0.0, 0.0, s).duration, full.duration / s, rtol=1e-12)
        # trapezoid with v s and a s^2 (cruise reached on this line at these overrides)
        v, a = v_max * s, a_max * s * s
        assert np.isclose(rt.remaining(0.0, 0.0, 0.0, s).duration, 1.0 / v + v / a, rtol=2e-3)
    # from a moving state inside the envelope: s^2 times the unit answer from the scaled state
    theta, v, a = _state(spline, 0.4, 0.5, 1.0)
    s = 0.6
    assert np.allclose(spline.remaining(theta, v, a, s).x, s * s * spline.remaining(theta, v / s, a / s**2).x,
                       rtol=1e-12)


def test_lowering_the_override_while_fast_brakes_into_the_envelope(spline, spline_plan):
    theta = 0.35
    v = float(spline_plan.profile.theta_dot_at(theta))
    p = spline.remaining(theta, v, 0.0, 0.3)
    assert np.isclose(np.sqrt(p.x[0]), v) and _feasible(spline, p) <= 1.0 + TOL
    slow = spline.remaining(theta, 0.0, 0.0, 0.3)
    assert p.x[-1] == 0.0 and np.allclose(p.x[-50:], slow.x[-50:], rtol=1e-9)  # it ends on the override's optimum


def test_unsaveable_state_names_the_limit_excess_and_gives_the_overshoot_free_stop(line):
    rt, v_max, a_max = line
    theta, v = 0.9, 0.95 * v_max  # 0.1 left; braking needs v^2 / (2 a)
    need = v * v / (2 * a_max)
    assert need > 1.0 - theta
    with pytest.raises(StateInfeasibleError) as info:
        rt.stop(theta, v)
    err = info.value
    assert np.isclose(err.limit_factor, need / (1.0 - theta), rtol=1e-6)
    assert np.isclose(err.overshoot, need - (1.0 - theta), rtol=1e-6)
    assert err.stop is not None and err.stop.grid[-1] <= 1.0 + 1e-12 and err.stop.x[-1] == 0.0
    assert "cannot be saved" in str(err) and "x" in str(err)
    with pytest.raises(StateInfeasibleError):
        rt.remaining(theta, v)


@pytest.mark.parametrize("call", [
    lambda rt: rt.remaining(0.1, 0.1, 0.0, 0.0), lambda rt: rt.remaining(0.1, 0.1, 0.0, 1.5),
    lambda rt: rt.remaining(-0.1, 0.1), lambda rt: rt.remaining(1.0, 0.1), lambda rt: rt.remaining(0.1, -0.1),
    lambda rt: rt.remaining(0.1, float("nan")), lambda rt: rt.stop(0.2, 0.0)])
def test_bad_queries_are_refused_with_a_message(line, call):
    with pytest.raises(PathmotionError, match="Retimer"):
        call(line[0])


def test_jerk_limited_remaining_stop_and_resume_meet_every_limit():
    path = SplineJointPath.from_waypoints(np.random.default_rng(1).uniform(-1.2, 1.2, (4, 6)))
    res = plan(path, ROBOT, PlanSettings(grid_points=60, limits={"use_jerk": True, "jerk": tuple(10 * ACC)}))
    rt = Retimer(res)
    theta = 0.4
    v, a = float(res.profile.theta_dot_at(theta)), float(res.profile.theta_ddot_at(theta))
    p = rt.remaining(theta, 0.8 * v, 0.5 * a)
    assert np.isclose(p.u_nodes[0], 0.5 * a) and np.isclose(np.sqrt(p.x[0]), 0.8 * v, rtol=1e-5)
    s = rt.stop(theta, v, a)
    r = rt.resume(0.6)
    for prof in (p, s, r):
        assert prof.smooth and prof.x[-1] == 0.0
        assert _feasible(rt, prof) <= 1.0 + 2 * TOL
    # the plan's own state: the rest of the plan (to the SLP's tolerance and the certification's tightening)
    own = rt.remaining(theta, v, a)
    rest = res.duration - float(np.interp(theta, res.profile.grid, res.profile.times))
    assert abs(own.duration - rest) <= 5e-3 * rest
    # the second-order stop (the fallback when no jerk-limited stop exists) is no longer, and within the
    # velocity, acceleration and torque limits on the dense resample
    s2 = rt.stop(theta, v, a, second_order=True)
    assert not s2.smooth and s2.x[-1] == 0.0 and np.isclose(np.sqrt(s2.x[0]), v, rtol=1e-12)
    assert s.grid[-1] - theta >= s2.grid[-1] - theta
    second = {k: r for k, r in rt.dense_ratios(s2, DT).values.items() if k not in ("jerk", "torque_rate") and r is not None}
    assert max(second.values()) <= 1.0 + TOL


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(1e-3, 0.97), speed=st.floats(0.05, 0.999), acc=st.floats(-6.0, 6.0),
       override=st.sampled_from([1.0, 0.7]))
def test_remaining_keeps_the_states_acceleration_at_the_switch(spline, where, speed, acc, override):
    # (from theta >= 1e-3: at the clamped spline's start Phi' = 0 and the rows force the first, graded intervals'
    # acceleration, which the dense resample's first sample cannot tell)
    theta, v, a = _state(spline, where, speed, acc)
    p = spline.remaining(theta, v, a, override)
    assert _feasible(spline, p) <= 1.0 + TOL and p.x[-1] == 0.0
    first = float(p.theta_ddot_at(theta))
    if np.isclose(first, a, rtol=1e-9, atol=1e-9 * max(1.0, abs(a))):
        return  # no jump in acceleration at the switch
    greedy = spline.remaining(theta, v, 1e9, override)
    if a > first:  # only when the steepest first step the limits allow is gentler
        assert first == float(greedy.theta_ddot_at(theta))
        return
    # a < first: keeping a on the first interval would all but stop the arm there (less than a quarter of
    # theta_dot^2 now or after the steepest step), break a limit, or leave a state from which the plan's end is
    # out of reach
    h = p.grid[1] - theta
    kept = v * v + 2.0 * a * h
    floor = 0.25 * max(v * v, greedy.x[1])
    if kept < floor:
        assert p.x[1] >= floor * (1 - 1e-12)
        return
    # (the override's limits: velocity x s, acceleration x s^2, i.e. the piece slowed by s under the full ones)
    piece = Profile(np.array([theta, p.grid[1]]), np.array([v * v, kept]) / override**2)
    broken = _feasible(spline, piece) > 1.0 - TOL
    try:
        spline.remaining(float(p.grid[1]), float(np.sqrt(kept)), 0.0, override)
    except StateInfeasibleError:
        broken = True
    assert broken
