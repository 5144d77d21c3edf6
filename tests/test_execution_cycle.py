"""execute's per-cycle path against the straightforward computation it replaces: the table lookup (one stacked
row), the reused protobuf messages, the clipping and the supervision's single compiled projection give the
same doubles and the same bytes as per-array interpolation, fresh messages, np.clip/np.degrees/np.radians and
simulate's monitor called on its own."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from abb_robot_client.egm import egm_pb2  # noqa: E402

from egm_support import irb140_task, line, planned as planned_scenario  # noqa: E402
from pathmotion.errors import ExecutionError  # noqa: E402
from pathmotion.execution.messages import RobotDecoder, SensorEncoder, encode_robot  # noqa: E402
from pathmotion.execution.reference import ReferenceTable  # noqa: E402
from pathmotion.execution.session import make_streamer  # noqa: E402

SHORT = irb140_task("egm_cycle", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5]))


@pytest.fixture(scope="module")
def planned():
    return planned_scenario(SHORT)


def _lerp(a: np.ndarray, t: np.ndarray, tau: float):
    """a at plan time tau by per-array linear interpolation on the evenly spaced times t (from 0), clamped."""
    tau = min(max(tau, 0.0), float(t[-1]))
    k = min(int(tau / t[1]), len(t) - 2)
    w = (tau - t[k]) / (t[k + 1] - t[k])
    return a[k] + w * (a[k + 1] - a[k])


def _sensor_bytes(seqno, tm, joints, speed, done):
    """An EgmSensor built field by field in a fresh message, degrees by np.degrees."""
    msg = egm_pb2.EgmSensor()
    msg.header.seqno = seqno
    msg.header.tm = tm
    msg.header.mtype = egm_pb2.EgmHeader.MSGTYPE_CORRECTION
    msg.RAPIDtoRobot.digVal = done
    msg.planned.joints.joints.extend(np.degrees(joints).tolist())
    if speed is not None:
        msg.speedRef.joints.joints.extend(np.degrees(speed).tolist())
    return msg.SerializeToString()


def test_the_table_lookup_is_per_array_interpolation_bit_for_bit():
    rng = np.random.default_rng(7)
    k, n = 57, 6
    t = np.arange(k) * 0.001
    arrays = [rng.normal(size=(k, n)) for _ in range(4)]
    theta = np.cumsum(rng.uniform(0.0, 0.01, k))
    table = ReferenceTable(t, arrays[0], arrays[1], theta, arrays[2], float(t[-1]), arrays[3])
    taus = np.concatenate([rng.uniform(-0.01, t[-1] + 0.01, 400), t, t[:-1] + 0.0005, [t[-1] + 1.0, -1.0]])
    for tau in taus:
        q, qd, plan, th, deflection = table.at(float(tau))
        for got, a in zip((q, qd, plan, deflection), arrays[:2] + arrays[2:]):
            assert np.array_equal(got, _lerp(a, t, float(tau)))
        assert th == float(_lerp(theta, t, float(tau)))
    # one row: that row, whatever the time
    single = ReferenceTable(t[:1], arrays[0][:1], arrays[1][:1], theta[:1], arrays[2][:1], 0.0, arrays[3][:1])
    assert all(np.array_equal(a, b) for a, b in zip(single.at(3.0)[:3], (arrays[0][0], arrays[1][0], arrays[2][0])))


def test_the_reused_messages_give_the_bytes_and_values_of_fresh_ones():
    rng = np.random.default_rng(3)
    encode, decode = SensorEncoder(), RobotDecoder()
    for i in range(200):
        q, qd = rng.uniform(-3.0, 3.0, 6), rng.uniform(-5.0, 5.0, 6)
        speed = None if i % 3 == 0 else qd  # a message without speeds after one with them: none are left over
        seqno, tm, done = int(rng.integers(0, 2**32)), int(rng.integers(0, 2**32)), bool(i % 5 == 0)
        assert encode(seqno, tm, q, speed, done) == _sensor_bytes(seqno, tm, q, speed, done)
        msg = decode(encode_robot(i + 1, 4 * i, q, qd))
        assert (msg.seqno, msg.tm) == (i + 1, 4 * i)
        assert np.array_equal(msg.joints, np.radians(np.degrees(q)))
        assert np.array_equal(msg.planned, np.radians(np.degrees(qd)))
        with pytest.raises(ExecutionError):
            decode(b"\xff" * 20)  # a rejected datagram leaves nothing behind for the next
    bad = encode_robot(1, 0, np.array([0.1, np.nan, 0.0, 0.0, 0.0, 0.0]), np.zeros(6))
    with pytest.raises(ExecutionError, match="not finite"):
        decode(bad)


def test_the_streamed_references_are_the_plan_table_clipped(planned):
    """After a rehearsal, every answer of a whole run (the arm reporting the reference it got) carries the table's references at
    its time, interpolated per array and clipped by np.clip, in degrees by np.degrees: bit for bit; and the
    supervision's projection is simulate's monitor and the path evaluation called one by one."""
    from pathmotion.control.kernels import evaluate_at
    from pathmotion.simulation.monitor import monitor_state

    robot, result, drives = planned
    st = make_streamer(robot, result, "shaping", drives)
    sv = st.supervision
    theta0 = sv.theta
    st.rehearse()  # as serve does: on a copy, this streamer untouched
    assert not st.started and not st.records and st.counts.received == 0 and st.seqno_out == 0
    assert sv.theta == theta0 and sv.peak.deviation == 0.0 and sv.tolerance < np.inf
    table, lim = st.table, robot.limits
    q_now = table.q[0]
    k, peak_tcp = 0, 0.0
    while not st.finished:
        theta_before = sv.theta
        reply = st.handle(encode_robot(k + 1, 4 * k, q_now, q_now), 0.0, lambda: 0.0)
        rec = st.records[-1]
        q = np.clip(_lerp(table.q, table.t, rec.tau), lim.lower, lim.upper)
        qd = np.clip(_lerp(table.qd, table.t, rec.tau), -lim.velocity, lim.velocity)
        assert reply == _sensor_bytes(k + 1, 4 * k, q, qd, st.finished)
        assert np.array_equal(rec.plan, _lerp(table.plan, table.t, rec.tau))
        q_hat = rec.reported - _lerp(table.deflection, table.t, rec.tau)
        theta, _, deviation, *_ = monitor_state(sv.arrays, q_hat, np.zeros(6), theta_before, sv.projection,
                                                np.full(6, np.inf), 0.0)
        assert (sv.theta, sv.deviation) == (theta, deviation)
        gap = sv._tcp(q_hat).copy() - sv._tcp(evaluate_at(sv.arrays, theta)[0])
        peak_tcp = max(peak_tcp, np.sqrt(gap @ gap))  # the supervision computes it only where it can matter
        assert sv.peak_tcp == peak_tcp
        q_now = np.radians(np.degrees(q))
        k += 1
    assert k > 100 and st.counts.clipped == 0 and st.stop_reason is None and peak_tcp > 0.0


def test_the_tcp_reach_bounds_the_tcp_distance(planned):
    """|FK(a) - FK(b)| <= sum_j r_j |a_j - b_j| for the IRB 140 (the bound that lets the supervision skip the
    forward kinematics), at random configurations and steps from micro-radians to a radian."""
    from pathmotion.execution.supervision import tcp_reach
    from pathmotion.robot import fk

    robot = planned[0]
    reach = tcp_reach(robot.model, robot.tcp_frame_id)
    assert np.all(np.isfinite(reach)) and reach[0] > reach[1] > reach[2] > 0.0
    rng = np.random.default_rng(11)
    lim = robot.limits
    a = rng.uniform(lim.lower, lim.upper, (300, 6))
    b = a + rng.normal(size=(300, 6)) * 10.0 ** rng.uniform(-6, 0, (300, 1))
    dist = np.linalg.norm(fk(robot, a)[0] - fk(robot, b)[0], axis=1)
    assert np.all(dist <= np.abs(a - b) @ reach + 1e-12)
    assert np.max(dist / (np.abs(a - b) @ reach)) > 0.3  # and not a vacuous one


def test_a_rehearsal_mid_run_leaves_the_streamer_as_it_was(planned, caplog):
    """serve rehearses again when it is entered again (after a Ctrl-C, during the stop): the streamer's state,
    counts, records and supervision are untouched, nothing is logged, and the next answer is what it would be."""
    import copy
    import logging

    robot, result, drives = planned
    st = make_streamer(robot, result, "orbital", drives)
    q = st.table.q[0]
    for k in range(60):
        st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
        q = st.records[-1].sent
    st.stop("stop requested")
    st.handle(encode_robot(61, 240, q, q), 0.0, lambda: 0.0)
    fields = ("_now", "_segment_start", "_last_seq", "_tm0", "seqno_out", "stop_reason", "_last_reply")
    before = {f: getattr(st, f) for f in fields}
    segment, counts, records = st.segment, copy.copy(st.counts), list(st.records)
    watch = copy.copy(st.supervision.__dict__)
    correction = st.loop.correction.copy()
    twin = copy.copy(st)
    twin.records, twin.counts = list(st.records), copy.copy(st.counts)
    twin.supervision, twin.loop = copy.copy(st.supervision), copy.copy(st.loop)
    caplog.clear()
    with caplog.at_level(logging.INFO):
        st.rehearse()
    assert not caplog.records
    assert {f: getattr(st, f) for f in fields} == before and st.segment is segment
    assert st.counts == counts and st.records == records and np.array_equal(st.loop.correction, correction)
    assert all(st.supervision.__dict__[k] is v for k, v in watch.items())
    message = encode_robot(62, 244, q, q)
    assert st.handle(message, 0.0, lambda: 0.0) == twin.handle(message, 0.0, lambda: 0.0)
