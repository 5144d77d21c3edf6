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
from typing import Callable, Sequence

import numpy as np

from .. import defaults
from ..errors import PathError
from .chain import TaskPath
from .segments import Segment

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


def distance_to_segments(points: np.ndarray, segments: Sequence[Segment]) -> np.ndarray:
    """Distance [m] (N,) from each point (N, 3) to the nearest point of any of ``segments``."""
    pts = np.atleast_2d(points)
    d = segments[0].closest(pts)[1]
    for seg in segments[1:]:
        d = np.minimum(d, seg.closest(pts)[1])
    return d


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
    return certified_max(lambda th: distance_to_segments(path.evaluate(np.minimum(th, path.length))[0], segs),
                         lo, min(hi, path.length), 1.0, rel_tol)
