"""The plant's sub-step count: a friction too stiff for RK4 at ``simulate.substeps`` raises the count to the
one the plant needs (h lambda <= 1, lambda = friction damping / joint inertia, computed here from Pinocchio's
mass matrix), and the summary says so; beyond defaults.MAX_PLANT_SUBSTEPS the error names scenario keys."""

import numpy as np
import pinocchio as pin
import pytest

import pathmotion as pm
from pathmotion import defaults
from pathmotion.errors import SimulationError
from pathmotion.simulation import Plant, Realism
from pathmotion.simulation.closed_loop import plant_substeps

from reliability_cases import JOINT

Q0 = np.array([0.3, 0.2, -0.4, 0.5, 0.7, -0.2])


def test_the_count_is_the_fewest_with_h_lambda_at_most_one(irb140):
    plant = Plant.from_robot(irb140, Realism(viscous_friction=30.0))
    model = plant.model
    inertia = np.diag(pin.crba(model, model.createData(), Q0))
    lam = np.max(30.0 / inertia)
    for ts in (0.004, 0.012, 0.02):
        need, why = plant.substeps_needed(Q0, ts)
        assert ts / need * lam <= 1.0 < ts / max(need - 1, 1e-300) * lam or need == 1
        assert "joint_6" in why
        plant.check_step(Q0, ts, need)
        if need > 1:
            with pytest.raises(SimulationError, match="simulate.substeps") as info:
                plant.check_step(Q0, ts, need - 1)
            assert "Realism" not in str(info.value) and "simulate.realism.viscous_friction" in str(info.value)
    assert plant_substeps(plant, Q0, 0.012, 2)[0] == plant.substeps_needed(Q0, 0.012)[0] > 2
    assert plant_substeps(plant, Q0, 0.012, 50) == (50, "")  # more than needed: kept, no note
    with pytest.raises(SimulationError, match="lower simulate.sample_time"):
        plant_substeps(Plant.from_robot(irb140, Realism(viscous_friction=1e7)), Q0, 0.012, 2)
    assert plant.substeps_needed(Q0, 0.012)[0] <= defaults.MAX_PLANT_SUBSTEPS


def test_simulate_at_12_ms_with_viscous_friction_raises_the_count_and_says_so(tmp_path):
    text = JOINT + "[simulate]\nsample_time = 0.012\n[simulate.realism]\nviscous_friction = 30.0\n"
    setup = pm.load_text(text, tmp_path)
    result = pm.plan_scenario(setup)
    summary = pm.simulate_scenario(setup, result).summary()
    assert summary["substeps"] > defaults.PLANT_SUBSTEPS
    assert summary["substeps_note"].startswith(f"simulate.substeps {defaults.PLANT_SUBSTEPS} raised to "
                                               f"{summary['substeps']}")
    plain = pm.simulate_scenario(pm.load_text(JOINT, tmp_path), pm.plan_scenario(pm.load_text(JOINT, tmp_path)))
    assert plain.summary()["substeps"] == defaults.PLANT_SUBSTEPS and plain.summary()["substeps_note"] is None
