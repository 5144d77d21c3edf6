"""The plant: RK4 with sub-steps against a tight solve_ivp reference, energy conservation, model
perturbation and sensor realism.

Stated bounds (IRB140, 4 ms samples x 4 RK4 sub-steps = 1 ms step, 1 s):
* constant torque, gravity on: max |q - q_ref| < 1e-8 rad, |qd - qd_ref| < 1e-7 rad/s;
* torque-free, gravity-free: relative drift of the kinetic energy < 1e-8.
"""

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from pathmotion.errors import SimulationError
from pathmotion.robot import Payload, kinetic_energy, mass_matrix
from pathmotion.simulation import Plant, Realism, Sensor, plant_model

Q0 = np.array([0.3, 0.2, -0.4, 0.5, 0.7, -0.2])
QD0 = np.array([0.8, -0.5, 0.6, 1.5, -1.0, 2.0])


def run_plant(plant, q, qd, tau, seconds, dt=0.004, substeps=4):
    for _ in range(int(round(seconds / dt))):
        q, qd = plant.step(q, qd, tau, dt, substeps)
    return q, qd


def reference(plant, q, qd, tau, seconds):
    n = len(q)

    def rhs(_, x):
        return np.concatenate([x[n:], plant.acceleration(x[:n], x[n:], tau)])

    sol = solve_ivp(rhs, (0, seconds), np.concatenate([q, qd]), method="DOP853", rtol=1e-10, atol=1e-12)
    return sol.y[:n, -1], sol.y[n:, -1]


def test_rk4_substeps_match_a_tight_reference_with_constant_torque(irb140):
    plant = Plant.from_robot(irb140)
    # gravity at Q0 plus M(Q0) times a moderate acceleration: the joints move by up to 5 rad in 1 s
    tau = pin.rnea(irb140.model, irb140.data, Q0, np.zeros(6), np.array([1.0, -1.0, 1.5, 2.0, -2.0, 3.0]))
    q, qd = run_plant(plant, Q0, QD0, tau, 1.0)
    q_ref, qd_ref = reference(plant, Q0, QD0, tau, 1.0)
    assert np.max(np.abs(q_ref - Q0)) > 0.5
    assert np.max(np.abs(q - q_ref)) < 1e-8
    assert np.max(np.abs(qd - qd_ref)) < 1e-7
    # and it is a real integration: one 4 ms Euler-like step per sample would be far off
    q1, _ = run_plant(plant, Q0, QD0, tau, 1.0, substeps=1, dt=0.04)
    assert np.max(np.abs(q1 - q_ref)) > 1e-6


def test_energy_is_conserved_without_torque_and_gravity(irb140):
    robot = replace(irb140, gravity=(0.0, 0.0, 0.0))
    plant = Plant.from_robot(robot)
    e0 = kinetic_energy(robot, Q0, QD0)
    q, qd = run_plant(plant, Q0, QD0, np.zeros(6), 1.0)
    assert abs(kinetic_energy(robot, q, qd) - e0) < 1e-8 * e0
    assert np.max(np.abs(q - Q0)) > 0.1  # it moved


def test_friction_dissipates_and_saturation_clips(irb140):
    robot = replace(irb140, gravity=(0.0, 0.0, 0.0))
    plant = Plant.from_robot(robot, Realism(viscous_friction=(2, 2, 1.5, 0, 0, 0), coulomb_friction=(3, 3, 2, 0, 0, 0)))
    e0 = kinetic_energy(robot, Q0, QD0)
    q, qd = run_plant(plant, Q0, QD0, np.zeros(6), 0.2)
    assert kinetic_energy(robot, q, qd) < e0
    tau, sat = plant.saturate(np.array([1000.0, 0, 0, 0, 0, -1000.0]))
    assert sat and tau[0] == irb140.limits.torque[0] and tau[-1] == -irb140.limits.torque[-1]
    assert plant.saturate(np.zeros(6))[1] is False


def test_stiff_friction_is_refused_with_a_fix(irb140):
    # 5 N m / 0.01 rad/s on joint 6's ~0.1 kg m^2 (mostly armature) decays in 0.2 ms < the 1 ms RK4 step
    plant = Plant.from_robot(irb140, Realism(coulomb_friction=5.0, coulomb_smoothing=0.01))
    with pytest.raises(SimulationError, match="joint_6.*substeps"):
        plant.check_step(Q0, 0.004, 4)


