"""The IRB140 limits file's jerk and torque-rate estimates: loaded, used by use_jerk = true."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api
from pathmotion.errors import RobotModelError
from pathmotion.planning import PlanSettings, plan
from pathmotion.robot import load_robot
from pathmotion.robot.limits import limits_from_dict

CIRCLE = "pathmotion/scenarios/circle_zero.toml"


def test_irb140_carries_the_argued_jerk_and_torque_rate_estimates():
    lim = load_robot("irb140").limits
    # the file's stated argument: jerk = 10x the acceleration estimate, torque rate = torque / 0.025 s
    np.testing.assert_allclose(lim.jerk, 10.0 * lim.acceleration)
    np.testing.assert_allclose(lim.torque_rate, lim.torque / 0.025)
    for name in lim.names:
        assert lim.sources[name]["jerk"] == "estimate"
        assert lim.sources[name]["torque_rate"] == "estimate"


def test_use_jerk_alone_plans_with_the_file_estimates():
    setup = api.load(CIRCLE, {"limits.use_jerk": True, "plan.grid_points": 100})
    res = plan(setup.path, setup.robot, setup.plan_settings)
    lim = setup.robot.limits
    explicit = plan(setup.path, setup.robot, PlanSettings(grid_points=100, baselines=False,
                                                          limits={"jerk": tuple(10.0 * lim.acceleration)}))
    assert res.duration == pytest.approx(explicit.duration, rel=1e-9)
    assert 0.9 < res.ratios.jerk <= 1.001  # the estimate binds and holds on the resample
    second = plan(setup.path, setup.robot, PlanSettings(grid_points=100, baselines=False))
    assert res.duration > second.duration


def test_jerk_on_some_joints_only_is_refused():
    joints = [{"name": f"j{k}", "lower": -1.0, "upper": 1.0, "velocity": 1.0, "torque": 1.0} for k in range(2)]
    joints[0]["jerk"] = 50.0
    with pytest.raises(RobotModelError, match="jerk given for some joints but not for \\['j1'\\]"):
        limits_from_dict({"joints": joints}, ("j0", "j1"))
    joints[1]["jerk"] = -1.0
    with pytest.raises(RobotModelError, match="jerk of j1"):
        limits_from_dict({"joints": joints}, ("j0", "j1"))
