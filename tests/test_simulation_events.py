"""Re-timing events in the closed loop (simulation/events.py): override, stop on the path and resume.

Independent references: the planned stop distance of the re-timer (the measured one in the loop agrees with
it), the measured joint speed (zero while stopped), and the path itself (the stop's sub-path evaluates as
the path does).
"""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api, defaults
from pathmotion.errors import ScenarioError, SimulationError, StateInfeasibleError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, Retimer, plan
from pathmotion.robot import load_robot
from pathmotion.simulation import SimulationSettings, simulate
from pathmotion.simulation.events import Event, SubPath

SCENARIO = """
name = "circle_events"
[robot]
name = "irb140"
[path]
type = "task"
orientation = "down"
[[path.segments]]
type = "circle"
center = [0.5, 0.0, 0.5]
radius = 0.1
normal = [0.0, 0.0, 1.0]
[simulate]
controller = "orbital"
events = [{t = 0.3, override = 0.5}, {t = 0.6, stop = true}, {t = 1.0, resume = true}]
"""


@pytest.fixture(scope="module")
def run():
    setup = api.load_text(SCENARIO)
    result = api.plan_scenario(setup)
    return result, api.simulate_scenario(setup, result)


def test_override_stop_and_resume_are_followed_and_reported(run):
    result, sim = run
    assert sim.tracking_ok and sim.cycle_time is not None
    override, stop, resume = sim.summary()["events"]
    assert [e["kind"] for e in (override, stop, resume)] == ["override", "stop", "resume"]
    for e in (override, stop, resume):
        assert e["reaction_time_s"] is not None and 0 <= e["reaction_time_s"] < 0.5 and e["retime_ms"] > 0
    # the loop stops where the re-timer planned it (within 2 % of the stop distance), and stays there
    assert stop["stop_distance"] == pytest.approx(stop["planned_stop_distance"], rel=0.02)
    # held from the loop's 2 % settling time on, 4 / its slowest pole (the integral rate; poles of the clock play:
    # (s + integral_rate)(s^2 + 2 zeta w s + w^2))
    settle = 4.0 / defaults.ORBITAL_INTEGRAL_RATE
    still = (sim.t > 0.6 + stop["reaction_time_s"] + settle) & (sim.t < 1.0)
    assert still.any() and np.max(np.abs(sim.qd[still])) < 1e-2
    assert np.ptp(sim.theta[still]) < 1e-3 * stop["stop_distance"] + 1e-6
    # half speed from the override: the motion takes longer than the plan by at least the stop's wait
    assert sim.cycle_time > result.duration + 0.3


def test_event_needs_exactly_one_action_and_the_orbital_controller():
    with pytest.raises(SimulationError, match="exactly one"):
        Event(0.5, override=0.5, stop=True)
    with pytest.raises(SimulationError, match=r"\(0, 1\]"):
        Event(0.5, override=1.5)
    bad = SCENARIO.replace("{t = 1.0, resume = true}", "{t = 1.0, resume = true, stop = true}")
    with pytest.raises(ScenarioError, match="events"):
        api.load_text(bad)
    robot = load_robot("irb140")
    path = SplineJointPath.from_waypoints(np.random.default_rng(0).uniform(-1, 1, (3, 6)))
    res = plan(path, robot, PlanSettings(grid_points=60, verify="off"))
    with pytest.raises(SimulationError, match="orbital"):
        simulate(robot, path, res.profile, "computed_torque", SimulationSettings(events=(Event(0.1, stop=True),)),
                 retimer=Retimer(res))
    with pytest.raises(SimulationError, match="Retimer"):
        simulate(robot, path, res.profile, "orbital", SimulationSettings(events=(Event(0.1, stop=True),)))


def test_sub_path_evaluates_as_the_path():
    path = SplineJointPath.from_waypoints(np.random.default_rng(1).uniform(-1, 1, (5, 6)))
    sub = SubPath.of(path, 0.6)
    th = np.linspace(0.0, 0.6, 7)
    for a, b in zip(sub.evaluate3(th), path.evaluate3(th)):
        assert np.array_equal(a, b)
    assert sub.knots == (0.25, 0.5) and sub.domain == (0.0, 0.6)
    with pytest.raises(Exception, match="outside"):
        sub.evaluate(0.7)


def test_a_stop_at_rest_holds_until_the_resume_and_a_replay_of_the_plan_changes_nothing():
    robot = load_robot("irb140")
    path = SplineJointPath.from_waypoints(np.random.default_rng(5).uniform(-1, 1, (3, 6)))
    res = plan(path, robot, PlanSettings(limits={"use_torque": True}))
    rt = Retimer(res)
    base = simulate(robot, path, res.profile, "orbital", SimulationSettings(), retimer=rt)
    held = simulate(robot, path, res.profile, "orbital",
                    SimulationSettings(events=(Event(0.0, stop=True), Event(0.2, resume=True))), retimer=rt)
    assert held.tracking_ok and held.cycle_time == pytest.approx(base.cycle_time + 0.2, abs=0.02)
    assert np.max(np.abs(held.qd[held.t < 0.19])) < 1e-3
    # re-timing from the plan's own state mid-motion (a resume while moving, override 1) keeps the plan
    again = simulate(robot, path, res.profile, "orbital", SimulationSettings(events=(Event(0.1, resume=True),)),
                     retimer=rt)
    assert again.tracking_ok and again.cycle_time == pytest.approx(base.cycle_time, abs=0.01)


def test_an_override_from_full_speed_on_a_jerk_limited_plan_brakes_into_it():
    """A jerk-limited plan: the jerk-limited re-timer refuses override 0.5 from the plan's state at full speed
    (above the override's envelope); the event brakes into it within the second-order limits (a warning) and the
    loop follows: tracking holds, the measured path speed reaches half the plan's (reaction time reported), and
    the cycle is longer than the plan's."""
    setup = api.load_text(SCENARIO.replace(
        "events = [{t = 0.3, override = 0.5}, {t = 0.6, stop = true}, {t = 1.0, resume = true}]",
        "events = [{t = 0.3, override = 0.5}]") + "[limits]\nuse_jerk = true\n")
    result = api.plan_scenario(setup)
    theta, v, a = (float(x[0]) for x in result.profile.state_at_time(np.array([0.3])))
    with pytest.raises(StateInfeasibleError):
        Retimer(result).remaining(theta, v, a, 0.5)
    sim = api.simulate_scenario(setup, result)
    (override,) = sim.summary()["events"]
    assert sim.tracking_ok and override["reaction_time_s"] is not None and override["reaction_time_s"] < 0.5
    assert sim.cycle_time > result.duration + 0.1
