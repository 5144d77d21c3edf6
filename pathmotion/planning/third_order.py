"""Third-order limits (joint jerk, torque rate): sequential linear programming over the whole grid.

Variables x_k = theta_dot^2 and u_k = theta_ddot at the grid points, u linear between them in the
stretched coordinate xi of planning/smooth.py (the cube root of the distance to a rest point next
to one, theta elsewhere): x_{k+1} = x_k + 2 (w0_k u_k + w1_k u_{k+1}) and du/dtheta at each end of
an interval are linear in u, and the constant-jerk S-curve start from rest (x ~ s^(4/3), zero
acceleration at rest) is represented exactly (profile.py's smooth profile).

Third-order rows |sqrt(x) L(x, u, u')| <= lim, L linear, i.e. |L| <= lim / sqrt(x): the right side
is convex in x, so its tangent at x_ref lies below it, and
    |L| <= lim (1.5 / sqrt(x_ref) - 0.5 x / x_ref^1.5)
is a conservative linear form, exact at x_ref: every iterate meets the true limits at the grid
points. The first x_ref is the second-order (TOPP-RA) optimum (an upper bound of every profile
that also meets the third-order limits). Each LP minimizes the duration linearized at x_ref
(sum w_k x_k, w = dT/dx) with the trust region x <= (1 + rho) x_ref, solved by HiGHS (sparse);
a step that lengthens the motion is rejected and rho shrinks. Stop when the duration changes by
less than THIRD_ORDER_TOLERANCE.
"""

from __future__ import annotations

import logging
import os
import sys
from types import SimpleNamespace

import numpy as np

from .. import defaults
from ..errors import InfeasibleError
from .limit_rows import limit_rows
from .limits import EffectiveLimits, PathPoints
from . import smooth
from .profile import Profile

log = logging.getLogger(__name__)

#: x_ref below this fraction of its largest value is raised to it (keeps the tangents finite) [-].
X_REF_FLOOR = 1e-6
#: After the first LP, x_ref is the incumbent itself, raised only to this fraction of its largest value
#: where it is smaller (x next to a rest point can be 1e-12 of it on the graded grid) [-].
X_REF_MIN = 1e-14
#: Trust region: x_k <= (1 + rho) x_ref_k, rho starts here and shrinks by RHO_SHRINK on a rejected step.
RHO_START = 1.0
RHO_SHRINK = 0.25
RHO_MIN = 1e-3
#: HiGHS primal and dual feasibility tolerance on the scaled, row-normalized LP: rows next to a rest
#: point span many decades, and at the default 1e-7 an incumbent could exceed its jerk row by 20 %.
LP_TOLERANCE = 1e-10
#: Row generation: a pool row enters the LP when its slack at a solution is below this, in units of its
#: largest coefficient on the scaled variables (which are ~1 at the linearization point) [-].
ROW_MARGIN = 0.02
#: Row generation: at most this many solves of one LP (each adds the rows its solution violates) [-].
MAX_ROW_ROUNDS = 50
#: Row generation: at most this many rows per grid point enter in one round [-].
ROWS_PER_ROUND = 4
#: The duration's discretization error is estimated as this times the larger change of the duration from
#: the grid to its two nested coarse grids (even and odd points; _nested_estimate) [-]. Measured
#: (benchmarks/bench_third_order.py; verified plans, the planner adds the tightening's change): the error
#: against the converged reference was 0.07-0.24 of the estimate on the benchmark's circle cases (jerk 10x and 4x
#: the acceleration limits; 50, 100, 200 grid points) and 0.41-0.73 on the benchmark's 5 splines: the
#: change alone does not track the error (the grid's alignment with the profile's switches moves it).
ERROR_FACTOR = 8.0
#: HiGHS's Devex pricing: dual steepest edge (its default) first computes a weight for every row of a
#: hot-started basis, which costs more than the few pivots that then remain.
DEVEX = 1


class _Points:
    """Points where the LP imposes the limits. Point p lies in grid interval ``interval[p]``, and x, u and
    u' = du/dtheta there are linear in that interval's three variables ``cols[p]`` = (x at one of its
    ends, u_i, u_{i+1}) with the coefficients ``cx``, ``cu``, ``cd`` (P, 3). ``src`` (PathPoints) and
    ``src_scale`` {name: (M, m)} hold the path data and the limits' scales, the points being ``src``'s
    rows ``idx`` (P,); ``group`` (P,): an id per point (row generation adds a few rows per point)."""

    def __init__(self, cols, cx, cu, cd, src, src_scale, idx, group, interval):
        self.cols, self.cx, self.cu, self.cd = cols, cx, cu, cd
        self.src, self.src_scale, self.idx, self.group, self.interval = src, src_scale, idx, group, interval


