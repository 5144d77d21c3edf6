"""EGM execution: a real UDP loop on localhost (execute's serve against the virtual IRC5 in lockstep), the
drive model against analytic cases, and the malformed / foreign / late inputs of the protocol."""

from __future__ import annotations

import socket
import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis.extra.numpy import arrays as st_arrays
from hypothesis.strategies import floats as st_floats

pytest.importorskip("abb_robot_client")

from egm_support import free_port, irb140_task, line, planned as planned_scenario, run_commands  # noqa: E402
from pathmotion.errors import ExecutionError  # noqa: E402
from pathmotion.execution.drive_file import drive_file_for, load_drives, parse_drives  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.loops import open_listener, parse_address, run_virtual_robot, serve  # noqa: E402
from pathmotion.execution.messages import decode_robot, decode_sensor, encode_robot  # noqa: E402
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess  # noqa: E402

SHORT = irb140_task("egm_short", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5]))


@pytest.fixture(scope="module")
def planned():
    return planned_scenario(SHORT)


def _streamer(planned, mode="shaping", **kw):
    robot, result, drives = planned
    return make_streamer(robot, result, mode, drives, **kw)


def _until_switched(st, k, q):
    """Answer robot messages k, k + 1, ... (the arm reporting q) until the pending switch is made; the next k."""
    while st.pending is not None:
        st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
        k += 1
    return k


def _inside_limits(robot, records):
    sent = np.array([r.sent for r in records])
    lim = robot.limits
    return bool(np.all(sent >= lim.lower) and np.all(sent <= lim.upper))


def test_udp_lockstep_loop_either_side_first(planned):
    """The virtual robot starts first (its messages are refused until execute listens, and sent again), the
    motion completes through real datagrams, every reference inside the limits, no packet lost."""
    import time

    robot, result, drives = planned
    port = free_port()
    streamer = _streamer(planned)
    arm = VirtualArm(robot, drives, streamer.table.plan[0])
    box = {}
    robot_thread = threading.Thread(target=lambda: box.setdefault(
        "run", run_virtual_robot(arm, ("127.0.0.1", port), lockstep=True, max_time=result.duration + 2.0)))
    robot_thread.start()
    time.sleep(0.2)  # nobody listens yet: the robot's first messages go unanswered and are sent again
    sock = open_listener(port, "127.0.0.1")
    try:
        ended = serve(sock, streamer, first_timeout=10.0, silence=2.0)
    finally:
        robot_thread.join(20.0)
        sock.close()
    run = box["run"]
    assert ended == "done" and run.ended == "done"
    assert run.resent >= 1
    assert streamer.counts.lost == 0 and streamer.counts.rejected == 0
    assert _inside_limits(robot, streamer.records)
    # the arm ends where the plan ends (link side), independent of the messages' route
    end = result.trajectory.at_time([result.duration]).q[0]
    assert np.abs(arm.state.q - end).max() < 1e-3  # still ringing within the settle window


def test_a_late_answer_to_a_message_sent_again_is_not_taken_for_the_next(planned):
    """Lockstep: one answer comes after the robot's resend timeout, so the robot sends that message again and
    then receives two answers to it. The second is stale by the next cycle: every cycle still moves the arm
    by the answer to its own message (no one-cycle lag for the rest of the motion)."""
    import time

    from pathmotion.execution.messages import encode_sensor

    robot, result, drives = planned
    q0 = result.trajectory.at_time([0.0]).q[0]
    sensor = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sensor.bind(("127.0.0.1", 0))
    cycles, late_tm, resend = 30, 40, 0.02

    def answer_all():
        seen, seqno = set(), 0
        sensor.settimeout(5.0)
        while True:
            data, peer = sensor.recvfrom(4096)
            msg = decode_robot(data)
            if msg.tm == late_tm:
                # the first copy: the robot gives up waiting and sends it again; the repeats' answers come once
                # the robot has taken the first answer and moved on
                time.sleep(3 * resend if msg.tm not in seen else 0.005)
            seen.add(msg.tm)
            seqno += 1
            done = msg.tm >= 4 * (cycles - 1)
            sensor.sendto(encode_sensor(seqno, msg.tm, q0 + 1e-4 * msg.tm, None, done=done), peer)
            if done:
                return

    thread = threading.Thread(target=answer_all)
    thread.start()
    try:
        run = run_virtual_robot(VirtualArm(robot, drives, q0), sensor.getsockname(), lockstep=True,
                                max_time=1.0, resend=resend)
    finally:
        thread.join(10.0)
        sensor.close()
    assert run.ended == "done" and run.resent >= 1 and len(run.reference) == cycles
    tm = 4.0 * np.arange(cycles)
    np.testing.assert_allclose(np.asarray(run.reference), q0 + 1e-4 * tm[:, None], atol=1e-9)


