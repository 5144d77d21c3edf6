"""Certified verification: an upper bound of every limit's ratio on every grid interval, at a cost
that grows with the grid, not with the motion's duration (the dense 0.1 ms resample of verify.py
does; it stays as the independent check and as ``verify = "dense"``).

On grid interval i (width h) the profile is analytic: theta_ddot = u_i constant, x = theta_dot^2
linear in theta, x' = 2 u_i. Each limit is bounded by one of two means (its
:meth:`Limit.certify_row_form`, or the sampled form where that gives none or does not hold).

Row form (velocity, acceleration, torque, TCP speed; no path evaluation, no RNEA): the limited value
is v = a(theta) u + b(theta) x + c(theta) with path coefficients a, b, c known at the grid points
(for a speed limit the squared ratio, v = G x with G = (gain / limit)^2). v is exact at both ends
of the interval (the planner's grid data, each end seen from inside the interval), and with
|v''| <= M between them, v and -v each lie below their chord plus M s (h - s) / 2 (s = theta - theta_i),
so |v| is at most the largest value of that parabola: the larger end value where the chord rises by
more than M h^2 / 2, else its vertex (:func:`_chord_bound`); never more than the form that ignores
the ends' difference, max(|v(theta_i)|, |v(theta_i+1)|) + h^2 / 8 M. v'' = a'' u + b'' x + 4 b' u + c''.
The coefficients' derivatives come from the grid data: the slope s = (p_i+1 - p_i) / h equals p'
somewhere in the interval; a second divided difference D at grid point k equals p'' somewhere in the
two intervals around k (never taken across a segment connection). max |p''| on an interval is
REMAINDER_SAFETY x the largest |D| at the four grid points around it, and |b'| <= |s| + h max |b''|.

Safety argument: a, b, c are smooth functions of theta that vary on the scale of the path's segments
and spline spans, not of one grid interval, so p'' changes across four grid intervals by much less
than itself, and the factor 2 covers a doubling. Where p'' is not continuous (a spline knot: Phi'''
jumps, so Phi'' has a kink of slope jump J) inside the interval, the kink splits J / h between the
two second differences at its ends, and h^2 / 8 x 2 (D_i + D_i+1) = J h / 4 is the largest
interpolation error of such a kink (so the sum of those two also enters the maximum). The planner's
grids hold every knot, so no interval holds one inside; the second difference at a knot then measures
the kink besides the curvature. Where a limit knows its coefficient's slope jump there
(``RowForm.knot_jumps``: the jump of Phi''' for the acceleration's Phi'', M times it for the torque's
beta) it is subtracted, and D is the curvature on the two sides again. An interval with no second
difference on either side (a segment one interval long) is sampled instead.

Sampled form (the base class's default, e.g. the torque-speed envelope): the limit's own ``ratios``
at S + 1 points uniform in theta (both ends reuse the grid data, tau = alpha u + beta x + gamma; each
interior point costs one path evaluation and one RNEA, compiled and batched in fast_rnea.py), plus REMAINDER_SAFETY x the largest second
difference of the samples (widened by the third difference) / 8.

Each limit's row form is one compiled kernel call (:func:`row_bounds`). The sampled form runs once
per pass for all limits together (:func:`certify`): on the union of the intervals any limit samples,
each limit reading its intervals' rows. Every sample and every
interval's bound depends on its own interval only, so this equals sampling each limit on its own
(bit for bit), at one path evaluation and one RNEA batch per pass instead of one per limit.

tests/test_planning_certify.py checks both forms against the dense resample, interval by interval,
on random splines and limit sets.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numba import njit

from .. import defaults
from ..lift.joint_path import JointPath
from ..robot import Robot, rnea
from .fast_rnea import rnea_batch, supported
from . import smooth
from .profile import Profile
from .reduced import torque_derivative
from .trajectory import Samples

#: Sub-intervals per grid interval of the sampled form: S + 1 samples (both ends included) [-].
CERTIFY_SUBDIVISIONS = 4
#: Sub-intervals of the sampled form where the row form's bound exceeds REFINE_ABOVE (few intervals) [-].
REFINE_SUBDIVISIONS = 16
#: Row-form bounds above this ratio are refined by the sampled form: where the verify-and-tighten loop
#: starts to tighten at the default limit tolerance (below it no refinement pays) [-].
REFINE_ABOVE = 1.0 + defaults.TIGHTEN_TRIGGER * defaults.LIMIT_TOLERANCE
#: Sub-intervals per grid interval of a smooth (third-order) profile's sampled form, uniform in xi [-].
SMOOTH_SUBDIVISIONS = 4
#: Factor on the estimated second derivatives in the remainder terms [-].
REMAINDER_SAFETY = 2.0


@dataclass(frozen=True, eq=False)
class IntervalSamples:
    """Samples at S + 1 points of each grid interval in ``index`` (I,), flattened row-major:
    ``samples`` has N = I (S + 1) rows; :meth:`per_interval` reshapes (N, m) to (I, S + 1, m)."""

    samples: Samples
    index: np.ndarray
    points: int

    @property
    def intervals(self) -> int:
        return len(self.index)

    def per_interval(self, values: np.ndarray) -> np.ndarray:
        return np.asarray(values).reshape(self.intervals, self.points, -1)


@dataclass(eq=False)
class CertifyContext:
    """What a limit certifies itself from: the ``profile`` (its grid has K points), the grid data
    ``right``/``left`` (PathPoints on that grid, seen from the interval after / before each point),
    ``breaks`` (indices of segment connections on the grid), the path and the robot. ``only``:
    restrict the sampled form to these intervals (None: all)."""

    path: JointPath
    robot: Robot | None
    profile: Profile
    right: object
    left: object
    breaks: tuple[int, ...]
    needs_torque: bool
    _samples: dict = field(default_factory=dict)
    #: A smooth profile's samples also carry the torque rate (a torque-rate limit is active).
    torque_rate: bool = False

    @property
    def h(self) -> np.ndarray:
        return np.diff(self.profile.grid)

    def samples(self, index: np.ndarray | None = None, subdivisions: int = CERTIFY_SUBDIVISIONS,
                torque: np.ndarray | None = None) -> IntervalSamples:
        """Interval samples (sampled form) on the intervals ``index`` (all when None), computed once
        (torques only when ``needs_torque``; on a piecewise-constant profile only on the intervals
        ``index[torque]`` when given, NaN elsewhere)."""
        k1 = len(self.profile.grid) - 1
        index = np.arange(k1) if index is None else np.asarray(index, int)
        key = (index.tobytes(), subdivisions, self.needs_torque, None if torque is None else torque.tobytes())
        if key not in self._samples:
            if self.profile.smooth:
                self._samples[key] = smooth_interval_samples(self, index, subdivisions)
            else:
                self._samples[key] = interval_samples(self, index, subdivisions, torque)
        return self._samples[key]

    @cached_property
    def smooth_point(self) -> np.ndarray:
        """(K,) True where the path is smooth through the grid point (not a segment connection or an end)."""
        ok = np.ones(len(self.profile.grid), dtype=bool)
        ok[[0, -1]] = False
        ok[list(self.breaks)] = False
        return ok

    @cached_property
    def knots(self) -> tuple[np.ndarray, np.ndarray]:
        """The path's spline knots on the grid (``path.knots``; the planner's grids hold them all,
        planning/grid.py): their indices (k,) and the jump of Phi''' there (k, n), right minus left, from
        the grid data: Phi'' of a cubic spline is linear between knots, so the slopes of Phi'' over the two
        intervals at a knot are Phi''' on its two sides (exact; two path evaluations cost more than the rest
        of the row form)."""
        grid = self.profile.grid
        knots = np.asarray(getattr(self.path, "knots", ()), float)
        at = np.minimum(np.searchsorted(grid, knots), len(grid) - 1)
        g = at[(grid[at] == knots) & (at > 0) & (at < len(grid) - 1)]
        r, l = self.right.ddq, self.left.ddq
        after = (l[g + 1] - r[g]) / (grid[g + 1] - grid[g])[:, None]
        before = (l[g] - r[g - 1]) / (grid[g] - grid[g - 1])[:, None]
        return g, after - before


def row_bounds(ctx: CertifyContext, forms: dict) -> dict:
    """{name: (bound (K - 1, m), valid (K - 1,))}: the row-form bound of every limit's ratio on every
    interval and the intervals it holds on (the rest need the sampled form), for the row forms ``forms``
    {name: RowForm}; one :func:`_row_kernel` call per limit (all its coefficients in one pass)."""
    p, smooth = ctx.profile, ctx.smooth_point
    h = np.diff(p.grid)
    valid = smooth[:-1] | smooth[1:]
    out = {}
    for name, f in forms.items():
        pairs = [f.a, f.b, f.c]
        some = next(pair for pair in pairs if pair is not None)  # stands in for the absent ones (not read)
        arrays = [np.ascontiguousarray(side, dtype=float) for pair in pairs for side in (pair or some)]
        m = arrays[0].shape[1]
        index = ctx.knots[0] if any(j is not None for j in f.knot_jumps) else np.zeros(0, np.int64)
        jumps = np.zeros((3, len(index), m))
        for q, j in enumerate(f.knot_jumps):
            if j is not None and len(index):
                jumps[q] = j
        bound = np.empty((len(h), m))
        _row_kernel(*arrays, f.a is not None, f.b is not None, f.c is not None, h, p.u, p.x, smooth,
                    index.astype(np.int64), jumps, REMAINDER_SAFETY, bound)
        bound /= np.asarray(f.limit, float)
        out[name] = (np.sqrt(np.maximum(bound, 0.0)) if f.squared else bound, valid)
    return out


@njit(cache=True, nogil=True)
def _row_kernel(ar, al, br, bl, cr, cl, use_a, use_b, use_c, h, u, x, smooth, knots, jumps, safety, out):
    """Row-form bound ``out`` (K - 1, m) of |a u + b x + c| on every interval (module docstring) from the
    coefficients' (right, left) values (K, m) at the grid points (``use_*`` False: that coefficient is 0
    and its arrays are not read); ``smooth`` (K,): where second differences are taken; ``jumps`` (3, k, m):
    the slope jump of a, b, c at the grid points ``knots`` (k,), subtracted from the second difference there.
    :func:`_chord_bound` of the two end values and the curvature term
    a''|u| + b'' max x + 4 |b'| |u| + c'', each p'' ``safety`` x the largest second difference D at the grid
    points i - 1 .. i + 2 (or the sum of the two at its ends: a kink inside); D is 0 where ``smooth`` is
    False; |b'| <= |slope| + h max |b''|. One function: numba did not inline helpers
    taking arrays, and their calls cost 5x the arithmetic."""
    k1, m = out.shape
    use = (use_a, use_b, use_c)
    inv_h = 1.0 / h
    inv_mid = np.zeros(k1 + 1)  # 1 / the mean step at each grid point where a second difference is taken
    for g in range(1, k1):
        if smooth[g]:
            inv_mid[g] = 2.0 / (h[g] + h[g - 1])
    slope, d, m2 = np.zeros((3, k1)), np.zeros((3, k1 + 1)), np.zeros(3)
    for j in range(m):
        for q in range(3):
            if use[q]:
                pr, pl = (ar, al) if q == 0 else ((br, bl) if q == 1 else (cr, cl))
                for i in range(k1):
                    slope[q, i] = (pl[i + 1, j] - pr[i, j]) * inv_h[i]
                for g in range(1, k1):
                    d[q, g] = abs(slope[q, g] - slope[q, g - 1]) * inv_mid[g]
                for n in range(len(knots)):
                    g = knots[n]
                    d[q, g] = abs(slope[q, g] - slope[q, g - 1] - jumps[q, n, j]) * inv_mid[g]
        for i in range(k1):
            for q in range(3):
                top = d[q, i] + d[q, i + 1]
                if i > 0 and d[q, i - 1] > top:
                    top = d[q, i - 1]
                if i + 2 <= k1 and d[q, i + 2] > top:
                    top = d[q, i + 2]
                m2[q] = safety * top
            v0 = v1 = 0.0
            if use_a:
                v0 += ar[i, j] * u[i]
                v1 += al[i + 1, j] * u[i]
            if use_b:
                v0 += br[i, j] * x[i]
                v1 += bl[i + 1, j] * x[i + 1]
            if use_c:
                v0 += cr[i, j]
                v1 += cl[i + 1, j]
            au = abs(u[i])
            bend = m2[0] * au + m2[1] * max(x[i], x[i + 1]) + 4.0 * (abs(slope[1, i]) + h[i] * m2[1]) * au + m2[2]
            out[i, j] = _chord_bound(v0, v1, 0.5 * bend * h[i] * h[i])


@njit(cache=True, nogil=True)
def _chord_bound(v0, v1, a):
    """max over t in [0, 1] of |v| for v with end values v0, v1 and |v''| <= 2 ``a`` (in t): each of v and
    -v lies below its chord plus a t (1 - t), whose maximum is the larger end where the chord's rise
    exceeds a, else the parabola's vertex, e0 + (d + a)^2 / (4 a). At most max(|v0|, |v1|) + a / 4."""
    d = v1 - v0
    if a > abs(d):
        return max(v0 + (d + a) ** 2 / (4.0 * a), -v0 + (a - d) ** 2 / (4.0 * a))
    return max(abs(v0), abs(v1))