def _node_points(p: "_Problem", src, scale: dict, side: str, idx: np.ndarray) -> _Points:
    """The grid points ``idx`` as an end of an interval: ``side`` "right" (interval idx after each point,
    path data ``src`` = the right side) or "left" (interval idx - 1 before it, ``src`` the left side)."""
    k, n = p.k, len(idx)
    i = idx if side == "right" else idx - 1
    du = (p.du_lo if side == "right" else p.du_hi)[i]
    cx, cu = np.zeros((n, 3)), np.zeros((n, 3))
    cx[:, 0] = 1.0
    cu[:, 1 if side == "right" else 2] = 1.0
    cd = np.column_stack([np.zeros(n), -du, du])
    return _Points(np.column_stack([idx, k + i, k + i + 1]), cx, cu, cd, src, scale, idx, idx, i)


class _Problem:
    """The LP data that do not change between iterations (for one set of limit scales)."""

    def __init__(self, grid, samp, limits: EffectiveLimits, scale, rest, fixed, periodic, fixed_u=None):
        self.grid, self.samp, self.limits, self.scale = grid, samp, limits, scale
        self.k = k = len(grid)
        self.d = d = np.diff(grid)
        self.rest = rest
        start_rest, end_rest = rest[:-1], rest[1:]
        both = np.nonzero(start_rest & end_rest)[0]
        if both.size:
            i = int(both[0])
            raise InfeasibleError(f"the motion must stop at both theta = {grid[i]:.6g} and {grid[i + 1]:.6g} with "
                                  "no grid point between; raise grid_points")
        origin, sign = smooth.coordinates(grid, rest)
        xi_lo, xi_hi, w0, w1 = smooth.weights(grid, origin, sign)
        self.origin, self.sign, self.xi_lo, self.xi_hi = origin, sign, xi_lo, xi_hi
        self.w0, self.w1 = w0, w1
        # d u / d theta at each end of each interval, per unit of (u_{i+1} - u_i)
        with np.errstate(divide="ignore"):  # infinite at a rest point, where no row is imposed
            self.du_lo = 1.0 / (smooth.dtheta_dxi(sign, xi_lo) * (xi_hi - xi_lo))
            self.du_hi = 1.0 / (smooth.dtheta_dxi(sign, xi_hi) * (xi_hi - xi_lo))
        self._equalities(periodic)
        # bounds on x: the order-1 limits, rests and fixed ends
        right = limit_rows(samp.right, limits, scale, defaults.PLANNER_X_CAP)
        left = limit_rows(samp.left, limits, scale, defaults.PLANNER_X_CAP)
        x_hi = np.minimum(right.x_max, left.x_max)
        self.x_lo, self.x_hi = np.zeros(k), x_hi
        self.x_lo[rest] = self.x_hi[rest] = 0.0
        for idx, value in fixed.items():
            if value > x_hi[idx] * (1 + 1e-9):
                raise InfeasibleError(f"the boundary theta_dot {np.sqrt(value):.6g} at theta = {grid[idx]:.6g} "
                                      f"exceeds the largest the limits allow there ({np.sqrt(x_hi[idx]):.6g})")
            self.x_lo[idx] = self.x_hi[idx] = value
        rest_theta = grid[rest]
        length = grid[-1] - grid[0]
        self.rest_distance = (np.min(np.abs(grid[:, None] - rest_theta[None, :]), axis=1) if rest_theta.size
                              else np.full(k, length))
        self.rest_distance = np.clip(self.rest_distance, np.min(d), length)
        self.u_lo = np.where(rest, 0.0, -np.inf)
        self.u_hi = np.where(rest, 0.0, np.inf)
        for idx, value in (fixed_u or {}).items():  # a given theta_ddot (re-timing from a moving state)
            self.u_lo[idx] = self.u_hi[idx] = value
        self._row_points(samp, scale, right, left)
        self.quadrature = _Quadrature(self)

    def _equalities(self, periodic: bool) -> None:
        """x_{i+1} = x_i + 2 (w0 u_i + w1 u_{i+1}), and periodicity, as eq_cols, eq_coef (E, 4) (every row
        has four entries), b_eq (E,) = 0."""
        k = self.k
        i = np.arange(k - 1)
        cols = np.column_stack([i, i + 1, k + i, k + i + 1])
        coef = np.column_stack([-np.ones(k - 1), np.ones(k - 1), -2.0 * self.w0, -2.0 * self.w1])
        if periodic:
            cols = np.vstack([cols, [[0, k - 1, 0, 0], [k, 2 * k - 1, k, k]]])
            coef = np.vstack([coef, [[1.0, -1.0, 0.0, 0.0], [1.0, -1.0, 0.0, 0.0]]])
        self.eq_cols, self.eq_coef, self.b_eq = cols, coef, np.zeros(len(cols))

    def _row_points(self, samp, scale, right, left) -> None:
        """The points of the inequality rows and the rows that stay fixed (limits not linearized at x_ref):
        the order-2 rows at every moving grid point (the left side's only where its path data differ:
        breaks, knots, the last point), from the rows ``right``, ``left`` already built; the third-order
        rows' x_ref-free part (a3 u' + a u + b x) at both ends of every interval."""
        k, moving = self.k, ~self.rest
        self.nodes_r = _node_points(self, samp.right, scale, "right", np.nonzero(moving[:-1])[0])
        left_idx = np.arange(1, k)
        self.nodes_l = _node_points(self, samp.left, scale, "left", left_idx[moving[1:]])
        same = np.ones(k, bool)
        for r, l in ((right.a, left.a), (right.b, left.b), (right.c, left.c), (right.lo, left.lo), (right.hi, left.hi)):
            same &= np.all((r == l) | (np.isnan(r) & np.isnan(l)), axis=1)
        same[-1] = False
        self.left_differs = ~same[self.nodes_l.idx]
        self.fixed_limits = [lim for lim in self.limits if lim.order < 3 and not lim.relinearize]
        self.moving_limits = [lim for lim in self.limits if lim.order < 3 and lim.relinearize]
        fixed = np.isin(right.row_kind, [lim.name for lim in self.fixed_limits])
        self.static = self._order2(self.fixed_limits, None, [_columns(rows, fixed) for rows in (right, left)])
        self.third = [(pts, lim.rows3(pts.src, pts.src_scale[lim.name]))
                      for lim in self.limits if lim.order == 3 for pts in (self.nodes_r, self.nodes_l)]
        self.third = [(pts, _third_base(pts, r3)) for pts, r3 in self.third]

    def _order2(self, limits, x_ref, given=None) -> list:
        """Row blocks (cols, coef, rhs, group) of the order-2 ``limits`` at the moving grid points (the
        left side's only where its path data differ: breaks, knots, the last point); x_ref (K,) or None;
        given: their rows (a, b, c, lo, hi) on the right and left sides, when already built."""
        if not limits:
            return []
        out = []
        for side, pts in enumerate((self.nodes_r, self.nodes_l)):
            rows = given[side] if given else limit_rows(pts.src, limits, pts.src_scale, defaults.PLANNER_X_CAP, x_ref)
            sel = pts.idx
            keep_pt = self.left_differs if pts is self.nodes_l else np.ones(len(sel), bool)
            a, b, c, lo, hi = (v[sel][keep_pt] for v in (rows.a, rows.b, rows.c, rows.lo, rows.hi))
            cx, cu, cols, group = pts.cx[keep_pt], pts.cu[keep_pt], pts.cols[keep_pt], pts.group[keep_pt]
            for sign, rhs in ((1.0, hi - c), (-1.0, c - lo)):
                keep = np.isfinite(rhs) & ((a != 0) | (b != 0))
                coef = sign * (b[..., None] * cx[:, None, :] + a[..., None] * cu[:, None, :])
                pick = np.nonzero(keep)
                out.append((cols[pick[0]], coef[keep], rhs[keep], group[pick[0]]))
        return out

    def blocks(self, x_ref: np.ndarray) -> list:
        """Every inequality row block (cols, coef, rhs, group) at the linearization point x_ref (K,) (1 at
        rest points)."""
        out = list(self.static)
        out += self._order2(self.moving_limits, x_ref)
        for pts, (base, c, lim) in self.third:
            xr = x_ref[pts.idx][:, None]
            big, slope = 1.5 * lim / np.sqrt(xr), 0.5 * lim / xr**1.5
            tangent = slope[..., None] * pts.cx[:, None, :]
            cols = np.broadcast_to(pts.cols[:, None, :], base.shape).reshape(-1, 3)
            group = np.broadcast_to(pts.group[:, None], c.shape).ravel()
            for sign in (1.0, -1.0):
                out.append((cols, (sign * base + tangent).reshape(-1, 3), (big - sign * c).ravel(), group))
        return out


