"""The external computer's side of EGM as a state machine: each robot datagram in, the sensor datagram out.

The motion is a sequence of segments, each a profile on the plan's joint path tabulated as references
(:class:`.reference.ReferenceTable`), its plan time running with the robot's own clock (header.tm). An
override, a stop and a resume start a new segment, re-timed by :class:`pathmotion.planning.retime.Retimer`
within the plan's limits: the shortest stop along the path, the time-optimal rest under an override, the
time-optimal rest from standstill. A request at robot time t switches at t + lead (:attr:`Streamer.lead`):
until then the motion is the current segment, so the state there (theta, theta_dot, theta_ddot) is known at
once; a worker thread re-times from it while the loop answers from the current segment, and the first message
at or after t + lead is answered from the re-timed one. Packets are counted:
lost (a gap in seqno), duplicated (the same seqno again: answered again, the controller repeats a message
it got no answer to), out of order (an older seqno: not answered), rejected (not an EgmRobot of this
robot: not answered), late (answered more than defaults.EGM_LATE after it arrived).
"""

from __future__ import annotations

import copy
import logging
import math
import os
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from .. import defaults
from ..errors import ExecutionError, PathmotionError
from .messages import RobotDecoder, SensorEncoder, encode_robot
from .realtime import normal_scheduling
from .reference import ReferenceTable

log = logging.getLogger(__name__)

#: A path speed below this counts as standing still (nothing to stop) [unit theta / s].
STANDSTILL = 1e-9
#: Cycles :meth:`Streamer.rehearse` runs before the first robot message [-].
REHEARSAL = 100


def _robot_time(t: float) -> float:
    """``t`` [s] on the robot's clock: whole ms, the float a message of that time gives (header.tm / 1000)."""
    return round(t * 1000.0) / 1000.0


def _lower_priority(nice: int | None) -> None:
    """The calling thread at normal scheduling (SCHED_OTHER, whatever it inherited from a real-time loop thread:
    it never preempts the loop) and at the nice value ``nice`` (None: as it is; Linux: a thread's nice value is
    its own; where the system refuses a value below the thread's, it stays as it is)."""
    normal_scheduling()
    if nice is None:
        return
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), max(-20, min(nice, 19)))
    except (AttributeError, OSError):
        pass


@dataclass
class Counts:
    received: int = 0
    answered: int = 0
    lost: int = 0
    duplicated: int = 0
    out_of_order: int = 0
    rejected: int = 0
    late: int = 0
    clipped: int = 0


@dataclass
class Request:
    """A stop, override or resume request: its kind, the robot time it came at and the one its switch is
    scheduled at [s, from the first message], the override it runs at, its re-timing (a Future of (table or
    None, the PathmotionError or None, compute time [s])), how often it was scheduled, and how it ended:
    "pending", "switched", "kept" (no re-timed segment: the motion went on as it was), "at rest" (a stop with
    nothing to stop), "cancelled" (replaced by a later request). ``waited`` [s]: how long the loop waited for the
    re-timing at the switch (the answer then is late in real time)."""

    kind: str
    requested: float
    at: float
    override: float
    future: Future | None = None
    attempts: int = 1
    missed: bool = False
    compute: float | None = None
    waited: float = 0.0
    outcome: str = "pending"

    def summary(self) -> dict:
        """The request in execute's summary.json: times [s, robot time from the first message]."""
        return {"kind": self.kind, "requested_s": round(self.requested, 6),
                "switched_s": round(self.at, 6) if self.outcome == "switched" else None,
                "compute_s": None if self.compute is None else round(self.compute, 6),
                "waited_s": round(self.waited, 6), "attempts": self.attempts, "outcome": self.outcome}


@dataclass(slots=True)
class Record:
    """One answered robot message: receive and send times [s, this computer's clock], seqno, robot time tm
    [ms], time in its segment [s], theta, reported joints (n,), sent reference (n,), plan joints (n,)."""

    t_recv: float
    t_send: float
    seqno: int
    tm: float
    tau: float
    theta: float
    reported: np.ndarray
    sent: np.ndarray
    plan: np.ndarray


