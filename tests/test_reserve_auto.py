"""``[limits] torque_reserve = "auto"``: the bisection against a linear scan, the search on a real
scenario whose closed loop needs a reserve, a search that finds none (a failed result, exit 4), and the
scenario's validation of the key."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from pathmotion import api, defaults
from pathmotion.cli import EXIT_FAILED_RESULT, app
from pathmotion.errors import ScenarioError
from pathmotion.io.scenario import parse_scenario
from pathmotion.planning.limits.torque import check_reserve
from pathmotion.planning.profile import Profile
from pathmotion.robot import load_robot
from pathmotion.api.reserve import ReserveTrial, Verdict, search_reserve
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import simulate

STEP, TOP = defaults.AUTO_RESERVE_STEP, defaults.AUTO_RESERVE_MAX
COUNT = round(TOP / STEP)  # grid indices 0 .. COUNT
#: Unmodelled Coulomb friction in the plant, as a share of each joint's torque limit [-].
FRICTION = 0.05
#: circle_zero on torque alone (acceleration estimates off), on a plant with FRICTION x tau_max of unmodelled
#: Coulomb friction per joint: a plan with reserve r leaves r x tau_max for feedback, so by physics every
#: reserve < FRICTION leaves less torque than the friction takes (the command saturates while the plan runs at
#: its torque limit) and fails; from FRICTION on (tanh(qd / v_c) F_c < F_c: a sliver beyond the friction at
#: exactly FRICTION) a controller that knows the friction can track. The orbital controller identifies the
#: friction online (pathmotion/control/payload.py) and tracks from 0.05; with the observer alone it needed 0.075.
TORQUE_ONLY = {"limits.use_acceleration": False, "limits.torque_reserve": "auto",
               "simulate.realism.coulomb_friction": [float(v) for v in FRICTION * load_robot("irb140").limits.torque]}


# ----------------------------------------------------------------------------- the bisection
def _model(first_tracking: int, first_infeasible: int):
    """A monotone closed loop on the grid indices: fails below ``first_tracking``, tracks from it, cannot be
    planned from ``first_infeasible`` on; returns (run, the list of reserves it was called with)."""
    calls = []

    def run(reserve):
        calls.append(reserve)
        k = round(reserve / STEP)
        assert abs(k * STEP - reserve) < 1e-12  # only grid reserves are tried
        if k >= first_infeasible and k > 0:
            return ReserveTrial(reserve, Verdict.INFEASIBLE, "gravity")
        return ReserveTrial(reserve, Verdict.TRACKS if k >= first_tracking else Verdict.FAILS,
                            "" if k >= first_tracking else "tracking failed", 1.0 + reserve, 1.1, 1e-3)
    return run, calls


@pytest.mark.parametrize("first_infeasible", [COUNT + 1, 12, 3, 1])
def test_bisection_finds_what_a_linear_scan_finds(first_infeasible):
    bound = 1 + int(np.ceil(np.log2(COUNT + 1)))
    for first_tracking in range(COUNT + 2):  # COUNT + 1: no reserve tracks
        run, calls = _model(first_tracking, first_infeasible)
        search = search_reserve(run, TOP, STEP)
        scan = [k for k in range(COUNT + 1) if k >= first_tracking and (k < first_infeasible or k == 0)]
        expected = scan[0] * STEP if scan else None
        assert search.chosen == pytest.approx(expected) if scan else search.chosen is None
        assert len(calls) == len(set(calls)) <= bound
        assert [t.reserve for t in search.trials] == calls
        if scan:
            assert search.failure() is None and search.applied == search.chosen
        else:  # the largest reserve that could be planned, named in the failure
            largest = max(k for k in range(COUNT + 1) if k < first_infeasible or k == 0)
            tried = max(round(r / STEP) for r, t in zip(calls, search.trials) if t.verdict != Verdict.INFEASIBLE)
            assert tried == largest
            assert search.applied == pytest.approx(largest * STEP)
            assert f"the largest tried, {largest * STEP:g}, failed" in search.failure()


def test_a_bad_search_range_is_refused():
    with pytest.raises(ValueError, match="step"):
        search_reserve(lambda r: None, top=0.5, step=0.025)


# ------------------------------------------------------------------------- a real closed loop
@pytest.fixture(scope="module")
def auto():
    return api.search(api.load(scenario_path("circle_zero"), TORQUE_ONLY))


def test_auto_picks_the_smallest_reserve_that_tracks(auto):
    search = auto.reserve_search
    chosen = search.chosen
    assert chosen is not None and chosen >= FRICTION  # below the friction's share no torque is left for feedback
    by_reserve = {t.reserve: t for t in search.trials}
    assert by_reserve[0.0].verdict == Verdict.FAILS and "saturated" in by_reserve[0.0].reason
    low = [t for t in search.trials if t.reserve < FRICTION - 1e-12]
    assert low and all(t.verdict == Verdict.FAILS and "saturated" in t.reason for t in low)
    # the reserve one step below the chosen one was tried and failed (or is 0, which failed)
    assert by_reserve[round(chosen - STEP, 12)].verdict == Verdict.FAILS or chosen == STEP
    result = api.plan_scenario(auto)
    assert result.ratios.summary()["torque_reserve"] == chosen
    assert result.duration == pytest.approx(by_reserve[chosen].planned_duration_s)
    # the chosen plan, simulated afresh (not the search's run), tracks with the same figures
    sim = simulate(auto.robot, auto.path, result.profile, "orbital", api.simulation_settings(auto))
    assert sim.tracking_ok
    assert sim.path_accuracy() == pytest.approx(by_reserve[chosen].path_accuracy_m, rel=1e-9)
    assert api.simulate_scenario(auto, result).tracking_ok


def test_auto_is_reported_in_the_summaries_and_by_check(auto):
    result = api.plan_scenario(auto)
    summary = api.plan_summary(auto, result)
    assert summary["torque_reserve"] == auto.reserve_search.chosen
    records = summary["torque_reserve_search"]
    assert [r["torque_reserve"] for r in records] == [t.reserve for t in auto.reserve_search.trials]
    assert {r["verdict"] for r in records} <= {"tracks", "fails", "infeasible"}
    json.dumps(summary)
    sim_summary = api.simulation_summary(auto, result, api.simulate_scenario(auto, result))
    assert sim_summary["torque_reserve"] == auto.reserve_search.chosen
    assert api.plan_failures(result, auto) == []
    assert api.check_scenario(auto)["torque_reserve"] == auto.reserve_search.chosen


def test_no_reserve_tracks_is_a_failed_result(tmp_path):
    """An unmodelled 6 kg payload, and a controller that does not identify it (the observer alone), sags the TCP
    beyond 1 mm in the first 30 ms, before the plan moves: no reserve helps, every run fails; plan writes its files
    and exits 4 naming the largest reserve tried."""
    out = tmp_path / "out"
    sets = ["limits.use_acceleration=false", "limits.torque_reserve=auto", "plan.grid_points=100",
            "simulate.realism.payload_mass=6", "simulate.realism.payload_com=[0, 0, 0.1]",
            "simulate.identify_payload=false"]
    args = ["plan", str(scenario_path("circle_zero")), "--out", str(out), "--no-figures"]
    for s in sets:
        args += ["--set", s]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == EXIT_FAILED_RESULT, result.output
    text = " ".join(result.output.split())
    assert f"no reserve in [0, {TOP:g}]" in text and f"the largest tried, {TOP:g}, failed" in text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["torque_reserve"] == TOP
    assert {r["verdict"] for r in summary["torque_reserve_search"]} == {"fails"}
    assert [f["where"] for f in summary["failures"] if f["kind"] == "no_reserve"] == ["limits.torque_reserve"]


# --------------------------------------------------------------------------------- validation
@pytest.mark.parametrize("value", [0.5, 0.7, -0.1, float("nan"), float("inf"), "automatic", "Auto", True, [0.1]])
def test_bad_reserves_are_refused_with_what_is_allowed(value):
    text = scenario_path("circle_zero").read_text()
    with pytest.raises(ScenarioError, match=r"limits\.torque_reserve.*\[0, 0\.5\).*or \"auto\""):
        parse_scenario(text, "c.toml", {"limits.torque_reserve": value})


@pytest.mark.parametrize("value", ["auto", 0.0, 0.2, 0.49])
def test_good_reserves_are_taken(value):
    text = scenario_path("circle_zero").read_text()
    assert parse_scenario(text, "c.toml", {"limits.torque_reserve": value}).limits.torque_reserve == value


def test_the_planner_itself_refuses_auto():
    with pytest.raises(ScenarioError, match="auto"):
        check_reserve("auto")


def test_a_smooth_profile_takes_a_scalar_time():
    """Constant speed 2 rad/s as a smooth (third-order) profile: theta(t) = 2 t, scalar or array."""
    prof = Profile(np.array([0.0, 0.5, 1.0]), np.full(3, 4.0), np.zeros(3))
    theta, theta_dot, theta_ddot, jerk = prof.state3_at_time(0.3)
    assert np.shape(theta) == () and float(theta) == pytest.approx(0.6) and float(theta_dot) == pytest.approx(2.0)
    array = prof.state3_at_time(np.array([0.1, 0.3]))
    assert array[0] == pytest.approx([0.2, 0.6]) and array[1] == pytest.approx([2.0, 2.0])


def test_the_realistic_plant_is_expressible_as_scenario_keys():
    """docs/control.md's realistic plant (per-joint friction) as [simulate.realism], the closed loop "auto"
    searches in: the same Realism as Realism.realistic(seed=0); a negative joint's friction is refused."""
    from pathmotion.simulation import Realism

    keys = {"inertia_error": defaults.REALISTIC_INERTIA_ERROR, "payload_mass": defaults.REALISTIC_PAYLOAD_MASS,
            "payload_com": list(defaults.REALISTIC_PAYLOAD_COM),
            "viscous_friction": list(defaults.REALISTIC_VISCOUS_FRICTION),
            "coulomb_friction": list(defaults.REALISTIC_COULOMB_FRICTION),
            "encoder_resolution": defaults.REALISTIC_ENCODER_RESOLUTION,
            "position_noise": defaults.REALISTIC_POSITION_NOISE, "velocity_noise": defaults.REALISTIC_VELOCITY_NOISE,
            "delay": True, "seed": 0}
    setup = api.load(scenario_path("circle_zero"), {f"simulate.realism.{k}": v for k, v in keys.items()})
    assert api.simulation_settings(setup).realism == Realism.realistic(seed=0)
    text = scenario_path("circle_zero").read_text()
    with pytest.raises(ScenarioError, match=r"simulate\.realism\.coulomb_friction\[1\]"):
        parse_scenario(text, "c.toml", {"simulate.realism.coulomb_friction": [1.0, -1.0, 1, 1, 1, 1]})
