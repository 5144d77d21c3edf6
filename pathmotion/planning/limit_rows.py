"""Every active limit in one canonical per-point form, linear in u = theta_ddot and x = theta_dot^2.

At each path point k, rows r = 0..m-1:

    lo[k, r] <= a[k, r] u + b[k, r] x + c[k, r] <= hi[k, r]        and   0 <= x <= x_max[k]

Each limit object (planning/limits/) gives its own rows (order 2 and 3) or its bound on x (order 1):

joint acceleration  (a, b, c) = (Phi'_j, Phi''_j, 0),        lo/hi = -/+ qdd_max_j
joint torque        (a, b, c) = (alpha_j, beta_j, gamma_j),  lo/hi = -/+ tau_max_j
joint velocity      x_max <= qd_max_j^2 / Phi'_j^2           (a pure bound on x)
TCP speed           x_max <= v_max^2 / |J_v Phi'|^2          (a pure bound on x)

``scale`` {name: (K, m)} multiplies each limit point by point: the verify-and-tighten loop uses it to
tighten limits locally.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import EffectiveLimits, PathPoints


@dataclass(frozen=True, eq=False)
class LimitRows:
    """Canonical form at K points: a, b, c, lo, hi (K, m); x_max (K,) (inf where unbounded).

    ``row_kind`` (m,) (the limit's name) and ``row_column`` (m,) (its joint, or 0) name each row.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    x_max: np.ndarray
    row_kind: tuple[str, ...]
    row_column: tuple[int, ...]

    def at(self, k: int) -> tuple:
        """The rows (a, b, c, lo, hi) at point ``k``, each (m,)."""
        return self.a[k], self.b[k], self.c[k], self.lo[k], self.hi[k]

    def between(self, other: "LimitRows", i: int, f: float) -> tuple:
        """The rows linearly interpolated at the fraction ``f`` from point i (self) to point i + 1 (other)."""
        return tuple((1.0 - f) * p + f * q for p, q in zip(self.at(i), other.at(i + 1)))

    def slice(self, sl: slice) -> "LimitRows":
        """The rows at the points ``sl``."""
        return LimitRows(self.a[sl], self.b[sl], self.c[sl], self.lo[sl], self.hi[sl], self.x_max[sl],
                         self.row_kind, self.row_column)


def limit_rows(points: PathPoints, limits: EffectiveLimits, scale: dict[str, np.ndarray],
               x_cap: float = np.inf, x_ref: np.ndarray | None = None) -> LimitRows:
    """Assemble the canonical form at ``points`` from every active limit, each scaled by
    ``scale[name]`` (K, m). ``x_cap`` bounds x where no limit does; ``x_ref`` (K,) is the previous
    solve's x, for limits that linearize around it (None on the first solve)."""
    k = len(points.theta)
    x_max = np.full(k, float(x_cap))
    blocks, kinds, columns = [], [], []
    for lim in limits:
        bound = lim.bound(points, scale[lim.name])
        if bound is not None:
            x_max = np.minimum(x_max, bound)
        rows = lim.rows(points, scale[lim.name], x_ref)
        if rows is not None:
            blocks.append(rows)
            m = rows.a.shape[1]
            kinds += [lim.name] * m
            columns += list(range(m))
    if blocks:
        a, b, c, lo, hi = (np.concatenate([blk[i] for blk in blocks], axis=1) for i in range(5))
    else:
        a = b = c = lo = hi = np.zeros((k, 0))
    return LimitRows(a, b, c, lo, hi, x_max, tuple(kinds), tuple(columns))
