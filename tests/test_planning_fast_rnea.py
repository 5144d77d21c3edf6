"""The compiled batched RNEA (planning/fast_rnea.py) against Pinocchio's rnea, point by point: the IRB140
with and without a payload, the UR5 and the Panda (example-robot-data, dev extra; the Panda with its
fingers locked), and the fallback for a joint type the kernels do not handle."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pathmotion.planning.fast_rnea import chain_data, reduced_batch, rnea_batch, supported
from pathmotion.planning.reduced import reduced_dynamics
from pathmotion.robot import load_robot
from pathmotion.robot.model import Payload
from robot_support import DATA, PANDA_URDF, ROBOTS, UR5_URDF


def _robots(irb140):
    out = [irb140, irb140.with_payload(Payload(mass=6.0, com=(0.05, -0.02, 0.2),
                                               inertia=((0.02, 0.001, 0.0), (0.001, 0.03, 0.0), (0.0, 0.0, 0.01))))]
    if ROBOTS is not None:
        out.append(load_robot(UR5_URDF, DATA / "ur5_limits.toml"))
        out.append(load_robot(PANDA_URDF, DATA / "panda_limits.toml",
                              locked_joints={"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02}))
    return out


def _pinocchio(robot, q, qd, qdd):
    data = robot.model.createData()
    return np.array([pin.rnea(robot.model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])


def test_rnea_batch_matches_pinocchio(irb140):
    rng = np.random.default_rng(4)
    for robot in _robots(irb140):
        assert supported(robot), robot.name
        q, qd, qdd = (rng.uniform(-2.5, 2.5, (50, robot.n)) for _ in range(3))
        expected = _pinocchio(robot, q, qd, qdd)
        assert np.allclose(rnea_batch(robot, q, qd, qdd), expected, rtol=1e-12, atol=1e-10 * np.abs(expected).max())


def test_reduced_batch_is_the_three_rnea_combinations(irb140):
    """alpha = RNEA(q, 0, Phi') - G, beta = RNEA(q, Phi', Phi'') - G, gamma = RNEA(q, 0, 0), by Pinocchio."""
    rng = np.random.default_rng(5)
    for robot in _robots(irb140):
        q, dq, ddq = (rng.uniform(-2.0, 2.0, (40, robot.n)) for _ in range(3))
        zero = np.zeros_like(q)
        gamma = _pinocchio(robot, q, zero, zero)
        expected = (_pinocchio(robot, q, zero, dq) - gamma, _pinocchio(robot, q, dq, ddq) - gamma, gamma)
        for got, want in zip(reduced_batch(robot, q, dq, ddq), expected):
            assert np.allclose(got, want, rtol=1e-12, atol=1e-10 * np.abs(want).max())


def test_unsupported_joint_falls_back_to_pinocchio():
    """A free-flyer base (nq 7, nv 6) is not a chain of 1-dof joints: no kernel data, so reduced.py and
    certify.py take Pinocchio's point-by-point path."""
    model = pin.buildSampleModelHumanoidRandom()
    assert chain_data(model) is None

    class Stub:  # the one attribute supported() reads
        pass

    stub = Stub()
    stub.model = model
    assert not supported(stub)


def test_reduced_dynamics_uses_the_kernel_consistently(irb140):
    """planning/reduced.py's result equals the kernel's and Pinocchio's mass matrix times Phi'."""
    rng = np.random.default_rng(6)
    q, dq, ddq = (rng.uniform(-1.5, 1.5, (20, 6)) for _ in range(3))
    r = reduced_dynamics(irb140, q, dq, ddq)
    data = irb140.model.createData()
    for k in range(len(q)):
        m = pin.crba(irb140.model, data, q[k])
        m = np.triu(m) + np.triu(m, 1).T
        assert np.allclose(r.alpha[k], m @ dq[k], rtol=1e-12, atol=1e-9)


def _chain_model():
    """A 4-joint chain with every joint kind the kernels handle: an unaligned revolute, a prismatic along
    z, an unaligned prismatic and a revolute about y, with offsets, rotated placements and inertias."""
    model = pin.Model()
    rng = np.random.default_rng(7)
    joints = [pin.JointModelRevoluteUnaligned(*(np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5]))),
              pin.JointModelPZ(), pin.JointModelPrismaticUnaligned(*(np.array([0.3, -1.0, 0.2]) /
                                                                     np.linalg.norm([0.3, -1.0, 0.2]))),
              pin.JointModelRY()]
    parent = 0
    for k, joint in enumerate(joints):
        place = pin.SE3(pin.exp3(rng.uniform(-1, 1, 3)), rng.uniform(-0.3, 0.3, 3))
        parent = model.addJoint(parent, joint, place, f"j{k}")
        a = rng.uniform(-1, 1, (3, 3))
        model.appendBodyToJoint(parent, pin.Inertia(rng.uniform(1, 5), rng.uniform(-0.2, 0.2, 3), a @ a.T + 0.1 * np.eye(3)),
                                pin.SE3.Identity())
    model.armature = rng.uniform(0.0, 0.5, model.nv)
    return model


def test_all_supported_joint_kinds_match_pinocchio():
    model = _chain_model()

    class Stub:  # rnea_batch reads robot.model only
        pass

    robot = Stub()
    robot.model = model
    assert supported(robot)
    rng = np.random.default_rng(8)
    q, qd, qdd = (rng.uniform(-1.5, 1.5, (30, model.nv)) for _ in range(3))
    data = model.createData()
    expected = np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
    assert np.allclose(rnea_batch(robot, q, qd, qdd), expected, rtol=1e-12, atol=1e-10 * np.abs(expected).max())


def test_trajectory_samples_carry_pinocchios_torques(irb140):
    """Trajectory.at_time computes tau with the compiled RNEA: equal to Pinocchio's at its samples."""
    from pathmotion import api
    from pathmotion.planning import PlanSettings, plan
    from pathmotion.scenarios import scenario_path

    setup = api.load(scenario_path("circle_zero"))
    result = plan(setup.path, setup.robot, PlanSettings(grid_points=60, verify="off"))
    s = result.trajectory.at_time(np.linspace(0.0, result.duration, 200))
    expected = _pinocchio(setup.robot, s.q, s.qd, s.qdd)
    assert np.allclose(s.tau, expected, rtol=1e-12, atol=1e-10 * np.abs(expected).max())
