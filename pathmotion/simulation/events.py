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
            if theta >= self.path.domain[1]:  # the motion is over: nothing is left to re-time
                tail = None
            elif event.stop:
                tail = self.retimer.stop(theta, v_ref, u_ref) if v_ref > 0 else None
            elif event.resume or not self.stopped:  # an override while stopped applies at the resume
                tail = self.retimer.override_remaining(theta, v_ref, u_ref if v_ref > 0 else 0.0, self.override)
            else:
                tail = None
        except PathmotionError as err:
            raise SimulationError(f"event {event.kind} at t = {event.t:g} s, theta = {theta:.6g}: {err}") from err
        spent = 1e3 * (time.perf_counter() - clock)
        report = _Report(event, theta, v_ref, spent)
        held = False
        if tail is not None:
            for r in self.reports:  # superseded: the target they were judged against is gone
                if r.reaction_time is None and not r.event.stop:
                    r.goal = None
            self.target = _joined(self.target, tail, theta)
            self.stopped = bool(event.stop)
            self._switch(command, t, theta)
        elif event.stop and not self.stopped and theta < self.path.domain[1]:  # at rest already: hold there
            command.controller = _Held(command.controller, t)
            self.stopped = held = True
        report.scale = max(v_ref, 1e-9)
        if held:
            report.planned_stop_distance = report.stop_distance = report.reaction_time = 0.0
        elif event.stop and tail is not None:
            report.planned_stop_distance = float(self.target.grid[-1] - theta)
            report.goal = lambda th: 0.0
        elif tail is None:
            report.goal = None
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

    def _switch(self, command, t: float, theta: float) -> None:
        """The running orbital controller replaced by one designed for the new target, with its state (``theta``:
        the measured path position at t)."""
        running = command.controller
        old = getattr(running, "inner", running)
        path = self.path if self.target.grid[-1] >= self.path.domain[1] else SubPath.of(self.path, self.target.grid[-1])
        s = self.settings
        table = PathTable.from_path(path, s.table_points)
        sampled = (s.sample_time, int(s.realism.delay)) if s.sampled_design else (None, 0)
        design = OrbitalDesign.build(table, self.target, s.orbital_gains, *sampled)
        new = OrbitalController(design, self.robot, s.sample_time, int(s.realism.delay), s.sampled_design,
                                s.identify_payload)
        _take_over(new, old, t, running.t_ref if isinstance(running, _Held) else None, theta)
        command.controller = new


class _Held:
    """A running orbital controller ``inner`` holding the arm where its reference rests at time t [s] (a stop
    while the reference is at rest, e.g. before the motion starts): computed torque on the controller's model
    with its clock-play gains towards Phi(theta) at rest (the clock play itself would feed the plan's
    acceleration forward)."""

    def __init__(self, inner: OrbitalController, t: float):
        self.inner = inner
        self.t_ref, self.theta_hold = _played(inner, t)
        self.q_hold = np.asarray(inner.design.table.evaluate_scalar(self.theta_hold)[0], dtype=float)

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        c = self.inner
        q, qd = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(qd, dtype=float)
        c.observer.measure(q, qd)
        kp, kd, _ = c._clock_gains
        v = kp * (self.q_hold - q) - kd * qd
        return c.observer.command(c._model_torque(q, qd, v, self.theta_hold, None), c._offset)

    def __getattr__(self, name):
        return getattr(self.inner, name)


def _played(c: OrbitalController, t: float) -> tuple[float, float]:
    """(planned time [s], theta) of the running controller's reference at time t: in the clock play the
    played one (at most the end of its target), else its projected theta's."""
    d = c.design
    if c.clock is not None:  # c.theta is where the play began; the reference has moved on since
        _, t0, plan0 = c.clock
        played = min(plan0 + (t - t0), d.profile.duration)
        return played, float(d.profile.profile.state_at_time(np.array([played]))[0][0])
    theta = min(max(c.theta, d.table.domain[0]), d.table.domain[1])
    return d.profile.time(theta), theta


def _joined(old: Profile, tail: Profile, theta: float) -> Profile:
    """``old`` up to ``theta`` followed by ``tail`` (which starts at theta); piecewise-linear x."""
    keep = old.grid < theta - 1e-12 * max(1.0, abs(theta))
    return Profile(np.concatenate([old.grid[keep], tail.grid]), np.concatenate([old.x[keep], tail.x]))


def _take_over(new: OrbitalController, old: OrbitalController, t: float, held: float | None = None,
               measured: float | None = None) -> None:
    """``new`` continues ``old``'s run at time t [s]: its path position (in the clock play the played
    reference's, the end of old's target at most: a held stop resumes from there), integrals, observer and
    payload estimate, and the clock zone of the new design it is in (zones already passed are not entered
    again). The new target equals the old one up to the switch, so their planned times agree there. ``held``:
    the planned time [s] old's reference was held at (a stop at rest), else None. ``measured``: the measured path
    position at t; where old runs the orbital law (its theta is the last sample's projection) and new starts in a
    clock zone, the play starts from it, not a sample behind the arm."""
    theta = _played(old, t)[1] if held is None else \
        float(old.design.profile.profile.state_at_time(np.array([held]))[0][0])
    d = new.design
    theta = min(max(theta, d.table.domain[0]), d.table.domain[1])
    new.theta, new.theta_dot = theta, old.theta_dot
    new.observer, new.payload, new.v = old.observer, old.payload, old.v
    if new.xi.shape == old.xi.shape:
        new.xi[:], new.xi_q[:] = old.xi, old.xi_q
    planned = d.profile.time(theta)
    zone = d.zone_at(planned)
    if zone is not None and held is None and old.clock is None and measured is not None:
        new.theta = theta = min(max(measured, d.table.domain[0]), d.table.domain[1])
        planned = d.profile.time(theta)
        zone = d.zone_at(planned)
    if zone is not None:
        new.clock, new.next_zone = (zone, t, planned), zone + 1
        if old.clock is None:
            new._integral_to_joints(theta)
    else:
        new.clock = None
        new.next_zone = next((i for i, (z0, _) in enumerate(d.zones) if z0 > planned), len(d.zones))
        if old.clock is not None:
            new._integral_to_transverse()
