"""execute's path supervision: an arm that leaves the path (a 7.75 kg payload the plan does not know, the orbital
loop diverging at corner_g2's corner with rigid gears) trips it, the stop runs along the path with the loop
switched off and ends on the path (without the supervision the arm ends hundreds of millimetres away), and
summary.json records why; its deviation is checked against a dense search of the path; normal runs
(circle_smooth, corner_g2 with shaping, rigid and elastic gears) never trip it; a resume arms it again; the CLI
exits 4."""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from egm_support import irb140_task, line, run_commands  # noqa: E402
from pathmotion import api  # noqa: E402
from pathmotion.execution.drive_file import drive_file_for, load_drives  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.session import make_streamer, run_inprocess, write_execution  # noqa: E402
from pathmotion.robot import Payload, fk  # noqa: E402
from pathmotion.simulation.metrics import planned_tcp_line, tcp_path_deviation  # noqa: E402


#: The unknown payload [kg] (0.1 m beyond the flange) and the joint tolerance [rad] of the tripping case.
PAYLOAD, TOLERANCE = 7.75, 0.055


@lru_cache(maxsize=None)
def _shipped(name: str):
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath(f"{name}.toml").read_text())
    return setup.robot, api.plan_scenario(setup), load_drives(drive_file_for("irb140"), setup.robot.n)


@pytest.fixture(scope="module")
def corner():
    return _shipped("corner_g2")


def _run(planned, mode, rigid, payload=0.0, **kw):
    robot, result, drives = planned
    drives = drives.rigid() if rigid else drives
    st = make_streamer(robot, result, mode, drives, **kw)
    carried = robot.with_payload(Payload(mass=payload, com=(0.0, 0.0, 0.1))) if payload else None
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0], plant_robot=carried), result.duration + 2.0)
    return st, run


def _end_distance(robot, path, q_end: np.ndarray) -> float:
    """The link side's TCP distance [m] from the planned TCP path at the end of a run (dense search)."""
    lo, hi = path.domain
    grid = np.linspace(lo, hi, 20001)
    line_ = planned_tcp_line(robot, path, grid)
    return float(np.min(np.linalg.norm(line_ - fk(robot, q_end[None])[0][0], axis=1)))


def test_an_unknown_payload_trips_the_supervision_and_the_arm_stops_on_the_path(corner, tmp_path):
    robot, result, _ = corner
    path = result.trajectory.path
    # the payload that makes the orbital loop diverge (7.5 kg: the arm ends 52 mm off the path without the
    # supervision), and a joint tolerance that trips where the deviation is across the path (0.05 rad trips at
    # 0.1 s, the arm still lagging along it, where the TCP figure is no first-order distance from the path)
    st, run = _run(corner, "orbital", rigid=True, payload=PAYLOAD, path_tolerance=TOLERANCE)
    sv = st.supervision
    assert sv.tripped is not None and st.stop_reason.startswith("the arm left the path")
    assert st.loop is None  # the loop kept pushing the arm away during the stop: switched off
    # the stop along the path: the references' theta never runs back and comes to rest before the plan's end
    theta = np.array([r.theta for r in st.records])
    assert np.all(np.diff(theta) >= -1e-12) and theta[-1] < path.domain[1] - 0.1 * (path.domain[1] - path.domain[0])
    ended_at = _end_distance(robot, path, run.q[-1])
    assert ended_at < 1e-3, ended_at  # the trip stops on its own cycle
    # the peer: the same run without the supervision leaves the arm far from the path
    _, free = _run(corner, "orbital", rigid=True, payload=PAYLOAD, path_tolerance=None)
    assert _end_distance(robot, path, free.q[-1]) > 100 * max(ended_at, 1e-3)
    # the tripping deviation against a dense search of the path near it (rigid gears: the reported joints are
    # the link's, the planned deflection 0); the TCP figure bounds the distance to the planned TCP path
    e = sv.tripped
    rec = next(r for r in st.records if abs(r.tm / 1e3 - e.t) < 1e-9)
    lo, hi = path.domain
    dense = np.linspace(max(lo, e.theta - 0.05 * (hi - lo)), min(hi, e.theta + 0.05 * (hi - lo)), 200001)
    phi = path.evaluate(dense)[0]
    k = int(np.argmin(np.sum((phi - rec.reported) ** 2, axis=1)))
    assert e.theta == pytest.approx(dense[k], abs=2 * (dense[1] - dense[0]))
    assert e.deviation == pytest.approx(np.max(np.abs(rec.reported - phi[k])), rel=1e-3)
    assert e.deviation > st.supervision.tolerance == TOLERANCE
    grid = np.linspace(lo, hi, 4001)
    _, _, dist = tcp_path_deviation(robot, path, rec.reported[None], np.array([e.theta]), grid,
                                    planned_tcp_line(robot, path, grid))
    assert dist[0] <= e.tcp * (1 + 1e-6) and e.tcp < 1.5 * dist[0], (e.tcp, dist[0])
    summary = write_execution(tmp_path, robot, st, st.stop_reason)
    assert summary["ended"] == st.stop_reason and summary["peak_path_deviation_rad"] >= e.deviation
    assert summary["peak_path_deviation_tcp_m"] >= e.tcp and (tmp_path / "execution.csv").is_file()


