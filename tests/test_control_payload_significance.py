"""The identified payload is reported only when significant: a run with no payload (10 % link inertia error, the
model's mass error mapped onto the flange body) reports no mass and says what its figure is; a 6 kg payload the
model lacks is reported. The standard error is the filter's own, sqrt(P[0, 0])."""

import pytest

from pathmotion import api, defaults
from pathmotion.scenarios import scenario_path


def _summary(overrides: dict) -> tuple[dict, dict]:
    setup = api.load(scenario_path("circle_zero"), overrides)
    sim = api.simulate_scenario(setup, api.plan_scenario(setup))
    return sim.summary(), sim.identified


def test_no_payload_is_reported_without_one_and_a_payload_with_one():
    s, raw = _summary({"simulate.realism.inertia_error": 0.1, "simulate.realism.seed": 1})
    assert raw["mass_kg"] != 0.0 and abs(raw["mass_kg"]) < defaults.IDENTIFIED_SIGNIFICANCE * raw["mass_std_kg"]
    assert s["identified_payload_kg"] is None and s["identified_payload_com_m"] is None
    assert s["identified_payload_std_kg"] == pytest.approx(raw["mass_std_kg"])
    assert "no payload identified" in s["identified_payload_note"]
    # the identification converges over the motion: at a tenth of the file's accelerations (circle_zero in 1.38 s);
    # in the file's 0.51 s it reaches 4.95 of the 6 kg
    s, raw = _summary({"simulate.realism.payload_mass": defaults.REALISTIC_PAYLOAD_MASS, "limits.acceleration_scale": 0.1})
    assert s["identified_payload_kg"] == pytest.approx(defaults.REALISTIC_PAYLOAD_MASS, rel=0.05)
    assert s["identified_payload_note"] is None
    assert abs(s["identified_payload_kg"]) >= defaults.IDENTIFIED_SIGNIFICANCE * s["identified_payload_std_kg"]