def interval_state(profile: Profile, index: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta_dot, theta_ddot, t), each (I, P), at s = theta - theta_i (I, P) inside the intervals ``index``
    (I,); interval-aware, so the end of interval i uses u_i (not the next interval's)."""
    x0, u = profile.x[index][:, None], profile.u[index][:, None]
    v0, v = np.sqrt(x0), np.sqrt(np.maximum(x0 + 2.0 * u * s, 0.0))
    den = v0 + v  # 0 only where both speeds are (s = 0 at a stop): dt 0 there
    dt = 2.0 * s / np.where(den > 0, den, np.inf)
    return v, np.repeat(u, s.shape[1], axis=1), profile.times[index][:, None] + dt


def interval_samples(ctx: CertifyContext, index: np.ndarray, subdivisions: int = CERTIFY_SUBDIVISIONS,
                     torque: np.ndarray | None = None) -> IntervalSamples:
    """Samples at the S + 1 points of the intervals ``index`` of the profile's grid; the ends come from
    the grid data ``ctx.right``/``ctx.left``, torques only when ``ctx.needs_torque`` (and a robot), and
    then only on the intervals ``index[torque]`` when given (NaN on the others)."""
    grid, path, robot = ctx.profile.grid, ctx.path, ctx.robot
    k1, S, n = len(index), int(subdivisions), path.n
    s = (grid[index + 1] - grid[index])[:, None] * (np.arange(S + 1) / S)[None, :]
    theta = grid[index, None] + s
    theta[:, -1] = grid[index + 1]
    q, dq, ddq = np.empty((3, k1, S + 1, n))
    r, l = ctx.right, ctx.left
    for arr, pr, pl in ((q, r.q, l.q), (dq, r.dq, l.dq), (ddq, r.ddq, l.ddq)):
        arr[:, 0], arr[:, -1] = pr[index], pl[index + 1]
    if S > 1:
        inner = path.evaluate(theta[:, 1:-1].ravel())
        for arr, value in zip((q, dq, ddq), inner):
            arr[:, 1:-1] = value.reshape(k1, S - 1, n)
    theta_dot, theta_ddot, t = interval_state(ctx.profile, index, s)
    qd = dq * theta_dot[..., None]
    qdd = dq * theta_ddot[..., None] + ddq * (theta_dot**2)[..., None]
    tau = None
    if ctx.needs_torque and robot is not None:
        w = slice(None) if torque is None else np.asarray(torque, int)
        tau = np.empty((k1, S + 1, n)) if torque is None else np.full((k1, S + 1, n), np.nan)
        if S > 1:
            inverse = rnea_batch if supported(robot) else rnea
            tau[w, 1:-1] = inverse(robot, q[w, 1:-1].reshape(-1, n), qd[w, 1:-1].reshape(-1, n),
                                   qdd[w, 1:-1].reshape(-1, n)).reshape(-1, S - 1, n)
        tau[w, 0] = _grid_torque(r, index[w], theta_ddot[w, 0], theta_dot[w, 0] ** 2)
        tau[w, -1] = _grid_torque(l, index[w] + 1, theta_ddot[w, -1], theta_dot[w, -1] ** 2)
    size = k1 * (S + 1)
    samples = Samples(t.reshape(size), theta.reshape(size), theta_dot.reshape(size), theta_ddot.reshape(size),
                      q.reshape(size, n), qd.reshape(size, n), qdd.reshape(size, n),
                      None if tau is None else tau.reshape(size, n))
    return IntervalSamples(samples, index, S + 1)


def smooth_interval_samples(ctx: CertifyContext, index: np.ndarray, subdivisions: int = SMOOTH_SUBDIVISIONS
                            ) -> IntervalSamples:
    """Samples of a smooth (third-order) profile at S + 1 points of each interval in ``index``, uniform
    in the interval's stretched coordinate xi (planning/smooth.py), in which theta_ddot is linear and
    the S-curve next to a rest point is a polynomial: every limit's value is a smooth function of xi
    there, as the sampled form's remainder needs. The profile's state (x, theta_ddot, theta_dddot) is
    exact at every sample; the ends reuse the grid data (Phi''' from both sides of a knot), interior
    points evaluate the path to third order (joint jerk qddd), the torque, and the torque rate when
    ``ctx.torque_rate``. ``t`` is the interval's start time (the ratios do not read it)."""
    p, path, robot = ctx.profile, ctx.path, ctx.robot
    grid = p.grid
    k1, S, n = len(index), int(subdivisions), path.n
    origin, sign = p.coords
    index = np.ascontiguousarray(index, np.int64)
    theta, x, u, jerk = smooth.interval_samples(grid, p.x, p.u_nodes, origin, sign, index, S)
    r, l = ctx.right, ctx.left
    inner = _interior_path(ctx, theta[:, 1:-1].ravel()) if S > 1 else (np.empty((0, n)),) * 4
    c = lambda a: np.ascontiguousarray(a, float)  # noqa: E731
    q, qd, qdd, qddd, v = _smooth_samples_kernel(index, S, x, u, jerk, c(r.q), c(r.dq), c(r.ddq), c(r.dddq),
                                                 c(l.q), c(l.dq), c(l.ddq), c(l.dddq), *(c(a) for a in inner))
    flat = lambda a: a.reshape(k1 * (S + 1))  # noqa: E731
    tau = tau_dot = None
    if ctx.needs_torque and robot is not None:
        tau = (rnea_batch if supported(robot) else rnea)(robot, q, qd, qdd)
        if ctx.torque_rate:
            tau_dot = torque_derivative(robot, q, qd, qdd, qddd)
    t = np.broadcast_to(p.times[index, None], theta.shape)
    samples = Samples(flat(t), flat(theta), v, flat(u), q, qd, qdd, tau, flat(jerk), qddd, tau_dot)
    return IntervalSamples(samples, index, S + 1)


@njit(cache=True, nogil=True, error_model="numpy")
def _smooth_samples_kernel(index, subdivisions, x, u, jerk, rq, rdq, rddq, rdddq, lq, ldq, lddq, ldddq,
                           iq, idq, iddq, idddq):
    """:func:`smooth_interval_samples`' joint motion, sample by sample (I (S + 1) rows, interval by interval): the
    path data at an interval's start from the right side ``r*`` (K, n), at its end from the left side ``l*``, inside
    from ``i*`` (I (S - 1), n); v = sqrt(x), qd = Phi' v, qdd = Phi' u + Phi'' x, qddd = Phi' jerk + 3 Phi'' (v u)
    + Phi''' (x v): the operations of their array form, in the same order. Returns (q, qd, qdd, qddd (N, n), v (N,))."""
    pts, n = subdivisions + 1, rq.shape[1]
    size = index.shape[0] * pts
    q, qd, qdd, qddd = np.empty((size, n)), np.empty((size, n)), np.empty((size, n)), np.empty((size, n))
    v = np.empty(size)
    for p in range(index.shape[0]):
        i = index[p]
        for s in range(pts):
            row = p * pts + s
            xx, uu, jj = x[p, s], u[p, s], jerk[p, s]
            vv = np.sqrt(xx)
            v[row] = vv
            vu, xv = vv * uu, xx * vv
            for col in range(n):
                if s == 0:
                    a0, a1, a2, a3 = rq[i, col], rdq[i, col], rddq[i, col], rdddq[i, col]
                elif s == subdivisions:
                    a0, a1, a2, a3 = lq[i + 1, col], ldq[i + 1, col], lddq[i + 1, col], ldddq[i + 1, col]
                else:
                    m = p * (subdivisions - 1) + s - 1
                    a0, a1, a2, a3 = iq[m, col], idq[m, col], iddq[m, col], idddq[m, col]
                q[row, col] = a0
                qd[row, col] = a1 * vv
                qdd[row, col] = a1 * uu + a2 * xx
                qddd[row, col] = a1 * jj + 3.0 * a2 * vu + a3 * xv
    return q, qd, qdd, qddd, v


def _interior_path(ctx: CertifyContext, theta: np.ndarray) -> tuple:
    """path.evaluate3 at ``theta`` (the samples inside the intervals), kept with the grid data
    (``ctx.right``'s cache): a verify-and-tighten re-solve on the same grid samples the same points."""
    cache = getattr(ctx.right, "_cache", {})
    key = ("smooth_certify_interior", theta.tobytes())
    if key not in cache:
        cache[key] = ctx.path.evaluate3(theta)
    return cache[key]


def _grid_torque(points, index: np.ndarray, u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """tau = alpha u + beta x + gamma at the grid points ``index`` from the cached reduced dynamics."""
    from .limits.torque import reduced

    alpha, beta, gamma = reduced(points)
    return alpha[index] * u[:, None] + beta[index] * x[:, None] + gamma[index]


def sampled_bound(values: np.ndarray) -> np.ndarray:
    """Upper bound (I, m) of a function sampled at S + 1 uniform points per interval, ``values``
    (I, S + 1, m): the largest sample plus the interpolation remainder (module docstring)."""
    v = np.asarray(values, float)
    top = v.max(axis=1)
    if v.shape[1] < 3:
        return top
    with np.errstate(invalid="ignore"):
        d2 = v[:, :-2] - 2.0 * v[:, 1:-1] + v[:, 2:]
        curv = np.abs(d2).max(axis=1)
        if d2.shape[1] >= 2:
            curv = curv + np.abs(np.diff(d2, axis=1)).max(axis=1)
    bound = top + REMAINDER_SAFETY * curv / 8.0
    return np.where(np.isfinite(top), bound, top)


def smooth_sampled_bound(values: np.ndarray) -> np.ndarray:
    """Upper bound (I, m) of |f| from |f| sampled at S + 1 >= 4 uniform points per interval, ``values``
    (I, S + 1, m), f smooth on the interval.

    The ratios are absolute values, and |f| has a kink where f crosses zero, which second differences
    of |f| mistake for strong curvature (a jerk falling through zero inside an interval gave a 13 %
    remainder and an endless tightening loop). So the signs are recovered first: of the S + 1 sign
    patterns with at most one change (the first sample +), the one with the smallest largest second
    difference, i.e. the smoothest f. Then for g = f and g = -f, sub-interval by sub-interval: the larger end value plus the
    interpolation remainder where g may be concave. Linear interpolation's error is -g''/2 (s - a)(b - s),
    so g rises above the chord only where g'' < 0, by at most max(-g'', 0) / 8 (a unit sub-interval);
    g'' on a sub-interval is the larger of the second differences at its two ends (one end only at the
    interval's ends) widened by the largest third difference, times REMAINDER_SAFETY."""
    v = np.ascontiguousarray(values, float)
    if v.ndim != 3 or v.shape[1] < 4:
        raise ValueError(f"smooth_sampled_bound: values of shape (I, S + 1 >= 4, m), got {v.shape}")
    return _smooth_bound_kernel(v)


@njit(cache=True, inline="always")
def _nan_max(a, b):
    """max(a, b), NaN where either is (as np.maximum and np.max)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@njit(cache=True, inline="always")
def _tame(w):
    """Whether every sample is finite and below 1e300 in size: no sum or difference of them overflows (no NaN)."""
    for s in range(w.shape[0]):
        if not abs(w[s]) <= 1e300:
            return False
    return True


@njit(cache=True, inline="always")
def _straddle(w, s, p):
    """|second difference| at sample s of the samples w with the signs + up to sample p, - after it."""
    a = w[s] if s <= p else -w[s]
    b = w[s + 1] if s + 1 <= p else -w[s + 1]
    e = w[s + 2] if s + 2 <= p else -w[s + 2]
    return abs(a - 2.0 * b + e)


@njit(cache=True, nogil=True)
def _tame_bound(w, d2):
    """_smooth_bound_kernel's bound of one column of tame samples w (S + 1,) (no NaN arises): a second difference
    whose three samples share a sign is that of w (negated: the same size), only the two that straddle a pattern's
    sign change are formed again; the bounds of g = f and g = -f in one pass (-f's second differences are f's
    negated, exactly)."""
    s1 = w.shape[0]
    for s in range(s1 - 2):
        d2[s] = w[s] - 2.0 * w[s + 1] + w[s + 2]
    pick, least = 0, np.inf
    for p in range(s1):
        rough = 0.0
        for s in range(s1 - 2):
            val = _straddle(w, s, p) if s == p - 1 or s == p else abs(d2[s])
            rough = val if s == 0 else max(rough, val)
        if rough < least:
            pick, least = p, rough
    for s in range(s1 - 2):  # f's second differences
        d2[s] = (w[s] if s <= pick else -w[s]) - 2.0 * (w[s + 1] if s + 1 <= pick else -w[s + 1]) + \
            (w[s + 2] if s + 2 <= pick else -w[s + 2])
    d3 = abs(d2[1] - d2[0])
    for s in range(1, s1 - 3):
        d3 = max(d3, abs(d2[s + 1] - d2[s]))
    top_f, top_g = 0.0, 0.0
    for k in range(s1 - 1):
        left, right = d2[max(k - 1, 0)], d2[min(k, s1 - 3)]
        f0 = w[k] if k <= pick else -w[k]
        f1 = w[k + 1] if k + 1 <= pick else -w[k + 1]
        val_f = max(f0, f1) + REMAINDER_SAFETY * max(max(-left, -right) + d3, 0.0) / 8.0
        val_g = max(-f0, -f1) + REMAINDER_SAFETY * max(max(left, right) + d3, 0.0) / 8.0
        top_f = val_f if k == 0 else max(top_f, val_f)
        top_g = val_g if k == 0 else max(top_g, val_g)
    return max(top_f, top_g)


@njit(cache=True, nogil=True)
def _smooth_bound_kernel(v):
    """:func:`smooth_sampled_bound` on ``v`` (I, S + 1 >= 4, m), interval by interval and column by column: the same
    operations in the same order (the sign pattern of the least largest second difference, the first of equal
    ones; NaN propagated as numpy's maximum does)."""
    ni, s1, m = v.shape
    out = np.empty((ni, m))
    w = np.empty(s1)
    f = np.empty(s1)
    d2 = np.empty(s1 - 2)
    for i in range(ni):
        for c in range(m):
            for s in range(s1):
                w[s] = v[i, s, c]
            top = w[0]
            for s in range(1, s1):
                top = _nan_max(top, w[s])
            if not np.isfinite(top):
                out[i, c] = top
                continue
            if _tame(w):
                out[i, c] = _tame_bound(w, d2)
                continue
            # sign patterns k = 1 .. S + 1: + on the first k samples, - after
            pick, least = 0, np.inf
            for p in range(s1):
                rough = 0.0
                for s in range(s1 - 2):
                    a = w[s] if s <= p else -w[s]
                    b = w[s + 1] if s + 1 <= p else -w[s + 1]
                    e = w[s + 2] if s + 2 <= p else -w[s + 2]
                    val = abs(a - 2.0 * b + e)
                    rough = val if s == 0 else _nan_max(rough, val)
                if not np.isfinite(rough):
                    rough = np.inf
                if rough < least:
                    pick, least = p, rough
            bound = 0.0
            for side in range(2):
                for s in range(s1):
                    fs = w[s] if s <= pick else -w[s]
                    f[s] = fs if side == 0 else -fs
                for s in range(s1 - 2):
                    d2[s] = f[s] - 2.0 * f[s + 1] + f[s + 2]
                d3 = abs(d2[1] - d2[0])
                for s in range(1, s1 - 3):
                    d3 = _nan_max(d3, abs(d2[s + 1] - d2[s]))
                g_top = 0.0
                for k in range(s1 - 1):
                    left, right = d2[max(k - 1, 0)], d2[min(k, s1 - 3)]
                    concave = _nan_max(_nan_max(-left, -right) + d3, 0.0)
                    val = _nan_max(f[k], f[k + 1]) + REMAINDER_SAFETY * concave / 8.0
                    g_top = val if k == 0 else _nan_max(g_top, val)
                bound = g_top if side == 0 else _nan_max(bound, g_top)
            out[i, c] = bound
    return out


def certify(ctx: CertifyContext, limits, accept: float | None = None) -> dict:
    """{name: (K - 1, m) certified upper bound of the ratio on every interval} per active limit; the
    samples carry torques only for the limits that need them (the views share one sample cache). A smooth
    profile (theta_ddot not constant per interval: the row form does not apply) takes the sampled form
    for every limit, on :func:`smooth_interval_samples`. ``accept`` (the verify-and-tighten loop's
    1 + limit_tolerance; piecewise-constant profiles): row-form bounds in (REFINE_ABOVE, accept] are left
    unrefined when every bound ends at or below ``accept`` (see :func:`_certify_piecewise`)."""
    if ctx.profile.smooth:
        ctx.torque_rate = ctx.torque_rate or any(lim.order == 3 and lim.needs_torque for lim in limits)
        cs = ctx.samples(subdivisions=SMOOTH_SUBDIVISIONS)
        values = [cs.per_interval(lim.ratios(cs.samples, ctx.robot)) for lim in limits]
        if not values:
            return {}
        bound = smooth_sampled_bound(np.concatenate(values, axis=2))  # every limit's columns in one pass
        cut = np.cumsum([v.shape[2] for v in values])[:-1]
        return {lim.name: b for lim, b in zip(limits, np.split(bound, cut, axis=1))}
    return _certify_piecewise(ctx, limits, accept)


def _certify_piecewise(ctx: CertifyContext, limits, accept: float | None = None) -> dict:
    """:func:`certify` of a piecewise-constant theta_ddot profile. Each limit's row form where it holds
    (:func:`row_bounds`, one kernel call per limit); the sampled form, CERTIFY_SUBDIVISIONS, where it
    does not (every interval for a limit without one) and where the row form exceeds REFINE_ABOVE;
    REFINE_SUBDIVISIONS where that sampled bound exceeds it too (the smallest of the upper bounds is kept).
    Each pass samples the union of the intervals the limits need once (:func:`_sampled_union`).

    With ``accept`` (> REFINE_ABOVE), the intervals above ``accept`` go first; those in (REFINE_ABOVE,
    accept] only when some bound is still above ``accept`` afterwards. The planner tightens (or refines
    the grid) only then, and then on every interval above REFINE_ABOVE: its decisions and the final bounds
    it acts on are those of refining everything at once (every bound is per interval), while a plan that
    passes skips the sampling that could only lower bounds already within its tolerance."""
    k1, n = len(ctx.profile.grid) - 1, ctx.path.n
    forms = {lim.name: f for lim in limits if (f := lim.certify_row_form(ctx)) is not None}
    out, rowed = {}, {}
    for name, (bound, valid) in row_bounds(ctx, forms).items():
        out[name], rowed[name] = (bound if valid.all() else np.where(valid[:, None], bound, np.inf)), valid
    for lim in limits:
        if lim.name not in out:
            out[lim.name], rowed[lim.name] = np.full((k1, lim.columns(n)), np.inf), np.zeros(k1, bool)
    top = max((float(b.max()) for b in out.values() if b.size), default=0.0)
    if top <= REFINE_ABOVE or (accept is not None and top <= accept):
        return out  # nothing above the first level: no interval would be sampled
    done = {name: np.zeros(k1, bool) for name in out}
    levels = (accept, REFINE_ABOVE) if accept is not None and accept > REFINE_ABOVE else (REFINE_ABOVE,)
    for level in levels:
        if level != levels[0] and max((float(b.max()) for b in out.values() if b.size), default=0.0) <= accept:
            break
        wanted = {name: ~done[name] & (b > level).any(axis=1) for name, b in out.items()}
        _refine(ctx, limits, wanted, rowed, out)
        for name, w in wanted.items():
            done[name] |= w
    return out


def _refine(ctx: CertifyContext, limits, wanted: dict, rowed: dict, out: dict) -> None:
    """Lower the bounds ``out`` {name: (K - 1, m)} to the sampled form's (CERTIFY_SUBDIVISIONS) on the
    intervals ``wanted`` {name: (K - 1,)}, then to REFINE_SUBDIVISIONS' where a row form held (``rowed``)
    and the bound still exceeds REFINE_ABOVE (the smaller of two upper bounds is kept)."""
    fine = {}
    for name, b in _sampled_union(ctx, limits, wanted, CERTIFY_SUBDIVISIONS).items():
        w = np.nonzero(wanted[name])[0]
        out[name][w] = np.minimum(out[name][w], b[w])
        again = wanted[name] & rowed[name] & (out[name] > REFINE_ABOVE).any(axis=1)
        if again.any():
            fine[name] = again
    for name, b in (_sampled_union(ctx, limits, fine, REFINE_SUBDIVISIONS) if fine else {}).items():
        f = np.nonzero(fine[name])[0]
        out[name][f] = np.minimum(out[name][f], b[f])


def _sampled_union(ctx: CertifyContext, limits, wanted: dict, subdivisions: int) -> dict:
    """{name: (K - 1, m) sampled-form bound on the intervals where the mask ``wanted[name]`` (K - 1,) is
    True (NaN elsewhere)} for the limits with any: one sampling of the union of those intervals (torques
    only on the intervals of the limits that need them), every limit's ratios on it and one
    :func:`sampled_bound` for all (both act sample by sample and column by column)."""
    users = [lim for lim in limits if lim.name in wanted and wanted[lim.name].any()]
    if not users:
        return {}
    mask, need = wanted[users[0].name].copy(), None
    for lim in users[1:]:
        mask |= wanted[lim.name]
    union = np.nonzero(mask)[0]
    for lim in users if ctx.needs_torque else ():
        if lim.needs_torque:
            need = wanted[lim.name].copy() if need is None else need | wanted[lim.name]
    torque = None if need is None or need.sum() == len(union) else np.nonzero(need[union])[0]
    view = ctx if ctx.needs_torque == (need is not None) else replace(ctx, needs_torque=need is not None)
    every = view.samples(union, subdivisions, torque)
    values = [every.per_interval(lim.ratios(every.samples, ctx.robot)) for lim in users]
    bound = sampled_bound(np.concatenate(values, axis=2))
    out, start = {}, 0
    for lim, v in zip(users, values):
        full = np.full((len(mask), v.shape[2]), np.nan)
        full[union] = bound[:, start:start + v.shape[2]]
        out[lim.name], start = full, start + v.shape[2]
    return out
