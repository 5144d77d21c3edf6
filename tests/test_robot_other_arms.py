"""Other arms: locked joints, redundancy resolution for >6 joints, and the whole flow (plan and
simulate a circle and a blended corner) on the UR5 and the Panda of PyPI example-robot-data (dev extra).

Limits: tests/data/ur5_limits.toml and panda_limits.toml (ranges, speeds and torques from the URDFs; the
accelerations there are test assumptions)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pathmotion as pm
from pathmotion.errors import RobotModelError
from pathmotion.lift.constraint import joint_derivatives, joint_third_derivative
from pathmotion.geometry import FixedOrientation, distance_to_segments, horizontal_circle
from pathmotion.robot import fk, has_closed_form, ik_nearest, jacobian, load_robot
from pathmotion.robot import redundancy
from robot_support import DATA, PANDA_URDF, ROBOTS, UR5_URDF

pytestmark = pytest.mark.skipif(ROBOTS is None, reason="example-robot-data (dev extra) is not installed")

FINGERS = {"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02}
PANDA_READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
UR5_START = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
#: UR5 tool0 at UR5_START: z down, x along -world y.
UR5_DOWN = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
FD_STEP = 1e-5  # [m of theta]


@pytest.fixture(scope="module")
def panda():
    return load_robot(PANDA_URDF, DATA / "panda_limits.toml", locked_joints=FINGERS)


@pytest.fixture(scope="module")
def panda_circle(panda):
    path = horizontal_circle((0.4, 0.0, 0.4), 0.1)
    return path, pm.lift(panda, path, PANDA_READY)


# ------------------------------------------------------------------------------------ locked joints
def test_locked_joints_reduce_the_model(panda):
    full = load_robot(PANDA_URDF)
    assert full.n == 9 and panda.n == 7
    assert panda.joint_names == tuple(f"panda_joint{k}" for k in range(1, 8))
    assert panda.limits.names == panda.joint_names and panda.limits.acceleration is not None
    # independent check: the full model with the fingers at 0.02 m places every frame as the reduced one
    q = np.random.default_rng(3).uniform(panda.limits.lower, panda.limits.upper)
    q_full = np.concatenate([q, [0.02, 0.02]])
    for frame in ("panda_hand_tcp", "panda_leftfinger", "panda_rightfinger"):
        m_full, m_red = full.model, panda.model
        d_full, d_red = m_full.createData(), m_red.createData()
        pin.framesForwardKinematics(m_full, d_full, q_full)
        pin.framesForwardKinematics(m_red, d_red, q)
        a, b = d_full.oMf[m_full.getFrameId(frame)], d_red.oMf[m_red.getFrameId(frame)]
        assert np.allclose(a.homogeneous, b.homogeneous, atol=1e-12), frame
    # the locked fingers' mass still counts: gravity torques agree with the full model's
    g_full = pin.computeGeneralizedGravity(full.model, full.model.createData(), q_full)[:7]
    g_red = pin.computeGeneralizedGravity(panda.model, panda.model.createData(), q)
    assert np.allclose(g_full, g_red, atol=1e-10)


def test_locked_joint_errors():
    with pytest.raises(RobotModelError, match="locked joint 'gripper' is not a moving joint"):
        load_robot(PANDA_URDF, locked_joints={"gripper": 0.0})
    with pytest.raises(RobotModelError, match="locked joint 'panda_finger_joint1' = 0.5 is outside its range"):
        load_robot(PANDA_URDF, locked_joints={"panda_finger_joint1": 0.5})


def test_scenario_locked_joints_and_flange(tmp_path):
    locked = "{panda_finger_joint1 = 0.01, panda_finger_joint2 = 0.01}"
    text = (f'[robot]\nname = "{PANDA_URDF}"\nlocked_joints = {locked}\n'
            'flange_frame = "panda_hand"\n[path]\ntype = "joint"\n'
            f"waypoints = [{PANDA_READY.tolist()}, {(PANDA_READY + 0.1).tolist()}]\n")
    setup = pm.load_text(text, tmp_path)
    assert setup.robot.n == 7 and setup.robot.flange_frame == "panda_hand"
    assert setup.robot.locked_joints == (("panda_finger_joint1", 0.01), ("panda_finger_joint2", 0.01))


# ------------------------------------------------------------------------------------ redundancy
def test_jacobian_rate_matches_finite_differences(panda):
    rng = np.random.default_rng(1)
    q, v = rng.uniform(-1, 1, 7), rng.uniform(-1, 1, 7)
    fd = (jacobian(panda, q + 1e-6 * v) - jacobian(panda, q - 1e-6 * v)) / 2e-6
    assert np.max(np.abs(fd - redundancy.jacobian_rate(panda, q, v)[0])) < 1e-8


def test_redundant_lift_follows_the_path_with_exact_derivatives(panda, panda_circle):
    path, jp = panda_circle
    theta = np.linspace(0.0, path.length, 241)
    q, dq, ddq = jp.evaluate(theta)
    pos, rot = fk(panda, q)
    p, dp, ddp, r, w, dw = path.pose(theta)
    assert np.max(np.abs(pos - p)) < 1e-9 and np.max(np.abs(rot - r)) < 1e-9
    # finite differences of Phi and Phi'
    inner = theta[1:-1]
    hi, lo = jp.evaluate(inner + FD_STEP), jp.evaluate(inner - FD_STEP)
    _, d1, d2 = jp.evaluate(inner)
    assert np.max(np.abs((hi[0] - lo[0]) / (2 * FD_STEP) - d1)) < 1e-6 * np.max(np.abs(d1))
    assert np.max(np.abs((hi[1] - lo[1]) / (2 * FD_STEP) - d2)) < 1e-6 * np.max(np.abs(d2))
    # task-space identities, exact at every point: J Phi' = xi, J Phi'' + Jd Phi' = xi'
    jac = jacobian(panda, q)
    jd = redundancy.jacobian_rate(panda, q, dq)
    xi, dxi = np.concatenate([dp, w], 1), np.concatenate([ddp, dw], 1)
    assert np.max(np.abs(np.einsum("nij,nj->ni", jac, dq) - xi)) < 1e-10
    assert np.max(np.abs(np.einsum("nij,nj->ni", jac, ddq) + np.einsum("nij,nj->ni", jd, dq) - dxi)) < 1e-8
    # continuity: on a 20x finer grid no joint moves more than |Phi'| allows per step (no branch jump)
    fine = np.linspace(0.0, path.length, 4801)
    qf = jp(fine)
    step = np.max(np.abs(np.diff(qf, axis=0)), axis=0)
    assert np.all(step <= 1.01 * np.max(np.abs(dq), axis=0) * (fine[1] - fine[0]))
    # Phi''' (exact, from the ODE differentiated twice) against central differences of Phi''
    _, d1b, d2b, d3 = jp.evaluate3(inner)
    assert np.max(np.abs(d1b - d1)) < 1e-12 and np.max(np.abs(d2b - d2)) < 1e-9
    assert np.max(np.abs((hi[2] - lo[2]) / (2 * FD_STEP) - d3)) < 1e-5 * np.max(np.abs(d3))


def test_jacobian_second_rate_matches_finite_differences(panda):
    rng = np.random.default_rng(2)
    q, v, a = rng.uniform(-1, 1, (3, 7))
    h = 1e-4
    at = (lambda t: q + v * t + 0.5 * a * t * t)
    fd = (jacobian(panda, at(h)) - 2 * jacobian(panda, q) + jacobian(panda, at(-h))) / h**2
    assert np.max(np.abs(fd - redundancy.jacobian_second_rate(panda, q, v, a)[0])) < 1e-6


def test_null_space_motion_minimizes_weighted_speed_and_pulls_to_start(panda, panda_circle):
    path, _ = panda_circle
    theta = np.linspace(0.0, path.length, 400)
    winv = redundancy.joint_weights(panda)
    q0 = pm.lift(panda, path, PANDA_READY).reference_q[0]
    free, _, _ = redundancy.integrate_path(panda, theta, path.pose, q0, PANDA_READY, 0.0, winv)
    pulled, _, _ = redundancy.integrate_path(panda, theta, path.pose, q0, PANDA_READY, 5.0, winv)
    # gain 0: Phi' has no component in the null space in the W metric (W = diag(1 / qd_max^2)),
    # i.e. no other joint rate with the same TCP twist is slower against the limits
    xi = np.concatenate([path.pose(theta)[1], path.pose(theta)[4]], 1)
    dq = redundancy.resolved_rate(panda, free, xi, PANDA_READY, 0.0, winv)
    for k in (0, 150, 399):
        basis = np.linalg.svd(jacobian(panda, free[k]))[2][6:].T  # (7, 1) null space of J
        assert abs(basis[:, 0] @ (dq[k] / winv)) < 1e-10 * np.linalg.norm(dq[k] / winv)
    # the pull keeps the arm nearer to the start configuration
    assert np.max(np.linalg.norm(pulled - PANDA_READY, axis=1)) < np.max(np.linalg.norm(free - PANDA_READY, axis=1))


def test_ur5_lift_agrees_with_point_by_point_dls():
    """The UR5 (6 joints, no closed form) is lifted by the resolved-rate ODE; a second algorithm, damped least
    squares IK at every point from the lift's own reference, lands on the same configurations."""
    robot = load_robot(UR5_URDF, DATA / "ur5_limits.toml")
    path = horizontal_circle((0.45, 0.11, 0.35), 0.1, orientation=FixedOrientation(UR5_DOWN))
    jp = pm.lift(robot, path, UR5_START)
    assert not has_closed_form(robot) and jp.gain == 0.0
    theta = np.linspace(0.0, path.length, 97)
    q, dq, ddq, dddq = jp.evaluate3(theta)
    p, _, _, rot, _, _ = path.pose(theta)
    q_dls = ik_nearest(robot, p, rot, np.column_stack([np.interp(theta, jp.reference_theta, c)
                                                       for c in jp.reference_q.T]))
    assert np.max(np.abs(q - q_dls)) < 1e-8
    # the IRB140's formulas (J^-1, exact) give the same derivatives as the ODE's
    d1, d2 = joint_derivatives(robot, q, *path.pose(theta)[1:3], *path.pose(theta)[4:6])
    assert np.max(np.abs(d1 - dq)) < 1e-9 * np.max(np.abs(dq)) and np.max(np.abs(d2 - ddq)) < 1e-8 * np.max(np.abs(ddq))
    d3 = joint_third_derivative(robot, q, dq, ddq, path.pose3(theta)[3], path.pose3(theta)[7])
    assert np.max(np.abs(d3 - dddq)) < 1e-7 * np.max(np.abs(dddq))


