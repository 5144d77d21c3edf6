"""The external computer's side of EGM as a state machine: each robot datagram in, the sensor datagram out.

Plan time advances with the robot's own clock (header.tm) times a speed scale; an override, a stop and a
resume change the scale linearly over ``defaults.EGM_SPEED_RAMP`` (a stop along the path: q stays on the
plan's joint path while its speed falls to 0). Packets are counted: lost (a gap in seqno), duplicated (the
same seqno again: answered again, the controller repeats a message it got no answer to), out of order (an
older seqno: not answered), rejected (not an EgmRobot of this robot: not answered).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from .. import defaults
from ..errors import ExecutionError
from .messages import decode_robot, encode_sensor
from .reference import ReferenceTable

log = logging.getLogger(__name__)


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
class Record:
    """One answered robot message: receive and send times [s, this computer's clock], seqno, plan time [s],
    theta, reported joints (n,), sent reference (n,), plan joints (n,)."""

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
    """execute's logic. ``table``: the references; ``lower``/``upper``/``velocity`` (n,): the joint limits no
    sent reference leaves; ``tolerance`` [rad]: largest start distance; ``mode``: the correction mode."""

    table: ReferenceTable
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    mode: str = "none"
    tolerance: float = defaults.EGM_START_TOLERANCE
    settle: float = defaults.EGM_SETTLE_WINDOW
    ramp: float = defaults.EGM_SPEED_RAMP
    counts: Counts = field(default_factory=Counts)
    records: list = field(default_factory=list)
    stop_reason: str | None = None
    seqno_out: int = 0
    _last_seq: int | None = None
    _tm_last: float | None = None
    _tau: float = 0.0
    _scale: float = 1.0
    _target: float = 1.0
    _after_end: float = 0.0
    _last_reply: bytes | None = None

    @property
    def n(self) -> int:
        return self.table.q.shape[1]

    @property
    def started(self) -> bool:
        return self._last_seq is not None

    @property
    def finished(self) -> bool:
        """The motion (plan or stop) is over and the arm had the settle window."""
        return self._after_end >= self.settle

    def override(self, scale: float) -> None:
        if not np.isfinite(scale) or not 0.0 < scale <= 1.0:
            raise ExecutionError(f"override {scale!r}: give a speed fraction in (0, 1]")
        if self.stop_reason is None:
            self._target = float(scale)

    def stop(self, reason: str) -> None:
        """A stop along the path (kept until :meth:`resume`)."""
        if self.stop_reason is None:
            log.warning("stopping along the path: %s", reason)
        self.stop_reason = self.stop_reason or reason
        self._target = 0.0

    def resume(self, scale: float = 1.0) -> None:
        self.stop_reason = None
        self._target = float(scale)
        self._after_end = 0.0

    def _check_first(self, msg) -> None:
        if msg.joints.size != self.n:
            raise ExecutionError(f"the robot reports {msg.joints.size} joints, the plan has {self.n}: "
                                 f"wrong robot or wrong EGM configuration")
        gap = np.abs(msg.joints - self.table.q[0])
        j = int(np.argmax(gap))
        if gap[j] > self.tolerance:
            raise ExecutionError(f"the robot is not at the plan's start: joint {j + 1} is {np.degrees(gap[j]):.3f} deg "
                                 f"({gap[j]:.4g} rad) away (tolerance {self.tolerance:.4g} rad); move it to the start "
                                 f"(planned.joints of the first reply) or raise the start tolerance")

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

    def _advance(self, tm: float) -> None:
        dt = 0.0 if self._tm_last is None else max(0.0, (tm - self._tm_last) / 1000.0)
        self._tm_last = tm
        rate = dt / self.ramp if self.ramp > 0 else np.inf
        before = self._scale
        self._scale = min(self._target, before + rate) if self._target > before else max(self._target, before - rate)
        self._tau += 0.5 * (before + self._scale) * dt
        end = self.table.duration + (self.table.t[-1] - self.table.duration)
        if self._tau >= end or (self._scale == 0.0 and self._target == 0.0):
            self._after_end += dt

    def handle(self, data: bytes, t_recv: float, clock) -> bytes | None:
        """The answer to one datagram (None: not answered); ``clock()`` gives the send time [s]. Raises
        ExecutionError when the first robot message does not match the plan."""
        self.counts.received += 1
        try:
            msg = decode_robot(data)
        except ExecutionError as exc:
            self.counts.rejected += 1
            log.warning("ignored a datagram: %s", exc)
            return None
        if self._last_seq is None:
            self._check_first(msg)
        elif msg.joints.size != self.n:
            self.counts.rejected += 1
            log.warning("ignored a robot message with %d joints (the plan has %d)", msg.joints.size, self.n)
            return None
        kind = self._sequence(msg.seqno)
        if kind == "old":
            return None
        if kind == "duplicate" and self._last_reply is not None:
            return self._last_reply
        self._last_seq = msg.seqno
        self._advance(float(msg.tm))
        q, qd, plan, theta = self.table.at(self._tau)
        q, qd = self.correct(q, qd * self._scale, msg.joints)
        safe = np.clip(q, self.lower, self.upper)
        speed = np.clip(qd, -self.velocity, self.velocity)
        if np.any(safe != q) or np.any(speed != qd):
            self.counts.clipped += 1
        self.seqno_out += 1
        reply = encode_sensor(self.seqno_out, msg.tm, safe, speed, done=self.finished)
        t_send = clock()
        if t_send - t_recv > defaults.EGM_LATE:
            self.counts.late += 1
        self.counts.answered += 1
        self.records.append(Record(t_recv, t_send, msg.seqno, float(msg.tm), self._tau, theta, msg.joints, safe, plan))
        self._last_reply = reply
        return reply

    def correct(self, q: np.ndarray, qd: np.ndarray, reported: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The feedback correction of the reference (none here: the table is the whole reference)."""
        return q, qd
