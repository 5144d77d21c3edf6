"""Compiled jerk-limited stop: the shortest stop along the path from a moving state (theta, theta_dot,
theta_ddot) within every limit of the plan (velocity, acceleration, torque, jerk, torque rate).

The stop brakes as a triple integrator stops in least distance, with the path's limits at every point: the
path jerk turns theta_ddot = u down as fast as the order-3 rows allow towards the least u the order-2 rows
allow, holds it there (tracking it as it moves with theta and x = theta_dot^2), and ends with a constant-jerk
tail J = u^2 / (2 theta_dot) that brings u to 0 as theta_dot reaches 0 (distance 2 x / (3 |u|)). Of the tails
from every braking step that meet every limit along them, the one that stops first is taken. The braking phase is
integrated in time with a piecewise constant jerk (about STEPS_PER_STOP steps).

The rows are those the compiled remaining pass stores at Retimer construction (planning/retime_jerk.py:
order-2 rows, x_max and order-3 rows at the CHECK_POINTS of every plan interval), interpolated linearly
between neighbouring check points, and met with MARGIN to spare. :func:`profile_of` turns the result into
the project's smooth profile (u linear in xi = (theta_stop - theta)^(1/3) per interval, where the tail is
exact), its u scaled by a factor within round-off of 1 so that x reaches 0 exactly at the stop point.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import smooth

#: Share of every limit the stop keeps free for the linear interpolation of the rows and the discrete jerk [-].
MARGIN = 0.01
#: Braking steps per stop: the time step is the estimated stop time over this [-].
STEPS_PER_STOP = 400
#: Bounds of the time step [s] and the most steps a stop may take [-].
DT_MIN, DT_MAX, MAX_STEPS = 1e-5, 2e-3, 20000
#: Points along the constant-jerk tail where its limits are checked [-].
TAIL_POINTS = 8
#: Steps over which the state's own share of the limits fades to 1 - MARGIN [-].
FADE_STEPS = 10
#: A tail is tried once its jerk reaches this share of the largest the rows allow at its start [-].
TAIL_FILTER = 0.5
#: A tail is checked at least every this fraction of a plan interval along it [-].
CHECK_SPACING = 0.125
#: Braking depths tried: shares of the least u the order-2 rows allow [-].
DEPTHS = np.array([1.0, 0.85, 0.7, 0.55, 0.4, 0.25])
#: Intervals of the tail in the returned profile (equal in xi) [-].
TAIL_INTERVALS = 4
#: Re-evaluations of the order-3 rows at a braking step's end [-].
END_PASSES = 3
#: Relative slack of the checks (round-off) [-].
SLACK = 1e-9


@njit(cache=True, inline="always")
def _locate(s, grid):
    """(plan interval g, check segment q, weight w) of theta = s: between check points q and q + 1."""
    g = np.searchsorted(grid, s, side="right") - 1
    g = min(max(g, 0), grid.shape[0] - 2)
    f = (s - grid[g]) / (grid[g + 1] - grid[g]) * 4.0
    q = min(max(int(f), 0), 3)
    w = min(max(f - q, 0.0), 1.0)
    return g, q, w


@njit(cache=True, inline="always")
def _at(arr, q, g, r, w):
    return (1.0 - w) * arr[q, g, r] + w * arr[q + 1, g, r]


@njit(cache=True)
def _u_range(s, x, keep, grid, p2, px):
    """(least, largest) u the order-2 rows allow at (s, x) with ``keep`` of the limits; (inf, -inf) when x is
    above x_max."""
    g, q, w = _locate(s, grid)
    if x > keep * keep * ((1.0 - w) * px[q, g] + w * px[q + 1, g]):
        return np.inf, -np.inf
    a_, b_, c_, lo_, hi_ = p2
    low, high = -np.inf, np.inf
    for r in range(a_.shape[2]):
        a, b, c = _at(a_, q, g, r, w), _at(b_, q, g, r, w), _at(c_, q, g, r, w)
        lo, hi = keep * _at(lo_, q, g, r, w), keep * _at(hi_, q, g, r, w)
        rest = b * x + c
        slack = SLACK * (abs(lo) + abs(hi))
        if a > 0.0:
            low, high = max(low, (lo - slack - rest) / a), min(high, (hi + slack - rest) / a)
        elif a < 0.0:
            low, high = max(low, (hi + slack - rest) / a), min(high, (lo - slack - rest) / a)
        elif rest > hi + slack or rest < lo - slack:
            return np.inf, -np.inf
    return low, high


@njit(cache=True)
def _j_range(s, x, u, grid, p3):
    """(least, largest) path jerk the order-3 rows |a3 j + sqrt(x) (a u + b x + c)| <= (1 - MARGIN) lim allow
    at (s, x, u)."""
    g, q, w = _locate(s, grid)
    a3_, a_, b_, c_, lim_ = p3
    sx = np.sqrt(max(x, 0.0))
    low, high = -np.inf, np.inf
    for r in range(a3_.shape[2]):
        a3 = _at(a3_, q, g, r, w)
        rest = sx * (_at(a_, q, g, r, w) * u + _at(b_, q, g, r, w) * x + _at(c_, q, g, r, w))
        lim = (1.0 - MARGIN) * _at(lim_, q, g, r, w) * (1.0 + SLACK)
        if a3 > 0.0:
            low, high = max(low, (-lim - rest) / a3), min(high, (lim - rest) / a3)
        elif a3 < 0.0:
            low, high = max(low, (lim - rest) / a3), min(high, (-lim - rest) / a3)
        elif abs(rest) > lim:
            return np.inf, -np.inf
    return low, high


@njit(cache=True)
def _tail_ok(s, v, a, keep, s_end, grid, p2, p3, px):
    """Whether the constant-jerk tail from (s, theta_dot v, u = a < 0) to rest is a candidate: its jerk at least
    TAIL_FILTER of the largest the rows allow at its start, it ends before s_end and meets every row at
    TAIL_POINTS points equal in time plus one per CHECK_SPACING of the shortest plan interval it spans."""
    if a >= 0.0:
        return False
    jerk = a * a / (2.0 * v)
    period = 2.0 * v / -a
    dist = v * period / 3.0
    if s + dist > s_end or jerk < TAIL_FILTER * _j_range(s, v * v, a, grid, p3)[1]:
        return False
    g0 = min(max(np.searchsorted(grid, s, side="right") - 1, 0), grid.shape[0] - 2)
    g1 = min(max(np.searchsorted(grid, s + dist, side="right") - 1, g0), grid.shape[0] - 2)
    h = np.min(grid[g0 + 1:g1 + 2] - grid[g0:g1 + 1])
    points = TAIL_POINTS + int(dist / (CHECK_SPACING * h))
    for i in range(points + 1):
        t = period * i / points
        st = s + v * t + 0.5 * a * t * t + jerk * t**3 / 6.0
        vt = v + a * t + 0.5 * jerk * t * t
        at = a + jerk * t
        xt = vt * vt
        lo, hi = _u_range(st, xt, keep, grid, p2, px)
        if not lo <= at <= hi:
            return False
        jlo, jhi = _j_range(st, xt, at, grid, p3)
        if not jlo <= jerk <= jhi:
            return False
    return True


@njit(cache=True)
def _advance(s, v, a, jerk, dt):
    """(s, v, a) after dt at constant jerk."""
    return (s + v * dt + 0.5 * a * dt * dt + jerk * dt**3 / 6.0, v + a * dt + 0.5 * jerk * dt * dt,
            a + jerk * dt)


@njit(cache=True)
def _step(s, v, a, keep, depth, dt, grid, p2, p3, px):
    """One braking step of length dt: the jerk that brings u towards ``depth`` times the least u the rows allow
    at the step's end, within the order-3 rows at both of its ends (those at its end re-evaluated END_PASSES times); (s, v, a)
    after it, and whether its end meets the rows."""
    jlo, jhi = _j_range(s, v * v, a, grid, p3)
    if jlo > jhi:
        return s, v, a, False
    sp, vp = s + v * dt + 0.5 * a * dt * dt, v + a * dt
    target = depth * _u_range(sp, vp * vp, keep, grid, p2, px)[0]
    jerk = min(max((target - a) / dt, jlo), jhi)
    for _ in range(END_PASSES):
        s1, v1, a1 = _advance(s, v, a, jerk, dt)
        if v1 <= 0.0:
            return s1, v1, a1, False
        elo, ehi = _j_range(s1, v1 * v1, a1, grid, p3)
        if elo <= jerk <= ehi:
            break
        jerk = min(max(jerk, max(elo, jlo)), min(ehi, jhi))
    s1, v1, a1 = _advance(s, v, a, jerk, dt)
    if v1 <= 0.0:
        return s1, v1, a1, False
    elo, ehi = _j_range(s1, v1 * v1, a1, grid, p3)
    lo, hi = _u_range(s1, v1 * v1, keep, grid, p2, px)
    return s1, v1, a1, lo <= a1 <= hi and elo <= jerk <= ehi


@njit(cache=True)
def brake(s0, x0, u0, share, depth, s_end, grid, p2, p3, px, out_s, out_x, out_u):
    """The stop from (s0, x0 > 0, u0): brakes step by step until a step breaks a row, and of the tails from every
    step (_tail_ok) takes the one that stops first. Fills out_s, out_x, out_u with the braking points (the state
    first, the tail's start at n - 1) and returns n, the stop point [unit theta] ((-1, inf) when no tail meets
    the rows before s_end) and whether a braking step broke a row (a shallower braking may stop sooner).
    ``depth``: the braking aims at this share of the least u the rows allow. ``share``: the state's own share of the limits (>= 1 -
    MARGIN) of the order-2 rows, which fades to 1 - MARGIN over FADE_STEPS steps (the jerk is free at the state:
    the order-3 rows keep 1 - MARGIN from the start)."""
    keep0 = 1.0 - MARGIN
    v, a, s = np.sqrt(x0), u0, s0
    lo, hi = _u_range(s, x0, max(share, keep0), grid, p2, px)
    jlo, jhi = _j_range(s, x0, u0, grid, p3)
    if not lo <= u0 <= hi or jlo > jhi or lo >= 0.0:
        return -1, np.inf, True
    # time step: turn to the least u, brake at it, tail
    period = v / -lo + abs(a - lo) / max(-jlo, 1e-12) + 2.0 * abs(lo) / max(-jlo, jhi, 1e-12)
    dt = min(max(period / STEPS_PER_STOP, DT_MIN), DT_MAX)
    out_s[0], out_x[0], out_u[0] = s, x0, a
    best_n, best = -1, np.inf
    for k in range(min(out_s.shape[0] - 1, MAX_STEPS)):
        fade = min(k / FADE_STEPS, 1.0)
        keep = max(share, keep0) * (1.0 - fade) + keep0 * fade
        if s >= best:  # every later tail ends after the best one
            break
        if a < 0.0 and s + 2.0 * v * v / (3.0 * -a) < best and _tail_ok(s, v, a, keep, s_end, grid, p2, p3, px):
            best_n, best = k + 1, s + 2.0 * v * v / (3.0 * -a)
        s, v, a, ok = _step(s, v, a, keep, depth, dt, grid, p2, p3, px)
        if not ok or s >= s_end:
            return best_n, best, True
        out_s[k + 1], out_x[k + 1], out_u[k + 1] = s, v * v, a
    return best_n, best, False


@njit(cache=True)
def shortest(s0, x0, u0, share, s_end, grid, p2, p3, px, out_s, out_x, out_u):
    """The stop of the least distance over the braking depths DEPTHS (:func:`brake`; the deeper ones first,
    shallower ones while a braking step breaks a row); fills out_s, out_x, out_u with it and returns (n, the
    stop point), (-1, inf) when none is found."""
    best, best_depth, n = np.inf, -1.0, -1
    for depth in DEPTHS:
        n, stop, broke = brake(s0, x0, u0, share, depth, s_end, grid, p2, p3, px, out_s, out_x, out_u)
        if n >= 0 and stop < best:
            best, best_depth = stop, depth
        if not broke:
            break
    if best_depth < 0.0:
        return -1, np.inf
    if best_depth != depth or n < 0 or stop != best:
        n, best, _ = brake(s0, x0, u0, share, best_depth, s_end, grid, p2, p3, px, out_s, out_x, out_u)
    return n, best


def profile_of(s, x, u, stop):
    """(grid, x, u_nodes) of the smooth profile through the braking points (s, x, u) (n,) and the constant-jerk
    tail to rest at ``stop`` (TAIL_INTERVALS intervals equal in xi): u linear in xi = (stop - theta)^(1/3) on
    every interval, x from it (x_{k+1} = x_k + 2 (w0 u_k + w1 u_{k+1}), planning/smooth.py) from the state's x,
    the u after the state's scaled by the one factor that ends x at 0 at ``stop``. None when that leaves an x
    <= 0 before the stop."""
    xi_sw = np.cbrt(stop - s[-1])
    share = np.arange(1, TAIL_INTERVALS + 1) / TAIL_INTERVALS
    xi = xi_sw * (1.0 - share)
    grid = np.concatenate([s, stop - xi[:-1] ** 3, [stop]])
    un = np.concatenate([u, u[-1] * xi / xi_sw])
    rest = np.zeros(len(grid), bool)
    rest[-1] = True
    origin, sign = smooth.coordinates(grid, rest)
    _, _, w0, w1 = smooth.weights(grid, origin, sign)
    # x_end = x_0 + 2 (w0_0 u_0 + sum of the rest's terms); the terms of u_1.. scaled by lam end it at 0
    fixed = w0[0] * un[0]
    rest_terms = np.sum(w1 * un[1:]) + np.sum(w0[1:] * un[1:-1])
    if rest_terms >= 0.0:
        return None
    lam = -(x[0] / 2.0 + fixed) / rest_terms
    un[1:] *= lam
    xs = x[0] + 2.0 * np.concatenate([[0.0], np.cumsum(w0 * un[:-1] + w1 * un[1:])])
    xs[-1] = 0.0
    if np.any(xs[:-1] <= 0.0) or abs(lam - 1.0) > MARGIN:
        return None
    return grid, xs, un
