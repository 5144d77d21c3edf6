"""Compiled jerk-limited re-timing: a forward pass from a moving state that merges into a ceiling profile.

The smooth profile's form is that of planning/third_order.py and planning/smooth.py: x = theta_dot^2 and
u = theta_ddot at the grid points, u linear in each interval's stretched coordinate xi, so that
x_{k+1} = x_k + 2 (w0_k u_k + w1_k u_{k+1}) and u' = du/dtheta = (u_{k+1} - u_k) dl_k at the interval's start,
(u_{k+1} - u_k) dh_k at its end. The limits at every point: the order-2 rows lo <= a u + b x + c <= hi, the
bound x <= x_max, and the order-3 rows |sqrt(x) (a3 u' + a u + b x + c)| <= lim (joint jerk, torque rate).

At construction (:class:`JerkPass`), on the plan's grid: the rows on both sides of every point, the
interval weights, and the ceiling C: the smooth time-optimal profile with a free start (the project's
sequential LP, certified and tightened as a plan is), the fastest smooth motion to the plan's end.

A query (:func:`forward`) walks from the state over the grid points up to the next rest point. Its step is
the largest u_{k+1} the rows allow from which the descent (u turned towards C's u as fast as the rows
allow) still ends on or below C, found by bisection when the largest step does not; above C the least
step. At every point of the walk, and where its descent ends, merges into C over N = MERGE_LENGTHS
intervals are tried: u = u_C + d (1 - s) + alpha s (1 - s), s the fraction of the merge, d the offset
from u_C, alpha the value that ends the merge on C's x. Of those whose rows hold, the one of the least
total time (walk, descent, merge, C's rest) is the answer, C from its end on (none where the rows stop the
walk while a merge further on might still gain WALK_GAIN). Every step and merge meets
every row at CHECK_POINTS of each interval (the inner points' path data sampled at construction; the stretch
from the state to the next grid point is cut into intervals graded towards the state, FIRST_CUTS, or for a
state that nearly rests runs on past the point where its speed dips, cut finely there (JerkPass.first_points);
its path data is sampled at the query) with PASS_MARGIN to spare, which fades out along a merge to C's full limits; the
results are checked on the dense time resample in the tests, their certified bounds in the benchmark.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import defaults
from . import smooth
from .limit_rows import limit_rows
from .limits import PathPoints

#: Where each interval's rows are checked: fractions of the interval from its start to its end [-].
CHECK_POINTS = (0.0, 0.25, 0.5, 0.75, 1.0)
#: Merge lengths tried, in grid intervals [-].
MERGE_LENGTHS = np.array([2, 4, 8, 16, 32])
#: Relative slack of the rows' checks (round-off) [-].
ROW_SLACK = 1e-9
#: The pass keeps this fraction below every limit (velocity, order-2 and order-3 rows) at its check points,
#: for what the rows do between them; along a merge the margin fades out to the ceiling's full limits [-].
PASS_MARGIN = 0.005
#: The state's share of the order-2 limits the pass keeps to at least, and at most (a state above is refused) [-].
STATE_SHARE_MIN = 1.0
STATE_SHARE_MAX = defaults.RETIME_STATE_SHARE_MAX
#: The stretch from the state to the next grid point is cut at these fractions of it (graded towards the
#: state: a slow state's acceleration turns at the jerk limit within a small part of a plan interval) [-] ...
FIRST_CUTS = (0.0, 0.0625, 0.125, 0.25, 0.5, 1.0)
#: ... for a braking state that would rest within this many plan intervals at its deceleration, x0 / (2 |u0|)
#: (the others turn theta_ddot over a plan interval or more: one interval, a shorter walk) [-].
GRADED_REACH = 4.0
#: ... and where that rest reach D is below this share of a plan interval (the motion on nearly rests about D
#: on: u linear over a plan interval cannot turn theta_ddot there), the first stretch runs up to the first grid
#: point DIP_REACH D past the state, DIP_CUTS intervals per D around the dip [-].
DIP_REACH_MAX = 1.0
DIP_REACH = 8.0
DIP_CUTS = 16
#: Least spacing of the first stretch's points, relative to its length [-].
DIP_GAP = 1e-6
#: The pass's own intervals (from the state to where it runs on C) are returned cut into this many, the same
#: motion: the certified bound of an interval (planning/certify.py: samples and an interpolation remainder) is
#: loose on an interval whose jerk changes steeply, as a merge's or a slow state's graded first ones [-].
OUTPUT_SPLIT = 2
#: Least x (relative to the state's) at a point where the motion does not rest [-].
X_FLOOR = 1e-12
#: An interval whose u rises from u_k < 0 through 0 has its least x where u = 0: about x_k - u_k^2 h / (u_{k+1} -
#: u_k) (h its width; u linear in theta), taken this many times over, which must stay above the floor (the
#: check points can miss that dip from a slow state) [-].
DIP_SAFETY = 2.0


class JerkPass:
    """The state-independent data of the pass on ``grid`` (K,): ``samp`` the third-order path data (both
    sides), ``scale`` the limits' point-wise scales {name: (K, m)}, ``ceiling`` the smooth Profile C on
    ``grid``. Every interval carries Q check points (CHECK_POINTS: its start, inner points, its end): their rows
    p2 (five (Q, K-1, m2)), p3 (five (Q, K-1, m3)), x_max px (Q, K-1), and pc (4, Q, K-1): x = x_k + 2 u_k pc[0] +
    2 (u_{k+1} - u_k) pc[1], u = u_k + pc[2] (u_{k+1} - u_k), u' = pc[3] (u_{k+1} - u_k) there."""

    def __init__(self, path, robot, grid, samp, limits, scale, ceiling):
        self.grid = grid = np.ascontiguousarray(grid, float)
        self.cx = np.ascontiguousarray(ceiling.x)
        self.cu = np.ascontiguousarray(ceiling.u_nodes)
        self.rest = self.cx <= 0.0
        self.rest_index = np.nonzero(self.rest)[0]
        self._buffers = (np.empty(len(grid) + 1), np.empty(len(grid) + 1))  # the pass's work arrays
        self.tc = np.ascontiguousarray(np.concatenate([np.cumsum(ceiling.intervals[::-1])[::-1], [0.0]]))
        self.origin, self.sign = smooth.coordinates(grid, self.rest)
        self._sign_i = np.ascontiguousarray(self.sign, np.int64)
        self.pc = point_coefficients(grid, self.origin, self.sign)
        self.path, self.robot, self.limits = path, robot, limits
        self._inner_scale = inner_scale = {n: np.minimum(v[:-1], v[1:]) for n, v in scale.items()}
        inner = [(_sample_points(path, robot, (1.0 - a) * grid[:-1] + a * grid[1:]), inner_scale, slice(None))
                 for a in CHECK_POINTS[1:-1]]
        points = [(samp.right, scale, slice(0, -1)), *inner, (samp.left, scale, slice(1, None))]
        rows2 = [limit_rows(pts, limits, sc, defaults.PLANNER_X_CAP) for pts, sc, _ in points]
        self.p2 = tuple(np.ascontiguousarray(np.stack([getattr(r, n)[sl] for r, (_, _, sl) in zip(rows2, points)]))
                        for n in ("a", "b", "c", "lo", "hi"))
        self.px = np.ascontiguousarray(np.stack([r.x_max[sl] for r, (_, _, sl) in zip(rows2, points)]))
        third = [[lim.rows3(pts, sc[lim.name]) for lim in limits if lim.order == 3] for pts, sc, _ in points]
        self.p3 = tuple(np.ascontiguousarray(np.stack([np.concatenate([np.asarray(r[f]) for r in side], axis=1)[sl]
                                                       for side, (_, _, sl) in zip(third, points)]))
                        for f in range(5))
        self._r2, self._r3 = np.stack(self.p2), np.stack(self.p3)  # (5, Q, K-1, m): the kernels' layout

    def ceiling_at(self, i: int, theta: float) -> tuple[float, float]:
        """(x, u) of C at theta in grid interval i."""
        x, u, _ = smooth.state(self.grid, self.cx, self.cu, self.origin, self.sign, np.array(i), np.array(theta))
        return float(x), float(u)

    def _first(self, theta: float, i: int, j: int, pts_s: np.ndarray) -> tuple:
        """The rows at the check points of every output interval: the first ones, [theta, grid[j]] cut at ``pts_s``
        (F + 1,) (theta first, grid[j] last; every grid point between among them), then the plan's from grid interval
        j on (N output intervals in all): (r2 (5, Q, N, m2): a, b, c, lo, hi; r3 (5, Q, N, m3): a3, a, b, c, lim;
        x_max (Q, N); coefficients (4, Q, N)), the forward pass's ``grid_data`` rows. On the first intervals the path
        data sampled at their points (the last end: grid point j's), the limits scaled as on the grid interval each
        lies in."""
        g = self.grid
        nf = len(pts_s) - 1
        pc = _first_coefficients(pts_s, float(self.origin[j - 1]), int(self.sign[j - 1]), np.array(CHECK_POINTS))
        nq = len(CHECK_POINTS)
        at = (pts_s[:-1, None] + np.array(CHECK_POINTS[:-1])[None, :] * np.diff(pts_s)[:, None]).T  # (Q-1, F)
        pts = _sample_points(self.path, self.robot, at.ravel())
        if j == i + 1:
            scale = {n: np.repeat(v[i:i + 1], at.size, axis=0) for n, v in self._inner_scale.items()}
        else:
            idx = np.clip(np.searchsorted(g, np.tile(pts_s[:-1], nq - 1), side="right") - 1, i, j - 1)
            scale = {n: v[idx] for n, v in self._inner_scale.items()}
        rows2 = limit_rows(pts, self.limits, scale, defaults.PLANNER_X_CAP)
        rows3 = [lim.rows3(pts, scale[lim.name]) for lim in self.limits if lim.order == 3]

        # the output intervals that end at a grid point m (j among them): their end's rows are the plan interval
        # m - 1's end rows (left of m: a spline knot's third derivative jumps there), the others' their next start's
        inner = np.searchsorted(g, pts_s[1:], side="left")
        at_grid = np.nonzero((inner < len(g)) & (g[np.minimum(inner, len(g) - 1)] == pts_s[1:]))[0]
        at_grid = at_grid[at_grid < nf - 1]

        def stacked(sampled, plan):
            """(L, Q, N, ...) from the samples (L, (Q-1) F, ...) at the first intervals' check points before their
            ends and the plan's rows (L, Q, K-1, ...): for the ends at grid points and from grid interval j on (an
            interval's end is else the next one's start)."""
            sampled = sampled.reshape((len(sampled), nq - 1, nf) + sampled.shape[2:])
            out = np.empty((len(sampled), nq, nf + plan.shape[2] - j) + sampled.shape[3:])
            out[:, :nq - 1, :nf] = sampled
            out[:, nq - 1, :nf - 1] = sampled[:, 0, 1:]
            out[:, nq - 1, nf - 1] = plan[:, nq - 1, j - 1]
            if at_grid.size:
                out[:, nq - 1, at_grid] = plan[:, nq - 1, inner[at_grid] - 1]
            out[:, :, nf:] = plan[:, :, j:]
            return out

        r2 = stacked(np.stack([getattr(rows2, n) for n in ("a", "b", "c", "lo", "hi")]), self._r2)
        r3 = stacked(np.stack([np.concatenate([np.asarray(r[k]) for r in rows3], axis=1) for k in range(5)]),
                     self._r3)
        px = stacked(np.asarray(rows2.x_max)[None], self.px[None])[0]
        return r2, r3, px, np.concatenate([pc, self.pc[:, :, j:]], axis=2)

    def first_points(self, theta: float, i: int, j: int, nxt: int, x0: float, u0: float) -> tuple[int, np.ndarray, int]:
        """(j', points, merge_from): the first output intervals run from theta to grid point j' >= j, cut at the
        points (theta first, grid[j'] last); merges into C are tried from output point merge_from on. One interval
        [theta, grid[j]] (j = i + 2 where theta lies next to grid point i + 1), but for a braking state that would
        rest within GRADED_REACH plan intervals at its deceleration, D = x0 / (2 |u0|): the stretch to grid point
        j = i + 1 cut at FIRST_CUTS; and where D is within DIP_REACH_MAX of a plan interval (the motion on nearly
        rests: its speed dips where the jerk limit has turned theta_ddot, about D on), up to the first grid point
        DIP_REACH D past theta (before the next rest point nxt; where grid point j is that rest point, the stretch
        to it cut at FIRST_CUTS), cut at every grid point between, at D 2^-m
        (m = 1 .. 4) towards the state, at spacing D / DIP_CUTS over [D / 2, 2 D] and at D (2 + 2^m) (m = -2, -1,
        ...) after it, where the motion speeds up again (u turns at the jerk limit there too: the rows are checked
        on this stretch at its own points). Merges into C from that stretch's points (far below C, over its short
        intervals) are not tried: from grid point j' on."""
        g = self.grid
        h = g[i + 1] - g[i]
        if not (u0 < 0.0 and x0 < -2.0 * u0 * GRADED_REACH * h):
            return j, np.array([theta, g[j]]), 0
        d = x0 / (-2.0 * u0)
        end = min(max(j, int(np.searchsorted(g, theta + DIP_REACH * d))), nxt - 1)
        if d >= DIP_REACH_MAX * h or end < j:  # (end < j: the next grid point is a rest point)
            if j != i + 1:
                return j, np.array([theta, g[j]]), 0
            pts = theta + np.array(FIRST_CUTS) * (g[j] - theta)
            pts[-1] = g[j]
            return j, pts, 0
        cuts = theta + d * np.concatenate([0.5 ** np.arange(4, 0, -1), np.linspace(0.5, 2.0, int(1.5 * DIP_CUTS) + 1),
                                           2.0 + 2.0 ** np.arange(-2, 30)])
        fixed = np.concatenate([[theta], g[i + 1:end + 1]])  # every grid point between (knots among them) is kept
        gap = DIP_GAP * (g[end] - theta)
        cuts = cuts[(cuts < g[end]) & (np.min(np.abs(cuts[:, None] - fixed[None, :]), axis=1) > gap)]
        pts = np.unique(np.concatenate([fixed, cuts]))
        pts = pts[np.concatenate([[True], np.diff(pts) > gap])]
        return end, pts, len(pts) - 1

    @staticmethod
    def _state_share(r2, x0: float, u0: float) -> float:
        """The share of the order-2 limits the state (x0, u0) takes at its point (``r2``: JerkPass._first's), at
        least STATE_SHARE_MIN: the limits at the state, from which the pass's margin fades in over the first
        interval (the pass refuses a state above STATE_SHARE_MAX)."""
        a, b, c, lo, hi = r2[:, 0, 0]
        val = a * u0 + b * x0 + c
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(val > 0, val / hi, val / lo)
        return float(max(np.max(share[np.isfinite(share)], initial=0.0), STATE_SHARE_MIN))

    def applies(self, theta: float, i: int, j: int, x0: float) -> bool:
        """Whether the pass answers from (theta in grid interval i, j the first grid point after it, x0): a moving
        state (x0 > 0) where C's coordinate is measured from the next rest point (before the middle of a stretch
        after a rest point C's is measured from that rest point, a profile from a moving state's is not)."""
        nxt = int(self.rest_index[np.searchsorted(self.rest_index, j)])
        return x0 > 0.0 and not np.any(self.sign[i:nxt] > 0)

    def remaining(self, theta: float, i: int, f: float, j: int, x0: float, u0: float):
        """(grid, x, u, own) on [theta, grid[j:]] from the state (x0 > 0, u0) at theta (grid interval i at the fraction
        f; j the first grid point after it; the pass must apply there), or None when the pass finds no merge. ``own``:
        for a nearly resting state (its stretch past the speed dip, JerkPass.first_points) the number of leading
        points that are the pass's own (from there on the profile is C's), which the caller certifies (the pass's
        check points and margin are no certificate, and these states' steep jerk finds their gaps); else 0."""
        nxt = int(self.rest_index[np.searchsorted(self.rest_index, j)])
        j, pts, merge_from = self.first_points(theta, i, j, nxt, x0, u0)
        rows = self._first(theta, i, j, pts)
        c0 = self._ceiling_first(j, pts)
        share = self._state_share(rows[0], x0, u0)
        if share > STATE_SHARE_MAX:
            return None
        grid_data = (*rows, self.cx, self.cu)
        first = (share, np.ascontiguousarray((pts - pts[0]) / (pts[-1] - pts[0])))
        if len(self._buffers[0]) < len(pts) + len(self.grid) - j:
            self._buffers = (np.empty(len(pts) + len(self.grid)), np.empty(len(pts) + len(self.grid)))
        xs, us = self._buffers
        end = forward(grid_data, first, self.tc, j, nxt, x0, u0, c0, MERGE_LENGTHS, xs, us, merge_from)[1]
        if end < 0:
            return None
        grid = np.concatenate([pts, self.grid[j + 1:]])
        cx, cu = np.concatenate([c0[0], self.cx[j:]]), np.concatenate([c0[1], self.cu[j:]])
        out = split(grid, np.concatenate([xs[:end], cx[end:]]), np.concatenate([us[:end], cu[end:]]), end)
        return (*out, (OUTPUT_SPLIT * end + 1) if merge_from else 0)

    def _ceiling_first(self, j: int, pts: np.ndarray) -> np.ndarray:
        """(3, F): C's x, u and time [s] to the plan's end at the first output points pts[:-1] (pts (F + 1,), its
        last grid point j), the time over the stretch to grid point j by chords (x linear per output interval)."""
        idx = np.clip(np.searchsorted(self.grid, pts[:-1], side="right") - 1, 0, j - 1)
        x, u, _ = smooth.state_points(self.grid, self.cx, self.cu, self.origin, self._sign_i, idx, pts[:-1])
        xs = np.append(np.maximum(x, 0.0), self.cx[j])
        chords = 2.0 * np.diff(pts) / np.maximum(np.sqrt(xs[:-1]) + np.sqrt(xs[1:]), 1e-300)
        time = self.tc[j] + np.cumsum(chords[::-1])[::-1]
        return np.ascontiguousarray(np.stack([np.asarray(x, float), np.asarray(u, float), time]))


