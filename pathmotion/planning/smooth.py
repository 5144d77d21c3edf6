"""The smooth profile's interpolation: theta_ddot = u linear in a stretched coordinate xi per interval.

Next to a point where the motion rests (x = 0), the time-optimal jerk-limited start is the
constant-jerk S-curve, theta - a ~ t^3, so u ~ (theta - a)^(1/3) and x ~ (theta - a)^(4/3): scale-
free, and no refinement of a grid in theta makes u linear in theta represent it (the jerk of the
interpolant is off by ~1/(3k) on the k-th interval from rest). With xi = (theta - a)^(1/3) it is
exactly linear. So on every interval, u is linear in

    xi = (theta - a)^(1/3)   (sign +1: the interval lies in the half of its stretch nearer the rest point a before it)
    xi = (b - theta)^(1/3)   (sign -1: nearer the rest point b after it)
    xi = theta               (sign 0: no rest point on that side)

and x = x_i + 2 int u dtheta is exact in closed form; every relation stays linear in (x, u):
x_{i+1} = x_i + 2 (w0_i u_i + w1_i u_{i+1}), du/dtheta = (u_{i+1} - u_i) / (xi_{i+1} - xi_i) dxi/dtheta.
Away from a rest point the interpolant is O(Delta^2) accurate like linear-in-theta.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def coordinates(grid: np.ndarray, rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(origin, sign) per interval (K-1,): the rest point the interval's xi is measured from, and
    +1 / -1 / 0 (see the module docstring). ``rest`` (K,) marks the points at rest."""
    k = len(grid)
    idx = np.arange(k)
    prev = np.maximum.accumulate(np.where(rest, idx, -1))[:-1]  # last rest point <= i
    nxt = np.minimum.accumulate(np.where(rest, idx, k)[::-1])[::-1][1:]  # first rest point >= i + 1
    has_a, has_b = prev >= 0, nxt < k
    centre = 0.5 * (grid[:-1] + grid[1:])
    ta = grid[np.maximum(prev, 0)]
    tb = grid[np.minimum(nxt, k - 1)]
    nearer_a = np.where(has_a & has_b, centre - ta <= tb - centre, has_a)
    sign = np.where(nearer_a & has_a, 1, np.where(has_b, -1, 0))
    origin = np.where(sign > 0, ta, np.where(sign < 0, tb, 0.0))
    return origin, sign


def xi_of(origin, sign, theta):
    """xi at theta (arrays broadcast together)."""
    return np.where(sign > 0, np.cbrt(np.maximum(theta - origin, 0.0)),
                    np.where(sign < 0, np.cbrt(np.maximum(origin - theta, 0.0)), theta))


def theta_of(origin, sign, xi):
    return np.where(sign > 0, origin + xi**3, np.where(sign < 0, origin - xi**3, xi))


def dtheta_dxi(sign, xi):
    """d theta / d xi: 3 xi^2 (sign +1), -3 xi^2 (sign -1), 1 (sign 0)."""
    return np.where(sign == 0, 1.0, 3.0 * sign * xi**2)


def xi_integral(origin, sign, theta0, theta):
    """int_{theta0}^{theta} (xi - xi(theta0)) d theta."""
    x0 = xi_of(origin, sign, theta0)
    d0, d1 = np.abs(theta0 - origin), np.abs(theta - origin)
    cube = np.where(sign > 0, 0.75 * (d1 ** (4 / 3) - d0 ** (4 / 3)), 0.75 * (d0 ** (4 / 3) - d1 ** (4 / 3)))
    lin = np.where(sign == 0, 0.5 * (theta - theta0) ** 2, cube - x0 * (theta - theta0))
    return lin


def weights(grid: np.ndarray, origin: np.ndarray, sign: np.ndarray):
    """(xi_lo, xi_hi, w0, w1) per interval (K-1,): xi at its ends, and x_{i+1} - x_i = 2 (w0 u_i + w1 u_{i+1})."""
    lo, hi = grid[:-1], grid[1:]
    xi_lo, xi_hi = xi_of(origin, sign, lo), xi_of(origin, sign, hi)
    w1 = xi_integral(origin, sign, lo, hi) / (xi_hi - xi_lo)
    return xi_lo, xi_hi, (hi - lo) - w1, w1


