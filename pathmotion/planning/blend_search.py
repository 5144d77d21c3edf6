"""The tolerance-optimal blend: the asymmetric G2 blend shape that minimises the time-optimal
duration of the whole path within a certified deviation bound (issue 17).

Each corner's blend is a quintic G2 Bezier (geometry/blends.py) described by three numbers: the
balance entry / (entry + exit) (where the apex sits), and the end-speed shapes of its entry and
exit sides; its size is then the largest whose certified deviation is <= the tolerance
(:func:`~pathmotion.geometry.blends.g2_shape_for_tolerance`), so ``blend_max_deviation_m`` stays
certified whatever the search picks. The search is cyclic coordinate descent with a golden-section
step per coordinate on the duration of fast plans (coarse grid, no verification), a few dozen plans
per corner. It starts from the symmetric G2 blend (balance 1/2, default shape) and keeps the best
shape seen, so the result is never slower than the symmetric blend on the search's own grid; the
final choice is re-planned on the full grid against the symmetric one and the faster is kept.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .. import defaults
from ..constraint import lift
from ..errors import PathmotionError
from ..geometry import TaskPath
from ..geometry.blends import with_blends
from ..geometry.blends import G2Shape, g2_shape_for_tolerance, with_shaped_g2_blends
from .planner import PlanSettings, plan

log = logging.getLogger(__name__)

#: Search box of the coordinates (balance, shape_entry, shape_exit).
BALANCE_RANGE = (0.2, 0.8)
SHAPE_RANGE = (0.25, 1.0)
#: Golden-section steps per coordinate and cycles over the coordinates.
GOLDEN_STEPS = 6
SEARCH_CYCLES = 2
#: Grid points of the search's fast plans.
SEARCH_GRID_POINTS = 300

_GOLD = (np.sqrt(5.0) - 1.0) / 2.0


@dataclass(frozen=True)
class OptimalBlend:
    """The chosen blends: ``shapes`` {connection index: G2Shape}, the blended ``path``, its full-grid
    ``duration`` [s], the symmetric G2 blend's ``symmetric_duration`` [s], and ``plans`` run."""

    shapes: dict
    path: TaskPath
    duration: float
    symmetric_duration: float
    plans: int


def _params(shape: G2Shape) -> np.ndarray:
    return np.array([shape.entry / (shape.entry + shape.exit), shape.shape_entry, shape.shape_exit])


class _Objective:
    """Duration of the path with the blend parameters x at one corner (others fixed), cached."""

    def __init__(self, robot, original: TaskPath, shapes: dict, corner: int, tolerance: float,
                 settings: PlanSettings, q_start):
        self.robot, self.original, self.shapes, self.corner = robot, original, dict(shapes), corner
        self.tolerance, self.settings, self.q_start = tolerance, settings, q_start
        chosen = set(shapes)
        self.shared = (corner - 1 in chosen, corner + 1 in chosen)
        self.cache: dict[tuple, tuple[float, G2Shape]] = {}
        self.plans = 0

    def shape(self, x) -> G2Shape:
        return g2_shape_for_tolerance(self.original, self.corner, self.tolerance, float(x[0]), float(x[1]),
                                      float(x[2]), shared=self.shared)

    def __call__(self, x) -> float:
        key = tuple(np.round(np.asarray(x, float), 12))
        if key not in self.cache:
            shape = self.shape(x)
            self.cache[key] = (duration_with(self.robot, self.original, {**self.shapes, self.corner: shape},
                                             self.settings, self.q_start), shape)
            self.plans += 1
        return self.cache[key][0]

    def best(self) -> tuple[float, G2Shape]:
        return min(self.cache.values(), key=lambda v: v[0])


def duration_with(robot, original: TaskPath, shapes: dict, settings: PlanSettings, q_start=None) -> float:
    """Time-optimal duration [s] of ``original`` with the blends ``shapes``; inf if it cannot be
    lifted or planned (a shape the search must avoid)."""
    try:
        path = lift(robot, with_shaped_g2_blends(original, shapes), q_start, original=original)
        return float(plan(path, robot, settings).profile.duration)
    except PathmotionError as exc:
        log.debug("blend search: shape rejected (%s)", exc)
        return float("inf")