def split(grid, x, u, upto: int, parts: int = OUTPUT_SPLIT):
    """The smooth profile (grid, x, u) (K,) with each of its intervals before point ``upto`` cut into ``parts``,
    x and u at the new points from its own form (the same motion: no rest point is added, so every interval keeps
    its coordinate). Returns (grid, x, u)."""
    if upto <= 0 or parts <= 1:
        return grid, x, u
    origin, sign = smooth.coordinates(grid, x <= 0.0)
    return _split_kernel(grid, x, u, origin.astype(float), sign.astype(np.int64), int(upto), int(parts))


@njit(cache=True, nogil=True)
def _split_kernel(grid, x, u, origin, sign, upto, parts):
    """:func:`split`: each new point (at the fractions k / parts of its interval) right after its interval's start."""
    n = grid.shape[0] + upto * (parts - 1)
    g, xs, us = np.empty(n), np.empty(n), np.empty(n)
    p = 0
    for i in range(grid.shape[0]):
        g[p], xs[p], us[p] = grid[i], x[i], u[i]
        p += 1
        if i < upto:
            for k in range(1, parts):
                th = grid[i] + (k / parts) * (grid[i + 1] - grid[i])
                g[p] = th
                xx, us[p], _ = smooth.state_at(grid, x, u, origin, sign, i, th)
                xs[p] = max(xx, 0.0)
                p += 1
    return g, xs, us


