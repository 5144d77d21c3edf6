"""The free-shape reference with joint torque limits (free_shape_optimum(..., torque=True)) against
pathmotion's own time-optimal stop planned with them (PlanSettings(torque=True)).

The case: the 90 degree turn on an IRB140 with its rated 6 kg payload (10 cm below the flange)
and drives at 35 % of the shipped torque limits. The shipped limits do not bind on this turn (the
stop takes 0.7197 s with and without them, even with a 10 kg payload; the acceleration limits bind
first), so weaker drives make the torque limit the active one: the stop takes 0.7867 s with it."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("casadi", reason='the free-shape reference needs CasADi: pip install "pathmotion[optimal]"')

from pathmotion.robot import load_robot  # noqa: E402
from pathmotion.robot.model import Payload  # noqa: E402
from pathmotion.study import free_shape as fs  # noqa: E402

TURN = np.array([(0.4, -0.1, 0.45), (0.5, -0.1, 0.45), (0.5, 0.1, 0.45)])  # the 90 degree turn
#: Fraction of the shipped torque limits the test's drives have.
WEAK_DRIVES = 0.35
#: Meshes: delta = 0 needs the extrapolation over three (25 intervals alone are 3 % short: the path is imposed at
#: the nodes, so between them the TCP cuts the corner).
MESHES = (25, 50, 100)


@pytest.fixture(scope="module")
def robot():
    arm = load_robot("irb140").with_payload(Payload(6.0, (0.0, 0.0, 0.1), ((0.01, 0, 0), (0, 0.01, 0), (0, 0, 0.01))))
    return arm.with_limits(dataclasses.replace(arm.limits, torque=arm.limits.torque * WEAK_DRIVES))


@pytest.mark.slow
def test_delta_zero_with_torque_reproduces_the_torque_limited_stop(robot):
    line = fs.Polyline(TURN)
    free_stop = fs.stop_plan(robot, line)[1].profile.duration
    stop = fs.stop_plan(robot, line, torque=True)[1].profile.duration
    assert stop > 1.05 * free_stop  # the torque limit binds
    free = fs.free_shape_optimum(robot, TURN, 0.0, meshes=MESHES)
    opt = fs.free_shape_optimum(robot, TURN, 0.0, meshes=MESHES, torque=True)
    assert opt.success and free.success, (opt.status, free.status)
    assert opt.torque and not free.torque
    assert opt.duration == pytest.approx(stop, rel=5e-3)
    assert free.duration == pytest.approx(free_stop, rel=5e-3)
    # the torque-limited optimum is never faster, mesh by mesh (its feasible set is a subset of the other's)
    assert all(a >= b - 1e-9 for a, b in zip(opt.durations, free.durations))
    v, v_free = opt.solutions[-1].verification, free.solutions[-1].verification
    assert v_free["max_torque_ratio"] > 1.1  # the torque-free optimum needs more torque than the drives have
    assert v["max_torque_ratio"] <= 1 + 1e-3  # dense resample (Pinocchio), both sides of every node
    assert v["max_velocity_ratio"] <= 1 + 1e-6 and v["max_acceleration_ratio"] <= 1 + 1e-6
    assert v["max_orientation_error_rad"] < 1e-5 and v["max_excess_m"] < 5e-5


def test_torque_ratio_of_a_resting_arm_is_its_gravity_load(robot):
    """At rest (qd = u = 0) the torque is gravity's, which Pinocchio gives directly."""
    import pinocchio as pin

    q = np.array([0.3, 0.4, -0.2, 0.5, 0.6, 0.1])
    motion = fs.Guess(np.array([0.0, 0.1, 0.2]), np.tile(q, (3, 1)), np.zeros((3, 6)), np.zeros((2, 6)), (0, 2))
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q)
    assert fs.max_torque_ratio(robot, motion) == pytest.approx(np.max(np.abs(g) / robot.limits.torque), rel=1e-12)
