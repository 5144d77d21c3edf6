"""The certified largest distance of a quintic from lines, compiled: the blend search's inner loop.

The optimal blend search sizes each candidate blend by bisection on its certified deviation
(:func:`~pathmotion.geometry.blends.g2_shape_for_tolerance`): about 30 certified maxima per size, each a
few rounds of :func:`~pathmotion.geometry.deviation.certified_max` over a quintic against the corner's two
lines, some 50 000 maxima per corner. In numpy each round is some 20 calls on arrays of a few hundred
points, so the time would go into numpy's per-call overhead (two thirds of a corner's search). :func:`quintic_lines_max` runs the same branch and bound, operation for operation, in one
compiled call.

Same operations means same numbers: the curve by Horner's rule as ``BezierSegment._polyval``, each
line's closest point as ``Line.closest`` (its dot product written out, not BLAS, so that neither depends
on the CPU's BLAS kernel), the bound 0.5 (d0 + d1 + K (u1 - u0)), the same intervals kept, split and
appended in the same order. tests/test_geometry_quintic_deviation.py checks the result against certified_max bit
for bit.
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np

from .. import defaults
from .bezier_polyval import power_basis
from .deviation import BOUND_ROUNDING, Deviation
from .segments import _POWER_SCALE, _POWER_SIGNED


@numba.njit(cache=True)
def _distance(coef, starts, dirs, lengths, u, out):
    """out[i] = distance [m] of X(u[i]) (monomial coefficients coef (6, 3)) from the nearest of the lines
    (starts, dirs (k, 3), lengths (k,)); the operations of BezierSegment._polyval and Line.closest."""
    for i in range(u.shape[0]):
        ui = u[i]
        x0, x1, x2 = coef[5, 0], coef[5, 1], coef[5, 2]
        for k in range(4, -1, -1):
            x0 = x0 * ui + coef[k, 0]
            x1 = x1 * ui + coef[k, 1]
            x2 = x2 * ui + coef[k, 2]
        best = np.inf
        for j in range(starts.shape[0]):
            s = (x0 - starts[j, 0]) * dirs[j, 0] + (x1 - starts[j, 1]) * dirs[j, 1]
            s = s + (x2 - starts[j, 2]) * dirs[j, 2]
            s = min(max(s, 0.0), lengths[j])
            r0 = starts[j, 0] + s * dirs[j, 0] - x0
            r1 = starts[j, 1] + s * dirs[j, 1] - x1
            r2 = starts[j, 2] + s * dirs[j, 2] - x2
            d = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if d < best or j == 0:
                best = d
        out[i] = best


@numba.njit(cache=True)
def _branch_and_bound(coef, starts, dirs, lengths, u, lipschitz, rel_tol, stop_above, stop_below, max_rounds,
                      max_intervals, atol):
    """certified_max's loop on the initial samples u (M + 1,): (lower, upper, where)."""
    d = np.empty(u.shape[0])
    _distance(coef, starts, dirs, lengths, u, d)
    n = u.shape[0] - 1
    a, b, da, db = u[:-1].copy(), u[1:].copy(), d[:-1].copy(), d[1:].copy()
    best = 0
    for i in range(1, d.shape[0]):
        if d[i] > d[best]:
            best = i
    lower, where = d[best], u[best]
    dropped = 0.0
    ub = np.empty(n)
    for _ in range(max_rounds):
        top = 0.0
        for i in range(n):
            ub[i] = 0.5 * (da[i] + db[i] + lipschitz * (b[i] - a[i]))
            top = max(top, ub[i])
        upper = max(top, dropped, lower)
        if lower > stop_above or upper <= stop_below or upper - lower <= rel_tol * upper + atol:
            return lower, upper, where
        cut = lower * (1.0 + rel_tol) + atol
        kept = 0
        for i in range(n):
            if ub[i] > cut:
                a[kept], b[kept], da[kept], db[kept] = a[i], b[i], da[i], db[i]
                kept += 1
            else:
                dropped = max(dropped, ub[i])
        if kept > max_intervals:  # a flat maximum: the bracket stays valid, only wider
            n = kept
            break
        m = np.empty(kept)
        for i in range(kept):
            m[i] = 0.5 * (a[i] + b[i])
        dm = np.empty(kept)
        _distance(coef, starts, dirs, lengths, m, dm)
        if kept:
            k = 0
            for i in range(1, kept):
                if dm[i] > dm[k]:
                    k = i
            if dm[k] > lower:
                lower, where = dm[k], m[k]
        # [a, m], [m, b]: the kept intervals' left halves, then their right halves
        a2, b2, da2, db2 = np.empty(2 * kept), np.empty(2 * kept), np.empty(2 * kept), np.empty(2 * kept)
        a2[:kept], a2[kept:] = a[:kept], m
        b2[:kept], b2[kept:] = m, b[:kept]
        da2[:kept], da2[kept:] = da[:kept], dm
        db2[:kept], db2[kept:] = dm, db[:kept]
        a, b, da, db, n = a2, b2, da2, db2, 2 * kept
        ub = np.empty(n)
    top = 0.0
    for i in range(n):
        top = max(top, 0.5 * (da[i] + db[i] + lipschitz * (b[i] - a[i])))
    return lower, max(top, dropped, lower), where