@pytest.fixture(scope="module")
def planned_smooth():
    """SHORT with the jerk limits: elastic gears ring after the acceleration steps of a second-order plan."""
    return planned_scenario(SHORT + "[limits]\nuse_jerk = true\n")


def test_shaping_beats_none_on_elastic_gears(planned_smooth):
    """Through the elastic drives, shaping's path accuracy on a jerk-limited plan is better than the raw plan's,
    and within 0.25 mm; either way the arm starts moving no earlier than EGM's transport delay after the first
    message, and within a few cycles of it."""
    planned = planned_smooth
    robot, result, drives = planned
    out = {}
    for mode in ("none", "shaping"):
        st = _streamer(planned, mode)
        run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0)
        figures = arm_figures(robot, run)
        out[mode] = figures["path_accuracy_m"]
        assert drives.transport_delay <= figures["start_latency_s"] <= drives.transport_delay + 4 * drives.cycle
    assert out["shaping"] < out["none"]
    assert out["shaping"] <= 0.25e-3


def test_rigid_drive_follows_a_ramp_exactly():
    """Rigid gears, constant-speed ramp on axis 1: the link ends on the ramp's end (feed-forward + integral)."""
    from pathmotion.robot import load_robot

    robot = load_robot("irb140")
    drives = load_drives(drive_file_for("irb140"), 6).rigid()
    q0 = np.radians([0, 20, -10, 0, 40, 0])
    arm = VirtualArm(robot, drives, q0)
    speed = 0.5
    for k in range(300):
        t = k * drives.cycle
        p = q0.copy()
        p[0] += speed * min(t, 0.4)
        s = np.zeros(6)
        s[0] = speed if t < 0.4 else 0.0
        arm.cycle(p, s)
    assert arm.state.q[0] == pytest.approx(q0[0] + 0.2, abs=1e-6)


def test_elastic_gear_holds_the_static_deflection():
    """Held still, an elastic gear's deflection equals gravity torque / stiffness (the analytic static case)."""
    import pinocchio as pin
    from pathmotion.robot import load_robot

    robot = load_robot("irb140")
    drives = load_drives(drive_file_for("irb140"), 6)
    q0 = np.radians([0, 30, -20, 0, 30, 0])
    arm = VirtualArm(robot, drives, q0)
    hold = arm.feedback
    for _ in range(100):
        arm.cycle(hold, np.zeros(6))
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), arm.state.q)
    wind = (arm.state.qm - arm.state.q)[:3]
    assert wind == pytest.approx(g[:3] / drives.stiffness[:3], rel=1e-3, abs=1e-7)


def _feed(streamer, packets):
    replies = []
    for p in packets:
        replies.append(streamer.handle(p, 0.0, lambda: 0.0))
    return replies


def test_garbage_truncated_and_huge_datagrams_are_rejected(planned):
    st = _streamer(planned)
    good = encode_robot(1, 0, st.table.q[0], st.table.q[0])
    replies = _feed(st, [b"not a protobuf \xff\xff", good[: len(good) - 3], b"\x00" * 65536, good])
    assert replies[:3] == [None, None, None] and replies[3] is not None
    assert st.counts.rejected == 3
    with pytest.raises(ExecutionError, match="bytes are not an EgmRobot"):
        decode_robot(b"\xff" * 20)


def test_a_seven_joint_robot_is_refused(planned):
    st = _streamer(planned)
    q7 = np.append(st.table.q[0], 0.0)
    with pytest.raises(ExecutionError, match="reports 7 joints, the plan has 6"):
        st.handle(encode_robot(1, 0, q7, q7), 0.0, lambda: 0.0)


def test_a_robot_away_from_the_start_is_refused_with_the_distance(planned):
    st = _streamer(planned)
    q = st.table.q[0].copy()
    q[2] += 0.1
    with pytest.raises(ExecutionError, match=r"joint 3 is 5\.7\d+ deg"):
        st.handle(encode_robot(1, 0, q, q), 0.0, lambda: 0.0)


def test_sequence_numbers_lost_duplicated_out_of_order(planned):
    st = _streamer(planned)
    q = st.table.q[0]
    seqs = [1, 2, 2, 5, 4, 6]
    replies = _feed(st, [encode_robot(s, 4 * s, q, q) for s in seqs])
    assert st.counts.duplicated == 1 and st.counts.lost == 2 and st.counts.out_of_order == 1
    assert replies[2] == replies[1]  # a repeated message gets the same answer again
    assert replies[4] is None  # an older message is not answered
    assert [decode_sensor(r, 6).seqno for r in replies if r is not None] == [1, 2, 2, 3, 4]


