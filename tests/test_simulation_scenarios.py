"""Closed loop on the shipped thesis scenarios, loaded as a user would (api.load(scenario_path(...))).

References: the planned duration (the plan itself; the robot on the orbit takes the planned time), the
thesis' accuracy figure (max joint deviation 0.0002 rad, Chapter 8) and its findings for the corner
cases (Chapter 7: a velocity jump at a sharp corner makes tracking fail; stopping there succeeds; a
tangent connection at boundary-level velocity succeeds).
"""

import dataclasses

import numpy as np
import pytest

from pathmotion import api
from pathmotion.planning import plan
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import Realism, SimulationSettings, simulate

THESIS_MAX_DEVIATION = 2e-4  # rad (thesis, Chapter 8)
#: The thesis' figures hold at the thesis' pace: the limits file's accelerations scaled to a tenth make circle_zero
#: plan 1.38 s (the thesis: 1.559 s); at the file's own (torque-derived) accelerations it takes 0.51 s.
THESIS_PACE = {"limits.acceleration_scale": 0.1}


def planned(name, overrides=None):
    """The scenario's own plan (its settings, ``overrides`` applied), without the comparison baselines the test
    does not use."""
    setup = api.load(scenario_path(name), overrides)
    return setup, plan(setup.path, setup.robot, dataclasses.replace(setup.plan_settings, baselines=False))


@pytest.fixture(scope="module")
def circle_zero():
    return planned("circle_zero")


@pytest.fixture(scope="module")
def thesis_circle():
    return planned("circle_zero", THESIS_PACE)


@pytest.mark.parametrize("controller", ["orbital", "computed_torque"])
def test_full_circle_from_rest_to_rest_takes_the_planned_time(thesis_circle, controller):
    """Regression: start configuration == end configuration. The arrival test must not fire at t = 0."""
    setup, result = thesis_circle
    assert not setup.path.closed
    lo, hi = setup.path.domain
    assert np.allclose(setup.path.evaluate(lo)[0], setup.path.evaluate(hi, side="left")[0], atol=1e-9)
    r = simulate(setup.robot, setup.path, result.profile, controller, api.simulation_settings(setup))
    s = r.summary()
    assert s["tracking_ok"]
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
    assert r.theta[-1] == pytest.approx(hi, abs=1e-3 * (hi - lo))  # it went around
    assert s["max_joint_deviation_rad"] <= THESIS_MAX_DEVIATION


def test_circle_with_boundary_level_end_velocities():
    """The plan ends moving: the run ends when the robot crosses the end of the path, at the planned time."""
    setup, result = planned("circle_max", THESIS_PACE)
    assert result.profile.x[0] > 0 and result.profile.x[-1] > 0
    r = simulate(setup.robot, setup.path, result.profile, "orbital", api.simulation_settings(setup))
    s = r.summary()
    assert s["tracking_ok"]
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
    assert s["max_joint_deviation_rad"] <= THESIS_MAX_DEVIATION
    assert r.theta[-1] <= setup.path.domain[1] and r.t[-1] <= s["cycle_time_s"]


@pytest.mark.parametrize("controller", ["orbital", "computed_torque"])
def test_a_too_fast_corner_fails_with_its_distance(controller):
    """corner_max drives a 90 degree corner at boundary-level speed (a velocity jump): both model-based
    controllers throw the TCP millimetres off the path with torque commands above the limit. The verdict is a
    path-tolerance failure near the corner, stating the largest distance, which is the run's path accuracy.
    (PD + gravity already leaves the 1 mm tolerance on the way to the corner: see the next test.)"""
    setup, result = planned("corner_max")
    s = simulate(setup.robot, setup.path, result.profile, controller, api.simulation_settings(setup)).summary()
    f = s["failure"]
    assert not s["tracking_ok"] and f["reason"] == "path_tolerance" and s["cycle_time_s"] is None
    corner = setup.path.kinks[0]
    assert abs(f["theta"] - corner) < 0.05 * (setup.path.domain[1] - setup.path.domain[0])
    assert f["value"] > 5 * f["limit"] and f["limit"] == s["path_tolerance_m"] == 1e-3
    assert f["value"] == pytest.approx(s["path_accuracy_m"], rel=0.02)
    assert f"{f['value'] * 1e3:.4g} mm" in f["message"]
    # one corner; the distance from the sharp path (its nearest point anywhere, here often the other leg) is
    # at most the distance from the planned path at the current theta
    (corner_deviation,) = s["cornering_deviation_m"]
    assert f["limit"] < corner_deviation <= s["path_accuracy_m"] * (1 + 1e-9)
    assert s["max_commanded_torque_ratio"] > 1.0 >= s["max_torque_ratio"]


