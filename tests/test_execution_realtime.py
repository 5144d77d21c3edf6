"""execute --realtime-priority: the loop thread at SCHED_FIFO with the memory locked where the system grants it, a
warning naming what to change and normal priority where it refuses (both paths faked, so that they run as any
user), the scheduling restored after, the re-timing worker at normal scheduling, and what the loop got in
summary.json. The runs at a real SCHED_FIFO priority are short (the loop blocks in select, never spins) and are
skipped where the system refuses."""

from __future__ import annotations

import errno
import os
import socket
import threading

import pytest

from pathmotion import defaults
from pathmotion.execution import realtime as rt
from pathmotion.execution.realtime import current_scheduling, realtime

linux = pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="Linux scheduling")


class FakeLibc:
    """mlockall / munlockall that record their calls and answer ``result`` (-1: refused)."""

    def __init__(self, result=0):
        self.result, self.calls = result, []

    def mlockall(self, flags):
        self.calls.append(("mlockall", flags))
        return self.result

    def munlockall(self):
        self.calls.append(("munlockall",))
        return 0


class FakeScheduler:
    """os.sched_* over a table thread id -> (policy, priority): what the real calls would do where permitted."""

    def __init__(self, monkeypatch, refuse=False):
        self.table, self.calls, self.refuse = {}, [], refuse
        monkeypatch.setattr(os, "sched_getscheduler", lambda tid: self.table.get(tid, (os.SCHED_OTHER, 0))[0])
        monkeypatch.setattr(os, "sched_getparam",
                            lambda tid: os.sched_param(self.table.get(tid, (os.SCHED_OTHER, 0))[1]))
        monkeypatch.setattr(os, "sched_setscheduler", self.set)

    def set(self, tid, policy, param):
        self.calls.append((tid, policy, param.sched_priority))
        if self.refuse:
            raise PermissionError(errno.EPERM, "Operation not permitted")
        self.table[tid] = (policy, param.sched_priority)


@linux
def test_refused_priority_and_memory_lock_warn_and_go_on(monkeypatch, caplog):
    """No CAP_SYS_NICE, RLIMIT_RTPRIO 0, RLIMIT_MEMLOCK too small: no error; warnings name what was refused and what
    to change; the block runs at normal priority, and nothing is undone after."""
    sched = FakeScheduler(monkeypatch, refuse=True)
    libc = FakeLibc(-1)
    monkeypatch.setattr(rt, "_libc", lambda: libc)
    monkeypatch.setattr(rt.ctypes, "get_errno", lambda: errno.EPERM)
    tid = threading.get_native_id()
    with realtime(50) as got:
        inside = current_scheduling()
    assert sched.calls == [(tid, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50)]  # asked, refused, never restored
    assert inside == {"policy": "SCHED_OTHER", "priority": 0}
    assert got["requested_priority"] == 50 and got["policy"] == "SCHED_OTHER" and got["priority"] == 0
    assert not got["memory_locked"] and len(got["refused"]) == 2
    assert libc.calls == [("mlockall", rt._mcl_flags())]  # nothing to unlock
    text = caplog.text
    assert "SCHED_FIFO priority 50" in text and "Operation not permitted" in text
    assert "CAP_SYS_NICE" in text and "ulimit -r 50" in text and "/etc/security/limits.conf" in text
    assert "mlockall refused" in text and "ulimit -l" in text and "normal priority" in text


def test_no_realtime_scheduling_on_this_system(monkeypatch, caplog):
    """Not Linux (no os.sched_setscheduler): a warning, the block runs as it is."""
    for name in ("sched_setscheduler", "sched_getscheduler", "sched_getparam"):
        monkeypatch.delattr(os, name, raising=False)
    monkeypatch.setattr(rt.sys, "platform", "darwin")
    with realtime(50) as got:
        pass
    assert got["policy"] == "unknown" and not got["memory_locked"]
    assert "not available on this system" in caplog.text and "normal priority" in caplog.text


@linux
def test_granted_priority_is_set_and_restored(monkeypatch, caplog):
    """Where permitted: the thread at SCHED_FIFO (its children reset to normal scheduling), the memory locked
    (present and future pages), both undone on exit, an exception's exit included; no warning."""
    sched = FakeScheduler(monkeypatch)
    libc = FakeLibc(0)
    monkeypatch.setattr(rt, "_libc", lambda: libc)
    tid = threading.get_native_id()
    sched.table[tid] = (os.SCHED_OTHER, 0)
    with pytest.raises(KeyboardInterrupt):
        with realtime(50) as got:
            assert sched.table[tid] == (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50)
            raise KeyboardInterrupt
    assert got == {"requested_priority": 50, "policy": "SCHED_FIFO", "priority": 50, "memory_locked": True,
                   "refused": []}
    assert sched.table[tid] == (os.SCHED_OTHER, 0)
    assert libc.calls == [("mlockall", rt._mcl_flags()), ("munlockall",)]
    assert rt._mcl_flags() & 3 == 3 or rt._mcl_flags() == 0x6000  # MCL_CURRENT | MCL_FUTURE
    assert "realtime-priority" not in caplog.text