def _sample_points(path, robot, theta):
    """Third-order path data at the points ``theta`` (interior points of the path's pieces): sample_grid's right
    side, without its left side (the points' last one seen from the left, which no check point is)."""
    q, dq, ddq, dddq = path.evaluate3(theta, "right")
    points = PathPoints(robot, path, theta, q, dq, ddq)
    points._cache["dddq"] = np.atleast_2d(dddq)
    return points


def point_coefficients(grid, origin, sign) -> np.ndarray:
    """(4, Q, K-1): per interval of ``grid`` in the coordinates (origin, sign) (planning/smooth.py) and per
    check point (CHECK_POINTS), the coefficients (cxu, cxv, lam, dp) of x = x_k + 2 u_k cxu + 2 (u_{k+1} - u_k)
    cxv, u = u_k + lam (u_{k+1} - u_k), u' = dp (u_{k+1} - u_k)."""
    lo, hi = grid[:-1], grid[1:]
    xi_lo, xi_hi, _, w1 = smooth.weights(grid, origin, sign)
    span = xi_hi - xi_lo
    out = np.zeros((4, len(CHECK_POINTS), len(lo)))
    with np.errstate(divide="ignore"):  # infinite next to a rest point, where no row is checked
        for q, a in enumerate(CHECK_POINTS):
            th = hi if a == 1.0 else (1.0 - a) * lo + a * hi
            xi = xi_hi if a == 1.0 else (xi_lo if a == 0.0 else smooth.xi_of(origin, sign, th))
            out[0, q] = th - lo
            out[1, q] = w1 if a == 1.0 else smooth.xi_integral(origin, sign, lo, th) / span
            out[2, q] = (xi - xi_lo) / span
            out[3, q] = 1.0 / (smooth.dtheta_dxi(sign, xi) * span)
    return np.ascontiguousarray(out)


