"""Certified verification (planning/certify.py) against the independent dense time resample:
the certified bound of every limit on every grid interval is never below the resample's maximum
there, on random splines and limit sets; the default (certified) plan passes the 0.1 ms resample;
the verify modes parse and the dense mode stays available."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from pathmotion.errors import ScenarioError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.modes import VerifyMode
from pathmotion.planning import PlanSettings, Trajectory, effective_limits, plan
from pathmotion.planning.planner import certified_bounds
from pathmotion.planning.verify import sample_ratios
from pathmotion.robot import Payload
from tests.planning_paths import PolylinePath, assert_bounds_cover, dense_interval_max

#: Limit sets: keyword arguments of PlanSettings (the torque-speed envelope exercises the sampled form).
LIMIT_SETS = {
    "vel+acc": dict(limits={"use_torque": False}),
    "torque": dict(),
    "torque-binding": dict(limits={"torque_scale": 0.35, "torque_reserve": 0.0}),  # 35 % of the torque, no reserve
    "payload": dict(limits={"acceleration_scale": 2.0}),
    "tcp": dict(limits={"use_torque": False, "tcp_speed": 0.6}),
    "envelope": dict(limits={"torque_speed": {"knee": 0.4, "at_max_speed": 0.5}}),
}
DENSE_DT = 2e-4


def _spline(seed: int, waypoints: int) -> SplineJointPath:
    return SplineJointPath.from_waypoints(np.random.default_rng(seed).uniform(-1.5, 1.5, size=(waypoints, 6)))


def _check_bounds(path, robot, limit_set, grid_points):
    s = PlanSettings(grid_points=grid_points, verify="off", **LIMIT_SETS[limit_set])
    res = plan(path, robot, s)
    limits = effective_limits(robot, s)
    bounds = certified_bounds(path, robot, res.profile, s)
    dense = dense_interval_max(path, robot, res.profile, limits, DENSE_DT)
    assert_bounds_cover(bounds, dense, limit_set)
    for name, d in dense.items():
        b = bounds[name]
        if grid_points >= 400:  # not vacuous: on a fine grid the largest bound is near the resample's maximum
            assert b.max() <= d.max() + 0.05 * max(d.max(), 1.0), (limit_set, name, float(b.max()), float(d.max()))
    return bounds, dense


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 10_000), waypoints=st.sampled_from([4, 7, 12]),
       limit_set=st.sampled_from(sorted(LIMIT_SETS)), grid_points=st.sampled_from([60, 150, 400, 1000]))
def test_certified_bound_covers_the_dense_resample(irb140, seed, waypoints, limit_set, grid_points):
    _check_bounds(_spline(seed, waypoints), irb140, limit_set, grid_points)


def test_certified_bound_on_a_path_with_kinks_and_breaks(irb140):
    """Segment connections (no second differences across them) and stops at kinks."""
    wp = np.array([[0, 0, 0, 0, 0, 0], [0.5, 0.3, -0.2, 0.4, 0.2, 0.1], [0.9, 0.1, 0.3, -0.2, 0.6, 0.5],
                   [1.3, 0.6, 0.1, 0.3, 0.1, -0.4]])
    _check_bounds(PolylinePath.through(wp), irb140, "torque", 120)


def test_payload_makes_torque_bind_and_the_bound_holds(irb140):
    robot = irb140.with_payload(Payload(mass=6.0, com=np.array([0.0, 0.0, 0.1])))
    path = _spline(3, 7)
    bounds, dense = _check_bounds(path, robot, "payload", 200)
    assert dense["torque"].max() > 0.99  # torque binds


@pytest.mark.parametrize("limit_set", ["vel+acc", "torque-binding", "tcp"])
def test_default_plan_passes_the_dense_resample(irb140, limit_set):
    """The default (certified) plan: no limit above 1 + limit_tolerance on the 0.1 ms resample."""
    path = _spline(11, 7)
    s = PlanSettings(grid_points=300, **LIMIT_SETS[limit_set])
    res = plan(path, irb140, s)
    assert res.ratios.method == "certified"
    limits = effective_limits(irb140, s)
    _, r = sample_ratios(Trajectory(path, res.profile, irb140), limits, 1e-4)
    worst = max(float(v.max()) for v in r.values())
    assert worst <= 1.0 + s.limit_tolerance
    assert worst <= res.ratios.max_ratio + 1e-9  # the certified summary bounds the resample


def test_dense_mode_still_available_and_agrees(irb140):
    path = _spline(5, 4)
    cert = plan(path, irb140, PlanSettings(limits={"torque_scale": 0.35, "torque_reserve": 0.0}))
    dense = plan(path, irb140, PlanSettings(limits={"torque_scale": 0.35, "torque_reserve": 0.0}, verify="dense"))
    assert dense.ratios.method == "dense" and dense.ratios.sample_time == pytest.approx(1e-4)
    assert dense.ratios.max_ratio <= 1.001
    assert abs(cert.duration - dense.duration) <= 5e-4 * dense.duration  # both tighten; the bound more


def test_verify_modes_parse():
    assert PlanSettings(verify=True).verify == VerifyMode.CERTIFIED
    assert PlanSettings(verify=False).verify == VerifyMode.OFF
    assert PlanSettings(verify="dense").verify == VerifyMode.DENSE
    assert PlanSettings().verify == VerifyMode.CERTIFIED and PlanSettings().baselines is False
    with pytest.raises(ScenarioError, match="verify"):
        PlanSettings(verify="sometimes")


@pytest.mark.parametrize("limit_set, robot_payload, grid_points", [
    ("torque-binding", False, 120), ("payload", True, 150), ("tcp", False, 150), ("envelope", False, 150)])
def test_union_sampling_equals_each_limit_alone(irb140, limit_set, robot_payload, grid_points):
    """certify() samples the union of the intervals all limits need once per pass; the bounds must be
    bit for bit those of certifying each limit on its own (samples and bounds are per interval)."""
    from pathmotion.planning.certify import CertifyContext, certify
    from pathmotion.planning.grid_data import grid_breaks, sample_grid

    robot = irb140.with_payload(Payload(mass=6.0, com=np.array([0.0, 0.0, 0.1]))) if robot_payload else irb140
    for path in (_spline(4, 4), _spline(9, 7)):
        s = PlanSettings(grid_points=grid_points, verify="off", **LIMIT_SETS[limit_set])
        profile = plan(path, robot, s).profile
        limits = effective_limits(robot, s)
        breaks = grid_breaks(path, profile.grid)
        samp = sample_grid(path, robot, profile.grid, breaks)

        def context():
            return CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque)

        together = context()
        union = certify(together, limits)
        assert {key[1] for key in together._samples} >= {4, 16}, "both passes must sample for the test to bite"
        for lim in limits:
            alone = certify(context(), [lim])[lim.name]
            assert np.array_equal(union[lim.name], alone), (limit_set, lim.name)


def _row_reference(form, grid, u, x, smooth, knots, safety):
    """Row-form bound (K - 1, m) written out with numpy, interval by interval (the kernel's reference):
    the end values, each coefficient's second differences (none at the ends and breaks; at the grid
    points ``knots`` less the coefficient's slope jump), its curvature estimate, and the chord-plus-parabola
    maximum found by dense evaluation of |chord| + a t (1 - t) over t in [0, 1]."""
    h = np.diff(grid)
    k1, m = len(h), len(np.atleast_1d(form.limit))
    v0, v1, bend = np.zeros((k1, m)), np.zeros((k1, m)), np.zeros((k1, m))
    t = np.linspace(0.0, 1.0, 20001)
    for kind, (pair, jump) in enumerate(zip((form.a, form.b, form.c), form.knot_jumps)):
        if pair is None:
            continue
        pr, pl = pair
        factor0 = (u, x[:-1], np.ones(k1))[kind][:, None]
        factor1 = (u, x[1:], np.ones(k1))[kind][:, None]
        v0 += pr[:-1] * factor0
        v1 += pl[1:] * factor1
        slope = (pl[1:] - pr[:-1]) / h[:, None]
        d = np.zeros((k1 + 1, m))
        for g in range(1, k1):
            if smooth[g]:
                kink = jump[list(knots).index(g)] if jump is not None and g in knots else 0.0
                d[g] = np.abs(slope[g] - slope[g - 1] - kink) / (0.5 * (h[g] + h[g - 1]))
        for i in range(k1):
            cand = [d[i] + d[i + 1]] + ([d[i - 1]] if i > 0 else []) + ([d[i + 2]] if i + 2 <= k1 else [])
            m2 = safety * np.max(cand, axis=0)
            if kind == 0:
                bend[i] += m2 * abs(u[i])
            elif kind == 1:
                bend[i] += m2 * max(x[i], x[i + 1]) + 4.0 * (np.abs(slope[i]) + h[i] * m2) * abs(u[i])
            else:
                bend[i] += m2
    a = 0.5 * bend * (h**2)[:, None]
    chord = v0[:, :, None] + (v1 - v0)[:, :, None] * t
    bound = (np.abs(chord) + a[:, :, None] * t * (1.0 - t)).max(axis=2) / np.asarray(form.limit, float)
    return np.sqrt(np.maximum(bound, 0.0)) if form.squared else bound


@pytest.mark.parametrize("seed", range(6))
def test_row_kernel_equals_the_numpy_reference(seed):
    """row_bounds (one compiled kernel call per limit) against the numpy reference above, on random
    coefficients, an uneven grid with a break and two knots, absent coefficients, a squared form and a
    coefficient whose slope jumps at the knots."""
    from types import SimpleNamespace

    from pathmotion.planning.certify import REMAINDER_SAFETY, CertifyContext, row_bounds
    from pathmotion.planning.limits import RowForm

    rng = np.random.default_rng(seed)
    k, m = 40, 3
    grid = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, k - 2)]))
    u, x = rng.normal(0.0, 2.0, k - 1), rng.uniform(0.0, 3.0, k)
    breaks, knots = (13,), (8, 27)
    profile = SimpleNamespace(grid=grid, u=u, x=x)
    ctx = CertifyContext(SimpleNamespace(n=m), None, profile, None, None, breaks, False)
    ctx.__dict__["knots"] = (np.array(knots), None)  # the cached property, as the path would give it

    def pair():
        right = rng.normal(size=(k, m))
        left = right.copy()
        left[list(breaks)] = rng.normal(size=(len(breaks), m))  # the other side of the break differs
        return right, left

    forms = {"abc": RowForm(pair(), pair(), pair(), rng.uniform(0.5, 2.0, m)),
             "b only, squared": RowForm(None, tuple(np.abs(p) for p in pair()), None, np.ones(m), squared=True),
             "b kinked at knots": RowForm(pair(), pair(), None, rng.uniform(0.5, 2.0, m),
                                          knot_jumps=(None, rng.normal(0.0, 30.0, (len(knots), m)), None))}
    smooth = np.ones(k, bool)
    smooth[[0, -1, *breaks]] = False
    for name, (bound, valid) in row_bounds(ctx, forms).items():
        ref = _row_reference(forms[name], grid, u, x, smooth, knots, REMAINDER_SAFETY)
        # the reference maximizes on a t grid of step 5e-5: below the exact maximum by at most ~1e-8 relative
        assert np.all(bound >= ref - 1e-12) and np.allclose(bound, ref, rtol=1e-7, atol=1e-12), name
        assert np.array_equal(valid, smooth[:-1] | smooth[1:]), name


def test_chord_bound_is_the_parabola_maximum():
    """_chord_bound(v0, v1, a) = max over t of |v0 + (v1 - v0) t| + a t (1 - t), between the larger end
    and that plus a / 4 (the earlier bound that ignored the ends' difference)."""
    from pathmotion.planning.certify import _chord_bound

    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 200001)
    for v0, v1, a in zip(rng.normal(size=300), rng.normal(size=300), np.abs(rng.normal(size=300)) * rng.choice([0, 0.1, 3], 300)):
        exact = float((np.abs(v0 + (v1 - v0) * t) + a * t * (1.0 - t)).max())
        got = _chord_bound(v0, v1, a)
        assert exact - 1e-12 <= got <= exact + 1e-9
        assert max(abs(v0), abs(v1)) <= got <= max(abs(v0), abs(v1)) + a / 4.0 + 1e-15


def test_knot_next_to_a_fast_changing_torque_curvature(irb140):
    """Regression: a 12-waypoint spline on a 60-point grid, where the reduced dynamics' beta changes its
    second derivative 2.6x within one interval next to a knot. Skipping beta's second difference at the
    knot altogether (rather than subtracting its kink) undercut the dense maximum there by 1e-4."""
    _check_bounds(_spline(35227, 12), irb140, "torque-binding", 60)


@pytest.mark.parametrize("limit_set, grid_points", [("torque-binding", 60), ("payload", 80), ("tcp", 60)])
def test_accept_leaves_bounds_within_it_or_refines_all(irb140, limit_set, grid_points):
    """certify(..., accept): every bound is an upper bound of the full refinement's (accept=None); when
    some bound exceeds ``accept`` the bounds are the full refinement's bit for bit (the planner tightens
    on them), otherwise every bound is within ``accept`` (the plan passes either way)."""
    from pathmotion.planning.certify import CertifyContext, certify
    from pathmotion.planning.grid_data import grid_breaks, sample_grid

    robot = irb140.with_payload(Payload(mass=6.0, com=np.array([0.0, 0.0, 0.1]))) if limit_set == "payload" else irb140
    seen = set()
    for seed in range(8):
        path = _spline(seed, 12)
        s = PlanSettings(grid_points=grid_points, verify="off", **LIMIT_SETS[limit_set])
        profile = plan(path, robot, s).profile
        limits = effective_limits(robot, s)
        breaks = grid_breaks(path, profile.grid)
        samp = sample_grid(path, robot, profile.grid, breaks)
        context = lambda: CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque)  # noqa: E731
        accept = 1.0 + s.limit_tolerance
        full, lazy = certify(context(), limits), certify(context(), limits, accept)
        over = max(float(b.max()) for b in lazy.values()) > accept
        seen.add(over)
        for name in full:
            assert np.all(lazy[name] >= full[name]), (seed, name)
            if over:
                assert np.array_equal(lazy[name], full[name]), (seed, name)
            else:
                assert lazy[name].max() <= accept
    assert True in seen, "no case needed the full refinement: the test would not bite"