@dataclass
class Streamer:
    """execute's logic. ``table``: the plan's references; ``retime(kind, state, override, previous, offset)``:
    the re-timed table of a stop ("stop"), an override ("override") or a resume ("resume") from ``state`` =
    (theta, theta_dot, theta_ddot), continuing the table ``previous`` (its raw motion, its correction) at its
    time ``offset``; ``lower``/``upper``/``velocity`` (n,): the joint limits no sent reference
    leaves; ``tolerance`` [rad]: largest start distance; ``mode``: the correction mode; ``loop``: the
    transverse loop of the orbital mode (a :class:`.orbital.TransverseLoop`) or None; ``supervision``: the
    path supervision (a :class:`.supervision.PathSupervision`) or None; ``plan``: the planned
    planning.Trajectory (for the figures); ``lead`` [s]: a request switches this long after it came (0: on its
    own cycle, re-timed before that cycle's answer); ``realtime``: False (lockstep, in-process) waits at the
    switch for a re-timing that is not ready (the run does not depend on compute time); True (a real
    controller) never waits the first ``defaults.EGM_SWITCH_RETRIES`` times: the motion goes on as it was and
    the switch is scheduled again from a later state once the re-timing is done, and a request's lead is at
    least ``defaults.EGM_SWITCH_MARGIN`` times what the last re-timing of its kind took. ``requests``: every
    :class:`Request`. ``scheduling``: how the loop thread answering it was scheduled (set by
    :func:`.loops.serve`, :func:`.realtime.realtime`'s record; empty before)."""

    table: ReferenceTable
    retime: Callable
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    mode: str = "none"
    tolerance: float = defaults.EGM_START_TOLERANCE
    settle: float = defaults.EGM_SETTLE_WINDOW
    loop: object = None
    supervision: object = None
    plan: object = None
    lead: float = defaults.EGM_SWITCH_LEAD
    realtime: bool = False
    requests: list = field(default_factory=list)
    scheduling: dict = field(default_factory=dict)
    counts: Counts = field(default_factory=Counts)
    records: list = field(default_factory=list)
    stop_reason: str | None = None
    seqno_out: int = 0
    override_scale: float = 1.0
    _last_seq: int | None = None
    _tm0: float | None = None
    _now: float = 0.0
    _segment: ReferenceTable | None = None
    _segment_start: float = 0.0
    _last_reply: bytes | None = None
    _pending: Request | None = None
    _took: dict = field(default_factory=dict, repr=False)  # kind -> its last re-timing's compute time [s]
    _worker: ThreadPoolExecutor | None = field(default=None, repr=False)
    _decode: RobotDecoder = field(default_factory=RobotDecoder, repr=False)
    _encode: SensorEncoder = field(default_factory=SensorEncoder, repr=False)
    _n: int = field(init=False, repr=False)
    _low: np.ndarray = field(init=False, repr=False)  # [lower, -velocity]
    _high: np.ndarray = field(init=False, repr=False)  # [upper, velocity]

    def __post_init__(self):
        self._segment = self.table
        velocity = np.asarray(self.velocity, float)
        self._n = self.table.q.shape[1]
        self._low = np.concatenate([np.asarray(self.lower, float), -velocity])
        self._high = np.concatenate([np.asarray(self.upper, float), velocity])
        self.table.at(0.0)  # the table's lookup is built now, not at the first robot message

    @property
    def n(self) -> int:
        return self.table.q.shape[1]

    @property
    def started(self) -> bool:
        return self._last_seq is not None

    @property
    def segment(self) -> ReferenceTable:
        return self._segment

    @property
    def rest_time(self) -> float:
        """Robot time [s, from the first message] at which the current segment's motion comes to rest at the servo
        (its references' rest plus the delay they take to reach it, :attr:`ReferenceTable.delay`)."""
        return self._segment_start + self._segment.duration + self._segment.delay

    @property
    def finished(self) -> bool:
        """The motion (plan or stop) is over, the arm had the settle window and no switch is pending."""
        return self._pending is None and self._now - self._segment_start >= self._segment.end + self.settle

    def _state(self) -> tuple[float, float, float]:
        return self._segment.state(self._now - self._segment_start)

    @property
    def pending(self) -> Request | None:
        """The request whose switch is scheduled and not yet made (None: none)."""
        return self._pending

    def _retimed(self, kind: str, state: tuple, override: float, previous: ReferenceTable, offset: float):
        """(re-timed table or None, the PathmotionError or None, compute time [s]); the table's lookup is built
        here, off the loop."""
        t0 = time.perf_counter()
        try:
            table = self.retime(kind, state, override, previous, offset)
            table.at(0.0)
            return table, None, time.perf_counter() - t0
        except PathmotionError as exc:
            return None, exc, time.perf_counter() - t0

    def _schedule(self, req: Request) -> None:
        """Re-time ``req`` from the current segment's state at its time: in the worker thread, or (lead 0) here;
        a stop with nothing to stop then is none (its outcome "at rest")."""
        offset = req.at - self._segment_start
        state = self._segment.state(offset)
        if req.kind == "stop" and state[1] <= STANDSTILL:
            req.outcome, self._pending = "at rest", None
            return
        args = (req.kind, state, req.override, self._segment, offset)
        if req.at <= self._now:
            req.future = Future()
            req.future.set_result(self._retimed(*args))
            return
        if self._worker is None:
            self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pathmotion-retime",
                                              initializer=_lower_priority, initargs=(self._worker_nice(),))
        req.future = self._worker.submit(self._retimed, *args)

    def _worker_nice(self) -> int | None:
        """The re-timing worker's nice value (called on the loop's thread): the loop's own plus
        ``defaults.EGM_WORKER_NICE``, or plus ``defaults.EGM_WORKER_NICE_REALTIME`` when the loop runs a real-time
        policy (:attr:`scheduling`); None where a thread's nice value cannot be read."""
        real_time = self.scheduling.get("policy") in ("SCHED_FIFO", "SCHED_RR")
        try:
            loop = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
        except (AttributeError, OSError):
            return None
        return loop + (defaults.EGM_WORKER_NICE_REALTIME if real_time else defaults.EGM_WORKER_NICE)

    def _request(self, kind: str, override: float, immediate: bool = False) -> None:
        """A switch of ``kind`` at robot time now + lead (``immediate``: now, re-timed on this cycle), replacing a
        pending one (its re-timing is dropped); a stop with nothing to stop at that time is none."""
        self._cancel()
        req = Request(kind, self._now, self._now if immediate else _robot_time(self._now + self._lead(kind)), override)
        self.requests.append(req)
        self._pending = req
        self._schedule(req)
        self._due()

    def _lead(self, kind: str) -> float:
        """The lead of a request of ``kind``: :attr:`lead`; in real time at least ``defaults.EGM_SWITCH_MARGIN``
        times the last re-timing of that kind took (with lead > 0)."""
        if self.lead <= 0.0:
            return 0.0
        last = self._took.get(kind, 0.0) if self.realtime else 0.0
        return max(self.lead, defaults.EGM_SWITCH_MARGIN * last)

    def _cancel(self) -> None:
        if self._pending is not None:
            self._pending.outcome = "cancelled"
            self._pending = None

    def _due(self) -> None:
        """Make the pending switch when its time has come (at the first message at or after it): wait for its
        re-timing when it is not ready (lockstep, or after its retries), or (real time) go on with the current
        segment and schedule it again from a later state once the re-timing is done."""
        req = self._pending
        if req is None:
            return
        if req.missed:
            if req.future.done():
                req.compute = self._took[req.kind] = req.future.result()[2]
                lead = self._lead(req.kind)
                req.at, req.missed, req.attempts = _robot_time(self._now + lead), False, req.attempts + 1
                log.warning("the %s's re-timing took %.0f ms, past its switch: scheduled again %.0f ms ahead",
                            req.kind, 1e3 * req.compute, 1e3 * lead)
                self._schedule(req)
            return
        if self._now < req.at:
            return
        if not req.future.done():
            if self.realtime and req.attempts <= defaults.EGM_SWITCH_RETRIES:
                req.missed = True
                return
            t0 = time.perf_counter()
            req.future.result()
            req.waited += time.perf_counter() - t0
            (log.warning if self.realtime else log.debug)(
                "waited %.1f ms for the %s's re-timing at its switch", 1e3 * req.waited, req.kind)
        self._install(req)

    def _install(self, req: Request) -> None:
        table, exc, req.compute = req.future.result()
        self._took[req.kind] = req.compute
        self._pending = None
        if exc is not None:
            req.outcome = "kept"
            state = self._segment.state(req.at - self._segment_start)
            log.warning("cannot re-time (%s) at theta = %.6g: %s; the motion goes on as it was", req.kind, state[0],
                        exc)
            return
        self._segment, self._segment_start = table, req.at
        req.outcome = "switched"
        if req.kind == "resume":
            self.stop_reason = None
            if self.supervision is not None:
                self.supervision.rearm()

    def close(self) -> None:
        """End the re-timing worker (after the re-timing under way); a pending switch stays pending (its
        re-timing's result is kept, a later request starts another worker)."""
        if self._worker is not None:
            self._worker.shutdown(wait=True)
            self._worker = None

    def override(self, scale: float) -> None:
        """Run the rest of the motion at ``scale`` in (0, 1] of the plan's limits (during a stop: the resume's;
        a pending resume is scheduled again at it)."""
        if not np.isfinite(scale) or not 0.0 < scale <= 1.0:
            raise ExecutionError(f"override {scale!r}: give a speed fraction in (0, 1]")
        self.override_scale = float(scale)
        if self._pending is not None and self._pending.kind == "resume":
            self._request("resume", self.override_scale)
        elif self.stop_reason is None:
            self._request("override", self.override_scale)

    def stop(self, reason: str, immediate: bool = False) -> None:
        """The shortest stop along the path (kept until :meth:`resume`), switched a lead later (``immediate``: on
        this cycle, whose answer waits for its re-timing); it replaces a pending override, cancels a pending resume
        (the arm stays at rest), and a second stop leaves a pending or made one as it is."""
        if self.stop_reason is not None:
            if self._pending is not None and self._pending.kind == "resume":
                log.warning("stopping along the path: %s (the pending resume is cancelled)", reason)
                self._cancel()
                self.stop_reason = reason
            return
        log.warning("stopping along the path: %s", reason)
        self.stop_reason = reason
        self._request("stop", 1.0, immediate)

    def resume(self) -> None:
        """From a stop at rest: the time-optimal rest of the motion (at the current override)."""
        if self.stop_reason is None or (self._pending is not None and self._pending.kind == "resume"):
            return
        if self._pending is not None:
            log.warning("resume ignored: the stop is not made yet (switch at %.3f s)", self._pending.at)
            return
        state = self._state()
        if state[1] > STANDSTILL:
            log.warning("resume ignored: the arm is still stopping (theta_dot = %.3g)", state[1])
            return
        self._request("resume", self.override_scale)

    def rehearse(self, cycles: int = REHEARSAL) -> None:
        """Answer ``cycles`` robot messages (an arm that follows the plan's references from the start, 4 ms apart)
        on a copy of this streamer, its counts, records, supervision and loop its own (never tripping), through
        this streamer's decoder and encoder: before the first real message Python specialises the per-cycle
        code and it and its data are in memory and cache, so the first answers take no longer than the rest.
        This streamer is left as it was."""
        watch = copy.copy(self.supervision)
        if watch is not None:
            watch.tolerance = math.inf
            watch.rearm()
        twin = replace(self, counts=Counts(), records=[], supervision=watch, loop=copy.copy(self.loop),
                       stop_reason=None, seqno_out=0, _last_seq=0, _tm0=0.0, _now=0.0, _segment_start=0.0,
                       _last_reply=None, requests=[], _pending=None, _worker=None, _took={})
        q = self.table.q[0]
        twin._check_first(self._decode(encode_robot(0, 0, q, q)))
        for k in range(cycles):
            twin.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
            q = twin.records[-1].sent

    def _supervise(self, reported: np.ndarray, deflection: np.ndarray) -> None:
        """Supervise the reported joints; a trip stops at once (the arm is leaving the path: every cycle of a lead
        would take it farther, so this cycle's answer waits for the stop's re-timing). A diverging orbital loop
        during the supervision's stop is switched off: the shaped stop alone is streamed."""
        s = self.supervision
        if s.check(reported, deflection, self._now):
            if self.stop_reason is None:
                self.stop(s.reason(s.trip), immediate=True)
                return
            log.warning("during the stop: %s", s.reason(s.trip))
            self.stop_reason = s.reason(s.trip)
        elif self.loop is not None and not s.armed and self.stop_reason is not None and s.diverging():
            log.warning("the path deviation keeps growing during the stop (%.4g rad): the orbital correction is "
                        "switched off, the shaped stop alone is streamed", s.deviation)
            self.loop = None

    def _check_first(self, msg) -> None:
        if msg.joints.size != self.n:
            raise ExecutionError(f"the robot reports {msg.joints.size} joints, the plan has {self.n}: "
                                 f"wrong robot or wrong EGM configuration")
        gap = np.abs(msg.joints - self.table.q[0])
        j = int(np.argmax(gap))
        if gap[j] > self.tolerance:
            raise ExecutionError(f"the robot is not at the plan's start: joint {j + 1} is {np.degrees(gap[j]):.3f} deg "
                                 f"({gap[j]:.4g} rad) away (tolerance {self.tolerance:.4g} rad); move it to the start "
                                 f"(planned.joints of the first reply) or raise --start-tolerance")

    def _sequence(self, seq: int) -> str:
        """'new', 'duplicate' or 'old', counting lost messages."""
        last = self._last_seq
        if last is None:
            return "new"
        step = (seq - last) & 0xFFFFFFFF
        if step == 0:
            self.counts.duplicated += 1
            return "duplicate"
        if step > 0x7FFFFFFF:
            self.counts.out_of_order += 1
            return "old"
        self.counts.lost += step - 1
        return "new"

    def _decoded(self, data: bytes):
        """The robot message in ``data``, or None (counted as rejected) when it is not one of this robot's."""
        try:
            msg = self._decode(data)
        except ExecutionError as exc:
            self.counts.rejected += 1
            log.warning("ignored a datagram: %s", exc)
            return None
        if self._last_seq is None:
            self._check_first(msg)
            log.info("first robot message (seqno %d): %d joints at the plan's start; streaming", msg.seqno, self.n)
        elif msg.joints.size != self.n:
            self.counts.rejected += 1
            log.warning("ignored a robot message with %d joints (the plan has %d)", msg.joints.size, self.n)
            return None
        return msg

    def handle(self, data: bytes, t_recv: float, clock) -> bytes | None:
        """The answer to one datagram (None: not answered); ``clock()`` gives the send time [s]. Raises
        ExecutionError when the first robot message does not match the plan."""
        self.counts.received += 1
        msg = self._decoded(data)
        if msg is None:
            return None
        kind = self._sequence(msg.seqno)
        if kind == "old":
            return None
        if kind == "duplicate" and self._last_reply is not None:
            return self._last_reply
        self._last_seq = msg.seqno
        if self._tm0 is None:
            self._tm0 = float(msg.tm)
        self._now = max(self._now, ((msg.tm - self._tm0) % 2**32) / 1000.0)
        if self._pending is not None:
            self._due()
        n = self._n
        segment = self._segment
        tau = self._now - self._segment_start
        row = segment.row(tau)  # [q, qd, plan, deflection, theta]
        if self.supervision is not None:
            self._supervise(msg.joints, row[3 * n:4 * n])
            if self._segment is not segment:  # a stop made on this cycle (lead 0)
                tau = self._now - self._segment_start
                row = self._segment.row(tau)
        wanted = row[:2 * n]  # q, qd
        if self.loop is not None:
            wanted = wanted.copy()
            wanted[:n] += self.loop.update(msg.joints, row[3 * n:4 * n], float(row[4 * n]))
        sent = np.minimum(np.maximum(wanted, self._low), self._high)  # np.clip's values, without its dispatch
        if (sent != wanted).any():
            self.counts.clipped += 1
        safe, plan, theta = sent[:n], row[2 * n:3 * n], float(row[4 * n])
        self.seqno_out += 1
        reply = self._encode(self.seqno_out, msg.tm, safe, sent[n:], done=self.finished)
        t_send = clock()
        if t_send - t_recv > defaults.EGM_LATE:
            self.counts.late += 1
        self.counts.answered += 1
        self.records.append(Record(t_recv, t_send, msg.seqno, float(msg.tm), tau, theta, msg.joints, safe, plan))
        self._last_reply = reply
        return reply