@njit(cache=True, nogil=True, error_model="numpy")
def _first_coefficients(pts, origin, sign, at):
    """point_coefficients of the intervals of ``pts`` in one coordinate (origin, sign), ``at`` the check points:
    smooth.weights' and smooth.xi_integral's formulas point by point (the query's first stretch)."""
    n = pts.shape[0] - 1
    out = np.zeros((4, at.shape[0], n))
    for k in range(n):
        lo, hi = pts[k], pts[k + 1]
        xi_lo, xi_hi = smooth.xi_at(origin, sign, lo), smooth.xi_at(origin, sign, hi)
        span = xi_hi - xi_lo
        for q in range(at.shape[0]):
            a = at[q]
            th = hi if a == 1.0 else (1.0 - a) * lo + a * hi
            xi = xi_hi if a == 1.0 else (xi_lo if a == 0.0 else smooth.xi_at(origin, sign, th))
            out[0, q, k] = th - lo
            out[1, q, k] = smooth.xi_integral_at(origin, sign, lo, th) / span
            out[2, q, k] = (xi - xi_lo) / span
            out[3, q, k] = 1.0 / ((1.0 if sign == 0 else 3.0 * sign * xi * xi) * span)
    return out


# ----------------------------------------------------------------------------------------------- kernels


@njit(cache=True, inline="always")
def _cut(low, high, q, bot, top):
    """[low, high] narrowed to the v with bot <= q v <= top; (low, high, False) when none."""
    if q > 0.0:
        return max(low, bot / q), min(high, top / q), True
    if q < 0.0:
        return max(low, top / q), min(high, bot / q), True
    return low, high, not (top < 0.0 or bot > 0.0)


