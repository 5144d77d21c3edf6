"""RAPID programs of the kinds cells run (tests/data/rapid/), imported, planned and simulated; each fine point
checked against the robtarget by a reader of its own (not the import), the lift's derivatives with a turning
tool by finite differences, the slerp against scipy's, moves.csv against the plan, and the bad inputs."""

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from pathmotion import api
from pathmotion.errors import ScenarioError, UnreachableError
from pathmotion.geometry.orientation import smoothstep5
from pathmotion.api.program import axis_times
from pathmotion.io.rapid import parse_rapid, read_rapid, scenario_toml
from pathmotion.io.scenario import parse_scenario
from pathmotion.report.html import build_report
from pathmotion.report.tables import read_rows
from pathmotion.robot import fk, load_robot

DATA = Path(__file__).parent / "data" / "rapid"
FAST = {"plan.verify": "off", "plan.duration_tolerance": 0.01}


def imported(text_or_path, overrides=None):
    flange = api.rapid_flange("irb140")
    prog = read_rapid(text_or_path, flange) if isinstance(text_or_path, Path) else parse_rapid(text_or_path, "prog.mod",
                                                                                             flange)
    text = scenario_toml(prog, api.rapid_zone_tolerances(prog))
    return prog, api.load_text(text, DATA, {**FAST, **(overrides or {})})


# ------------------------------------------------------------------------------- an independent reader
def _numbers(text):
    return [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:E-?\d+)?", text)]


def _pose(numbers):
    """(position (3,) [m], rotation (3, 3)) of [x, y, z] mm and [q1..q4]."""
    w, x, y, z = numbers[3:7]
    return np.array(numbers[:3]) / 1000, Rotation.from_quat([x, y, z, w]).as_matrix()


def fine_targets(path: Path):
    """[(name, TCP position [m], rotation)] in the base frame of every fine-point move to a named target."""
    text = path.read_text()
    decl = {m.group(2).lower(): (m.group(1).lower(), m.group(3)) for m in
            re.finditer(r"(?i)(robtarget|tooldata|wobjdata)\s+(\w+)\s*:=\s*(\[.*?\]);", text, re.S)}
    out = []
    for m in re.finditer(r"(?i)Move[LJC]\s+(?:\w+\s*,\s*)?(\w+)\s*,\s*v\d+\s*,\s*fine\s*,\s*\w+\s*(?:\\WObj:=(\w+))?",
                         text):
        p, r = _pose(_numbers(decl[m.group(1).lower()][1]))
        if m.group(2):
            nums = _numbers(decl[m.group(2).lower()][1])
            up, ur = _pose(nums[0:7])
            op, orr = _pose(nums[7:14])
            p, r = up + ur @ (op + orr @ p), ur @ orr @ r
        out.append((m.group(1), p, r))
    return out, decl


def tool_of(decl, path: Path):
    name = re.search(r"(?i)Move\w+\s+[^;]*?,\s*(t\w+)", path.read_text()).group(1).lower()
    return _pose(_numbers(decl[name][1])[0:7])  # robhold TRUE is not a number: [[x, y, z], [q1..q4]] first


# ------------------------------------------------------------------------------------------ the programs
@pytest.fixture(scope="module", params=["palletizing", "glue_bead", "deburring", "tending", "abs_joint"])
def planned(request):
    prog, setup = imported(DATA / f"{request.param}.mod")
    return request.param, prog, setup, api.plan_scenario(setup)


