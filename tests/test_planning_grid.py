"""The adaptive planner grid (planning/grid.py): the method's convergence order, convergence of the
adaptive duration to toppra's fine-grid optimum (a second algorithm, Richardson-extrapolated) within
the requested tolerance, and an error estimate that shrinks with the tolerance and bounds the true
error."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion import api, defaults
from pathmotion.errors import ScenarioError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, effective_limits, plan
from pathmotion.planning.verify import sample_ratios
from pathmotion.planning.grid import ORDER, Grid, make_grid, pieces_for, pieces_within
from pathmotion.scenarios import scenario_path

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
CASES = [(1, 7), (2, 12), (3, 4)]  # (seed, waypoints) of random clamped splines
CIRCLE = scenario_path("circle_zero")


@pytest.fixture(scope="module")
def robot(irb140):
    return irb140.with_limits(replace(irb140.limits, acceleration=ACC))


def _spline(seed, n):
    return SplineJointPath.from_waypoints(np.random.default_rng(seed).uniform(-1.5, 1.5, (n, 6)))


def _toppra_path(path):
    """A pathmotion JointPath seen as a toppra geometric path (q, q', q'' at theta)."""
    import toppra.interpolator as interp

    class Wrapped(interp.AbstractGeometricPath):
        def __call__(self, ss, order=0):
            return path.evaluate(np.clip(np.atleast_1d(ss), *path.domain), "right")[order]

        @property
        def dof(self):
            return path.n

        @property
        def path_interval(self):
            return np.array(path.domain)

        @property
        def waypoints(self):
            return None

    return Wrapped()


def _toppra_t_star(path, robot, acc, torque: bool, points=(6000, 12000), tau_max=None) -> float:
    """toppra's optimum, first-order Richardson from two fine uniform grids (interpolation everywhere); ``tau_max``
    (n,) [N m]: the torque limits toppra enforces (default the robot's)."""
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    lim = robot.limits
    cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T)]
    if acc is not None:
        cons.append(constraint.JointAccelerationConstraint(np.vstack([-acc, acc]).T))
    if torque:
        model, data = robot.model, robot.model.createData()
        cons.append(constraint.JointTorqueConstraint(
            lambda q, v, a: pin.rnea(model, data, q, v, a),
            np.vstack([-lim.torque, lim.torque]).T if tau_max is None else np.vstack([-tau_max, tau_max]).T,
            np.zeros(robot.n), discretization_scheme=constraint.DiscretizationType.Interpolation))
    tpath = _toppra_path(path)
    t = [algo.TOPPRA(cons, tpath, gridpoints=np.linspace(*path.domain, n),
                     parametrizer="ParametrizeConstAccel").compute_trajectory().duration for n in points]
    return 2.0 * t[1] - t[0]


def _assert_dense_within_limits(result, path, robot):
    """No limit above 1 + limit_tolerance on the 0.1 ms resample (independent of the certification)."""
    limits = effective_limits(robot, result.settings)
    _, ratios = sample_ratios(result.trajectory, limits, defaults.VERIFY_SAMPLE_TIME, result.jump_intervals)
    worst = max(float(np.max(v)) for v in ratios.values())
    assert worst <= 1.0 + result.settings.limit_tolerance, worst


def test_split_and_halve_insert_equal_parts_and_keep_the_special_points():
    g = Grid(np.array([0.0, 1.0, 3.0, 4.0]), (1,), (2,))
    s = g.split(np.array([1, 4, 2]))
    np.testing.assert_allclose(s.theta, [0, 1, 1.5, 2, 2.5, 3, 3.5, 4])
    assert s.theta[list(s.breaks)] == [1.0] and s.theta[list(s.kinks)] == [3.0]
    np.testing.assert_allclose(g.halved().theta, [0, 0.5, 1, 2, 3, 3.5, 4])
    np.testing.assert_allclose(g.halved([False, True, False]).theta, [0, 1, 2, 3, 4])


def test_pieces_follow_the_square_root_of_the_change_and_meet_the_target():
    change = np.array([0.0, 1e-6, 4e-6, 16e-6])
    n = pieces_for(change, 1e-6)
    assert n[0] == 1 and list(n[1:] / n[1]) == pytest.approx([1, 2, 4], rel=0.2)
    assert float(np.sum(change / n)) <= 1e-6


