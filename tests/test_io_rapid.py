"""The RAPID import: frames, arcs, speeds and zones against hand-computed values, the unsupported
list, errors, the CLI round trip, and the constant-speed estimate on analytic cases."""

import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pathmotion import api
from pathmotion.cli import app
from pathmotion.errors import ScenarioError
from pathmotion.geometry import Arc, max_deviation
from pathmotion.io.rapid import (arc_through, effective_zones, parse_rapid, rapid_estimate_s, read_rapid,
                                 segment_speeds, segments)
from pathmotion.io.scenario import load_scenario
from pathmotion.study.free_shape import Polyline

DATA = Path(__file__).parent / "data"
runner = CliRunner()
S = math.sqrt(0.5)


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.fixture(scope="module")
def frames():
    return read_rapid(DATA / "frames.mod")


def test_targets_are_tcp_points_in_the_base_frame(frames):
    # object point = oframe (10, 0, 0) + target; user frame turns it 90 deg about z and adds (400, 100, 300) mm
    def base(p):
        return (np.array([400, 100, 300]) + rot_z(math.pi / 2) @ (np.array([10, 0, 0]) + np.array(p))) / 1000

    expected = [base([100, 0, 200]), base([100, 100, 200]), base([100, 200, 200]), base([0, 200, 200])]
    assert [m.line for m in frames.moves] == [16, 17, 18, 20]
    for move, want in zip(frames.moves, expected):
        np.testing.assert_allclose(move.point, want, atol=1e-9)
    np.testing.assert_allclose(frames.moves[0].point, [0.4, 0.21, 0.5], atol=1e-9)
    down = np.diag([1.0, -1.0, -1.0])  # q = [0, 1, 0, 0]: half a turn about x
    np.testing.assert_allclose(frames.moves[0].rotation, rot_z(math.pi / 2) @ down, atol=1e-9)
    np.testing.assert_allclose(frames.moves[1].via, base([150, 50, 200]), atol=1e-9)


def test_tool_frame_and_load(frames):
    t = frames.tool
    np.testing.assert_allclose(t.frame.translation, [0, 0, 0.1])
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    np.testing.assert_allclose(t.frame.rotation, [[c, 0, s], [0, 1, 0], [-s, 0, c]], atol=1e-9)
    assert t.mass == 2.0
    np.testing.assert_allclose(t.com, [0, 0, 0.05])
    np.testing.assert_allclose(t.inertia, np.diag([0.02, 0.01, 0.03]), atol=1e-9)  # axes swapped by the 90 deg aom


def test_movec_arc_centre_normal_sweep(frames):
    _, start, arc, length = segments(frames)[0]
    np.testing.assert_allclose(arc.center, [0.35, 0.21, 0.5], atol=1e-9)
    np.testing.assert_allclose(arc.normal, [0, 0, 1], atol=1e-9)
    assert arc.sweep == pytest.approx(math.pi) and arc.radius == pytest.approx(0.05)
    assert length == pytest.approx(0.05 * math.pi)
    ref = Arc.through_points(start, frames.moves[1].via, frames.moves[1].point)  # the geometry layer's own
    np.testing.assert_allclose(ref.centre, arc.center, atol=1e-12)
    assert ref.sweep == pytest.approx(arc.sweep)


def test_arc_through_points_on_a_tilted_circle():
    rng = np.random.default_rng(4)
    centre, r = rng.normal(size=3), 0.3
    u, v = np.linalg.qr(rng.normal(size=(3, 2)))[0].T
    pts = [centre + r * (math.cos(a) * u + math.sin(a) * v) for a in (0.2, 1.5, 4.0)]
    arc = arc_through(*pts)
    np.testing.assert_allclose(arc.center, centre, atol=1e-12)
    np.testing.assert_allclose(arc.normal, np.cross(u, v), atol=1e-12)
    assert arc.sweep == pytest.approx(3.8)
    with pytest.raises(ScenarioError, match="collinear"):
        arc_through([0, 0, 0], [1, 0, 0], [2, 0, 0])


def test_speeds_and_zones(frames):
    lengths = [seg[3] for seg in segments(frames)]
    # vSlow's v_tcp 250 mm/s; \V:=800 overrides v1000; \T:=0.5 s over the MoveJ's 0.1 m line
    np.testing.assert_allclose(segment_speeds(frames), [0.25, 0.8, lengths[2] / 0.5])
    assert lengths[2] == pytest.approx(0.1)
    assert [m.zone for m in frames.moves] == pytest.approx([0.0, 0.005, 0.003, 0.007])
    assert effective_zones(frames) == pytest.approx([0.005, 0.003])


