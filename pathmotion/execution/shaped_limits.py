"""The plan's limits on the shaped motion of a second-order plan (--correction shaping / orbital).

The shaper (reference.py, :func:`~.reference.path_motion`) averages theta(t) over earlier times: at a corner
the averaged motion arrives with the faster speeds of before, and its joint velocity, acceleration and torque
exceed the plan's limits (corner_g2: acceleration 1.24 times its limit). :func:`shaped_plan` plans again with
the limits that the shaped motion exceeds scaled down (each such limit uniformly along the path, by its
excess), until the shaped motion of the plan it streams is within the original plan's limits
(1 + limit_tolerance): the plan streamed is slower, the path the same (the shaper moves along it).
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from .. import defaults
from ..planning import Samples, effective_limits, plan
from ..planning.planner import TIGHTEN_TARGET
from ..robot import Robot, rnea
from .reference import RawMotion, path_motion, shaper_support

log = logging.getLogger(__name__)


def motion_ratios(robot: Robot, path, motion: np.ndarray, limits, t: np.ndarray | None = None) -> dict[str, float]:
    """{limit name: largest ratio} of the motion (K, 3) (theta, theta_dot, theta_ddot) along ``path`` against
    the effective ``limits`` (order 1 and 2: velocity, acceleration, torque, TCP speed; third-order ones are
    left out: a shaped motion's jerk is not continuous)."""
    theta, theta_dot, theta_ddot = (np.asarray(c, float) for c in np.asarray(motion).T)
    q, dq, ddq = path.evaluate(theta)
    qd = dq * theta_dot[:, None]
    qdd = dq * theta_ddot[:, None] + ddq * (theta_dot**2)[:, None]
    tau = rnea(robot, q, qd, qdd) if limits.needs_torque else None
    samples = Samples(np.zeros(len(theta)) if t is None else t, theta, theta_dot, theta_ddot, q, qd, qdd, tau)
    return {lim.name: float(np.max(lim.ratios(samples, robot))) for lim in limits.active if lim.order <= 2}


def shaped_ratios(robot: Robot, plan_result, period: float, limits=None,
                  step: float = defaults.EGM_TABLE_STEP) -> dict[str, float]:
    """:func:`motion_ratios` of ``plan_result``'s motion shaped for a gear mode of ``period`` [s], sampled every
    ``step`` [s], against ``limits`` (default: the plan's own effective limits)."""
    limits = effective_limits(robot, plan_result.settings) if limits is None else limits
    raw = RawMotion(plan_result.profile)
    t = np.arange(int(np.ceil((raw.duration + shaper_support(period)) / step)) + 1) * step
    return motion_ratios(robot, plan_result.trajectory.path, np.stack(path_motion(raw, t, period), axis=1), limits, t)


def shaped_plan(robot: Robot, plan_result, period: float,
                iterations: int = defaults.EGM_SHAPED_REPLANS) -> tuple[object, dict[str, float]]:
    """(a plan whose motion shaped for ``period`` [s] is within ``plan_result``'s limits, its shaped ratios
    against them). Where a limit's ratio exceeds 1 + TIGHTEN_TRIGGER x limit_tolerance, that limit's scale is
    multiplied by (1 - TIGHTEN_TARGET x tol) / ratio and the path planned again, at most ``iterations`` times
    (a log warning when the ratios are still above 1 + tol then). A jerk-limited plan (no shaper, period 0) or
    one already within its limits comes back as it is."""
    settings = plan_result.settings
    limits = effective_limits(robot, settings)
    tol = settings.limit_tolerance
    result = plan_result
    ratios = shaped_ratios(robot, result, period, limits)
    if period <= 0.0 or plan_result.profile.smooth:
        return result, ratios
    for _ in range(iterations):
        if max(ratios.values(), default=0.0) <= 1.0 + tol:
            break
        choices = result.settings.limits
        for name, r in ratios.items():
            if r > 1.0 + defaults.TIGHTEN_TRIGGER * tol:
                choices = choices.replace(name, scale=choices[name].scale * (1.0 - TIGHTEN_TARGET * tol) / r)
        result = plan(result.trajectory.path, robot, replace(result.settings, limits=choices, baselines=False))
        ratios = shaped_ratios(robot, result, period, limits)
    worst = max(ratios.values(), default=0.0)
    if worst > 1.0 + tol:
        log.warning("the shaped motion still exceeds the plan's limits by %.3g %% after %d plans with lower limits "
                    "(%s)", 100.0 * (worst - 1.0), iterations, _listed(ratios))
    if result is not plan_result:
        log.info("shaping: planned again with %s so that the shaped motion keeps the plan's limits (%s): "
                 "%.6g s instead of %.6g s (+%.3g %%)",
                 ", ".join(f"{n} x {result.settings.limits[n].scale / settings.limits[n].scale:.4g}"
                           for n in ratios if result.settings.limits[n].scale != settings.limits[n].scale),
                 _listed(ratios), result.duration, plan_result.duration,
                 100.0 * (result.duration / plan_result.duration - 1.0))
    return result, ratios


def _listed(ratios: dict[str, float]) -> str:
    return ", ".join(f"{name} {r:.4f}" for name, r in ratios.items())