def test_pd_gravity_leaves_the_tolerance_first_where_it_first_lags():
    setup, result = planned("corner_max")
    r = simulate(setup.robot, setup.path, result.profile, "pd_gravity", api.simulation_settings(setup))
    f = r.summary()["failure"]
    assert f["reason"] == "path_tolerance" and f["theta"] < setup.path.kinks[0]
    k = int(np.argmax(r.path_deviation > 1e-3))  # the first sample outside, measured after the run
    assert f["t"] == pytest.approx(r.t[k], abs=1.5 * r.sample_time)
    assert f["value"] == pytest.approx(np.max(r.path_deviation), rel=0.02)


def test_a_stop_at_the_corner_succeeds():
    setup, result = planned("corner_stop")
    s = simulate(setup.robot, setup.path, result.profile, "orbital", api.simulation_settings(setup)).summary()
    assert s["tracking_ok"] and s["path_accuracy_m"] < 1e-3
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
    assert s["settle_time_s"] >= s["cycle_time_s"]
    assert s["max_joint_deviation_rad"] <= 1.5 * THESIS_MAX_DEVIATION


def test_computed_torque_with_an_unmodelled_payload_reports_its_cycle_time():
    """A 6 kg payload the controller does not know: computed torque sags millimetres off the path and never
    comes within 1e-3 rad of the final configuration (the old arrival window: a 'timeout'); within a 10 mm
    path tolerance (and 5 deg: the sag turns the tool too) it tracks, and its cycle time is when the TCP reached
    the end within that tolerance (at the thesis' pace: at the file's accelerations computed torque leaves the
    joint tolerance with 6 kg it does not know)."""
    setup, result = planned("circle_zero", THESIS_PACE)
    settings = SimulationSettings(realism=Realism(payload_mass=6.0), path_tolerance=0.01, path_tolerance_deg=5.0)
    r = simulate(setup.robot, setup.path, result.profile, "computed_torque", settings)
    s = r.summary()
    assert s["tracking_ok"], s["failure"]
    assert 1e-3 < s["path_accuracy_m"] < 0.01
    q_end = setup.path.evaluate(setup.path.domain[1], side="left")[0]
    assert np.max(np.abs(r.q[-1] - q_end)) > 1e-3  # outside the old joint window at the end of the run
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.02 * s["planned_duration_s"]


def test_tangent_connection_at_boundary_level_velocity_succeeds():
    """circle_vertical: the planner lets theta_dot jump at the (tangent, curvature-discontinuous) connection,
    a joint-velocity step dv; a critically damped loop of bandwidth w lags by at most dv / (w e)."""
    setup, result = planned("circle_vertical")
    s = simulate(setup.robot, setup.path, result.profile, "orbital", api.simulation_settings(setup)).summary()
    assert s["tracking_ok"]
    assert abs(s["cycle_time_s"] - s["planned_duration_s"]) <= 0.01 * s["planned_duration_s"]
    p, b = result.profile, setup.path.breaks[0]
    i = int(np.argmin(np.abs(p.grid - b)))
    jump = np.sqrt(p.x[i + 2]) - np.sqrt(p.x[i - 2])
    dv = np.max(np.abs(setup.path.evaluate(b)[1])) * abs(jump)
    w = SimulationSettings().orbital_gains.bandwidth
    assert s["max_joint_deviation_rad"] <= 1.2 * dv / (w * np.e) + THESIS_MAX_DEVIATION