@pytest.mark.parametrize("zone, mm", [("fine", 0), ("z0", 0.3), ("z1", 1), ("z15", 15), ("z60", 60), ("z200", 200)])
def test_abb_zone_table(zone, mm):
    prog = parse_rapid(f"MODULE m\nPROC main()\nMoveL [[0,0,0],[1,0,0,0]], v100, {zone}, tool0;\n"
                       "MoveL [[1000,0,0],[1,0,0,0]], v100, fine, tool0;\nENDPROC\nENDMODULE\n")
    assert prog.moves[0].zone == pytest.approx(mm / 1000)


def test_unsupported_instructions_are_listed_with_line_numbers(frames):
    lines = [ln for ln, _ in frames.unsupported]
    assert lines == [22, 24]  # WaitTime (line 25) is a dwell after the last move
    assert frames.moves[-1].dwell == 0.5
    assert "SingArea" in frames.unsupported[0][1] and "SetDO" in frames.unsupported[1][1]


@pytest.mark.parametrize("body, match", [
    ("MoveL p1, v100, fine, tool0;\nMoveL p2, v100, fine, tool0;", r"prog.mod:3: robtarget 'p1' is not declared"),
    ("MoveL [[0,0,0],[1,0,0,0]], vfast, fine, tool0;\nMoveL [[9,0,0],[1,0,0,0]], v100, fine, tool0;",
     r"prog.mod:3: .*vfast.*v5 \.\.\. v7000"),
    ("MoveL [[0,0,0],[1,0,0,0]], v100, fine, tool0 \\Corr;", r"prog.mod:3: optional argument \\corr"),
    ("MoveL [[0,0,0],[1,0,0,0]], v100, fine, tool0;\nMoveL [[0,0,0],[1,0,0,0]], v100, fine, tool1;",
     r"prog.mod:4: tool tool1 is not declared"),
    ("MoveL [[0,0,0],[0,0,0,0]], v100, fine, tool0;", r"prog.mod:3: .*quaternion.*not a rotation"),
    ("MoveL [[0,0,0],[1,0,0,0]], v100, fine, tool0;", r"prog.mod: PROC main has 1 MoveL"),
])
def test_errors_name_file_line_and_fix(body, match):
    with pytest.raises(ScenarioError, match=match):
        segments(parse_rapid(f"MODULE m\nPROC main()\n{body}\nENDPROC\nENDMODULE\n", "prog.mod"))


def test_estimate_square_with_fine_points_is_perimeter_over_speed():
    assert rapid_estimate_s([0.3] * 4, [0.5] * 4, [0.0] * 3, [math.pi / 2] * 3) == pytest.approx(1.2 / 0.5)


def test_estimate_zone_replaces_the_corner_by_its_fillet_at_the_slower_speed():
    # 90 deg corner, zone 0.1 m: the fillet of radius 0.1 m (a quarter circle) replaces 0.2 m of the corner
    t = rapid_estimate_s([1.0, 2.0], [1.0, 0.5], [0.1], [math.pi / 2])
    assert t == pytest.approx(0.9 / 1.0 + 1.9 / 0.5 + (math.pi / 2 * 0.1) / 0.5)
    straight = rapid_estimate_s([1.0, 2.0], [1.0, 1.0], [0.1], [0.0])  # a zone on a straight joint costs nothing
    assert straight == pytest.approx(3.0)
    with pytest.raises(ScenarioError, match="one speed per segment"):
        rapid_estimate_s([1.0, 2.0], [1.0], [0.1], [0.0])


def test_cli_import_refuses_unsupported_then_skips_them(tmp_path):
    out = tmp_path / "frames.toml"
    res = runner.invoke(app, ["import-rapid", str(DATA / "frames.mod"), "--out", str(out)])
    assert res.exit_code == 1 and "line 22" in res.output and "--skip-unsupported" in res.output
    assert not out.exists()
    res = runner.invoke(app, ["import-rapid", str(DATA / "frames.mod"), "--out", str(out), "--skip-unsupported"])
    assert res.exit_code == 0, res.output
    scenario, _ = load_scenario(out)
    assert scenario.robot.tool.translation == pytest.approx((0, 0, 0.1))
    assert scenario.robot.tool.rotation_rpy == pytest.approx((0, math.pi / 4, 0))
    assert [s.type for s in scenario.path.segments] == ["arc", "line", "joint", "dwell"]  # MoveJ, WaitTime
    assert scenario.path.segments[2].end_pose.robconf == (0, -1, 1, 0)
    assert scenario.path.segments[3].time == 0.5 and scenario.path.segments[3].program.line == 25
    assert scenario.rapid.speeds == pytest.approx(segment_speeds(read_rapid(DATA / "frames.mod")))
    assert "MoveJ at line(s) 20" in scenario.description and "skipped: line 22" in scenario.description