@pytest.mark.parametrize("name", ["circle_smooth", "corner_g2"])
@pytest.mark.parametrize("rigid", [True, False], ids=["rigid", "elastic"])
def test_no_false_alarm_with_shaping(name, rigid):
    st, _ = _run(_shipped(name), "shaping", rigid)
    sv = st.supervision
    assert sv.tripped is None and st.stop_reason is None and st.finished
    assert 0.0 < sv.peak.deviation < 0.5 * sv.tolerance, sv.peak


@pytest.mark.slow
def test_cli_execute_exits_4_when_the_arm_leaves_the_path(tmp_path):
    """The two commands as processes; execute's tolerance below what the arm does: a stop along the path, exit
    4 naming the deviation and what to change, summary.json and execution.csv written."""
    import json

    scenario = tmp_path / "short.toml"
    scenario.write_text(irb140_task("egm_short", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5]))
                        + "[limits]\nuse_jerk = true\n")
    ex, _, _ = run_commands(scenario, ["--out", str(tmp_path / "robot")],
                            ["--out", str(tmp_path / "run"), "--set", "simulate.joint_tolerance=0.0002"])
    assert ex.returncode == 4, ex.stdout + ex.stderr
    error = [ln for ln in ex.stderr.splitlines() if ln.startswith("error:")]
    assert len(error) == 1 and "the arm left the path" in error[0] and "simulate.joint_tolerance" in error[0]
    assert "override" in error[0] and "payload" in error[0]
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["ended"].startswith("the arm left the path") and "0.0002 rad" in summary["ended"]
    assert summary["peak_path_deviation_rad"] > summary["path_deviation_tolerance_rad"] == 0.0002
    assert (tmp_path / "run" / "execution.csv").is_file()


def test_the_supervision_rearms_on_resume():
    """Reported joints 0.1 rad off the path after the start: a stop; at rest, 'resume' arms it again and the same
    deviation stops the motion again."""
    from egm_support import planned
    from pathmotion.execution.messages import encode_robot

    robot, result, drives = planned(irb140_task("egm_short", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5])))
    st = make_streamer(robot, result, "shaping", drives)
    start = st.table.q[0]
    off = start + np.array([0, 0, 0.1, 0, 0, 0])
    k = 0

    def send(q, cycles):
        nonlocal k
        for _ in range(cycles):
            st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
            k += 1

    send(start, 5)
    assert st.stop_reason is None
    send(off, 1)
    first = st.stop_reason
    assert first.startswith("the arm left the path") and not st.supervision.armed
    send(off, int((st.segment.duration + 0.1) / 0.004))  # the stop runs to rest
    st.resume()
    assert st.pending.kind == "resume" and st.stop_reason == first  # switched a lead later
    while st.pending is not None:
        send(start, 1)
    assert st.stop_reason is None and st.supervision.armed
    send(off, 1)
    assert st.stop_reason.startswith("the arm left the path") and st.stop_reason != first
    assert st.supervision.reason() == first  # summary.json and the CLI report the first trip