def test_fine_points_are_the_robtargets_poses(planned):
    """Flange FK of a bare IRB140 at the planned joints, times the tool read here: within 0.01 mm and 0.01 deg
    of each fine-point robtarget (through its work object), at the stop the plan makes there."""
    name, _, setup, _ = planned
    targets, decl = fine_targets(DATA / f"{name}.mod")
    tool_p, tool_r = tool_of(decl, DATA / f"{name}.mod")
    bare = load_robot("irb140")
    stops = np.array(sorted({*setup.path.kinks, *setup.path.domain, *(t for t, _ in getattr(setup.path, "dwells", ()))}))
    flange_p, flange_r = fk(bare, setup.path(stops))
    tcp_p = flange_p + np.einsum("nij,j->ni", flange_r, tool_p)
    tcp_r = flange_r @ tool_r
    assert len(targets) >= 3
    for target, p, r in targets:
        k = int(np.argmin(np.linalg.norm(tcp_p - p, axis=1)))
        assert np.linalg.norm(tcp_p[k] - p) < 1e-5, target
        angle = Rotation.from_matrix(tcp_r[k].T @ r).magnitude()
        assert math.degrees(angle) < 0.01, target


def test_moves_csv_is_the_cycle_by_move(planned, tmp_path):
    name, prog, setup, result = planned
    api.write_plan(setup, result, tmp_path)
    names, rows = read_rows(tmp_path / "moves.csv")
    segments = setup.scenario.path.segments
    assert len(rows) == len(segments)
    assert [r["line"] for r in rows] == [s.program.line for s in segments]
    assert sum(r["cycle_s"] for r in rows) == pytest.approx(result.duration, rel=1e-6)
    ratios = [r["binding_ratio"] for r in rows if isinstance(r["binding_ratio"], float)]
    assert 0.98 < max(ratios) < 1.1  # a limit binds (the coarse unverified plan of FAST overshoots by a few %)
    for r in rows:
        if r["instruction"] != "WaitTime":
            assert r["peak_tcp_speed_m_s"] >= r["mean_tcp_speed_m_s"] * (1 - 1e-6)
    html = build_report(tmp_path).read_text()
    assert "Program moves" in html and "sortable" in html and f"in {len(rows)} moves" in html


@pytest.mark.parametrize("name", ["palletizing", "glue_bead", "deburring", "tending", "abs_joint"])
def test_programs_simulate_within_tracking(name):
    _, setup = imported(DATA / f"{name}.mod")
    result = api.plan_scenario(setup)
    sim = api.simulate_scenario(setup, result)
    assert api.simulation_summary(setup, result, sim)["tracking_ok"]


def test_program_structure_of_the_tending_cycle():
    prog = read_rapid(DATA / "tending.mod")
    lines = [m.line for m in prog.moves]
    assert len(prog.moves) == 1 + 3 * (3 + 3) + 1  # home, 3 x (tray in/out + the inlined LoadMachine), home
    assert lines.count(25) == 3 and lines.count(26) == 3  # LoadMachine's moves, once per loop pass
    x = [m.point[0] for m in prog.moves if m.line == 15]
    np.testing.assert_allclose(np.diff(x), [0.04, 0.04])  # Offs(pTray, i * pitch, ...)
    assert sum(m.dwell for m in prog.moves) == pytest.approx(3 * (0.2 + 0.5))
    assert not prog.moves[-1].conf and prog.moves[-2].conf  # ConfL \Off before the last move
    assert any("Conc ignored" in r for r in prog.remarks)


# ----------------------------------------------------------------------------------- orientation
def test_lift_derivatives_include_the_turning_tool():
    """Phi' and Phi'' of the tilted glue bead against central differences of Phi inside its arcs and lines."""
    _, setup = imported(DATA / "glue_bead.mod")
    path, task = setup.path, setup.task_path
    assert np.ptp(task.orientation(np.linspace(*task.domain, 50))[1], axis=0).max() > 1.0  # the tool turns
    h = 1e-5
    for seg, lo in zip(task.segments, task.offsets):
        if seg.length < 0.01:
            continue
        th = lo + seg.length * np.array([0.3, 0.55, 0.8])
        _, d1, d2 = path.evaluate(th)
        qm, q0, qp = path(th - h), path(th), path(th + h)
        np.testing.assert_allclose(d1, (qp - qm) / (2 * h), atol=1e-4 * max(1.0, np.abs(d1).max()))
        np.testing.assert_allclose(d2, (qp - 2 * q0 + qm) / h**2, atol=2e-3 * max(1.0, np.abs(d2).max()))


