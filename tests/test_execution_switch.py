"""execute's switches off the loop: a stop, override or resume request at robot time t is re-timed in a worker
thread from the state at t + lead while the loop answers from the current segment, and switched at the first
message at or after t + lead; overlapping requests; lockstep runs that do not depend on compute time."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from egm_support import irb140_task, line, planned as planned_scenario
from pathmotion import defaults
from pathmotion.execution.drives import VirtualArm
from pathmotion.execution.messages import decode_sensor, encode_robot
from pathmotion.execution.session import make_streamer, run_inprocess, write_execution

LONG = irb140_task("egm_long", line([0.45, -0.15, 0.5], [0.45, 0.15, 0.5]))
CYCLE = 0.004


@pytest.fixture(scope="module")
def planned():
    return planned_scenario(LONG)


class Held:
    """A retime wrapper whose first call waits until the test releases it (at most ``timeout`` s): it records the
    thread it ran on and whether the test released it (a retime on the loop's own thread would hold the loop,
    and the test could not go on to release it)."""

    def __init__(self, retime, timeout: float = 2.0):
        self.retime, self.timeout = retime, timeout
        self.release, self.calls = threading.Event(), []

    def __call__(self, *args):
        if not self.calls:
            self.calls.append((threading.current_thread() is threading.main_thread(),
                               self.release.wait(self.timeout)))
        else:
            self.calls.append((threading.current_thread() is threading.main_thread(), True))
        return self.retime(*args)


def _feed(st, k0: int, cycles: int, q=None):
    """Answer robot messages k0 .. k0 + cycles - 1 (4 ms apart), the arm reporting the reference it got."""
    q = st.table.q[0] if q is None else q
    for k in range(k0, k0 + cycles):
        reply = st.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
        q = decode_sensor(reply, st.n).joints
    return q


def _steps(st):
    sent = np.array([r.sent for r in st.records])
    return np.abs(np.diff(sent, axis=0)).max(axis=1)


@pytest.mark.parametrize("realtime", [False, True], ids=["lockstep", "realtime"])
def test_a_slow_retime_does_not_hold_the_loop(planned, realtime, monkeypatch):
    """The re-timing of a stop is held until the test releases it: the request and the answers until its switch
    return meanwhile (the re-timing runs off the loop's thread), every answer comes from the current segment, and
    the stop is switched at t + lead (real time: the loop never waits; the stop, not ready at its switch, is
    scheduled again from a later state), the references continuous across the switch. The retries are not
    counted here (a loaded machine may need more than the default's: a re-timing slower than the margin times
    the last), only that the loop never waits for them."""
    monkeypatch.setattr(defaults, "EGM_SWITCH_RETRIES", 40)
    robot, result, drives = planned
    st = make_streamer(robot, result, "shaping", drives, realtime=realtime)
    held = Held(st.retime)
    st.retime = held
    lead_cycles = int(round(st.lead / CYCLE))
    q = _feed(st, 0, 30)
    st.stop("stop requested")
    q = _feed(st, 30, lead_cycles + (3 if realtime else -1), q)  # real time: past the switch, still held
    assert st.pending is not None and st.pending.kind == "stop" and st.segment is st.table
    assert len(st.records) == 30 + lead_cycles + (3 if realtime else -1)
    held.release.set()
    k = len(st.records)
    while st.pending is not None and k < 2000:
        q = _feed(st, k, 1, q)
        k += 1
        if realtime:
            time.sleep(CYCLE)  # the robot's clock: a re-timing scheduled again has its lead in real time
    assert held.calls[0] == (False, True), "the re-timing ran on the loop's thread and held it"
    req = st.requests[0]
    assert req.outcome == "switched" and st.segment is not st.table
    assert req.requested == pytest.approx(29 * CYCLE)
    if realtime:
        assert req.attempts >= 2 and req.waited == 0.0 and req.at > req.requested + st.lead
    else:
        assert req.attempts == 1 and req.at == pytest.approx(req.requested + st.lead)
    switch = int(np.ceil(req.at / CYCLE - 1e-9))  # the record of the first message at or after the switch
    assert st.records[switch].tau == pytest.approx(switch * CYCLE - req.at, abs=1e-9)
    assert all(r.tau == pytest.approx(r.tm / 1e3) for r in st.records[:switch])  # the plan until then
    q = _feed(st, k, 200, q)
    steps = _steps(st)
    assert steps[switch - 1:switch + 2].max() <= 1.5 * steps[:switch - 1].max()
    if not realtime:
        assert st.records[-1].theta < result.trajectory.path.domain[1] - 1e-3  # stopped before the end


def test_lockstep_runs_do_not_depend_on_compute_time(planned):
    """Two in-process runs with a stop, one whose re-timing takes 30 ms longer: identical references, the
    stop switched at the request's time plus the lead."""
    import time as _time

    robot, result, drives = planned
    runs = []
    for delay in (0.0, 0.03):
        st = make_streamer(robot, result, "shaping", drives)
        retime = st.retime

        def slow(*args, retime=retime, delay=delay):
            _time.sleep(delay)
            return retime(*args)

        st.retime = slow
        run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0,
                      stop_at=0.3 * result.duration)
        runs.append(st)
    a, b = (np.array([r.sent for r in st.records]) for st in runs)
    assert a.shape == b.shape and np.array_equal(a, b)
    for st in runs:
        (req,) = st.requests
        assert req.outcome == "switched" and req.at == pytest.approx(req.requested + st.lead)


