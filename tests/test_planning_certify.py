"""Certified verification (planning/certify.py) against the independent dense time resample:
the certified bound of every limit on every grid interval is never below the resample's maximum
there, on random splines and limit sets; the default (certified) plan passes the 0.1 ms resample;
the verify modes parse and the dense mode stays available."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from pathmotion.errors import ScenarioError
from pathmotion.joint_path import SplineJointPath
from pathmotion.modes import VerifyMode
from pathmotion.planning import PlanSettings, Trajectory, effective_limits, plan
from pathmotion.planning.planner import certified_bounds
from pathmotion.planning.verify import sample_ratios
from pathmotion.robot import Payload
from tests.planning_paths import PolylinePath, assert_bounds_cover, dense_interval_max

#: Limit sets: keyword arguments of PlanSettings (the torque-speed envelope exercises the sampled form).
LIMIT_SETS = {
    "vel+acc": dict(torque=False),
    "torque": dict(),
    "torque-binding": dict(torque_scale=0.35),
    "payload": dict(acceleration_scale=2.0),
    "tcp": dict(torque=False, tcp_speed_limit=0.6),
    "envelope": dict(torque_speed={"knee": 0.4, "at_max_speed": 0.5}),
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
    cert = plan(path, irb140, PlanSettings(torque_scale=0.35))
    dense = plan(path, irb140, PlanSettings(torque_scale=0.35, verify="dense"))
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
    from pathmotion.planning.planner import _grid_breaks, _sample

    robot = irb140.with_payload(Payload(mass=6.0, com=np.array([0.0, 0.0, 0.1]))) if robot_payload else irb140
    for path in (_spline(4, 4), _spline(9, 7)):
        s = PlanSettings(grid_points=grid_points, verify="off", **LIMIT_SETS[limit_set])
        profile = plan(path, robot, s).profile
        limits = effective_limits(robot, s)
        breaks = _grid_breaks(path, profile.grid)
        samp = _sample(path, robot, profile.grid, breaks)

        def context():
            return CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque)

        together = context()
        union = certify(together, limits)
        assert {key[1] for key in together._samples} >= {4, 16}, "both passes must sample for the test to bite"
        for lim in limits:
            alone = certify(context(), [lim])[lim.name]
            assert np.array_equal(union[lim.name], alone), (limit_set, lim.name)
