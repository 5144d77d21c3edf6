"""Joint moves chained with task segments on one path coordinate (pathmotion/lift/chain.py, joint_move.py),
against finite differences, an independent arc length, forward kinematics and the scenario's errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from pathmotion import api, defaults
from pathmotion.errors import PathError, PathmotionError, ScenarioError, UnreachableError
from pathmotion.lift.chain import JointMove, lift_chain
from pathmotion.lift.joint_move import PiecewiseJointPath, tcp_arc_length
from pathmotion.robot import fk, ik, jacobian, load_robot
from pathmotion.robot.robconf import has_robconf, robconf_of

DOWN = np.array(defaults.TOOL_DOWN_ROTATION)


@pytest.fixture(scope="module")
def robot():
    return load_robot("irb140")


@pytest.fixture(scope="module")
def home(robot):
    return ik(robot, np.array([0.5, 0.0, 0.5]), DOWN, np.zeros(6))


def scenario(home, segments: str, blends: str = "", extra: str = "") -> str:
    return (f'name = "joint_moves"\n[path]\ntype = "task"\nstart_configuration = {np.asarray(home).tolist()}\n'
            f"{extra}{segments}{blends}")


MIXED = """
[[path.segments]]
type = "joint"
end_pose = {position = [0.45, 0.2, 0.45], quaternion = [0, 1, 0, 0], robconf = [0, 0, 2, 0]}
[[path.segments]]
type = "line"
end = [0.45, 0.3, 0.45]
[[path.segments]]
type = "line"
end = [0.35, 0.3, 0.45]
[[path.segments]]
type = "joint"
end = %s
"""
ZONES = """
[[path.blends]]
corner = 1
type = "g2"
tolerance = 0.01
[[path.blends]]
corner = 2
type = "g2"
tolerance = 0.005
[[path.blends]]
corner = 3
type = "g2"
tolerance = 0.02
"""


@pytest.fixture(scope="module")
def mixed(home):
    return api.load_text(scenario(home, MIXED % np.asarray(home).tolist())).path


@pytest.fixture(scope="module")
def zoned(home):
    return api.load_text(scenario(home, MIXED % np.asarray(home).tolist(), ZONES)).path


def _joint_range(path: PiecewiseJointPath, k: int = 0):
    piece = [p for p in path.pieces if p.kind == "joint"][k]
    return piece.lo, piece.hi, piece


def test_the_joint_move_is_exactly_linear_in_the_joints(robot, home, mixed):
    lo, hi, piece = _joint_range(mixed)
    theta = np.linspace(lo, hi, 101)
    q = mixed.evaluate(theta, side="left")[0]
    end = ik(robot, np.array([0.45, 0.2, 0.45]), DOWN, home)
    # independent of the implementation: the straight joint line between its two ends, at the theta fraction
    expected = home + ((theta - lo) / (hi - lo))[:, None] * (end - home)
    np.testing.assert_allclose(q, expected, atol=1e-14)
    _, d1, d2, d3 = mixed.evaluate3(theta[1:-1])
    np.testing.assert_allclose(d1, np.broadcast_to((end - home) / (hi - lo), d1.shape), rtol=1e-13)
    assert np.all(d2 == 0.0) and np.all(d3 == 0.0)


def test_its_theta_length_is_the_tcp_arc_length(robot, home, mixed):
    lo, hi, piece = _joint_range(mixed)
    end = piece.path.q1
    # independent: a polyline through 200001 FK points, refined by Richardson extrapolation (error ~ h^2)
    def polyline(count):
        u = np.linspace(0.0, 1.0, count)[:, None]
        p = fk(robot, home + u * (end - home))[0]
        return np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))
    coarse, fine = polyline(100001), polyline(200001)
    reference = fine + (fine - coarse) / 3.0
    assert hi - lo == pytest.approx(reference, rel=1e-10)
    assert tcp_arc_length(robot, home, end) == hi - lo


@pytest.mark.parametrize("which", ["mixed", "zoned"])
def test_phi_derivatives_match_finite_differences(request, which):
    path = request.getfixturevalue(which)
    stops = np.array(sorted(set(path.breaks) | {path.domain[0], path.domain[1]}))
    theta = np.linspace(*path.domain, 400)
    h = 1e-4
    theta = theta[np.min(np.abs(theta[:, None] - stops[None]), axis=1) > 3 * h]  # each stencil on one piece
    got = path.evaluate3(theta)
    at = [path.evaluate3(theta + k * h) for k in (-2, -1, 1, 2)]
    for k, tol in ((1, 1e-9), (2, 1e-7), (3, 1e-5)):  # five-point central differences: error ~ h^4
        fd = (at[0][k - 1] - 8 * at[1][k - 1] + 8 * at[2][k - 1] - at[3][k - 1]) / (12 * h)
        scale = max(1.0, np.max(np.abs(got[k])))
        assert np.max(np.abs(fd - got[k])) <= tol * scale, k


def test_zone_blends_are_c2_and_remove_the_stops(mixed, zoned):
    assert len(mixed.kinks) == 3  # joint -> line, the line corner, line -> joint
    assert zoned.kinks == ()
    for piece in zoned.pieces:
        if piece.kind != "blend":
            continue
        for end in (piece.lo, piece.hi):
            left, right = zoned.evaluate(end, side="left"), zoned.evaluate(end, side="right")
            for a, b in zip(left, right):
                np.testing.assert_allclose(a, b, atol=1e-9 * max(1.0, np.max(np.abs(a))))


def test_zone_blends_keep_the_tcp_within_their_tolerance(robot, zoned):
    sharp = zoned.original_task_path
    assert sharp is not None
    for piece, tol in zip([p for p in zoned.pieces if p.kind == "blend"], (0.01, 0.005, 0.02)):
        theta = np.linspace(piece.lo, piece.hi, 801)
        tcp = fk(robot, zoned.evaluate(theta)[0])[0]
        # independent: the exact closest point over every segment of the sharp path (FK traces included)
        distance = np.min([seg.closest(tcp)[1] for seg in sharp.segments], axis=0)
        assert np.max(distance) <= tol * (1 + 1e-6)
        assert np.max(distance) > 0.05 * tol  # a blend, not the sharp path


def test_tcp_trace_is_the_forward_kinematics_of_phi(robot, zoned):
    theta = np.linspace(*zoned.domain, 997)
    np.testing.assert_allclose(zoned.task_path.evaluate(theta)[0], fk(robot, zoned.evaluate(theta)[0])[0], atol=1e-9)


def test_a_joint_move_chains_back_into_a_task_run_on_its_branch(robot, home):
    text = scenario(home, """