def test_overlapping_requests(planned, caplog):
    """An override pending, then a stop: the stop replaces it. A stop pending: a resume is ignored and a second
    stop (a second Ctrl-C) leaves it as it is; an override only sets the resume's speed. Stopped at rest with a
    resume pending, a stop cancels the resume: the arm stays at rest. A pending resume takes a later override."""
    import logging

    robot, result, drives = planned
    st = make_streamer(robot, result, "none", drives)
    q = _feed(st, 0, 20)
    st.override(0.5)
    assert st.pending.kind == "override"
    st.stop("first")
    with caplog.at_level(logging.WARNING):
        st.resume()
    assert "resume ignored: the stop is not made yet" in caplog.text
    st.stop("second")
    st.override(0.7)
    assert [r.kind for r in st.requests] == ["override", "stop"]
    assert [r.outcome for r in st.requests] == ["cancelled", "pending"] and st.pending is st.requests[1]
    assert st.stop_reason == "first" and st.override_scale == 0.7
    k = 20
    while st.pending is not None:
        q = _feed(st, k, 1, q)
        k += 1
    assert st.requests[1].outcome == "switched" and st.segment is not st.table
    stop_segment = st.segment
    q = _feed(st, k, int(stop_segment.duration / CYCLE) + 2, q)  # to rest
    k += int(stop_segment.duration / CYCLE) + 2
    st.resume()
    assert st.pending.kind == "resume" and st.pending.override == 0.7
    st.override(0.4)  # the pending resume at the new speed
    assert [r.outcome for r in st.requests[2:]] == ["cancelled", "pending"] and st.pending.override == 0.4
    st.stop("third")
    assert st.pending is None and st.requests[-1].outcome == "cancelled" and st.stop_reason == "third"
    theta = st.records[-1].theta
    q = _feed(st, k, 20, q)
    assert st.segment is stop_segment and st.records[-1].theta == pytest.approx(theta, abs=1e-12)


def test_a_pending_stop_survives_the_end_of_serve(planned, tmp_path):
    """serve ends the worker when it ends (as on a Ctrl-C, after which execute serves on): a stop pending then is
    still switched at its time, and summary.json lists each request: kind, robot time requested and switched,
    compute time."""
    robot, result, drives = planned
    st = make_streamer(robot, result, "shaping", drives)
    q = _feed(st, 0, 30)
    st.stop("interrupted")
    st.close()
    assert st.pending is not None
    q = _feed(st, 30, 10, q)
    assert st.pending is None and st.requests[0].outcome == "switched"
    st.override(0.5)  # during the stop: no request, the resume's speed
    summary = write_execution(tmp_path, robot, st, st.stop_reason)
    (entry,) = summary["requests"]
    assert entry["kind"] == "stop" and entry["requested_s"] == pytest.approx(29 * CYCLE)
    assert entry["switched_s"] == pytest.approx(29 * CYCLE + st.lead) and entry["compute_s"] > 0.0
    st.close()


