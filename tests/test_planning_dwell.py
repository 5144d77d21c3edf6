"""Dwells (a wait at rest, WaitTime): the profile's holds against the motion without them, the compiled controller
look-up against the profile, and a planned and closed-loop simulated chain of joint moves, a line and a dwell."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api, defaults
from pathmotion.control.kernels import profile_at_time
from pathmotion.control.profile_lookup import ProfileLookup
from pathmotion.errors import PathmotionError, ScenarioError
from pathmotion.planning.profile import Profile
from pathmotion.robot import fk, ik, load_robot, rnea

DOWN = np.array(defaults.TOOL_DOWN_ROTATION)


@pytest.fixture(scope="module")
def moving():
    grid = np.linspace(0.0, 4.0, 41)
    x = np.sin(np.pi * grid / 2.0) ** 2  # stops at 0, 2 and 4
    x[[0, 20, 40]] = 0.0
    return Profile(grid, x)


def test_holds_add_their_time_and_hold_still(moving):
    held = moving.with_holds([(0.0, 0.2), (2.0, 0.5), (4.0, 0.3)])
    assert held.duration == pytest.approx(moving.duration + 1.0, abs=1e-15)
    arrive = float(moving.times[20])  # the motion reaches theta = 2 at this time (the plan without holds)
    t = np.linspace(0.0, held.duration, 3001)
    theta, rate, acc, jerk = held.state3_at_time(t)
    # independent: the motion without holds, shifted by the holds passed so far; at rest inside each hold
    shift = np.where(t < 0.2, 0.0, np.where(t < 0.2 + arrive + 0.5, 0.2, 0.7))
    shift = np.where(t < 0.2 + arrive, np.minimum(t, 0.2), shift)
    rest = (t < 0.2) | ((t > 0.2 + arrive) & (t < 0.7 + arrive)) | (t > held.duration - 0.3)
    ref = moving.state3_at_time(np.clip(t - shift, 0.0, moving.duration))
    np.testing.assert_allclose(theta[~rest], ref[0][~rest], atol=1e-12)
    np.testing.assert_allclose(rate[~rest], ref[1][~rest], atol=1e-9)
    np.testing.assert_allclose(acc[~rest], ref[2][~rest], atol=1e-12)
    assert np.all(rate[rest] == 0.0) and np.all(acc[rest] == 0.0)
    np.testing.assert_array_equal(theta[(t > 0.2 + arrive) & (t < 0.7 + arrive)], 2.0)
    np.testing.assert_array_equal(theta[t < 0.2], 0.0)


def test_the_compiled_lookup_equals_the_profile(moving):
    held = moving.with_holds([(0.0, 0.2), (2.0, 0.5)])
    arrays = ProfileLookup(held).arrays
    t = np.linspace(0.0, held.duration, 1999)
    theta, rate, acc = held.state_at_time(t)
    got = np.array([profile_at_time(arrays, float(tk)) for tk in t])
    np.testing.assert_allclose(got[:, 0], theta, atol=1e-12)
    np.testing.assert_allclose(got[:, 1], rate, atol=1e-9)
    np.testing.assert_allclose(got[:, 2], acc, atol=1e-12)


def test_a_hold_where_the_motion_does_not_stop_is_an_error(moving):
    with pytest.raises(PathmotionError, match="does not stop"):
        moving.with_holds([(1.0, 0.5)])
    with pytest.raises(PathmotionError, match="not a grid point"):
        moving.with_holds([(1.01, 0.5)])


CHAIN = """name = "dwell_chain"
[path]
type = "task"
start_configuration = %s
[[path.segments]]
type = "joint"
end_pose = {position = [0.45, 0.15, 0.45], quaternion = [0, 1, 0, 0]}
%s[[path.segments]]
type = "line"
end = [0.45, 0.15, 0.38]
[plan]
grid_points = 200
[simulate]
path_tolerance = 0.001
"""
DWELL = '[[path.segments]]\ntype = "dwell"\ntime = %s\n'


@pytest.fixture(scope="module")
def plans():
    robot = load_robot("irb140")
    home = ik(robot, np.array([0.5, 0.0, 0.5]), DOWN, np.zeros(6)).tolist()
    out = {}
    for wait in (None, 0.35):
        setup = api.load_text(CHAIN % (home, "" if wait is None else DWELL % wait))
        out[wait] = (setup, api.plan_scenario(setup))
    return out


def test_a_dwell_adds_exactly_its_time_to_the_cycle(plans):
    (_, plain), (setup, held) = plans[None], plans[0.35]
    # the dwell sits where the joint move meets the line, a stop either way: the motion is the same
    assert setup.path.dwells == ((setup.path.kinks[0], 0.35),)
    assert held.duration == pytest.approx(plain.duration + 0.35, rel=1e-12)


def test_the_robot_is_at_rest_during_the_dwell(plans):
    setup, result = plans[0.35]
    stop = setup.path.kinks[0]
    samples = result.trajectory.sample(0.002)
    waiting = np.abs(samples.theta - stop) == 0.0
    span = samples.t[waiting]
    assert span[-1] - span[0] == pytest.approx(0.35, abs=0.0041)
    assert np.all(samples.qd[waiting] == 0.0) and np.all(samples.qdd[waiting] == 0.0)
    robot = setup.robot
    q = samples.q[waiting]
    np.testing.assert_allclose(samples.tau[waiting], rnea(robot, q, 0 * q, 0 * q), atol=1e-9)  # gravity only
    np.testing.assert_allclose(fk(robot, q)[0], np.broadcast_to([0.45, 0.15, 0.45], (len(q), 3)), atol=1e-9)


def test_closed_loop_tracks_the_chain_and_waits(plans):
    setup, result = plans[0.35]
    sim = api.simulate_scenario(setup, result)
    summary = api.simulation_summary(setup, result, sim)
    assert summary["tracking_ok"], summary
    assert sim.cycle_time == pytest.approx(result.duration, abs=2 * setup.scenario.simulate.sample_time)
    stop = setup.path.kinks[0]
    arrive = float(result.profile.times[np.searchsorted(result.profile.grid, stop)]) - 0.35
    inside = (sim.t > arrive + 0.05) & (sim.t < arrive + 0.30)
    assert inside.sum() > 10
    assert np.max(np.abs(sim.qd[inside])) < 1e-2  # at rest, up to the controller's settling
    assert np.max(np.linalg.norm(sim.tcp[inside] - [0.45, 0.15, 0.45], axis=1)) < 1e-3
    assert np.max(sim.path_deviation) < 1e-3



def test_a_dwell_at_an_end_the_plan_moves_through_is_an_error(plans):
    setup, _ = plans[None]
    home = setup.scenario.path.start_configuration
    text = (CHAIN % (list(home), "")).replace("[plan]\n", DWELL % 0.1 + '[plan]\nend = "max"\n')
    with pytest.raises(ScenarioError, match=r"dwell at the path's end .* plan.end"):
        api.plan_scenario(api.load_text(text))


def test_dwells_at_the_start_and_end_wait_there(plans):
    (setup, plain) = plans[None]
    home = setup.scenario.path.start_configuration
    text = (CHAIN % (list(home), "")).replace("[[path.segments]]\ntype = \"joint\"", DWELL % 0.2 +
                                              "[[path.segments]]\ntype = \"joint\"", 1)
    text = text.replace("[plan]\n", DWELL % 0.3 + "[plan]\n")
    held_setup = api.load_text(text)
    assert held_setup.path.dwells == ((0.0, 0.2), (held_setup.path.domain[1], 0.3))
    held = api.plan_scenario(held_setup)
    assert held.duration == pytest.approx(plain.duration + 0.5, rel=1e-12)
    samples = held.trajectory.at_time(np.array([0.0, 0.1, 0.199, held.duration - 0.29, held.duration]))
    np.testing.assert_array_equal(samples.theta[:3], 0.0)
    np.testing.assert_array_equal(samples.theta[3:], held_setup.path.domain[1])
    assert np.all(samples.qd == 0.0)
