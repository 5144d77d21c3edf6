"""Real-time scheduling of execute's loop thread (``execute --realtime-priority N``), as an EGM host runs its
answering loop: the thread at SCHED_FIFO priority N, the process's memory locked (mlockall MCL_CURRENT |
MCL_FUTURE) so that no page fault stalls a cycle. Where the system refuses either (no CAP_SYS_NICE and
RLIMIT_RTPRIO below N, no CAP_IPC_LOCK and RLIMIT_MEMLOCK too small, not Linux) a warning names what was refused
and what to change, and the loop goes on as it is. The scheduling is restored when the loop ends.

Threads the loop thread creates (execute's re-timing worker) start at normal scheduling (SCHED_RESET_ON_FORK), and
:func:`normal_scheduling` puts a thread back to SCHED_OTHER whatever it inherited: a worker at normal priority
never preempts the loop, and the loop, which sleeps in its receive most of each cycle, leaves it the core.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import logging
import os
import platform
import sys
import threading

log = logging.getLogger(__name__)

#: mlockall's flags (MCL_CURRENT, MCL_FUTURE) by machine: most Linux architectures use 1, 2; these differ.
_MCL = {"ppc": (0x2000, 0x4000), "sparc": (0x2000, 0x4000), "alpha": (0x2000, 0x4000)}

_FIX_PRIORITY = ("run execute with CAP_SYS_NICE (e.g. as root), or raise the real-time priority limit: `ulimit -r "
                 "{n}` in the shell (as allowed by an 'rtprio {n}' line for the user in /etc/security/limits.conf)")
_FIX_MEMORY = ("run execute with CAP_IPC_LOCK (or as root), or raise the locked-memory limit: `ulimit -l "
               "unlimited` (as allowed by a 'memlock unlimited' line for the user in /etc/security/limits.conf)")


def _libc():
    return ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)


def _mcl_flags() -> int:
    machine = platform.machine().lower()
    current, future = next((v for k, v in _MCL.items() if machine.startswith(k)), (1, 2))
    return current | future


def lock_memory() -> str | None:
    """Lock the process's pages in memory, present and future (mlockall); None when done, else why not."""
    if not sys.platform.startswith("linux"):
        return "mlockall is not available on this system (Linux's)"
    try:
        libc = _libc()
        if libc.mlockall(_mcl_flags()) == 0:
            return None
        err = ctypes.get_errno()
    except (OSError, AttributeError) as exc:
        return f"mlockall is not available ({exc})"
    return f"mlockall refused ({os.strerror(err)})"


def unlock_memory() -> None:
    """Undo :func:`lock_memory` (munlockall)."""
    with contextlib.suppress(OSError, AttributeError):
        _libc().munlockall()


def _policy_name(policy: int) -> str:
    names = {getattr(os, n): n for n in ("SCHED_OTHER", "SCHED_BATCH", "SCHED_IDLE", "SCHED_FIFO", "SCHED_RR")
             if hasattr(os, n)}
    return names.get(policy & ~getattr(os, "SCHED_RESET_ON_FORK", 0), str(policy))


def current_scheduling(tid: int | None = None) -> dict:
    """The scheduling of thread ``tid`` (None: the calling one): {"policy": "SCHED_OTHER" | "SCHED_FIFO" | ...,
    "priority": its real-time priority (0 outside SCHED_FIFO/RR)}; policy "unknown" where it cannot be read."""
    tid = threading.get_native_id() if tid is None else tid
    try:
        return {"policy": _policy_name(os.sched_getscheduler(tid)), "priority": os.sched_getparam(tid).sched_priority}
    except (AttributeError, OSError):
        return {"policy": "unknown", "priority": 0}


def normal_scheduling() -> None:
    """The calling thread back to SCHED_OTHER when it runs a real-time policy (inherited from the thread that
    created it); nothing elsewhere."""
    tid = threading.get_native_id()
    try:
        if os.sched_getscheduler(tid) & ~os.SCHED_RESET_ON_FORK in (os.SCHED_FIFO, os.SCHED_RR):
            os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError):
        pass


def priority_range() -> tuple[int, int]:
    """SCHED_FIFO's priorities on this system (Linux: 1-99; elsewhere Linux's)."""
    try:
        return os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    except (AttributeError, OSError):
        return 1, 99


@contextlib.contextmanager
def realtime(priority: int):
    """The calling thread at SCHED_FIFO ``priority`` (0: unchanged) with the process's memory locked, for the
    ``with`` block; yields what it got: {"requested_priority", "policy", "priority", "memory_locked", "refused"
    (what the system refused, with what to change; empty when nothing)}. A refusal is a warning, never an error:
    the block runs at the scheduling the thread has. Restores the thread's scheduling and unlocks the memory on
    exit."""
    tid = threading.get_native_id()
    got = {"requested_priority": priority, **current_scheduling(tid), "memory_locked": False, "refused": []}
    if priority <= 0:
        yield got
        return
    try:
        before = (os.sched_getscheduler(tid), os.sched_getparam(tid))
    except (AttributeError, OSError):
        before = None
    reason = lock_memory()
    got["memory_locked"] = reason is None
    if reason is not None:
        got["refused"].append(f"memory lock: {reason}; {_FIX_MEMORY}; the loop goes on with its memory unlocked")
    switched = False
    if before is None:
        got["refused"].append("SCHED_FIFO: real-time scheduling is not available on this system; the loop goes on at "
                              "normal priority")
    else:
        try:
            # threads the loop creates (the re-timing worker) start at normal scheduling
            os.sched_setscheduler(tid, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, os.sched_param(priority))
            switched = True
        except OSError as exc:
            got["refused"].append(f"SCHED_FIFO priority {priority}: {exc.strerror or exc}; "
                                  + _FIX_PRIORITY.format(n=priority) + "; the loop goes on at normal priority")
    got.update(current_scheduling(tid))
    for what in got["refused"]:
        log.warning("--realtime-priority %d: %s", priority, what)
    try:
        yield got
    finally:
        if switched:
            _restore(tid, *before)
        if got["memory_locked"]:
            unlock_memory()


def _restore(tid: int, policy: int, param) -> None:
    """Thread ``tid`` back to ``policy`` / ``param``; without CAP_SYS_NICE (SCHED_FIFO granted by RLIMIT_RTPRIO)
    Linux refuses to clear SCHED_RESET_ON_FORK, so the policy is restored with it kept."""
    try:
        os.sched_setscheduler(tid, policy, param)
        return
    except OSError:
        pass
    try:
        os.sched_setscheduler(tid, policy | os.SCHED_RESET_ON_FORK, param)
    except OSError as exc:
        log.warning("could not restore the loop thread's scheduling: %s", exc.strerror or exc)
