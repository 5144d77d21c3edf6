"""Closed-loop simulation of the IRB140: orbital stabilization against the time-indexed baselines.

References: the thesis' accuracy figure (max joint deviation 0.0002 rad for zero end velocities,
thesis-excerpt, Chapter 8), the planned duration, and the physics of the failure cases.
"""

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from pathmotion.control import OrbitalDesign, PathTable
from pathmotion.lift.joint_path import JointPath, SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.planning.trajectory import Trajectory
from pathmotion.robot import Payload
from pathmotion.simulation import FAILURE_REASONS, Realism, SimulationSettings, simulate

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])
THESIS_MAX_DEVIATION = 2e-4  # rad, thesis Chapter 8 (zero end velocities)
CONTROLLERS = ("orbital", "computed_torque", "pd_gravity")


def trapezoid(v=0.9, a=2.0):
    """theta_dot ramps 0 -> v -> 0 at |theta_ddot| = a: x = theta_dot^2 piecewise linear in theta."""
    ta = v * v / (2 * a)
    return Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))


@dataclass(frozen=True, eq=False)
class PeriodicSplinePath(JointPath):
    """Closed joint path: periodic cubic spline through 8 points around ``centre``."""

    spline: CubicSpline | None = None

    @classmethod
    def around(cls, centre, amplitude):
        th = np.linspace(0, 1, 9)
        c, s = np.cos(2 * np.pi * th), np.sin(2 * np.pi * th)
        pts = centre + amplitude * np.stack([c, s, 0.5 * np.sin(4 * np.pi * th), c, s, s], axis=1)
        pts[-1] = pts[0]
        return cls(n=6, domain=(0.0, 1.0), closed=True, spline=CubicSpline(th, pts, bc_type="periodic"))

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        out = (self.spline(th), self.spline(th, 1), self.spline(th, 2))
        return tuple(o[0] for o in out) if scalar else out


@pytest.fixture(scope="module")
def spline():
    return SplineJointPath.from_waypoints(WAYPOINTS)


@pytest.fixture(scope="module")
def profile():
    return trapezoid()


@pytest.fixture(scope="module")
def design(spline, profile):
    return OrbitalDesign.build(PathTable.from_path(spline), profile)


def test_the_inputs_are_feasible(irb140, spline, profile):
    s = Trajectory(spline, profile, irb140).sample(0.002)
    assert np.max(np.abs(s.tau) / irb140.limits.torque) < 1.0
    assert np.max(np.abs(s.qd) / irb140.limits.velocity) < 1.0


def test_orbital_nominal_meets_the_thesis_accuracy(irb140, spline, profile, design):
    r = simulate(irb140, spline, profile, "orbital", design=design)
    s = r.summary()
    assert s["tracking_ok"] and s["failure"] is None
    assert s["max_joint_deviation_rad"] <= THESIS_MAX_DEVIATION
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
    assert s["path_accuracy_m"] < 1e-4
    assert s["saturation_time_s"] == 0.0 and s["max_sharp_deviation_m"] is None
    assert np.all(np.diff(r.theta) >= -1e-9)  # theta never runs backwards
    assert r.theta[-1] == pytest.approx(1.0, abs=1e-3)
    # the deviation is measured from the projection: q_desired = Phi(theta)
    assert np.allclose(r.q_desired, spline(r.theta), atol=1e-12)
    assert np.allclose(r.tcp_desired, r.tcp, atol=1e-3)


def test_baselines_track_the_same_plan(irb140, spline, profile):
    s = simulate(irb140, spline, profile, "computed_torque").summary()
    assert s["tracking_ok"] and s["max_joint_deviation_rad"] < THESIS_MAX_DEVIATION


def test_pd_gravity_is_judged_by_the_tcp_path_tolerance(irb140, spline, profile):
    """The decentralized PD lags by millimetres: outside the default 1 mm path tolerance, with the distance the
    run measured; inside a tolerance above its path accuracy, with a cycle time. (Its tool also turns beyond the
    default orientation tolerance, which fails it earlier: set wide here, the TCP's distance is the subject.)"""
    position_only = SimulationSettings(path_tolerance_deg=180.0)
    s = simulate(irb140, spline, profile, "pd_gravity", position_only).summary()
    assert not s["tracking_ok"] and s["failure"]["reason"] == "path_tolerance", s["failure"]
    assert s["failure"]["value"] == pytest.approx(s["path_accuracy_m"], rel=0.05) and s["path_accuracy_m"] > 1e-3
    assert simulate(irb140, spline, profile, "pd_gravity").summary()["failure"]["reason"] == "orientation_tolerance"
    wide = SimulationSettings(path_tolerance=2 * s["path_accuracy_m"], path_tolerance_deg=180.0)
    s2 = simulate(irb140, spline, profile, "pd_gravity", wide).summary()
    assert s2["tracking_ok"] and s2["path_accuracy_m"] <= wide.path_tolerance
    assert s2["max_joint_deviation_rad"] < 0.05 and s2["cycle_time_s"] is not None


def test_tracking_is_the_same_at_2_4_8_16_ms(irb140, spline, profile, design):
    """theta is one coordinate over the whole path, so no knot (segment change) can be skipped at any
    sample time. Expected degradation: the torque is held for one sample, so the deviation grows with the
    sample time; up to 8 ms it stays within the thesis' 2e-4 rad, at 16 ms within 1e-3 rad; durations within 1 %."""
    devs = {}
    for ts in (0.002, 0.004, 0.008, 0.016):
        r = simulate(irb140, spline, profile, "orbital", SimulationSettings(sample_time=ts), design=design)
        s = r.summary()
        assert s["tracking_ok"], ts
        assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
        knots = np.array([1 / 3, 2 / 3])
        assert np.all(np.diff(r.theta) >= -1e-9)
        assert np.all([np.any(r.theta < k) and np.any(r.theta > k) for k in knots])
        devs[ts] = s["max_joint_deviation_rad"]
    values = [devs[ts] for ts in sorted(devs)]
    assert np.all(np.diff(values) > 0), devs
    assert max(devs[0.002], devs[0.004], devs[0.008]) <= THESIS_MAX_DEVIATION, devs
    assert devs[0.016] <= 1e-3


