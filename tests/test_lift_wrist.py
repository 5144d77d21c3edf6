"""Wrist singularity (q5 = 0) in the lift: straight lines with a fixed tool orientation through it are
lifted on the smooth branch (q5 changes sign, q4 and q6 continuous), planned and verified; a line that
misses it by a little needs a wrist flip and is refused with a tool rotation that is checked to work.

Independent references: forward kinematics (the lift reaches the path), finite differences of Phi
(derivatives), finite differences of the raw closed-form IK away from q5 = 0 (the window fit at the
crossing), the symmetry of the line through the zero pose (q4 = -q6 = +-pi/2 there), a fresh lift of the
suggested tool rotation."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pathmotion import api, defaults
from pathmotion.lift.constraint import lift
from pathmotion.errors import UnreachableError
from pathmotion.geometry import FixedOrientation, Line, TaskPath
from pathmotion.planning import effective_limits, limit_ratios
from pathmotion.robot import fk
from pathmotion.robot.ik import ik_nearest
from pathmotion.lift.wrist_crossing import signed_t5


def through(robot, q_singular, direction, half):
    """A line of length 2 * half [m] with the tool orientation of q_singular (q5 = 0), centred on its TCP."""
    p, r = fk(robot, np.asarray(q_singular, float))
    v = np.asarray(direction, float) / np.linalg.norm(direction)
    return TaskPath((Line(p - half * v, p + half * v),), FixedOrientation(r))


#: The fuzzer's example (q4 = 90 deg, q6 = -90 deg held while q5 passes 0): a line along y through the
#: zero pose; the old refused test's vertical line through it; a line in a general direction through a
#: general singular configuration (q4 moves while q5 passes 0).
LINES = {
    "fuzzer": lambda robot: through(robot, np.zeros(6), (0, 1, 0), 0.05),
    "vertical": lambda robot: TaskPath((Line((0.515, 0.0, 0.65), (0.515, 0.0, 0.78)),),
                                       FixedOrientation(fk(robot, np.zeros(6))[1])),
    "general": lambda robot: through(robot, [0.3, 0.2, -0.4, 0.7, 0.0, -0.2], (0.3, 0.5, -0.2), 0.06),
}


@pytest.fixture(scope="module", params=sorted(LINES))
def crossing(request, irb140):
    task = LINES[request.param](irb140)
    return request.param, task, lift(irb140, task)


def test_the_line_crosses_q5_zero_on_the_smooth_branch(crossing, irb140):
    _, task, path = crossing
    (ps,) = path.check.wrist_passages
    assert ps.crossed and ps.min_abs_q5 <= defaults.WRIST_CROSSING_TOLERANCE
    assert path.wrist_windows and path.check.min_singular_value < 1e-12  # really through the singularity
    theta = np.unique(np.concatenate([np.linspace(*task.domain, 20_001), [ps.theta]]))
    q, dq, _ = path.evaluate(theta)
    t5 = signed_t5(irb140, q)
    assert t5[0] * t5[-1] < 0  # q5 changes sign ...
    step = np.abs(np.diff(q, axis=0))  # ... and every joint moves continuously (no pi jump of q4, q6)
    bound = np.maximum(np.abs(dq[:-1]), np.abs(dq[1:])) * np.diff(theta)[:, None] * 1.01 + 1e-9
    assert np.all(step <= bound)
    pos, rot = fk(irb140, q)
    p_task, _, _, r_task, _, _ = task.pose(theta)
    assert np.abs(pos - p_task).max() < 1e-9 and np.abs(rot - r_task).max() < 1e-9


def test_the_fuzzer_line_holds_q4_and_q6_at_ninety_degrees(irb140):
    # by symmetry the smooth branch's split at q5 = 0 is q4 = -q6 = +-pi/2 (the wrist axis moves along y)
    path = lift(irb140, LINES["fuzzer"](irb140))
    (ps,) = path.check.wrist_passages
    q = path.evaluate(ps.theta)[0]
    assert abs(abs(q[3]) - np.pi / 2) < 1e-9 and abs(q[3] + q[5]) < 1e-9
    assert (ps.q4, ps.q6) == pytest.approx((q[3], q[5]), abs=1e-12)


def test_derivatives_match_central_differences_through_the_crossing(crossing):
    _, task, path = crossing
    lo, hi = task.domain
    h = 1e-5
    theta = np.linspace(lo + 3 * h, hi - 3 * h, 1501)
    q, dq, ddq, dddq = path.evaluate3(theta)
    qp, dqp, ddqp = path.evaluate(theta + h)
    qm, dqm, ddqm = path.evaluate(theta - h)
    np.testing.assert_allclose(dq, (qp - qm) / (2 * h), atol=1e-7 * max(1.0, np.abs(dq).max()))
    np.testing.assert_allclose(ddq, (dqp - dqm) / (2 * h), atol=1e-5 * max(1.0, np.abs(ddq).max()))
    np.testing.assert_allclose(dddq, (ddqp - ddqm) / (2 * h), atol=1e-3 * max(1.0, np.abs(dddq).max()))
    # evaluate and evaluate3 agree
    for a, b in zip(path.evaluate(theta), (q, dq, ddq)):
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_window_derivative_at_the_crossing_matches_the_raw_closed_form(crossing, irb140):
    # Phi'(theta*) from the window fit against a 4th-order difference of the closed-form IK itself at
    # theta* +- h, +- 2h, where |q5| ~ 1e-3 and the IK is regular (it never evaluates q5 = 0)
    _, task, path = crossing
    (ps,) = path.check.wrist_passages
    h = 5e-4
    stencil = ps.theta + h * np.array([-2.0, -1.0, 1.0, 2.0])
    p, _, _, rot, _, _ = task.pose(stencil)
    q = ik_nearest(irb140, p, rot, path.evaluate(stencil)[0])
    fd = (q[0] - 8 * q[1] + 8 * q[2] - q[3]) / (12 * h)
    dq = path.evaluate(ps.theta)[1]
    np.testing.assert_allclose(dq, fd, atol=1e-6 * max(1.0, np.abs(dq).max()))


def test_speed_cost_is_the_velocity_limit_bound_in_the_passage(crossing, irb140):
    _, task, path = crossing
    (ps,) = path.check.wrist_passages
    dq = path.evaluate(ps.speed_limit_theta)[1]
    j = irb140.joint_names.index(ps.speed_limit_joint)
    assert ps.speed_limit == pytest.approx(irb140.limits.velocity[j] / abs(dq[j]), rel=1e-12)
    theta = np.linspace(*ps.region, 201)
    with np.errstate(divide="ignore"):  # a joint at rest (Phi_j = 0) does not bound the speed
        bound = np.min(irb140.limits.velocity / np.abs(path.evaluate(theta)[1]), axis=1)
    assert ps.speed_limit <= bound.min() * (1 + 1e-3)  # the reported bound is the passage's smallest
    summary = ps.summary()
    assert summary["crossed"] is True and summary["speed_limit_joint"] == ps.speed_limit_joint


def test_the_fuzzer_line_plans_and_verifies_through_the_scenario(irb140):
    rot = fk(irb140, np.zeros(6))[1]
    text = (f'name = "wrist_crossing"\n[path]\ntype = "task"\norientation = {np.round(rot, 12).tolist()}\n'
            '[[path.segments]]\ntype = "line"\nstart = [0.515, -0.05, 0.712]\nend = [0.515, 0.05, 0.712]\n')
    setup = api.load_text(text)
    result = api.plan_scenario(setup)
    assert api.plan_failures(result) == []
    ratios = limit_ratios(result.trajectory, effective_limits(setup.robot, result.settings), 2.5e-5)
    assert ratios.max_ratio <= 1 + result.settings.limit_tolerance
    summary = api.plan_summary(setup, result)
    (entry,) = summary["wrist_singularity_crossings"]
    assert entry["crossed"] and entry["theta"] == pytest.approx(0.05, abs=1e-9)
    assert 0 < entry["planned_speed_m_s"] <= entry["speed_limit_m_s"] * (1 + 1e-3)
    # the executed motion is continuous through the crossing: every joint step per 1 ms sample stays
    # below its velocity limit x 1 ms (a pi flip of q4/q6 would take one sample)
    samples = result.trajectory.sample(1e-3)
    assert np.all(np.abs(np.diff(samples.q, axis=0)) <= irb140.limits.velocity * 1e-3 * (1 + 2e-3))
    pos, _ = fk(irb140, samples.q)
    assert np.abs(pos[:, [0, 2]] - [0.515, 0.712]).max() < 1e-9  # on the line


def flip_line(robot, dz):
    """The fuzzer line shifted up by dz [m]: it misses the singularity by about dz / 0.38 rad."""
    p, r = fk(robot, np.zeros(6))
    return TaskPath((Line(p + (0, -0.05, dz), p + (0, 0.05, dz)),), FixedOrientation(r))


@pytest.mark.parametrize("dz", [1e-9, 1e-3])
def test_a_near_miss_needs_a_flip_and_the_suggested_tool_rotation_avoids_it(irb140, dz):
    task = flip_line(irb140, dz)
    with pytest.raises(UnreachableError, match=r"theta = 0\.0500 m \(segment 1\).*wrist flip") as info:
        lift(irb140, task)
    msg = str(info.value)
    assert "\n" not in msg and info.value.reason == "singular"
    assert "which no choice of wrist branch avoids" in msg
    found = re.search(r"rotating the tool frame by ([+-]\d+) deg about its own ([xyz]) axis", msg)
    assert found, msg
    angle, axis = int(found.group(1)), "xyz".index(found.group(2))
    tilt = Rotation.from_rotvec(np.radians(angle) * np.eye(3)[axis]).as_matrix()
    rotated = TaskPath(task.segments, FixedOrientation(task.tool_orientation.rotation @ tilt))
    path = lift(irb140, rotated)  # the suggestion works: lifted, and clear of the singularity
    q = path.evaluate(np.linspace(*rotated.domain, 2001))[0]
    assert np.min(np.abs(np.sin(signed_t5(irb140, q)))) >= defaults.WRIST_CLEARANCE * (1 - 1e-6)
    assert not path.check.wrist_passages or all(not p.crossed for p in path.check.wrist_passages)
    if angle > 1:  # it is the smallest such rotation (1 deg steps): one degree less does not clear
        smaller = Rotation.from_rotvec(np.radians(angle - np.sign(angle)) * np.eye(3)[axis]).as_matrix()
        other = TaskPath(task.segments, FixedOrientation(task.tool_orientation.rotation @ smaller))
        try:
            q = lift(irb140, other).reference_q
        except UnreachableError:
            return
        assert np.min(np.abs(np.sin(signed_t5(irb140, q)))) < defaults.WRIST_CLEARANCE


def test_a_wider_miss_is_planned_slowly_and_its_speed_cost_reported(irb140):
    # 5 mm above: q5 stays >= 0.013 rad, q4 turns by ~2.9 rad, the joint-4 velocity limit binds there
    path = lift(irb140, flip_line(irb140, 0.005))
    (ps,) = path.check.wrist_passages
    assert not ps.crossed and ps.min_abs_q5 == pytest.approx(0.0132, rel=0.02)
    assert abs(ps.q4_turn) > 2.5 and ps.speed_limit_joint == "joint_4"
    assert ps.speed_cost > 0.9  # the passage costs over 90 % of the speed its edges allow
    assert not path.wrist_windows


def test_a_path_starting_at_the_singularity_leaves_it_smoothly(irb140):
    # the reference's first point is exactly singular: its q4/q6 split is the path's limit, not q_start's
    p, r = fk(irb140, np.zeros(6))
    task = TaskPath((Line(p, p + (0.0, 0.06, 0.0)),), FixedOrientation(r))
    path = lift(irb140, task)
    theta = np.linspace(*task.domain, 4001)
    q, dq, _ = path.evaluate(theta)
    assert np.abs(fk(irb140, q)[0] - task.pose(theta)[0]).max() < 1e-9
    step = np.abs(np.diff(q, axis=0))
    assert np.all(step <= np.maximum(np.abs(dq[:-1]), np.abs(dq[1:])) * np.diff(theta)[:, None] * 1.01 + 1e-9)
    assert abs(abs(q[0, 3]) - np.pi / 2) < 1e-6  # the limit along y, as on the line through the pose


def test_a_corner_at_the_singularity_needing_a_wrist_turn_at_rest_is_refused(irb140):
    # arrive along y, leave along z: the two sides reach q5 = 0 with q4 = +-pi/2 and q4 = 0 (or pi)
    p, r = fk(irb140, np.zeros(6))
    task = TaskPath((Line(p - (0.0, 0.04, 0.0), p), Line(p, p + (0.0, 0.0, 0.04))), FixedOrientation(r))
    with pytest.raises(UnreachableError, match=r"theta = 0\.0400 m .*corner exactly at the wrist singularity.*"
                                               r"q4 would have to jump.*rotating the tool frame by") as info:
        lift(irb140, task)
    assert "\n" not in str(info.value)


def test_a_loop_through_the_singularity_ends_on_the_other_wrist_branch_and_is_not_closed(irb140):
    # a horizontal circle starting at the zero pose: the wrist branch differs at its two ends (q4 + pi,
    # q6 - pi: the same pose), so the joint path is open (a periodic plan would jump there)
    p, r = fk(irb140, np.zeros(6))
    from pathmotion.geometry import horizontal_circle

    task = horizontal_circle(centre=tuple(p - (0.05, 0.0, 0.0)), radius=0.05, orientation=FixedOrientation(r))
    assert task.closed
    path = lift(irb140, task)
    ends = path.evaluate(np.array(task.domain))[0]
    assert abs(abs(ends[1, 3] - ends[0, 3]) - np.pi) < 1e-5  # really the other wrist branch
    assert np.abs(fk(irb140, ends)[0][1] - fk(irb140, ends)[0][0]).max() < 1e-9  # at the same pose
    assert not path.closed
    assert lift(irb140, horizontal_circle()).closed  # an ordinary loop still closes