@njit(cache=True, inline="always")
def _ceiling(k, j, grid_data, c0):
    """(x, u) of C at output point k (c0 (3, F): C at the first output points)."""
    nf = c0.shape[1]
    if k < nf:
        return c0[0, k], c0[1, k]
    cx, cu = grid_data[4], grid_data[5]
    return cx[j + k - nf], cu[j + k - nf]


@njit(cache=True, inline="always")
def _c_time(k, j, tc, c0):
    """C's time [s] from output point k to the plan's end."""
    nf = c0.shape[1]
    return c0[2, k] if k < nf else tc[j + k - nf]


@njit(cache=True, nogil=True)
def _interval_ok(k, j, grid_data, first, x, u, v, floor, check_end, keep0, keep1):
    """Whether every row holds at the check points of output interval k from (x, u) with u_{k+1} = v, the
    limits times ``keep0`` at its start to ``keep1`` at its end (linear between; the end point's order-2 rows
    and bounds only with ``check_end``)."""
    r2, r3, px, pc = grid_data[0], grid_data[1], grid_data[2], grid_data[3]
    nq = pc.shape[1]
    if u < 0.0 < v and x - DIP_SAFETY * u * u * pc[0, nq - 1, k] / (v - u) < floor:
        return False  # x dips below the floor where u crosses 0 between the check points
    for q in range(nq):
        cxu, cxv, lam, dp = pc[0, q, k], pc[1, q, k], pc[2, q, k], pc[3, q, k]
        keep = keep0 + (keep1 - keep0) * q / (nq - 1)
        xp = x + 2.0 * u * cxu + 2.0 * (v - u) * cxv
        up = u + lam * (v - u)
        if q > 0 and (q < nq - 1 or check_end):
            if xp < floor or xp > px[q, k] * keep * keep:
                return False
            if not _rows2_within(r2, q, k, xp, up, keep):
                return False
        if xp > 0.0 and np.isfinite(dp):
            sx = np.sqrt(xp)
            for r in range(r3.shape[3]):
                if abs(sx * (r3[0, q, k, r] * dp * (v - u) + r3[1, q, k, r] * up + r3[2, q, k, r] * xp
                             + r3[3, q, k, r])) > keep * r3[4, q, k, r] * (1.0 + ROW_SLACK):
                    return False
    return True


@njit(cache=True, inline="always")
def _rows2_within(r2, q, k, x, u, keep):
    """lo keep <= a u + b x + c <= hi keep on the order-2 rows r2 (a, b, c, lo, hi) at check point q of output
    interval k."""
    for r in range(r2.shape[3]):
        val = r2[0, q, k, r] * u + r2[1, q, k, r] * x + r2[2, q, k, r]
        lo, hi = r2[3, q, k, r], r2[4, q, k, r]
        slack = ROW_SLACK * (abs(lo) + abs(hi))
        if val > keep * hi + slack or val < keep * lo - slack:
            return False
    return True