def test_knot_jumps_match_one_sided_finite_differences(irb140):
    """The slope jumps the acceleration and torque limits give at spline knots (Phi''' and M Phi''' jumps)
    equal those of Phi'' and of beta measured by one-sided finite differences on either side of each knot."""
    from pathmotion.planning.certify import CertifyContext
    from pathmotion.planning.grid_data import grid_breaks, sample_grid
    from pathmotion.planning.reduced import reduced_dynamics

    path, robot = _spline(3, 7), irb140
    s = PlanSettings(grid_points=200, verify="off")
    profile = plan(path, robot, s).profile
    limits = effective_limits(robot, s)
    breaks = grid_breaks(path, profile.grid)
    samp = sample_grid(path, robot, profile.grid, breaks)
    ctx = CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque)
    index = ctx.knots[0]
    assert len(index) == 5 and np.allclose(profile.grid[index], path.knots)
    eps = 1e-5

    def one_sided_slope(f, theta, sign):  # second order: (-3 f0 + 4 f1 - f2) / (2 eps), f1 = f(theta + sign eps)
        return sign * (-3.0 * f(theta) + 4.0 * f(theta + sign * eps) - f(theta + 2 * sign * eps)) / (2.0 * eps)

    for name, coeff in (("acceleration", lambda th: path.evaluate(np.atleast_1d(th))[2]),
                        ("torque", lambda th: reduced_dynamics(robot, *path.evaluate(np.atleast_1d(th))).beta)):
        jump = limits.get(name).certify_row_form(ctx).knot_jumps[1]
        for n, theta in enumerate(profile.grid[index]):
            measured = one_sided_slope(coeff, theta, 1.0) - one_sided_slope(coeff, theta, -1.0)
            assert np.allclose(jump[n], measured[0], rtol=1e-4, atol=1e-6 * np.abs(jump).max()), (name, n)