@settings(max_examples=60, deadline=None)
@given(error=st.lists(st.floats(0.0, 1e-3), min_size=1, max_size=40), room=st.integers(-5, 400))
def test_pieces_within_a_room_add_at_most_that_many_points_and_follow_the_error(error, room):
    """The capped split adds at most ``room`` points, splits a larger error into at least as many parts, and
    uses the room up to the parts of a single interval (the next larger multiplier would overflow it)."""
    from pathmotion.planning.grid import MAX_PIECES

    error = np.array(error)
    n = pieces_within(error, room)
    assert n.shape == error.shape and n.min() >= 1 and n.max() <= MAX_PIECES
    assert int(np.sum(n - 1)) <= max(room, 0)
    order = np.argsort(error, kind="stable")
    assert np.all(np.diff(n[order]) >= 0), (error, n)
    free = (error > 0) & (n < MAX_PIECES)
    if room > 0 and free.any():  # not leaving room for another part of every interval with an error
        assert int(np.sum(n - 1)) > room - int(np.sum(free)) * MAX_PIECES


def test_the_adaptive_grid_stops_at_its_largest_and_says_so(robot, caplog):
    """With max_points below what the tolerance needs, no grid after the first halving exceeds it, the last grid
    is filled up to it, and the result carries the estimate of that grid (above the tolerance) and a warning."""
    from pathmotion.planning.grid import refine
    from pathmotion.planning.planner import _solve_on

    path = _spline(2, 7)
    settings = PlanSettings(duration_tolerance=5e-4)
    limits = effective_limits(robot, settings)
    initial = make_grid(path, 200)
    seen = []

    def solve(g):
        seen.append(len(g.theta))
        return _solve_on(path, robot, settings, limits, g)

    free = refine(solve, initial, 5e-5)
    cap = (seen[1] + seen[-1]) // 2
    assert cap < seen[-1], "the tolerance must need more than the cap for this test"
    seen.clear()
    with caplog.at_level("WARNING", logger="pathmotion.planning.grid"):
        capped = refine(solve, initial, 5e-5, max_points=cap)
    assert max(seen[2:]) <= cap and seen[-1] > 0.9 * cap
    assert len(capped.grid.theta) == seen[-1] and capped.error_estimate > 5e-5 * capped.solved.sol.profile.duration
    assert capped.error_estimate > free.error_estimate
    assert "at its largest" in caplog.text


def test_measured_convergence_order_is_the_one_the_estimate_assumes(robot):
    """Halving every interval of a fixed grid divides the duration's change by 2^ORDER."""
    path = _spline(1, 7)
    d = [plan(path, robot, PlanSettings(grid_points=n, verify="off")).duration for n in (400, 800, 1600, 3200)]
    ratios = np.diff(d)[:-1] / np.diff(d)[1:]
    assert np.all(np.abs(np.log2(ratios) - ORDER) < 0.25), ratios


@pytest.mark.parametrize("seed, waypoints", CASES)
def test_adaptive_duration_converges_to_toppras_optimum(robot, seed, waypoints):
    path = _spline(seed, waypoints)
    t_star = _toppra_t_star(path, robot, ACC, torque=False)
    estimates = []
    for tol in (2e-3, 5e-4, 1.25e-4):
        r = plan(path, robot, PlanSettings(duration_tolerance=tol))
        err = abs(r.duration - t_star)
        assert err <= tol * t_star, (tol, err / t_star)
        assert err <= r.duration_error_estimate, (tol, err, r.duration_error_estimate)
        _assert_dense_within_limits(r, path, robot)
        estimates.append(r.duration_error_estimate)
    assert estimates[0] > estimates[1] > estimates[2]


def test_adaptive_circle_scenario_within_tolerance_of_toppra(irb140):
    setup = api.load(CIRCLE)
    settings = replace(setup.plan_settings, baselines=False)
    r = plan(setup.path, setup.robot, settings)
    active = {lim.name: lim for lim in effective_limits(setup.robot, settings)}
    acc = setup.robot.limits.acceleration if "acceleration" in active else None
    # toppra gets the torque the planner enforces: the limits less the feedback reserve
    t_star = _toppra_t_star(setup.path, setup.robot, acc, torque=True, tau_max=active["torque"].tau_max)
    assert abs(r.duration - t_star) <= settings.duration_tolerance * t_star
    assert abs(r.duration - t_star) <= r.duration_error_estimate


