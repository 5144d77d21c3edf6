"""Loading robots: the built-in IRB140 and its limits, other URDFs, bad input, pickling."""

import pickle
import tomllib
from importlib import resources

import numpy as np
import pytest

from pathmotion.errors import PathmotionError, RobotModelError
from pathmotion.robot import (
    JointLimits, Payload, Tool, builtin_robot_names, fk, has_closed_form, ik, load_robot, rnea,
)

PLANAR = """<?xml version="1.0"?>
<robot name="planar3">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.25 0 0"/><mass value="2.0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="1.5"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial></link>
  <link name="l3"><inertial><origin xyz="0.15 0 0"/><mass value="1.0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0"/><axis xyz="0 0 1"/>LIMIT</joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>LIMIT</joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 0 1"/>LIMIT</joint>
  <joint name="j3_tool0" type="fixed"><parent link="l3"/><child link="tool0"/><origin xyz="0.3 0 0"/></joint>
</robot>
"""
URDF_LIMIT = '<limit lower="-2.5" upper="2.5" effort="30" velocity="2"/>'

PLANAR_LIMITS = """
[[joints]]
name = "j1"
lower = -1.0
upper = 1.5
velocity = 1.0
acceleration = 5.0
torque = 40.0
[[joints]]
name = "j2"
lower = -2.0
upper = 2.0
velocity = 1.5
acceleration = 6.0
torque = 20.0
[[joints]]
name = "j3"
lower = -2.0
upper = 2.0
velocity = 2.0
acceleration = 7.0
torque = 10.0
"""

# ABB product specification IRB 140 (3HAC041346-001 rev Q, 2020): ranges p. 34 [deg], IRB 140 speeds
# p. 38 [deg/s]; torque limits are estimates (see irb140.md / docs/robot.md).
ABB_RANGE_DEG = [(-180, 180), (-90, 110), (-230, 50), (-200, 200), (-115, 115), (-400, 400)]
ABB_SPEED_DEG_S = [200, 200, 260, 360, 360, 450]
ESTIMATED_TORQUE = [250, 350, 120, 20, 20, 10]


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture
def planar_urdf(tmp_path):
    return write(tmp_path, "planar3.urdf", PLANAR.replace("LIMIT", URDF_LIMIT))


# ------------------------------------------------------------------------------------------------
# Built-in robot


def test_builtin_names():
    assert "irb140" in builtin_robot_names()


def test_builtin_limits_match_abb_table():
    lim = load_robot("irb140").limits
    np.testing.assert_allclose(np.degrees(lim.lower), [r[0] for r in ABB_RANGE_DEG], atol=1e-8)
    np.testing.assert_allclose(np.degrees(lim.upper), [r[1] for r in ABB_RANGE_DEG], atol=1e-8)
    np.testing.assert_allclose(np.degrees(lim.velocity), ABB_SPEED_DEG_S, atol=1e-8)
    np.testing.assert_allclose(lim.torque, ESTIMATED_TORQUE)
    assert lim.acceleration is not None and np.all(lim.acceleration > 0)


def test_every_builtin_limit_figure_is_marked_official_or_estimate():
    doc = tomllib.loads((resources.files("pathmotion.robot") / "data" / "irb140_limits.toml").read_text())
    for joint in doc["joints"]:
        src = joint["sources"]
        assert set(src) == {"range", "velocity", "acceleration", "torque", "jerk", "torque_rate", "armature"}, joint["name"]
        assert src["range"] == "official" and src["velocity"] == "official"
        assert src["acceleration"] == "estimate" and src["torque"] == "estimate" and src["armature"] == "estimate"
    lim = load_robot("irb140").limits
    assert lim.sources["joint_1"]["torque"] == "estimate"


def test_builtin_arm_mass_is_abbs_98_kg():
    model = load_robot("irb140").model
    moving = sum(model.inertias[j].mass for j in range(1, model.njoints))
    base = 26.36  # base link mass of the CAD-derived model (irb140.md), fixed to the universe
    assert moving + base == pytest.approx(98.0, abs=0.05)


# ------------------------------------------------------------------------------------------------
# Other URDFs


def test_planar_urdf_with_its_own_limits_file(tmp_path, planar_urdf):
    limits = write(tmp_path, "planar_limits.toml", PLANAR_LIMITS)
    arm = load_robot(planar_urdf, limits)
    assert arm.n == 3 and arm.joint_names == ("j1", "j2", "j3")
    np.testing.assert_allclose(arm.limits.upper, [1.5, 2.0, 2.0])
    np.testing.assert_allclose(arm.limits.acceleration, [5.0, 6.0, 7.0])
    assert arm.flange_frame == "tool0"
    assert not has_closed_form(arm)
    # analytic planar forward kinematics
    q = np.array([0.3, -0.7, 1.1])
    pos, rot = fk(arm, q)
    c = np.cumsum(q)
    np.testing.assert_allclose(pos, [0.5 * np.cos(c[0]) + 0.4 * np.cos(c[1]) + 0.3 * np.cos(c[2]),
                                     0.5 * np.sin(c[0]) + 0.4 * np.sin(c[1]) + 0.3 * np.sin(c[2]), 0.0], atol=1e-12)
    # IK of a 3-joint arm falls back to damped least squares
    np.testing.assert_allclose(ik(arm, pos, rot, q + 0.1), q, atol=1e-8)


