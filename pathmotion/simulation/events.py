"""Re-timing events in the closed loop: a speed override, a stop on the path and a resume, at given times.

At an event's first sample the reference is re-timed from where it stands: at the measured path position
theta, the current target profile's speed and acceleration (the controller keeps tracking; a measured speed
a little above the limits' envelope cannot make the re-timing fail). planning/retime.py gives the tail:
``remaining`` at the override for an override or a resume while moving, ``stop`` for a stop, ``remaining``
from rest for a resume at rest. The new target is the old one up to theta joined to that tail; a stop's
target ends at rest where the stop ends, on the path cut there (the controller holds that point until a
resume). The orbital controller is designed anew for the new target and takes over the running one's
state (theta, its integrals, the disturbance observer and the payload estimate), so the switch is one
sample.

Each event's report: the re-timing's wall time, the path position and speed at the event, the reaction
time (until the measured speed is within REACTION_BAND of what the event asks for: the override's speed,
rest, or the resumed profile's once that is up to half its top speed), and for a stop the distance to rest,
planned and measured (path units).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..control import OrbitalController, OrbitalDesign, PathTable
from ..errors import PathmotionError, SimulationError
from ..lift.joint_path import JointPath
from ..planning.profile import Profile

log = logging.getLogger(__name__)

#: The measured path speed is "within" a target when it differs by at most this fraction of the speed at the
#: event (for a stop: below this fraction of it; for a resume, of the resumed profile's top speed) [-].
REACTION_BAND = 0.05


@dataclass(frozen=True)
class Event:
    """At time ``t`` [s]: set the speed ``override`` in (0, 1], or ``stop`` on the path, or ``resume``."""

    t: float
    override: float | None = None
    stop: bool = False
    resume: bool = False

    def __post_init__(self):
        actions = (self.override is not None) + bool(self.stop) + bool(self.resume)
        if actions != 1:
            raise SimulationError(f"event at t = {self.t!r}: give exactly one of override, stop = true, resume = true")
        if not (isinstance(self.t, (int, float)) and math.isfinite(self.t) and self.t >= 0):
            raise SimulationError(f"event time t = {self.t!r}; it must be a number >= 0 [s]")
        if self.override is not None and not (isinstance(self.override, (int, float)) and 0 < self.override <= 1):
            raise SimulationError(f"event at t = {self.t:g} s: override = {self.override!r}; it must be in (0, 1]")

    @property
    def kind(self) -> str:
        return "override" if self.override is not None else "stop" if self.stop else "resume"


@dataclass(frozen=True, eq=False)
class SubPath(JointPath):
    """``base`` on the part [domain] of its theta range (a stop's target ends where the stop ends)."""

    base: JointPath | None = None

    @classmethod
    def of(cls, base: JointPath, hi: float) -> "SubPath":
        lo = base.domain[0]
        inside = lambda values: tuple(v for v in values if lo < v < hi)  # noqa: E731
        return cls(n=base.n, domain=(lo, float(hi)), kinks=inside(base.kinks), breaks=inside(base.breaks),
                   joint_names=base.joint_names, peaks=inside(base.peaks), base=base)

    @property
    def knots(self) -> tuple[float, ...]:
        lo, hi = self.domain
        return tuple(k for k in getattr(self.base, "knots", ()) if lo < k < hi)

    def evaluate(self, theta, side="right"):
        self._check_theta(theta)
        return self.base.evaluate(theta, side)

    def evaluate3(self, theta, side="right"):
        self._check_theta(theta)
        return self.base.evaluate3(theta, side)


@dataclass
class _Report:
    """One event's figures (see the module docstring); ``goal(theta)``: the speed it asks for there."""

    event: Event
    theta: float
    theta_dot: float
    retime_ms: float
    planned_stop_distance: float | None = None
    reaction_time: float | None = None
    stop_distance: float | None = None
    goal: object = field(default=None, repr=False)
    scale: float = 1.0

    def as_dict(self) -> dict:
        return {"t_s": self.event.t, "kind": self.event.kind, "override": self.event.override,
                "theta": float(self.theta), "theta_dot": float(self.theta_dot), "retime_ms": self.retime_ms,
                "reaction_time_s": self.reaction_time, "stop_distance": self.stop_distance,
                "planned_stop_distance": self.planned_stop_distance}


class EventPlayer:
    """Applies ``events`` to a running orbital loop: call :meth:`step` once per sample before the control."""

    def __init__(self, events, retimer, robot, path: JointPath, profile: Profile, settings):
        self.pending = sorted(events, key=lambda e: e.t)
        self.retimer, self.robot, self.path, self.settings = retimer, robot, path, settings
        self.target, self.override, self.stopped = profile, 1.0, False
        self.reports: list[_Report] = []

    def step(self, t: float, theta: float, theta_dot: float, command) -> None:
        """Apply the events due at ``t`` [s] (measured path position theta and speed theta_dot), switching the
        controller held by ``command`` (the loop's command wrapper); update the open reports' reactions."""
        while self.pending and self.pending[0].t <= t + 1e-12:
            self._apply(self.pending.pop(0), t, theta, command)
        for r in self.reports:
            if r.reaction_time is None and r.goal is not None and t >= r.event.t:
                goal = r.goal(theta)
                if goal is not None and abs(theta_dot - goal) <= REACTION_BAND * r.scale:
                    r.reaction_time = t - r.event.t
                    if r.event.stop:
                        r.stop_distance = theta - r.theta

    def _apply(self, event: Event, t: float, theta: float, command) -> None:
        theta = min(max(theta, self.target.grid[0]), self.target.grid[-1])
        x_ref, u_ref = float(self.target.x_at(theta)), float(self.target.theta_ddot_at(theta))
        v_ref = math.sqrt(x_ref)
        if event.override is not None:
            self.override = float(event.override)
        clock = time.perf_counter()
        try:
            if event.stop:
                tail = self.retimer.stop(theta, v_ref, u_ref) if v_ref > 0 else None
            elif event.resume or not self.stopped:  # an override while stopped applies at the resume
                tail = self.retimer.remaining(theta, v_ref, u_ref if v_ref > 0 else 0.0, self.override)
            else:
                tail = None
        except PathmotionError as err:
            raise SimulationError(f"event {event.kind} at t = {event.t:g} s, theta = {theta:.6g}: {err}") from err
        spent = 1e3 * (time.perf_counter() - clock)
        report = _Report(event, theta, v_ref, spent)
        if tail is not None:
            self.target = _joined(self.target, tail, theta)
            self.stopped = bool(event.stop)
            self._switch(command, t)
        report.scale = max(v_ref, 1e-9)
        if tail is None:
            report.goal = None
        elif event.stop:
            report.planned_stop_distance = float(self.target.grid[-1] - theta)
            report.goal = lambda th: 0.0
        elif event.resume:
            report.scale = top = float(np.sqrt(np.max(tail.x)))

            def goal(th, p=self.target):  # judged once the resumed profile is up to half its top speed
                speed = float(p.theta_dot_at(min(th, p.grid[-1])))
                return speed if speed >= 0.5 * top else None
            report.goal = goal
        else:
            plan = self.retimer.plan.profile
            report.goal = lambda th, s=self.override: s * float(plan.theta_dot_at(min(th, plan.grid[-1])))
        self.reports.append(report)
        log.info("event %s at t = %.4g s, theta = %.6g: re-timed in %.3g ms", event.kind, t, theta, spent)

    def _switch(self, command, t: float) -> None:
        """The running orbital controller replaced by one designed for the new target, with its state."""
        old = command.controller
        path = self.path if self.target.grid[-1] >= self.path.domain[1] else SubPath.of(self.path, self.target.grid[-1])
        s = self.settings
        table = PathTable.from_path(path, s.table_points)
        sampled = (s.sample_time, int(s.realism.delay)) if s.sampled_design else (None, 0)
        design = OrbitalDesign.build(table, self.target, s.orbital_gains, *sampled)
        new = OrbitalController(design, self.robot, s.sample_time, int(s.realism.delay), s.sampled_design,
                                s.identify_payload)
        _take_over(new, old, t)
        command.controller = new


def _joined(old: Profile, tail: Profile, theta: float) -> Profile:
    """``old`` up to ``theta`` followed by ``tail`` (which starts at theta); piecewise-linear x."""
    keep = old.grid < theta - 1e-12 * max(1.0, abs(theta))
    return Profile(np.concatenate([old.grid[keep], tail.grid]), np.concatenate([old.x[keep], tail.x]))


def _take_over(new: OrbitalController, old: OrbitalController, t: float) -> None:
    """``new`` continues ``old``'s run at time t [s]: its theta, integrals, observer and payload estimate, and
    the clock zone of the new design it is in (zones already passed are not entered again)."""
    new.theta, new.theta_dot = old.theta, old.theta_dot
    new.observer, new.payload, new.v = old.observer, old.payload, old.v
    if new.xi.shape == old.xi.shape:
        new.xi[:], new.xi_q[:] = old.xi, old.xi_q
    d = new.design
    planned = d.profile.time(min(max(new.theta, d.table.domain[0]), d.table.domain[1]))
    zone = d.zone_at(planned)
    if zone is not None:
        new.clock, new.next_zone = (zone, t, planned), zone + 1
        new._integral_to_joints(new.theta) if old.clock is None else None
    else:
        new.clock = None
        new.next_zone = next((i for i, (z0, _) in enumerate(d.zones) if z0 > planned), len(d.zones))
        if old.clock is not None:
            new._integral_to_transverse()
