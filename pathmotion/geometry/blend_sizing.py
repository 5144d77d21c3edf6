"""The sizing of a G2 blend between two lines, compiled (numba): g2_shape_for_tolerance's search for the largest
corner quintic within the tolerance builds its pieces and bounds their deviation some 40 times per shape, and every
plan of the blend search sizes one shape. Here the build (geometry/blends.py, _BlendPieces and _hermite_points), the
certified bound (:func:`~pathmotion.geometry.quintic_deviation.bezier_pieces_lines_max`) and the scan and bisections
(blends._largest, blends._largest_between) run in one call: the same operations in the same order, so the same
floats and the same size. The squares la^2, lb^2 are libm's pow(x, e) with the exponent ``two`` a run-time argument
(2.0), as Python's ``la ** 2`` computes them (a constant exponent would be folded into la * la, which differs from
pow in the last bit for about 1 in 1000 values).
"""

from __future__ import annotations

import numba
import numpy as np

from .quintic_deviation import _pieces_upper


@numba.njit(cache=True)
def _hermite(out, pA, tA, kA, pB, tB, kB, la, lb, two):
    """_hermite_points' control points (6, 3) into ``out``."""
    a1, a2, a3 = la / 5, 2 * la / 5, la ** two / 20
    b1, b2, b3 = lb / 5, 2 * lb / 5, lb ** two / 20
    for j in range(3):
        out[0, j] = pA[j]
        out[1, j] = pA[j] + a1 * tA[j]
        out[2, j] = pA[j] + a2 * tA[j] + a3 * kA[j]
        out[3, j] = pB[j] - b2 * tB[j] + b3 * kB[j]
        out[4, j] = pB[j] - b1 * tB[j]
        out[5, j] = pB[j]


@numba.njit(cache=True)
def _side(out, join, back, n_back, terms):
    """An offset piece's control points: ``join`` less the ``n_back`` rows of ``back`` in order, plus each of the
    three ``terms`` (6, 3) in order (_BlendPieces.__call__)."""
    x = join.copy()
    for b in range(n_back):
        for j in range(3):
            x[j] = x[j] - back[b, j]
    for i in range(6):
        for j in range(3):
            v = x[j] + terms[0, i, j]
            v = v + terms[1, i, j]
            out[i, j] = v + terms[2, i, j]


@numba.njit(cache=True)
def build(out, size, balance, lines, frames, la_share, has, backs, n_backs, terms, two):
    """The pieces (in path order: entry piece if has[0], corner quintic, exit piece if has[1]) of the blend whose
    corner quintic has ``size`` into ``out`` (3, 6, 3); returns their count. ``lines`` (2, 3, 3): per side the
    line the corner quintic ends on (start, unit direction, (length, 0, 0)); ``frames`` (2, 2, 3): its (tangent,
    curvature vector) at each end; ``la_share`` (2,): 2.5 shape per side; ``backs`` (2, 3, 3) and ``n_backs`` (2,),
    ``terms`` (2, 3, 6, 3): each offset piece's products (_BlendPieces._side)."""
    inner = (balance * size, (1 - balance) * size)
    sa = lines[0, 2, 0] - inner[0]
    sa = min(max(sa, 0.0), lines[0, 2, 0])
    sb = min(max(inner[1], 0.0), lines[1, 2, 0])
    pA = lines[0, 0] + sa * lines[0, 1]
    pB = lines[1, 0] + sb * lines[1, 1]
    k = 0
    if has[0]:
        k = 1
    _hermite(out[k], pA, frames[0, 0], frames[0, 1], pB, frames[1, 0], frames[1, 1], la_share[0] * inner[0],
             la_share[1] * inner[1], two)
    if has[0]:
        _side(out[0], pA, backs[0], n_backs[0], terms[0])
    if has[1]:
        _side(out[k + 1], pB, backs[1], n_backs[1], terms[1])
    return k + 1 + (1 if has[1] else 0)


@numba.njit(cache=True)
def largest_size(size_min, size_max, scan, bisections, tol, balance, lines, frames, la_share, has, backs, n_backs,
                 terms, two, signed, scale, starts, dirs, lengths, u, rel_tol, max_rounds, max_intervals, rounding):
    """g2_shape_for_tolerance's size: ``size_max`` if its blend is within ``tol``, else _largest_between's answer
    over (size_min, size_max) (``scan``: its geometric scan's shares, np.geomspace(1, 1e-6, 24); ``bisections``);
    the pieces' bound as bezier_pieces_lines_max's with stop_above = stop_below = tol (the lines ``starts``,
    ``dirs``, ``lengths``, ``u`` its initial samples)."""
    out = np.empty((3, 6, 3))

    def ok(size):
        n = build(out, size, balance, lines, frames, la_share, has, backs, n_backs, terms, two)
        return _pieces_upper(out[:n], signed, scale, starts, dirs, lengths, u, rel_tol, tol, tol, max_rounds,
                             max_intervals, rounding) <= tol

    if ok(size_max):
        return size_max
    lo, hi = size_min, size_max
    if lo <= 0.0:  # _largest(ok, hi, bisections): halve until ok, double while ok
        start = hi
        while not ok(hi):
            hi *= 0.5
            if hi < start * 2.0 ** -40:
                return 0.0
        lo, hi = hi, 2.0 * hi
        for _ in range(200):
            if not ok(hi):
                break
            lo, hi = hi, 2.0 * hi
        good, bad = lo, hi
    else:  # _largest_between: the first ok point of the geometric scan down from hi
        xs = lo + (hi - lo) * scan
        found = False
        good, bad = lo, lo
        for k in range(1, xs.shape[0]):
            if ok(xs[k]):
                good, bad, found = xs[k], xs[k - 1], True
                break
        if not found:
            return lo
    for _ in range(bisections):  # between the ok point and the failing one
        mid = 0.5 * (good + bad)
        if ok(mid):
            good = mid
        else:
            bad = mid
    return good