def test_limits_come_from_the_urdf_when_no_file_is_given(planar_urdf):
    arm = load_robot(planar_urdf)
    np.testing.assert_allclose(arm.limits.lower, [-2.5] * 3)
    np.testing.assert_allclose(arm.limits.velocity, [2.0] * 3)
    np.testing.assert_allclose(arm.limits.torque, [30.0] * 3)
    assert arm.limits.acceleration is None


def test_urdf_without_limits_and_no_file_names_the_joints(tmp_path):
    path = write(tmp_path, "nolimits.urdf", PLANAR.replace("LIMIT", ""))
    with pytest.raises(RobotModelError, match=r"joints \['j1', 'j2', 'j3'\] have no <limit>"):
        load_robot(path)


def test_urdf_without_limits_with_a_limits_file_loads(tmp_path):
    path = write(tmp_path, "nolimits.urdf", PLANAR.replace("LIMIT", ""))
    arm = load_robot(path, write(tmp_path, "lim.toml", PLANAR_LIMITS))
    np.testing.assert_allclose(arm.limits.torque, [40.0, 20.0, 10.0])


def test_urdf_with_zero_velocity_and_effort_names_what_is_missing(tmp_path):
    path = write(tmp_path, "zero.urdf", PLANAR.replace("LIMIT", '<limit lower="-1" upper="1" effort="0" velocity="0"/>'))
    with pytest.raises(RobotModelError, match=r"limits missing for j1: velocity, j1: effort"):
        load_robot(path)


def test_malformed_urdf(tmp_path):
    with pytest.raises(RobotModelError, match="not well-formed XML"):
        load_robot(write(tmp_path, "broken.urdf", PLANAR.replace("</robot>", "")))
    with pytest.raises(RobotModelError, match="cannot be parsed"):
        load_robot(write(tmp_path, "nolinks.urdf", '<robot name="x"><joint name="j" type="weird"/></robot>'))


def test_unknown_robot_name():
    with pytest.raises(RobotModelError, match="neither a built-in robot"):
        load_robot("irb9999")


def test_limits_file_with_wrong_number_of_joints(tmp_path, planar_urdf):
    two = PLANAR_LIMITS[: PLANAR_LIMITS.rindex("[[joints]]")]
    with pytest.raises(RobotModelError, match=r"2 \[\[joints\]\] entries, but the robot has 3 joints"):
        load_robot(planar_urdf, write(tmp_path, "two.toml", two))


@pytest.mark.parametrize("old, new, message", [
    ("velocity = 1.5", "velocity = -1.5", "velocity of j2 is -1.5"),
    ("torque = 10.0", "torque = 0.0", "torque of j3 is 0"),
    ("lower = -1.0", "lower = 2.0", "j1 has lower 2 >= upper 1.5"),
    ("lower = -1.0", "lower = nan", "NaN"),
    ('name = "j3"', 'name = "j9"', "'j9', not a joint"),
    ("torque = 40.0", 'torque = "40"', "is not a number"),
    ("acceleration = 6.0\n", "", "acceleration given for some joints but not for"),
])
def test_bad_limits_files(tmp_path, planar_urdf, old, new, message):
    assert old in PLANAR_LIMITS
    path = write(tmp_path, "bad.toml", PLANAR_LIMITS.replace(old, new, 1))
    with pytest.raises(RobotModelError, match=message.replace("[", r"\[").replace("(", r"\(")):
        load_robot(planar_urdf, path)


def test_invalid_toml_and_missing_file(tmp_path, planar_urdf):
    with pytest.raises(RobotModelError, match="not valid TOML"):
        load_robot(planar_urdf, write(tmp_path, "x.toml", "[[joints]\nname ="))
    with pytest.raises(RobotModelError, match="does not exist"):
        load_robot(planar_urdf, tmp_path / "missing.toml")


def test_limits_object_for_other_joints_is_rejected(planar_urdf):
    lim = JointLimits(names=("a", "b", "c"), lower=[-1] * 3, upper=[1] * 3, velocity=[1] * 3, torque=[1] * 3)
    with pytest.raises(RobotModelError, match="limits are for joints"):
        load_robot(planar_urdf, lim)


def test_bad_payload_and_tool():
    with pytest.raises(RobotModelError, match="mass"):
        Payload(mass=-1.0)
    with pytest.raises(PathmotionError, match="NaN"):
        Payload(mass=1.0, com=(0.0, np.nan, 0.0))
    with pytest.raises(RobotModelError, match="not a proper rotation"):
        Tool(rotation=((1, 0, 0), (0, 1, 0), (0, 0, -1)))


# ------------------------------------------------------------------------------------------------
# Pickling


def test_robot_pickles_to_an_equal_model():
    robot = load_robot("irb140", payload=Payload(mass=3.0, com=(0.0, 0.0, 0.05)),
                       tool=Tool(translation=(0.0, 0.0, 0.1)))
    robot.model  # build the cached model before pickling: it must not travel in the pickle
    copy = pickle.loads(pickle.dumps(robot))
    for key in ("name", "urdf_text", "flange_frame", "payload", "tool", "gravity"):
        assert getattr(copy, key) == getattr(robot, key)
    for key in ("lower", "upper", "velocity", "torque", "acceleration"):
        np.testing.assert_array_equal(getattr(copy.limits, key), getattr(robot.limits, key))
    assert copy.limits.sources == robot.limits.sources
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, (3, 6))
    np.testing.assert_array_equal(rnea(copy, q, qd, qdd), rnea(robot, q, qd, qdd))
    np.testing.assert_array_equal(fk(copy, q)[0], fk(robot, q)[0])
    assert has_closed_form(copy)
    assert len(pickle.dumps(robot)) < 20_000  # URDF text and parameters only