def test_lead_zero_switches_on_the_requests_cycle(planned):
    """--switch-lead 0: the re-timing runs on the request's own call (on the loop's thread), the switch at once."""
    robot, result, drives = planned
    st = make_streamer(robot, result, "none", drives, lead=0.0)
    held = Held(st.retime, timeout=0.0)
    st.retime = held
    _feed(st, 0, 20)
    st.stop("stop requested")
    assert held.calls[0][0] and st.pending is None and st.segment is not st.table
    assert st.requests[0].at == st.requests[0].requested and st.requests[0].outcome == "switched"


def test_real_time_leads_cover_the_last_re_timing_of_the_kind(planned):
    """Against a real controller a request's lead is at least EGM_SWITCH_MARGIN times what the last re-timing of
    its kind took (no re-timing started only to miss its switch); lockstep keeps the lead as set."""
    from pathmotion import defaults

    robot, result, drives = planned
    for realtime, expected in ((True, defaults.EGM_SWITCH_MARGIN * 0.1), (False, defaults.EGM_SWITCH_LEAD)):
        st = make_streamer(robot, result, "none", drives, realtime=realtime)
        _feed(st, 0, 20)
        st._took["override"] = 0.1
        st.override(0.5)
        assert st.pending.at - st.pending.requested == pytest.approx(expected)
        st.close()


def test_the_re_timing_worker_runs_nicer_than_the_loop(planned):
    """On a busy machine the system runs the loop's thread before the worker's (Linux: a thread's own nice)."""
    import os

    robot, result, drives = planned
    st = make_streamer(robot, result, "none", drives)
    retime, seen = st.retime, []

    def nice(*args):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        return retime(*args)

    st.retime = nice
    q = _feed(st, 0, 20)
    st.stop("stop requested")
    _feed(st, 20, 6, q)
    st.close()
    from pathmotion import defaults

    own = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    assert seen == [min(own + defaults.EGM_WORKER_NICE, 19)] and seen[0] > own


def test_behind_a_realtime_loop_the_worker_runs_at_normal_scheduling_and_the_loop_s_nice(planned, monkeypatch):
    """execute --realtime-priority: the worker the SCHED_FIFO loop starts runs SCHED_OTHER (it never preempts the
    loop) at the loop's nice value (not nicer: while it holds Python's lock the loop waits for it to run). The loop
    at a real SCHED_FIFO priority where the system allows it (a few cycles; it never spins), else as serve records
    a granted one."""
    import os

    from pathmotion import defaults
    from pathmotion.execution import realtime as rt

    robot, result, drives = planned
    st = make_streamer(robot, result, "none", drives)
    retime, seen = st.retime, []

    def worker(*args):
        seen.append((os.getpriority(os.PRIO_PROCESS, threading.get_native_id()), rt.current_scheduling()))
        return retime(*args)

    st.retime = worker
    monkeypatch.setattr(rt, "lock_memory", lambda: "not tried in the tests")
    with rt.realtime(1) as got:
        st.scheduling = got if got["policy"] == "SCHED_FIFO" else {"policy": "SCHED_FIFO", "priority": 1}
        q = _feed(st, 0, 20)
        st.stop("stop requested")
        _feed(st, 20, 6, q)
    st.close()
    own = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    assert defaults.EGM_WORKER_NICE_REALTIME == 0
    assert seen == [(own, {"policy": "SCHED_OTHER", "priority": 0})]


def test_the_switch_is_at_the_message_of_its_time_whatever_the_float_sum(planned):
    """t + lead as a float sum can exceed the robot time of the message it names (0.016 + 0.02 >
    36 / 1000): the switch is at that message's time exactly (the re-timing starts from the state there and
    continues the segment before it from there), not one cycle later."""
    robot, result, drives = planned
    st = make_streamer(robot, result, "none", drives)
    q = _feed(st, 0, 5)  # robot time 16 ms
    assert 0.016 + 0.02 > 36 / 1000
    st.override(0.5)
    assert st.pending.at == 36 / 1000
    _feed(st, 5, 5, q)  # up to 36 ms
    assert st.pending is None and st.requests[0].outcome == "switched"
    assert st.records[-1].tau == pytest.approx(0.0, abs=1e-9)
    st.close()