def test_closed_path_period_and_accuracy(irb140):
    path = PeriodicSplinePath.around(np.array([0.0, 0.3, -0.2, 0.0, 0.6, 0.0]), 0.25)
    profile = Profile(np.linspace(0, 1, 11), np.full(11, 1.2**2))  # theta_dot = 1.2/s: period 0.833 s
    results = {c: simulate(irb140, path, profile, c, SimulationSettings(laps=2)).summary() for c in CONTROLLERS}
    orbital = results["orbital"]
    assert orbital["tracking_ok"]
    assert orbital["planned_duration_s"] == pytest.approx(1 / 1.2)
    assert abs(orbital["cycle_time_s"] - orbital["planned_duration_s"]) <= 0.01 * orbital["planned_duration_s"]
    assert orbital["max_joint_deviation_rad"] <= THESIS_MAX_DEVIATION
    assert orbital["max_joint_deviation_rad"] < 0.1 * results["pd_gravity"]["max_joint_deviation_rad"]


def test_realistic_plant_orbital_beats_pd_gravity(irb140, spline, profile, design):
    """10 % link mass/inertia error, noise, quantization, one-sample delay, friction on axes 1-3, 4 ms; the
    controller knows the rated 6 kg payload (ABB's load data), the plant carries it 0.1 m beyond the flange."""
    robot = irb140.with_payload(Payload(6.0, (0.0, 0.0, 0.1)))
    settings = SimulationSettings(realism=Realism.realistic(seed=1, payload_mass=0.0))
    res = {c: simulate(robot, spline, profile, c, settings).summary() for c in CONTROLLERS}
    assert res["orbital"]["tracking_ok"] and res["computed_torque"]["tracking_ok"]
    assert res["orbital"]["max_joint_deviation_rad"] < res["pd_gravity"]["max_joint_deviation_rad"]
    assert res["orbital"]["max_joint_deviation_rad"] < res["computed_torque"]["max_joint_deviation_rad"]
    assert res["orbital"]["path_accuracy_m"] < res["pd_gravity"]["path_accuracy_m"]


def test_realism_is_deterministic(irb140, spline, profile, design):
    settings = SimulationSettings(realism=Realism(position_noise=1e-5, velocity_noise=1e-3, inertia_error=0.1, seed=5))
    a = simulate(irb140, spline, profile, "orbital", settings, design=design)
    b = simulate(irb140, spline, profile, "orbital", settings, design=design)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.tau, b.tau)
    c = simulate(irb140, spline, profile, "orbital", SimulationSettings(realism=Realism(
        position_noise=1e-5, velocity_noise=1e-3, inertia_error=0.1, seed=6)), design=design)
    assert not np.array_equal(a.q, c.q)


def test_a_profile_far_too_fast_is_a_reported_failure(irb140, spline, profile):
    factor = 1.0
    while np.max(np.abs(Trajectory(spline, profile.scaled(factor), irb140).sample(0.004).tau)
                 / irb140.limits.torque) < 3.0:
        factor += 1.0
    fast = profile.scaled(factor)
    for c in CONTROLLERS:
        r = simulate(irb140, spline, fast, c)
        s = r.summary()
        assert not s["tracking_ok"], c
        assert s["failure"]["reason"] in FAILURE_REASONS
        assert s["cycle_time_s"] is None
        assert s["max_commanded_torque_ratio"] > 1.0 and s["saturation_time_s"] > 0
        assert s["max_torque_ratio"] <= 1.0  # applied: saturated at the limit
        assert 0.0 <= s["failure"]["theta"] <= 1.0 and s["failure"]["t"] <= r.t[-1] + 1e-12


def test_time_budget_ends_the_run(irb140, spline, profile, design):
    s = simulate(irb140, spline, profile, "orbital", SimulationSettings(time_budget_factor=0.5, time_budget_margin=0.0),
                 design=design).summary()
    assert not s["tracking_ok"] and s["failure"]["reason"] == "timeout"
    assert s["failure"]["t"] == pytest.approx(0.5 * profile.duration, abs=0.005)


def test_the_monitor_measures_the_tcp_with_robot_fk(irb140, spline):
    """The loop's monitor computes the TCP frame alone (forwardKinematics + updateFramePlacement) on its own Pinocchio
    data; its distances from the planned TCP path and from its end equal those of robot.fk (every frame), bit for
    bit, at configurations off the path."""
    from pathmotion.robot import fk
    from pathmotion.simulation.closed_loop import _Monitor
    from pathmotion.simulation.metrics import line_window, planned_tcp_line, polyline_distance_local

    table = PathTable.from_path(spline, 401)
    line = planned_tcp_line(irb140, spline, table.grid)
    monitor = _Monitor(table, irb140, line, 0.004)
    rng = np.random.default_rng(2)
    for theta in (0.0, 0.3, 0.77, 1.0):
        q = spline.evaluate(theta)[0] + rng.normal(0.0, 0.02, 6)
        tcp = fk(irb140, q)[0]
        centre = np.array([min(max(int(np.searchsorted(table.grid, theta)) - 1, 0), len(table.grid) - 2)])
        want = polyline_distance_local(tcp[None, :], line, centre, line_window(len(table.grid)), False)[0][0]
        assert monitor.tcp(q, theta) == (float(want), float(np.linalg.norm(tcp - line[-1])))
