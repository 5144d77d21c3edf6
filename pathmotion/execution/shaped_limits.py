"""The plan's limits on the shaped motion of a second-order plan (--correction shaping / orbital).

The shaper (reference.py, :func:`~.reference.path_motion`) averages theta(t) over earlier times: at a corner
the averaged motion arrives with the faster speeds of before, and its joint velocity, acceleration and torque
exceed the plan's limits (corner_g2: acceleration 1.24 times its limit). :func:`shaped_plan` plans again with
each limit the shaped motion exceeds scaled down by its excess where the shaper took the excess from, until the
shaped motion of the plan it streams is within the original plan's limits (1 + limit_tolerance): the plan
streamed is slower, the path the same (the shaper moves along it).
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from .. import defaults
from ..planning import effective_limits, plan
from ..planning.planner import TIGHTEN_TARGET, at_points
from ..planning.trajectory import motion_samples
from ..robot import Robot
from .reference import RawMotion, path_motion, shaper_support

log = logging.getLogger(__name__)


def motion_ratios(robot: Robot, path, motion: np.ndarray, limits, t: np.ndarray | None = None) -> dict[str, float]:
    """{limit name: largest ratio} of the motion (K, 3) (theta, theta_dot, theta_ddot) along ``path`` against
    the effective ``limits`` (order 1 and 2: velocity, acceleration, torque, TCP speed; third-order ones are
    left out: a shaped motion's jerk is not continuous)."""
    return {name: float(r.max()) for name, r in _sample_ratios(robot, path, motion, limits, t).items()}


def _shaped(robot: Robot, plan_result, period: float, limits, step: float):
    """The plan's motion shaped for ``period`` [s] every ``step`` [s]: ({limit name: ratio per sample (K,)} against
    ``limits``, and per sample the raw motion's theta window (lo (K,), hi (K,)) the shaper averaged over)."""
    raw = RawMotion(plan_result.profile)
    t = np.arange(int(np.ceil((raw.duration + shaper_support(period)) / step)) + 1) * step
    motion = np.stack(path_motion(raw, t, period), axis=1)
    ratios = _sample_ratios(robot, plan_result.trajectory.path, motion, limits, t)
    return ratios, raw.state(t - shaper_support(period))[0], raw.state(t)[0]


def _sample_ratios(robot: Robot, path, motion: np.ndarray, limits, t: np.ndarray | None = None) -> dict:
    """{limit name: ratio per sample (K,), the largest over its columns} (see :func:`motion_ratios`)."""
    theta, theta_dot, theta_ddot = np.asarray(motion, float).T
    samples = motion_samples(path, robot if limits.needs_torque else None,
                             np.zeros(len(theta)) if t is None else t, theta, theta_dot, theta_ddot)
    return {lim.name: np.max(np.asarray(lim.ratios(samples, robot)).reshape(len(theta), -1), axis=1)
            for lim in limits.active if lim.order <= 2}


def shaped_ratios(robot: Robot, plan_result, period: float, limits=None,
                  step: float = defaults.EGM_TABLE_STEP) -> dict[str, float]:
    """:func:`motion_ratios` of ``plan_result``'s motion shaped for a gear mode of ``period`` [s], sampled every
    ``step`` [s], against ``limits`` (default: the plan's own effective limits)."""
    limits = effective_limits(robot, plan_result.settings) if limits is None else limits
    return {name: float(r.max()) for name, r in _shaped(robot, plan_result, period, limits, step)[0].items()}


class _LocalScale:
    """The local tightening :func:`~pathmotion.planning.plan` takes (``scale_along``): per round, per limit, the
    raw motion's theta windows whose shaped average exceeded it and their factors; at a grid point, the product
    over rounds of the smallest factor of the windows that the grid intervals on either side of it overlap."""

    def __init__(self):
        self.rounds: list[dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]] = []

    def __call__(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for windows in self.rounds:
            for name, (lo, hi, factor) in windows.items():
                overlap = (theta[:-1, None] <= hi[None]) & (theta[1:, None] >= lo[None])  # (K - 1, W)
                point = at_points(np.where(overlap, factor[None], 1.0).min(axis=1))
                out[name] = out.get(name, np.ones(len(theta))) * point
        return out


def shaped_plan(robot: Robot, plan_result, period: float, iterations: int = defaults.EGM_SHAPED_REPLANS,
                step: float = defaults.EGM_TABLE_STEP) -> tuple[object, dict[str, float]]:
    """(a plan whose motion shaped for ``period`` [s] is within ``plan_result``'s limits, its shaped ratios
    against them). Where the shaped motion exceeds a limit by more than TIGHTEN_TRIGGER x limit_tolerance, that
    limit is scaled by (1 - TIGHTEN_TARGET x tol) / ratio on the path the shaper averaged there (the raw
    motion's theta over the last quarter period) and the path planned again (``planning.plan``'s ``scale_along``),
    at most ``iterations`` times (a log warning when the ratios are still above 1 + tol then). A jerk-limited
    plan (no shaper, period 0) or one already within its limits comes back as it is."""
    settings = plan_result.settings
    limits = effective_limits(robot, settings)
    tol = settings.limit_tolerance
    result, local = plan_result, _LocalScale()
    per_sample, lo, hi = _shaped(robot, result, period, limits, step)
    if period > 0.0 and not plan_result.profile.smooth:
        for _ in range(iterations):
            if max((float(r.max()) for r in per_sample.values()), default=0.0) <= 1.0 + tol:
                break
            windows = {}
            for name, r in per_sample.items():
                over = r > 1.0 + defaults.TIGHTEN_TRIGGER * tol
                if over.any():
                    windows[name] = (lo[over], hi[over], (1.0 - TIGHTEN_TARGET * tol) / r[over])
            local.rounds.append(windows)
            result = plan(plan_result.trajectory.path, robot, replace(settings, baselines=False), scale_along=local)
            per_sample, lo, hi = _shaped(robot, result, period, limits, step)
    ratios = {name: float(r.max()) for name, r in per_sample.items()}
    worst = max(ratios.values(), default=0.0)
    if worst > 1.0 + tol and result is not plan_result:
        log.warning("the shaped motion still exceeds the plan's limits by %.3g %% after %d plans with limits "
                    "tightened locally (%s)", 100.0 * (worst - 1.0), len(local.rounds), _listed(ratios))
    if result is not plan_result:
        log.info("shaping: planned again %d times with the limits tightened where the shaped motion exceeded them, "
                 "so that it keeps the plan's limits (%s): %.6g s instead of %.6g s (+%.3g %%)", len(local.rounds),
                 _listed(ratios), result.duration, plan_result.duration,
                 100.0 * (result.duration / plan_result.duration - 1.0))
    return result, ratios


def _listed(ratios: dict[str, float]) -> str:
    return ", ".join(f"{name} {r:.4f}" for name, r in ratios.items())