[[path.segments]]
type = "line"
start = [0.5, 0.0, 0.5]
end = [0.5, 0.1, 0.5]
[[path.segments]]
type = "joint"
end_pose = {position = [0.45, 0.2, 0.45], quaternion = [0, 1, 0, 0]}
[[path.segments]]
type = "line"
end = [0.45, 0.2, 0.35]
""")
    path = api.load_text(text).path
    kinds = [p.kind for p in path.pieces]
    assert kinds == ["task", "joint", "task"]
    np.testing.assert_allclose(fk(robot, path.evaluate(path.domain[1])[0])[0], [0.45, 0.2, 0.35], atol=1e-9)


@pytest.mark.parametrize("segments, error, match", [
    ('[[path.segments]]\ntype = "joint"\nend_pose = {position = [0.45, 0.2, 0.45], quaternion = [0, 1, 0, 0], '
     'robconf = [2, 0, 0, 0]}\n', UnreachableError, r"path.segments\[0\]: no IK solution .* robconf \[2, 0, 0, 0\]"),
    ('[[path.segments]]\ntype = "joint"\nend = [0.1, 0.2, 0.3]\n', PathmotionError,
     r"path.segments\[0\]: 3 joint values"),
    ('[[path.segments]]\ntype = "joint"\nend = [0.1, 0.2, 9.0, 0, 0, 0]\n', PathmotionError,
     r"path.segments\[0\]: joint joint_3 = 9 rad is outside"),
    ('[[path.segments]]\ntype = "joint"\nend = [0.3, 0.2, 0.1, 0.0, 1.0, 0.0]\n[[path.segments]]\ntype = "line"\n'
     'end = [0.4, 0.1, 0.4]\n', PathError, r"path.segments\[1\]: the task path does not start where .* orientation"),
    ('[[path.segments]]\ntype = "dwell"\ntime = 1.0\n', PathError, "no motion"),
])
def test_bad_joint_moves_are_errors_naming_the_segment(home, segments, error, match):
    with pytest.raises(error, match=match):
        api.load_text(scenario(home, segments))


def test_a_joint_move_needs_a_start(home):
    text = scenario(home, '[[path.segments]]\ntype = "joint"\nend = [0.3, 0.2, 0.1, 0.0, 1.0, 0.0]\n')
    text = text.replace(f"start_configuration = {np.asarray(home).tolist()}\n", "")
    with pytest.raises(PathError, match=r"path.segments\[0\].*start_configuration"):
        api.load_text(text)


def test_a_zero_length_joint_move_and_a_blend_at_a_dwell_are_errors(home):
    same = f'[[path.segments]]\ntype = "joint"\nend = {np.asarray(home).tolist()}\n'
    with pytest.raises(PathError, match=r"path.segments\[0\]: the joint move ends where it starts"):
        api.load_text(scenario(home, same))
    dwell = MIXED.replace('[[path.segments]]\ntype = "line"', '[[path.segments]]\ntype = "dwell"\ntime = 0.1\n'
                          '[[path.segments]]\ntype = "line"', 1) % np.asarray(home).tolist()
    with pytest.raises(ScenarioError, match=r"path.blends\[0\]: corner 1 is at a dwell"):
        api.load_text(scenario(home, dwell, '[[path.blends]]\ncorner = 1\ntype = "g2"\ntolerance = 0.01\n'))


def test_a_reorientation_in_place_gets_a_theta_length(robot, home):
    turned = np.asarray(home).copy()
    turned[5] -= 0.5  # the tool turns about its own axis: the TCP stays
    path = api.load_text(scenario(home, f'[[path.segments]]\ntype = "joint"\nend = {turned.tolist()}\n')).path
    assert path.length == pytest.approx(0.1 * 0.5)
    np.testing.assert_allclose(path.evaluate(path.domain[1])[0], turned, atol=1e-15)


def test_corner_all_zones_every_joint_connection_but_a_dwell(home):
    dwell = MIXED.replace('type = "joint"\nend = %s', 'type = "dwell"\ntime = 0.2\n[[path.segments]]\n'
                          'type = "joint"\nend = %s') % np.asarray(home).tolist()
    path = api.load_text(scenario(home, dwell, '[[path.blends]]\ncorner = "all"\ntype = "g2"\ntolerance = 0.01\n')).path
    assert [p.kind for p in path.pieces] == ["joint", "blend", "task", "joint"]
    assert len(path.kinks) == 1 and path.dwells == ((path.kinks[0], 0.2),)
    assert path.pieces[2].path.original_task_path is not None  # the line corner got its G2 blend


def test_an_unreachable_task_run_names_its_segments(home):
    far = MIXED.replace("end = [0.35, 0.3, 0.45]", "end = [1.5, 0.3, 0.45]") % np.asarray(home).tolist()
    with pytest.raises(UnreachableError, match=r"path.segments\[1..2\] \(theta and segment counted from its start\)"):
        api.load_text(scenario(home, far))


def test_a_pose_target_is_reached_exactly(robot, mixed):
    lo, hi, piece = _joint_range(mixed)
    p, r = fk(robot, mixed.evaluate(hi, side="left")[0])
    np.testing.assert_allclose(p, [0.45, 0.2, 0.45], atol=1e-8)  # 0.01 um
    angle = np.arccos(np.clip((np.trace(r.T @ DOWN) - 1.0) / 2.0, -1.0, 1.0))
    assert angle < np.radians(1e-6)
    assert has_robconf(robot, piece.path.q1, (0, 0, 2, 0))
    assert robconf_of(robot, piece.path.q1) == (0, 0, 2, 0)  # q4 = -0.0 counts in quadrant 0


@settings(max_examples=8)
@given(st.lists(st.floats(-0.8, 0.8), min_size=12, max_size=12))
def test_tcp_arc_length_against_a_refined_polyline(robot, values):
    lim = robot.limits
    q0 = 0.5 * (lim.lower + lim.upper) + 0.5 * np.asarray(values[:6]) * (lim.upper - lim.lower)
    q1 = 0.5 * (lim.lower + lim.upper) + 0.5 * np.asarray(values[6:]) * (lim.upper - lim.lower)

    def polyline(count):
        p = fk(robot, q0 + np.linspace(0.0, 1.0, count)[:, None] * (q1 - q0))[0]
        return np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))

    coarse, fine = polyline(20001), polyline(40001)
    assert tcp_arc_length(robot, q0, q1) == pytest.approx(fine + (fine - coarse) / 3.0, rel=1e-8, abs=1e-12)


def test_the_chain_check_covers_every_piece(robot, mixed):
    check = mixed.check
    theta = np.linspace(*mixed.domain, 4001)
    q = mixed.evaluate(theta)[0]
    sv = np.linalg.svd(jacobian(robot, q), compute_uv=False)[:, -1]
    margin = np.minimum(q - robot.limits.lower, robot.limits.upper - q)
    # independent: the same minima on a dense grid of the whole chain (the check samples every 2 mm)
    assert check.min_singular_value == pytest.approx(np.min(sv), abs=1e-3)
    assert check.min_singular_theta == pytest.approx(theta[np.argmin(sv)], abs=5e-3)
    assert check.range_margin == pytest.approx(np.min(margin), abs=1e-3)
    assert check.kinks == mixed.kinks


def test_a_dwell_between_lines_stops_and_continues_on_the_branch(robot, home):
    text = scenario(home, """
