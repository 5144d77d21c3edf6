"""Certified verification: an upper bound of every limit's ratio on every grid interval, at a cost
that grows with the grid, not with the motion's duration (the dense 0.1 ms resample of verify.py
does; it stays as the independent check and as ``verify = "dense"``).

On grid interval i (width h) the profile is analytic: theta_ddot = u_i constant, x = theta_dot^2
linear in theta, x' = 2 u_i. Each limit is bounded by one of two means (its
:meth:`Limit.certify_row_form`, or the sampled form where that gives none or does not hold).

Row form (velocity, acceleration, torque, TCP speed; no path evaluation, no RNEA): the limited value
is v = a(theta) u + b(theta) x + c(theta) with path coefficients a, b, c known at the grid points
(for a speed limit the squared ratio, v = G x with G = (gain / limit)^2). v is exact at both ends
of the interval (the planner's grid data, each end seen from inside the interval), and between them
|v| <= max(|v(theta_i)|, |v(theta_i+1)|) + h^2 / 8 max |v''| (the error of linear interpolation),
v'' = a'' u + b'' x + 4 b' u + c''. The coefficients' derivatives come from the grid data: the slope
s = (p_i+1 - p_i) / h equals p' somewhere in the interval; a second divided difference D at grid
point k equals p'' somewhere in the two intervals around k (never taken across a segment
connection). max |p''| on an interval is REMAINDER_SAFETY x the largest |D| at the four grid points
around it, and |b'| <= |s| + h max |b''|.

Safety argument: a, b, c are smooth functions of theta that vary on the scale of the path's segments
and spline spans, not of one grid interval, so p'' changes across four grid intervals by much less
than itself, and the factor 2 covers a doubling. Where p'' is not continuous (a spline knot: Phi'''
jumps, so Phi'' has a kink of slope jump J) inside the interval, the kink splits J / h between the
two second differences at its ends, and h^2 / 8 x 2 (D_i + D_i+1) = J h / 4 is the largest
interpolation error of such a kink (so the sum of those two also enters the maximum). An interval with no
second difference on either side (a segment one interval long) is sampled instead.

Sampled form (the base class's default, e.g. the torque-speed envelope): the limit's own ``ratios``
at S + 1 points uniform in theta (both ends reuse the grid data, tau = alpha u + beta x + gamma; each
interior point costs one path evaluation and one RNEA, compiled and batched in fast_rnea.py), plus REMAINDER_SAFETY x the largest second
difference of the samples (widened by the third difference) / 8.

The sampled form runs once per pass for all limits together (:func:`certify`): on the union of the
intervals any limit samples, each limit reading its intervals' rows. Every sample and every
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
from ..joint_path import JointPath
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
#: Row-form bounds above this ratio are refined by the sampled form: half the default limit tolerance,
#: where the verify-and-tighten loop would start to tighten (below it no refinement pays) [-].
REFINE_ABOVE = 1.0 + 0.5 * defaults.LIMIT_TOLERANCE
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

    def row_bound(self, a, b, c) -> tuple[np.ndarray, np.ndarray]:
        """Row-form bound (K - 1, m) of |a u + b x + c| on every interval, and a mask (K - 1,) of the
        intervals it holds on (the rest need the sampled form). a, b, c: (right, left) pairs of (K, m)
        arrays of the coefficient at the grid points, or None for 0."""
        p = self.profile
        h, k1 = self.h, len(self.profile.grid) - 1
        m = next(pair[0].shape[1] for pair in (a, b, c) if pair is not None)
        ends0, ends1, bend = np.zeros((k1, m)), np.zeros((k1, m)), np.zeros((k1, m))
        smooth = self.smooth_point
        for kind, coeff in enumerate((a, b, c)):
            if coeff is not None:
                _row_terms(kind, np.asarray(coeff[0], float), np.asarray(coeff[1], float), h, p.u, p.x, smooth,
                           REMAINDER_SAFETY, ends0, ends1, bend)
        top = np.maximum(np.abs(ends0), np.abs(ends1))
        return top + (h**2 / 8.0)[:, None] * bend, smooth[:-1] | smooth[1:]


@njit(cache=True)
def _row_terms(kind, pr, pl, h, u, x, smooth, safety, ends0, ends1, bend):
    """Add one coefficient's part (kind 0: a, times u; 1: b, times x; 2: c) to the end values
    ``ends0``/``ends1`` and the curvature term ``bend`` (K - 1, m) of the row form (module docstring):
    p'' on interval i is ``safety`` x the largest second difference D at the grid points i - 1 .. i + 2
    (or the sum of the two at its ends: a kink inside); D is 0 at the ends and segment connections."""
    k1, m = ends0.shape
    d = np.zeros(k1 + 1)
    slope = np.empty(k1)
    for j in range(m):
        for i in range(k1):
            slope[i] = (pl[i + 1, j] - pr[i, j]) / h[i]
        for g in range(1, k1):
            d[g] = abs(slope[g] - slope[g - 1]) / (0.5 * (h[g] + h[g - 1])) if smooth[g] else 0.0
        for i in range(k1):
            m2 = d[i] + d[i + 1]
            if i > 0 and d[i - 1] > m2:
                m2 = d[i - 1]
            if i + 2 <= k1 and d[i + 2] > m2:
                m2 = d[i + 2]
            m2 *= safety
            if kind == 0:
                ends0[i, j] += pr[i, j] * u[i]
                ends1[i, j] += pl[i + 1, j] * u[i]
                bend[i, j] += m2 * abs(u[i])
            elif kind == 1:
                ends0[i, j] += pr[i, j] * x[i]
                ends1[i, j] += pl[i + 1, j] * x[i + 1]
                bend[i, j] += m2 * max(x[i], x[i + 1]) + 4.0 * (abs(slope[i]) + h[i] * m2) * abs(u[i])
            else:
                ends0[i, j] += pr[i, j]
                ends1[i, j] += pl[i + 1, j]
                bend[i, j] += m2


def interval_state(profile: Profile, i: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta_dot, theta_ddot, t) at s = theta - theta_i inside interval i (arrays of one shape);
    interval-aware, so the end of interval i uses u_i (not the next interval's)."""
    x0 = profile.x[i]
    u = profile.u[i]
    x = np.maximum(x0 + 2.0 * u * s, 0.0)
    v0, v = np.sqrt(x0), np.sqrt(x)
    den = v0 + v
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(den > 0, 2.0 * s / np.where(den > 0, den, 1.0), 0.0)
    return v, np.broadcast_to(u, np.shape(s)), profile.times[i] + dt