PROGRAM = """MODULE m
PERS tooldata tT := [TRUE, [[0, 0, 100], [1, 0, 0, 0]], [1, [0, 0, 50], [1, 0, 0, 0], 0, 0, 0]];
CONST robtarget pA := [[450, -100, 400], {qa}, [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
CONST robtarget pB := [[450, 20, 400], {qb}, {cb}, [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
CONST robtarget pC := [[550, 20, 400], {qc}, [0, -1, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
PROC main()
{conf}MoveL pA, v500, fine, tT;
MoveL pB, v500, {zone}, tT;
MoveL pC, v500, fine, tT;
ENDPROC
ENDMODULE
"""


def quat(tilt_deg, yaw_deg=0.0):
    r = Rotation.from_euler("z", yaw_deg, degrees=True) * Rotation.from_euler("x", 180, degrees=True) * \
        Rotation.from_euler("y", tilt_deg, degrees=True)
    x, y, z, w = r.as_quat()
    return f"[{w:.9f}, {x:.9f}, {y:.9f}, {z:.9f}]", r


def program(zone="fine", cb="[0, -1, 2, 0]", conf="", qa=0.0, qb=30.0, qc=30.0, yc=0.0):
    return PROGRAM.format(qa=quat(qa)[0], qb=quat(qb)[0], qc=quat(qc, yc)[0], cb=cb, zone=zone, conf=conf)


def test_orientation_between_targets_is_the_slerp_smooth_in_the_path_coordinate():
    _, setup = imported(program())
    task = setup.task_path
    ends = Rotation.concatenate([quat(0.0)[1], quat(30.0)[1]])
    slerp = Slerp([0.0, 1.0], ends)
    for s in (0.1, 0.25, 0.5, 0.9):
        want = slerp(float(smoothstep5(np.array([s]))[0][0])).as_matrix()
        np.testing.assert_allclose(task.orientation(0.12 * s)[0], want, atol=1e-9)  # pA -> pB is 120 mm


def test_a_zone_blends_the_orientation_and_a_fine_point_meets_it():
    target = quat(30.0)[1].as_matrix()
    turned = []
    for zone in ("fine", "z10"):
        _, setup = imported(program(zone=zone, qc=0.0, yc=0.0))
        th = api.program_thetas(setup.scenario.path, setup.robot, setup.path)[0][1]
        turned.append(Rotation.from_matrix(setup.task_path.orientation(th)[0].T @ target).magnitude())
    assert turned[0] < 1e-9
    assert 1e-4 < turned[1] < math.radians(30.0) * 15 / 100  # cut by the orientation zone, at most its share


def test_a_quaternion_flip_takes_the_shorter_turn_and_says_so():
    text = program().replace(quat(30.0)[0], "[" + ", ".join(f"{-v:.9f}" for v in _numbers(quat(30.0)[0])) + "]", 1)
    prog, setup = imported(text)
    assert any("opposite signs" in n for n in prog.remarks + tuple(_notes(prog)))
    _, same = imported(program())
    th = np.linspace(*setup.task_path.domain, 40)
    np.testing.assert_allclose(setup.task_path.orientation(th)[0], same.task_path.orientation(th)[0], atol=1e-9)


def _notes(prog):
    from pathmotion.io.rapid import notes

    return notes(prog)


def test_a_non_unit_quaternion_is_normalised_with_a_warning(caplog):
    text = program().replace(quat(0.0)[0], "[0, 1.01, 0, 0]", 1)
    prog = parse_rapid(text, "prog.mod")
    assert any("norm 1.01" in r and "normalized" in r for r in prog.remarks)
    assert any("norm 1.01" in rec.getMessage() for rec in caplog.records)
    np.testing.assert_allclose(prog.moves[0].rotation, np.diag([1.0, -1.0, -1.0]), atol=1e-12)