[[path.segments]]
type = "line"
end = [0.5, 0.1, 0.5]
[[path.segments]]
type = "dwell"
time = 0.5
[[path.segments]]
type = "line"
end = [0.5, 0.2, 0.5]
""")
    path = api.load_text(text).path
    assert [p.kind for p in path.pieces] == ["task", "task"]
    assert path.kinks == (pytest.approx(0.1),) and path.dwells == ((path.kinks[0], 0.5),)
    left, right = path.evaluate(path.kinks[0], side="left"), path.evaluate(path.kinks[0], side="right")
    np.testing.assert_allclose(left[0], right[0], atol=1e-12)  # the same configuration on both sides
    np.testing.assert_allclose(fk(robot, right[0])[0], [0.5, 0.1, 0.5], atol=1e-12)


def test_a_corner_blended_twice_is_an_error(home):
    twice = ('[[path.blends]]\ncorner = "all"\ntype = "g2"\ntolerance = 0.01\n'
             '[[path.blends]]\ncorner = 1\ntype = "g2"\ntolerance = 0.02\n')
    with pytest.raises(ScenarioError, match=r"path.blends\[1\]: connection 1 is already blended by path.blends\[0\]"):
        api.load_text(scenario(home, MIXED % np.asarray(home).tolist(), twice))
    circle = '[[path.blends]]\ncorner = 1\ntype = "circle"\nradius = 0.01\n'
    with pytest.raises(ScenarioError, match=r"path.blends\[0\]: corner 1 joins a joint move"):
        api.load_text(scenario(home, MIXED % np.asarray(home).tolist(), circle))


@settings(max_examples=10)
@given(st.lists(st.floats(-0.6, 0.6), min_size=18, max_size=18), st.floats(0.002, 0.03), st.floats(0.002, 0.03))
def test_zones_between_random_joint_moves(robot, values, tol_a, tol_b):
    lim = robot.limits
    mid, half = 0.5 * (lim.lower + lim.upper), 0.5 * (lim.upper - lim.lower)
    q = [mid + np.asarray(values[6 * k:6 * k + 6]) * half for k in range(3)]
    assume(min(np.max(np.abs(q[k + 1] - q[k])) for k in range(2)) > 0.05)
    items = [JointMove(q[1], None, "a"), JointMove(q[2], None, "b"), JointMove(q[0], None, "c")]
    path = lift_chain(robot, items, q[0], {0: tol_a, 1: tol_b})
    sharp = path.original_task_path
    for piece, tol in zip([p for p in path.pieces if p.kind == "blend"], (tol_a, tol_b)):
        for end in (piece.lo, piece.hi):  # C2 where the blend meets the joint moves
            for a, b in zip(path.evaluate(end, side="left"), path.evaluate(end, side="right")):
                np.testing.assert_allclose(a, b, atol=1e-9 * max(1.0, np.max(np.abs(a))))
        theta = np.linspace(piece.lo, piece.hi, 501)
        qs = path.evaluate(theta)[0]
        assert np.all((qs >= lim.lower) & (qs <= lim.upper))
        tcp = fk(robot, qs)[0]
        assert np.max(np.min([seg.closest(tcp)[1] for seg in sharp.segments], axis=0)) <= tol * (1 + 1e-6)