def test_the_thesis_max_connection_fails_its_plan_and_the_chain_variant_runs():
    """circle_vertical (the thesis' 'max' connection) reports the speed jump as a plan failure and says so in its
    description; circle_vertical_chain, the same path with a continuous speed, plans within every limit (its
    acceleration ratio is bounded, not the jump's unbounded one) and tracks."""
    setup, result = planned("circle_vertical")
    failures = api.plan_failures(result, setup)
    assert any("path speed jumps" in f.message for f in failures)
    assert "fails on purpose" in setup.scenario.description and "circle_vertical_chain" in setup.scenario.description
    chain_setup, chain = planned("circle_vertical_chain")
    assert api.plan_failures(chain, chain_setup) == [] and chain.ratios.within()
    assert chain_setup.path.length == pytest.approx(setup.path.length)
    assert chain.profile.duration >= result.profile.duration  # the jump is the faster, unrunnable motion
    s = simulate(chain_setup.robot, chain_setup.path, chain.profile, "orbital",
                 api.simulation_settings(chain_setup)).summary()
    assert s["tracking_ok"], s["failure"]


def test_realistic_plant_orbital_beats_both_baselines_on_tcp_deviation():
    """The issue's conditions on the thesis' horizontal circle (periodic plan, one lap): 10 % link mass and
    inertia error, a 6 kg payload the controllers do not know, 4 ms sampling with a one-sample delay, encoder
    quantization, position and velocity noise, joint friction. The orbital controller, with its integral action,
    disturbance observer and payload identification, tracks and deviates least from the TCP path (measured with the
    default reserve: 0.84 mm and 0.38 deg; the period planned 0.451 s). The baselines do not track at this pace
    (computed torque saturates 6.0 mm off, PD + gravity 14.9 mm off; a failed run's accuracy is its failure value,
    a lower bound of its deviation), so they deviate at least twice as much."""
    setup, result = planned("circle_periodic")
    realism = Realism.realistic(seed=0)
    assert realism.inertia_error == 0.1 and realism.payload_mass == 6.0 and realism.delay
    assert realism.position_noise > 0 and realism.velocity_noise > 0 and realism.encoder_resolution > 0
    settings = SimulationSettings(realism=realism, laps=1, path_tolerance=0.01, path_tolerance_deg=2.0)
    assert settings.sample_time == 0.004
    res = {c: simulate(setup.robot, setup.path, result.profile, c, settings).summary()
           for c in ("orbital", "computed_torque", "pd_gravity")}
    orbital = res["orbital"]
    assert orbital["tracking_ok"], res
    for c in ("computed_torque", "pd_gravity"):
        assert orbital["path_accuracy_m"] < 0.5 * res[c]["path_accuracy_m"], (c, res)
        assert orbital["path_accuracy_deg"] < 0.5 * res[c]["path_accuracy_deg"], (c, res)
    # the orbit, not the clock, is stabilized; the speed integral keeps the period close to the plan
    assert abs(orbital["cycle_time_s"] - orbital["planned_duration_s"]) <= 0.04 * orbital["planned_duration_s"]


@pytest.mark.parametrize("sampled", [True, False], ids=["sampled", "continuous"])
def test_strong_friction_does_not_stall_the_orbital_controller_before_the_end(circle_zero, sampled):
    """With 2 N m s/rad + 2 N m friction on every joint the orbital controller stopped at 95 % of the
    circle (timeout) while the baselines finished: the Riccati solution ended at zero on I and int I, so the
    speed feedback faded out over the last 1/speed_rate of the orbital segment, and the robot, slowed by
    friction and facing the plan's deceleration as feedforward, stopped short of the clock play that takes
    over near the end. With the stationary solution as the end condition it arrives (sampled design: cycle
    1.153 s against 1.088 s planned, path accuracy 1.7 mm before the disturbance observer, which takes the
    friction up: now 1.088 s and 0.10 mm; a 5 mm tolerance lets the run measure the arrival either way; with
    the old end condition both designs time out here)."""
    setup, result = circle_zero
    realism = Realism(viscous_friction=2.0, coulomb_friction=2.0)
    settings = dataclasses.replace(api.simulation_settings(setup), realism=realism, path_tolerance=0.005,
                                   sampled_design=sampled)
    s = simulate(setup.robot, setup.path, result.profile, "orbital", settings).summary()
    assert s["tracking_ok"], s["failure"]
    assert s["cycle_time_s"] <= 1.1 * s["planned_duration_s"]