# --------------------------------------------------------------------------------------- robconf
def test_a_robconf_the_move_cannot_keep_is_an_error_naming_target_and_line():
    with pytest.raises(UnreachableError, match=r"line 8, target pB: the move arrives with robconf \[0, -1, 2, 0\], "
                                                r"not the programmed \[0, -1, -2, 0\]"):
        imported(program(cb="[0, -1, -2, 0]"))
    prog, setup = imported(program(cb="[0, -1, -2, 0]", conf="ConfL \\Off;\n"))  # \Off: the continuous branch
    assert not prog.moves[1].conf and setup.path.domain[1] > 0


def test_a_start_robconf_that_cannot_reach_its_pose_is_an_error():
    text = program().replace("[-1, 0, 1, 0]", "[2, 0, 1, 0]")
    with pytest.raises(UnreachableError, match=r"line 7, target pA\): no IK solution of this pose has robconf "
                                                r"\[2, 0, 1, 0\]"):
        imported(text)


# ------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("body, match", [
    ("PROC main()\nMoveL pA, v100, fine, tT;\nMoveL pA, v100, fine, tT;\nA;\nENDPROC\nPROC A()\nB;\nENDPROC\n"
     "PROC B()\nA;\nENDPROC", r"prog.mod:15: procedure A calls itself \(main -> A -> B -> A\)"),
    ("PROC main()\nMoveL pA, v100, fine, tT;\nMoveL [[450, -100, 400], [0, 0, 1, 0]], v100, fine, tT;\nENDPROC",
     r"prog.mod:8: MoveL to inline \[450, -100, 400\] only turns the tool"),
    ("PROC main()\nFOR i FROM 1 TO 3 STEP 0 DO\nMoveL pA, v100, fine, tT;\nENDFOR\nENDPROC", r"STEP 0 never ends"),
    ("PROC main()\nMoveL pA, v100, fine, tT;\nMoveL Offs(pA, i * 2, 0, 0), v100, fine, tT;\nENDPROC",
     r"prog.mod:8: cannot read the value 'i'"),
])
def test_bad_programs_are_clear_errors(body, match):
    head = PROGRAM.split("PROC main()")[0].format(qa=quat(0)[0], qb=quat(0)[0], qc=quat(0)[0], cb="[0, 0, 0, 0]")
    with pytest.raises(ScenarioError, match=match):
        parse_rapid(head + body + "\nENDMODULE\n", "prog.mod")


def test_a_repeated_target_is_dropped_and_said():
    text = program().replace("MoveL pB, v500, fine, tT;", "MoveL pB, v500, fine, tT;\nMoveL pB, v500, fine, tT;")
    prog = parse_rapid(text, "prog.mod")
    assert len(prog.moves) == 3 and any("zero-length move" in r for r in prog.remarks)


# ------------------------------------------------------------------------------------ program scale
def test_the_1000_move_contour_imports_to_a_valid_scenario():
    prog = read_rapid(DATA / "contour_1000.mod")
    assert len(prog.moves) == 1001
    tolerances = api.rapid_zone_tolerances(prog)
    scenario = parse_scenario(scenario_toml(prog, tolerances), "contour_1000.toml")
    assert len(scenario.path.segments) == 1000 and len(scenario.path.blends) == 999
    assert all(s.program.move == "MoveL" and s.quaternion == (0.0, 1.0, 0.0, 0.0) for s in scenario.path.segments)


