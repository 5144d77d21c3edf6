"""MuJoCo as a second plant, checked against Pinocchio and the built-in RK4 plant.

MuJoCo parses the URDF itself (inertials, fixed-joint fusion of the payload links), so these are
checks of two independent model builds, not of one model read twice. Stated bounds (IRB140):

* M(q) (mj_fullM, armature included) and the bias C(q, qd) qd + g(q) (qfrc_bias) against Pinocchio's
  crba and rnea(q, qd, 0), 30 random states, with a payload (off-diagonal inertia, offset com, on a
  flange frame rotated from the last link) and the realism model errors: relative 1e-12.
* Open-loop torque replay, 0.5 s at 4 ms x 2 steps, the same ZOH torque sequence from the same state:
  MuJoCo's RK4 is the same classical scheme at the same step as ours, so the truncation errors are the
  same function of the same dynamics and the states differ by amplified round-off: < 1e-10 rad,
  < 1e-9 rad/s (measured ~1e-15). MuJoCo's implicitfast is first order: its distance to ours falls by
  ~4x when the step falls by 4x (asserted in [3, 5]).
* Coulomb friction: MuJoCo's friction loss is a hard bound F_c (our plant smooths it with tanh(qd/v_c)):
  at |qd| >= 0.1 rad/s, under a torque that balances the bias, MuJoCo's friction force is -F_c sign(qd)
  within 1e-9 N m. (It is a velocity constraint with a reference deceleration |qd| / (0.475 x 2h): a
  commanded deceleration steeper than that is resisted, so the friction can then act along qd.)
"""

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("mujoco")

from pathmotion.errors import RobotModelError, SimulationError  # noqa: E402
from pathmotion.robot import Payload  # noqa: E402
from pathmotion.simulation import Plant, Realism, plant_model  # noqa: E402
from pathmotion.simulation.mujoco_plant import MujocoIntegrator, MujocoPlant, plant_urdf  # noqa: E402

REL_DYNAMICS = 1e-12
REPLAY_Q, REPLAY_QD = 1e-10, 1e-9
TS, SUBSTEPS, REPLAY_SAMPLES = 0.004, 2, 125
Q0 = np.array([0.1, 0.3, -0.2, 0.4, 0.5, 0.1])
QD0 = np.array([0.5, -0.3, 0.2, 1.0, -0.5, 0.8])
PAYLOAD = Payload(mass=2.5, com=(0.02, -0.01, 0.06), inertia=((0.012, 0.002, -0.001), (0.002, 0.02, 0.0005),
                                                               (-0.001, 0.0005, 0.015)))
VISCOUS = (2.0, 2.0, 1.5, 0.4, 0.4, 0.3)
COULOMB = (3.0, 3.0, 2.0, 0.8, 0.8, 0.5)


@pytest.mark.parametrize("realism", [Realism(), Realism(inertia_error=0.1, payload_mass=6.0, seed=4)],
                         ids=["nominal", "model_error"])
def test_mass_matrix_and_bias_match_pinocchio(irb140, realism):
    robot = irb140.with_payload(PAYLOAD)
    mj = MujocoPlant.from_robot(robot, realism)
    model = plant_model(robot, realism)
    data = model.createData()
    assert np.array_equal(mj.model.dof_armature, robot.limits.armature)
    rng = np.random.default_rng(7)
    for _ in range(30):
        q, qd = rng.uniform(-2.5, 2.5, 6), rng.uniform(-3.0, 3.0, 6)
        m_pin = pin.crba(model, data, q)
        m_pin = np.triu(m_pin) + np.triu(m_pin, 1).T
        b_pin = pin.rnea(model, data, q, qd, np.zeros(6))
        assert np.max(np.abs(mj.mass_matrix(q) - m_pin)) <= REL_DYNAMICS * np.max(np.abs(m_pin))
        assert np.max(np.abs(mj.bias(q, qd) - b_pin)) <= REL_DYNAMICS * np.max(np.abs(b_pin))
    # the realism really changed the model (so the comparison above is not of the nominal arm twice)
    if realism.payload_mass:
        nominal = pin.crba(robot.model, robot.data, Q0)
        assert np.max(np.abs(mj.mass_matrix(Q0) - np.triu(nominal) - np.triu(nominal, 1).T)) > 1e-3