def _columns(rows, mask: np.ndarray):
    """The LimitRows ``rows``' columns ``mask`` (m,) as (a, b, c, lo, hi)."""
    return SimpleNamespace(**{n: getattr(rows, n)[:, mask] for n in ("a", "b", "c", "lo", "hi")})


def _third_base(pts: _Points, rows3) -> tuple:
    """(base (P, m, 3), c (P, m), lim (P, m)): a third-order row |sqrt(x) L| <= lim at the points, L = a3 u'
    + a u + b x + c, with a3 u' + a u + b x written on the points' three variables (coefficients base)."""
    sel = pts.idx
    a3, a, b, c, lim = (np.asarray(v)[sel] for v in rows3)
    base = a3[..., None] * pts.cd[:, None, :] + a[..., None] * pts.cu[:, None, :] + b[..., None] * pts.cx[:, None, :]
    return base, c, lim


def _assemble(p: _Problem, x_ref: np.ndarray):
    """The inequality pool coef . z[cols] <= rhs: cols, coef (R, 3) (every row has three entries, on
    the variables of its point), rhs (R,) and each row's group (R,)."""
    blocks = p.blocks(x_ref)
    return tuple(np.concatenate([b[j] for b in blocks]) for j in range(4))


#: Gauss-Legendre nodes and weights on [0, 1] for the duration and its gradient.
_GL_T, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_T, _GL_W = 0.5 * (_GL_T + 1.0), 0.5 * _GL_W