@pytest.fixture(scope="module")
def cycle_z10(tmp_path_factory):
    out = tmp_path_factory.mktemp("rapid") / "cycle.toml"
    res = runner.invoke(app, ["import-rapid", str(DATA / "abb_cycle.mod"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_imported_cycle_checks_and_blends_start_at_the_zone_radius(cycle_z10):
    res = runner.invoke(app, ["check", str(cycle_z10)])
    assert res.exit_code == 0, res.output
    setup = api.load(cycle_z10)
    corner = np.array([0.5, -0.1525, 0.525])  # the first top corner, zone z10
    blend = setup.task_path.segments[1]
    assert blend.kind != "line"
    assert np.linalg.norm(blend.start_point - corner) == pytest.approx(0.010, abs=2e-5)
    assert np.linalg.norm(blend.end_point - corner) == pytest.approx(0.010, abs=2e-5)


def test_plan_summary_reports_the_rapid_estimate(cycle_z10):
    setup = api.load(cycle_z10)
    path = setup.original_task_path
    want = rapid_estimate_s([s.length for s in path.segments], [1.0] * 6, [0.01, 0.01, 0.0, 0.01, 0.01],
                            [math.pi / 2, math.pi / 2, math.pi, math.pi / 2, math.pi / 2])
    # by hand: 0.71 m of lines, each of the 4 zones swaps 20 mm for a 10 mm-radius quarter circle, at 1 m/s
    assert want == pytest.approx(0.71 - 4 * 0.02 + 4 * math.pi / 2 * 0.01)
    assert api.rapid_estimate(setup) == pytest.approx(want)


def test_rapid_section_counts_are_validated(tmp_path):
    text = (Path(__file__).parents[1] / "scenarios" / "abb_cycle.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("zones = [0.0, 0.0, 0.0, 0.0, 0.0]", "zones = [0.0]"))
    with pytest.raises(ScenarioError, match="rapid: .*6 speeds need 5 zones"):
        load_scenario(bad)


@pytest.mark.slow
def test_import_with_optimal_blends_keeps_each_zones_deviation_and_is_faster(cycle_z10, tmp_path):
    """--blend optimal: the same corners and tolerances as the zones' G2 blends, each blend searched for the
    shortest duration within its zone's deviation (a fine point stays a stop)."""
    out = tmp_path / "cycle_optimal.toml"
    res = runner.invoke(app, ["import-rapid", str(DATA / "abb_cycle.mod"), "--out", str(out), "--blend", "optimal"])
    assert res.exit_code == 0, res.output
    g2, _ = load_scenario(cycle_z10)
    optimal, _ = load_scenario(out)
    assert [b.type.value for b in optimal.path.blends] == ["optimal"] * len(g2.path.blends)
    assert [(b.corner, b.tolerance) for b in optimal.path.blends] == [(b.corner, b.tolerance) for b in g2.path.blends]
    fast, slow = api.search(api.load(out)), api.load(cycle_z10)
    t_fast, t_slow = api.plan_scenario(fast).profile.duration, api.plan_scenario(slow).profile.duration
    assert t_fast < t_slow
    assert len(fast.task_path.kinks) == len(slow.task_path.kinks) == 1  # the fine point between the moves down and up
    tolerance = max(b.tolerance for b in g2.path.blends)
    assert max_deviation(fast.task_path, fast.original_task_path).distance <= tolerance * (1 + 1e-9)
    sharp = fast.original_task_path  # and on a dense projection onto the program's lines, independent of that bound
    corners = Polyline(np.array([sharp.segments[0].start_point] + [seg.end_point for seg in sharp.segments]))
    samples = fast.task_path.evaluate(np.linspace(0.0, fast.task_path.length, 20001))[0]
    assert np.max(corners.distance(samples)) <= tolerance * (1 + 1e-6)


def test_import_refuses_an_unknown_blend_type(tmp_path):
    out = tmp_path / "cycle.toml"
    res = runner.invoke(app, ["import-rapid", str(DATA / "abb_cycle.mod"), "--out", str(out), "--blend", "circle"])
    assert res.exit_code == 1 and "--blend circle" in res.output and "optimal" in res.output
    assert not out.exists()
