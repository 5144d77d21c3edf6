"""The rules that end a closed-loop run and judge it, one small object each (docs/control.md, "Verdict").

The verdict follows ISO 9283's terms: the TCP must stay within ``path_tolerance`` [m] of the PLANNED path,
the torque must not stay saturated longer than ``saturation_limit`` [s], the run must not diverge, and the
joints must stay within ``joint_tolerance`` [rad] of the path (a coarse backstop).

Every sample the loop hands each rule, in order, the monitor's view of the true state (:class:`Sample`);
the first rule with a verdict decides the sample:

* a :class:`~.metrics.Failure` ends the run as failed;
* an :class:`Arrival` sets the cycle time and, if ``stop``, ends the run as arrived;
* None passes to the next rule.

After the controller has computed the torque, each rule's ``check_torque`` sees it (command and applied).
When the run ends (for any reason) the loop asks each rule to ``finish``: a rule that watches an episode
(the TCP outside the tolerance, a saturated stretch) reports it then if it is still open. Of all failures
the one that started first is the run's failure. A rule may keep state across samples, so
:func:`end_rules` builds fresh ones for every run. A new rule is a new class, added to the list.

The rules, in the order they are checked:

* :class:`Diverged`: NaN/inf or |qd_j| > DIVERGENCE_SPEED_FACTOR x the velocity limit; a non-finite torque;
* :class:`EndCrossing` (open path planned to end moving): the robot crosses the end; the run stops there
  and the crossing sample is not part of the motion;
* :class:`LeftRange` (open paths): past an end of the path by more than the joint tolerance;
* :class:`PathTolerance`: the TCP farther than the path tolerance from the planned path: one excursion,
  reported when the TCP is back (or the run ends) with where it left and its largest distance;
* :class:`JointTolerance`: max_j |q - Phi(theta)| above the joint tolerance;
* :class:`Saturation` (torque hook): a joint torque clipped at its limit for longer than the limit time;
* :class:`TcpArrival` (open paths): the TCP within the path tolerance of the end of the path, in the end's
  own stretch; the run goes on for ``settle_time`` to measure the settling;
* :class:`Laps` (closed paths): after ``laps`` turns; the cycle time is the mean period;
* :class:`Timeout`: not arrived within the time budget.

Crossing times are interpolated linearly between samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np

from .. import defaults
from ..control import PathTable
from ..planning.profile import Profile
from .metrics import Failure

#: Slack on "the settle time is over", against round-off in k * Ts [s].
STOP_SLACK = 1e-12
#: |Phi'|^2 below which the path counts as stopped (clamped spline ends), relative to its largest |Phi'|^2 [-].
FLAT_SPEED2 = 1e-12
#: Time step of the search for the planned entry into the arrival ball [s].
PLAN_ARRIVAL_STEP = 1e-3
#: Samples of the plan's time grid examined at once, from the end backwards, in that search [-].
PLAN_ARRIVAL_CHUNK = 64


class Sample(NamedTuple):
    """The true state at sample k, t = k Ts [s], as the monitor sees it: theta (unwrapped on closed paths),
    theta_dot [1/s], deviation = max_j |q - Phi(theta)| [rad], along = Phi'^T (q - Phi) / |Phi'|^2 [theta],
    speed2 = |Phi'|^2, ok (finite and below the speed limit), q, qd (n,), previous_theta (theta of the
    sample before; the start of the domain at k = 0), arrived: whether an Arrival has set the cycle time,
    tcp_distance: distance of the TCP from the planned TCP path [m], tcp_to_end: from the path's end point [m]."""

    k: int
    t: float
    theta: float
    theta_dot: float
    deviation: float
    along: float
    speed2: float
    ok: bool
    q: np.ndarray
    qd: np.ndarray
    previous_theta: float
    arrived: bool
    tcp_distance: float = 0.0
    tcp_to_end: float = np.inf


@dataclass(frozen=True)
class Arrival:
    """The run reached its end. time: cycle time [s] (None: keep the one already set); stop: the run ends at
    this sample; keep: this sample is part of the recorded motion; settle: settle time [s], if measured."""

    time: float | None
    stop: bool = True
    keep: bool = True
    settle: float | None = None