@njit(cache=True, inline="always")
def _start_keep(k, keep, first):
    """The share of the limits kept at output point k: ``keep``, but from the state to grid point j (the first
    output points) what the state itself takes (first[0]; the state is given) fading to ``keep`` along that
    stretch (first[1]: its points' fractions of it)."""
    pos = first[1]
    return first[0] + (keep - first[0]) * pos[k] if k < pos.shape[0] - 1 else keep


@njit(cache=True, nogil=True)
def _bounds(k, j, grid_data, first, x, u, floor):
    """(least, largest) u_{k+1} that output interval k's check points allow from (x, u) at its start, and the
    interval's (w0, w1); (inf, -inf) when none. The order-3 rows at the middle and the end take sqrt(x) at its
    largest over the range: conservative for every u_{k+1} in it."""
    low, high, ok = -np.inf, np.inf, True
    r2, r3, px, pc = grid_data[0], grid_data[1], grid_data[2], grid_data[3]
    nq = pc.shape[1]
    keep0 = _start_keep(k, 1.0 - PASS_MARGIN, first)
    keep1 = _start_keep(k + 1, 1.0 - PASS_MARGIN, first)
    for q in range(1, nq):
        keep = keep0 + (keep1 - keep0) * q / (nq - 1)
        cxu, cxv, lam = pc[0, q, k], pc[1, q, k], pc[2, q, k]
        base = x + 2.0 * u * (cxu - cxv)  # x there = base + 2 cxv v
        low, high, ok2 = _cut(low, high, 2.0 * cxv, floor - base, keep * keep * px[q, k] - base)
        ok = ok and ok2
        for r in range(r2.shape[3]):
            a, b, c, lo, hi = r2[0, q, k, r], r2[1, q, k, r], r2[2, q, k, r], r2[3, q, k, r], r2[4, q, k, r]
            rest = a * u * (1.0 - lam) + b * base + c
            low, high, ok2 = _cut(low, high, a * lam + 2.0 * b * cxv, keep * lo - rest, keep * hi - rest)
            ok = ok and ok2
    if not ok or low > high:
        return np.inf, -np.inf, 0.0, 0.0
    for q in range(nq):
        keep = keep0 + (keep1 - keep0) * q / (nq - 1)
        cxu, cxv, lam, dp = pc[0, q, k], pc[1, q, k], pc[2, q, k], pc[3, q, k]
        base = x + 2.0 * u * (cxu - cxv)
        top = base + 2.0 * cxv * high
        if top <= 0.0 or not np.isfinite(dp):
            continue
        sx = np.sqrt(top)
        for r in range(r3.shape[3]):
            a3, a, b, c, lim = r3[0, q, k, r], r3[1, q, k, r], r3[2, q, k, r], r3[3, q, k, r], r3[4, q, k, r]
            rest = -a3 * dp * u + a * u * (1.0 - lam) + b * base + c
            low, high, ok2 = _cut(low, high, a3 * dp + a * lam + 2.0 * b * cxv, -keep * lim / sx - rest,
                                  keep * lim / sx - rest)
            ok = ok and ok2
    if not ok or low > high:
        return np.inf, -np.inf, 0.0, 0.0
    cxu, cxv = pc[0, nq - 1, k], pc[1, nq - 1, k]
    if u < 0.0:  # x dips where u crosses 0 inside the interval: not below the floor; u_{k+1} <= 0 has no dip
        dip = u + DIP_SAFETY * u * u * cxu / max(x - floor, 1e-300)
        if dip > 0.0 and high < dip:
            high = min(high, 0.0)
        elif dip > 0.0:
            low = max(low, dip)
        if low > high:
            return np.inf, -np.inf, 0.0, 0.0
    return low, high, cxu - cxv, cxv


@njit(cache=True, nogil=True)
def _merge(k, x, u, n, last, j, grid_data, first, c0, floor, tc, budget, out_x, out_u, write):
    """The merge from output point k (state x, u) into C over n intervals: its time [s] (chords: x linear per
    interval), or nan when a row fails or when its time plus C's from where it stands reaches ``budget`` [s]
    (``last``: the output point where the motion rests; tc: C's time to the end from each grid point).
    ``write``: its points into out_x, out_u."""
    xc, uc = _ceiling(k, j, grid_data, c0)
    d, e = u - uc, x - xc
    sa, sb = 0.0, 0.0
    pc = grid_data[3]
    nq = pc.shape[1]
    for i in range(n):
        a0, a1 = i / n, (i + 1) / n
        cxu, cxv = pc[0, nq - 1, k + i], pc[1, nq - 1, k + i]
        sa += (cxu - cxv) * (1.0 - a0) + cxv * (1.0 - a1)
        sb += (cxu - cxv) * a0 * (1.0 - a0) + cxv * a1 * (1.0 - a1)
    if sb <= 0.0:
        return np.nan
    alpha = -(e + 2.0 * d * sa) / (2.0 * sb)
    xi, ui, time = x, u, 0.0
    keep = _start_keep(k, 1.0 - PASS_MARGIN, first)
    for i in range(n):
        p = k + i + 1
        s = (i + 1) / n
        xcp, ucp = _ceiling(p, j, grid_data, c0)
        v = ucp + d * (1.0 - s) + alpha * s * (1.0 - s)
        if i == n - 1:
            v = ucp
        # the margin fades out along the merge: it ends on the ceiling, which keeps the limits in full (from the
        # state itself, what the state takes)
        if not _interval_ok(k + i, j, grid_data, first, xi, ui, v, floor, p < last and i < n - 1,
                            keep + (1.0 - keep) * i / n, keep + (1.0 - keep) * s):
            return np.nan
        cxu, cxv = pc[0, nq - 1, k + i], pc[1, nq - 1, k + i]
        x1 = xcp if i == n - 1 else xi + 2.0 * ui * cxu + 2.0 * (v - ui) * cxv
        if write:
            out_x[p], out_u[p] = x1, v
        time += 2.0 * cxu / (np.sqrt(xi) + np.sqrt(x1))
        if time + _c_time(p, j, tc, c0) >= budget:
            return np.nan
        xi, ui = x1, v
    return time


