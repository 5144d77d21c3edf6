"""Scenario error messages as a newcomer meets them: a typo gets the closest key, --set errors name --set,
and --set values read as TOML."""

import pytest

from pathmotion.errors import ScenarioError
from pathmotion.io.scenario import parse_scenario, parse_value
from pathmotion.scenarios import scenario_path


def _first_line(text, overrides=None):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "c.toml", overrides)
    return str(info.value).splitlines()


@pytest.mark.parametrize("scenario, old, new, expected", [
    ("circle_max", "radius = 0.1", "radus = 0.1", "c.toml: path.segments[0].radus: unknown key 'radus'; "
                                                  "did you mean 'radius'?"),
    ("corner_g2", "tolerance = ", "tolerence = ", "did you mean 'tolerance'?"),
    ("circle_max", "[plan]", "[plna]", "c.toml: plna: unknown key 'plna'; did you mean 'plan'?"),
    ("corner_g2", 'type = "line"', 'type = "line"\nendd = 1', "path.segments[1].endd: unknown key 'endd'; "
                                                             "did you mean 'end'?"),
])
def test_a_typo_gets_the_closest_key_on_the_first_line(scenario, old, new, expected):
    text = scenario_path(scenario).read_text()
    assert old in text
    lines = _first_line(text.replace(old, new, 1))
    assert expected in lines[0]
    assert not any("more)" in line for line in lines)


def test_a_key_far_from_every_allowed_one_lists_the_allowed_keys():
    lines = _first_line(scenario_path("circle_max").read_text().replace("[plan]", "[plan]\nzzzzzz = 1"))
    assert "unknown key 'zzzzzz'; allowed here: grid_points, start, end" in lines[0]


def test_every_error_is_shown_one_a_line():
    text = scenario_path("circle_max").read_text().replace("[plan]", "[plan]\ngrid_points = 'a'\nperiodic = 3")
    lines = _first_line(text)
    assert len(lines) == 2 and "plan.grid_points" in "".join(lines) and "plan.periodic" in "".join(lines)


def test_set_errors_name_set_not_the_file():
    text = scenario_path("circle_max").read_text()
    assert _first_line(text, {"plan.gird_points": 3})[0] == ("--set plan.gird_points: unknown key 'gird_points'; "
                                                             "did you mean 'grid_points'?")
    assert _first_line(text, {"plan.grid_points": "x"})[0].startswith("--set plan.grid_points: ")
    assert _first_line(text.replace("radius = 0.1", "radius = -0.1"), {"plan.grid_points": 300})[0].startswith(
        "c.toml: path.segments[0].radius")


@pytest.mark.parametrize("text, value", [
    ('"text"', "text"), ("'a b'", "a b"), ("orbital", "orbital"), ("3", 3), ("1_000", 1000), ("0.04", 0.04),
    ("1e3", 1000.0), ("1.", 1.0), ("TRUE", True), ("false", False), ("[0.5, 0, 0.5]", [0.5, 0, 0.5]),
    ("{knee = 0.5}", {"knee": 0.5}), ("0.5, 0.3", "0.5, 0.3"),
])
def test_set_values_read_as_toml_with_a_bare_word_a_string(text, value):
    out = parse_value(text)
    assert out == value and type(out) is type(value)


@pytest.mark.parametrize("text", ["nan", "inf", "-inf", "[1, 2", '"open'])
def test_set_values_that_cannot_be_meant_are_errors(text):
    with pytest.raises(ScenarioError):
        parse_value(text)


# ------------------------------------------------------------------------------------ unit slips
def _load_error(text):
    from pathmotion import api

    with pytest.raises(ScenarioError) as info:
        api.load_text(text)
    return str(info.value)


@pytest.mark.parametrize("scenario, old, new, says", [
    ("circle_max", "radius = 0.1", "radius = 100", ("path.segments[0].radius = 100", "mm? the unit is m", "0.1")),
    ("circle_max", "center = [0.5, 0.0, 0.5]", "center = [500, 0, 500]",
     ("path.segments[0].center = [500, 0, 500]", "beyond IRB140's reach", "mm? the unit is m", "[0.5, 0, 0.5]")),
    ("corner_g2", "tolerance = 0.005", "tolerance = 5", ("path.blends[0].tolerance = 5", "mm? the unit is m")),
    ("circle_max", "radius = 0.1", "radius = 0.1\nstart_angle = 90",
     ("path.segments[0].start_angle = 90 rad", "degrees? the unit is rad", "1.5708")),
    ("circle_max", '[robot]\nname = "irb140"', '[robot]\nname = "irb140"\n[robot.tool]\nrotation_rpy = [0, 0, 180]',
     ("robot.tool.rotation_rpy[2] = 180 rad", "degrees? the unit is rad")),
    ("circle_max", '[robot]\nname = "irb140"', '[robot]\nname = "irb140"\n[robot.payload]\nmass = 6.5',
     ("robot.payload.mass = 6.5 kg", "rated payload 6 kg", "the unit is kg")),
])
def test_unit_slips_are_caught_and_name_the_key(scenario, old, new, says):
    text = scenario_path(scenario).read_text()
    assert old in text
    message = _load_error(text.replace(old, new, 1))
    for part in says:
        assert part in message, (part, message)


def test_values_in_the_right_units_pass_the_slip_checks():
    """A full-turn arc, the rated payload and a point at the reach bound's edge are not slips."""
    from pathmotion import api
    from pathmotion.io.scenario import unit_slips

    setup = api.load(scenario_path("circle_max"))
    bound = api.reach_bound(setup.robot)
    import numpy as np
    from pathmotion.robot import fk

    stretched = np.linalg.norm(fk(setup.robot, np.array([0.0, 0.0, -1.5, 0.0, 0.0, 0.0]))[0])
    assert 0.8 < stretched <= bound < 2.0  # an upper bound of the reach, near the arm's size
    unit_slips(setup.scenario.model_copy(), bound, 6.0)
    text = scenario_path("circle_max").read_text().replace('[robot]\nname = "irb140"',
                                                          '[robot]\nname = "irb140"\n[robot.payload]\nmass = 6.0')
    api.load_text(text)