@linux
def test_granted_by_rlimit_alone_the_scheduling_is_restored_too(monkeypatch):
    """SCHED_FIFO granted by RLIMIT_RTPRIO without CAP_SYS_NICE: Linux refuses to clear SCHED_RESET_ON_FORK, so the
    thread goes back to its policy with the flag kept (not left at SCHED_FIFO)."""
    sched = FakeScheduler(monkeypatch)
    set_ = sched.set

    def no_clearing(tid, policy, param):
        flag = os.SCHED_RESET_ON_FORK
        if sched.table.get(tid, (0, 0))[0] & flag and not policy & flag:
            raise PermissionError(errno.EPERM, "Operation not permitted")
        set_(tid, policy, param)

    monkeypatch.setattr(os, "sched_setscheduler", no_clearing)
    monkeypatch.setattr(rt, "lock_memory", lambda: "not tried in the tests")
    tid = threading.get_native_id()
    with realtime(20) as got:
        assert sched.table[tid] == (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 20)
    assert got["policy"] == "SCHED_FIFO"
    assert sched.table[tid] == (os.SCHED_OTHER | os.SCHED_RESET_ON_FORK, 0)
    assert current_scheduling() == {"policy": "SCHED_OTHER", "priority": 0}


def test_priority_zero_changes_nothing(monkeypatch):
    sched = FakeScheduler(monkeypatch) if hasattr(os, "sched_setscheduler") else None
    libc = FakeLibc(0)
    monkeypatch.setattr(rt, "_libc", lambda: libc)
    with realtime(0) as got:
        pass
    assert got["requested_priority"] == 0 and not got["memory_locked"] and got["refused"] == []
    assert libc.calls == [] and (sched is None or sched.calls == [])


@linux
def test_a_worker_started_by_a_realtime_thread_runs_at_normal_scheduling(monkeypatch):
    """The worker's initializer puts an inherited real-time policy back to SCHED_OTHER, and sets its nice value."""
    from pathmotion.execution.streamer import _lower_priority

    sched = FakeScheduler(monkeypatch)
    box = {}

    def worker():
        tid = threading.get_native_id()
        sched.table[tid] = (os.SCHED_FIFO, 50)
        nice = os.getpriority(os.PRIO_PROCESS, tid)
        _lower_priority(nice + 1)  # a higher nice value is always allowed
        box.update(policy=sched.table[tid], nice=(nice, os.getpriority(os.PRIO_PROCESS, tid)))

    t = threading.Thread(target=worker)  # a thread of its own: its nice value ends with it
    t.start()
    t.join()
    assert box["policy"] == (os.SCHED_OTHER, 0)
    assert box["nice"][1] == min(box["nice"][0] + 1, 19)


def _granted_or_skip():
    """Skip unless this process may run a thread at SCHED_FIFO 1 (root or CAP_SYS_NICE or RLIMIT_RTPRIO >= 1)."""
    box = {}

    def probe():
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
            box["ok"] = True
        except (AttributeError, OSError):
            box["ok"] = False

    t = threading.Thread(target=probe)  # a thread of its own, that ends at once
    t.start()
    t.join()
    if not box["ok"]:
        pytest.skip("this user may not run SCHED_FIFO threads")


@linux
def test_a_real_fifo_block_and_the_threads_it_starts(monkeypatch):
    """For real, where permitted: SCHED_FIFO 1 inside (no spinning: the block only starts a thread and joins it),
    a thread started inside at normal scheduling, the calling thread's scheduling back after."""
    _granted_or_skip()
    monkeypatch.setattr(rt, "lock_memory", lambda: "not tried in the tests")  # the scheduling alone
    before = current_scheduling()
    box = {}
    with realtime(1) as got:
        inside = current_scheduling()
        child = threading.Thread(target=lambda: box.setdefault("child", current_scheduling()))
        child.start()
        child.join()
    assert got["policy"] == inside["policy"] == "SCHED_FIFO" and inside["priority"] == 1
    assert box["child"] == {"policy": "SCHED_OTHER", "priority": 0}
    assert current_scheduling() == before