#: The walk goes on this many points after the point of the best merge [-].
STALL = 5
#: ... and on after that while its time so far plus C's from its point is below the best total by this fraction
#: (a merge from further on may still gain that much); a walk the rows stop there gives no answer [-].
WALK_GAIN = 0.02
#: Bisection steps of the largest step from which the descent still stays below C [-].
BISECTION_STEPS = 6
#: x above C's by more than this fraction counts as above C [-].
CROSS = 1e-9


@njit(cache=True, nogil=True)
def _descend(k, x, u, last, j, grid_data, first, c0, floor, out_x, out_u, write):
    """The descent from output point k: u turned towards C's as fast as the rows allow (the least step while
    above C) until it lies on or below C with u <= u_C there. Returns (m, x_m, u_m, time [s]) at that point,
    m = -1 when it crosses above C (having been below) or the rows admit no step first. ``write``: its points
    into out_x, out_u."""
    xc, uc = _ceiling(k, j, grid_data, c0)
    above = x > xc * (1.0 + CROSS)
    time = 0.0
    for i in range(k, last):
        xc, uc = _ceiling(i, j, grid_data, c0)
        if x <= xc * (1.0 + CROSS):
            if u <= uc:
                return i, x, u, time
            above = False
        elif not above:
            return -1, x, u, time
        if i == last - 1:
            break
        lo, hi, w0, w1 = _bounds(i, j, grid_data, first, x, u, floor)
        if lo > hi:
            break
        _, ucn = _ceiling(i + 1, j, grid_data, c0)
        v = lo if x > xc * (1.0 + CROSS) else max(lo, min(hi, ucn))
        x1, dt = _pass_step(i, j, grid_data, first, x, u, v, w0, w1, floor)
        if dt < 0.0:
            break
        time += dt
        x, u = x1, v
        if write:
            out_x[i + 1], out_u[i + 1] = x, u
    return -1, x, u, time


@njit(cache=True, nogil=True)
def _rows2_right(k, j, grid_data, first, x, u):
    """The order-2 rows at output point k >= 1 seen from the interval after it (they differ from the end
    point's at breaks and knots; the first output points lie inside a plan interval); true at the grid's last
    point."""
    r2 = grid_data[0]
    if k < first[1].shape[0] - 1 or k >= r2.shape[2]:
        return True
    return _rows2_within(r2, 0, k, x, u, 1.0 - PASS_MARGIN)


@njit(cache=True, nogil=True)
def _pass_step(k, j, grid_data, first, x, u, v, w0, w1, floor):
    """The pass's interval k with end acceleration ``v``: (x at k + 1, its time [s]) when every row holds at
    the pass's margin (and the order-2 rows at k + 1), else (x at k + 1, -1.0)."""
    x1 = x + 2.0 * (w0 * u + w1 * v)
    if not _interval_ok(k, j, grid_data, first, x, u, v, floor, True, _start_keep(k, 1.0 - PASS_MARGIN, first),
                        _start_keep(k + 1, 1.0 - PASS_MARGIN, first)) or not _rows2_right(k + 1, j, grid_data,
                                                                                         first, x1, v):
        return x1, -1.0
    return x1, 2.0 * (w0 + w1) / (np.sqrt(x) + np.sqrt(x1))


@njit(cache=True, nogil=True)
def _largest_safe(k, x, u, lo, hi, w0, w1, last, j, grid_data, first, c0, floor, out_x, out_u):
    """The largest u_{k+1} in [the descent's own step, hi] (of output interval k from (x, u), weights w0, w1)
    from which the descent still ends on or below C: hi, else by BISECTION_STEPS bisections. Returns (u_{k+1},
    the descent from there: (m, x_m, u_m, time), m = -2 where it was not computed)."""
    got = _descend(k + 1, x + 2.0 * (w0 * u + w1 * hi), hi, last, j, grid_data, first, c0, floor, out_x, out_u,
                   False)
    if got[0] >= 0:
        return hi, got
    _, ucn = _ceiling(k + 1, j, grid_data, c0)
    low, top = max(lo, min(hi, ucn)), hi  # the descent's own step ends below C
    kept = (-2, 0.0, 0.0, 0.0)
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (low + top)
        got = _descend(k + 1, x + 2.0 * (w0 * u + w1 * mid), mid, last, j, grid_data, first, c0, floor, out_x,
                       out_u, False)
        if got[0] >= 0:
            low, kept = mid, got
        else:
            top = mid
    return low, kept


