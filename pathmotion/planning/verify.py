"""Verification of a trajectory against the limits on a dense time resample.

ratio = max over samples and joints of |value| / limit, for joint velocity, joint acceleration,
joint torque and TCP speed (None where that limit is off). A ratio <= 1 + LIMIT_TOLERANCE passes.
A kink crossed at non-zero speed makes the joint velocity jump: its acceleration and torque are
unbounded and reported as inf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..robot import jacobian
from .constraints import EffectiveLimits
from .trajectory import Samples, Trajectory, sample_times

KINDS = ("velocity", "acceleration", "torque", "tcp_speed")


@dataclass(frozen=True)
class LimitRatios:
    """max |value| / limit per kind (None: limit off); ``sample_time`` [s] of the resample;
    ``worst``: where the largest ratio occurs (kind, joint, t, theta)."""

    velocity: float | None
    acceleration: float | None
    torque: float | None
    tcp_speed: float | None
    sample_time: float
    worst: str

    @property
    def max_ratio(self) -> float:
        vals = [v for v in (self.velocity, self.acceleration, self.torque, self.tcp_speed) if v is not None]
        return max(vals) if vals else 0.0

    def within(self, tolerance: float = defaults.LIMIT_TOLERANCE) -> bool:
        return self.max_ratio <= 1.0 + tolerance


def sample_ratios(trajectory: Trajectory, limits: EffectiveLimits, dt: float,
                  jump_intervals=()) -> tuple[Samples, dict]:
    """Resample every ``dt`` [s], plus the middle of every jump interval (theta_a, theta_b) of the
    profile (shorter than any sample step); ratios per kind: (N, n) arrays ((N, 1) for TCP speed)."""
    traj = trajectory
    if limits.torque is None and traj.robot is not None:
        traj = Trajectory(traj.path, traj.profile, None)
    prof = traj.profile
    t = sample_times(prof.duration, dt)
    if jump_intervals:
        i = np.searchsorted(prof.grid, [a for a, _ in jump_intervals])
        t = np.sort(np.concatenate([t, 0.5 * (prof.times[i] + prof.times[i + 1])]))
    s = traj.at_time(t)
    out = {}
    if limits.velocity is not None:
        out["velocity"] = np.abs(s.qd) / limits.velocity
    if limits.acceleration is not None:
        out["acceleration"] = np.abs(s.qdd) / limits.acceleration
    if limits.torque is not None:
        out["torque"] = np.abs(s.tau) / limits.torque
    if limits.tcp_speed is not None:
        jv = jacobian(trajectory.robot, s.q)[:, :3, :]
        out["tcp_speed"] = (np.linalg.norm(np.einsum("kij,kj->ki", jv, s.qd), axis=1) / limits.tcp_speed)[:, None]
    return s, out


def limit_ratios(trajectory: Trajectory, limits: EffectiveLimits, dt: float = defaults.VERIFY_SAMPLE_TIME,
                 velocity_jumps: tuple[float, ...] = (), joint_names: tuple[str, ...] | None = None,
                 jump_intervals=()) -> LimitRatios:
    """Ratios on a resample every ``dt`` [s]; ``velocity_jumps``: theta of kinks crossed at speed;
    ``jump_intervals``: (theta_a, theta_b) of the profile's jumps in theta_dot (also sampled)."""
    s, ratios = sample_ratios(trajectory, limits, dt, jump_intervals)
    return summarize(s, ratios, limits, dt, velocity_jumps, joint_names)


def summarize(s: Samples, ratios: dict, limits: EffectiveLimits, dt: float,
              velocity_jumps: tuple[float, ...] = (), joint_names: tuple[str, ...] | None = None) -> LimitRatios:
    """LimitRatios from sampled ratio arrays (see :func:`sample_ratios`)."""
    values = {k: None for k in KINDS}
    worst, worst_text = -1.0, "no limit active"
    for kind, r in ratios.items():
        k, j = np.unravel_index(int(np.argmax(r)), r.shape)
        values[kind] = float(r[k, j])
        if values[kind] > worst:
            worst = values[kind]
            name = "TCP" if kind == "tcp_speed" else (joint_names[j] if joint_names else f"joint {j + 1}")
            worst_text = f"{kind} of {name} at t = {s.t[k]:.6g} s, theta = {s.theta[k]:.6g}: ratio {worst:.6g}"
    if velocity_jumps:
        for kind in ("acceleration", "torque"):
            if values[kind] is not None:
                values[kind] = float("inf")
        if limits.acceleration is not None or limits.torque is not None:
            worst_text = (f"joint velocity jumps at the kink theta = {velocity_jumps[0]:.6g} (crossed at non-zero "
                          "speed): unbounded acceleration and torque")
    return LimitRatios(values["velocity"], values["acceleration"], values["torque"], values["tcp_speed"], dt, worst_text)


def worst_outside(s: Samples, ratios: dict, intervals) -> float:
    """Largest ratio over the samples outside the given theta intervals (jumps at "max" connections)."""
    free = np.ones(len(s.t), dtype=bool)
    for a, b in intervals:
        free &= ~((s.theta >= a) & (s.theta <= b))
    vals = [float(r[free].max()) for r in ratios.values() if free.any()]
    return max(vals, default=0.0)
