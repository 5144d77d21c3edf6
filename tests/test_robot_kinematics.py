"""Forward kinematics of the built-in IRB140 against ABB's table and an independent DH model;
Jacobian and Jdot*qd against finite differences; the singularity measure."""

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion import defaults
from pathmotion.robot import fk, frame_acceleration_bias, jacobian, load_robot, manipulability

# ABB "Product specification IRB 140" (3HAC041346-001 rev Q, 2020), working range p. 35:
# wrist-centre position (axis 1 = 0) in the base frame [mm] for axis 2, axis 3 [deg].
ABB_WRIST_CENTRE_TABLE = [
    # axis 2, axis 3, x, z
    (0, 0, 450, 712),
    (0, -90, 70, 1092),
    (0, 50, 314, 421),
    (110, -90, 765, 99),
    (-90, 50, 1, 596),
    (110, -230, 218, 558),
    (-90, -90, -670, 352),
]

# Standard DH table of the IRB140 (same source, pp. 34-35; also Corke's Robotics Toolbox):
# rows a [m], d [m], alpha [rad], offset [rad], with theta_DH = q_ABB + offset.
DH = np.array([
    [0.070, 0.352, -np.pi / 2, 0.0],
    [0.360, 0.0, 0.0, -np.pi / 2],
    [0.0, 0.0, -np.pi / 2, 0.0],
    [0.0, 0.380, np.pi / 2, 0.0],
    [0.0, 0.0, -np.pi / 2, 0.0],
    [0.0, 0.065, 0.0, np.pi],
])


def dh_fk(q: np.ndarray) -> np.ndarray:
    """Flange pose (4, 4) by the standard DH convention A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    t = np.eye(4)
    for (a, d, alpha, offset), qi in zip(DH, q):
        th = qi + offset
        ct, st_, ca, sa = np.cos(th), np.sin(th), np.cos(alpha), np.sin(alpha)
        t = t @ np.array([
            [ct, -st_ * ca, st_ * sa, a * ct],
            [st_, ct * ca, -ct * sa, a * st_],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ])
    return t


@pytest.fixture(scope="module")
def robot():
    return load_robot("irb140")


@pytest.mark.parametrize("axis2, axis3, x_mm, z_mm", ABB_WRIST_CENTRE_TABLE)
def test_wrist_centre_matches_abb_table(robot, axis2, axis3, x_mm, z_mm):
    q = np.radians([0.0, axis2, axis3, 0.0, 0.0, 0.0])
    centre, _ = fk(robot, q, frame="link_5")  # link_5's origin lies on axes 4, 5 and 6
    assert abs(centre[0] * 1e3 - x_mm) < 0.5
    assert abs(centre[1]) < 1e-12
    assert abs(centre[2] * 1e3 - z_mm) < 0.5


def test_flange_at_abb_zero_pose(robot):
    pos, _ = fk(robot, np.zeros(6), frame="flange")
    np.testing.assert_allclose(pos, [0.515, 0.0, 0.712], atol=1e-12)


def test_fk_matches_standard_dh_up_to_constant_flange_rotation(robot):
    rng = np.random.default_rng(11)
    qs = rng.uniform(robot.limits.lower, robot.limits.upper, size=(200, 6))
    pos, rot = fk(robot, qs, frame="flange")
    ref = np.array([dh_fk(q) for q in qs])
    np.testing.assert_allclose(pos, ref[:, :3, 3], atol=1e-9)
    # the DH frame 6 and the URDF flange differ by a constant rotation: find it once, then check it
    constant = ref[0, :3, :3].T @ rot[0]
    np.testing.assert_allclose(constant.T @ constant, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(ref[:, :3, :3] @ constant, rot, atol=1e-9)
    # and it is the expected axis permutation (DH z6 = flange x): not the identity
    np.testing.assert_allclose(np.abs(constant), [[0, 0, 1], [0, 1, 0], [1, 0, 0]], atol=1e-12)


def test_batch_fk_equals_single_fk(robot):
    rng = np.random.default_rng(1)
    qs = rng.uniform(robot.limits.lower, robot.limits.upper, size=(5, 6))
    pos, rot = fk(robot, qs)
    for k, q in enumerate(qs):
        p1, r1 = fk(robot, q)
        np.testing.assert_array_equal(p1, pos[k])
        np.testing.assert_array_equal(r1, rot[k])


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6))
def test_jacobian_matches_finite_differences(robot, unit):
    q = robot.limits.lower + (np.array(unit) + 1.0) / 2.0 * (robot.limits.upper - robot.limits.lower)
    jac = jacobian(robot, q)
    h = 1e-6
    p0, r0 = fk(robot, q)
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        pp, rp = fk(robot, q + dq)
        pm, rm = fk(robot, q - dq)
        np.testing.assert_allclose(jac[:3, j], (pp - pm) / (2 * h), atol=1e-8)
        omega = (pin.log3(rp @ r0.T) - pin.log3(rm @ r0.T)) / (2 * h)  # world-frame angular rate
        np.testing.assert_allclose(jac[3:, j], omega, atol=1e-8)


def test_acceleration_bias_matches_finite_differences_of_jacobian(robot):
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, 6)
    qd = rng.uniform(-1, 1, 6)
    h = 1e-6
    jdot = (jacobian(robot, q + h * qd) - jacobian(robot, q - h * qd)) / (2 * h)
    bias = frame_acceleration_bias(robot, q, qd)
    np.testing.assert_allclose(bias, jdot @ qd, atol=1e-7)


def test_manipulability_detects_wrist_singularity(robot):
    regular = np.array([0.1, 0.3, -0.4, 0.5, 0.8, 0.2])
    singular = regular.copy()
    singular[4] = 0.0
    assert manipulability(robot, regular) > 10 * defaults.SINGULARITY_THRESHOLD
    assert manipulability(robot, singular) < 1e-12
    # the measure is the smallest singular value of the 6x6 Jacobian
    sv = np.linalg.svd(jacobian(robot, regular), compute_uv=False)
    assert manipulability(robot, regular) == pytest.approx(sv.min(), rel=1e-12)
