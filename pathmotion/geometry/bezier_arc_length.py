"""Arc length of a quintic Bezier curve and its inverse, compiled (numba): the work of
:class:`~pathmotion.geometry.segments.BezierSegment` that every plan of a blended path repeats.

With X(u) = sum_k coef[k] u^k (coef (6, 3) [m]) and the speed g(u) = |X'(u)|,

    s(u) = S[k] + int_{k/P}^{u} g(v) dv,        k = min(floor(u P), P - 1),

with S the arc length at the P panel edges, each panel integrated by a Gauss-Legendre rule (the nodes and
weights on [-1, 1] are given); u(s) by Newton's method on s(u) - s from a table's linear interpolation, each
point until its own |s(u) - s| < tol. The blend search plans some 900 blended paths per corner; in numpy these
loops were a quarter of its CPU, most of it per-call overhead on a few thousand points. The sums run in a fixed
order, so the numbers do not depend on the CPU's BLAS kernel.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _speed(coef, u):
    """|X'(u)| [m] at one u (Horner on the derivative's coefficients k coef[k])."""
    d0, d1, d2 = 5.0 * coef[5, 0], 5.0 * coef[5, 1], 5.0 * coef[5, 2]
    for k in range(4, 0, -1):
        d0 = d0 * u + k * coef[k, 0]
        d1 = d1 * u + k * coef[k, 1]
        d2 = d2 * u + k * coef[k, 2]
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(cache=True)
def _integral(coef, lo, hi, nodes, weights):
    """int_lo^hi |X'(v)| dv [m] by the Gauss-Legendre rule (nodes, weights on [-1, 1])."""
    half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
    acc = 0.0
    for j in range(nodes.shape[0]):
        acc += weights[j] * _speed(coef, mid + half * nodes[j])
    return half * acc


@numba.njit(cache=True)
def panel_edges(coef, panels, nodes, weights):
    """Arc length [m] (panels + 1,) at u = 0, 1/P, ..., 1."""
    out = np.zeros(panels + 1)
    for k in range(panels):
        out[k + 1] = out[k] + _integral(coef, k / panels, (k + 1) / panels, nodes, weights)
    return out


@numba.njit(cache=True)
def _arc_length(coef, edges, u, nodes, weights):
    panels = edges.shape[0] - 1
    u = min(max(u, 0.0), 1.0)
    k = min(int(u * panels), panels - 1)
    return edges[k] + _integral(coef, k / panels, u, nodes, weights)


@numba.njit(cache=True)
def arc_lengths(coef, edges, u, nodes, weights):
    """s(u) [m] (N,) at u (N,) (clipped to [0, 1])."""
    out = np.empty(u.shape[0])
    for i in range(u.shape[0]):
        out[i] = _arc_length(coef, edges, u[i], nodes, weights)
    return out


@numba.njit(cache=True)
def parameters(coef, edges, table_u, table_s, s, tol, nodes, weights):
    """u(s) (N,) at arc lengths s (N,) [m] in [0, length]: Newton from the table (table_u, table_s), at most
    50 steps, each point until |s(u) - s| < tol [m]."""
    guess = np.interp(s, table_s, table_u)
    out = np.empty(s.shape[0])
    for i in range(s.shape[0]):
        u = guess[i]
        for _ in range(50):
            err = _arc_length(coef, edges, u, nodes, weights) - s[i]
            u = min(max(u - err / _speed(coef, u), 0.0), 1.0)
            if abs(err) < tol:
                break
        out[i] = u
    return out