Verdict = Failure | Arrival | None


class EndRule(Protocol):
    """What the loop asks every rule, every sample, and once at the end."""

    def check(self, s: Sample) -> Verdict:
        """Verdict on the true state, before the controller runs."""

    def check_torque(self, s: Sample, command: np.ndarray, applied: np.ndarray, finite: bool,
                     clipped: bool) -> Failure | None:
        """Verdict on the torque (n,) [N m] just commanded and applied (saturated), before the plant step."""

    def finish(self, s: Sample) -> Failure | None:
        """The run has ended at sample ``s``: a failure still open (an episode under way), or None."""


class Rule:
    """Base class: no verdict on any hook."""

    def check(self, s: Sample) -> Verdict:
        return None

    def check_torque(self, s, command, applied, finite, clipped) -> Failure | None:
        return None

    def finish(self, s: Sample) -> Failure | None:
        return None


@dataclass
class Diverged(Rule):
    """The state is NaN/inf or a joint speed is above ``speed_factor`` x its limit; or the controller
    returned a non-finite torque."""

    speed_factor: float = defaults.DIVERGENCE_SPEED_FACTOR

    def check(self, s: Sample) -> Verdict:
        if s.ok:
            return None
        return Failure("diverged", s.t, s.theta, f"the state diverged (|qd| above {self.speed_factor:g} x the velocity "
                       f"limit or NaN) at t = {s.t:.4g} s, theta = {s.theta:.6g}")

    def check_torque(self, s, command, applied, finite, clipped) -> Failure | None:
        if finite:
            return None
        return Failure("diverged", s.t, s.theta, f"the controller returned a non-finite torque at t = {s.t:.4g} s, "
                       f"theta = {s.theta:.6g}")


@dataclass
class EndCrossing(Rule):
    """Open path planned to end moving: arrival when the robot crosses the normal plane of the end, theta_ext =
    end, theta_ext = theta + along extending the projection past it; the run stops there."""

    end: float
    sample_time: float

    def check(self, s: Sample) -> Verdict:
        if s.theta < self.end:
            return None
        ext, prev, ts = s.theta + s.along, s.previous_theta, self.sample_time
        done = float(s.t - ts + ts * (self.end - prev) / (ext - prev)) if ext > prev else s.t
        return Arrival(done, stop=True, keep=False)


@dataclass
class LeftRange(Rule):
    """Open path: the robot is past an end of the domain [lo, hi] by more than ``threshold`` [rad] along the
    path (along |Phi'|); not tested where |Phi'|^2 <= speed_eps."""

    lo: float
    hi: float
    threshold: float
    speed_eps: float

    def check(self, s: Sample) -> Verdict:
        if not ((s.theta <= self.lo or s.theta >= self.hi) and s.speed2 > self.speed_eps):
            return None
        excess = s.along * np.sqrt(s.speed2)
        if (s.theta >= self.hi and excess > self.threshold) or (s.theta <= self.lo and excess < -self.threshold):
            side = "end" if s.theta >= self.hi else "start"
            return Failure("left_path_range", s.t, s.theta, f"the robot left the path past its {side} "
                           f"(theta = {s.theta:.6g}) by {abs(excess):.3g} rad at t = {s.t:.4g} s",
                           value=float(abs(excess)), limit=self.threshold, unit="rad")
        return None


@dataclass
class PathTolerance(Rule):
    """The TCP farther than ``tolerance`` [m] from the planned path. One excursion: where (t, theta) it left,
    and its largest distance, reported when the TCP is back within the tolerance or the run ends."""

    tolerance: float
    left: tuple[float, float] | None = field(default=None, init=False)
    peak: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), init=False)

    def check(self, s: Sample) -> Verdict:
        if s.tcp_distance > self.tolerance:
            if self.left is None:
                self.left = (s.t, s.theta)
            if s.tcp_distance > self.peak[0]:
                self.peak = (float(s.tcp_distance), s.t, s.theta)
            return None
        return self.finish(s)

    def finish(self, s: Sample) -> Failure | None:
        if self.left is None:
            return None
        (t, theta), (peak, tp, thp) = self.left, self.peak
        return Failure("path_tolerance", t, theta, f"the TCP left the {self.tolerance * 1e3:.4g} mm path tolerance at "
                       f"t = {t:.4g} s, theta = {theta:.6g} and went {peak * 1e3:.4g} mm from the planned path "
                       f"(largest at t = {tp:.4g} s, theta = {thp:.6g}); slow the motion down there or raise "
                       "simulate.path_tolerance", value=peak, limit=self.tolerance, unit="m")


