"""The external computer's side of EGM as a state machine: each robot datagram in, the sensor datagram out.

The motion is a sequence of segments, each a profile on the plan's joint path tabulated as references
(:class:`.reference.ReferenceTable`), its plan time running with the robot's own clock (header.tm). An
override, a stop and a resume start a new segment from the current state (theta, theta_dot, theta_ddot),
re-timed by :class:`pathmotion.planning.retime.Retimer` within the plan's limits: the shortest stop along the
path, the time-optimal rest under an override, the time-optimal rest from standstill. Packets are counted:
lost (a gap in seqno), duplicated (the same seqno again: answered again, the controller repeats a message
it got no answer to), out of order (an older seqno: not answered), rejected (not an EgmRobot of this
robot: not answered), late (answered more than defaults.EGM_LATE after it arrived).
"""

from __future__ import annotations

import copy
import logging
import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from .. import defaults
from ..errors import ExecutionError, PathmotionError
from .messages import RobotDecoder, SensorEncoder, encode_robot
from .reference import ReferenceTable

log = logging.getLogger(__name__)

#: A path speed below this counts as standing still (nothing to stop) [unit theta / s].
STANDSTILL = 1e-9
#: Cycles :meth:`Streamer.rehearse` runs before the first robot message [-].
REHEARSAL = 100


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
    planning.Trajectory (for the figures)."""

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
        """The motion (plan or stop) is over and the arm had the settle window."""
        return self._now - self._segment_start >= self._segment.end + self.settle

    def _state(self) -> tuple[float, float, float]:
        return self._segment.state(self._now - self._segment_start)

    def _switch(self, kind: str, override: float) -> bool:
        """Start a re-timed segment from the current state; False (and a warning) when there is none."""
        state = self._state()
        if kind == "stop" and state[1] <= STANDSTILL:
            return True  # at rest already
        try:
            table = self.retime(kind, state, override, self._segment, self._now - self._segment_start)
        except PathmotionError as exc:
            log.warning("cannot re-time (%s) at theta = %.6g: %s; the motion goes on as it was", kind, state[0], exc)
            return False
        self._segment, self._segment_start = table, self._now
        return True

    def override(self, scale: float) -> None:
        """Run the rest of the motion at ``scale`` in (0, 1] of the plan's limits."""
        if not np.isfinite(scale) or not 0.0 < scale <= 1.0:
            raise ExecutionError(f"override {scale!r}: give a speed fraction in (0, 1]")
        self.override_scale = float(scale)
        if self.stop_reason is None:
            self._switch("override", self.override_scale)

    def stop(self, reason: str) -> None:
        """The shortest stop along the path (kept until :meth:`resume`)."""
        if self.stop_reason is not None:
            return
        log.warning("stopping along the path: %s", reason)
        self.stop_reason = reason
        self._switch("stop", 1.0)

    def resume(self) -> None:
        """From a stop: the time-optimal rest of the motion (at the current override)."""
        if self.stop_reason is None:
            return
        state = self._state()
        if state[1] > STANDSTILL:
            log.warning("resume ignored: the arm is still stopping (theta_dot = %.3g)", state[1])
            return
        if self._switch("resume", self.override_scale):
            self.stop_reason = None
            if self.supervision is not None:
                self.supervision.rearm()

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
                       _last_reply=None)
        q = self.table.q[0]
        twin._check_first(self._decode(encode_robot(0, 0, q, q)))
        for k in range(cycles):
            twin.handle(encode_robot(k + 1, 4 * k, q, q), 0.0, lambda: 0.0)
            q = twin.records[-1].sent

    def _supervise(self, reported: np.ndarray, deflection: np.ndarray) -> bool:
        """Supervise the reported joints; True when a stop began (the segment changed). A diverging orbital loop
        during the supervision's stop is switched off: the shaped stop alone is streamed."""
        s = self.supervision
        if s.check(reported, deflection, self._now):
            if self.stop_reason is None:
                self.stop(s.reason(s.trip))
                return True
            log.warning("during the stop: %s", s.reason(s.trip))
            self.stop_reason = s.reason(s.trip)
        elif self.loop is not None and not s.armed and self.stop_reason is not None and s.diverging():
            log.warning("the path deviation keeps growing during the stop (%.4g rad): the orbital correction is "
                        "switched off, the shaped stop alone is streamed", s.deviation)
            self.loop = None
        return False

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
        n = self._n
        tau = self._now - self._segment_start
        row = self._segment.row(tau)  # [q, qd, plan, deflection, theta]
        if self.supervision is not None and self._supervise(msg.joints, row[3 * n:4 * n]):
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
