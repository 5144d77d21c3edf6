"""The compiled per-sample kernels against independent numpy references, and the monitor at a sharp kink.

References: tests/control_reference.py (numpy projection, matrix transverse basis, the planning Profile's
own x_at / state_at_time, np.interp of the gains), and the exact geometry of a two-segment joint-space
polyline (the nearest point is known in closed form).
"""

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, strategies as st

import control_reference as ref
from pathmotion import defaults
from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable, ProfileLookup
from pathmotion.control.kernels import ProfileArrays, orbital_command, profile_at_time
from pathmotion.control.orbital import SAMPLE_MERGE, sample_grid
from pathmotion.lift.joint_path import JointPath, SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.simulation import SimulationSettings, simulate
from pathmotion.simulation.monitor import monitor_state

from tests.planning_paths import CONTROL_WAYPOINTS as WAYPOINTS, trapezoid


@pytest.fixture(scope="module")
def design():
    return OrbitalDesign.build(PathTable.from_path(SplineJointPath.from_waypoints(WAYPOINTS)), trapezoid(),
                               OrbitalGains())


@pytest.mark.parametrize("theta", [0.2, 0.45, 0.7])
@pytest.mark.parametrize("integral", [True, False])
def test_compiled_law_equals_the_reference(design, theta, integral):
    table = design.table
    rng = np.random.default_rng(int(theta * 100))
    phi, dphi, _ = table.evaluate_scalar(theta)
    q = phi + rng.normal(0, 1e-3, 6)
    qd = dphi * 0.8 + rng.normal(0, 1e-2, 6)
    ts, guess = 0.004, theta - 0.003
    xi0 = rng.normal(0, 1e-3, 6) if integral else np.zeros(0)
    gain = design.gain if integral else design.gain[:, :, 6:]
    xi = xi0.copy()
    x_perp, v = np.zeros(gain.shape[2]), np.zeros(6)
    th, thd = orbital_command(table.arrays, design.profile.arrays, design.basis.arrays, table.projection(), gain,
                              q, qd, guess, ts, xi, x_perp, v)
    want = ref.orbital_command(design if integral else _without_integral(design), q, qd, guess, xi0, ts)
    assert th == pytest.approx(want[0], abs=1e-12) and thd == pytest.approx(want[1], rel=1e-10)
    assert np.allclose(xi, want[2], atol=1e-15)
    assert np.allclose(x_perp, want[3], atol=1e-13)
    assert np.allclose(v, want[4], rtol=1e-10, atol=1e-10)


def _without_integral(design):
    """The design with the integral columns of the gain dropped (a law without integral action)."""
    from dataclasses import replace
    return replace(design, gain=design.gain[:, :, 6:])


def test_profile_lookup_equals_the_planned_profile():
    """x*, u* against Profile.x_at / theta_ddot_at; t*(theta) inverts Profile.state_at_time."""
    p = trapezoid()
    lookup = ProfileLookup(p)
    theta = np.linspace(0.0, 1.0, 41)
    for th in theta:
        assert lookup.state(th) == pytest.approx(ref.profile_state(p, th), abs=1e-14)
    times = lookup.times(theta)
    assert np.allclose([lookup.time(th) for th in theta], times, atol=1e-15)
    assert np.allclose(p.state_at_time(times)[0], theta, atol=1e-12)
    closed = ProfileLookup(Profile(np.array([0.0, 0.5, 1.0]), np.array([1.0, 2.0, 1.0])), closed=True)
    assert closed.state(1.25) == pytest.approx(closed.state(0.25), abs=1e-15)


def test_compiled_profile_at_time_equals_the_profile():
    p = trapezoid()
    arrays = ProfileArrays(p.times, p.grid, p.x, p.u)
    for t in np.linspace(-0.1, p.duration + 0.1, 37):
        got = profile_at_time(arrays, t)
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
    th, thd, dev, _, _, ok = monitor_state(table.arrays, q, np.zeros(6), 0.999, table.projection(), *args)
    assert ok and th == pytest.approx(1.05, abs=1e-9) and dev < 1e-12
    # away from the kink the monitor is the plain local projection
    q2 = path(0.5) + 0.01 * np.array([0, 0, 1.0, 0, 0, 0])
    th2, _, dev2, _, _, _ = monitor_state(table.arrays, q2, np.zeros(6), 0.49, table.projection(), *args)
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
    assert abs(s["cycle_time_s"] - profile.duration) <= 0.01 * profile.duration
    assert r.theta[-1] == pytest.approx(2.0, abs=1e-3)