# ------------------------------------------------------------------------------------ whole flow
def _flow(robot_lines: str, path_lines: str, tmp_path):
    setup = pm.load_text(robot_lines + path_lines, tmp_path)
    result = pm.plan_scenario(setup)
    sim = pm.simulate_scenario(setup, result)
    return setup, result, sim


def _check_flow(setup, result, sim):
    assert result.ratios is not None and result.ratios.within()
    # the planned motion lies on the path: FK of the sampled joints against the task path
    s = result.trajectory.sample(0.01)
    pos = fk(setup.robot, s.q)[0]
    assert np.max(np.abs(pos - setup.task_path.evaluate(s.theta)[0])) < 1e-6
    # independent lower bound: no joint above its speed limit -> T >= integral of dtheta / theta_dot_max
    theta = np.linspace(*setup.path.domain, 2001)
    dq = setup.path.evaluate(theta)[1]
    vmax = 1.0 / np.max(np.abs(dq) / setup.robot.limits.velocity, axis=1)
    assert result.duration >= np.trapezoid(1.0 / vmax, theta) * 0.999
    assert sim.tracking_ok and np.max(sim.path_deviation) < 1e-3


UR5_ROBOT = f'[robot]\nname = "{UR5_URDF}"\nlimits = "{DATA / "ur5_limits.toml"}"\n'
PANDA_ROBOT = (f'[robot]\nname = "{PANDA_URDF}"\nlimits = "{DATA / "panda_limits.toml"}"\n'
               "locked_joints = {panda_finger_joint1 = 0.02, panda_finger_joint2 = 0.02}\n")