def test_stop_along_the_path_never_jumps_and_stays_in_limits(planned):
    """A stop mid-motion (the Retimer's shortest stop, switched at 0.4 of the plan): every reference lies on the
    plan's joint path at its own theta, theta never runs back, the arm comes to rest before the path's end,
    inside the limits."""
    robot, result, drives = planned
    st = _streamer(planned, "none")
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0,
                        stop_at=0.4 * result.duration - st.lead)
    path = result.trajectory.path
    theta = np.array([r.theta for r in st.records])
    assert st.stop_reason == "stop requested"
    assert theta[-1] < path.domain[1] - 1e-6  # stopped before the end
    assert np.all(np.diff(theta) >= -1e-12)  # never runs back
    sent = np.array([r.sent for r in st.records])
    assert np.abs(sent - path.evaluate(theta)[0]).max() < 1e-5  # on the path (table interpolation)
    assert np.abs(np.diff(sent, axis=0)).max() < robot.limits.velocity.max() * 0.004
    assert _inside_limits(robot, st.records)
    assert np.abs(run.arm.state.qd).max() < 1e-2


def test_override_slows_the_rest_of_the_motion(planned):
    """override 0.5 at the start: the motion takes longer than the plan (the Retimer's re-timed rest)."""
    robot, result, drives = planned
    st = _streamer(planned, "none")
    q = st.table.q[0]
    st.handle(encode_robot(1, 0, q, q), 0.0, lambda: 0.0)
    st.override(0.5)
    _until_switched(st, 1, q)
    assert st.segment.duration > 1.3 * result.duration


def test_override_at_full_speed_on_a_jerk_limited_plan_slows_the_motion(planned_smooth, caplog):
    """A jerk-limited plan at its top speed: the jerk-limited re-timer refuses override 0.5 (the state is above
    the override's envelope), so execute brakes into it within the second-order limits (a warning says so)
    instead of keeping the motion: the re-timed motion enters the envelope (Retimer.max_speed at 0.5) and stays
    in it, slower than the plan's rest, its shaped motion is within the plan's velocity, acceleration and torque limits, every reference inside
    the joint limits, and it ends at the plan's end."""
    import logging

    from pathmotion.execution.shaped_limits import motion_ratios
    from pathmotion.planning import effective_limits
    from pathmotion.planning.retime import Retimer

    robot, result, drives = planned_smooth
    st = _streamer(planned_smooth, "shaping")
    profile = result.profile
    top = float(np.sqrt(profile.x.max()))
    t_top = float(profile.times[int(np.argmax(profile.x > 0.8 ** 2 * top ** 2))])  # 0.8 of the top speed, rising
    q = st.table.q[0]
    k = 0
    while 0.004 * k < t_top:
        st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
        q = st.records[-1].sent
        k += 1
    with caplog.at_level(logging.WARNING):
        st.override(0.5)
        k = _until_switched(st, k, q)
    assert st.segment is not st.table, "the override kept the motion"
    assert "within the second-order limits" in caplog.text
    # it brakes into the override's envelope (the largest speed from which the end is reachable at 0.5) and stays in
    retimer = Retimer(result)
    theta, theta_dot = st.segment.motion[:, 0], st.segment.motion[:, 1]
    moving = theta < theta[-1] - 1e-3 * (theta[-1] - theta[0])
    envelope = np.array([retimer.max_speed(th, 0.5) for th in theta[moving]])
    inside = theta_dot[moving] <= 1.01 * envelope
    assert inside.any() and inside[int(np.argmax(inside)):].all()
    assert st.segment.duration > 1.05 * (result.duration - st.requests[-1].at)  # slower than the plan's rest
    assert st.segment.theta[-1] == pytest.approx(st.table.theta[-1], abs=1e-9)
    ratios = motion_ratios(robot, result.trajectory.path, st.segment.motion, effective_limits(robot, result.settings))
    assert max(ratios.values()) <= 1.0 + result.settings.limit_tolerance, ratios
    for j in range(k, k + 2000):
        if st.finished:
            break
        st.handle(encode_robot(j + 1, 4 * j, q, q), 0.0, lambda: 0.0)
        q = st.records[-1].sent
    assert st.finished and _inside_limits(robot, st.records)


