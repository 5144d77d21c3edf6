"""Planner boundary conditions, periodic cycles, connection modes, baselines and infeasibility errors."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pathmotion import defaults
from pathmotion.errors import InfeasibleError, ScenarioError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, plan
from pathmotion.planning.planner import effective_limits
from pathmotion.robot import gravity

sys.path.insert(0, str(Path(__file__).parent))
from planning_paths import PeriodicSplinePath, PolylinePath  # noqa: E402

LINE = [np.zeros(6), np.array([1.0, 0.5, -0.5, 0.3, 0.2, 0.0])]
CORNER = [np.zeros(6), np.array([1.0, 0.5, -0.5, 0.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0, 0.5, 0.0, 0.0])]
FAST = dict(baselines=False, grid_points=300)


@pytest.fixture(scope="module")
def line():
    return PolylinePath.through(LINE)


def test_max_zero_and_given_start(irb140, line):
    zero = plan(line, irb140, PlanSettings(**FAST))
    top = plan(line, irb140, PlanSettings(start="max", **FAST))
    v_max = float(top.profile.theta_dot_at(0.0))
    assert v_max > 0 and top.duration < zero.duration
    given = plan(line, irb140, PlanSettings(start=0.5 * v_max, **FAST))
    assert float(given.profile.theta_dot_at(0.0)) == pytest.approx(0.5 * v_max, rel=1e-9)
    assert top.duration < given.duration < zero.duration
    # "max" is the largest feasible start velocity: just above it is infeasible, with the range
    with pytest.raises(InfeasibleError, match=r"feasible start velocity range is \[0, ") as err:
        plan(line, irb140, PlanSettings(start=1.001 * v_max, **FAST))
    lo, hi = (float(v) for v in str(err.value).split("[")[1].split("]")[0].split(","))
    assert hi == pytest.approx(v_max, rel=1e-6)
    assert "theta = 0" in str(err.value)


def test_max_end_and_infeasible_end(irb140, line):
    top = plan(line, irb140, PlanSettings(end="max", **FAST))
    v_end = float(top.profile.theta_dot_at(line.domain[1]))
    assert v_end > 0
    with pytest.raises(InfeasibleError, match=r"end velocity theta_dot = .* is infeasible.*feasible range") as err:
        plan(line, irb140, PlanSettings(end=1.01 * v_end, **FAST))
    hi = float(str(err.value).split("[")[1].split("]")[0].split(",")[1])
    assert hi == pytest.approx(v_end, rel=1e-6)


def test_periodic_cycle(irb140):
    wp = np.array([[0, 0, 0, 0, 0, 0], [1, 0.5, -0.5, 0.3, 0.2, 0], [0.5, -0.3, 0.2, 0, 1, 1], [0, 0, 0, 0, 0, 0]], float)
    path = PeriodicSplinePath.through(wp)
    rest = plan(path, irb140, PlanSettings(**FAST))
    cyc = plan(path, irb140, PlanSettings(periodic=True, **FAST))
    assert cyc.profile.x[0] == pytest.approx(cyc.profile.x[-1], rel=1e-12)
    assert cyc.profile.x[0] > 0
    assert cyc.duration <= rest.duration
    assert cyc.ratios.within()
    # largest such: starting and ending slightly faster is infeasible
    with pytest.raises(InfeasibleError):
        plan(path, irb140, PlanSettings(start=1.001 * np.sqrt(cyc.profile.x[0]), end=1.001 * np.sqrt(cyc.profile.x[0]), **FAST))
    with pytest.raises(ScenarioError, match="ends where it starts"):
        plan(PolylinePath.through(LINE), irb140, PlanSettings(periodic=True))


def test_kink_stops_in_chain_mode_and_jumps_with_max_connections(irb140):
    path = PolylinePath.through(CORNER)
    assert path.kinks == (1.0,)
    chain = plan(path, irb140, PlanSettings(**FAST))
    k = int(np.argmin(np.abs(chain.profile.grid - 1.0)))
    assert chain.profile.x[k] == 0.0
    assert chain.ratios.within()
    zero = plan(path, irb140, PlanSettings(connections="zero", **FAST))
    assert zero.duration == pytest.approx(chain.duration, rel=1e-12)
    fast = plan(path, irb140, PlanSettings(connections="max", **FAST))
    assert len(fast.segment_profiles) == 2
    assert fast.duration < chain.duration
    assert float(fast.profile.theta_dot_at(1.0)) > 0
    assert fast.ratios.acceleration == np.inf  # the corner taken at speed: velocity jump
    # each segment on its own reaches its boundary-level velocity at the corner
    first, second = fast.segment_profiles
    alone = plan(PolylinePath.through(CORNER[:2]), irb140, PlanSettings(end="max", **FAST))
    assert first.x[-1] == pytest.approx(alone.profile.x[-1], rel=1e-9)


def test_max_connection_with_unequal_speeds_reports_the_jump(irb140):
    """A smooth-direction break where the two segments' boundary velocities differ: jump interval."""
    wp = [np.zeros(6), np.array([0.5, 0, 0, 0, 0, 0]), np.array([2.5, 0, 0, 0, 0, 0])]
    path = PolylinePath.through(wp)  # same direction, different Phi' scale: break, not a kink
    assert path.kinks == () and path.breaks == (1.0,)
    res = plan(path, irb140, PlanSettings(connections="max", limits={"use_torque": False}, **FAST))
    assert len(res.jump_intervals) == 1
    a, b = res.jump_intervals[0]
    assert b == 1.0 and 0 < b - a < 1e-4
    assert res.ratios.acceleration > 10.0


