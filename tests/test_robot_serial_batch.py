"""Batched serial-chain kinematics against Pinocchio, point by point, and against finite differences."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pathmotion.robot import Tool, frame_acceleration_bias, jacobian, kinematics, load_robot
from pathmotion.robot.serial_batch import chain_of
from robot_support import PANDA_URDF, ROBOTS, UR5_URDF


def _arms():
    yield "irb140", lambda: load_robot("irb140")
    yield "irb140 + tool", lambda: load_robot("irb140", tool=Tool((0.02, -0.01, 0.15), ((0.0, -1.0, 0.0),
                                                                                       (1.0, 0.0, 0.0),
                                                                                       (0.0, 0.0, 1.0))))
    if ROBOTS is not None:
        yield "ur5", lambda: load_robot(UR5_URDF)
        yield "panda", lambda: load_robot(PANDA_URDF,
                                          locked_joints={"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02})


def _pinocchio(robot, q, qd, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(kinematics, "SERIAL_BATCH_MIN", 10**9)
        return jacobian(robot, q), frame_acceleration_bias(robot, q, qd)


@pytest.mark.parametrize("name, make", list(_arms()), ids=[a[0] for a in _arms()])
def test_batch_equals_pinocchio_point_by_point(name, make, monkeypatch):
    robot = make()
    assert chain_of(robot.model, robot.frame_id(None)) is not None
    rng = np.random.default_rng(1)
    q = rng.uniform(-3.0, 3.0, (200, robot.n))
    qd = rng.uniform(-2.0, 2.0, (200, robot.n))
    jac, bias = jacobian(robot, q), frame_acceleration_bias(robot, q, qd)
    jac_ref, bias_ref = _pinocchio(robot, q, qd, monkeypatch)
    assert np.max(np.abs(jac - jac_ref)) <= 1e-13
    assert np.max(np.abs(bias - bias_ref)) <= 1e-12 * max(1.0, np.max(np.abs(bias_ref)))


def test_bias_is_the_rate_of_the_jacobian():
    """Jdot(q, qd) qd = d/dt (J(q + t qd)) qd at t = 0, by central differences of the batched Jacobian."""
    robot = load_robot("irb140")
    rng = np.random.default_rng(2)
    q, qd = rng.uniform(-2.0, 2.0, (64, 6)), rng.uniform(-1.0, 1.0, (64, 6))
    h = 1e-6
    rate = (jacobian(robot, q + h * qd) - jacobian(robot, q - h * qd)) / (2 * h)
    expected = np.einsum("kij,kj->ki", rate, qd)
    assert np.max(np.abs(frame_acceleration_bias(robot, q, qd) - expected)) <= 1e-7


def test_other_models_are_left_to_pinocchio():
    assert chain_of(pin.buildSampleModelHumanoid(), 0) is None  # free flyer: nq != nv
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "slide")
    frame = model.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    assert chain_of(model, frame) is None  # prismatic


@pytest.mark.parametrize("name, make", list(_arms()), ids=[a[0] for a in _arms()])
def test_jerk_bias_equals_pinocchio_point_by_point(name, make, monkeypatch):
    """The compiled third-order recursion against tcp_jerk_bias's Pinocchio derivatives, point by point."""
    from pathmotion.lift.constraint import tcp_jerk_bias

    robot = make()
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.uniform(-3.0, 3.0, (200, robot.n)), rng.uniform(-2.0, 2.0, (200, robot.n)), \
        rng.uniform(-5.0, 5.0, (200, robot.n))
    batch = tcp_jerk_bias(robot, q, qd, qdd)
    with monkeypatch.context() as m:
        m.setattr(kinematics, "SERIAL_BATCH_MIN", 10**9)
        ref = tcp_jerk_bias(robot, q, qd, qdd)
    assert np.max(np.abs(batch - ref)) <= 1e-12 * max(1.0, np.max(np.abs(ref)))


def test_jerk_bias_is_the_rate_of_the_acceleration():
    """Along q(t) = q + qd t + qdd t^2 / 2 the classical acceleration is J qdd + Jdot qd; its central difference
    at t = 0 is the batched jerk bias (independent of Pinocchio's derivatives)."""
    from pathmotion.lift.constraint import tcp_jerk_bias

    robot = load_robot("irb140")
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.uniform(-2.0, 2.0, (64, 6)), rng.uniform(-1.0, 1.0, (64, 6)), rng.uniform(-2.0, 2.0, (64, 6))

    def acc(t):
        qt, qdt = q + qd * t + 0.5 * qdd * t * t, qd + qdd * t
        return np.einsum("kij,kj->ki", jacobian(robot, qt), qdd) + frame_acceleration_bias(robot, qt, qdt)

    h = 1e-4
    expected = (acc(h) - acc(-h)) / (2 * h)
    assert np.max(np.abs(tcp_jerk_bias(robot, q, qd, qdd) - expected)) <= 1e-6