def _torques(robot) -> list[np.ndarray]:
    """Gravity compensation at Q0 plus a sine per joint: a fixed open-loop torque sequence (n,) per sample."""
    g0 = pin.rnea(robot.model, robot.data, Q0, np.zeros(6), np.zeros(6))
    amp = np.array([30.0, 30.0, 15.0, 3.0, 3.0, 1.5])
    return [g0 + amp * np.sin(2 * np.pi * 3.0 * k * TS + np.arange(6)) for k in range(REPLAY_SAMPLES)]


def _replay(plant, torques, substeps=SUBSTEPS):
    q, qd = Q0.copy(), QD0.copy()
    for tau in torques:
        q, qd = plant.step(q, qd, tau, TS, substeps)
    return q, qd


@pytest.mark.parametrize("realism", [Realism(), Realism(viscous_friction=VISCOUS)], ids=["frictionless", "viscous"])
def test_open_loop_replay_matches_the_builtin_plant(irb140, realism):
    torques = _torques(irb140)
    q_b, qd_b = _replay(Plant.from_robot(irb140, realism), torques)
    q_m, qd_m = _replay(MujocoPlant.from_robot(irb140, realism), torques)
    assert np.max(np.abs(q_b - Q0)) > 0.3  # the arm moved
    assert np.max(np.abs(q_m - q_b)) < REPLAY_Q
    assert np.max(np.abs(qd_m - qd_b)) < REPLAY_QD


def test_implicitfast_converges_to_the_builtin_plant_at_first_order(irb140):
    torques = _torques(irb140)
    q_b, _ = _replay(Plant.from_robot(irb140), torques, substeps=8)
    plant = MujocoPlant.from_robot(irb140, integrator=MujocoIntegrator.IMPLICITFAST)
    errors = [np.max(np.abs(_replay(plant, torques, substeps=s)[0] - q_b)) for s in (2, 8)]
    assert errors[0] > 1e-5  # a different, first-order integrator, not RK4 again
    assert 3.0 < errors[0] / errors[1] < 5.0


def test_friction_loss_is_a_hard_coulomb_bound(irb140):
    mj = MujocoPlant.from_robot(irb140, Realism(coulomb_friction=COULOMB))
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = rng.uniform(-2, 2, 6)
        qd = rng.choice([-1.0, 1.0], 6) * rng.uniform(0.1, 2.0, 6)
        mj.acceleration(q, qd, mj.bias(q, qd))
        assert np.max(np.abs(mj.data.qfrc_constraint + np.asarray(COULOMB) * np.sign(qd))) < 1e-9


def test_torque_saturates_like_the_builtin_plant(irb140):
    mj, builtin = MujocoPlant.from_robot(irb140), Plant.from_robot(irb140)
    tau = np.array([400.0, -10.0, 130.0, 0.0, -30.0, 5.0])
    (out_m, sat_m), (out_b, sat_b) = mj.saturate(tau), builtin.saturate(tau)
    assert sat_m and sat_b and np.array_equal(out_m, out_b)


def test_geometry_is_stripped_so_missing_meshes_do_not_matter(irb140):
    text = irb140.urdf_text.replace('<link name="link_2">', '<link name="link_2"><visual><geometry><mesh '
                                    'filename="package://nowhere/link_2.stl"/></geometry></visual><collision>'
                                    '<geometry><mesh filename="missing.stl"/></geometry></collision>')
    robot = replace(irb140, urdf_text=text)
    assert "missing.stl" not in plant_urdf(robot)
    MujocoPlant.from_robot(robot).step(Q0, QD0, np.zeros(6), TS, SUBSTEPS)