def interval_samples(ctx: CertifyContext, index: np.ndarray, subdivisions: int = CERTIFY_SUBDIVISIONS,
                     torque: np.ndarray | None = None) -> IntervalSamples:
    """Samples at the S + 1 points of the intervals ``index`` of the profile's grid; the ends come from
    the grid data ``ctx.right``/``ctx.left``, torques only when ``ctx.needs_torque`` (and a robot), and
    then only on the intervals ``index[torque]`` when given (NaN on the others)."""
    grid, path, robot = ctx.profile.grid, ctx.path, ctx.robot
    k1, S, n = len(index), int(subdivisions), path.n
    frac = np.arange(S + 1) / S
    i = np.repeat(index, S + 1).reshape(k1, S + 1)
    s = (grid[index + 1] - grid[index])[:, None] * frac[None, :]
    theta = grid[index, None] + s
    theta[:, -1] = grid[index + 1]
    q, dq, ddq = (np.empty((k1, S + 1, n)) for _ in range(3))
    r, l = ctx.right, ctx.left
    for arr, pr, pl in ((q, r.q, l.q), (dq, r.dq, l.dq), (ddq, r.ddq, l.ddq)):
        arr[:, 0], arr[:, -1] = pr[index], pl[index + 1]
    if S > 1:
        qi, dqi, ddqi = path.evaluate(theta[:, 1:-1].ravel())
        q[:, 1:-1], dq[:, 1:-1], ddq[:, 1:-1] = (a.reshape(k1, S - 1, n) for a in (qi, dqi, ddqi))
    theta_dot, theta_ddot, t = interval_state(ctx.profile, i, s)
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
    flat = lambda a: None if a is None else a.reshape(k1 * (S + 1), *a.shape[2:])  # noqa: E731
    samples = Samples(flat(t), flat(theta), flat(theta_dot), flat(np.array(theta_ddot)), flat(q), flat(qd),
                      flat(qdd), flat(tau))
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
    o, sg = origin[index, None], sign[index, None]
    xi0, xi1 = smooth.xi_of(o, sg, grid[index, None]), smooth.xi_of(o, sg, grid[index + 1, None])
    xi = xi0 + (xi1 - xi0) * (np.arange(S + 1) / S)[None, :]
    theta = np.clip(smooth.theta_of(o, sg, xi), grid[index, None], grid[index + 1, None])
    theta[:, 0], theta[:, -1] = grid[index], grid[index + 1]
    i = np.repeat(index[:, None], S + 1, 1)
    x, u, jerk = smooth.state(grid, p.x, p.u_nodes, origin, sign, i, theta)
    q, dq, ddq, dddq = (np.empty((k1, S + 1, n)) for _ in range(4))
    r, l = ctx.right, ctx.left
    for arr, pr, pl in ((q, r.q, l.q), (dq, r.dq, l.dq), (ddq, r.ddq, l.ddq), (dddq, r.dddq, l.dddq)):
        arr[:, 0], arr[:, -1] = pr[index], pl[index + 1]
    if S > 1:
        inner = _interior_path(ctx, theta[:, 1:-1].ravel())
        for arr, value in zip((q, dq, ddq, dddq), inner):
            arr[:, 1:-1] = value.reshape(k1, S - 1, n)
    v = np.sqrt(x)
    qd = dq * v[..., None]
    qdd = dq * u[..., None] + ddq * x[..., None]
    qddd = dq * jerk[..., None] + 3.0 * ddq * (v * u)[..., None] + dddq * (x * v)[..., None]
    flat = lambda a: None if a is None else a.reshape(k1 * (S + 1), *a.shape[2:])  # noqa: E731
    tau = tau_dot = None
    if ctx.needs_torque and robot is not None:
        tau = (rnea_batch if supported(robot) else rnea)(robot, flat(q), flat(qd), flat(qdd))
        if ctx.torque_rate:
            tau_dot = torque_derivative(robot, flat(q), flat(qd), flat(qdd), flat(qddd))
    t = np.broadcast_to(p.times[index, None], theta.shape)
    samples = Samples(flat(t), flat(theta), flat(v), flat(u), flat(q), flat(qd), flat(qdd), tau, flat(jerk),
                      flat(qddd), tau_dot)
    return IntervalSamples(samples, index, S + 1)


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
    v = np.asarray(values, float)
    s1 = v.shape[1]
    # (P, S + 1): no sign change, or one after sample k (a smooth f crosses zero at most once in so short
    # an interval; a second crossing lies where |f| is small, and a wrong pattern only widens the bound)
    signs = np.array([[1.0] * k + [-1.0] * (s1 - k) for k in range(1, s1 + 1)])
    with np.errstate(invalid="ignore"):
        f = signs[:, None, :, None] * v[None]  # (P, I, S + 1, m)
        rough = np.abs(f[:, :, :-2] - 2.0 * f[:, :, 1:-1] + f[:, :, 2:]).max(axis=2)  # (P, I, m)
        pick = np.argmin(np.where(np.isfinite(rough), rough, np.inf), axis=0)  # (I, m)
        f = np.take_along_axis(f, pick[None, :, None, :], axis=0)[0]  # (I, S + 1, m)
        tops = []
        for g in (f, -f):
            d2 = g[:, :-2] - 2.0 * g[:, 1:-1] + g[:, 2:]  # at the interior samples 1 .. S - 1
            d3 = np.abs(np.diff(d2, axis=1)).max(axis=1, keepdims=True)
            left = np.concatenate([d2[:, :1], d2], axis=1)  # sub-interval k: samples k, k + 1
            right = np.concatenate([d2, d2[:, -1:]], axis=1)
            concave = np.maximum(np.maximum(-left, -right) + d3, 0.0)
            tops.append((np.maximum(g[:, :-1], g[:, 1:]) + REMAINDER_SAFETY * concave / 8.0).max(axis=1))
    bound = np.maximum(*tops)
    return np.where(np.isfinite(v.max(axis=1)), bound, v.max(axis=1))


