"""The re-timer with jerk limits (planning/retime.py): the compiled pass against the sequential-LP reference,
and states the reference refused.

Independent references: the dense time resample of every returned profile (each active limit, every
0.5 ms), the offline planner from the same speed, and the sequential LP (planning/third_order.py) from the
same state.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hypothesis import HealthCheck, given, settings, strategies as st

from pathmotion.errors import StateInfeasibleError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, Retimer, plan
from pathmotion.robot import load_robot

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
ROBOT = load_robot("irb140")
ROBOT = ROBOT.with_limits(replace(ROBOT.limits, acceleration=ACC))
TOL = 1e-3  # the plans' limit tolerance (defaults.LIMIT_TOLERANCE)
DT = 5e-4  # dense resample step [s]


@pytest.fixture(scope="module")
def torque_jerk():
    """(path, plan, retimer): a random 6-joint spline through 5 waypoints, torque and jerk (10 x the
    accelerations) limits, 120 grid points."""
    path = SplineJointPath.from_waypoints(np.random.default_rng(1).uniform(-1.5, 1.5, (5, 6)))
    limits = {"use_torque": True, "use_jerk": True, "jerk": tuple(10 * ACC)}
    res = plan(path, ROBOT, PlanSettings(grid_points=120, limits=limits))
    return path, res, Retimer(res)


def test_stop_from_a_large_acceleration_where_the_spline_starts(torque_jerk):
    # theta_ddot = 0.99 x the offline plan's own start acceleration from this speed: the jerk limit turns it
    # within ~1e-3 of the path, which a stop grid without grading towards the state does not resolve
    path, res, rt = torque_jerk
    theta, v, a = 0.004738774109017252, 0.1265318223548721, 9.29709097378817
    tail = replace(path, domain=(theta, path.domain[1]))
    offline = plan(tail, ROBOT, replace(res.settings, start=v, grid_points=120))
    assert np.isclose(offline.profile.u_nodes[0], a / 0.99, rtol=0.02)  # a motion from this state exists
    s = rt.stop(theta, v, a)
    assert s.smooth and s.x[-1] == 0.0 and np.isclose(s.u_nodes[0], a) and np.isclose(np.sqrt(s.x[0]), v)
    assert s.grid[-1] < path.domain[1]
    assert rt.dense_ratios(s, DT).max_ratio <= 1.0 + 2 * TOL


def _answer(rt, theta, v, a, **kw):
    try:
        return rt.remaining(theta, v, a, **kw)
    except StateInfeasibleError:
        return None


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.01, 0.9), speed=st.floats(0.05, 1.3), acc=st.floats(-3.0, 3.0))
def test_compiled_pass_against_the_sequential_lp_from_random_states(torque_jerk, where, speed, acc):
    # moving states (the pass answers those), theta_dot above and below the plan's own speed there, theta_ddot not
    # the plan's
    path, res, rt = torque_jerk
    theta = where * path.domain[1]
    v, a = speed * float(res.profile.theta_dot_at(theta)), acc
    fast, lp = rt.compiled_remaining(theta, v, a), _answer(rt, theta, v, a, reference=True)
    if fast is None:  # remaining answers with the sequential LP (or refuses with it)
        assert (_answer(rt, theta, v, a) is None) == (lp is None)
        return
    assert fast.smooth and fast.grid[0] == theta and fast.grid[-1] == path.domain[1] and fast.x[-1] == 0.0
    assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and np.isclose(fast.u_nodes[0], a, rtol=1e-12)  # no jump
    assert rt.dense_ratios(fast, DT).max_ratio <= 1.0 + 2 * TOL
    if lp is not None:  # never faster than the LP's optimum (to its tolerance); slower: median 0.3 %, worst ~11 %
        assert 1.0 - 2e-3 <= fast.duration / lp.duration <= 1.25


def test_compiled_pass_scales_exactly_with_the_override(torque_jerk):
    path, res, rt = torque_jerk
    theta = 0.3
    v, a = 0.4 * float(res.profile.theta_dot_at(theta)), 0.2
    for s in (0.8, 0.5):
        scaled, unit = rt.remaining(theta, v, a, s), rt.remaining(theta, v / s, a / s**2)
        assert np.allclose(scaled.x, s * s * unit.x, rtol=1e-12) and np.allclose(scaled.u_nodes, s * s * unit.u_nodes)
        assert np.isclose(scaled.duration, unit.duration / s, rtol=1e-12)


def _lp_stop(rt, theta, v, a):
    try:
        return rt.stop(theta, v, a, reference=True)
    except StateInfeasibleError:
        return None


@settings(max_examples=8, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.05, 0.9), speed=st.floats(0.05, 1.0), acc=st.floats(-1.0, 1.0))
def test_compiled_stop_against_the_sequential_lp_from_random_states(torque_jerk, where, speed, acc):
    # the compiled stop, where it answers: feasible on the dense resample, continuous at the switch (speed,
    # acceleration), at rest (theta_dot = theta_ddot = 0) on the path, and no shorter than the LP's least distance
    # (to its bisection accuracy); where it does not, stop answers as the LP does
    path, res, rt = torque_jerk
    theta = where * path.domain[1]
    v, a = speed * float(res.profile.theta_dot_at(theta)), acc
    fast, lp = rt.compiled_stop(theta, v, a), _lp_stop(rt, theta, v, a)
    if fast is None:
        try:
            got = rt.stop(theta, v, a)
        except StateInfeasibleError:
            got = None
        assert (got is None) == (lp is None)
        return
    assert fast.smooth and fast.grid[0] == theta and fast.grid[-1] < path.domain[1]
    assert fast.x[-1] == 0.0 and fast.u_nodes[-1] == 0.0 and np.all(fast.x[:-1] > 0.0)
    assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == a  # no jump at the switch
    assert rt.dense_ratios(fast, DT).max_ratio <= 1.0 + 2 * TOL  # jerk included: within the limits across the switch
    assert rt.stop(theta, v, a).grid[-1] == fast.grid[-1]  # stop answers with the compiled stop
    if lp is not None:
        ratio = (fast.grid[-1] - theta) / (lp.grid[-1] - theta)
        # never much shorter than the LP's (the LP bisects its distance to 1 %); longer: median ~+0.4 %, worst
        # ~+65 % where the velocity terms of the jerk rows forbid a close at speed (docs/retime.md)
        assert 0.97 <= ratio <= 1.7


def test_compiled_stop_from_a_state_braking_on_the_plan(torque_jerk):
    # the plan's own state half way (on its limits): a jerk-limited stop exists, compiled, within the limits
    path, res, rt = torque_jerk
    theta = 0.5 * path.domain[1]
    v, a = float(res.profile.theta_dot_at(theta)), float(res.profile.theta_ddot_at(theta))
    fast = rt.compiled_stop(theta, v, a)
    lp = _lp_stop(rt, theta, v, a)
    assert (fast is None) == (lp is None) or fast is None
    if fast is not None:
        assert rt.dense_ratios(fast, DT).max_ratio <= 1.0 + 2 * TOL and fast.x[-1] == 0.0
