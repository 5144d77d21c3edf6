"""The free-shape reference's symbolic inverse dynamics (pathmotion/study/symbolic_dynamics.py) against
Pinocchio's rnea (pathmotion.robot.dynamics), the planner's compiled RNEA (planning/fast_rnea.py) and
its reduced dynamics (the torque model of the planner's torque limit), at random states: the IRB140
bare and with an offset payload (both with the drives' armature), the UR5 and the full Panda with its
two prismatic finger joints (example-robot-data, dev extra)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("casadi", reason='the free-shape reference needs CasADi: pip install "pathmotion[optimal]"')

from pathmotion.errors import PathmotionError  # noqa: E402
from pathmotion.planning.fast_rnea import rnea_batch  # noqa: E402
from pathmotion.planning.reduced import reduced_dynamics  # noqa: E402
from pathmotion.robot import load_robot, rnea  # noqa: E402
from pathmotion.robot.model import Payload  # noqa: E402
from pathmotion.study.symbolic_dynamics import inverse_dynamics_function  # noqa: E402
from robot_support import DATA, PANDA_URDF, ROBOTS, UR5_URDF  # noqa: E402

PAYLOAD = Payload(mass=6.0, com=(0.05, -0.02, 0.2), inertia=((0.02, 0.001, 0.0), (0.001, 0.03, 0.0), (0.0, 0.0, 0.01)))


def _robots(irb140):
    out = [irb140, irb140.with_payload(PAYLOAD)]
    if ROBOTS is not None:
        out.append(load_robot(UR5_URDF, DATA / "ur5_limits.toml"))
        out.append(load_robot(PANDA_URDF))  # 7 revolute + 2 prismatic joints
    return out


def _symbolic(f, q, qd, qdd):
    return np.array([np.asarray(f(a, b, c)).ravel() for a, b, c in zip(q, qd, qdd)])


def _close(got, want):
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(want).max()))


def test_symbolic_rnea_matches_pinocchio_and_the_planner(irb140):
    assert np.all(np.asarray(irb140.model.armature) > 0)  # the IRB140's drives have armature: it must count
    rng = np.random.default_rng(11)
    for robot in _robots(irb140):
        f = inverse_dynamics_function(robot)
        q, qd, qdd = (rng.uniform(-2.5, 2.5, (40, robot.n)) for _ in range(3))
        tau = _symbolic(f, q, qd, qdd)
        _close(tau, rnea(robot, q, qd, qdd))
        _close(tau, rnea_batch(robot, q, qd, qdd))


def test_symbolic_rnea_carries_the_payload_and_the_armature(irb140):
    """Each ingredient changes the torque, so a model without it would fail the comparison above."""
    rng = np.random.default_rng(12)
    q, qd, qdd = (rng.uniform(-2.0, 2.0, irb140.n) for _ in range(3))
    bare = np.asarray(inverse_dynamics_function(irb140)(q, qd, qdd)).ravel()
    loaded = np.asarray(inverse_dynamics_function(irb140.with_payload(PAYLOAD))(q, qd, qdd)).ravel()
    assert np.max(np.abs(loaded - bare)) > 1.0  # [N m]
    no_armature = irb140.model.copy()
    no_armature.armature[:] = 0.0
    without = np.asarray(inverse_dynamics_function(SimpleNamespace(model=no_armature, n=irb140.n))(q, qd, qdd)).ravel()
    np.testing.assert_allclose(bare - without, np.asarray(irb140.model.armature) * qdd, atol=1e-10)


def test_symbolic_rnea_is_the_planners_reduced_dynamics(irb140):
    """Along a path q = Phi(theta): tau(Phi, Phi' s_dot, Phi' s_ddot + Phi'' s_dot^2) = alpha s_ddot +
    beta s_dot^2 + gamma, the form the planner's torque limit is written in."""
    robot = irb140.with_payload(PAYLOAD)
    f = inverse_dynamics_function(robot)
    rng = np.random.default_rng(13)
    q, dq, ddq = (rng.uniform(-2.0, 2.0, (20, robot.n)) for _ in range(3))
    s_dot, s_ddot = rng.uniform(0.1, 2.0, 20), rng.uniform(-5.0, 5.0, 20)
    red = reduced_dynamics(robot, q, dq, ddq)
    tau = _symbolic(f, q, dq * s_dot[:, None], dq * s_ddot[:, None] + ddq * s_dot[:, None] ** 2)
    _close(tau, red.torque(s_ddot, s_dot ** 2))


def test_joints_it_does_not_handle_are_refused():
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "turn")
    model.appendBodyToJoint(joint, pin.Inertia.Random(), pin.SE3.Identity())
    ball = model.addJoint(joint, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    model.appendBodyToJoint(ball, pin.Inertia.Random(), pin.SE3.Identity())
    with pytest.raises(PathmotionError, match="nq = 5, nv = 4"):
        inverse_dynamics_function(SimpleNamespace(model=model, n=2))
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelHX(0.01), pin.SE3.Identity(), "screw")  # helical: one coordinate
    with pytest.raises(PathmotionError, match="screw is of type JointModelHX"):
        inverse_dynamics_function(SimpleNamespace(model=model, n=model.nv))
