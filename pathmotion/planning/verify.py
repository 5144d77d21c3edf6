"""Verification of a trajectory against the limits: the dense time resample (``verify = "dense"``
and the independent check of planning/certify.py's certified interval bounds, the default), and the
summary of either.

ratio = max over samples and columns (joints, or the TCP) of |value| / limit, for every registered
limit (planning/limits/; None where that limit is off). A ratio <= 1 + LIMIT_TOLERANCE passes.
A kink crossed at non-zero speed makes the joint velocity jump: every limit of order >= 2
(acceleration, torque) is then unbounded and reported as inf.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import defaults
from .limits import REGISTRY, EffectiveLimits
from .trajectory import Samples, Trajectory, sample_times


@dataclass(frozen=True)
class LimitRatios:
    """max |value| / limit per registered limit name (None: limit off), e.g. ``ratios.torque`` or
    ``ratios.values["torque"]``; ``sample_time`` [s] of the resample (None for certified bounds);
    ``worst``: where the largest ratio occurs (kind, joint, t, theta); ``extra``: the limits'
    settings for summary.json (e.g. {"torque_reserve": 0.2}); ``method``: "dense" (sampled maxima)
    or "certified" (upper bounds over every grid interval)."""

    values: dict
    sample_time: float | None
    worst: str
    extra: dict = field(default_factory=dict)
    method: str = "dense"

    def __getattr__(self, name: str):
        if name != "values" and any(cls.name == name for cls in REGISTRY):
            return self.values.get(name)
        raise AttributeError(name)

    @property
    def max_ratio(self) -> float:
        vals = [v for v in self.values.values() if v is not None]
        return max(vals) if vals else 0.0

    def within(self, tolerance: float = defaults.LIMIT_TOLERANCE) -> bool:
        return self.max_ratio <= 1.0 + tolerance

    def summary(self) -> dict:
        """{summary key: ratio or None} for every registered limit, e.g. {"max_torque_ratio": 0.98, ...}."""
        out = {cls.summary_key(): self.values.get(cls.name) for cls in REGISTRY}
        for cls in REGISTRY:
            out.update({key: self.extra.get(key) for key in cls.extra_summary_keys})
        return out


def sample_ratios(trajectory: Trajectory, limits: EffectiveLimits, dt: float,
                  jump_intervals=()) -> tuple[Samples, dict]:
    """Resample every ``dt`` [s], plus the middle of every jump interval (theta_a, theta_b) of the
    profile (shorter than any sample step); ratios {name: (N, m)} per active limit."""
    traj = trajectory
    if not limits.needs_torque and traj.robot is not None:
        traj = Trajectory(traj.path, traj.profile, None)
    prof = traj.profile
    t = sample_times(prof.duration, dt)
    if jump_intervals:
        i = np.searchsorted(prof.grid, [a for a, _ in jump_intervals])
        t = np.sort(np.concatenate([t, 0.5 * (prof.times[i] + prof.times[i + 1])]))
    s = traj.at_time(t, third=limits.third_order, torque_rate=limits.needs_torque_rate)
    return s, {lim.name: lim.ratios(s, trajectory.robot) for lim in limits}


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
    def where(lim, k, j, ratio):
        return (f"{lim.name} of {lim.column_name(j, joint_names)} at t = {s.t[k]:.6g} s, "
                f"theta = {s.theta[k]:.6g}: ratio {ratio:.6g}")
    values, worst_text = _largest(ratios, limits, where)
    return _with_jumps(LimitRatios(values, dt, worst_text), limits, velocity_jumps)


def summarize_intervals(profile, bounds: dict, limits: EffectiveLimits, velocity_jumps: tuple[float, ...] = (),
                        joint_names: tuple[str, ...] | None = None) -> LimitRatios:
    """LimitRatios from certified bounds {name: (K - 1, m)} on the intervals of ``profile``'s grid
    (planning/certify.py): each value is the largest bound, "worst" names its interval."""
    grid, times = profile.grid, profile.times

    def where(lim, i, j, ratio):
        return (f"{lim.name} of {lim.column_name(j, joint_names)} for t in [{times[i]:.6g}, "
                f"{times[i + 1]:.6g}] s, theta in [{grid[i]:.6g}, {grid[i + 1]:.6g}]: ratio <= {ratio:.6g}")
    values, worst_text = _largest(bounds, limits, where)
    ratios = LimitRatios(values, None, worst_text, {}, "certified")
    return _with_jumps(ratios, limits, velocity_jumps)


def _largest(arrays: dict, limits: EffectiveLimits, where) -> tuple[dict, str]:
    """Per limit, the largest entry of its (K, m) array {name: array}; and ``where(lim, k, j, ratio)``'s text for the
    largest over all limits ("no limit active" when none is; formatted once, for that one)."""
    values = {cls.name: None for cls in REGISTRY}
    worst, worst_lim = -1.0, None
    for lim in limits:
        values[lim.name] = float(arrays[lim.name].max())
        if values[lim.name] > worst:
            worst, worst_lim = values[lim.name], lim
    if worst_lim is None:
        return values, "no limit active"
    r = arrays[worst_lim.name]
    k, j = np.unravel_index(int(np.argmax(r)), r.shape)
    return values, where(worst_lim, k, j, worst)


def _with_jumps(ratios: LimitRatios, limits: EffectiveLimits, velocity_jumps) -> LimitRatios:
    """``ratios`` with inf for every limit of order >= 2 when a kink is crossed at speed, and the extra keys."""
    values, worst_text = dict(ratios.values), ratios.worst
    if velocity_jumps:
        jumped = [lim.name for lim in limits if lim.order >= 2]
        for name in jumped:
            values[name] = float("inf")
        if jumped:
            worst_text = (f"joint velocity jumps at the kink theta = {velocity_jumps[0]:.6g} (crossed at non-zero "
                          "speed): unbounded acceleration and torque")
    extra = {key: value for lim in limits for key, value in lim.summary_values().items()}
    return LimitRatios(values, ratios.sample_time, worst_text, extra, ratios.method)


def interval_maxima(theta: np.ndarray, ratios: dict, grid: np.ndarray) -> dict:
    """{name: (K - 1, m)} largest of the values ``ratios`` {name: (N, m)} at ``theta`` (N,) in each
    interval of ``grid`` (K,) (0 where an interval holds no value; a value at a grid point counts for
    the interval it starts)."""
    k = np.clip(np.searchsorted(grid, theta, side="right") - 1, 0, len(grid) - 2)
    out = {}
    for name, r in ratios.items():
        r = np.asarray(r, float).reshape(len(theta), -1)
        acc = np.zeros((len(grid) - 1, r.shape[1]))
        np.maximum.at(acc, k, r)
        out[name] = acc
    return out


def worst_outside(s: Samples, ratios: dict, intervals) -> float:
    """Largest ratio over the samples outside the given theta intervals (jumps at "max" connections)."""
    free = outside(s.theta, intervals)
    vals = [float(r[free].max()) for r in ratios.values() if free.any()]
    return max(vals, default=0.0)


def outside(theta: np.ndarray, intervals) -> np.ndarray:
    """Mask (N,) of the theta outside every interval (a, b) (bounds included in the intervals)."""
    free = np.ones(len(theta), dtype=bool)
    for a, b in intervals:
        free &= ~((theta >= a) & (theta <= b))
    return free
