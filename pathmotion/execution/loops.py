"""The two UDP loops: execute's (answer every robot datagram) and the virtual IRC5's (send every 4 ms, or
wait for each answer in lockstep). Loopback or any address; bounded by timeouts, never by a busy wait."""

from __future__ import annotations

import gc
import logging
import select
import socket
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from .. import defaults
from ..errors import ExecutionError
from .drives import VirtualArm
from .messages import decode_sensor, encode_robot
from .realtime import realtime
from .streamer import Streamer

log = logging.getLogger(__name__)


def parse_address(text: str) -> tuple[str, int]:
    """'HOST:PORT' -> (host, port) (a clear error otherwise)."""
    host, sep, port = str(text).rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ExecutionError(f"--egm {text!r}: give HOST:PORT, e.g. 127.0.0.1:6510")
    return host, int(port)


def open_listener(port: int, host: str = "0.0.0.0") -> socket.socket:
    """A UDP socket bound to (host, port) (port 0: an ephemeral one)."""
    if not 0 <= port < 65536:
        raise ExecutionError(f"--egm {port}: a UDP port is 0-65535 (6510 is EGM's usual one)")
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise ExecutionError(f"cannot listen on UDP port {port}: {exc.strerror or exc}; choose another --egm port") from None
    return sock


def serve(sock: socket.socket, streamer: Streamer, *, commands=None,
          first_timeout: float = defaults.EGM_FIRST_MESSAGE_TIMEOUT, silence: float = defaults.EGM_SILENCE,
          priority: int = defaults.EGM_REALTIME_PRIORITY) -> str:
    """Answer robot datagrams on ``sock`` until the motion is over; returns how it ended: "done", "silent"
    (the controller stopped sending mid-motion), or the stop's reason. ``commands()``: pending stdin lines.
    A KeyboardInterrupt leaves it; the caller stops the streamer and serves on. Python's cycle collector is
    paused while serving (reference counting still frees what the loop drops): one collection of the whole heap
    takes about 0.1 s, 25 EGM cycles, and would answer them all late. The streamer then rehearses its cycle
    (:meth:`.streamer.Streamer.rehearse`, after the collection that sweeps the caches): the first answers are as
    quick as the rest. A request's re-timing runs in the streamer's worker thread (:attr:`.streamer.Streamer.lead`):
    Python's thread switch interval is lowered to ``defaults.EGM_SWITCH_INTERVAL`` while serving, so that the loop
    gets the interpreter back within a fraction of a millisecond when a message comes, and the worker is ended
    when serve ends (a pending switch stays pending for the next serve). ``priority`` > 0: the calling thread
    answers at SCHED_FIFO ``priority`` with the process's memory locked (:func:`.realtime.realtime`: a refusal
    is a warning, the loop goes on at normal priority; restored when serve ends); what it got is
    ``streamer.scheduling``. The loop never busy-waits (it blocks in select between messages), so a real-time
    loop leaves the core to the rest between cycles."""
    gc.collect()
    gc.freeze()  # what exists now is never scanned again
    gc.disable()
    interval = sys.getswitchinterval()
    sys.setswitchinterval(defaults.EGM_SWITCH_INTERVAL)
    try:
        with realtime(priority) as got:
            streamer.scheduling = got
            streamer.rehearse()
            return _serve(sock, streamer, commands, first_timeout, silence)
    finally:
        sys.setswitchinterval(interval)
        streamer.close()
        gc.enable()
        gc.unfreeze()


def _serve(sock: socket.socket, streamer: Streamer, commands, first_timeout: float, silence: float) -> str:
    """:func:`serve`'s loop."""
    clock = time.perf_counter
    last = clock()
    log.info("execute: listening on UDP port %d (%s correction)", sock.getsockname()[1], streamer.mode)
    while True:
        for line in (commands() if commands else ()):
            apply_command(streamer, line)
        wait = first_timeout if not streamer.started else silence
        ready, _, _ = select.select([sock], [], [], min(wait, 0.05))
        now = clock()
        if not ready:
            if now - last < wait:
                continue
            if not streamer.started:
                raise ExecutionError(f"no robot message within {first_timeout:g} s on UDP port "
                                     f"{sock.getsockname()[1]}; is EGM running on the controller?")
            streamer.stop("the controller went silent")
            return "silent"
        data, addr = sock.recvfrom(defaults.EGM_MAX_DATAGRAM)
        last = now
        reply = streamer.handle(data, now, clock)
        if reply is not None:
            sock.sendto(reply, addr)
        if streamer.finished:
            return streamer.stop_reason or "done"


