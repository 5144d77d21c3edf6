"""Compiled kernels of the re-timer (planning/retime.py) on the interval rows of planning/topp.py.

Interval i carries rows P[i, r] x_i + Q[i, r] x_{i+1} <= R[i, r] (u constant on the interval); point k
carries the canonical rows lo <= a u + b x + c <= hi (planning/limit_rows.py). Every kernel is O(K m).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def step_up(P, Q, R, i, xi, hi):
    """The largest x_{i+1} <= ``hi`` that interval i's rows allow from x_i = ``xi``."""
    for k in range(P.shape[1]):
        q = Q[i, k]
        if q > 0.0:
            v = (R[i, k] - P[i, k] * xi) / q
            if v < hi:
                hi = v
    return hi


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def least_u(a, b, c, lo, hi, x):
    """(least, largest) u with lo <= a u + b x + c <= hi on every row at one point, x given."""
    umin, umax = -np.inf, np.inf
    for r in range(a.shape[0]):
        ar = a[r]
        top, bot = hi[r] - c[r] - b[r] * x, lo[r] - c[r] - b[r] * x
        if ar > 0.0:
            umin, umax = max(umin, bot / ar), min(umax, top / ar)
        elif ar < 0.0:
            umin, umax = max(umin, top / ar), min(umax, bot / ar)
        elif top < 0.0 or bot > 0.0:
            return np.inf, -np.inf
    return umin, umax


@njit(cache=True)
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
