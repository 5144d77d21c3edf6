"""Compiled kernels of the re-timer (planning/retime.py) on the interval rows of planning/topp.py.

Interval i carries rows P[i, r] x_i + Q[i, r] x_{i+1} <= R[i, r] (u constant on the interval); point k
carries the canonical rows lo <= a u + b x + c <= hi (planning/limit_rows.py). Every kernel is O(K m).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def step_up(P, Q, R, i, xi, hi):
    """The largest x_{i+1} <= ``hi`` that interval i's rows allow from x_i = ``xi``."""
    for k in range(P.shape[1]):
        q = Q[i, k]
        if q > 0.0:
            v = (R[i, k] - P[i, k] * xi) / q
            if v < hi:
                hi = v
    return hi


@njit(cache=True, nogil=True)
def step_down(P, Q, R, i, xi):
    """(lowest, highest) x_{i+1} that interval i's rows allow from x_i = ``xi`` (lowest may be < 0: the
    rows would let x reach 0 inside the interval)."""
    lo, hi = -np.inf, np.inf
    for k in range(P.shape[1]):
        q, r = Q[i, k], R[i, k] - P[i, k] * xi
        if q < 0.0:
            v = r / q
            if v > lo:
                lo = v
        elif q > 0.0:
            v = r / q
            if v < hi:
                hi = v
        elif r < 0.0:
            return np.inf, -np.inf
    return lo, hi


@njit(cache=True, nogil=True)
def greedy_from(P, Q, R, klo, khi, j, xj, out):
    """Forward greedy pass (the time-optimal choice, Pham & Pham 2018) from x_j = ``xj`` through the
    controllable sets [klo, khi]: fills out[0] = xj, out[1..] = x_{j+1}..x_{K-1}."""
    n = klo.shape[0]
    out[0] = xj
    x = xj
    for i in range(j, n - 1):
        v = step_up(P, Q, R, i, x, khi[i + 1])
        if v < klo[i + 1]:
            v = klo[i + 1]
        x = v
        out[i + 1 - j] = x


@njit(cache=True, nogil=True)
def brake(P, Q, R, j, xj, target, x_max, out):
    """Lowest profile (maximum deceleration) from x_j = ``xj``: out[0] = xj, out[k - j] = x_k. Returns k > j,
    the first point where the lowest x is <= target[k] (out[k - j] = the largest x there <= target[k]), or
    -(i + 2) when x can reach 0 inside interval i, or -1 when the rows admit no x_{i+1} (cannot be saved)."""
    n = target.shape[0]
    x = xj
    out[0] = xj
    for i in range(j, n - 1):
        lo, hi = step_down(P, Q, R, i, x)
        if hi > x_max[i + 1]:
            hi = x_max[i + 1]
        if lo > hi:
            return -1
        if lo <= target[i + 1]:
            out[i + 1 - j] = min(target[i + 1], hi)
            return i + 1
        if lo <= 0.0:
            return -(i + 2)
        x = lo
        out[i + 1 - j] = x
    return -1


@njit(cache=True, nogil=True, inline="always")
def _narrow(low, high, q, bot, top, offset):
    """[low, high] narrowed to the y = offset + v with bot <= q v <= top: (low, high, False when no v
    satisfies it, q = 0 with 0 outside [bot, top])."""
    if q > 0.0:
        return max(low, offset + bot / q), min(high, offset + top / q), True
    if q < 0.0:
        return max(low, offset + top / q), min(high, offset + bot / q), True
    return low, high, not (top < 0.0 or bot > 0.0)


@njit(cache=True, nogil=True)
def least_u(a, b, c, lo, hi, x):
    """(least, largest) u with lo <= a u + b x + c <= hi on every row at one point, x given."""
    umin, umax = -np.inf, np.inf
    for r in range(a.shape[0]):
        umin, umax, ok = _narrow(umin, umax, a[r], lo[r] - c[r] - b[r] * x, hi[r] - c[r] - b[r] * x, 0.0)
        if not ok:
            return np.inf, -np.inf
    return umin, umax


@njit(cache=True, nogil=True)
def stop_inside(a0, b0, c0, lo0, hi0, a1, b1, c1, lo1, hi1, x0, width, iterations):
    """Shortest distance d in (0, width] over which x falls from ``x0`` to 0 at a constant u = -x0 / (2 d)
    allowed by the rows at the interval's start (x = x0) and at the stop point (x = 0; rows interpolated
    linearly between the interval's ends 0 and 1); inf when none."""
    ulo0, uhi0 = least_u(a0, b0, c0, lo0, hi0, x0)
    d = width
    for _ in range(iterations):
        f = d / width
        ulo1, uhi1 = least_u((1 - f) * a0 + f * a1, (1 - f) * b0 + f * b1, (1 - f) * c0 + f * c1,
                             (1 - f) * lo0 + f * lo1, (1 - f) * hi0 + f * hi1, 0.0)
        u = max(ulo0, ulo1)
        if not u < 0.0 or u > min(uhi0, uhi1):
            return np.inf
        d = x0 / (-2.0 * u)
        if d > width:
            return np.inf
    return d