@dataclass
class JointTolerance(Rule):
    """max_j |q - Phi(theta)| above ``threshold`` [rad]."""

    threshold: float

    def check(self, s: Sample) -> Verdict:
        if s.deviation <= self.threshold:
            return None
        return Failure("joint_tolerance", s.t, s.theta, f"joint deviation {s.deviation:.3g} rad > {self.threshold:g} "
                       f"rad at t = {s.t:.4g} s, theta = {s.theta:.6g}; slow the profile down or raise the gains",
                       value=float(s.deviation), limit=self.threshold, unit="rad")


@dataclass
class Saturation(Rule):
    """A joint torque clipped at its limit in more than ``limit`` [s] of consecutive samples (each sample
    counts ``sample_time``); reported when the stretch ends or the run ends, with its length."""

    limit: float
    sample_time: float
    start: tuple[float, float] | None = field(default=None, init=False)
    length: float = field(default=0.0, init=False)
    peak: float = field(default=0.0, init=False)

    def check_torque(self, s, command, applied, finite, clipped) -> Failure | None:
        if clipped:
            if self.start is None:
                self.start, self.length, self.peak = (s.t, s.theta), 0.0, 0.0
            self.length += self.sample_time
            self.peak = max(self.peak, float(np.max(np.abs(command) / np.maximum(np.abs(applied), 1e-300))))
            return None
        return self.finish(s)

    def finish(self, s: Sample) -> Failure | None:
        if self.start is None:
            return None
        (t, theta), length = self.start, self.length
        self.start = None
        if length <= self.limit + STOP_SLACK:
            return None
        return Failure("saturation", t, theta, f"a joint torque stayed saturated for {length:.4g} s from t = {t:.4g} "
                       f"s, theta = {theta:.6g} (limit {self.limit:g} s; commands up to {self.peak:.3g} x the limit); "
                       "slow the motion down there or plan with a torque reserve", value=float(length),
                       limit=self.limit, unit="s")


@dataclass
class TcpArrival(Rule):
    """Open path: arrival when the TCP is within ``tolerance`` [m] of the end point with theta >= ``from_theta``
    (the end's own stretch of the path), the entry interpolated. The plan itself spends ``planned`` -
    ``plan_arrival`` [s] (its duration less its own entry into the ball) inside it: credited to the run, so a
    perfect tracker reports the planned duration. The run stops ``settle_time`` [s] later; the settle time is
    when the TCP last entered the ball (same clock), None if it is outside at the end."""

    tolerance: float
    from_theta: float
    planned: float
    plan_arrival: float
    settle_time: float
    sample_time: float
    stop_at: float | None = field(default=None, init=False)
    previous: float | None = field(default=None, init=False)
    settled: float | None = field(default=None, init=False)

    def _entry(self, s: Sample) -> float:
        prev, dist, tol, ts = self.previous, s.tcp_to_end, self.tolerance, self.sample_time
        done = s.t if prev is None or prev <= tol else s.t - ts + ts * (prev - tol) / (prev - dist)
        return float(done + self.planned - self.plan_arrival)

    def check(self, s: Sample) -> Verdict:
        inside = s.tcp_to_end <= self.tolerance
        entry = self._entry(s) if inside and (self.previous is None or self.previous > self.tolerance) else None
        self.previous = s.tcp_to_end if s.theta >= self.from_theta else None
        if self.stop_at is not None:
            self.settled = (entry if entry is not None else self.settled) if inside else None
            if s.t >= self.stop_at - STOP_SLACK:
                return Arrival(None, settle=self.settled)
            return None
        if s.theta < self.from_theta or not inside:
            return None
        self.stop_at, self.settled = s.t + self.settle_time, entry if entry is not None else self._entry(s)
        return Arrival(self.settled, stop=False)