class _Quadrature:
    """The smooth profile's duration T = sum_i int dtheta / sqrt(x(theta)) by Gauss-Legendre quadrature
    in each interval's xi (as profile.py), at fixed nodes: x at node q is linear in its interval's
    three variables, x_q = cx_q . z[cols_q], written from the interval's end nearer to its rest point
    (the equality rows make both forms equal; this one stays finite next to a rest point, where
    x ~ xi^4), and T = sum_q wq_q / sqrt(x_q)."""

    def __init__(self, p: "_Problem"):
        k, g = p.k, len(_GL_T)
        i = np.repeat(np.arange(k - 1), g)
        o, sg, lo, dxi = p.origin[i], p.sign[i], p.grid[i], (p.xi_hi - p.xi_lo)[i]
        xi = p.xi_lo[i] + np.tile(_GL_T, k - 1) * dxi
        th = np.clip(smooth.theta_of(o, sg, xi), lo, p.grid[i + 1])
        self.wq = np.tile(_GL_W, k - 1) * smooth.dtheta_dxi(sg, xi) * dxi
        integral = 2.0 * smooth.xi_integral(o, sg, lo, th) / dxi
        self.cx = np.column_stack([np.ones_like(th), 2.0 * (th - lo) - integral, integral])
        right = sg < 0  # next to a rest point after the interval: from x_{i+1}
        self.cx[right, 1] -= 2.0 * p.w0[i[right]]
        self.cx[right, 2] -= 2.0 * p.w1[i[right]]
        self.cols = np.column_stack([np.where(right, i + 1, i), k + i, k + i + 1])
        self.rest, self.n = p.rest, 2 * k

    def _rate(self, z: np.ndarray, power: float) -> np.ndarray:
        x = np.einsum("qj,qj->q", self.cx, z[self.cols])
        with np.errstate(divide="ignore", invalid="ignore"):
            f = self.wq / np.maximum(x, 0.0) ** power
        return np.where(np.isfinite(f), f, 0.0) if power > 1 else f

    def duration(self, x: np.ndarray, u: np.ndarray) -> float:
        return float(np.sum(self._rate(np.concatenate([x, u]), 0.5)))

    def gradient(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(dT/dx, dT/du) (2K,); entries of points at rest are 0 (those variables are fixed)."""
        f = -0.5 * self._rate(np.concatenate([x, u]), 1.5)
        g = np.bincount(self.cols.ravel(), weights=(f[:, None] * self.cx).ravel(), minlength=self.n)
        g[:self.n // 2][self.rest] = 0.0
        g[self.n // 2:][self.rest] = 0.0
        return g


class _Lp:
    """The sequence of LPs of one solve, on one HiGHS instance, by row generation with hot starts.

    Every LP has the same pool of inequality rows (only their values change with the linearization
    point), and few of them are ever near active (one joint's jerk at a time, the torque of a few).
    Each LP is solved on the rows generated so far (all equalities and the pool rows that were ever
    added); while its solution violates a pool row, the tightest rows within ROW_MARGIN of each grid
    point are added to the model in place (HiGHS keeps its basis, the new rows basic) and it is solved
    again, so the result is the optimum of the full LP. A new LP (new values) is passed whole and
    starts from the previous LP's optimal basis: a few dual simplex pivots."""

    def __init__(self):
        self.highs = _silent_highs()
        for key, value in (("primal_feasibility_tolerance", LP_TOLERANCE), ("dual_feasibility_tolerance", LP_TOLERANCE),
                           ("threads", 1), ("presolve", "off"),
                           ("simplex_dual_edge_weight_strategy", DEVEX)):
            self.highs.setOptionValue(key, value)
        self.order = np.zeros(0, int)  # pool rows in the model, in the model's order
        self.pool_size = None
        self.basis = None  # the last optimal HighsBasis
        self.status = ""

    def solve(self, c, a_eq, b_eq, cols, coef, b_ub, nodes, col_lo, col_hi, z0=None) -> np.ndarray | None:
        """argmin c.z s.t. a_eq z = b_eq, the pool coef . z[cols] <= b_ub, col_lo <= z <= col_hi; None
        unless optimal. a_eq: (cols, coef) (E, 4) of the equality rows; cols, coef (R, 3); every row
        scaled to unit largest coefficient (ROW_MARGIN is in those units); nodes (R,): the group (grid
        point) of each pool row (each round adds at most ROWS_PER_ROUND rows per group). z0: a point
        near the solution (scaled variables), or None: on a model without pool rows, the rows nearly
        active there enter before the first solve (fewer rounds)."""
        if self.pool_size != len(b_ub):
            self.order, self.pool_size, self.basis = np.zeros(0, int), len(b_ub), None
        active = np.zeros(self.pool_size, bool)
        if z0 is not None and not len(self.order):
            self.order = _tightest(np.nonzero(b_ub - np.einsum("rj,rj->r", coef, z0[cols]) < ROW_MARGIN)[0],
                                   b_ub - np.einsum("rj,rj->r", coef, z0[cols]), nodes)
        active[self.order] = True
        self._pass(c, a_eq, b_eq, cols, coef, b_ub, col_lo, col_hi)
        h = self.highs
        for _ in range(MAX_ROW_ROUNDS):
            h.run()
            status = h.getModelStatus()
            self.status = h.modelStatusToString(status)
            if status != _highspy().HighsModelStatus.kOptimal:
                return None
            z = np.array(h.getSolution().col_value)
            slack = b_ub - np.einsum("rj,rj->r", coef, z[cols])
            if not (slack[~active] < -LP_TOLERANCE).any():
                self.basis = h.getBasis()
                return z
            new = _tightest(np.nonzero(~active & (slack < ROW_MARGIN))[0], slack, nodes)
            active[new] = True
            self.order = np.concatenate([self.order, new])
            start, index, value = _csr_rows(cols[new], coef[new])
            h.addRows(len(new), np.full(len(new), -np.inf), b_ub[new], len(value), start, index, value)
        self.status = f"not settled after {MAX_ROW_ROUNDS} rounds of row generation"
        return None

    def _pass(self, c, a_eq, b_eq, cols, coef, b_ub, col_lo, col_hi) -> None:
        """Pass the LP on the equalities and the pool rows ``self.order``, with the last optimal basis."""
        rows = self.order
        start, index, value = _csr_rows(cols[rows], coef[rows])
        eq_start, eq_index, eq_value = _csr_rows(*a_eq)
        eq_start = np.append(eq_start, len(eq_value))
        n_row, n_col = len(b_eq) + len(rows), len(c)
        hs = _highspy()
        lp = hs.HighsLp()
        lp.num_col_, lp.num_row_ = n_col, n_row
        lp.col_cost_, lp.col_lower_, lp.col_upper_ = c, col_lo, col_hi
        lp.row_lower_ = np.concatenate([b_eq, np.full(len(rows), -np.inf)])
        lp.row_upper_ = np.concatenate([b_eq, b_ub[rows]])
        m = lp.a_matrix_
        m.format_, m.num_col_, m.num_row_ = hs.MatrixFormat.kRowwise, n_col, n_row
        m.start_ = np.concatenate([eq_start[:-1], eq_start[-1] + start, [eq_start[-1] + len(value)]])
        m.index_, m.value_ = np.concatenate([eq_index, index]), np.concatenate([eq_value, value])
        self.highs.passModel(lp)
        if self.basis is not None:
            self.highs.setBasis(self.basis)




def _tightest(cand: np.ndarray, slack: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The ROWS_PER_ROUND rows of least slack of each group among the pool rows ``cand``."""
    order = cand[np.lexsort((slack[cand], nodes[cand]))]
    first = np.unique(nodes[order], return_index=True)[1]
    rank = np.arange(len(order)) - np.repeat(first, np.diff(np.append(first, len(order))))
    return order[rank < ROWS_PER_ROUND]


_BANNER_SHOWN = []
#: Key of the solve's _Lp in the grid data's cache (PathPoints._cache).
_LP_KEY = "third_order_lp"


_HIGHSPY = []


def _highspy():
    """highspy, imported on first use (only plans with third-order limits need it)."""
    if not _HIGHSPY:
        import highspy

        _HIGHSPY.append(highspy)
    return _HIGHSPY[0]


def _silent_highs():
    """A HiGHS instance with its output off. Its first construction in a process prints a banner on the
    standard output before any option can be set; that one is sent to the null device."""
    if _BANNER_SHOWN:
        h = _highspy().Highs()
    else:
        sys.stdout.flush()
        saved = os.dup(1)
        try:
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                h = _highspy().Highs()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        _BANNER_SHOWN.append(True)
    h.setOptionValue("output_flag", False)
    return h


def _solve_scaled(p: _Problem, lp: _Lp, cols, coef, b_ub, nodes, w, bounds, x_ref, z0=None):
    """The LP in scaled variables x_k = x_ref_k y_k, u_k = x_ref_k / r_k v_k (r_k the distance to the
    nearest rest point: u ~ x / r on an S-curve), so that x near a rest point (1e-9 and less on the
    graded grid) is resolved to the solver's relative tolerance; rows rescaled to unit largest
    coefficient. Returns the solution in the original variables, None unless optimal."""
    col = np.concatenate([x_ref, x_ref / p.rest_distance])
    coef = coef * col[cols]
    norm = np.abs(coef).max(axis=1)
    norm = np.where(norm > 0, norm, 1.0)
    coef /= norm[:, None]
    eq_coef = p.eq_coef * col[p.eq_cols]
    eq_coef /= np.abs(eq_coef).max(axis=1, keepdims=True)
    c = w * col
    c = c / max(np.max(np.abs(c)), 1e-300)
    z = lp.solve(c, (p.eq_cols, eq_coef), p.b_eq, cols, coef, b_ub / norm, nodes, bounds[:, 0] / col,
                 bounds[:, 1] / col, None if z0 is None else z0 / col)
    return None if z is None else z * col


def _csr_rows(cols: np.ndarray, coef: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start, index, value) of rows cols, coef (R, m) in row-wise sparse form, zeros left out."""
    nonzero = coef != 0
    start = np.concatenate([[0], np.cumsum(nonzero.sum(axis=1))[:-1]]) if len(coef) else np.zeros(0, int)
    return start, cols[nonzero], coef[nonzero]


def _chain_u(p: _Problem, x: np.ndarray) -> np.ndarray | None:
    """u (K,) of a smooth profile from its x (K,) on this grid: the equality rows solved forward from
    the first point (at rest: u = 0), u_{i+1} = ((x_{i+1} - x_i) / 2 - w0_i u_i) / w1_i, u = 0 at rest
    points. None when the first point is not at rest (u_0 unknown) or x has another length."""
    if len(x) != p.k or not p.rest[0]:
        return None
    u = np.zeros(p.k)
    for i in range(p.k - 1):
        if not p.rest[i + 1]:
            u[i + 1] = (0.5 * (x[i + 1] - x[i]) - p.w0[i] * u[i]) / p.w1[i]
    return u if np.all(np.isfinite(u)) else None


def _s_curve_cap(p: _Problem) -> np.ndarray:
    """x (K,) of the constant-jerk S-curve from the nearest rest point, x = (4.5 j d^2)^(2/3) with the
    path jerk j = min_j J_j / |Phi'_j| at that rest point (inf where no jerk row bounds it): the
    linearization point starts below it, near the exact start (far above it, the first tangents
    would crush the profile next to rest into a poorer local optimum)."""
    cap = np.full(p.k, np.inf)
    for rows3 in (lim.rows3(p.samp.right, p.scale[lim.name]) for lim in p.limits if lim.order == 3):
        for r in np.nonzero(p.rest)[0]:
            with np.errstate(divide="ignore"):
                j = np.min(rows3.lim[r] / np.abs(rows3.a3[r]))
            if np.isfinite(j):
                cap = np.minimum(cap, (4.5 * j * (p.grid - p.grid[r]) ** 2) ** (2.0 / 3.0))
    return cap


def solve_third_order(grid, samp, limits: EffectiveLimits, scale: dict, x_start: np.ndarray, rest: np.ndarray,
                      fixed: dict, periodic: bool, tolerance: float = defaults.THIRD_ORDER_TOLERANCE,
                      max_iterations: int = defaults.THIRD_ORDER_ITERATIONS, smooth_start: bool = False
                      ) -> tuple[Profile, int, float | None]:
    """The smooth time-optimal profile (Profile with u_nodes), the LP count and the estimate of the
    duration's discretization error [s] (:func:`_nested_estimate`; None with ``smooth_start``, or where
    the grid is too small to nest).

    x_start (K,): the linearization point of the first LP (the second-order optimum, or with
    ``smooth_start`` a smooth solution on this grid, e.g. before the limits were tightened: then the
    first LP already minimizes the linearized duration from it, in the trust region); rest (K,) bool:
    points where the motion is at rest (x = u = 0); fixed {index: x}: boundary values."""
    p = _Problem(grid, samp, limits, scale, rest, fixed, periodic)
    # one HiGHS instance per grid's path data: a re-solve after tightening (same grid, same rows, other
    # values) starts from the last optimal basis and the rows generated so far
    lp = samp.right._cache.setdefault(_LP_KEY, _Lp())
    u_start = _chain_u(p, x_start) if smooth_start else None
    if u_start is not None:
        return (*_slp(p, lp, x_start, u_start, tolerance, max_iterations), None)
    profile, lps = _slp(p, lp, np.minimum(x_start, _s_curve_cap(p)), None, tolerance, max_iterations)
    estimate, c_lps = _nested_estimate(p, samp, limits, scale, fixed, periodic, profile, tolerance)
    return profile, lps + c_lps, estimate


def solve_from_state(grid, samp, limits: EffectiveLimits, scale: dict, x_start: np.ndarray, rest: np.ndarray,
                     fixed: dict, fixed_u: dict, tolerance: float = defaults.THIRD_ORDER_TOLERANCE,
                     max_iterations: int = defaults.THIRD_ORDER_ITERATIONS) -> tuple[Profile, int]:
    """The smooth time-optimal profile with x and u given at some points (``fixed`` and ``fixed_u``
    {index: value}; planning/retime.py starts it at the measured state), linearized first around
    ``x_start`` (K,) (the second-order optimum from that state; capped by the S-curve next to the rest points,
    as :func:`solve_third_order` does); (profile, LP count). No error estimate."""
    p = _Problem(grid, samp, limits, scale, rest, fixed, False, fixed_u)
    return _slp(p, _Lp(), np.minimum(x_start, _s_curve_cap(p)), None, tolerance, max_iterations)


def _nested_estimate(p: _Problem, samp, limits, scale, fixed, periodic, profile: Profile,
                     tolerance) -> tuple[float | None, int]:
    """(error estimate [s], LP count): the profile solved again on the two nested coarse grids (the even
    and the odd points, each with the points where the motion rests or the path data differ on the
    two sides), each from ``profile`` there; the estimate is ERROR_FACTOR times the larger change of the
    duration (one LP each). (None, 0) when a coarse grid would not be smaller by a third, or has no solution."""
    r, l = samp.right, samp.left
    always = p.rest | np.any((r.dq != l.dq) | (r.ddq != l.ddq) | (r.dddq != l.dddq), axis=1)
    always[[0, -1]] = True
    always[list(fixed)] = True
    change, lps = 0.0, 0
    for parity in (0, 1):
        keep = always.copy()
        keep[parity::2] = True
        idx = np.nonzero(keep)[0]
        if len(idx) > 2 * p.k // 3 or len(idx) < 5:
            return None, lps
        sides = _Sides(_subset(r, idx), _subset(l, idx))
        c_fixed = {int(np.searchsorted(idx, i)): v for i, v in fixed.items()}
        try:
            cp = _Problem(p.grid[idx], sides, limits, {n: v[idx] for n, v in scale.items()}, p.rest[idx], c_fixed,
                          periodic)
            # one LP: from the fine profile it takes the coarse grid's step; the next ones would confirm it
            coarse, n = _slp(cp, _Lp(), profile.x[idx], profile.u_nodes[idx], tolerance, 1, own_grid=False)
        except InfeasibleError as err:
            log.debug("third-order: no profile on a nested coarse grid (%s): no error estimate", err)
            return None, lps
        lps += n
        change = max(change, abs(coarse.duration - profile.duration))
        log.debug("third-order: %d points %.6g s, nested %d points %.6g s", p.k, profile.duration, len(idx),
                  coarse.duration)
    return ERROR_FACTOR * change, lps


class _Sides:
    """Path data seen from both sides of each grid point (as the planner's sampled grid data)."""

    def __init__(self, right, left):
        self.right, self.left = right, left


def _subset(points: PathPoints, idx: np.ndarray) -> PathPoints:
    """``points`` at the grid points ``idx``, with every per-point quantity already derived (the third
    derivative, reduced dynamics, ...) taken from its cache."""
    k = len(points.theta)
    points.dddq  # noqa: B018 (computed once, kept in the cache)
    out = PathPoints(points.robot, points.path, points.theta[idx], points.q[idx], points.dq[idx], points.ddq[idx],
                     side=points.side)

    def per_point(v):
        return isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == k

    for key, value in points._cache.items():
        if per_point(value):
            out._cache[key] = value[idx]
        elif isinstance(value, tuple) and value and all(per_point(v) for v in value):
            out._cache[key] = tuple(v[idx] for v in value)
    return out


def _slp(p: _Problem, lp: _Lp, x_start: np.ndarray, u_start: np.ndarray | None, tolerance: float,
         max_iterations: int, own_grid: bool = True) -> tuple[Profile, int]:
    """The sequential LP on ``p`` from x_start (K,), with u_start (K,) a smooth start (else the first LP
    keeps x_start's shape): (profile, LP count). ``own_grid`` False: the smooth start comes from another
    grid (it need not nearly meet this grid's rows), and the first LP's trust region does not bound x
    from below."""
    rest = p.rest
    floor = X_REF_FLOOR * max(np.max(x_start), 1e-12)
    x_ref = np.where(rest, 0.0, np.maximum(np.minimum(x_start, p.x_hi), floor))
    best, best_t, rho = None, np.inf, RHO_START
    lps = 0
    for _ in range(max_iterations):
        xr = np.where(rest, 1.0, x_ref)
        cols, coef, b_ub, nodes = _assemble(p, xr)
        x_lo = p.x_lo
        if best is None and u_start is not None:  # from a smooth profile: its linearized duration
            w = p.quadrature.gradient(x_start, u_start)
            if own_grid:
                x_lo = np.maximum(p.x_lo, np.where(rest, 0.0, x_ref / (1.0 + rho)))
        elif best is None:
            # first LP, from the second-order optimum (no consistent u, not feasible): keep its shape,
            # every point's x counts relative to x_ref (a linearized duration would trade regions
            # against each other far outside its range of validity)
            w = np.concatenate([np.where(rest, 0.0, -1.0 / xr), np.zeros(p.k)])
        else:
            w = p.quadrature.gradient(best[0], best[1])
            x_lo = np.maximum(p.x_lo, np.where(rest, 0.0, x_ref / (1.0 + rho)))
        x_hi = np.where(rest, 0.0, np.minimum(p.x_hi, (1.0 + rho) * x_ref))
        x_hi = np.maximum(x_hi, x_lo)
        bounds = np.column_stack([np.concatenate([x_lo, p.u_lo]), np.concatenate([x_hi, p.u_hi])])
        z0 = None
        if best is None:  # the rows nearly active at the start enter the LP before its first solve
            u0 = u_start if u_start is not None else np.where(rest, 0.0, 0.5 * np.gradient(x_ref, p.grid))
            z0 = np.concatenate([x_ref, u0])
        z = _solve_scaled(p, lp, cols, coef, b_ub, nodes, w, bounds, xr, z0)
        lps += 1
        if z is None:
            log.debug("third-order LP %d: %s", lps, lp.status)
            if best is not None:
                break
            raise InfeasibleError(f"third-order limits: no smooth profile meets the limits (the LP is {lp.status}); "
                                  "relax the jerk or torque-rate limits")
        x, u = np.maximum(z[:p.k], 0.0), z[p.k:]
        x[rest] = 0.0
        u[rest] = 0.0
        t = p.quadrature.duration(x, u)
        if t < best_t:
            change = (best_t - t) / t
            best, best_t, x_ref = (x, u), t, np.where(rest, 0.0, np.maximum(x, X_REF_MIN * np.max(x)))
            log.debug("third-order LP %d: duration %.6g s (rho %.3g)", lps, t, rho)
            if change < tolerance:
                break
        else:
            log.debug("third-order LP %d: duration %.6g s rejected (rho %.3g)", lps, t, rho)
            rho *= RHO_SHRINK
            if rho < RHO_MIN:
                break
    if best is None:
        raise InfeasibleError(f"third-order limits: none of {lps} LPs gave a profile with a finite duration; "
                              "raise grid_points or relax the jerk or torque-rate limits")
    return Profile(p.grid, best[0], best[1]), lps