def test_a_controller_that_vanishes_mid_motion_ends_in_a_stop(planned):
    robot, result, drives = planned
    sock = open_listener(0, "127.0.0.1")
    port = sock.getsockname()[1]
    st = _streamer(planned)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tx.settimeout(2.0)
    q = st.table.plan[0]
    box = {}
    server = threading.Thread(target=lambda: box.setdefault("ended", serve(sock, st, first_timeout=5.0, silence=0.2)))
    server.start()
    try:
        for k in range(10):
            tx.sendto(encode_robot(k + 1, 4 * k, q, q), ("127.0.0.1", port))
            tx.recv(65536)
        server.join(5.0)
    finally:
        tx.close()
        sock.close()
    assert box["ended"] == "silent"
    assert st.stop_reason == "the controller went silent"


def test_drive_file_errors_name_the_key():
    text = drive_file_for("irb140").read_text()
    with pytest.raises(Exception, match="6 \\[\\[axes\\]\\] tables for a 7-joint arm"):
        parse_drives(text, 7)
    with pytest.raises(Exception, match="egm.lowpass_bandwidth.status"):
        parse_drives(text.replace('lowpass_bandwidth = { value = 20.0, status = "estimate"',
                                  'lowpass_bandwidth = { value = 20.0, status = "guess"'), 6)


def test_address_errors():
    assert parse_address("127.0.0.1:6510") == ("127.0.0.1", 6510)
    with pytest.raises(ExecutionError, match="a UDP port is 0-65535"):
        open_listener(70000)
    with open_listener(0, "127.0.0.1") as taken, pytest.raises(ExecutionError, match="cannot listen on UDP port"):
        open_listener(taken.getsockname()[1], "127.0.0.1")
    for bad in ("6510", "host:", "host:70000", ":1"):
        with pytest.raises(ExecutionError, match="HOST:PORT"):
            parse_address(bad)


@pytest.mark.slow
def test_cli_execute_against_virtual_robot(tmp_path):
    """The two commands as processes: execute started second, both exit 0 and write their files; a jerk-limited
    plan (the elastic gears ring after a second-order plan's acceleration steps) tracks within 1 mm."""
    import json

    scenario = tmp_path / "short.toml"
    scenario.write_text(SHORT + "[limits]\nuse_jerk = true\n")
    ex, robot, out = run_commands(scenario, ["--out", str(tmp_path / "robot")], ["--out", str(tmp_path / "run")])
    assert ex.returncode == 0, ex.stdout + ex.stderr
    assert robot.returncode == 0, out
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["ended"] == "done" and summary["packets_lost"] == 0
    assert (tmp_path / "run" / "execution.csv").is_file() and (tmp_path / "robot" / "robot.csv").is_file()
    arm = json.loads((tmp_path / "robot" / "summary.json").read_text())
    assert arm["ended"] == "done" and arm["path_accuracy_m"] < 1e-3


def test_stdin_commands(planned, caplog):
    """'override F', 'stop', 'resume' lines; a bad line is logged and ignored."""
    from pathmotion.execution.loops import apply_command

    robot, result, drives = planned
    st = _streamer(planned, "none")
    q = st.table.q[0]
    for k in range(10):  # moving
        st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
    apply_command(st, "override 2")
    assert "ignored the command" in caplog.text and st.override_scale == 1.0
    apply_command(st, "override 0.5")
    assert st.override_scale == 0.5
    apply_command(st, "stop")
    assert st.stop_reason == "stop requested"
    k, stop_segment = 10, st.segment
    while k == 10 or st.records[-1].tau < stop_segment.duration:  # until the stop has come to rest
        st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
        k += 1
    assert st.records[-1].theta < result.trajectory.path.domain[1]
    apply_command(st, "resume")
    assert st.pending.kind == "resume"
    _until_switched(st, k, q)
    assert st.stop_reason is None and st.segment.duration > 0
    apply_command(st, "jump 3")
    assert "give 'override F', 'stop' or 'resume'" in caplog.text