def test_gravity_above_torque_limit_names_joint_and_theta(irb140):
    path = SplineJointPath.from_waypoints([[0, 0.2, 0, 0, 0, 0], [0.5, 0.8, -0.3, 0, 0.5, 0], [1, 0.4, 0.2, 0, 0, 0]])
    g = gravity(irb140, path(np.linspace(0, 1, 101)))
    torque = irb140.limits.torque.copy()
    torque[1] = 0.8 * np.max(np.abs(g[:, 1]))
    robot = irb140.with_limits(replace(irb140.limits, torque=torque))
    with pytest.raises(InfeasibleError, match=r"gravity torque of joint_2 at theta = [0-9.]+ is .* N m") as err:
        plan(path, robot, PlanSettings(**FAST))
    assert "lower the payload" in str(err.value)


def test_baselines_are_slower_and_feasible(irb140):
    # long enough to cruise; a joint-space line is a curved TCP path, so the TCP speed varies
    line = PolylinePath.through([LINE[0], 3.0 * LINE[1]])
    res = plan(line, irb140, PlanSettings(grid_points=300, baselines=True))
    fitted, constant = res.baselines.fitted, res.baselines.constant_speed
    assert res.duration < fitted.duration
    assert res.duration < constant.duration
    assert fitted.ratios.within() and constant.ratios.within()
    # fitted profile lies at least the margin below the optimum
    th = res.profile.grid[1:-1]
    assert np.all(fitted.profile.theta_dot_at(th) <= (1 - defaults.FITTED_PROFILE_MARGIN) * res.profile.theta_dot_at(th) + 1e-12)
    # constant speed: a straight joint line has a curved TCP path; its cruise holds a constant TCP speed
    assert "constant TCP speed" in constant.description


@pytest.mark.parametrize("waypoints", [LINE, [np.zeros(6), np.array([0.6, 0.9, -0.7, 1.2, -0.4, 0.8]),
                                              np.array([1.4, 0.2, 0.1, -0.5, 0.6, 0.0])]])
def test_certified_baselines_hold_on_the_dense_resample(irb140, waypoints):
    """The baselines verified by the certified bound per grid interval (verify = "certified") exceed no limit on the
    independent 0.1 ms resample, and are within the limit tolerance of the baselines verified on that resample."""
    from pathmotion.planning.trajectory import Trajectory
    from pathmotion.planning.verify import limit_ratios

    path = PolylinePath.through(waypoints)
    settings = PlanSettings(grid_points=300, baselines=True, limits={"use_torque": True})
    certified = plan(path, irb140, settings).baselines
    dense = plan(path, irb140, replace(settings, verify="dense")).baselines
    tol = settings.limit_tolerance
    for name in ("fitted", "constant_speed"):
        b, d = getattr(certified, name), getattr(dense, name)
        assert b.ratios.method == "certified"
        resampled = limit_ratios(Trajectory(path, b.profile, irb140), effective_limits(irb140, settings))
        assert resampled.within(tol), (name, resampled.worst)
        # the certified bound is an upper bound: its baseline is at most as fast, and slower by no more than tol
        assert d.duration * (1 - 1e-9) <= b.duration <= d.duration * (1 + 2 * tol), name


def test_baselines_of_a_jerk_limited_plan_are_verified_on_the_dense_resample(irb140):
    """With a jerk limit the plan is smooth but the baselines' theta_ddot is constant per interval: the certified
    bound does not cover their jerk, so they are verified on the resample (a sample time), and none fails."""
    path = SplineJointPath.from_waypoints([LINE[0], 0.5 * LINE[1] + [0.2, 0, 0, 0, 0, 0], LINE[1]])
    jerk = tuple(10.0 * np.asarray(irb140.limits.acceleration))
    res = plan(path, irb140, PlanSettings(grid_points=100, baselines=True, start="zero", end="zero",
                                          limits={"use_torque": False, "jerk": jerk}))
    for base in (res.baselines.fitted, res.baselines.constant_speed):
        assert base.ratios.sample_time is not None and base.duration > res.duration


