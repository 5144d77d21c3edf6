"""Numerical edge cases of the planner: grids from 10 points up (100,000 in
benchmarks/bench_memory.py), dynamic singularities (alpha_i(theta) = 0 under torque limits), a limit
touched exactly, a very short segment between long ones, a path of 50 segments. Each converges with
every limit kept on the 0.1 ms resample, or says why; the duration varies smoothly with the grid."""

import numpy as np
import pytest

from pathmotion import PlanSettings, lift, load_robot, plan
from pathmotion.geometry import Line, TaskPath
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning.reduced import reduced_dynamics

# the shipped joint_waypoints scenario's waypoints (rad)
WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0], [0.6, 0.3, -0.4, 0.5, 0.9, 1.0], [1.2, 0.5, -0.2, -0.3, 0.6, 2.0],
                      [0.5, 0.2, -0.6, 0.2, 1.1, 1.0], [0.0, 0.0, 0.0, 0.0, 0.5, 0.0]])
TOL = 1e-3


@pytest.fixture(scope="module")
def robot():
    return load_robot("irb140")


@pytest.fixture(scope="module")
def spline():
    return SplineJointPath.from_waypoints(WAYPOINTS)


def within_limits(result) -> bool:
    return result.ratios.max_ratio <= 1.0 + TOL


def test_duration_converges_smoothly_with_the_grid_from_10_points(robot, spline):
    grids = (10, 20, 40, 80, 160, 320, 640, 1280, 2560)
    durations = []
    for k in grids:
        res = plan(spline, robot, PlanSettings(grid_points=k, limits={"use_torque": False}, baselines=False))
        assert within_limits(res), (k, res.ratios.worst)
        durations.append(res.duration)
    d = np.array(durations)
    err = np.abs(d[:-1] - d[-1])
    # smooth: after the coarsest grids the error to the finest falls at least ~linearly with the step
    assert np.all(err[3:] <= 0.75 * err[2:-1] + 1e-4 * d[-1]), d
    assert err[-1] <= 2e-3 * d[-1] and err[0] <= 0.25 * d[-1]


def test_dynamic_singularities_under_torque_limits_are_crossed(robot, spline):
    """Where a component of alpha(theta) = M(q) Phi' changes sign the torque row does not bound theta_ddot
    (a dynamic singularity); with tight torque limits the planner still converges within every limit."""
    theta = np.linspace(0, 1, 2001)
    red = reduced_dynamics(robot, *spline.evaluate(theta))
    crossings = np.sum(np.diff(np.sign(red.alpha), axis=0) != 0, axis=0)
    assert crossings.sum() >= 3, crossings  # the path really has alpha_i = 0 points
    loose = plan(spline, robot, PlanSettings(grid_points=400, baselines=False))
    tight = plan(spline, robot, PlanSettings(grid_points=400, limits={"torque_scale": 0.2, "torque_reserve": 0.0}, baselines=False))
    assert within_limits(tight), tight.ratios.worst
    assert tight.ratios.torque > 1.0 - TOL  # the torque limit is active (0.15 is below gravity)
    assert tight.duration > loose.duration


def test_a_limit_is_touched_exactly_not_exceeded(robot):
    """On a straight line with a TCP speed limit far below what the joints allow, the motion cruises at
    exactly that speed: the largest ratio is 1 (to the tolerance), never above."""
    task = TaskPath((Line((0.5, -0.2, 0.5), (0.5, 0.2, 0.5)),))
    path = lift(robot, task)
    res = plan(path, robot, PlanSettings(grid_points=300, limits={"use_torque": False, "tcp_speed": 0.2},
                                         baselines=False))
    assert 1.0 - TOL <= res.ratios.tcp_speed <= 1.0 + TOL
    # cruise time of 0.4 m at 0.2 m/s bounds the duration from below, and the ramps are short
    assert 2.0 < res.duration < 2.3


def test_a_very_short_segment_between_long_ones(robot):
    """A 0.1 mm segment between two 0.25 m ones (sharp corners on both sides: the motion stops at each)."""
    a, b, c, d = (0.5, -0.25, 0.5), (0.5, 0.0, 0.5), (0.5001, 0.0, 0.5), (0.5001, 0.25, 0.5)
    task = TaskPath((Line(a, b), Line(b, c), Line(c, d)))
    path = lift(robot, task)
    assert len(path.kinks) == 2
    res = plan(path, robot, PlanSettings(grid_points=400, baselines=False))
    assert within_limits(res), res.ratios.worst
    long_only = plan(lift(robot, TaskPath((Line(a, b),))), robot, PlanSettings(grid_points=200, baselines=False))
    # two long rest-to-rest moves plus a tiny one: a little more than twice one long move
    assert 2 * long_only.duration * 0.98 < res.duration < 2 * long_only.duration * 1.2


def test_a_path_of_50_segments(robot):
    """A zigzag of 50 lines, 2 cm each: 49 sharp corners where the motion stops. Chain planning and
    segment-by-segment planning (rest at every connection) are two routes to the same optimum."""
    pts = [(0.45 + 0.02 * (k % 2), -0.25 + 0.01 * k, 0.5) for k in range(51)]
    task = TaskPath(tuple(Line(p, q) for p, q in zip(pts[:-1], pts[1:])))
    path = lift(robot, task)
    assert len(path.kinks) == 49
    chain = plan(path, robot, PlanSettings(grid_points=3000, limits={"use_torque": False}, baselines=False))
    each = plan(path, robot, PlanSettings(grid_points=3000, limits={"use_torque": False}, baselines=False,
                                          connections="zero"))
    assert within_limits(chain) and within_limits(each)
    assert chain.duration == pytest.approx(each.duration, rel=1e-3)