@settings(max_examples=50, deadline=None)
@given(st_arrays(np.float64, (20, 6), elements=st_floats(-3.0, 3.0)), st_arrays(np.float64, (20, 6), elements=st_floats(-3.0, 3.0)))
def test_no_sent_reference_leaves_the_limits(scale_q, scale_qd):
    """Whatever the table holds (here up to 3x the limits), what is sent lies inside the position and speed
    limits, and each clipped answer is counted."""
    from pathmotion.execution.reference import ReferenceTable
    from pathmotion.execution.streamer import Streamer
    from pathmotion.robot import load_robot

    lim = load_robot("irb140").limits
    t = np.arange(20) * 0.004
    q = scale_q * np.maximum(np.abs(lim.lower), np.abs(lim.upper))
    qd = scale_qd * lim.velocity
    table = ReferenceTable(t, q, qd, t, q, float(t[-1]), np.zeros_like(q), motion=np.zeros((20, 3)))
    inside = lim.lower + 0.5 * (lim.upper - lim.lower)
    table.q[0] = inside  # the robot's start
    streamer = Streamer(table, None, lim.lower, lim.upper, lim.velocity, tolerance=1e-9)
    outside = 0
    for k in range(20):
        reply = streamer.handle(encode_robot(k + 1, 4 * k, inside, inside), 0.0, lambda: 0.0)
        sent = decode_sensor(reply, 6)
        assert np.all(sent.joints >= lim.lower - 1e-12) and np.all(sent.joints <= lim.upper + 1e-12)
        assert np.all(np.abs(sent.speed) <= lim.velocity + 1e-12)
        outside += bool(np.any(q[k] < lim.lower) or np.any(q[k] > lim.upper) or np.any(np.abs(qd[k]) > lim.velocity))
    assert streamer.counts.clipped == outside


def test_a_shaped_stop_continues_the_references(planned):
    """With shaping (the averaged second-order plan), a stop's references start where the plan's left off: the
    step between consecutive references at the switch is no larger than the steps of the motion before it."""
    robot, result, drives = planned
    st = _streamer(planned, "shaping")
    stop_at = 0.4 * result.duration
    run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0, stop_at=stop_at)
    sent = np.array([r.sent for r in st.records])
    steps = np.abs(np.diff(sent, axis=0)).max(axis=1)
    k = int(round(st.requests[0].at / drives.cycle))  # the switch, a lead after the request
    assert st.requests[0].outcome == "switched" and k > int(round(stop_at / drives.cycle))
    assert steps[k - 1:k + 2].max() <= 1.5 * steps[:k - 1].max()
    assert _inside_limits(robot, st.records)


@pytest.mark.parametrize("rigid", [True, False], ids=["rigid", "elastic"])
def test_the_first_reference_is_the_robots_start(planned_smooth, rigid):
    """With shaping (gear deflection, low-pass inverse), the first reference sent is where the
    robot reports it is (the motor side, wound up by gravity on elastic gears), and the references of a
    jerk-limited plan leave it with no larger step than the motion's own later steps; none is clipped."""
    robot, result, drives = planned_smooth
    drives = drives.rigid() if rigid else drives
    st = make_streamer(robot, result, "shaping", drives)
    arm = VirtualArm(robot, drives, st.table.plan[0])
    start = arm.feedback
    run_inprocess(st, arm, result.duration + 0.5)
    sent = np.array([r.sent for r in st.records])
    assert np.abs(sent[0] - start).max() < 1e-12
    steps = np.abs(np.diff(sent, axis=0)).max(axis=1)
    assert steps[:5].max() <= steps[5:].max() and st.counts.clipped == 0


def test_serve_pauses_the_cycle_collector_and_restores_it(monkeypatch):
    """A collection of the whole heap takes about 25 EGM cycles: serve rehearses the streamer's cycle, then
    answers with the collector paused and Python's switch interval lowered (the re-timing worker yields the
    interpreter quickly), and leaves both as it found them and the worker ended, also when the loop raises."""
    import gc
    import socket
    import sys

    from pathmotion import defaults
    from pathmotion.execution.loops import open_listener, serve

    seen = []

    class OneMessage:
        mode, started, stop_reason = "none", False, None
        finished = False

        def rehearse(self):
            seen.append("rehearsed")

        def close(self):
            seen.append("closed")

        def handle(self, data, t_recv, clock):
            seen.append(gc.isenabled())
            seen.append(sys.getswitchinterval())
            self.started = self.finished = True
            return b"ok"

    sock = open_listener(0, "127.0.0.1")
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    robot.sendto(b"x", sock.getsockname())
    assert gc.isenabled()
    interval = sys.getswitchinterval()
    assert serve(sock, OneMessage(), first_timeout=5.0) == "done"
    assert seen == ["rehearsed", False, pytest.approx(defaults.EGM_SWITCH_INTERVAL), "closed"] and robot.recv(16) == b"ok"
    assert gc.isenabled() and sys.getswitchinterval() == interval

    class Raises(OneMessage):
        def handle(self, data, t_recv, clock):
            raise KeyboardInterrupt

    robot.sendto(b"x", sock.getsockname())
    with pytest.raises(KeyboardInterrupt):
        serve(sock, Raises(), first_timeout=5.0)
    assert gc.isenabled() and gc.get_freeze_count() == 0
    assert seen[-1] == "closed" and sys.getswitchinterval() == interval  # the worker ended on the interrupt too
    sock.close()
    robot.close()