def test_a_smooth_profile_runs_through_the_clock_zones(irb140):
    """A jerk-limited (smooth, u_nodes given) profile: the controller looks its zones up with the profile's own
    state_at_time, which takes arrays (a scalar raised IndexError: circle_smooth, the executable motion,
    could not be simulated). The zone thetas equal the profile's, and a run from rest to rest arrives on time."""
    grid = np.linspace(0.0, 1.0, 41)
    x = 0.6 * np.sin(np.pi * grid)  # theta_dot^2, at rest at both ends
    profile = Profile(grid, x, u_nodes=0.3 * np.pi * np.cos(np.pi * grid))  # u = x' / 2
    assert profile.smooth
    path = SplineJointPath.from_waypoints(WAYPOINTS)
    r = simulate(irb140, path, profile, "orbital", SimulationSettings(design_cache=False))
    s = r.summary()
    assert s["tracking_ok"], s["failure"]
    assert abs(s["cycle_time_s"] - profile.duration) <= 0.01 * profile.duration
    from pathmotion.control import OrbitalController

    design = OrbitalDesign.build(PathTable.from_path(path), profile, OrbitalGains(), 0.004)
    c = OrbitalController(design, irb140, 0.004)
    starts = [z0 for z0, _ in design.zones]
    assert len(starts) == 2
    assert np.allclose(c._zone_theta, [profile.state_at_time(np.array([t]))[0][0] for t in starts], rtol=0, atol=1e-12)


def _stop_after_a_short_move(first_duration: float):
    """The 135 degree joint-space polyline with a stop at the kink: [0, 1] a rest-to-rest trapezoid (acceleration
    500 /s^2) of ``first_duration`` [s], then [1, 2] a slow one (0.4 /s, also 500 /s^2: only the stops are below min_speed). Returns (path, profile)."""
    acc = 500.0  # T = 1/v + v/a, the smaller root
    v = acc * (first_duration - math.sqrt(first_duration**2 - 4.0 / acc)) / 2.0
    ta, tb = v * v / (2 * acc), 0.4**2 / (2 * acc)
    grid = np.array([0.0, ta, 1 - ta, 1.0, 1 + tb, 2 - tb, 2.0])
    profile = Profile(grid, np.array([0.0, v * v, v * v, 0.0, 0.16, 0.16, 0.0]))
    d1 = np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0])
    d2 = np.array([-0.4, 0.4, 0.0, 0.0, 0.0, 0.0]) / np.sqrt(2.0)
    q0 = np.array([0.0, 0.2, -0.3, 0.0, 0.6, 0.0])
    return Polyline(n=6, domain=(0.0, 2.0), kinks=(1.0,), breaks=(1.0,), a=q0, d1=d1, d2=d2), profile


@pytest.mark.parametrize("gap_samples, merged", [(0.225, True), (3.0, False)])
def test_clock_zones_less_than_a_sample_apart_are_one(gap_samples, merged):
    """A short move between two stops whose clock zones (terminal_time_to_go w each side of a stop) leave a gap
    of less than one sample: the sampled design merges the zones (a controller sample cannot fall on the orbit
    there; the few grid points in the gap once gave a design over an empty sample grid). A gap of three samples
    keeps its orbital segment. Expected zones from the profile's own times."""
    ts, w = 0.004, OrbitalGains().terminal_time_to_go
    path, profile = _stop_after_a_short_move(2 * w + gap_samples * ts)
    t_stop = float(profile.times[3])
    assert t_stop - 2 * w == pytest.approx(gap_samples * ts, rel=1e-9)
    design = OrbitalDesign.build(PathTable.from_path(path), profile, OrbitalGains(), ts)
    end = (profile.duration - w, profile.duration)
    want = [(0.0, t_stop + w), end] if merged else [(0.0, w), (t_stop - w, t_stop + w), end]
    assert np.allclose(design.zones, want, rtol=0, atol=1e-9)
    assert np.isfinite(design.gain).all()


@given(st.floats(0.0, 10.0), st.floats(1e-6, 0.1), st.floats(1e-3, 0.01))
def test_sample_grid_covers_any_open_interval(t0, span, ts):
    """Open segments: at least one sample, from t0 to t1, every interval ts but the last, which is within
    (SAMPLE_MERGE ts, (1 + SAMPLE_MERGE) ts] unless it is the only one (then it is the whole span)."""
    t = sample_grid(np.array([t0, t0 + span]), ts, periodic=False)
    steps = np.diff(t)
    assert len(t) >= 2 and t[0] == t0 and t[-1] == t0 + span
    assert np.allclose(steps[:-1], ts, rtol=1e-9)
    if len(steps) == 1:
        assert steps[0] == pytest.approx(span, rel=1e-9) or SAMPLE_MERGE * ts < steps[0] <= (1 + SAMPLE_MERGE) * ts
    else:
        assert SAMPLE_MERGE * ts * (1 - 1e-9) < steps[-1] <= (1 + SAMPLE_MERGE) * ts * (1 + 1e-9)