@dataclass
class Laps(Rule):
    """Closed path: arrival after ``laps`` turns of theta from ``lo`` (period ``length``); the cycle time is the
    mean period."""

    lo: float
    length: float
    laps: int
    sample_time: float

    def check(self, s: Sample) -> Verdict:
        turns = (s.theta - self.lo) / self.length
        if turns < self.laps:
            return None
        prev, ts = (s.previous_theta - self.lo) / self.length, self.sample_time
        return Arrival(float((s.t - ts + ts * (self.laps - prev) / (turns - prev)) / self.laps))


@dataclass
class Timeout(Rule):
    """Not arrived by ``budget`` [s]."""

    budget: float
    domain: tuple[float, float]

    def check(self, s: Sample) -> Verdict:
        if s.arrived or s.t < self.budget:
            return None
        lo, hi = self.domain
        return Failure("timeout", s.t, s.theta, f"the TCP did not reach the end of the path within the time budget "
                       f"{self.budget:.4g} s (theta = {s.theta:.6g} of [{lo:.6g}, {hi:.6g}])",
                       value=float((s.theta - lo) / (hi - lo)), unit="fraction of the path")


def end_rules(table: PathTable, profile: Profile, tcp_line: np.ndarray, budget: float, settings) -> list[EndRule]:
    """Fresh rules for one run of the plan ``profile`` on ``table`` (planned TCP path tcp_line (M, 3) [m] on
    table.grid, time budget [s], SimulationSettings), in the order they are checked."""
    lo, hi = table.domain
    ts, jtol, ptol = settings.sample_time, settings.joint_tolerance, settings.path_tolerance
    rules: list[EndRule] = [Diverged()]
    judge = [PathTolerance(ptol), JointTolerance(jtol), Saturation(settings.saturation_limit, ts)]
    if table.closed:
        return [*rules, *judge, Laps(lo, hi - lo, settings.laps, ts), Timeout(budget, (lo, hi))]
    if profile.x[-1] > 0:  # planned to end moving: what follows the crossing is not part of the plan
        rules.append(EndCrossing(hi, ts))
    rules += [LeftRange(lo, hi, jtol, FLAT_SPEED2 * table.speed2_scale), *judge]
    # arrival also needs theta past the point where the plan enters the ball (less the ball's own theta
    # extent), so a path that starts where it ends (a full circle from rest to rest) does not arrive at t = 0
    plan_arrival, theta_in = plan_arrival_time(table.grid, tcp_line, profile, ptol)
    rules.append(TcpArrival(ptol, theta_in - (hi - theta_in), profile.duration, plan_arrival,
                            settings.settle_time, ts))
    return [*rules, Timeout(budget, (lo, hi))]


def plan_arrival_time(grid: np.ndarray, tcp_line: np.ndarray, profile: Profile, tolerance: float
                      ) -> tuple[float, float]:
    """Planned time [s] and theta at which the planned TCP (tcp_line (M, 3) on grid (M,), linear in between)
    enters the ball of radius ``tolerance`` [m] around the path's end point for the last time (found on a
    PLAN_ARRIVAL_STEP grid searched from the end, interpolated linearly)."""
    t_all = np.linspace(0.0, profile.duration, max(2, int(np.ceil(profile.duration / PLAN_ARRIVAL_STEP)) + 1))
    end = tcp_line[-1]
    stop = len(t_all)
    while stop > 0:
        lo_i = max(0, stop - PLAN_ARRIVAL_CHUNK)
        t = t_all[lo_i:stop + 1]
        theta = profile.state_at_time(t)[0]
        tcp = np.stack([np.interp(theta, grid, tcp_line[:, a]) for a in range(3)], axis=1)
        dist = np.linalg.norm(tcp - end, axis=1)
        outside = np.nonzero(dist > tolerance)[0]
        if len(outside):
            i = int(outside[-1])
            if i + 1 >= len(t):
                return float(profile.duration), float(theta[-1])
            w = (dist[i] - tolerance) / (dist[i] - dist[i + 1])
            return float(t[i] + (t[i + 1] - t[i]) * w), float(theta[i] + (theta[i + 1] - theta[i]) * w)
        stop = lo_i
    return 0.0, float(profile.state_at_time(np.zeros(1))[0][0])