def state(grid, x, u, origin, sign, i, theta):
    """(x, u, du/dtheta * sqrt(x) = theta_dddot) at theta in interval i (arrays of one shape)."""
    i, theta = np.asarray(i), np.asarray(theta, float)
    shape = np.broadcast_shapes(i.shape, theta.shape)
    flat_i = np.ascontiguousarray(np.broadcast_to(i, shape), np.int64).ravel()
    flat_t = np.ascontiguousarray(np.broadcast_to(theta, shape)).ravel()
    xx, uu, jerk = state_points(np.ascontiguousarray(grid, float), np.ascontiguousarray(x, float),
                                 np.ascontiguousarray(u, float), np.ascontiguousarray(origin, float),
                                 np.ascontiguousarray(sign, np.int64), flat_i, flat_t)
    return xx.reshape(shape)[()], uu.reshape(shape)[()], jerk.reshape(shape)  # (numpy's types: 0-d x, u are scalars)


@njit(cache=True, inline="always")
def xi_at(origin, sign, theta):
    """:func:`xi_of` at one point (compiled, inlined)."""
    if sign > 0:
        return np.cbrt(max(theta - origin, 0.0))
    if sign < 0:
        return np.cbrt(max(origin - theta, 0.0))
    return theta


@njit(cache=True, inline="always")
def xi_integral_at(origin, sign, theta0, theta):
    """:func:`xi_integral` at one point (compiled, inlined)."""
    if sign == 0:
        return 0.5 * (theta - theta0) ** 2
    d0, d1 = abs(theta0 - origin), abs(theta - origin)
    cube = 0.75 * (d1 ** (4 / 3) - d0 ** (4 / 3)) if sign > 0 else 0.75 * (d0 ** (4 / 3) - d1 ** (4 / 3))
    return cube - xi_at(origin, sign, theta0) * (theta - theta0)


@njit(cache=True, nogil=True, error_model="numpy")
def state_points(grid, x, u, origin, sign, index, theta):
    """:func:`state` point by point: the same formulas in the same order.

    x is integrated from the interval's start, or from its end where the motion rests there (from the start, x
    next to the rest point would be the difference of nearly equal numbers, and the jerk's sqrt(x) / xi^2 below
    would lose all its digits); theta_dddot = g sqrt(x) / (dtheta/dxi), and at a rest point (xi = 0) its limit
    sqrt(x) / xi^2, that of the S-curve x = x_end (xi / xi_end)^4."""
    n = theta.shape[0]
    xs, us, js = np.empty(n), np.empty(n), np.empty(n)
    for p in range(n):
        xs[p], us[p], js[p] = state_at(grid, x, u, origin, sign, index[p], theta[p])
    return xs, us, js


@njit(cache=True, inline="always", error_model="numpy")
def state_at(grid, x, u, origin, sign, i, th):
    """:func:`state` at one point (theta ``th`` in interval ``i``; compiled, inlined)."""
    o, sg = origin[i], sign[i]
    xi_lo, xi_hi = xi_at(o, sg, grid[i]), xi_at(o, sg, grid[i + 1])
    g = (u[i + 1] - u[i]) / (xi_hi - xi_lo)
    xi = xi_at(o, sg, th)
    uu = u[i] + g * (xi - xi_lo)
    if x[i + 1] <= 0.0:
        val = x[i + 1] + 2.0 * (u[i + 1] * (th - grid[i + 1]) + g * xi_integral_at(o, sg, grid[i + 1], th))
    else:
        val = x[i] + 2.0 * (u[i] * (th - grid[i]) + g * xi_integral_at(o, sg, grid[i], th))
    xx = val if (val >= 0.0 or val != val) else 0.0
    slope = 1.0 if sg == 0 else 3.0 * sg * xi ** 2
    if slope != 0:
        return xx, uu, g * np.sqrt(xx) / slope
    far, x_far = (xi_lo, x[i]) if abs(xi_lo) > abs(xi_hi) else (xi_hi, x[i + 1])
    return xx, uu, g * np.sqrt(x_far) / (3.0 * sg * (far if far != 0 else 1.0) ** 2)