@pytest.mark.slow
def test_the_1000_move_contour_is_checked_and_planned_within_every_limit(tmp_path):
    """The 1,000-move contour (999 z1 zones) passes check and is planned with the certified verification: no limit
    exceeded, at rest at its last target (the robtarget read here, flange FK times the tool), one moves.csv row per
    move whose times sum to the cycle, and the cycle at least the path length over the largest TCP speed planned."""
    _, setup = imported(DATA / "contour_1000.mod", {"plan.verify": "certified"})
    assert len(setup.task_path.segments) == 1000 + 999
    assert api.check_scenario(setup)["segments"] == 1999
    result = api.plan_scenario(setup)
    assert not api.plan_failures(result, setup) and result.ratios.within()
    assert result.profile.x[-1] == 0.0
    text = (DATA / "contour_1000.mod").read_text()
    last = _pose(_numbers(re.findall(r"MoveL (\[\[.*?\]\])", text)[-1]))
    tool_p, tool_r = tool_of(fine_targets(DATA / "contour_1000.mod")[1], DATA / "contour_1000.mod")
    flange_p, flange_r = fk(load_robot("irb140"), setup.path(np.array([setup.path.domain[1]])))
    np.testing.assert_allclose(flange_p[0] + flange_r[0] @ tool_p, last[0], atol=1e-5)
    assert math.degrees(Rotation.from_matrix((flange_r[0] @ tool_r).T @ last[1]).magnitude()) < 0.01
    api.write_plan(setup, result, tmp_path)
    _, rows = read_rows(tmp_path / "moves.csv")
    assert len(rows) == 1000 and sum(r["cycle_s"] for r in rows) == pytest.approx(result.duration, rel=1e-6)
    peak = max(r["peak_tcp_speed_m_s"] for r in rows)
    assert result.duration >= setup.task_path.length / peak


def _jointtargets_deg(text: str) -> dict:
    """{name or "inline k": robax (6,) [deg]} of every jointtarget, read here by regular expression."""
    out = {m.group(1).lower(): _numbers(m.group(2))[:6]
           for m in re.finditer(r"(?i)jointtarget\s+(\w+)\s*:=\s*\[\s*(\[[^\]]*\])", text)}
    for k, m in enumerate(re.finditer(r"(?i)MoveAbsJ\s*\[\s*(\[[^\]]*\])", text)):
        out[f"inline {k}"] = _numbers(m.group(1))[:6]
    return out


def test_moveabsj_is_a_joint_move_to_the_jointtarget_in_radians():
    """abs_joint.mod starts at the jointtarget jHome and ends by MoveAbsJ at an inline one: the path starts and
    ends at those axes, degrees read here and converted by numpy (1e-9 rad). The MoveAbsJ segment is a joint
    segment with ``end``, the move before it a MoveL whose TCP is where the joint move starts."""
    text = (DATA / "abs_joint.mod").read_text()
    want = _jointtargets_deg(text)
    prog, setup = imported(DATA / "abs_joint.mod")
    path = setup.scenario.path
    assert [m.instruction for m in prog.moves] == ["MoveAbsJ", "MoveJ", "MoveL", "MoveL", "MoveJ", "MoveL", "MoveL",
                                                   "MoveAbsJ"]
    assert np.allclose(path.start_configuration, np.deg2rad(want["jhome"]), rtol=0, atol=1e-9)
    last = path.segments[-1]
    assert last.type == "joint" and last.program.move == "MoveAbsJ"
    assert np.allclose(last.end, np.deg2rad(want["inline 0"]), rtol=0, atol=1e-9)
    lo, hi = setup.path.domain
    assert np.allclose(setup.path(lo), np.deg2rad(want["jhome"]), rtol=0, atol=1e-9)
    assert np.allclose(setup.path(hi), np.deg2rad(want["inline 0"]), rtol=0, atol=1e-9)
    # the import's TCP at the inline jointtarget: bare flange FK times the tool read here
    _, decl = fine_targets(DATA / "abs_joint.mod")
    tool_p, tool_r = tool_of(decl, DATA / "abs_joint.mod")
    flange_p, flange_r = fk(load_robot("irb140"), np.deg2rad(want["inline 0"]))
    assert np.allclose(prog.moves[-1].point, flange_p + flange_r @ tool_p, atol=1e-12)
    assert np.allclose(prog.moves[-1].rotation, flange_r @ tool_r, atol=1e-12)