def test_grid_points_gives_a_fixed_grid_without_estimate(robot):
    path = _spline(1, 7)
    r = plan(path, robot, PlanSettings(grid_points=300, verify="off"))
    assert r.grid_points == len(make_grid(path, 300).theta)
    assert r.duration_error_estimate is None


@pytest.mark.parametrize("bad", [0.0, -1e-3, 0.5, True])
def test_tolerance_out_of_range_names_the_key(bad):
    with pytest.raises(ScenarioError, match="plan.duration_tolerance"):
        PlanSettings(duration_tolerance=bad)


def test_the_former_key_plan_tolerance_names_the_new_one():
    with pytest.raises(ScenarioError, match="unknown key 'tolerance'; it is now called 'duration_tolerance'"):
        api.load(CIRCLE, {"plan.tolerance": 2e-3})


def test_scenario_tolerance_reaches_the_plan_and_the_summary():
    setup = api.load(CIRCLE, {"plan.duration_tolerance": 2e-3})
    assert setup.plan_settings.duration_tolerance == 2e-3 and setup.plan_settings.grid_points is None
    result = plan(setup.path, setup.robot, replace(setup.plan_settings, baselines=False))
    summary = api.plan_summary(setup, result)
    assert 0 < summary["duration_error_estimate"] <= 2e-3 * result.duration
    fixed = api.load(CIRCLE, {"plan.grid_points": 300})
    assert fixed.plan_settings.grid_points == 300


def test_refinement_nests_its_grids_and_splits_by_the_error(robot):
    """Every grid the refinement solves contains the previous one (so path data is reused at the shared
    points), the first refinement halves every interval, and the estimate it returns is the one of the
    last grid, within the tolerance."""
    from pathmotion.planning.grid import refine
    from pathmotion.planning.planner import _solve_on

    path = _spline(2, 7)
    settings = PlanSettings(duration_tolerance=5e-4)
    limits = effective_limits(robot, settings)
    seen = []

    def solve(g):
        seen.append(g.theta)
        return _solve_on(path, robot, settings, limits, g)

    initial = make_grid(path, 200)
    out = refine(solve, initial, 5e-4)
    assert len(seen) >= 3 and len(seen[1]) == 2 * len(seen[0]) - 1
    for coarse, fine in zip(seen, seen[1:]):
        assert np.all(np.isin(coarse, fine)), "a refinement dropped a point of its parent"
    assert np.array_equal(out.grid.theta, seen[-1])
    assert 0 < out.error_estimate <= 5e-4 * out.solved.sol.profile.duration
    # the second refinement is not uniform: it splits each interval by its estimated error
    parts = np.diff(np.searchsorted(seen[2], seen[1]))
    assert parts.min() == 1 and parts.max() > 2


@settings(max_examples=60, deadline=None)
@given(first=st.floats(1e-9, 0.2), piece=st.floats(0.05, 0.8), where=st.floats(0.2, 0.7))
def test_a_short_piece_gets_grid_points_inside_whatever_the_first_segment(first, piece, where):
    """Grading towards every break is in units of the uniform step (domain / (points - 1)): a segment much
    shorter than a step at the start (a blend that uses all of its neighbour but a sliver, 1e-7 of a step)
    made the grading collapse onto the breaks, and a 0.6 mm corner piece 0.6 steps long got no point inside:
    the search's coarse plan did not see its curvature peak (0.55 s where it takes 0.73 s). Lengths in steps."""
    from types import SimpleNamespace

    points, length = 300, 0.31
    step = length / (points - 1)
    a = where * length
    breaks = (0.0, first * step, a, a + piece * step, length)
    grid = make_grid(SimpleNamespace(domain=(0.0, length), breaks=breaks, kinks=()), points).theta
    for lo, hi in zip(breaks, breaks[1:]):
        inside = grid[(grid > lo) & (grid < hi)]
        if hi - lo >= step / 4:
            assert inside.size >= 2, (lo, hi, inside)
    for i in range(1, len(breaks) - 1):  # the first grading point on each side, half a step away, where it fits
        b = breaks[i]  # (in its own neighbouring segment: beyond the next break the grid grades towards that one)
        for c in (b - step / 2, b + step / 2):
            if breaks[i - 1] < c < breaks[i + 1] and not np.any(np.abs(np.array(breaks) - c) < 1e-3 * step):
                assert np.min(np.abs(grid - c)) < 1e-6 * step, (b, c)  # or its rounding twin (GRID_MIN_GAP)


