"""Shared closed-loop helpers of the control tests: the periodic thesis circle planned once, and one orbital lap
on it with a given plant (tests/test_control_observer.py, tests/test_control_payload.py)."""

from __future__ import annotations

import dataclasses

from pathmotion import api, defaults
from pathmotion.control import OrbitalGains
from pathmotion.planning import plan
from pathmotion.robot import Payload
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import Plant, Realism, SimulationSettings, simulate


def periodic_circle_plan():
    """(setup, profile) of ``circle_periodic`` planned without baselines, with accelerations of 10, 10, 12, 20, 20,
    25 rad/s^2 (a 0.980 s lap): the laps' measured figures in the tests' docstrings are for that circle, whatever the
    limits file holds."""
    setup = api.load(scenario_path("circle_periodic"), {"limits.acceleration": [10.0, 10.0, 12.0, 20.0, 20.0, 25.0]})
    return setup, plan(setup.path, setup.robot, dataclasses.replace(setup.plan_settings, baselines=False)).profile


def orbital_lap(setup, profile, realism: Realism = Realism(), identify: bool = False, believed: float = 0.0,
                gains: OrbitalGains = OrbitalGains()) -> dict:
    """One lap's summary of the orbital controller (``identify``: payload identification on; ``believed`` [kg]: the
    model carries a payload of this mass at docs/control.md's payload centre of mass that the plant lacks), path
    tolerance 0.5 m so that the lap always completes."""
    robot, plant = setup.robot, None
    if believed:
        plant = Plant.from_robot(robot, realism)
        robot = robot.with_payload(Payload(believed, defaults.REALISTIC_PAYLOAD_COM))
    settings = SimulationSettings(realism=realism, laps=1, path_tolerance=0.5, orbital_gains=gains, design_cache=False,
                                  identify_payload=identify)
    return simulate(robot, setup.path, profile, "orbital", settings, plant=plant).summary()
