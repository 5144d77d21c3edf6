"""The rules that end a closed-loop run, one small object each (docs/control.md, "Failure rules").

Every sample the loop hands each rule, in order, the monitor's view of the true state (:class:`Sample`);
the first rule with a verdict decides the sample:

* a :class:`~.metrics.Failure` ends the run as failed;
* an :class:`Arrival` sets the simulated duration and, if ``stop``, ends the run as arrived;
* None passes to the next rule.

After the controller has computed the torque, each rule's ``check_torque`` sees it (command and applied).
A rule may keep state across samples (the arrival ball, the settle time), so :func:`end_rules` builds fresh
ones for every run. A new rule is a new class with ``check`` and/or ``check_torque``, added to the list.

The rules, in the order they are checked:

* :class:`Diverged`: NaN/inf or |qd_j| > DIVERGENCE_SPEED_FACTOR x the velocity limit; a non-finite torque;
* :class:`EndCrossing` (open path planned to end moving): the robot crosses the end; the run stops there
  and the crossing sample is not part of the motion;
* :class:`LeftRange` (open paths): past an end of the path by more than the threshold;
* :class:`Deviation`: max_j |q - Phi(theta)| above the threshold;
* :class:`RestArrival` (open paths): within ``arrival_tolerance`` of the final configuration, in the end's
  own stretch of the path; the run goes on for ``settle_time``;
* :class:`Laps` (closed paths): after ``laps`` turns; the duration is the mean period;
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


class Sample(NamedTuple):
    """The true state at sample k, t = k Ts [s], as the monitor sees it: theta (unwrapped on closed paths),
    theta_dot [1/s], deviation = max_j |q - Phi(theta)| [rad], along = Phi'^T (q - Phi) / |Phi'|^2 [theta],
    speed2 = |Phi'|^2, ok (finite and below the speed limit), q, qd (n,), previous_theta (theta of the
    sample before; the start of the domain at k = 0), arrived: whether an Arrival has set the duration."""

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


@dataclass(frozen=True)
class Arrival:
    """The run reached its end. time: simulated duration [s] (None: keep the one already set); stop: the
    run ends at this sample; keep: this sample is part of the recorded motion."""

    time: float | None
    stop: bool = True
    keep: bool = True


Verdict = Failure | Arrival | None


class EndRule(Protocol):
    """What the loop asks every rule, every sample."""

    def check(self, s: Sample) -> Verdict:
        """Verdict on the true state, before the controller runs."""

    def check_torque(self, s: Sample, command: np.ndarray, applied: np.ndarray, finite: bool,
                     clipped: bool) -> Failure | None:
        """Verdict on the torque (n,) [N m] just commanded and applied (saturated), before the plant step."""


class Rule:
    """Base class: no verdict on either hook."""

    def check(self, s: Sample) -> Verdict:
        return None

    def check_torque(self, s, command, applied, finite, clipped) -> Failure | None:
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
                           f"(theta = {s.theta:.6g}) by {abs(excess):.3g} rad at t = {s.t:.4g} s")
        return None


@dataclass
class Deviation(Rule):
    """max_j |q - Phi(theta)| above ``threshold`` [rad]."""

    threshold: float

    def check(self, s: Sample) -> Verdict:
        if s.deviation <= self.threshold:
            return None
        return Failure("deviation", s.t, s.theta, f"joint deviation {s.deviation:.3g} rad > {self.threshold:g} rad at "
                       f"t = {s.t:.4g} s, theta = {s.theta:.6g}; slow the profile down or raise the gains")


@dataclass
class RestArrival(Rule):
    """Open path: arrival when max_j |q - q_end| <= tolerance [rad] with theta >= ``from_theta`` (the end's own
    stretch of the path), the crossing interpolated. The plan itself spends ``planned`` - ``plan_arrival`` [s]
    (its duration less its own entry into the ball) inside it: credited to the run. The run stops
    ``settle_time`` [s] later."""

    q_end: np.ndarray
    tolerance: float
    from_theta: float
    planned: float
    plan_arrival: float
    settle_time: float
    sample_time: float
    stop_at: float | None = field(default=None, init=False)
    previous: float | None = field(default=None, init=False)

    def check(self, s: Sample) -> Verdict:
        if self.stop_at is not None:
            return Arrival(None) if s.t >= self.stop_at - STOP_SLACK else None
        if s.theta < self.from_theta:
            return None
        dist, prev, tol, ts = float(np.abs(s.q - self.q_end).max()), self.previous, self.tolerance, self.sample_time
        self.previous = dist
        if dist > tol:
            return None
        done = s.t if prev is None or prev <= tol else s.t - ts + ts * (prev - tol) / (prev - dist)
        self.stop_at = s.t + self.settle_time
        return Arrival(float(done + self.planned - self.plan_arrival), stop=False)


@dataclass
class Laps(Rule):
    """Closed path: arrival after ``laps`` turns of theta from ``lo`` (period ``length``); the duration is the
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
        return Failure("timeout", s.t, s.theta, f"the robot did not reach the end of the path within the time budget "
                       f"{self.budget:.4g} s (theta = {s.theta:.6g} of [{lo:.6g}, {hi:.6g}])")


def end_rules(table: PathTable, profile: Profile, q_end: np.ndarray, budget: float, settings) -> list[EndRule]:
    """Fresh rules for one run of the plan ``profile`` on ``table`` (final configuration q_end (n,), time
    budget [s], SimulationSettings), in the order they are checked."""
    lo, hi = table.domain
    ts, thr = settings.sample_time, settings.failure_threshold
    rules: list[EndRule] = [Diverged()]
    if table.closed:
        return [*rules, Deviation(thr), Laps(lo, hi - lo, settings.laps, ts), Timeout(budget, (lo, hi))]
    if profile.x[-1] > 0:  # planned to end moving: what follows the crossing is not part of the plan
        rules.append(EndCrossing(hi, ts))
    rules += [LeftRange(lo, hi, thr, FLAT_SPEED2 * table.speed2_scale), Deviation(thr)]
    # arrival also needs theta past the point where the plan enters the ball (less the ball's own theta
    # extent), so a path that starts where it ends (a full circle from rest to rest) does not arrive at t = 0
    plan_arrival, theta_in = plan_arrival_time(table, profile, q_end, settings.arrival_tolerance)
    rules.append(RestArrival(q_end, settings.arrival_tolerance, theta_in - (hi - theta_in),
                             profile.duration, plan_arrival, settings.settle_time, ts))
    return [*rules, Timeout(budget, (lo, hi))]


def plan_arrival_time(table: PathTable, profile: Profile, q_end: np.ndarray, tolerance: float) -> tuple[float, float]:
    """Planned time [s] and theta at which the plan enters max_j |Phi(theta*(t)) - q_end| <= tolerance for the
    last time (found on a PLAN_ARRIVAL_STEP grid, interpolated linearly)."""
    t = np.linspace(0.0, profile.duration, max(2, int(np.ceil(profile.duration / PLAN_ARRIVAL_STEP)) + 1))
    theta = profile.state_at_time(t)[0]
    dist = np.max(np.abs(table.evaluate(theta)[0] - q_end), axis=1)
    outside = np.nonzero(dist > tolerance)[0]
    if len(outside) == 0:
        return 0.0, float(theta[0])
    i = int(outside[-1])
    if i + 1 >= len(t):
        return float(profile.duration), float(theta[-1])
    w = (dist[i] - tolerance) / (dist[i] - dist[i + 1])
    return float(t[i] + (t[i + 1] - t[i]) * w), float(theta[i] + (theta[i + 1] - theta[i]) * w)
