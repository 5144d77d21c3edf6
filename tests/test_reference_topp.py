"""The CasADi + IPOPT reference (benchmarks/reference_topp.py) against toppra (acceleration only) and
against the closed-form jerk-limited S-curve on a straight joint-space line."""

import numpy as np
import pytest

pytest.importorskip("casadi", reason="the reference transcription needs casadi (dev extra: pip install -e '.[dev]')")

from pathmotion.lift.constraint import lift  # noqa: E402
from pathmotion.geometry import Arc, TaskPath  # noqa: E402
from pathmotion.lift.joint_path import JointPath  # noqa: E402

from benchmark_modules import load_benchmark  # noqa: E402

ref = load_benchmark("reference_topp")

TOLERANCE = 2e-3  # the reference agrees with toppra to 0.2 % in the acceleration-only case
GRIDS = (100, 200, 400)
S_CURVE_TOLERANCE = 1e-4  # the analytic case converges fast: 2e-5 at these grids


@pytest.mark.slow  # ~15 s: IPOPT on three grids plus toppra
def test_acceleration_only_reference_matches_toppra(irb140):
    pytest.importorskip("toppra", reason="the comparison needs toppra (dev extra)")
    # a lifted quarter circle: Phi' != 0 at both ends (a clamped spline has Phi' = 0 there, so any
    # theta_dot is joint rest and the boundary becomes a matter of discretization)
    task = TaskPath((Arc((0.45, 0.0, 0.55), (0.55, 0.0, 0.55), (0.0, 0.3, 1.0), np.pi / 2),))
    path = lift(irb140, task)
    lim = irb140.limits
    limits = ref.ReferenceLimits(velocity=lim.velocity, acceleration=lim.acceleration)
    t_ref, order, profiles = ref.converged_duration(path, irb140, limits, GRIDS, table_points=2001)
    t_toppra = ref.toppra_duration(path, irb140, lim.velocity, lim.acceleration, gridpoints=2001)
    assert abs(t_ref / t_toppra - 1.0) < TOLERANCE, (t_ref, t_toppra, [p.duration for p in profiles])
    # the finest solution honours every limit at its nodes (IPOPT's tolerance)
    fine = profiles[-1]
    _, dq, ddq, _ = path.evaluate3(fine.theta)
    qd = dq * fine.theta_dot[:, None]
    assert np.all(np.abs(qd) <= lim.velocity * (1 + 1e-6))
    qdd = dq[:-1] * fine.control[:, None] + ddq[:-1] * fine.theta_dot[:-1, None] ** 2
    assert np.all(np.abs(qdd) <= lim.acceleration * (1 + 1e-6))


class _StraightLine(JointPath):
    """q = q0 + delta theta on [0, 1]: Phi' = delta, Phi'' = Phi''' = 0 (a test double)."""

    def __init__(self, q0, delta):
        super().__init__(n=len(q0), domain=(0.0, 1.0))
        object.__setattr__(self, "q0", np.asarray(q0, float))
        object.__setattr__(self, "delta", np.asarray(delta, float))

    def evaluate3(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        q = self.q0 + th[:, None] * self.delta
        d = np.broadcast_to(self.delta, q.shape).copy()
        out = (q, d, np.zeros_like(q), np.zeros_like(q))
        return tuple(o[0] for o in out) if scalar else out

    def evaluate(self, theta, side="right"):
        return self.evaluate3(theta, side)[:3]


def s_curve_time(distance, v, a, j):
    """Closed-form minimum rest-to-rest time of a 1-D motion (rest = zero velocity and acceleration)
    under |velocity| <= v, |acceleration| <= a, |jerk| <= j."""
    def accel_time(peak):  # time to reach speed ``peak`` from rest
        return peak / a + a / j if peak >= a * a / j else 2.0 * np.sqrt(peak / j)

    if distance >= v * accel_time(v):  # v is reached: accelerate, cruise, brake
        return 2.0 * accel_time(v) + (distance - v * accel_time(v)) / v
    lo, hi = 0.0, v  # peak speed with distance = peak * accel_time(peak) (two symmetric halves)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid * accel_time(mid) < distance else (lo, mid)
    return 2.0 * accel_time(lo)


@pytest.mark.slow  # ~12 s each: IPOPT on three grids
@pytest.mark.parametrize("jerk_scale", [3.0, 30.0])
def test_jerk_limited_reference_matches_the_s_curve(irb140, jerk_scale):
    lim = irb140.limits
    delta = np.array([0.8, -0.5, 0.3, 1.2, -0.7, 1.5])
    path = _StraightLine(np.zeros(6), delta)
    jerk = jerk_scale * lim.acceleration
    limits = ref.ReferenceLimits(velocity=lim.velocity, acceleration=lim.acceleration, jerk=jerk)
    t_ref, _, profiles = ref.converged_duration(path, irb140, limits, GRIDS, table_points=201)
    # along the line every joint is delta_j * theta: the binding limit in theta units is the smallest ratio
    expected = s_curve_time(1.0, *(np.min(x / np.abs(delta)) for x in (lim.velocity, lim.acceleration, jerk)))
    assert abs(t_ref / expected - 1.0) < S_CURVE_TOLERANCE, (t_ref, expected, [p.duration for p in profiles])
    fine = profiles[-1]
    assert fine.theta_ddot[0] == 0.0 and fine.theta_ddot[-1] == 0.0  # rest means zero acceleration too