def test_settings_are_validated():
    with pytest.raises(ScenarioError):
        PlanSettings(start="fast")
    with pytest.raises(ScenarioError):
        PlanSettings(connections="smooth")
    with pytest.raises(ScenarioError):
        PlanSettings(periodic=True, start="max")


def _bisection_top(problem) -> float:
    """The largest v with {v} controllable from x_0 = v, by plain bisection on [0, the point-wise bound] (the
    reference for solve_periodic's bound of the laps)."""
    from pathmotion.planning.topp import controllable_sets

    def ok(v):
        s = controllable_sets(problem, v, v)
        slack = 1e-9 * (1 + v)
        return s.failed_at < 0 and s.lo[0] - slack <= v <= s.hi[0] + slack

    lo, hi = 0.0, float(min(problem.x_max[0], problem.x_max[-1]))
    if ok(hi):
        return hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), torque=st.booleans())
def test_the_periodic_cycle_is_the_bisections_and_the_laps_bound_holds(irb140, monkeypatch, seed, torque):
    """On random closed joint paths the fastest cycle (the laps' bound, checked) matches a plain bisection to
    1e-8 (or the set-membership slack); the laps' bound is never below it; forcing the bisection (a bound far too high) gives the same cycle."""
    from pathmotion.planning import boundary, segments

    rng = np.random.default_rng(seed)
    wp = rng.uniform(-0.8, 0.8, (int(rng.integers(3, 6)), 6))
    path = PeriodicSplinePath.through(np.vstack([wp, wp[:1]]))
    problems, solve = [], boundary.solve_periodic

    def capture(problem, where=""):
        problems.append(problem)
        return solve(problem, where)

    monkeypatch.setattr(segments, "solve_periodic", capture)
    cfg = PlanSettings(periodic=True, limits={"use_torque": torque}, **FAST)
    cyc = plan(path, irb140, cfg)
    problem = problems[-1]
    reference = _bisection_top(problem)
    slack = 2e-9 * (1 + reference)  # either may accept a v up to the set-membership slack above the top
    assert cyc.profile.x[0] == pytest.approx(cyc.profile.x[-1], rel=1e-12)
    assert cyc.profile.x[0] == pytest.approx(reference, rel=1e-8, abs=slack)
    top = float(min(problem.x_max[0], problem.x_max[-1]))
    assert min(boundary._lap_bound(problem, top)) >= reference - slack
    assert cyc.ratios.within()
    monkeypatch.setattr(boundary, "_lap_bound", lambda p, top: (2.0 * top, 2.0 * top))  # no help: the bisection
    forced = plan(path, irb140, cfg)
    assert forced.profile.x[0] == pytest.approx(reference, rel=1e-8, abs=slack)
    assert forced.duration == pytest.approx(cyc.duration, rel=1e-8)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_max_feasible_scale_is_the_largest_scale_the_rows_allow(seed):
    """s * x meets every row P x_i + Q x_i+1 <= R and x <= x_max at s = max_feasible_scale, and some row or bound
    is exceeded just above it (checked on the rows directly)."""
    from pathmotion.planning.baselines import max_feasible_scale
    from pathmotion.planning.topp import IntervalProblem

    rng = np.random.default_rng(seed)
    k, m = int(rng.integers(2, 40)), int(rng.integers(0, 6))
    P, Q = rng.normal(size=(k - 1, m)), rng.normal(size=(k - 1, m))
    R = rng.uniform(0.1, 2.0, (k - 1, m))
    x = np.where(rng.random(k) < 0.2, 0.0, rng.uniform(0.0, 2.0, k))
    x_max = np.where(rng.random(k) < 0.2, np.inf, rng.uniform(0.5, 3.0, k))
    s = max_feasible_scale(IntervalProblem(np.arange(k, dtype=float), P, Q, R, x_max), x)

    def worst(scale):  # largest row value / bound and x / x_max
        lhs = P * scale * x[:-1, None] + Q * scale * x[1:, None]
        return max(float(np.max(lhs / R, initial=0.0)), float(np.max(scale * x / x_max, initial=0.0)))

    if np.isfinite(s):
        assert worst(s) <= 1.0 + 1e-12 and worst(s * (1.0 + 1e-9)) > 1.0
    else:
        assert worst(1e6) <= 1.0