def test_plant_model_scales_links_and_adds_the_payload(irb140):
    realism = Realism(inertia_error=0.1, payload_mass=6.0, seed=4)
    model = plant_model(irb140, realism)
    scales = realism.link_scales(6)
    assert set(np.round(scales, 12)) <= {0.9, 1.1}
    nominal = [irb140.model.inertias[j].mass for j in range(1, 7)]
    masses = [model.inertias[j].mass for j in range(1, 7)]
    expected = np.array(nominal) * scales
    expected[-1] += 6.0
    assert np.allclose(masses, expected)
    # the same payload built as the robot's own payload gives the same model when nothing is scaled
    own = irb140.with_payload(Payload(6.0, (0.0, 0.0, 0.1)))
    unscaled = plant_model(irb140, Realism(payload_mass=6.0, payload_com=(0.0, 0.0, 0.1), payload_inertia=(0, 0, 0)))
    m_plant = pin.crba(unscaled, unscaled.createData(), Q0)
    assert np.allclose(np.triu(m_plant), np.triu(mass_matrix(own, Q0)), atol=1e-12)
    assert not np.allclose(np.triu(m_plant), np.triu(mass_matrix(irb140, Q0)), atol=1e-3)
    # nominal robot untouched
    assert irb140.model.inertias[6].mass == nominal[-1]


def test_sensor_is_seeded_and_quantizes():
    realism = Realism(encoder_resolution=1e-3, position_noise=0.0, velocity_noise=0.01, seed=7)
    a, b = Sensor(realism), Sensor(realism)
    q, qd = np.array([0.12345, -0.5]), np.array([1.0, 2.0])
    qa, qda = a.measure(q, qd)
    qb, qdb = b.measure(q, qd)
    assert np.array_equal(qa, qb) and np.array_equal(qda, qdb)
    assert np.allclose(qa, [0.123, -0.5])
    assert not np.array_equal(qda, qd)
    assert np.array_equal(Sensor(Realism()).measure(q, qd)[0], q)


def test_armature_is_in_the_mass_matrix_inverse_and_forward_dynamics(irb140):
    """The limits file's armature (reflected rotor inertia) enters crba, rnea and aba: against the same model
    without it, M grows by diag(armature) exactly, RNEA(q, 0, qdd) - RNEA(q, 0, 0) = (M0 + diag(armature)) qdd,
    and ABA inverts RNEA."""
    arm = np.asarray(irb140.limits.armature)
    assert arm.shape == (6,) and np.all(arm > 0) and irb140.limits.sources["joint_1"]["armature"] == "estimate"
    bare = pin.Model(irb140.model)
    bare.armature = np.zeros(6)
    bd, d = bare.createData(), irb140.model.createData()
    m0 = mass_matrix(replace(irb140, limits=replace(irb140.limits, armature=None)), Q0)
    assert np.allclose(m0, np.triu(pin.crba(bare, bd, Q0)) + np.triu(pin.crba(bare, bd, Q0), 1).T)
    m = mass_matrix(irb140, Q0)
    assert np.allclose(m - m0, np.diag(arm), atol=1e-12)
    qdd = np.array([1.0, -2.0, 0.5, 3.0, -1.0, 2.0])
    zero = np.zeros(6)
    lhs = pin.rnea(irb140.model, d, Q0, zero, qdd) - pin.rnea(irb140.model, d, Q0, zero, zero)
    assert np.allclose(lhs, (m0 + np.diag(arm)) @ qdd, atol=1e-10)
    tau = pin.rnea(irb140.model, d, Q0, QD0, qdd)
    assert np.allclose(pin.aba(irb140.model, d, Q0, QD0, tau), qdd, atol=1e-10)
    # velocity terms do not involve the armature (rotor gyroscopic effects are neglected, as in Pinocchio)
    assert np.allclose(pin.rnea(irb140.model, d, Q0, QD0, zero), pin.rnea(bare, bd, Q0, QD0, zero), atol=1e-10)
