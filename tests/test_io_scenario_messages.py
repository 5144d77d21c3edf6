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