@linux
def test_serve_records_the_scheduling_its_loop_got(monkeypatch):
    """serve(priority=N) answers at what the system grants (refused: normal priority) and records it on the
    streamer; its thread's scheduling is back after."""
    from pathmotion.execution.loops import open_listener, serve

    class OneMessage:
        mode, started, finished, stop_reason = "none", False, False, None
        scheduling: dict = {}

        def rehearse(self):
            pass

        def close(self):
            pass

        def handle(self, data, t_recv, clock):
            self.seen = current_scheduling()
            self.started = self.finished = True
            return b"ok"

    libc = FakeLibc(0)
    monkeypatch.setattr(rt, "_libc", lambda: libc)
    sock = open_listener(0, "127.0.0.1")
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        with monkeypatch.context() as m:
            FakeScheduler(m, refuse=True)
            robot.sendto(b"x", sock.getsockname())
            st = OneMessage()
            assert serve(sock, st, first_timeout=5.0, priority=30) == "done"
        assert st.scheduling["policy"] == "SCHED_OTHER" and st.scheduling["requested_priority"] == 30
        assert any("SCHED_FIFO priority 30" in r for r in st.scheduling["refused"])
        assert st.seen == {"policy": "SCHED_OTHER", "priority": 0} and robot.recv(16) == b"ok"
        _granted_or_skip()
        before = current_scheduling()
        robot.sendto(b"x", sock.getsockname())
        st = OneMessage()
        assert serve(sock, st, first_timeout=5.0, priority=1) == "done"
        assert st.seen == {"policy": "SCHED_FIFO", "priority": 1} and st.scheduling["policy"] == "SCHED_FIFO"
        assert current_scheduling() == before and libc.calls[-1] == ("munlockall",)
    finally:
        robot.close()
        sock.close()


@linux
def test_the_worker_is_not_niced_behind_a_realtime_loop():
    """Behind a SCHED_FIFO loop the worker runs at the loop's nice value (it hands the loop Python's lock back only
    once it runs); behind a normal loop, defaults.EGM_WORKER_NICE nicer."""
    from pathmotion.execution.streamer import Streamer

    loop = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    st = Streamer.__new__(Streamer)
    st.scheduling = {}
    assert st._worker_nice() == loop + defaults.EGM_WORKER_NICE and defaults.EGM_WORKER_NICE > 0
    st.scheduling = {"policy": "SCHED_OTHER", "priority": 0}
    assert st._worker_nice() == loop + defaults.EGM_WORKER_NICE
    st.scheduling = {"policy": "SCHED_FIFO", "priority": 50}
    assert st._worker_nice() == loop + defaults.EGM_WORKER_NICE_REALTIME == loop


def test_the_summary_records_the_loop_scheduling():
    from pathmotion.execution.session import execution_summary
    from pathmotion.execution.streamer import Counts

    class St:
        records, requests, supervision, mode, counts = [], [], None, "none", Counts()
        scheduling = {"requested_priority": 50, "policy": "SCHED_FIFO", "priority": 50, "memory_locked": True,
                      "refused": []}

    summary = execution_summary(None, St(), "done")
    assert summary["loop_scheduling"] == St.scheduling


def test_cli_refuses_a_priority_outside_sched_fifo_s_range(tmp_path):
    """Exit 1 before planning, naming the range."""
    from typer.testing import CliRunner

    from pathmotion.cli import app

    for bad in ("-1", "100"):
        res = CliRunner().invoke(app, ["execute", str(tmp_path / "none.toml"), "--egm", "0",
                                       "--realtime-priority", bad])
        assert res.exit_code == 1 and f"--realtime-priority {bad}" in res.output and "1-99" in res.output, res.output


@pytest.mark.slow
def test_cli_execute_records_its_loop_scheduling(tmp_path):
    """execute --realtime-priority 1 against the virtual robot (processes, lockstep): it completes either way, and
    summary.json says what the loop asked for and got (SCHED_FIFO 1 where the system allows it; else normal
    priority and what was refused)."""
    import json

    pytest.importorskip("abb_robot_client")
    from egm_support import irb140_task, line, run_commands

    scenario = tmp_path / "short.toml"
    scenario.write_text(irb140_task("egm_short", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5])))
    ex, robot, out = run_commands(scenario, ["--out", str(tmp_path / "robot")],
                                  ["--out", str(tmp_path / "run"), "--realtime-priority", "1"])
    assert ex.returncode == 0, ex.stdout + ex.stderr
    got = json.loads((tmp_path / "run" / "summary.json").read_text())["loop_scheduling"]
    assert got["requested_priority"] == 1
    if got["policy"] == "SCHED_FIFO":
        assert got["priority"] == 1 and not any(r.startswith("SCHED_FIFO") for r in got["refused"])
    else:
        assert any(r.startswith("SCHED_FIFO priority 1") for r in got["refused"])
        assert "--realtime-priority 1" in ex.stderr + ex.stdout