def certify(ctx: CertifyContext, limits) -> dict:
    """{name: (K - 1, m) certified upper bound of the ratio on every interval} per active limit; the
    samples carry torques only for the limits that need them (the views share one sample cache). A smooth
    profile (theta_ddot not constant per interval: the row form does not apply) takes the sampled form
    for every limit, on :func:`smooth_interval_samples`."""
    if ctx.profile.smooth:
        ctx.torque_rate = ctx.torque_rate or any(lim.order == 3 and lim.needs_torque for lim in limits)
        cs = ctx.samples(subdivisions=SMOOTH_SUBDIVISIONS)
        values = [cs.per_interval(lim.ratios(cs.samples, ctx.robot)) for lim in limits]
        if not values:
            return {}
        bound = smooth_sampled_bound(np.concatenate(values, axis=2))  # every limit's columns in one pass
        cut = np.cumsum([v.shape[2] for v in values])[:-1]
        return {lim.name: b for lim, b in zip(limits, np.split(bound, cut, axis=1))}
    return _certify_piecewise(ctx, limits)


def _certify_piecewise(ctx: CertifyContext, limits) -> dict:
    """:func:`certify` of a piecewise-constant theta_ddot profile. Each limit's row form where it holds
    (:meth:`Limit.certify_row_form`); the sampled form, CERTIFY_SUBDIVISIONS, where it does not, on every
    interval for a limit without one, and where the row form exceeds REFINE_ABOVE; REFINE_SUBDIVISIONS
    where that sampled bound exceeds it too (the smallest of the upper bounds is kept). Each pass samples
    the union of the intervals the limits need once (:func:`_sampled_union`)."""
    k1 = len(ctx.profile.grid) - 1
    rows, sampled, over = {}, {}, {}
    for lim in limits:
        form = lim.certify_row_form(ctx)
        if form is None:
            rows[lim.name], sampled[lim.name] = None, np.ones(k1, bool)
            continue
        bound, valid = form
        rows[lim.name], over[lim.name] = (bound, valid), (bound > REFINE_ABOVE).any(axis=1) & valid
        sampled[lim.name] = over[lim.name] if valid.all() else over[lim.name] | ~valid
    coarse = _sampled_union(ctx, limits, sampled, CERTIFY_SUBDIVISIONS)
    refine = {}
    for name, o in over.items():
        if name in coarse:
            r = o & (coarse[name] > REFINE_ABOVE).any(axis=1)
            if r.any():
                refine[name] = r
    fine = _sampled_union(ctx, limits, refine, REFINE_SUBDIVISIONS) if refine else {}
    out = {}
    for lim in limits:
        name = lim.name
        if rows[name] is None:
            out[name] = coarse[name]
            continue
        bound, valid = rows[name]
        if name in coarse:
            b = coarse[name]
            if name in fine:
                r = np.nonzero(refine[name])[0]
                b[r] = np.minimum(b[r], fine[name][r])
            if not valid.all():
                invalid = np.nonzero(~valid)[0]
                bound[invalid] = b[invalid]  # the row form does not hold there
            o = np.nonzero(over[name])[0]
            bound[o] = np.minimum(bound[o], b[o])  # both are upper bounds
        out[name] = bound
    return out


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