@njit(cache=True, nogil=True)
def rows_at(g, a, b, c, lo, hi, xm, oa, ob, oc, olo, ohi, t, right, err, x, u):
    """Rows at ``t`` seen from the interval after it (``right``) or before it, linear inside each plan
    interval between the right-side rows (first index) and the left-side rows (second index) of its ends;
    written into oa..ohi (m,); returns x_max there. a..xm: (2, K, m) / (2, K) stacks [right, left].
    err (5, K - 1, m): bounds of the interpolation's error of a, b, c, lo, hi on each plan interval; the
    bounds lo, hi are narrowed by the error of the row's value at x and |u| = ``u``."""
    k = g.shape[0]
    if right:
        i = np.searchsorted(g, t, side="right") - 1
    else:
        i = np.searchsorted(g, t, side="left") - 1
    i = min(max(i, 0), k - 2)
    f = (t - g[i]) / (g[i + 1] - g[i])
    for r in range(a.shape[2]):
        oa[r] = (1.0 - f) * a[0, i, r] + f * a[1, i + 1, r]
        ob[r] = (1.0 - f) * b[0, i, r] + f * b[1, i + 1, r]
        oc[r] = (1.0 - f) * c[0, i, r] + f * c[1, i + 1, r]
        margin = err[0, i, r] * u + err[1, i, r] * x + err[2, i, r]
        olo[r] = (1.0 - f) * lo[0, i, r] + f * lo[1, i + 1, r] + margin + err[3, i, r]
        ohi[r] = (1.0 - f) * hi[0, i, r] + f * hi[1, i + 1, r] - margin - err[4, i, r]
    return (1.0 - f) * xm[0, i] + f * xm[1, i + 1]


@njit(cache=True, nogil=True)
def _next_x_range(a0, b0, c0, lo0, hi0, a1, b1, c1, lo1, hi1, x, h):
    """Range of x_1 at the end of an interval of width h from x at its start, u = (x_1 - x) / (2 h)
    constant, the start rows (a0..hi0) at x and the end rows (a1..hi1) at x_1."""
    low, high = -np.inf, np.inf
    k2 = 0.5 / h
    for r in range(a0.shape[0]):
        # the start rows bound x_1 - x through u; the end rows bound x_1 itself
        low, high, ok = _narrow(low, high, a0[r] * k2, lo0[r] - c0[r] - b0[r] * x, hi0[r] - c0[r] - b0[r] * x, x)
        if not ok:
            return np.inf, -np.inf
        low, high, ok = _narrow(low, high, a1[r] * k2 + b1[r], lo1[r] - c1[r] + a1[r] * k2 * x,
                                hi1[r] - c1[r] + a1[r] * k2 * x, 0.0)
        if not ok:
            return np.inf, -np.inf
    return low, high


@njit(cache=True, nogil=True)
def fine_brake(g, a, b, c, lo, hi, xm, err, theta, x0, end, n, xs, iterations):
    """Maximum deceleration from (theta, x0) on n uniform points up to ``end``, the rows interpolated at each
    (rows_at, narrowed by the interpolation's error ``err`` at the previous step's |u|; the first step is
    taken twice, the second time at its own |u|): xs[k] = x at point k. Returns (k, d): x reaches 0 at d
    after point k; (-1, 0) when it does not before ``end`` or the rows admit no x there."""
    m = a.shape[2]
    w = np.empty((10, m))
    h = (end - theta) / (n - 1)
    x = x0
    xs[0] = x0
    u = 0.0
    for k in range(n - 1):
        t0, t1 = theta + k * h, theta + (k + 1) * h
        for _ in range(2 if k == 0 else 1):
            rows_at(g, a, b, c, lo, hi, xm, w[0], w[1], w[2], w[3], w[4], t0, True, err, x, u)
            x_max = rows_at(g, a, b, c, lo, hi, xm, w[5], w[6], w[7], w[8], w[9], t1, False, err, x, u)
            low, high = _next_x_range(w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8], w[9], x, h)
            u = abs(low - x) / (2.0 * h) if np.isfinite(low) else u
        high = min(high, x_max)
        if low > high:
            return -1, 0.0
        if low <= 0.0:
            d = stop_inside(w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8], w[9], x, h, iterations)
            return k, min(d, h)
        x = low
        xs[k + 1] = x
    return -1, 0.0