def apply_command(streamer: Streamer, line: str) -> None:
    """One stdin line: 'override F', 'stop' or 'resume' (others are logged and ignored)."""
    words = line.split()
    try:
        if words[:1] == ["override"] and len(words) == 2:
            streamer.override(float(words[1]))
        elif words == ["stop"]:
            streamer.stop("stop requested")
        elif words == ["resume"]:
            streamer.resume()
        elif words:
            log.warning("ignored the command %r; give 'override F', 'stop' or 'resume'", line.strip())
    except (ValueError, ExecutionError) as exc:
        log.warning("ignored the command %r: %s", line.strip(), exc)


@dataclass
class RobotRun:
    """What the virtual arm did at each EGM cycle: t (K,) [s]; q link side, qm motor side, reference (K, n)
    [rad]; answered (K,) bool; tau (K, n) [N m]; resent: robot messages sent again for want of an answer."""

    t: list = field(default_factory=list)
    q: list = field(default_factory=list)
    qm: list = field(default_factory=list)
    reference: list = field(default_factory=list)
    tau: list = field(default_factory=list)
    answered: list = field(default_factory=list)
    resent: int = 0
    ended: str = ""

    def arrays(self) -> dict:
        return {k: np.asarray(getattr(self, k)) for k in ("t", "q", "qm", "reference", "tau", "answered")}


def _receive(sock: socket.socket, n: int, timeout: float, answers_tm: int | None = None):
    """The newest valid sensor message within ``timeout`` (None if none); with ``answers_tm`` [ms] only one that
    answers the robot message of that time (the sensor echoes it in header.tm): a late answer to a message that
    was sent again is stale by the next cycle and is dropped."""
    got = None
    end = time.perf_counter() + timeout
    while True:
        left = end - time.perf_counter()
        ready, _, _ = select.select([sock], [], [], max(left, 0.0) if got is None else 0.0)
        if not ready:
            return got
        try:
            data = sock.recv(defaults.EGM_MAX_DATAGRAM)
        except OSError:  # nobody listening yet (ICMP port unreachable on a connected socket)
            if got is None and time.perf_counter() < end:
                time.sleep(min(0.005, max(end - time.perf_counter(), 0.0)))
                continue
            return got
        try:
            message = decode_sensor(data, n)
        except ExecutionError as exc:
            log.warning("virtual robot: ignored a datagram: %s", exc)
            continue
        if answers_tm is None or message.tm == answers_tm & 0xFFFFFFFF:
            got = message


def run_virtual_robot(arm: VirtualArm, address: tuple[str, int], *, lockstep: bool, max_time: float,
                      resend: float = defaults.EGM_RESEND, resend_limit: int = defaults.EGM_RESEND_LIMIT) -> RobotRun:
    """Stream EgmRobot to ``address`` and move ``arm`` by the answers until the sensor says done, ``max_time``
    [s] of arm time passes, or (lockstep) ``resend_limit`` repeats go unanswered (before the first answer: as many
    as span ``defaults.EGM_FIRST_MESSAGE_TIMEOUT``)."""
    dt = arm.params.cycle
    run = RobotRun()
    ref = arm.feedback
    speed = np.zeros(arm.n)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.connect(address)
    try:
        k, next_send = 0, time.perf_counter()
        while k * dt <= max_time:
            tm = int(round(k * dt * 1000))
            packet = encode_robot(k + 1, tm, arm.feedback, ref)
            answer, tries = None, 0
            while answer is None:
                try:
                    sock.send(packet)
                except OSError:
                    pass  # nobody listening yet (ICMP refused): the controller keeps sending
                if lockstep:
                    answer = _receive(sock, arm.n, resend, answers_tm=tm)
                    tries += answer is None
                    run.resent += answer is None
                    # before the first answer the sensor may still be preparing (planning, refining): as long
                    # as execute waits for its first robot message
                    if tries > (resend_limit if k > 0 else defaults.EGM_FIRST_MESSAGE_TIMEOUT / resend):
                        run.ended = "the sensor stopped answering"
                        return run
                else:
                    next_send += dt
                    answer = _receive(sock, arm.n, max(0.0, next_send - time.perf_counter()))
                    break
            if answer is not None:
                ref, speed = answer.joints, answer.speed if answer.speed is not None else np.zeros(arm.n)
            else:
                speed = np.zeros(arm.n)  # no new reference: hold the last position
            arm.cycle(ref, speed)
            run.t.append(k * dt)
            run.q.append(arm.state.q.copy())
            run.qm.append(arm.state.qm.copy())
            run.reference.append(np.asarray(ref, float).copy())
            run.tau.append(arm.tau.copy())
            run.answered.append(answer is not None)
            k += 1
            if answer is not None and answer.done:
                run.ended = "done"
                return run
        run.ended = "time limit"
        return run
    finally:
        sock.close()