@njit(cache=True, nogil=True)
def forward(grid_data, first, tc, j, nxt, x0, u0, c0, lengths, out_x, out_u, merge_from=0):
    """The pass from the state (x0, u0) (output point 0) over the output points 1.. = grid points j.. up to
    the rest point ``nxt`` (grid index): fills out_x, out_u up to the best merge's end and returns (its total
    time [s], the first output point from which the profile is C's); (inf, -1) when no merge is found.
    ``grid_data``: (r2, r3, px, pc, cx, cu): the rows at the check points of every output interval, the first F
    (from the state to grid point j: JerkPass._first) and the plan's from grid interval j on, stacked (r2 (5, Q,
    N, m2): a, b, c, lo, hi; r3 (5, Q, N, m3): a3, a, b, c, lim; px (Q, N); pc (4, Q, N): JerkPass's), and C's x
    and u on the grid (JerkPass.cx, cu); ``first``: (the state's share of the limits, JerkPass._state_share; the
    first output points' fractions of the stretch to grid point j (F + 1,)); tc (K,): C's time to the end from
    each grid point; c0 (3, F): C's x, u and time to the end at the first output points.

    The walk: below C the largest step from which the descent still ends on or below C (the largest step the
    rows allow, else a bisection down to the descent's own step; that step where even the descent crosses above
    C), above C the least step. At every point of the walk, the merges of every length from there and from where
    its descent ends are candidates; the one of the least total time (walk, descent, merge, C's rest) is taken.
    The walk ends STALL points after the best merge's point once its time plus C's from there is within
    WALK_GAIN of the best total; stopped by the rows before that, it gives no answer. Merges start at output
    points >= ``merge_from`` (JerkPass.first_points)."""
    last = nxt - j + first[1].shape[0] - 1
    floor = X_FLOOR * x0
    x, u = x0, u0
    out_x[0], out_u[0] = x0, u0
    if not _rows2_within(grid_data[0], 0, 0, x0, u0, first[0]):
        return np.inf, -1  # the state breaks a limit itself
    best_t, best_k, best_m, best_n, t, trapped = np.inf, -1, -1, 0, 0.0, np.inf
    known = (-2, 0.0, 0.0, 0.0)  # the descent from the walk's next point, where _largest_safe computed it
    for k in range(last):
        m, xd, ud, td = known if known[0] != -2 else _descend(k, x, u, last, j, grid_data, first, c0, floor, out_x,
                                                               out_u, False)
        known = (-2, 0.0, 0.0, 0.0)
        for start in range(2):
            s0, sx, su, st = (k, x, u, 0.0) if start == 0 else (m, xd, ud, td)
            if start == 1 and m <= k:
                break
            if s0 < merge_from:
                continue
            for n in lengths:
                if s0 + n > last:
                    break
                tm = _merge(s0, sx, su, n, last, j, grid_data, first, c0, floor, tc, best_t - t - st, out_x,
                            out_u, False)
                if np.isfinite(tm) and t + st + tm + _c_time(s0 + n, j, tc, c0) < best_t:
                    best_t, best_k, best_m, best_n = t + st + tm + _c_time(s0 + n, j, tc, c0), k, s0, n
        if k == last - 1 or (best_k >= 0 and k - best_k > STALL
                             and t + _c_time(k, j, tc, c0) > (1.0 - WALK_GAIN) * best_t):
            break
        lo, hi, w0, w1 = _bounds(k, j, grid_data, first, x, u, floor)
        trapped = t + _c_time(k, j, tc, c0)  # where the walk ends when no step follows
        if lo > hi:
            break
        xc, _ = _ceiling(k, j, grid_data, c0)
        if x > xc * (1.0 + CROSS):
            v = lo
        elif m < 0:  # the descent crosses above C: its own step (the merges from above C may still end on it)
            v = max(lo, min(hi, _ceiling(k + 1, j, grid_data, c0)[1]))
        else:
            v, known = _largest_safe(k, x, u, lo, hi, w0, w1, last, j, grid_data, first, c0, floor, out_x, out_u)
        x1, dt = _pass_step(k, j, grid_data, first, x, u, v, w0, w1, floor)
        if dt < 0.0:
            break
        t += dt
        x, u = x1, v
        out_x[k + 1], out_u[k + 1] = x, u
        trapped = np.inf
    if best_k < 0 or trapped < (1.0 - WALK_GAIN) * best_t:
        return np.inf, -1  # none, or the walk stopped where a merge further on might still gain WALK_GAIN
    if best_m > best_k:
        _descend(best_k, out_x[best_k], out_u[best_k], last, j, grid_data, first, c0, floor, out_x, out_u,
                 True)
    _merge(best_m, out_x[best_m], out_u[best_m], best_n, last, j, grid_data, first, c0, floor, tc, np.inf,
           out_x, out_u, True)
    return best_t, best_m + best_n
