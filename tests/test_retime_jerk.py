"""The re-timer with jerk limits (planning/retime.py): the compiled pass against the sequential-LP reference,
and states the reference refused.

Independent references: the dense time resample of every returned profile (each active limit, every
0.5 ms), the offline planner from the same speed, and the sequential LP (planning/third_order.py) from the
same state.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from hypothesis import HealthCheck, example, given, settings, strategies as st

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


def _state_share(path, theta, v, a):
    """The share of the joint acceleration limits the state (theta, theta_dot, theta_ddot) takes itself [-]: a
    random state may lie above them, and the re-timer keeps its motion within that share (plus the tolerance)."""
    _, dq, ddq = (np.asarray(r, float).ravel() for r in path.evaluate(float(theta)))
    return float(np.max(np.abs(dq * a + ddq * v * v) / ACC))


def _answer(rt, theta, v, a, **kw):
    try:
        return rt.remaining(theta, v, a, **kw)
    except StateInfeasibleError:
        return None


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.01, 0.9), speed=st.floats(0.05, 1.3), acc=st.floats(-3.0, 3.0))
@example(where=0.6953125, speed=0.375, acc=0.0)  # the best merge lies more than a few points down the walk
@example(where=0.697265625, speed=0.375, acc=0.0)  # the rows stop the walk below C where it rides x_max
@example(where=0.5, speed=0.25, acc=-1.0)  # braking to a speed dip: faster than the LP, certified
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
    assert rt.dense_ratios(fast, DT).max_ratio <= max(1.0, _state_share(path, theta, v, a)) + 2 * TOL
    if lp is not None:  # slower than the LP: median ~0.35 %, up to ~14 %
        assert fast.duration / lp.duration <= 1.25
    if lp is not None and fast.duration < (1.0 - 2e-3) * lp.duration:
        # faster than the LP's optimum on its grid: a slow braking state whose speed dips past it, which the pass's
        # stretch there resolves finer than the LP's grid (3 % at theta 0.5, theta_dot a quarter of the plan's,
        # theta_ddot -1): certified within the limits, so a motion the LP's grid misses
        assert rt.certify(fast).max_ratio <= max(1.0, _state_share(path, theta, v, a)) + TOL


def test_a_plan_state_of_circle_smooth_near_the_start_has_a_jerk_limited_stop(circle_smooth):
    # neither compiled answer exists from this state (its jerk rows forbid a deceleration for a while; the pass,
    # below the limits the plan runs at, cannot turn into the ceiling as the plan does): the stop is the plan's own
    # motion to its end, re-expressed without the start's rest point on parts fine enough for its jerk there
    _, res, rt = circle_smooth
    theta, v, a = _plan_state(res, 0.20703125)
    got = rt.stop(theta, v, a)
    assert got.smooth and got.grid[0] == theta and got.x[-1] == 0.0
    assert np.isclose(np.sqrt(got.x[0]), v, rtol=1e-9) and np.isclose(got.u_nodes[0], a, rtol=1e-9)
    assert rt.dense_ratios(got, DT).max_ratio <= 1.0 + 2 * TOL
    assert got.duration <= (1.0 - 0.20703125) * res.profile.duration * 1.001


def test_a_stop_where_only_the_sequential_lp_finds_a_motion_to_the_next_rest_point(torque_jerk):
    # near the plan's speed with the offline plan's start acceleration (a state of the optimality benchmark): no
    # compiled stop, no compiled pass, not on the plan; the LP's motion to the path's end is a stop within every
    # limit, from the state (its start nudged by at most the limit tolerance) to rest
    path, _, rt = torque_jerk
    theta, v, a = 0.45699501267031495, 0.27413724239231846, 0.6186903617215244
    assert rt.compiled_stop(theta, v, a) is None and rt.compiled_remaining(theta, v, a) is None
    got = rt.stop(theta, v, a)
    assert got.smooth and got.grid[0] == theta and got.x[-1] == 0.0 and got.grid[-1] == path.domain[1]
    assert np.isclose(np.sqrt(got.x[0]), v, rtol=TOL) and np.isclose(got.u_nodes[0], a, rtol=TOL)
    assert rt.dense_ratios(got, DT).max_ratio <= 1.0 + 2 * TOL


def test_the_stop_from_a_plan_state_across_a_spline_knot_keeps_the_jerk_limit(torque_jerk):
    # the stop's constant-jerk close crosses the knot at theta = 0.25, where Phi''' and so the order-3 rows jump:
    # checked at sampled times only, it exceeded joint 2's jerk limit by 0.55 % just after the knot
    _, res, rt = torque_jerk
    theta, v, a = _plan_state(res, 0.140625)
    assert rt.dense_ratios(rt.stop(theta, v, a), DT).max_ratio <= 1.0 + 2 * TOL


@pytest.mark.parametrize("theta, v, a", [
    (0.037434796227497666, 0.08527405642162118, -1.32944632739536),
    (0.012816962708627564, 0.1334223962662442, -2.7363479522317),
    (0.012063041533469496, 0.09395966565427619, -1.56261622902286),
    (0.03010302689039361, 0.11135523154556809, -1.5630647239089308)])
def test_compiled_pass_from_a_slow_state_braking_hard(torque_jerk, theta, v, a):
    # slow and braking hard: the jerk limit turns theta_ddot within a small part of the plan interval after the
    # state (the graded stretch to the next grid point resolves it); the pass answers where the LP does,
    # continuous at the state, within every limit (jerk across the switch included) on the dense resample and
    # certified, within 1 % of the LP; these states' speed dips after the turn, which the pass's stretch
    # resolves finer than the LP's grid: the pass is up to 1.2 % faster than the LP there (certified, so a
    # motion within the limits), never more than 2 % (the LP's grid is graded towards the state)
    path, res, rt = torque_jerk
    lp = _answer(rt, theta, v, a, reference=True)
    fast = rt.compiled_remaining(theta, v, a)
    assert lp is not None and fast is not None
    assert fast.smooth and fast.grid[0] == theta and fast.x[-1] == 0.0 and np.all(np.diff(fast.grid) > 0.0)
    assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == a
    assert rt.dense_ratios(fast, DT).max_ratio <= 1.0 + 2 * TOL
    assert rt.certify(fast).max_ratio <= 1.0 + TOL
    assert 0.98 <= fast.duration / lp.duration <= 1.01


def _certified_compiled_answer(rt, theta, v, a):
    """The compiled pass's answer from (theta, v, a): from that state, certified within the limits, and the dense
    resample below its certificate."""
    fast = rt.compiled_remaining(theta, v, a)
    assert fast is not None and np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == a
    certified = rt.certify(fast).max_ratio
    assert certified <= 1.0 + TOL and rt.dense_ratios(fast, DT).max_ratio <= certified + 1e-6
    return fast


@pytest.mark.parametrize("theta, v, a", [
    (0.04785468316040023, 0.017443851862113426, -0.6742091052006553),
    (0.002015753549089236, 0.04297753298050798, -2.8179000618917835)])
def test_compiled_pass_from_a_state_that_nearly_rests(torque_jerk, theta, v, a):
    # braking to within a fraction of a plan interval of rest (theta_dot 0.017 and 0.043): the motion on dips to a
    # small speed where the jerk limit has turned theta_ddot, which u linear over the stretch to the next grid
    # point cannot follow (the LP on its grid refuses these states); the stretch up to a few rest reaches past the
    # state, cut finely around the dip, carries it: the pass answers, from the state, certified within the limits
    # (the dense resample below the certificate), and within 5 % of the offline plan from the same speed (which
    # picks its own start acceleration: a lower bound up to its grid)
    path, res, rt = torque_jerk
    fast = _certified_compiled_answer(rt, theta, v, a)
    assert rt.remaining(theta, v, a).duration == fast.duration and fast.x[-1] == 0.0
    off = plan(replace(path, domain=(theta, path.domain[1])), ROBOT, replace(res.settings, start=v))
    assert 0.998 * off.duration <= fast.duration <= 1.05 * off.duration


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.01, 0.9), speed=st.floats(0.02, 0.5), acc=st.floats(-3.0, -0.5))
def test_compiled_pass_from_random_slow_braking_states(torque_jerk, where, speed, acc):
    # slow states braking: where the pass answers, its profile starts at the state (speed and acceleration), is
    # within every limit on the dense resample (the jerk across the graded first intervals included) and no
    # faster than the LP's optimum; where it does not, remaining answers with the LP or refuses with it
    path, res, rt = torque_jerk
    theta = where * path.domain[1]
    v, a = speed * float(res.profile.theta_dot_at(theta)), acc
    fast, lp = rt.compiled_remaining(theta, v, a), _answer(rt, theta, v, a, reference=True)
    if fast is None:
        assert (_answer(rt, theta, v, a) is None) == (lp is None)
        return
    assert fast.smooth and fast.grid[0] == theta and fast.x[-1] == 0.0
    assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == a
    assert rt.dense_ratios(fast, DT).max_ratio <= max(1.0, _state_share(path, theta, v, a)) + 2 * TOL
    if lp is not None and fast.duration < (1.0 - 2e-3) * lp.duration:  # finer than the LP's grid at a speed dip
        assert rt.certify(fast).max_ratio <= max(1.0, _state_share(path, theta, v, a)) + TOL


def test_compiled_pass_from_a_state_above_its_limits(torque_jerk):
    # half the plan's speed with theta_ddot 1.5 % above the largest the acceleration and torque limits allow there (a
    # measured state): the pass answers from it, without a jump, no further above a limit on the dense resample
    # than the state itself, and no faster than the sequential LP from the state just within the limits
    path, res, rt = torque_jerk
    for where in (0.35, 0.6, 0.8):
        theta = where * path.domain[1]
        v = 0.5 * float(res.profile.theta_dot_at(theta))
        a_top = _largest_acceleration(rt, theta, v)
        fast = rt.compiled_remaining(theta, v, 1.015 * a_top)
        assert fast is not None and fast.x[-1] == 0.0
        assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == 1.015 * a_top
        state = _state_ratio(path, theta, v, 1.015 * a_top)
        assert 1.01 < state and rt.dense_ratios(fast, DT).max_ratio <= state + 2 * TOL
        lp = _answer(rt, theta, v, a_top, reference=True)
        assert lp is not None and fast.duration >= (1.0 - 2e-3) * lp.duration * (1.0 - 0.015)


def _largest_acceleration(rt, theta, v) -> float:
    """The largest theta_ddot the joint acceleration and torque limits allow at (theta, v) (Pinocchio's RNEA:
    the torque is affine in theta_ddot), from the robot model directly."""
    path = rt.path
    q, d1, d2 = (np.asarray(w, float) for w in path.evaluate(theta))
    qd = d1 * v
    data = ROBOT.model.createData()
    t0 = pin.rnea(ROBOT.model, data, q, qd, d2 * v * v)
    t1 = pin.rnea(ROBOT.model, data, q, qd, d1 + d2 * v * v) - t0
    top = np.inf
    for lin, off, lim in ((d1, d2 * v * v, ACC), (t1, t0, ROBOT.limits.torque)):
        for k in range(6):
            if abs(lin[k]) > 1e-12:
                top = min(top, (np.sign(lin[k]) * lim[k] - off[k]) / lin[k])
    return float(top)


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


def _state_ratio(path, theta, v, a) -> float:
    """The state's own largest ratio of a joint acceleration or torque limit (Pinocchio's RNEA)."""
    q, d1, d2 = (np.asarray(w, float) for w in path.evaluate(theta))
    qd, qdd = d1 * v, d1 * a + d2 * v * v
    tau = pin.rnea(ROBOT.model, ROBOT.model.createData(), q, qd, qdd)
    return float(max(np.max(np.abs(qdd) / ACC), np.max(np.abs(tau) / ROBOT.limits.torque)))


def _check_stop(rt, path, fast, theta, v, a):
    """A compiled stop: smooth, from the state without a jump in speed or acceleration, at rest on the path before
    its end, within every limit (jerk included) on the dense resample, or no further above one than the state
    itself (a given state may lie a little above the acceleration or torque limits)."""
    assert fast.smooth and fast.grid[0] == theta and fast.grid[-1] < path.domain[1]
    assert fast.x[-1] == 0.0 and fast.u_nodes[-1] == 0.0 and np.all(fast.x[:-1] > 0.0)
    assert np.isclose(np.sqrt(fast.x[0]), v, rtol=1e-12) and fast.u_nodes[0] == a
    assert rt.dense_ratios(fast, DT).max_ratio <= max(1.0, _state_ratio(path, theta, v, a)) + 2 * TOL


@settings(max_examples=8, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.05, 0.9), speed=st.floats(0.05, 1.3), acc=st.floats(-3.0, 3.0))
def test_compiled_stop_against_the_sequential_lp_from_random_states(torque_jerk, where, speed, acc):
    # theta_dot above and below the plan's, theta_ddot not the plan's: where the compiled stop answers it is
    # feasible, continuous at the switch and at rest, stop answers with it, and it is no shorter than the
    # second-order stop (the LP's distance is bisected to 1 % on a coarse grid; from some states its coarse grid
    # is ~15 % longer than the compiled stop's); where it does not, stop runs to the next rest point or refuses
    # with a stop it can run
    path, res, rt = torque_jerk
    theta = where * path.domain[1]
    v, a = speed * float(res.profile.theta_dot_at(theta)), acc
    fast, lp = rt.compiled_stop(theta, v, a), _lp_stop(rt, theta, v, a)
    if fast is None:
        try:
            got = rt.stop(theta, v, a)
            assert got.x[-1] == 0.0 and got.grid[0] == theta and rt.dense_ratios(got, DT).max_ratio <= 1.0 + 2 * TOL
        except StateInfeasibleError as err:
            assert err.stop is not None and err.stop.x[-1] == 0.0 and err.stop.grid[0] == theta
        return
    _check_stop(rt, path, fast, theta, v, a)
    assert rt.stop(theta, v, a).grid[-1] == fast.grid[-1]  # stop answers with the compiled stop
    # never shorter than the stop without the jerk limits (a lower bound), nor much shorter than the LP's
    assert fast.grid[-1] - theta >= (1.0 - TOL) * (rt.stop(theta, v, a, second_order=True).grid[-1] - theta)
    if lp is not None:
        assert (fast.grid[-1] - theta) / (lp.grid[-1] - theta) >= 0.8


def test_compiled_stop_distance_within_one_percent_of_the_sequential_lp(torque_jerk):
    # 16 seeded random moving states over the path (theta_dot up to 1.3 x the plan's, theta_ddot in [-2, 2]):
    # where the LP finds a stop, so does the compiled stop, within 1 % of the LP's distance (itself bisected to
    # 1 %) or shorter for at least 3 in 4 of them and at the median; every compiled stop is within the limits and
    # no shorter than the second-order stop
    path, res, rt = torque_jerk
    rng = np.random.default_rng(3)
    ratios, answered = [], 0
    for _ in range(16):
        theta = rng.uniform(0.05, 0.9) * path.domain[1]
        v, a = rng.uniform(0.1, 1.3) * float(res.profile.theta_dot_at(theta)), rng.uniform(-2.0, 2.0)
        lp = _lp_stop(rt, theta, v, a)
        fast = rt.compiled_stop(theta, v, a)
        if fast is not None:
            _check_stop(rt, path, fast, theta, v, a)
            second = rt.stop(theta, v, a, second_order=True).grid[-1] - theta
            assert fast.grid[-1] - theta >= (1.0 - TOL) * second
        if lp is None:
            continue
        answered += fast is not None
        if fast is not None:
            ratios.append((fast.grid[-1] - theta) / (lp.grid[-1] - theta))
    ratios = np.array(ratios)
    assert len(ratios) >= 8 and answered == len(ratios)
    assert np.median(ratios) <= 1.01 and np.mean(ratios <= 1.01) >= 0.75


@pytest.mark.parametrize("theta, v, a, most", [
    (0.1731619295867796, 0.2386866335543975, 0.8608459682278425, 1.45),
    (0.1441908304720601, 0.22585941915473798, 1.0622458733371363, 1.1)])
def test_compiled_stop_whose_braking_meets_a_rising_deceleration_bound(torque_jerk, theta, v, a, most):
    # states of the optimality benchmark whose braking at the least acceleration runs into a stretch where that
    # least acceleration rises faster than the jerk rows let theta_ddot follow (the torque's velocity terms near
    # their limit): the braking that gives way there and brakes fully again after it stops within `most` times the
    # LP reference's distance (the braking that ends there: 1.66 and 1.18 times), within the limits
    path, res, rt = torque_jerk
    fast, lp = rt.compiled_stop(theta, v, a), _lp_stop(rt, theta, v, a)
    assert fast is not None and lp is not None
    _check_stop(rt, path, fast, theta, v, a)
    assert fast.grid[-1] - theta <= most * (lp.grid[-1] - theta)


def test_a_state_no_jerk_limited_stop_can_save(torque_jerk):
    # slow and braking hard: the jerk limits cannot turn theta_ddot to 0 before theta_dot runs out (the LP finds
    # no stop either), nor does the motion go on to the next rest point: a clear error that carries the shortest
    # stop within the velocity, acceleration and torque limits, which a caller that must stop runs
    path, res, rt = torque_jerk
    theta, v, a = 0.045577531828742184, 0.04242355607578061, -1.8452190301900058
    assert _lp_stop(rt, theta, v, a) is None and rt.compiled_stop(theta, v, a) is None
    with pytest.raises(StateInfeasibleError, match="cannot stop within the jerk") as err:
        rt.stop(theta, v, a)
    s = err.value.stop
    assert s.grid[0] == theta and np.isclose(np.sqrt(s.x[0]), v) and s.x[-1] == 0.0 and s.grid[-1] < path.domain[1]
    second = rt.stop(theta, v, a, second_order=True)
    assert np.array_equal(s.grid, second.grid) and np.array_equal(s.x, second.x)
    ratios = rt.dense_ratios(s, DT).values
    assert all(ratios[k] <= 1.0 + 2 * TOL for k in ("velocity", "acceleration", "torque"))


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


def test_compiled_stop_over_a_spline_knot_is_certified(torque_jerk):
    # a stop whose braking crosses the spline's knot at theta = 0.25 (Phi''' jumps there): the knot is one of its
    # grid points (its motion unchanged), so the certified bounds hold it within the limits and agree with the
    # dense resample (an interval holding the knot inside certified a 9 % jerk excess the motion does not have)
    path, res, rt = torque_jerk
    theta, v, a = 0.22938262888871214, 0.12620398619233164, 1.4090828960554298
    s = rt.compiled_stop(theta, v, a)
    assert s is not None and s.grid[0] < 0.25 < s.grid[-1] and 0.25 in s.grid
    _check_stop(rt, path, s, theta, v, a)
    certified, dense = rt.certify(s).max_ratio, rt.dense_ratios(s, 1e-4).max_ratio
    assert dense <= certified <= max(1.0 + TOL, dense + 1e-3)


def test_states_certified_unable_to_turn_have_no_jerk_limited_stop(torque_jerk, monkeypatch):
    # seeded slow states braking hard: where the certificate says the deceleration cannot be turned before the
    # speed runs out, neither the compiled stop's search nor the compiled pass (both run without the certificate)
    # nor the sequential LP (its first few: stop and remaining) finds a motion; stop refuses with the stop it can
    # run, remaining refuses; the certificate holds for some of them and not for all
    path, res, rt = torque_jerk
    rng = np.random.default_rng(11)
    certified, lp_checked = 0, 0
    for _ in range(200):
        theta = rng.uniform(0.0, 0.9) * path.domain[1]
        v, a = rng.uniform(0.01, 0.5) * float(res.profile.theta_dot_at(theta)), rng.uniform(-4.0, -0.5)
        if not rt._cannot_turn(theta, v * v, a):
            continue
        certified += 1
        with pytest.raises(StateInfeasibleError) as err:
            rt.stop(theta, v, a)
        assert err.value.stop is not None and err.value.stop.x[-1] == 0.0 and err.value.stop.grid[0] == theta
        with monkeypatch.context() as m:
            m.setattr(rt, "_cannot_turn", lambda *state: False)
            assert rt.compiled_stop(theta, v, a) is None and rt.compiled_remaining(theta, v, a) is None
        assert _answer(rt, theta, v, a) is None
        if lp_checked < 3:
            lp_checked += 1
            assert _lp_stop(rt, theta, v, a) is None and _answer(rt, theta, v, a, reference=True) is None
    assert 10 <= certified <= 190


@pytest.fixture(scope="module")
def circle_smooth():
    """(path, plan, retimer) of the circle_smooth scenario (jerk limits, a torque reserve; from rest to rest)."""
    from pathmotion import api
    from pathmotion.scenarios import scenario_path
    res = api.plan_scenario(api.load(scenario_path("circle_smooth")))
    return res.trajectory.path, res, Retimer(res)


def _plan_state(res, fraction):
    """(theta, theta_dot, theta_ddot) of the plan at ``fraction`` of its duration."""
    theta, v, a, _ = res.profile.state3_at_time(np.array([fraction * res.profile.duration]))
    return float(theta[0]), float(v[0]), float(a[0])


@pytest.mark.parametrize("plan_name", ["circle_smooth", "torque_jerk"])
@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.005, 0.995))
@example(fraction=0.5)  # circle_smooth: below the ceiling at the jerk limit, neither compiled answer exists there
def test_every_state_on_the_plan_has_a_jerk_limited_stop(request, plan_name, fraction):
    # the plan's own motion from any of its states is a motion within every limit to its next rest point: the
    # re-timer finds a stop from every such state, continuous at the state and within the limits on the dense
    # resample; past the start its remaining motion as well, no slower than the plan's own by more than 1 %
    _, res, rt = request.getfixturevalue(plan_name)
    theta, v, a = _plan_state(res, fraction)
    answers = [rt.stop(theta, v, a)]
    if fraction >= 0.25:  # nearer the start from rest the sequential LP answers (or refuses) the plan's own state
        answers.append(rt.remaining(theta, v, a))
    for got in answers:
        assert got.smooth and np.isclose(got.grid[0], theta) and got.x[-1] >= 0.0
        assert np.isclose(np.sqrt(got.x[0]), v, rtol=1e-9) and np.isclose(got.u_nodes[0], a, rtol=1e-9, atol=1e-9)
        assert rt.dense_ratios(got, DT).max_ratio <= 1.0 + 2 * TOL
    assert answers[0].x[-1] == 0.0
    if len(answers) == 2:
        assert answers[1].duration <= (1.0 - fraction) * res.profile.duration * 1.01


@pytest.mark.parametrize("fraction", [0.2762923797321721])  # found by hypothesis (the test above)
def test_stop_from_a_plan_state_the_interpolated_rows_read_above_its_limits(torque_jerk, fraction):
    # the plan's own state takes 0.99 of its acceleration limits, the order-2 rows interpolated between check points
    # read 1.0104 there: the stop may keep that share of the order-2 rows while it leaves the state, but its jerk,
    # which it chooses, within 1 - MARGIN of the order-3 rows; certified within the limits like a plan
    _, res, rt = torque_jerk
    theta, v, a = _plan_state(res, fraction)
    assert _state_share(torque_jerk[0], theta, v, a) < 1.0
    for got in (rt.stop(theta, v, a), rt.compiled_stop(theta, v, a)):
        assert got is not None and got.x[-1] == 0.0 and np.isclose(got.u_nodes[0], a)
        certified = rt.certify(got).max_ratio
        assert rt.dense_ratios(got, DT).max_ratio <= certified + 1e-6 and certified <= 1.0 + TOL


def test_a_compiled_stop_that_fails_its_certificate_is_not_returned(torque_jerk, monkeypatch):
    # the compiled stop meets rows interpolated between check points, which certify nothing by themselves: its
    # first answer's certificate made to fail, the next one (a shallower braking, stopping no sooner) is returned,
    # certified
    _, res, rt = torque_jerk
    theta, v, a = _plan_state(res, 0.5)
    first = rt.compiled_stop(theta, v, a)
    assert first is not None
    certify, calls = rt.certify, []

    def failing_first(profile):
        calls.append(profile)
        got = certify(profile)
        return got if len(calls) > 1 else replace(got, values={**got.values, "jerk": 2.0})

    monkeypatch.setattr(rt, "certify", failing_first)
    got = rt.compiled_stop(theta, v, a)
    assert len(calls) >= 2 and np.array_equal(calls[0].grid, first.grid)
    assert got is not None and not np.array_equal(got.grid, first.grid) and got.grid[-1] >= first.grid[-1] - 1e-9
    assert certify(got).max_ratio <= 1.0 + TOL


@pytest.mark.parametrize("theta, v, a", [
    (0.037434796227497666, 0.08527405642162118, -1.32944632739536),  # the jerk at the state at the limit
    (0.002854422301887691, 0.06691933893030654, -0.20276384804826542),  # a merge's steep jerk
    (0.029562904848176537, 0.0010087377057796051, 1.9802863788104732),  # slow: the graded first stretch
    (0.030355693724025, 0.26558697186400637, 0.5399501580636619)])  # a stop's first interval
def test_compiled_answers_are_certified_within_the_limits(torque_jerk, theta, v, a):
    # certified like a plan: the certified bound of every interval within 1 + the limit tolerance (these states
    # lie below their limits), and above the dense resample's ratio (the certificate bounds the motion)
    path, res, rt = torque_jerk
    assert _state_share(path, theta, v, a) < 1.0
    answers = [p for p in (rt.compiled_remaining(theta, v, a), rt.compiled_stop(theta, v, a)) if p is not None]
    assert answers
    for p in answers:
        certified = rt.certify(p).max_ratio
        assert rt.dense_ratios(p, 1e-4).max_ratio <= certified + 1e-6 and certified <= 1.0 + TOL


def _enforced_ratio(rt, path, theta, v, a) -> float:
    """The state's own largest ratio of a joint acceleration or the enforced torque limit (the robot's less the
    plans' torque reserve; Pinocchio's RNEA) [-]."""
    q, d1, d2 = (np.asarray(w, float) for w in path.evaluate(theta))
    qd, qdd = d1 * v, d1 * a + d2 * v * v
    tau = pin.rnea(ROBOT.model, ROBOT.model.createData(), q, qd, qdd)
    tau_max = next(lim for lim in rt.limits if lim.name == "torque").tau_max
    return float(max(np.max(np.abs(qdd) / ACC), np.max(np.abs(tau) / tau_max)))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.01, 0.9), speed=st.floats(0.05, 1.2), acc=st.floats(-12.0, 12.0),
       override=st.sampled_from([1.0, 0.6]))
@example(where=0.3, speed=0.6, acc=-12.0, override=1.0)
@example(where=0.5, speed=1.0, acc=0.0, override=1.0)
@example(where=0.5, speed=0.5, acc=0.0, override=1.0)  # within the limits: the LP answers
def test_states_above_their_limits_are_refused_as_the_lp_refuses_them(torque_jerk, where, speed, acc, override):
    # the share certificate (the state's own acceleration or torque share above 1 + the tolerance) against
    # Pinocchio's RNEA at the state, and against the sequential LP: where it refuses, the LP finds no motion
    # either (remaining answers only by the compiled pass, which takes a state up to 2 % above its limits, or
    # refuses); where the LP answers, it does not refuse. At an override s the LP solves the unit problem from
    # (theta_dot / s, theta_ddot / s^2)
    path, res, rt = torque_jerk
    theta = where * path.domain[1]
    v = speed * float(res.profile.theta_dot_at(theta))
    s = override
    share = rt._start_share(theta, v * v / s**2, acc / s**2)
    ratio = _enforced_ratio(rt, path, theta, v / s, acc / s**2)
    assert share <= ratio * (1.0 + 1e-9) + 1e-12
    lp = _answer(rt, theta, v, acc, override=s, reference=True)
    if share > 1.0 + TOL:
        assert ratio > 1.0 + TOL and lp is None
        got = _answer(rt, theta, v, acc, override=s)
        assert got is None or s < 1.0 or rt.certify(got).max_ratio <= ratio + 2 * TOL
    if lp is not None:
        assert share <= 1.0 + TOL


@pytest.fixture(scope="module")
def corner_g2_jerk():
    """(path, plan, retimer) of the corner_g2 scenario planned with its jerk limits: the G2 blend's spline knots
    leave grid intervals far shorter than the others."""
    from pathmotion import api
    from pathmotion.scenarios import scenario_path
    res = api.plan_scenario(api.load(scenario_path("corner_g2"), {"limits.use_jerk": True}))
    return res.trajectory.path, res, Retimer(res)


@pytest.mark.parametrize("fraction", [0.42, 0.51, 0.58])
def test_stops_from_plan_states_around_a_blend_with_short_grid_intervals(corner_g2_jerk, fraction):
    # around the blend no braking-point search finds a stop before the path's end; each of its tail checks spans
    # the blend's short knot intervals, which are checked on their own (their shortness does not multiply the
    # checks of the other intervals): the answer is the plan's own motion to rest, within every limit
    _, res, rt = corner_g2_jerk
    theta, v, a = _plan_state(res, fraction)
    got = rt.stop(theta, v, a)
    assert got.smooth and got.grid[0] == theta and got.x[-1] == 0.0
    assert np.isclose(np.sqrt(got.x[0]), v, rtol=1e-9) and np.isclose(got.u_nodes[0], a, rtol=1e-9)
    assert rt.dense_ratios(got, DT).max_ratio <= 1.0 + 2 * TOL


def test_the_first_stretch_kernels_agree_with_the_smooth_form(torque_jerk):
    # the query's first-stretch coefficients and the ceiling's x, u at its points are compiled point by point:
    # against planning/smooth.py's vectorized formulas (point_coefficients, state) on stretches graded towards
    # states across the path
    from scipy.integrate import quad

    from pathmotion.planning import retime_jerk as rj, smooth
    jp = torque_jerk[2]._jerk
    for k in (5, 30, 60, 100):
        lo, hi = jp.grid[k], jp.grid[k + 1]
        pts = lo + (hi - lo) * np.array([0.3, 0.31, 0.33, 0.4, 0.6, 1.0])
        pts[-1] = hi
        n = len(pts) - 1
        ref = rj.point_coefficients(pts, np.repeat(jp.origin[k], n), np.repeat(jp.sign[k], n))
        got = rj._first_coefficients(pts, float(jp.origin[k]), int(jp.sign[k]), np.array(rj.CHECK_POINTS))
        # the lengths cxu, cxv: x_k + 2 u_k cxu + 2 (u_{k+1} - u_k) cxv differs at the cancellation of both forms
        # next to the path's start (cxv ~ h^2 / (6 d^(2/3)) from terms ~ d^(4/3), d the distance to the rest point)
        assert np.allclose(got[:2], ref[:2], rtol=0.0, atol=1e-4 * (hi - lo))
        assert np.allclose(got[2:], ref[2:], rtol=1e-6, atol=0.0)
        # the ceiling's x, u at those points (smooth.state's compiled kernel, which the pass calls) against the
        # smooth form's definition: u linear in xi over the interval, x = x_k + 2 (integral of u d theta) by quadrature
        index = np.full(n, k)
        x, u, _ = smooth.state(jp.grid, jp.cx, jp.cu, jp.origin, jp.sign, index, pts[:-1])
        xi = lambda th: smooth.xi_of(jp.origin[k], jp.sign[k], th)  # noqa: E731
        u_of = lambda th: jp.cu[k] + (jp.cu[k + 1] - jp.cu[k]) * (xi(th) - xi(lo)) / (xi(hi) - xi(lo))  # noqa: E731
        x_ref = [jp.cx[k] + 2.0 * quad(u_of, lo, th, epsabs=0.0, epsrel=1e-12)[0] for th in pts[:-1]]
        assert np.allclose(u, [u_of(th) for th in pts[:-1]], rtol=1e-9, atol=1e-12)
        assert np.allclose(x, x_ref, rtol=1e-7, atol=1e-12)


@pytest.mark.parametrize("theta, v, a", [
    (0.4838273491423397, 0.05900915881907442, -0.636655121815015),
    (0.22902778002132854, 0.07039557917401798, -0.34804172231513675)])
def test_a_nearly_resting_state_whose_stretch_passes_a_spline_knot(torque_jerk, theta, v, a):
    # the first stretch of a nearly resting braking state runs over grid points up to a spline knot (0.25, 0.5): an
    # interval ending at the knot is checked on the rows left of it (the path's third derivative jumps there), not
    # on the next interval's start; checked on the right-hand rows the jerk of joint 2 took 1.064 to 1.074 of its
    # limit just before the knot
    _certified_compiled_answer(torque_jerk[2], theta, v, a)


@pytest.mark.parametrize("theta, v, a", [
    (0.005067601958848721, 0.03520068388398293, -2.9197307401397268),
    (0.26265696377187214, 0.04380438800651926, -1.6415066124123623)])
def test_a_nearly_resting_state_whose_pass_breaks_a_limit_between_its_check_points(torque_jerk, theta, v, a):
    # the pass's own part from a nearly resting state is certified before it is taken: from these states its walk
    # broke the jerk of joint 2 between its check points (certified 1.039 and 1.008; next to the clamped spline's
    # start and past the knot at 0.25), so the pass gives none (remaining solves the LP) or a certified answer
    path, res, rt = torque_jerk
    fast = rt.compiled_remaining(theta, v, a)
    assert fast is None or rt.certify(fast).max_ratio <= 1.0 + TOL


@pytest.mark.parametrize("back, frac, share", [(1, 0.1, 0.01), (1, 0.5, 0.3), (1, 0.9, 0.9), (2, 0.5, 0.01)])
def test_a_nearly_resting_state_next_to_a_rest_point(torque_jerk, back, frac, share):
    # braking to within a fraction of a plan interval of rest in the last grid intervals before the plan's end (a
    # rest point): the first stretch runs from the state to a grid point after it, at most to the rest point (a
    # stretch capped before the rest point was one point, an IndexError); a state the limits cannot save is refused
    # with its clear error
    path, res, rt = torque_jerk
    g = res.profile.grid
    i = len(g) - 1 - back
    h = g[i + 1] - g[i]
    theta, a = g[i] + frac * h, -1.0
    v = np.sqrt(2.0 * share * h * abs(a))
    j, pts, _ = rt._jerk.first_points(theta, i, i + 1, len(g) - 1, v * v, a)
    assert len(pts) >= 2 and pts[0] == theta and pts[-1] == g[j] and j >= i + 1
    try:
        s = rt.remaining(theta, v, a)
    except StateInfeasibleError:
        return
    assert s.x[-1] == 0.0 and np.isclose(np.sqrt(s.x[0]), v) and rt.certify(s).max_ratio <= 1.0 + TOL


def test_a_stop_a_moment_before_a_fine_point_brakes_into_it():
    # abb_cycle jerk-limited, the state execute's shaped references reach 4 ms before the plan rests at a fine point
    # (theta_dot 3e-5, theta_ddot -0.13): its stop runs into the fine point within the jerk limit (a stretch past the
    # speed dip, capped at the rest point, had no room: the jerk-limited stop was refused and execute stopped with
    # acceleration steps)
    from importlib import resources

    from pathmotion import api

    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("abb_cycle.toml").read_text(),
                          overrides={"limits.use_jerk": True})
    rt = Retimer(api.plan_scenario(setup))
    theta, v, a = 0.3549999960760106, 2.7931599263058183e-05, -0.13254779862029675
    s = rt.stop(theta, v, a)
    assert s.smooth and s.x[-1] == 0.0 and s.grid[-1] <= 0.355 + 1e-12
    assert rt.certify(s).max_ratio <= 1.0 + TOL