def interval_samples(grid, x, u, origin, sign, index, subdivisions: int):
    """(theta, x, u, theta_dddot), each (I, S + 1): the state at S + 1 points of each interval in ``index`` (I,)
    uniform in its xi, theta clipped to the interval and its ends the grid points."""
    index = np.ascontiguousarray(index, np.int64)
    return _samples_kernel(np.ascontiguousarray(grid, float), np.ascontiguousarray(x, float),
                           np.ascontiguousarray(u, float), np.ascontiguousarray(origin, float),
                           np.ascontiguousarray(sign, np.int64), index, int(subdivisions))


@njit(cache=True, nogil=True, error_model="numpy")
def _samples_kernel(grid, x, u, origin, sign, index, subdivisions):
    """:func:`interval_samples`, point by point: xi = xi_lo + (xi_hi - xi_lo) (s / S), theta_of(xi) clipped to
    the interval (the ends set to its grid points), the state there as :func:`state`."""
    shape = (index.shape[0], subdivisions + 1)
    th, xs, us, js = np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape)
    for p in range(index.shape[0]):
        i = index[p]
        o, sg, lo, hi = origin[i], sign[i], grid[i], grid[i + 1]
        xi0, xi1 = xi_at(o, sg, lo), xi_at(o, sg, hi)
        for s in range(subdivisions + 1):
            if s == 0:
                t = lo
            elif s == subdivisions:
                t = hi
            else:
                xi = xi0 + (xi1 - xi0) * (s / subdivisions)
                t = (o + xi ** 3.0) if sg > 0 else ((o - xi ** 3.0) if sg < 0 else xi)
                t = lo if t < lo else (hi if t > hi else t)
            th[p, s] = t
            xs[p, s], us[p, s], js[p, s] = state_at(grid, x, u, origin, sign, i, t)
    return th, xs, us, js


def interval_times(grid, x, u, origin, sign, nodes, weights) -> np.ndarray:
    """Duration of every interval (K-1,) [s] by the 8-point quadrature (``nodes``, ``weights`` on [0, 1]) in its xi of
    dt/dlambda = (dtheta/dxi) (xi_hi - xi_lo) / sqrt(x), lambda the fraction of its xi range (finite at a rest
    point, where x ~ xi^4 and dtheta/dxi ~ xi^2); the sum of the weighted values pairwise, as numpy's sum."""
    if len(nodes) != 8 or len(weights) != 8:
        raise ValueError("interval_times: an 8-point quadrature")
    return _times_kernel(np.ascontiguousarray(grid, float), np.ascontiguousarray(x, float),
                         np.ascontiguousarray(u, float), np.ascontiguousarray(origin, float),
                         np.ascontiguousarray(sign, np.int64), np.ascontiguousarray(nodes, float),
                         np.ascontiguousarray(weights, float))


@njit(cache=True, nogil=True, error_model="numpy")
def _times_kernel(grid, x, u, origin, sign, nodes, weights):
    """:func:`interval_times`, interval by interval."""
    out = np.empty(grid.shape[0] - 1)
    r = np.empty(8)
    for i in range(grid.shape[0] - 1):
        o, sg = origin[i], sign[i]
        xi0 = xi_at(o, sg, grid[i])
        dxi = xi_at(o, sg, grid[i + 1]) - xi0
        for k in range(8):
            xi = xi0 + nodes[k] * dxi
            th = (o + xi ** 3.0) if sg > 0 else ((o - xi ** 3.0) if sg < 0 else xi)
            th = min(max(th, grid[i]), grid[i + 1])
            xx = state_at(grid, x, u, origin, sign, i, th)[0]
            dth = (1.0 if sg == 0 else 3.0 * sg * xi ** 2) * dxi
            r[k] = weights[k] * (dth / np.sqrt(xx))
        out[i] = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    return out
