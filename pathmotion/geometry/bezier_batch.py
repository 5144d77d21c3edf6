"""Many quintic Bezier segments' points, unit tangents and curvature vectors in one compiled call: a blended
program's path evaluations (each lift of the planner's grid, the deviation check) would otherwise call
:meth:`~pathmotion.geometry.segments.BezierSegment.evaluate` once per blend, some 2,000 calls per evaluation of a
1,000-move program, most of their time numpy's per-call overhead.

The operations are BezierSegment.evaluate's, element by element and in its order: u(s) by
:func:`~pathmotion.geometry.bezier_arc_length.parameters` on each run of points of one segment, X, X', X'' by
:func:`~pathmotion.geometry.bezier_polyval.polyval`, g = sqrt((x0 x0 + x1 x1) + x2 x2) as np.linalg.norm, T = X'/g,
p'' = (X'' - (X''.T) T) / (g g): the same floats.
"""

from __future__ import annotations

import numba
import numpy as np

from .bezier_arc_length import parameters
from .bezier_polyval import polyval


@numba.njit(cache=True)
def _fill(x, dx, ddx, p, t, k, at):
    """Rows ``at`` of p, t, k (N, 3) from X, X', X'' (n, 3) at n points."""
    for i in range(x.shape[0]):
        r = at + i
        g = np.sqrt((dx[i, 0] * dx[i, 0] + dx[i, 1] * dx[i, 1]) + dx[i, 2] * dx[i, 2])
        t0, t1, t2 = dx[i, 0] / g, dx[i, 1] / g, dx[i, 2] / g
        along = (ddx[i, 0] * t0 + ddx[i, 1] * t1) + ddx[i, 2] * t2
        g2 = g * g
        p[r, 0], p[r, 1], p[r, 2] = x[i, 0], x[i, 1], x[i, 2]
        t[r, 0], t[r, 1], t[r, 2] = t0, t1, t2
        k[r, 0] = (ddx[i, 0] - along * t0) / g2
        k[r, 1] = (ddx[i, 1] - along * t1) / g2
        k[r, 2] = (ddx[i, 2] - along * t2) / g2


@numba.njit(cache=True)
def evaluate_many(coefs, edges, table_u, tables_s, lengths, tols, which, s, nodes, weights, f0, f1, f2):
    """(p, p', p'') (N, 3) each at arc lengths s (N,) [m] of the segments ``which`` (N,) (indices into the stacks:
    coefs (B, 6, 3), panel edges (B, P + 1), arc-length tables (B, M) at the shared table_u (M,), lengths (B,),
    Newton tolerances (B,) [m]); s is clipped to [0, length]; runs of equal ``which`` are evaluated together."""
    n = s.shape[0]
    p, t, k = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    a = 0
    while a < n:
        j = which[a]
        b = a + 1
        while b < n and which[b] == j:
            b += 1
        sj = np.empty(b - a)
        for i in range(b - a):
            sj[i] = min(max(s[a + i], 0.0), lengths[j])
        u = parameters(coefs[j], edges[j], table_u, tables_s[j], sj, tols[j], nodes, weights)
        _fill(polyval(coefs[j], u, f0, 0), polyval(coefs[j], u, f1, 1), polyval(coefs[j], u, f2, 2), p, t, k, a)
        a = b
    return p, t, k
