"""Time-optimal path parameterization by reachability analysis (TOPP-RA, Pham & Pham 2018).

Discretization ("interpolation", first order): on each interval [theta_i, theta_{i+1}] the path
acceleration u is constant, so x_{i+1} = x_i + 2 Delta_i u, and every row of the canonical form is
imposed at BOTH ends of the interval with that same u. Written in the two unknowns (x_i, x_{i+1})
with u = (x_{i+1} - x_i) / (2 Delta_i), interval i is a polygon

    P[i, r] x_i + Q[i, r] x_{i+1} <= R[i, r]   (r = 0..M-1),   0 <= x_i <= x_max_i,  0 <= x_{i+1} <= x_max_{i+1}

Backward pass: the controllable set K_i (x_i from which the end set can be reached) is the
projection on x_i of that polygon cut with x_{i+1} in K_{i+1}. Forward pass: from x_0, take the
largest x_{i+1} in K_{i+1} the polygon allows (the greedy choice is time-optimal, Pham & Pham 2018,
Theorem 2). The reachable sets (forward projections) give the feasible range of an end velocity.

Each projection is exact: Fourier-Motzkin elimination of the other unknown over all pairs of rows,
with no division by the eliminated coefficient, so rows whose coefficient vanishes (dynamic
singularities: alpha_j = 0, or Phi'_j = 0) need no special case. The passes are numba kernels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .limit_rows import LimitRows

#: Slack added to every normalized row, relative to its bound and absolute [units of x]: absorbs
#: round-off in nearly parallel rows (far below the verification tolerance).
ROW_SLACK_REL = 1e-10
ROW_SLACK = 1e-13
#: A projected interval [lo, hi] with hi < lo - EMPTY_TOL * (1 + |hi|) is empty.
EMPTY_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class IntervalProblem:
    """Discretized problem: grid (K,); rows P, Q, R (K-1, M) (normalized, |P| + |Q| = 1 or 0; R
    includes the round-off slack); x_max (K,) upper bound on x at each point (0 where the motion
    must stop); x_max_right / x_max_left (K,): the bound from the limits on the side of the
    interval after / before each point (they differ at segment connections only)."""

    grid: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    x_max: np.ndarray
    x_max_right: np.ndarray | None = None
    x_max_left: np.ndarray | None = None

    def __post_init__(self):
        for name in ("x_max_right", "x_max_left"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, self.x_max)

    @property
    def size(self) -> int:
        return len(self.grid)

    def slice(self, i0: int, i1: int) -> "IntervalProblem":
        """The sub-problem on points i0..i1 (inclusive), planned on its own: its end points are
        bounded only by the limits on its own side of a segment connection."""
        x_max = self.x_max[i0:i1 + 1].copy()
        x_max[0], x_max[-1] = self.x_max_right[i0], self.x_max_left[i1]
        return IntervalProblem(self.grid[i0:i1 + 1], self.P[i0:i1], self.Q[i0:i1], self.R[i0:i1], x_max)

    def capped(self, bound: np.ndarray) -> "IntervalProblem":
        """The same problem with x <= bound (K,) added at every point (on both sides)."""
        return IntervalProblem(self.grid, self.P, self.Q, self.R, np.minimum(self.x_max, bound),
                               np.minimum(self.x_max_right, bound), np.minimum(self.x_max_left, bound))


@dataclass(frozen=True, eq=False)
class SetSequence:
    """Intervals [lo_i, hi_i] of x at each grid point (K,); ``failed_at`` = index where the set
    became empty (-1: none; the sets from there on toward the pass's start are meaningless)."""

    lo: np.ndarray
    hi: np.ndarray
    failed_at: int


def interval_problem(grid: np.ndarray, start: LimitRows, end: LimitRows,
                     x_max_right: np.ndarray, x_max_left: np.ndarray) -> IntervalProblem:
    """Build the interval rows. ``start`` holds the constraints at points 0..K-2 as seen from the
    interval they start (K-1 rows), ``end`` at points 1..K-1 as seen from the interval they end."""
    grid = np.asarray(grid, float)
    P, Q, R = _interval_rows(grid, start.a, start.b, start.c, start.lo, start.hi, end.a, end.b, end.c, end.lo, end.hi)
    return IntervalProblem(grid, P, Q, R, np.minimum(x_max_right, x_max_left), np.asarray(x_max_right, float),
                           np.asarray(x_max_left, float))


@njit(cache=True)
def _interval_rows(grid, a_s, b_s, c_s, lo_s, hi_s, a_e, b_e, c_e, lo_e, hi_e):
    """P, Q, R (K - 1, 4 m) of interval_problem: per interval the start rows (<= hi, >= lo) then the end
    rows, each normalized to |P| + |Q| = 1 (or 0) with the round-off slack added to R."""
    k1, m = a_s.shape
    P, Q, R = np.empty((k1, 4 * m)), np.empty((k1, 4 * m)), np.empty((k1, 4 * m))
    for i in range(k1):
        k2 = 0.5 / (grid[i + 1] - grid[i])  # 1 / (2 Delta)
        for j in range(m):
            # start row: a u + b x_i = (b - a k2) x_i + a k2 x_{i+1};  end row: -a k2 x_i + (a k2 + b) x_{i+1}
            p_s, q_s = b_s[i, j] - a_s[i, j] * k2, a_s[i, j] * k2
            p_e, q_e = -a_e[i, j] * k2, a_e[i, j] * k2 + b_e[i, j]
            for col, p, q, r in ((j, p_s, q_s, hi_s[i, j] - c_s[i, j]), (m + j, -p_s, -q_s, c_s[i, j] - lo_s[i, j]),
                                 (2 * m + j, p_e, q_e, hi_e[i, j] - c_e[i, j]),
                                 (3 * m + j, -p_e, -q_e, c_e[i, j] - lo_e[i, j])):
                norm = abs(p) + abs(q)
                scale = 1.0 / norm if norm > 0 else 1.0
                r = r * scale
                P[i, col], Q[i, col], R[i, col] = p * scale, q * scale, r + ROW_SLACK_REL * abs(r) + ROW_SLACK
    return P, Q, R


@njit(cache=True)
def _cut(d, e, lo, hi):
    """Intersect [lo, hi] with {x : d x <= e}."""
    if d > 0.0:
        v = e / d
        if v < hi:
            hi = v
    elif d < 0.0:
        v = e / d
        if v > lo:
            lo = v
    elif e < 0.0:
        lo = np.inf
    return lo, hi


@njit(cache=True)
def _project(A, B, R, i, ylo, yhi, xlo, xhi, slack):
    """Range of x with some y in [ylo, yhi] such that A[i] x + B[i] y <= R[i] (rows), x in [xlo, xhi]."""
    lo, hi = xlo, xhi
    if ylo > yhi:
        return np.inf, -np.inf
    m = A.shape[1]
    for k in range(m):
        a, b, r = A[i, k], B[i, k], R[i, k] + slack
        if b > 0.0:  # y <= (r - a x) / b, with y >= ylo
            lo, hi = _cut(a, r - b * ylo, lo, hi)
            for j in range(m):
                bj = B[i, j]
                if bj < 0.0:  # y >= (r_j - a_j x) / b_j
                    lo, hi = _cut(A[i, j] * b - a * bj, (R[i, j] + slack) * b - r * bj, lo, hi)
        elif b < 0.0:  # y >= (r - a x) / b, with y <= yhi
            lo, hi = _cut(a, r - b * yhi, lo, hi)
        else:
            lo, hi = _cut(a, r, lo, hi)
    return lo, hi


@njit(cache=True)
def _sweep(A, B, R, x_max, first_lo, first_hi, backward, slack, empty_tol):
    """Backward (controllable) or forward (reachable) sets; returns lo, hi, failed index."""
    n = x_max.shape[0]
    lo = np.full(n, np.nan)
    hi = np.full(n, np.nan)
    start = n - 1 if backward else 0
    lo[start] = max(first_lo, 0.0)
    hi[start] = min(first_hi, x_max[start])
    if hi[start] < lo[start] - empty_tol * (1.0 + abs(hi[start])):
        return lo, hi, start
    hi[start] = max(hi[start], lo[start])
    for step in range(n - 1):
        if backward:
            i = n - 2 - step
            nxt, cur = i + 1, i
        else:
            i = step
            nxt, cur = i, i + 1
        l, h = _project(A, B, R, i, lo[nxt], hi[nxt], 0.0, x_max[cur], slack)
        if h < l - empty_tol * (1.0 + abs(h)):
            return lo, hi, cur
        if h < l:
            h = l
        lo[cur] = max(l, 0.0)
        hi[cur] = max(h, lo[cur])
    return lo, hi, -1


@njit(cache=True)
def _greedy(P, Q, R, klo, khi, x0, slack):
    """Forward pass: x_{i+1} = the largest value in K_{i+1} allowed from x_i."""
    n = klo.shape[0]
    x = np.empty(n)
    x[0] = x0
    m = P.shape[1]
    for i in range(n - 1):
        hi = khi[i + 1]
        xi = x[i]
        for k in range(m):
            q = Q[i, k]
            if q > 0.0:
                v = (R[i, k] + slack - P[i, k] * xi) / q
                if v < hi:
                    hi = v
        if hi < klo[i + 1]:
            hi = klo[i + 1]
        x[i + 1] = hi
    return x


@njit(cache=True)
def _side_row(a, b, c, lo, hi, k, r, m):
    """Row r of point k of the one-sided form (A u + B x <= R) of two-sided rows lo <= a u + b x + c <= hi (m rows):
    r < m: (a, b, hi - c); r >= m: (-a, -b, c - lo) of row r - m."""
    if r < m:
        return a[k, r], b[k, r], hi[k, r] - c[k, r]
    q = r - m
    return -a[k, q], -b[k, q], c[k, q] - lo[k, q]


@njit(cache=True)
def _point_max(a, b, c, lo, hi):
    """Largest x at each point with some u such that every row holds, lo <= a u + b x + c <= hi (K, m each): over
    the one-sided rows A u + B x <= R, the least bound of a row with A = 0 (B > 0) and of each pair with A_r > 0 >
    A_j (their intersection); inf if none binds."""
    n, m = a.shape
    out = np.full(n, np.inf)
    for k in range(n):
        hi_x = np.inf
        for r in range(2 * m):
            ar, br, rr = _side_row(a, b, c, lo, hi, k, r, m)
            if ar == 0.0:
                if br > 0.0 and rr / br < hi_x:
                    hi_x = rr / br
            elif ar > 0.0:
                for j in range(2 * m):
                    aj, bj, rj = _side_row(a, b, c, lo, hi, k, j, m)
                    if aj < 0.0:
                        d = bj * ar - br * aj
                        if d > 0.0:
                            v = (rj * ar - rr * aj) / d
                            if v < hi_x:
                                hi_x = v
        out[k] = hi_x
    return out


def controllable_sets(problem: IntervalProblem, end_lo: float, end_hi: float) -> SetSequence:
    """K_i: the x_i from which the end set [end_lo, end_hi] is reachable (backward pass)."""
    lo, hi, fail = _sweep(problem.P, problem.Q, problem.R, problem.x_max, float(end_lo), float(end_hi),
                          True, 0.0, EMPTY_TOL)
    return SetSequence(lo, hi, int(fail))


def reachable_sets(problem: IntervalProblem, start_lo: float, start_hi: float) -> SetSequence:
    """L_i: the x_i reachable from the start set [start_lo, start_hi] (forward pass)."""
    lo, hi, fail = _sweep(problem.Q, problem.P, problem.R, problem.x_max, float(start_lo), float(start_hi),
                          False, 0.0, EMPTY_TOL)
    return SetSequence(lo, hi, int(fail))


def greedy_profile(problem: IntervalProblem, sets: SetSequence, x0: float) -> np.ndarray:
    """The time-optimal x (K,) from x_0 = ``x0`` (which must lie in sets K_0) through the controllable sets."""
    return _greedy(problem.P, problem.Q, problem.R, sets.lo, sets.hi, float(x0), 0.0)


def maximum_velocity_curve(pc: LimitRows) -> np.ndarray:
    """x_max(theta) (K,) from the point-wise limits: the largest x at each point for which some u
    satisfies every row there (the maximum-velocity curve of the phase-plane plot; inf if unbounded)."""
    return np.minimum(_point_max(pc.a, pc.b, pc.c, pc.lo, pc.hi), pc.x_max)