@pytest.mark.parametrize("body, match", [
    ("MoveAbsJ [[0, 0, 0, 0, 90], [9E9]], v100, fine, tool0;\nMoveL [[500, 0, 500], [0, 1, 0, 0]], v100, fine, tool0;",
     "expected \\[\\[robax_a"),
    ("MoveAbsJ jNone, v100, fine, tool0;\nMoveL [[500, 0, 500], [0, 1, 0, 0]], v100, fine, tool0;",
     "jointtarget 'jNone' is not declared"),
    ("MoveAbsJ pA, v100, fine, tool0;\nMoveL [[500, 0, 500], [0, 1, 0, 0]], v100, fine, tool0;",
     "pA is a robtarget, expected a jointtarget"),
])
def test_bad_jointtargets_are_clear_errors(body, match):
    head = "MODULE m\nCONST robtarget pA := [[500, 0, 500], [0, 1, 0, 0], [0, 0, 0, 0], [9E9]];\nPROC main()\n"
    with pytest.raises(ScenarioError, match=match):
        parse_rapid(head + body + "\nENDPROC\nENDMODULE\n", "prog.mod", api.rapid_flange())


def test_moveabsj_without_kinematics_says_what_to_pass():
    text = "MODULE m\nPROC main()\nMoveAbsJ [[0, 0, 0, 0, 90, 0], [9E9]], v100, fine, tool0;\nENDPROC\nENDMODULE\n"
    with pytest.raises(ScenarioError, match="prog.mod:3: MoveAbsJ needs the robot's kinematics"):
        parse_rapid(text, "prog.mod")


def test_a_joint_move_takes_at_least_its_slowest_axis_at_max_speed():
    """abs_joint.mod's last move, MoveAbsJ v2000 from the fine point pPlaceAbove: its slowest axis at max speed
    (dq from the jointtarget read here and the planned joints at pPlaceAbove, the IRB140's axis speeds) takes
    longer than its TCP arc length at 2 m/s, so that is its programmed time. The estimate of this chain is the sum
    of the moves' programmed times: the MoveL moves' lengths are the robtargets' distances read here."""
    text = (DATA / "abs_joint.mod").read_text()
    _, setup = imported(DATA / "abs_joint.mod")
    spec, robot, path = setup.scenario.path, setup.robot, setup.path
    end = np.deg2rad(_jointtargets_deg(text)["inline 0"])
    slowest = float(np.max(np.abs(end - path(path.kinks[-1])) / load_robot("irb140").limits.velocity))
    _, lengths = api.program_thetas(spec, robot, path)
    assert lengths[-1] == pytest.approx(path.domain[1] - path.kinks[-1], rel=1e-12)
    assert lengths[-1] / 2.0 < slowest  # the axis binds, not the TCP speed
    floors = axis_times(spec, robot, path)
    assert floors[-1] == pytest.approx(slowest, rel=1e-9)
    assert [f for s, f in zip(spec.segments, floors) if s.type != "joint"] == [0.0] * 4
    _, decl = fine_targets(DATA / "abs_joint.mod")
    point = {n: np.array(_numbers(decl[n][1])[:3]) / 1000 for n in ("ppick", "ppickabove", "pplace", "pplaceabove")}
    drop = np.linalg.norm(point["ppick"] - point["ppickabove"])
    place = np.linalg.norm(point["pplace"] - point["pplaceabove"])
    assert np.allclose([lengths[k] for k in (1, 2, 4, 5)], [drop, drop, place, place], rtol=1e-12)
    moves = [s.program for s in spec.segments]
    want = sum(max(length / mv.speed, floor) for mv, length, floor in zip(moves, lengths, floors))
    assert api.rapid_estimate(setup) == pytest.approx(want, rel=1e-12)
    assert want > sum(length / mv.speed for mv, length in zip(moves, lengths)) + slowest - lengths[-1] / 2.0 - 1e-12
