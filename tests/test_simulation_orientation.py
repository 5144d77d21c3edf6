"""ISO 9283's orientation path accuracy (ATo): ``path_accuracy_deg``, the largest angle between the tool's
orientation and the planned one on the path, reported for every controller and judged against
``simulate.path_tolerance_deg`` (defaults.PATH_TOLERANCE_DEG) in the verdict."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from pathmotion import api, defaults
from pathmotion.robot import fk, load_robot
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import Realism, SimulationSettings, simulate
from pathmotion.simulation.metrics import orientation_deviation

IRB140 = load_robot("irb140")


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1.5, 1.5), min_size=6, max_size=6), st.lists(st.floats(-1.5, 1.5), min_size=6, max_size=6),
       st.floats(1e-9, 1.0))
def test_the_angle_is_the_relative_rotations_magnitude(q, q2, scale):
    q, q_d = np.array([q]), np.array(q) + scale * (np.array([q2]) - np.array(q))
    r, r_d = fk(IRB140, q)[1][0], fk(IRB140, q_d)[1][0]
    expected = Rotation.from_matrix(r_d.T @ r).magnitude()  # scipy, independent of the formula
    assert orientation_deviation(IRB140, q, q_d)[0] == pytest.approx(expected, abs=1e-9)


def test_every_controller_reports_it_and_the_verdict_judges_it():
    setup = api.load(scenario_path("circle_periodic"))
    result = api.plan_scenario(setup)
    loose = SimulationSettings(realism=Realism.realistic(seed=0), laps=1, path_tolerance=0.01)
    assert loose.path_tolerance_deg == defaults.PATH_TOLERANCE_DEG == setup.scenario.simulate.path_tolerance_deg
    runs = {c: simulate(setup.robot, setup.path, result.profile, c, loose) for c in ("orbital", "computed_torque")}
    orbital, computed = runs["orbital"].summary(), runs["computed_torque"].summary()
    assert orbital["tracking_ok"] and orbital["path_accuracy_deg"] < defaults.PATH_TOLERANCE_DEG
    # computed torque keeps the TCP within 10 mm but turns the tool beyond the tolerance: the verdict fails it
    assert computed["path_accuracy_m"] < 0.01 and not computed["tracking_ok"]
    assert computed["failure"]["reason"] == "orientation_tolerance" and computed["cycle_time_s"] is None
    assert computed["failure"]["value"] == pytest.approx(computed["path_accuracy_deg"], rel=1e-12)
    assert computed["failure"]["limit"] == defaults.PATH_TOLERANCE_DEG and computed["failure"]["unit"] == "deg"
    # the figure itself: the largest tool angle from the planned orientation at the projection (scipy)
    sim = runs["computed_torque"]
    angles = [Rotation.from_matrix(rd.T @ r).magnitude() for r, rd in
              zip(fk(setup.robot, sim.q)[1], fk(setup.robot, sim.q_desired)[1])]
    assert computed["path_accuracy_deg"] == pytest.approx(np.degrees(max(angles)), rel=1e-6)
