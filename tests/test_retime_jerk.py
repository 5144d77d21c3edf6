"""The re-timer with jerk limits (planning/retime.py): the compiled pass against the sequential-LP reference,
and states the reference refused.

Independent references: the dense time resample of every returned profile (each active limit, every
0.5 ms), the offline planner from the same speed, and the sequential LP (planning/third_order.py) from the
same state.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, Retimer, plan
from pathmotion.robot import load_robot

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
ROBOT = load_robot("irb140")
ROBOT = ROBOT.with_limits(replace(ROBOT.limits, acceleration=ACC))
TOL = 1e-3  # the plans' limit tolerance (defaults.LIMIT_TOLERANCE)
DT = 5e-4  # dense resample step [s]


@pytest.fixture(scope="module")
def torque_jerk():
    """(path, plan, retimer): a random 6-joint spline through 5 waypoints, torque and jerk (10 x the
    accelerations) limits, 120 grid points."""
    path = SplineJointPath.from_waypoints(np.random.default_rng(1).uniform(-1.5, 1.5, (5, 6)))
    limits = {"use_torque": True, "use_jerk": True, "jerk": tuple(10 * ACC)}
    res = plan(path, ROBOT, PlanSettings(grid_points=120, limits=limits))
    return path, res, Retimer(res)


def test_stop_from_a_large_acceleration_where_the_spline_starts(torque_jerk):
    # theta_ddot = 0.99 x the offline plan's own start acceleration from this speed: the jerk limit turns it
    # within ~1e-3 of the path, which a stop grid without grading towards the state does not resolve
    path, res, rt = torque_jerk
    theta, v, a = 0.004738774109017252, 0.1265318223548721, 9.29709097378817
    tail = replace(path, domain=(theta, path.domain[1]))
    offline = plan(tail, ROBOT, replace(res.settings, start=v, grid_points=120))
    assert np.isclose(offline.profile.u_nodes[0], a / 0.99, rtol=0.02)  # a motion from this state exists
    s = rt.stop(theta, v, a)
    assert s.smooth and s.x[-1] == 0.0 and np.isclose(s.u_nodes[0], a) and np.isclose(np.sqrt(s.x[0]), v)
    assert s.grid[-1] < path.domain[1]
    assert rt.dense_ratios(s, DT).max_ratio <= 1.0 + 2 * TOL
