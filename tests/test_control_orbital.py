"""The compiled per-sample code against the pieces it is built from, and the monitor at a sharp kink.

References: the uncompiled composition (project / transverse_state / ProfileLookup / OrbitalDesign.gain_at /
PathTable.evaluate_scalar, each tested against its own reference in test_control_transverse.py), and the
exact geometry of a two-segment joint-space polyline (the nearest point is known in closed form).
"""

from dataclasses import dataclass

import numpy as np
import pytest

from pathmotion import defaults
from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable, transverse_state
from pathmotion.control.orbital_law import orbital_command, profile_at_time
from pathmotion.joint_path import JointPath, SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.simulation import SimulationSettings, simulate
from pathmotion.simulation.monitor import monitor_state

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


def trapezoid(v=0.9, a=2.0):
    ta = v * v / (2 * a)
    return Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))


@pytest.fixture(scope="module")
def design():
    return OrbitalDesign.build(PathTable.from_path(SplineJointPath.from_waypoints(WAYPOINTS)), trapezoid(),
                               OrbitalGains())


@pytest.mark.parametrize("theta", [0.2, 0.45, 0.7])
def test_compiled_law_equals_its_pieces(design, theta):
    table, lookup = design.table, design.profile
    rng = np.random.default_rng(int(theta * 100))
    phi, dphi, _ = table.evaluate_scalar(theta)
    q = phi + rng.normal(0, 1e-3, 6)
    qd = dphi * 0.8 + rng.normal(0, 1e-2, 6)
    ts, guess = 0.004, theta - 0.003
    st = transverse_state(table, design.basis, lookup, q, qd, guess)
    xi0 = rng.normal(0, 1e-3, 6)
    xi = xi0.copy()
    x_perp, v = np.zeros(design.gain.shape[2]), np.zeros(6)
    th, thd = orbital_command(table.grid, table.coeffs, table.closed, q, qd, guess, defaults.PROJECTION_ITERATIONS,
                              defaults.PROJECTION_TOLERANCE * table.length, defaults.PROJECTION_MAX_STEP * table.length,
                              design.basis.k, design.basis.sigma, lookup.profile.grid, lookup.profile.x,
                              lookup.profile.u, design.gain, xi, ts, x_perp, v)
    assert th == pytest.approx(st.theta, abs=1e-12) and thd == pytest.approx(st.theta_dot, rel=1e-10)
    z, zd, speed = st.x_perp[:5], st.x_perp[5:10], st.x_perp[10]
    expected_xi = xi0 + ts * np.concatenate([z, [speed]])
    assert np.allclose(xi, expected_xi, atol=1e-15)
    assert np.allclose(x_perp, np.concatenate([expected_xi, st.x_perp]), atol=1e-13)
    theta_m = st.theta + 0.5 * ts * st.theta_dot
    _, dphi_m, ddphi_m = table.evaluate_scalar(theta_m)
    x_m, u_m = lookup.state(theta_m)
    want = dphi_m * u_m + ddphi_m * x_m - design.gain_at(st.theta) @ x_perp
    assert np.allclose(v, want, rtol=1e-10, atol=1e-10)


def test_compiled_profile_at_time_equals_the_profile():
    p = trapezoid()
    for t in np.linspace(-0.1, p.duration + 0.1, 37):
        got = profile_at_time(p.times, p.grid, p.x, p.u, t)
        want = p.state_at_time(t)
        assert np.allclose(got, [float(np.asarray(w).ravel()[0]) for w in want], atol=1e-12)


@dataclass(frozen=True, eq=False)
class Polyline(JointPath):
    """q = a + theta d1 on [0, 1], then b + (theta - 1) d2 on [1, 2]: a kink at theta = 1."""

    a: np.ndarray = None
    d1: np.ndarray = None
    d2: np.ndarray = None

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        second = th > 1 if side == "left" else th >= 1
        b = self.a + self.d1
        q = np.where(second[:, None], b + (th - 1)[:, None] * self.d2, self.a + th[:, None] * self.d1)
        dq = np.where(second[:, None], self.d2, self.d1)
        out = (q, dq, np.zeros_like(q))
        return tuple(o[0] for o in out) if scalar else out


def test_monitor_passes_a_kink_sharper_than_90_degrees():
    """The second segment turns back by 135 degrees (joint space). A point on it, 0.05 past the kink, is nearest
    to itself (distance 0); the local projection from just before the kink alone would stay on the first
    segment at distance 0.05 sin(45 deg)."""
    d1 = np.array([1.0, 0, 0, 0, 0, 0])
    d2 = np.array([-1.0, 1.0, 0, 0, 0, 0]) / np.sqrt(2.0)
    path = Polyline(n=6, domain=(0.0, 2.0), kinks=(1.0,), breaks=(1.0,), a=np.zeros(6), d1=d1, d2=d2)
    table = PathTable.from_path(path, 201)
    q = d1 + 0.05 * d2
    args = (np.full(6, 1e3), 0.0)
    proj = (defaults.PROJECTION_ITERATIONS, defaults.PROJECTION_TOLERANCE * 2, defaults.PROJECTION_MAX_STEP * 2)
    alone = table.project(q, 0.999, *proj)[0]
    assert alone < 1.0  # stuck on the first segment
    th, thd, dev, _, _, ok = monitor_state(table.grid, table.coeffs, False, table.kinks, q, np.zeros(6), 0.999,
                                           *proj, *args)
    assert ok and th == pytest.approx(1.05, abs=1e-9) and dev < 1e-12
    # away from the kink the monitor is the plain local projection
    q2 = path(0.5) + 0.01 * np.array([0, 0, 1.0, 0, 0, 0])
    th2, _, dev2, _, _, _ = monitor_state(table.grid, table.coeffs, False, table.kinks, q2, np.zeros(6), 0.49,
                                          *proj, *args)
    assert th2 == pytest.approx(0.5, abs=1e-9) and dev2 == pytest.approx(0.01, abs=1e-12)


def test_the_run_stops_at_the_kink_and_goes_on(irb140):
    """A plan that stops at a 135 degree joint-space corner: the monitor follows the robot round the corner
    (the deviation stays small) and the run arrives at the planned time."""
    q0 = np.array([0.0, 0.2, -0.3, 0.0, 0.6, 0.0])
    d1 = np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0])
    d2 = np.array([-0.4, 0.4, 0.0, 0.0, 0.0, 0.0]) / np.sqrt(2.0)
    path = Polyline(n=6, domain=(0.0, 2.0), kinks=(1.0,), breaks=(1.0,), a=q0, d1=d1, d2=d2)
    grid = np.array([0.0, 0.25, 0.75, 1.0, 1.25, 1.75, 2.0])
    profile = Profile(grid, np.array([0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0]))  # rest at the kink
    r = simulate(irb140, path, profile, "orbital", SimulationSettings())
    s = r.summary()
    assert s["tracking_ok"] and s["max_joint_deviation_rad"] < 1e-3
    assert abs(s["simulated_duration_s"] - profile.duration) <= 0.01 * profile.duration
    assert r.theta[-1] == pytest.approx(2.0, abs=1e-3)
