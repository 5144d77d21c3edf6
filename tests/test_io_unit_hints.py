"""Values typed in the wrong unit get a hint naming the unit: joint speed limits in deg/s (a warning),
joint waypoints and a waypoint file's roll, pitch, yaw in degrees ("degrees?"), corner-atlas tolerances in
millimetres ("mm?")."""

import logging
import math

import pytest
from typer.testing import CliRunner

import pathmotion as pm
from pathmotion.cli import app
from pathmotion.errors import PathError, ScenarioError
from pathmotion.io.waypoints import parse_waypoints_csv

runner = CliRunner()
JOINT_DEG = 'name = "deg"\n[path]\ntype = "joint"\nwaypoints = [[0, 0, 0, 0, 30, 0], [20, 10, -10, 20, 45, 30]]\n'
JOINT = ('name = "j"\n[path]\ntype = "joint"\nwaypoints = [[0, 0, 0, 0, 0.5, 0], [0.3, 0.2, -0.2, 0.3, 0.8, 0.5]]\n'
         "[plan]\ngrid_points = 60\n")


def test_joint_speed_limits_in_degrees_per_second_are_flagged(tmp_path, caplog):
    deg = [200, 200, 260, 360, 360, 450]  # the IRB140's data sheet, deg/s
    with caplog.at_level(logging.WARNING, logger="pathmotion"):
        pm.load_text(JOINT + f"[limits]\nvelocity = {deg}\n", tmp_path)
    assert any("degrees?" in r.getMessage() and f"{math.radians(200):.4g} rad/s" in r.getMessage()
               for r in caplog.records)
    caplog.clear()
    rad = [round(math.radians(v), 4) for v in deg]
    with caplog.at_level(logging.WARNING, logger="pathmotion"):
        pm.load_text(JOINT + f"[limits]\nvelocity = {rad}\n", tmp_path)
    assert not [r for r in caplog.records if "degrees?" in r.getMessage()]
    scenario = tmp_path / "s.toml"
    scenario.write_text(JOINT + f"[limits]\nvelocity = {deg}\n")
    res = runner.invoke(app, ["check", str(scenario)])
    assert res.exit_code == 0 and "warning: limits.velocity" in res.output and "degrees?" in res.output


def test_joint_waypoints_in_degrees_get_the_hint(tmp_path):
    with pytest.raises(ScenarioError, match=r"outside its range .*degrees\? the unit is rad \(e.g. 45 deg = 0.785398"):
        pm.load_text(JOINT_DEG, tmp_path)
    # a value outside the range in radians, not degrees either way: no hint
    with pytest.raises(ScenarioError) as info:
        pm.load_text(JOINT.replace("0.8, 0.5]", "2.5, 0.5]"), tmp_path)
    assert "degrees?" not in str(info.value)


def test_roll_pitch_yaw_in_degrees_in_a_waypoint_file_get_the_hint():
    text = "x,y,z,roll,pitch,yaw\n0.5,0,0.5,180,0,0\n0.6,0,0.5,180,0,0\n"
    with pytest.raises(ScenarioError, match=r"line 2, column roll: 180 rad .*degrees\? .*180 deg = 3.14159 rad"):
        parse_waypoints_csv(text, "w.csv")
    points, rot = parse_waypoints_csv(text.replace("180", str(math.pi)), "w.csv")
    assert rot.shape == (2, 3, 3)


def test_corner_tolerances_in_millimetres_get_the_hint(tmp_path):
    from pathmotion.study.atlas import check_inputs

    with pytest.raises(PathError, match=r"mm\? the unit is m \(e.g. 5 mm = 0.005 m\)"):
        check_inputs([90], [5])
    with pytest.raises(PathError) as info:
        check_inputs([90], [-1])
    assert "mm?" not in str(info.value)
