"""Distance of one path from another: the largest distance from a point of ``path`` to the nearest
point of ``reference`` (a one-sided Hausdorff distance; not a parameter-matched difference).

The maximum is certified by branch and bound. d(x) = dist(x, reference) is 1-Lipschitz in x, so
along a curve c(u) with |c'(u)| <= K it is K-Lipschitz in u, and on an interval [u0, u1] with end
values d0, d1:

    max d <= (d0 + d1 + K (u1 - u0)) / 2

Intervals whose bound exceeds the best value found so far are halved until the bound and the best
sample agree to ``defaults.DEVIATION_RELATIVE_ACCURACY``. The result is a bracket
lower <= true max <= upper (up to floating-point rounding).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import chain
from typing import Callable, Sequence

import numpy as np

from .. import defaults
from ..errors import PathError
from .chain import TaskPath
from .segments import Segment, StackedSegments

#: certified_max: intervals whose bound exceeds the best value by less than this times
#: max(1, Lipschitz constant * interval) differ by rounding only and are not split further [-].
BOUND_ROUNDING = 1e-15
#: max_deviation: a theta_range may end this far beyond the path's domain (rounding) [m].
DOMAIN_ROUNDING = 1e-12


@dataclass(frozen=True)
class Deviation:
    """Certified maximum distance [m]: ``lower`` <= max <= ``upper``; ``theta`` [m] (or curve
    parameter) where ``lower`` is attained."""

    lower: float
    upper: float
    theta: float

    @property
    def distance(self) -> float:
        """Best estimate of the maximum distance [m] (the attained value, ``lower``)."""
        return self.lower


#: SegmentIndex: fewer segments than this are all measured against every point [-].
INDEX_MIN_SEGMENTS = 16
#: SegmentIndex: a segment's ball radius is half its length times (1 + this) plus BALL_ROUNDING [-], [m]
#: (arc length parameters of blends are numerical: |p'| = 1 up to rounding).
BALL_SLACK = 1e-6
BALL_ROUNDING = 1e-12


def distance_to_segments(points: np.ndarray, segments: Sequence[Segment]) -> np.ndarray:
    """Distance [m] (N,) from each point (N, 3) to the nearest point of any of ``segments``."""
    return SegmentIndex(segments).distance(points)


class SegmentIndex:
    """The segments of a path, for the distance from points to their nearest one in time linear in the points,
    not points x segments. A segment lies in the ball of radius length / 2 about its middle point (arc length
    parameter). The balls are grouped by radius (powers of two), each group in a k-d tree of its centres: a point is
    first measured against the segment whose ball's far side is nearest, then against the segments whose ball is
    nearer than that distance, so one long segment does not widen every query. The distances are those of measuring
    every segment (a blend's to rounding: its closest point is found iteratively on the batch of points given)."""

    def __init__(self, segments: Sequence[Segment]):
        self.segments = tuple(segments)
        if len(self.segments) >= INDEX_MIN_SEGMENTS:
            from scipy.spatial import cKDTree

            half = np.array([0.5 * seg.length for seg in self.segments])
            self.centres = np.array([seg.evaluate(np.array([h]))[0][0] for seg, h in zip(self.segments, half)])
            self.radii = half * (1.0 + BALL_SLACK) + BALL_ROUNDING
            self.stacked = StackedSegments(self.segments)
            size = np.floor(np.log2(self.radii)).astype(int)
            self.groups = [(idx, cKDTree(self.centres[idx]), float(self.radii[idx].max()))
                           for idx in (np.flatnonzero(size == k) for k in np.unique(size))]

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance [m] (N,) from each point (N, 3) to the nearest point of any segment."""
        pts = np.atleast_2d(np.asarray(points, float))
        if len(self.segments) < INDEX_MIN_SEGMENTS:
            d = self.segments[0].closest(pts)[1]
            for seg in self.segments[1:]:
                d = np.minimum(d, seg.closest(pts)[1])
            return d
        far, first = np.full(len(pts), np.inf), np.zeros(len(pts), int)
        for idx, tree, _ in self.groups:  # the ball whose far side is nearest: an upper bound of the distance
            dist, k = tree.query(pts)
            bound = dist + self.radii[idx[k]]
            better = bound < far
            far[better], first[better] = bound[better], idx[k[better]]
        d = np.full(len(pts), np.inf)
        self._measure(pts, d, np.arange(len(pts)), first)
        for idx, tree, largest in self.groups:
            near = tree.query_ball_point(pts, d + largest)
            counts = np.fromiter(map(len, near), int, len(near))
            cols = idx[np.fromiter(chain.from_iterable(near), int, int(counts.sum()))]
            rows = np.repeat(np.arange(len(pts)), counts)
            gap = np.sqrt(np.add.reduce((self.centres[cols] - pts[rows]) ** 2, axis=1)) - self.radii[cols]
            keep = gap < d[rows]
            self._measure(pts, d, rows[keep], cols[keep])
        return d

    def _measure(self, pts: np.ndarray, d: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
        """d[rows] = min(d[rows], distance of pts[rows] to segments[cols]), one call per segment."""
        lines = self.stacked.line[cols]  # the lines at once, the other segments one call each
        if lines.any():
            np.minimum.at(d, rows[lines], self.stacked.line_distance(pts[rows[lines]], cols[lines]))
            rows, cols = rows[~lines], cols[~lines]
        order = np.argsort(cols, kind="stable")
        rows, cols = rows[order], cols[order]
        starts = np.flatnonzero(np.r_[True, cols[1:] != cols[:-1]]) if len(cols) else np.array([], int)
        for a, b in zip(starts, np.r_[starts[1:], len(cols)]):
            idx = rows[a:b]
            np.minimum.at(d, idx, self.segments[cols[a]].closest(pts[idx])[1])


def certified_max(fn: Callable[[np.ndarray], np.ndarray], lo: float, hi: float, lipschitz: float,
                  rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY, initial: int = 256,
                  stop_above: float = np.inf, max_rounds: int = 60, stop_below: float = -np.inf) -> Deviation:
    """Bracket the maximum of a ``lipschitz``-continuous fn (vectorized, >= 0) on [lo, hi].

    Stops early once the attained value exceeds ``stop_above``, or once the bound is at most
    ``stop_below`` (then the bracket is wider than ``rel_tol``: the caller only needs to know on which
    side of a threshold the maximum lies; the bound only falls as intervals split, so the answer is
    the one the full refinement gives)."""
    u = np.linspace(lo, hi, initial + 1)
    d = fn(u)
    a, b, da, db = u[:-1], u[1:], d[:-1], d[1:]
    best = int(np.argmax(d))
    lower, where = float(d[best]), float(u[best])
    atol = BOUND_ROUNDING * max(1.0, lipschitz * (hi - lo))
    dropped = 0.0  # largest bound of the intervals already discarded
    for _ in range(max_rounds):
        ub = 0.5 * (da + db + lipschitz * (b - a))
        upper = max(float(np.max(ub, initial=0.0)), dropped, lower)
        if lower > stop_above or upper <= stop_below or upper - lower <= rel_tol * upper + atol:
            return Deviation(lower, upper, where)
        keep = ub > lower * (1.0 + rel_tol) + atol
        dropped = max(dropped, float(np.max(ub[~keep], initial=0.0)))
        a, b, da, db = a[keep], b[keep], da[keep], db[keep]
        if len(a) > defaults.DEVIATION_MAX_INTERVALS:  # a flat maximum: the bracket stays valid, only wider
            break
        m = 0.5 * (a + b)
        dm = fn(m)
        k = int(np.argmax(dm)) if len(dm) else 0
        if len(dm) and dm[k] > lower:
            lower, where = float(dm[k]), float(m[k])
        a, b, da, db = (np.concatenate([a, m]), np.concatenate([m, b]),
                        np.concatenate([da, dm]), np.concatenate([dm, db]))
    ub = 0.5 * (da + db + lipschitz * (b - a))
    return Deviation(lower, max(float(np.max(ub, initial=0.0)), dropped, lower), where)

def max_deviation(path: TaskPath, reference: TaskPath | Sequence[Segment],
                  theta_range: tuple[float, float] | None = None,
                  rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY) -> Deviation:
    """Largest distance [m] from a point of ``path`` (over ``theta_range``, default its whole domain)
    to the nearest point of ``reference`` (a TaskPath or segments), certified to ``rel_tol``.

    theta is arc length (|dp/dtheta| = 1), so the distance is 1-Lipschitz in theta.
    """
    segs = reference.segments if isinstance(reference, TaskPath) else tuple(reference)
    if not segs:
        raise PathError("max_deviation: the reference path has no segments")
    lo, hi = path.domain if theta_range is None else (float(theta_range[0]), float(theta_range[1]))
    if not (path.domain[0] <= lo < hi <= path.domain[1] + DOMAIN_ROUNDING):
        raise PathError(f"max_deviation: theta_range ({lo:.6g}, {hi:.6g}) is not inside the path's domain "
                        f"(0, {path.length:.6g}) m")
    index = SegmentIndex(segs)
    return certified_max(lambda th: index.distance(path.evaluate(np.minimum(th, path.length))[0]),
                         lo, min(hi, path.length), 1.0, rel_tol)
