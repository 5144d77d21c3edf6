"""ABB's robconf (cf1, cf4, cf6, cfx) and IK on the branch it names, against forward kinematics and
hand-derived configurations of the IRB 140."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from pathmotion.errors import UnreachableError
from pathmotion.robot import fk, load_robot
from pathmotion.robot.robconf import cfx_margins, ik_robconf, robconf_of


@pytest.fixture(scope="module")
def robot():
    return load_robot("irb140")


def test_hand_derived_configurations(robot):
    # q = 0: wrist centre in front of axis 1 and of the lower arm, q5 = 0 counts as positive
    assert robconf_of(robot, np.zeros(6)) == (0, 0, 0, 0)
    # quadrants: 100 deg -> 1, -10 deg -> -1, -100 deg -> -2; q5 < 0 -> cfx odd
    q = np.radians([100.0, 0.0, 0.0, -10.0, -30.0, -100.0])
    assert robconf_of(robot, q) == (1, -1, -2, 1)
    # arm bent back over the top: lower arm tilted back 70 deg, upper arm folded back further
    q = np.radians([0.0, -70.0, -150.0, 0.0, 30.0, 0.0])
    assert fk(robot, q)[0][0] < 0.0  # the TCP (and wrist) is behind the base
    assert robconf_of(robot, q)[3] == 6  # behind axis 1, and behind the lower arm (folded back past it)


@settings(max_examples=30)
@given(st.lists(st.floats(-0.95, 0.95), min_size=6, max_size=6))
def test_ik_on_its_own_robconf_returns_the_configuration(robot, fractions):
    lim = robot.limits
    q = lim.lower + (np.asarray(fractions) + 1.0) / 2.0 * (lim.upper - lim.lower)
    if abs(q[4]) < 0.05:  # near the wrist singularity the wrist angles are not unique
        q[4] = 0.05 if q[4] >= 0 else -0.05
    # IK is ill-conditioned at the shoulder and elbow singularities
    assume(min(abs(m) for m in cfx_margins(robot, q)[:2]) > 1e-3)
    p, r = fk(robot, q)
    got = ik_robconf(robot, p, r, robconf_of(robot, q))
    p2, r2 = fk(robot, got)
    np.testing.assert_allclose(p2, p, atol=1e-9)
    np.testing.assert_allclose(r2, r, atol=1e-9)
    np.testing.assert_allclose(got, q, atol=1e-7)  # the branch and turns robconf names are q's own


def test_a_robconf_the_pose_does_not_have_is_an_error_listing_the_ones_it_has(robot):
    q = np.array([0.3, 0.2, 0.1, 0.4, 0.8, -0.5])
    p, r = fk(robot, q)
    with pytest.raises(UnreachableError, match=r"path.segments\[3\].*robconf \[1, 0, -1, 0\].*\[0, 0, -1, 0\]"):
        ik_robconf(robot, p, r, (1, 0, -1, 0), where="path.segments[3]")
    with pytest.raises(UnreachableError, match="cfx in 0..7"):
        ik_robconf(robot, p, r, (0, 0, 0, 9), where="target")
    with pytest.raises(UnreachableError, match="target"):
        ik_robconf(robot, np.array([3.0, 0.0, 0.5]), r, (0, 0, 0, 0), where="target")


def test_at_the_elbow_singularity_both_sides_match(robot):
    q = np.array([0.0, 0.17453293, -np.pi / 2, 0.0, 0.05, 0.0])  # upper arm in line with the lower arm
    assert abs(cfx_margins(robot, q)[1]) < 1e-12
    p, r = fk(robot, q)
    for cfx in (0, 2):
        np.testing.assert_allclose(fk(robot, ik_robconf(robot, p, r, (0, 0, 0, cfx)))[0], p, atol=1e-9)


@pytest.mark.parametrize("degrees, cfx", [
    ([-103.1, -85.03, 19.06, -70.19, -35.87, 185.01], 5),
    ([-124.68, -61.16, -20.4, 56.41, -38.79, -24.56], 5),
    ([-103.1, -85.03, 19.06, 109.81, 35.87, 5.01], 4),
    ([-124.68, -61.16, -20.4, -123.59, 38.79, 155.44], 4),
])
def test_cfx_of_published_configurations(robot, degrees, cfx):
    """Joint sets with their controller cfx from an IRB 1660 test set (py-opw-kinematics, axis_configuration.rs):
    arms leaning back over the base. The IRB 140's links put the wrist centre on the same sides (by >= 0.13 m)."""
    q = np.radians(degrees)
    assert robconf_of(robot, q)[3] == cfx
    assert min(abs(m) for m in cfx_margins(robot, q)) > 0.1