UR5_Q = f"start_configuration = {UR5_START.tolist()}\norientation = {UR5_DOWN.tolist()}\n"
PANDA_Q = f"start_configuration = {PANDA_READY.tolist()}\n"


@pytest.mark.slow
@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_plan_and_simulate_circle(arm, tmp_path):
    robot, q, centre = ((UR5_ROBOT, UR5_Q, [0.45, 0.11, 0.35]) if arm == "ur5"
                        else (PANDA_ROBOT, PANDA_Q, [0.4, 0.0, 0.4]))
    path = f'[path]\ntype = "task"\nsegments = [{{type = "circle", center = {centre}, radius = 0.1}}]\n' + q
    setup, result, sim = _flow(robot, path, tmp_path)
    assert setup.robot.n == (6 if arm == "ur5" else 7)
    if arm == "ur5":
        assert not has_closed_form(setup.robot)  # not OPW: the DLS fallback lifts it
    _check_flow(setup, result, sim)


@pytest.mark.slow
@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_plan_and_simulate_blended_corner(arm, tmp_path):
    robot, q, pts = ((UR5_ROBOT, UR5_Q, [[0.4, 0.0, 0.35], [0.55, 0.0, 0.35], [0.55, 0.2, 0.35]]) if arm == "ur5"
                     else (PANDA_ROBOT, PANDA_Q, [[0.3, -0.1, 0.4], [0.45, -0.1, 0.4], [0.45, 0.1, 0.4]]))
    path = f'[path]\ntype = "waypoints"\npoints = {pts}\nblend_tolerance = 0.01\n' + q
    setup, result, sim = _flow(robot, path, tmp_path)
    assert setup.path.kinks == ()
    _check_flow(setup, result, sim)
    # the simulated TCP rounds the corner: within the tolerance (+ 1 mm tracking) of the two lines, not through it
    lines = setup.original_task_path.segments
    assert np.max(distance_to_segments(sim.tcp, lines)) < 0.01 + 1e-3
    assert np.min(np.linalg.norm(sim.tcp - np.array(pts[1]), axis=1)) > 0.005
