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
def _free_side(out, join, side, run, profile, free, axes, two):
    """The offset piece of ``side`` (0: entry, 1: exit) ending at a free end (a departure or arrival), of ``run``
    [m]: _BlendPieces._side's products (_piece_offsets of the lateral ``profile[side, :3]`` (offset [m], slope,
    bend [1/m]) and of the rise ``profile[side, 3:]``, their coefficients next to the free end ``free[side]`` (4,)
    [m]) along ``axes[side]`` (line direction, outward, corner normal; (3, 3)), then :func:`_side`'s sums."""
    entry = side == 0
    prof, ax, f = profile[side], axes[side], free[side]
    w, v = np.zeros(6), np.zeros(6)
    for c, (offset, slope, bend) in enumerate(((prof[0], prof[1], prof[2]), (prof[3], prof[4], prof[5]))):
        near = offset + slope * run / 5.0
        third = 2.0 * near - offset + bend * run ** two / 20.0
        x = w if c == 0 else v
        if entry:  # reversed, then the coefficients next to A's start (index 0 stays 0)
            x[5], x[4], x[3] = offset, near, third
            x[1], x[2] = f[2 * c], f[2 * c + 1]
        else:  # B's end first: w[4], w[3]
            x[0], x[1], x[2] = offset, near, third
            x[4], x[3] = f[2 * c], f[2 * c + 1]
    back, n_back, terms = np.empty((3, 3)), 0, np.empty((3, 6, 3))
    if entry:
        for j in range(3):
            back[0, j] = run * ax[0, j]
        n_back = 1
    for j in range(3):
        back[n_back, j] = prof[0] * ax[1, j]
        back[n_back + 1, j] = prof[3] * ax[2, j]
    for i in range(6):
        fifth = (i / 5.0) * run
        for j in range(3):
            terms[0, i, j] = fifth * ax[0, j]
            terms[1, i, j] = w[i] * ax[1, j]
            terms[2, i, j] = v[i] * ax[2, j]
    _side(out, join, back, n_back + 2, terms)


@numba.njit(cache=True)
def build(out, size, balance, lines, frames, la_share, has, backs, n_backs, terms, two, frees, free, ends, profile,
          axes):
    """The pieces (in path order: entry piece if has[0], corner quintic, exit piece if has[1]) of the blend whose
    corner quintic has ``size`` into ``out`` (3, 6, 3); returns their count, -1 where a free end's piece has no room
    (g2_blend_pieces raises its error there). ``lines`` (2, 3, 3): per side the
    line the corner quintic ends on (start, unit direction, (length, 0, 0)); ``frames`` (2, 2, 3): its (tangent,
    curvature vector) at each end; ``la_share`` (2,): 2.5 shape per side; ``backs`` (2, 3, 3) and ``n_backs`` (2,),
    ``terms`` (2, 3, 6, 3): each fixed offset piece's products (_BlendPieces._side). ``frees`` (2,): the side ends
    at a free end (its run from the join to ``ends[side]`` (2, 3): (the line's far point, its unit direction), the
    piece from :func:`_free_side` with ``free``, ``profile`` and ``axes``)."""
    inner = (balance * size, (1 - balance) * size)
    sa = lines[0, 2, 0] - inner[0]
    sa = min(max(sa, 0.0), lines[0, 2, 0])
    sb = min(max(inner[1], 0.0), lines[1, 2, 0])
    pA = lines[0, 0] + sa * lines[0, 1]
    pB = lines[1, 0] + sb * lines[1, 1]
    runs = np.zeros(2)
    for side in range(2):
        if frees[side]:
            d = pA - ends[0, 0] if side == 0 else ends[1, 0] - pB
            e = ends[side, 1]
            runs[side] = np.dot(d, e)  # BLAS ddot, as numpy's @ (its own summation)
            if not (has[side] and runs[side] > 0.0):
                return -1
    k = 0
    if has[0]:
        k = 1
    _hermite(out[k], pA, frames[0, 0], frames[0, 1], pB, frames[1, 0], frames[1, 1], la_share[0] * inner[0],
             la_share[1] * inner[1], two)
    for side, join, at in ((0, pA, 0), (1, pB, k + 1)):
        if not has[side]:
            continue
        if frees[side]:
            _free_side(out[at], join, side, runs[side], profile, free, axes, two)
        else:
            _side(out[at], join, backs[side], n_backs[side], terms[side])
    return k + 1 + (1 if has[1] else 0)


@numba.njit(cache=True)
def _largest_size(failed, size_min, size_max, scan, bisections, tol, balance, lines, frames, la_share, has, backs,
                  n_backs, terms, two, frees, free, ends, profile, axes, signed, scale, starts, dirs, lengths, u,
                  rel_tol, max_rounds, max_intervals, rounding):
    """:func:`largest_size`'s scan and bisections; ``failed[0]`` set where a build had no room (-1 from
    :func:`build`)."""
    out = np.empty((3, 6, 3))

    def ok(size):
        n = build(out, size, balance, lines, frames, la_share, has, backs, n_backs, terms, two, frees, free, ends,
                  profile, axes)
        if n < 0:
            failed[0] = True
            return False
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


@numba.njit(cache=True)
def largest_size(size_min, size_max, scan, bisections, tol, balance, lines, frames, la_share, has, backs, n_backs,
                 terms, two, frees, free, ends, profile, axes, signed, scale, starts, dirs, lengths, u, rel_tol,
                 max_rounds, max_intervals, rounding):
    """g2_shape_for_tolerance's size: ``size_max`` if its blend is within ``tol``, else _largest_between's answer
    over (size_min, size_max) (``scan``: its geometric scan's shares, np.geomspace(1, 1e-6, 24); ``bisections``);
    the pieces (:func:`build`'s arguments ``lines`` to ``axes``) bounded as bezier_pieces_lines_max does with
    stop_above = stop_below = tol (the lines ``starts``, ``dirs``, ``lengths``, ``u`` its initial samples).
    nan where a free end's piece had no room at a size tried (g2_blend_pieces raises there)."""
    failed = np.zeros(1, np.bool_)
    size = _largest_size(failed, size_min, size_max, scan, bisections, tol, balance, lines, frames, la_share, has,
                         backs, n_backs, terms, two, frees, free, ends, profile, axes, signed, scale, starts, dirs,
                         lengths, u, rel_tol, max_rounds, max_intervals, rounding)
    return np.nan if failed[0] else size