def test_a_urdf_mujoco_rejects_names_the_element(irb140):
    # link_6's principal moments violate the triangle inequality: Pinocchio accepts them, MuJoCo does not
    bad = irb140.urdf_text.replace('ixx="1e-05" ixy="0" ixz="0" iyy="1e-05"', 'ixx="1" ixy="0" ixz="0" iyy="1e-05"')
    assert bad != irb140.urdf_text
    with pytest.raises(RobotModelError, match="link_6") as info:
        MujocoPlant.from_robot(replace(irb140, urdf_text=bad))
    assert "MuJoCo" in str(info.value) and "\n" not in str(info.value)


def test_missing_mujoco_says_how_to_install(irb140, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ImportError
    with pytest.raises(SimulationError, match=r'pip install "pathmotion\[mujoco\]"') as info:
        MujocoPlant.from_robot(irb140)
    assert "\n" not in str(info.value)


def test_stiff_damping_is_refused_for_rk4(irb140):
    mj = MujocoPlant.from_robot(irb140, Realism(viscous_friction=(0, 0, 0, 0, 0, 500.0)))
    with pytest.raises(SimulationError, match="joint_6"):
        mj.check_step(Q0, TS, 1)
    MujocoPlant.from_robot(irb140, Realism(viscous_friction=(0, 0, 0, 0, 0, 500.0)),
                           integrator="implicitfast").check_step(Q0, TS, 1)


# ------------------------------------------------------------------------------------ the closed loop
def _circle_zero(plant: str, **overrides):
    from pathmotion import api

    setup = api.load(_shipped("circle_zero"), {"simulate.plant": plant, **overrides})
    result = api.plan_scenario(setup)
    return api.simulation_summary(setup, result, api.simulate_scenario(setup, result))


def _shipped(name: str) -> str:
    from importlib import resources

    return str(resources.files("pathmotion.scenarios") / f"{name}.toml")


@pytest.mark.parametrize("overrides", [{}, {"simulate.realism.viscous_friction": 2.0,
                                            "simulate.realism.coulomb_friction": 2.0}], ids=["nominal", "friction"])
def test_closed_loop_on_both_plants_gives_the_same_verdict(overrides):
    """Nominal: the plants agree to round-off, so everything matches. With friction the plants differ
    (MuJoCo's hard friction loss vs our tanh-smoothed Coulomb): same verdict, cycle time within 1 % when
    both track, the same failure within 1 % of the path when both fail, deviations of the same order."""
    builtin, mujoco = _circle_zero("builtin", **overrides), _circle_zero("mujoco", **overrides)
    assert (builtin["plant"], mujoco["plant"]) == ("builtin", "mujoco")
    assert builtin["tracking_ok"] == mujoco["tracking_ok"]
    if builtin["tracking_ok"]:
        a, b = builtin["cycle_time_s"], mujoco["cycle_time_s"]
        assert abs(a - b) <= 0.01 * a
    else:
        fb, fm = builtin["failure"], mujoco["failure"]
        assert fb["reason"] == fm["reason"]
        if fb["reason"] == "path_tolerance":  # where a slow drift grazes the tolerance is not sharp: how far is
            assert abs(fb["value"] - fm["value"]) <= 0.1 * fb["value"]
        else:
            assert abs(fb["theta"] - fm["theta"]) <= 0.01 * 2 * np.pi * 0.1  # 1 % of the circle's length [m]
    ratio = mujoco["max_joint_deviation_rad"] / builtin["max_joint_deviation_rad"]
    assert 0.5 < ratio < 2.0
    if not overrides:
        assert builtin["tracking_ok"]
        assert abs(ratio - 1.0) < 1e-6


def test_an_unknown_plant_is_refused():
    from pathmotion.errors import ScenarioError
    from pathmotion.simulation import SimulationSettings

    with pytest.raises(SimulationError, match="builtin, mujoco"):
        SimulationSettings(plant="ode")
    with pytest.raises(ScenarioError, match="plant"):
        _circle_zero("ode")
