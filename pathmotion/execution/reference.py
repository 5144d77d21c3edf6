"""The joint references execute streams: the plan tabulated in time, shaped for the drives, time-scaled.

``none`` streams q(t), qd(t) of the plan. ``shaping`` pre-compensates the known drive and EGM dynamics
(from the drive file), so that the arm's link side, not the reference, follows the plan:

    m(t) = q(t) + K^-1 tau_g(t)             the motor position that bends each elastic gear by its load
                                            (tau_g: the link-side torque of the plan, rotors excluded)
    m(t + L)                                lead by the transport delay L (whole EGM cycles)
    p_k = (m_k - (1 - a) m_(k-1)) / a       the exact inverse of EGM's first-order low-pass (a per cycle)

and the same for the speed reference. Every reference is clipped into the joint limits (position and speed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..robot import Robot, rnea
from .drive_file import DriveParameters

MODES = ("none", "shaping")


@dataclass(frozen=True, eq=False)
class ReferenceTable:
    """References at times t (K,) [s] of plan time: q (K, n) [rad], qd (K, n) [rad/s] (what is sent), theta (K,)
    and plan (K, n) (the plan's own joints, for the record); duration [s]; path, profile: the motion's
    JointPath and Profile (plan time 0 = the profile's first point)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    theta: np.ndarray
    plan: np.ndarray
    duration: float
    path: object = None
    profile: object = None

    @property
    def end(self) -> float:
        """Plan time of the last reference [s] (the duration plus the shaping's lead)."""
        return float(self.t[-1])

    def state(self, tau: float) -> tuple[float, float, float]:
        """(theta, theta_dot, theta_ddot) of the motion at plan time tau [s]."""
        th, thd, thdd = self.profile.state_at_time(np.array([min(max(tau, 0.0), self.duration)]))
        return float(th[0]), float(thd[0]), float(thdd[0])

    def at(self, tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(q, qd, plan q, theta) at plan time tau (clipped to [0, duration]), linearly interpolated."""
        tau = min(max(tau, 0.0), self.duration)
        k = min(int(tau / self.t[1]), len(self.t) - 2) if len(self.t) > 1 else 0
        if len(self.t) == 1:
            return self.q[0], self.qd[0], self.plan[0], float(self.theta[0])
        w = (tau - self.t[k]) / (self.t[k + 1] - self.t[k])
        lerp = lambda a: a[k] + w * (a[k + 1] - a[k])  # noqa: E731
        return lerp(self.q), lerp(self.qd), lerp(self.plan), float(lerp(self.theta))


def gear_deflection(robot: Robot, drives: DriveParameters, q, qd, qdd) -> np.ndarray:
    """K^-1 tau_g (N, n) [rad]: each elastic gear's deflection under the plan's link-side torque (rotor inertia
    excluded: it is on the motor side of the gear); 0 on rigid axes."""
    elastic = drives.elastic
    if not elastic.any():
        return np.zeros_like(q)
    tau = rnea(robot, q, qd, qdd)
    if robot.limits.armature is not None:
        tau = tau - qdd * np.asarray(robot.limits.armature, float)  # the link side only
    return np.where(elastic, tau / np.where(elastic, drives.stiffness, 1.0), 0.0)


def _invert_lowpass(x: np.ndarray, alpha: float, per: int) -> np.ndarray:
    """y with the low-pass y -> x undone at the EGM cycle (``per`` table steps per cycle)."""
    prev = np.concatenate([np.repeat(x[:1], per, axis=0), x[:-per]]) if len(x) > per else np.repeat(x[:1], len(x), 0)
    return (x - (1.0 - alpha) * prev) / alpha


def build_reference(robot: Robot, trajectory, mode: str, drives: DriveParameters | None,
                    step: float = defaults.EGM_TABLE_STEP) -> ReferenceTable:
    """The table of references for ``trajectory`` (a planning.Trajectory) in ``mode`` (one of MODES)."""
    duration = float(trajectory.duration)
    lead = 0.0 if mode == "none" else drives.transport_delay
    t = np.arange(0.0, duration + lead + step, step)
    s = trajectory.at_time(t)
    q, qd = s.q, s.qd
    if mode != "none":
        ahead = trajectory.at_time(t + lead)
        m = ahead.q + gear_deflection(robot, drives, ahead.q, ahead.qd, ahead.qdd)
        md = np.gradient(m, step, axis=0) if len(t) > 2 else ahead.qd
        alpha = 1.0 - np.exp(-2.0 * np.pi * drives.lowpass_bandwidth * drives.cycle)
        per = max(1, int(round(drives.cycle / step)))
        q, qd = _invert_lowpass(m, alpha, per), _invert_lowpass(md, alpha, per)
    lim = robot.limits
    q = np.clip(q, lim.lower, lim.upper)
    qd = np.clip(qd, -lim.velocity, lim.velocity)
    return ReferenceTable(t, q, qd, s.theta, s.q, duration, trajectory.path, trajectory.profile)