def _golden(f, x: np.ndarray, i: int, lo: float, hi: float, steps: int) -> None:
    """Golden-section search of f along coordinate i of x on [lo, hi] (f caches every point)."""
    def at(v):
        y = x.copy()
        y[i] = v
        return f(y)

    a, b = lo, hi
    c, d = b - _GOLD * (b - a), a + _GOLD * (b - a)
    fc, fd = at(c), at(d)
    for _ in range(steps):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _GOLD * (b - a)
            fc = at(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLD * (b - a)
            fd = at(d)


def _search_corner(objective: _Objective, start: np.ndarray, cycles: int, steps: int) -> G2Shape:
    objective(start)
    boxes = (BALANCE_RANGE, SHAPE_RANGE, SHAPE_RANGE)
    for _ in range(cycles):
        for i, (lo, hi) in enumerate(boxes):
            x = _params(objective.best()[1])
            _golden(objective, x, i, lo, hi, steps)
    return objective.best()[1]


def optimal_blends(robot, original: TaskPath, tolerance: float | dict, corners: Sequence[int] | None = None,
                   settings: PlanSettings | None = None, q_start=None, *, cycles: int = SEARCH_CYCLES,
                   steps: int = GOLDEN_STEPS, search_grid_points: int = SEARCH_GRID_POINTS) -> OptimalBlend:
    """The asymmetric G2 blends within ``tolerance`` [m] (or {corner: tolerance}) at ``corners``
    (connection indices, default every sharp corner) of ``original`` that minimise the time-optimal duration under ``settings``
    (see the module docstring). PathError as :func:`~pathmotion.geometry.with_g2_blends` when the
    tolerance does not fit."""
    settings = settings or PlanSettings()
    chosen = [c.index for c in original.connections if c.kind == "corner"] if corners is None else sorted(corners)
    tol = dict(tolerance) if isinstance(tolerance, dict) else {k: float(tolerance) for k in chosen}
    # the symmetric blends, and their errors (a tolerance too large: the largest that fits)
    symmetric = with_blends(original, {k: ("g2", tol[k]) for k in chosen})
    fast = replace_settings(settings, grid_points=search_grid_points, verify=False, baselines=False)
    start = np.array([0.5, defaults.G2_BLEND_SHAPE, defaults.G2_BLEND_SHAPE])
    shapes = {}
    for k in chosen:
        shared = (k - 1 in chosen, k + 1 in chosen)
        shapes[k] = g2_shape_for_tolerance(original, k, tol[k], *start, shared=shared)
    initial, plans = dict(shapes), 0
    for k in chosen:
        obj = _Objective(robot, original, shapes, k, tol[k], fast, q_start)
        shapes[k] = _search_corner(obj, start, cycles, steps)
        plans += obj.plans
        log.info("blend search: corner %d: %d plans, shape %s", k, obj.plans, shapes[k])
    full = replace_settings(settings, verify=False, baselines=False)
    sym_T = float(plan(lift(robot, symmetric, q_start, original=original), robot, full).profile.duration)
    opt_path = with_shaped_g2_blends(original, shapes)
    opt_T = duration_with(robot, original, shapes, full, q_start)
    if not opt_T < sym_T:  # keep the symmetric blend when the search found nothing faster on the full grid
        return OptimalBlend(initial, symmetric, sym_T, sym_T, plans + 2)
    return OptimalBlend(shapes, opt_path, opt_T, sym_T, plans + 2)


def replace_settings(settings: PlanSettings, **changes) -> PlanSettings:
    """A copy of ``settings`` with ``changes`` (PlanSettings validates in __init__)."""
    kw = {"grid_points": settings.grid_points, "tolerance": settings.tolerance, "limits": settings.limits,
          "start": settings.start,
          "end": settings.end, "periodic": settings.periodic, "connections": settings.connections,
          "limit_tolerance": settings.limit_tolerance, "verify": settings.verify,
          "verify_sample_time": settings.verify_sample_time,
          "max_tighten_iterations": settings.max_tighten_iterations, "baselines": settings.baselines,
          "fitted_margin": settings.fitted_margin}
    kw.update(changes)
    return PlanSettings(**kw)


__all__ = ["OptimalBlend", "duration_with", "optimal_blends"]