def test_a_narrow_curvature_peak_inside_a_segment_is_planned_alike_on_coarse_and_fine_grids(irb140):
    """A near-cusp Bezier (curvature peak 11111 1/m, about 0.03 mm wide at half height, against a step of 0.5 mm on
    300 points) planned on 300 points and on 4800: within 1 % once the grid is graded towards the peak, as at a break.
    Without the peaks (the grid before) the coarse plan does not see it: the optimal blend search found such a
    corner quintic at 135 deg / 7 mm (25000 1/m) and took 0.75 s for a motion of 0.87 s."""
    from dataclasses import replace as dc_replace

    from pathmotion.lift.constraint import lift
    from pathmotion.geometry import TaskPath
    from geometry_support import near_cusp

    seg = near_cusp(0.03)
    path = lift(irb140, TaskPath((seg,)))
    assert path.peaks == pytest.approx(seg.curvature_peaks)
    grid = make_grid(path, 300).theta
    step = path.length / 299
    central = seg.curvature_peaks[1]
    for level in (1, 2, 5, defaults.GRID_GRADING_LEVELS):
        for side in (-1, 1):
            assert np.min(np.abs(grid - (central + side * step * 0.5 ** level))) < 1e-9 * step

    def duration(p, points):
        return plan(p, irb140, PlanSettings(grid_points=points, verify=False, baselines=False)).profile.duration

    fine = duration(path, 4800)
    assert duration(path, 300) == pytest.approx(fine, rel=0.01)
    # the same path without its peaks, as the grid was before: 0.650 s on 300 points, 5 % short
    assert duration(dc_replace(path, peaks=()), 300) < 0.97 * fine


def test_path_data_of_a_refined_grid_is_the_parents_where_shared_and_evaluated_elsewhere(robot):
    """_sample with a donor (the previous grid's data) gives the path data a fresh evaluation gives, to round-off,
    and copies the donor's values at the shared points."""
    from pathmotion.planning.grid_data import sample_grid

    path = _spline(2, 7)
    coarse = make_grid(path, 200)
    fine = coarse.split(np.where(np.arange(len(coarse.theta) - 1) % 3 == 0, 3, 1))
    donor = sample_grid(path, robot, coarse.theta, coarse.breaks).right
    reused = sample_grid(path, robot, fine.theta, fine.breaks, donor)
    fresh = sample_grid(path, robot, fine.theta, fine.breaks)
    for side in ("right", "left"):
        for name in ("q", "dq", "ddq"):
            np.testing.assert_allclose(getattr(getattr(reused, side), name), getattr(getattr(fresh, side), name),
                                       rtol=1e-12, atol=1e-12)
    shared = np.isin(fine.theta, coarse.theta)
    assert 0 < shared.sum() < len(fine.theta)
    np.testing.assert_array_equal(reused.right.q[shared], donor.q)


def test_grading_towards_a_break_stops_at_the_next_break():
    """On a path of many short segments (10,000 of 1 mm, the uniform step of 200 points 50 mm) the initial grid
    grades each break only inside its neighbouring segments: the levels finer than a segment, on both sides of each
    break, and no coarser ones, which would land among other breaks' points."""
    from types import SimpleNamespace

    points, length, n = 200, 10.0, 10_000
    step = length / (points - 1)
    breaks = tuple(np.linspace(0.0, length, n + 1))
    grid = make_grid(SimpleNamespace(domain=(0.0, length), breaks=breaks, kinks=()), points).theta
    gap = length / n
    grades = step * 0.5 ** np.arange(1, defaults.GRID_GRADING_LEVELS + 1)
    fitting = grades[grades < gap]  # the finest levels only
    assert 0 < len(fitting) < len(grades)
    assert len(grid) <= points + (n + 1) * (1 + 2 * len(fitting))
    for b in np.asarray(breaks[1:-1])[::997]:  # the grading points of a break, on both sides, within its segments
        for d in fitting:
            for side in (-1, 1):
                assert np.min(np.abs(grid - (b + side * d))) < 1e-9 * step