@numba.njit(cache=True)
def _power_basis(b, signed, scale):
    """BezierSegment's power basis of control points b (6, 3) with the bound 5 max |b_(i+1) - b_i| of |X'| as
    _shaped_deviation computes it: (coef (6, 3), bound [m])."""
    coef = power_basis(b, signed, scale)
    top = 0.0
    for i in range(5):  # np.linalg.norm(np.diff(b, axis=0), axis=1): sqrt((d0 d0 + d1 d1) + d2 d2)
        d0, d1, d2 = b[i + 1, 0] - b[i, 0], b[i + 1, 1] - b[i, 1], b[i + 1, 2] - b[i, 2]
        top = max(top, np.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
    return coef, 5.0 * top


@numba.njit(cache=True)
def _bezier_branch_and_bound(b, signed, scale, starts, dirs, lengths, u, rel_tol, stop_above, stop_below, max_rounds,
                             max_intervals, rounding):
    coef, lipschitz = _power_basis(b, signed, scale)
    return _branch_and_bound(coef, starts, dirs, lengths, u, lipschitz, rel_tol, stop_above, stop_below, max_rounds,
                             max_intervals, rounding * max(1.0, lipschitz))


@numba.njit(cache=True)
def _pieces_upper(pieces, signed, scale, starts, dirs, lengths, u, rel_tol, stop_above, stop_below, max_rounds,
                  max_intervals, rounding):
    """The largest upper bound of the pieces (n, 6, 3), in order, stopping once one is above stop_above."""
    upper = 0.0
    for p in range(pieces.shape[0]):
        bound = _bezier_branch_and_bound(pieces[p], signed, scale, starts, dirs, lengths, u, rel_tol, stop_above,
                                         stop_below, max_rounds, max_intervals, rounding)[1]
        upper = max(upper, bound)
        if upper > stop_above:
            break
    return upper


@numba.njit(cache=True)
def _g2_lines_points(starts, dirs, lengths, cut, shape, b):
    """b (6, 3) = g2_control_points of the lines (starts, dirs, lengths (2,)) with ``cut`` and ``shape``: the
    operations of Line.evaluate (the cut points, clipped to the lines) and _hermite_points (curvature 0)."""
    la = 2.5 * shape * cut
    sa = min(max(lengths[0] - cut, 0.0), lengths[0])
    sb = min(max(cut, 0.0), lengths[1])
    for j in range(3):
        pa, ta = starts[0, j] + sa * dirs[0, j], dirs[0, j]
        pb, tb = starts[1, j] + sb * dirs[1, j], dirs[1, j]
        b[0, j] = pa
        b[1, j] = pa + la / 5 * ta
        b[2, j] = pa + 2 * la / 5 * ta
        b[3, j] = pb - 2 * la / 5 * tb
        b[4, j] = pb - la / 5 * tb
        b[5, j] = pb


@numba.njit(cache=True)
def _g2_lines_fits(starts, dirs, lengths, cut, shape, tol, b, signed, scale, u, rel_tol, max_rounds, max_intervals,
                   rounding):
    """Whether the G2 blend with ``cut`` deviates at most ``tol`` [m] from the two lines (its certified bound)."""
    _g2_lines_points(starts, dirs, lengths, cut, shape, b)
    return _bezier_branch_and_bound(b, signed, scale, starts, dirs, lengths, u, rel_tol, tol, tol, max_rounds,
                                    max_intervals, rounding)[1] <= tol


@numba.njit(cache=True)
def _g2_lines_cut(starts, dirs, lengths, shape, tol, start, bisections, signed, scale, u, rel_tol, max_rounds,
                  max_intervals, rounding):
    """blends._largest of cut -> (the G2 blend's certified bound <= tol), step for step (halve from ``start``,
    double, then ``bisections`` bisections)."""
    b = np.empty((6, 3))
    args = (b, signed, scale, u, rel_tol, max_rounds, max_intervals, rounding)
    lo, hi = 0.0, start
    while not _g2_lines_fits(starts, dirs, lengths, hi, shape, tol, *args):
        hi *= 0.5
        if hi < start * 2.0 ** -40:
            return 0.0
    lo, hi = hi, 2.0 * hi
    for _ in range(200):
        if not _g2_lines_fits(starts, dirs, lengths, hi, shape, tol, *args):
            break
        lo, hi = hi, 2.0 * hi
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        if _g2_lines_fits(starts, dirs, lengths, mid, shape, tol, *args):
            lo = mid
        else:
            hi = mid
    return lo


def g2_lines_cut(lines, shape: float, tolerance: float, start: float, bisections: int,
                 rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY, initial: int = 256,
                 max_rounds: int = 60) -> float:
    """The largest cut [m] (blends._largest from ``start`` [m] with ``bisections``) whose symmetric G2 blend of
    the two ``lines`` (A ending at the corner, B starting there) with ``shape`` has a certified deviation bound
    (:func:`bezier_lines_max`) of at most ``tolerance`` [m]; 0.0 if none down to start 2^-40. One compiled call
    for the whole search: the same cut as the search over g2_deviation, bit for bit (the per-check numpy and
    Python overhead was most of a 1,000-corner program's blending)."""
    return float(_g2_lines_cut(*_line_arrays(tuple(lines)), float(shape), float(tolerance), float(start),
                               int(bisections), _POWER_SIGNED, _POWER_SCALE, _samples(initial), float(rel_tol),
                               int(max_rounds), defaults.DEVIATION_MAX_INTERVALS, BOUND_ROUNDING))


@lru_cache(maxsize=16)  # a sizing checks ~40 sizes of the same corner's two lines (Lines hash by identity)
def _line_arrays(lines: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(starts (k, 3), unit directions (k, 3), lengths (k,)) of ``lines``, read-only."""
    out = (np.array([line.start for line in lines], float), np.array([line.direction for line in lines], float),
           np.array([line.length for line in lines], float))
    for a in out:
        a.flags.writeable = False
    return out


@lru_cache(maxsize=4)
def _samples(initial: int) -> np.ndarray:
    u = np.linspace(0.0, 1.0, initial + 1)
    u.flags.writeable = False
    return u


def quintic_lines_max(coef: np.ndarray, lines, lipschitz: float,
                      rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY, initial: int = 256,
                      stop_above: float = np.inf, max_rounds: int = 60, stop_below: float = -np.inf) -> Deviation:
    """certified_max of u -> distance of X(u) = sum_k coef[k] u^k (coef (6, 3) [m]) from the nearest of
    ``lines`` (:class:`~pathmotion.geometry.segments.Line`), u in [0, 1], with ``lipschitz`` a bound of |X'|
    [m]: the same bracket as ``certified_max(lambda u: distance_to_segments(BezierSegment._polyval(coef, u),
    lines), 0, 1, lipschitz, ...)``, bit for bit."""
    atol = BOUND_ROUNDING * max(1.0, lipschitz)
    lower, upper, where = _branch_and_bound(np.ascontiguousarray(coef, float), *_line_arrays(tuple(lines)),
                                            _samples(initial), float(lipschitz), float(rel_tol), float(stop_above),
                                            float(stop_below), int(max_rounds), defaults.DEVIATION_MAX_INTERVALS, atol)
    return Deviation(float(lower), float(upper), float(where))


def bezier_lines_max(b: np.ndarray, lines, rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY,
                     initial: int = 256, stop_above: float = np.inf, max_rounds: int = 60,
                     stop_below: float = -np.inf) -> Deviation:
    """:func:`quintic_lines_max` of the quintic Bezier curve with control points ``b`` (6, 3) [m], with
    the Lipschitz bound 5 max |b_(i+1) - b_i|: the same floats as ``quintic_lines_max(
    BezierSegment._power_basis(b), lines, that bound, ...)``, the power basis and the bound compiled too
    (the blend sizing's ~50 000 checks per corner spent most of their time in numpy's per-call overhead)."""
    lower, upper, where = _bezier_branch_and_bound(np.ascontiguousarray(b, float), _POWER_SIGNED, _POWER_SCALE,
                                                   *_line_arrays(tuple(lines)), _samples(initial), float(rel_tol),
                                                   float(stop_above), float(stop_below), int(max_rounds),
                                                   defaults.DEVIATION_MAX_INTERVALS, BOUND_ROUNDING)
    return Deviation(float(lower), float(upper), float(where))


def bezier_pieces_lines_max(pieces, lines, rel_tol: float = defaults.DEVIATION_RELATIVE_ACCURACY, initial: int = 256,
                            stop_above: float = np.inf, max_rounds: int = 60, stop_below: float = -np.inf) -> float:
    """The largest :func:`bezier_lines_max` upper bound [m] of the quintic Bezier ``pieces`` (each (6, 3)
    [m]), taken in order and stopping once it is above ``stop_above``: one compiled call for a blend's
    pieces (the same float as the loop over bezier_lines_max)."""
    return float(_pieces_upper(np.ascontiguousarray(pieces, float), _POWER_SIGNED, _POWER_SCALE,
                               *_line_arrays(tuple(lines)), _samples(initial), float(rel_tol), float(stop_above),
                               float(stop_below), int(max_rounds), defaults.DEVIATION_MAX_INTERVALS, BOUND_ROUNDING))
