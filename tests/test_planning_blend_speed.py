"""plan.blend_speed_scale: the blend is found from geometry, slowed by exactly the scale (velocities x s,
torques between the optimal ones and gravity), the rest re-planned, and every limit verified."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api
from pathmotion.errors import ScenarioError
from pathmotion.geometry.deviation import distance_to_segments
from pathmotion.planning import effective_limits, limit_ratios
from pathmotion.robot import gravity
from pathmotion.scenarios import scenario_path
from pathmotion.planning.blend_speed import blend_ranges, cap_blend_speed


@pytest.fixture(scope="module")
def planned():
    setup = api.load(scenario_path("corner_transition"), {"plan.grid_points": 300})
    return setup, api.plan_scenario(setup)


def test_blend_ranges_from_geometry(planned):
    setup, _ = planned
    (a, b), = blend_ranges(setup.task_path, setup.original_task_path)
    theta = np.linspace(*setup.task_path.domain, 400)
    d = distance_to_segments(setup.task_path.evaluate(theta)[0], setup.original_task_path.segments)
    inside = (theta > a + 1e-6) & (theta < b - 1e-6)
    outside = (theta < a - 1e-6) | (theta > b + 1e-6)
    assert np.all(d[inside] > 1e-6) and np.all(d[outside] < 1e-9)
    assert blend_ranges(setup.original_task_path, None) == ()


@pytest.mark.parametrize("scale", [0.5])
def test_scaled_blend(planned, scale):
    setup, opt = planned
    capped = cap_blend_speed(setup, opt, scale)
    (a, b), = blend_ranges(setup.task_path, setup.original_task_path)
    theta = np.linspace(a, b, 50)
    # on the blend: theta_dot is exactly s times the optimal one
    np.testing.assert_allclose(capped.profile.theta_dot_at(theta), scale * opt.profile.theta_dot_at(theta),
                               rtol=1e-12, atol=1e-12)
    # ... so the joint velocities are s times, and tau - gravity is s^2 times (Phi, Phi', Phi'' shared)
    q, dq, ddq = setup.path.evaluate(theta)
    g = gravity(setup.robot, q)

    def torque(profile):
        xd, xdd = profile.theta_dot_at(theta), profile.theta_ddot_at(theta)
        from pathmotion.robot import rnea

        return rnea(setup.robot, q, dq * xd[:, None], dq * xdd[:, None] + ddq * (xd**2)[:, None])

    mid = (theta > a + 1e-3) & (theta < b - 1e-3)  # away from the interval ends (u is right-continuous)
    np.testing.assert_allclose((torque(capped.profile) - g)[mid], scale**2 * (torque(opt.profile) - g)[mid],
                               rtol=1e-9, atol=1e-9)
    # everywhere: within the limits (an independent resample, 4x finer than the planner's), and slower
    ratios = limit_ratios(capped.trajectory, effective_limits(setup.robot, capped.settings), 2.5e-5)
    assert ratios.max_ratio <= 1 + capped.settings.limit_tolerance
    assert capped.profile.duration > opt.profile.duration
    # starts and ends at rest as the scenario asks
    assert capped.profile.x[0] == 0 and capped.profile.x[-1] == 0


def test_scale_through_the_scenario_key(planned):
    setup, opt = planned
    slow = api.load(scenario_path("corner_transition"), {"plan.grid_points": 300, "plan.blend_speed_scale": 0.75})
    res = api.plan_scenario(slow)
    half = cap_blend_speed(setup, opt, 0.5)
    assert opt.profile.duration < res.profile.duration < half.profile.duration
    assert cap_blend_speed(setup, opt, 1.0) is opt


def test_errors(planned):
    setup, opt = planned
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(ScenarioError, match="blend_speed_scale"):
            cap_blend_speed(setup, opt, bad)
    stop = api.load(scenario_path("corner_stop"), {"plan.grid_points": 300})
    with pytest.raises(ScenarioError, match="needs a blend"):
        cap_blend_speed(stop, api.plan_scenario(stop), 0.5)
    with pytest.raises(ScenarioError, match="blend_speed_scale"):
        api.load(scenario_path("corner_transition"), {"plan.blend_speed_scale": 2.0})
