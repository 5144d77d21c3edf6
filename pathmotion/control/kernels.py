"""The compiled (numba) per-sample kernels of the controllers and the closed-loop monitor: ONE implementation
of each computation, called through thin Python wrappers (PathTable, ProfileLookup, TransverseBasis,
OrbitalController, the simulation monitor). tests/control_reference.py holds independent numpy references.

Arguments are packed into named tuples (numba compiles a NamedTuple of arrays and scalars as a record):

* :class:`PathArrays` the tabulated path q = Phi(theta) (see :mod:`.path_table`);
* :class:`ProfileArrays` a piecewise-linear x = theta_dot^2 on its grid;
* :class:`Projection` the settings of the local projection onto the path;
* :class:`Basis` the reflection axis sigma e_k of the transverse basis (see :mod:`.transverse`).

The profile lookup, on a piece i of the grid, is one function, :func:`pathmotion.planning.profile.piece_x`
(compiled here as ``profile_x``):

    x*(theta) = max(x_i + 2 u_i (theta - theta_i), 0)
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from ..planning.profile import HOLD_ROUNDING, piece_x

#: |Phi'|^2 below which the projection treats Phi' as zero (clamped spline ends) and nudges theta [rad^2].
ZERO_SPEED2 = 1e-24
#: The nudge into the interior where Phi' = 0, as a fraction of the projection's largest step [-].
NUDGE_FRACTION = 1e-3
#: Relative slack of the step-halving test "the distance did not grow" (round-off) [-].
DISTANCE_SLACK = 1e-12
#: Floor of the distance test at distance 0 [rad^2].
TINY = 1e-300
#: Step halvings of one projection iteration before it gives up.
HALVINGS = 8
#: Planned joint speed^2 below which the clock play integrates all of the error (at rest) [rad^2/s^2].
REST_SPEED2 = 1e-12


class PathArrays(NamedTuple):
    """grid (M,) theta values; coeffs (M-1, 6, n) quintic coefficients; closed; kinks (K,) theta where Phi' jumps."""

    grid: np.ndarray
    coeffs: np.ndarray
    closed: bool
    kinks: np.ndarray


class ProfileArrays(NamedTuple):
    """times (M,) [s], grid (M,) theta, x (M,) theta_dot^2, u (M-1,) theta_ddot of a piecewise-linear x."""

    times: np.ndarray
    grid: np.ndarray
    x: np.ndarray
    u: np.ndarray


class Projection(NamedTuple):
    """iterations; tol and max_step in theta (absolute: already scaled by the path length)."""

    iterations: int
    tol: float
    max_step: float


class Basis(NamedTuple):
    """Reflection axis sigma e_k of the Householder transverse basis E(theta)."""

    k: int
    sigma: float


# --- path ---------------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def wrap(theta, lo, hi, closed):
    """theta into [lo, hi]: modulo the period if closed, clipped if open."""
    if closed:
        return lo + (theta - lo) % (hi - lo)
    return min(max(theta, lo), hi)


@numba.njit(cache=True)
def piece(grid, theta):
    """Index i of the grid interval [grid[i], grid[i+1]) holding theta (clamped to the first/last)."""
    return min(max(np.searchsorted(grid, theta, side="right") - 1, 0), len(grid) - 2)


@numba.njit(cache=True)
def evaluate_path(grid, coeffs, theta):
    """(3, n): Phi, Phi', Phi'' at one theta inside [grid[0], grid[-1]] (~1 us per call)."""
    i = piece(grid, theta)
    h = grid[i + 1] - grid[i]
    s = (theta - grid[i]) / h
    c = coeffs[i]
    n = c.shape[1]
    out = np.empty((3, n))
    for j in range(n):
        c0, c1, c2, c3, c4, c5 = c[0, j], c[1, j], c[2, j], c[3, j], c[4, j], c[5, j]
        out[0, j] = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
        out[1, j] = (c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))) / h
        out[2, j] = (2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5))) / (h * h)
    return out


@numba.njit(cache=True)
def evaluate_at(path, theta):
    """(3, n) Phi, Phi', Phi'' at theta wrapped/clipped into the path's domain."""
    grid = path.grid
    return evaluate_path(grid, path.coeffs, wrap(theta, grid[0], grid[-1], path.closed))


@numba.njit(cache=True)
def project(path, q, theta, proj):
    """Local projection of q onto the path near theta: argmin |q - Phi(theta)|^2 (see
    :func:`pathmotion.control.transverse.project`). Returns theta and (3, n) Phi, Phi', Phi'' there."""
    grid, coeffs, closed = path.grid, path.coeffs, path.closed
    lo, hi = grid[0], grid[-1]
    max_step = proj.max_step
    ev = evaluate_path(grid, coeffs, wrap(theta, lo, hi, closed))
    y = q - ev[0]
    dist = np.dot(y, y)
    for _ in range(proj.iterations):
        d2 = np.dot(ev[1], ev[1])
        if d2 <= ZERO_SPEED2:
            step = NUDGE_FRACTION * max_step
            if not closed and theta >= hi:
                step = -step
        else:
            curv = d2 - np.dot(ev[2], y)
            step = np.dot(ev[1], y) / (curv if curv > 0.5 * d2 else d2)
            step = min(max(step, -max_step), max_step)
            if abs(step) <= proj.tol:
                break
        accepted = False
        new = theta
        ev_new = ev
        y_new = y
        dist_new = dist
        for _halve in range(HALVINGS):
            new = theta + step
            if not closed:
                new = min(max(new, lo), hi)
            ev_new = evaluate_path(grid, coeffs, wrap(new, lo, hi, closed))
            y_new = q - ev_new[0]
            dist_new = np.dot(y_new, y_new)
            if dist_new <= dist * (1.0 + DISTANCE_SLACK) + TINY:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            break
        theta, ev, y, dist = new, ev_new, y_new, dist_new
    return theta, ev


# --- profile ------------------------------------------------------------------------------------------------


#: x*(theta) = max(x_i + 2 u_i (theta - theta_i), 0) on piece i: planning's own lookup, compiled.
profile_x = numba.njit(cache=True)(piece_x)


@numba.njit(cache=True)
def profile_state(profile, closed, theta):
    """(x*, u*) at theta (wrapped if closed, else clipped): planned theta_dot^2 and theta_ddot."""
    grid = profile.grid
    th = wrap(theta, grid[0], grid[-1], closed)
    i = piece(grid, th)
    return profile_x(grid, profile.x, profile.u, i, th), profile.u[i]


@numba.njit(cache=True)
def profile_states(profile, closed, theta):
    """(N, 2) rows (x*, u*) of :func:`profile_state` at each theta (N,)."""
    out = np.empty((len(theta), 2))
    for k in range(len(theta)):
        out[k, 0], out[k, 1] = profile_state(profile, closed, theta[k])
    return out


@numba.njit(cache=True)
def profile_time(profile, closed, theta):
    """Planned time t*(theta) [s] = t_i + 2 (theta - theta_i) / (sqrt(x_i) + sqrt(x*(theta))) (exact for a
    piecewise-linear x; within one period if closed)."""
    grid, x = profile.grid, profile.x
    th = wrap(theta, grid[0], grid[-1], closed)
    i = piece(grid, th)
    den = np.sqrt(x[i]) + np.sqrt(profile_x(grid, x, profile.u, i, th))
    return profile.times[i] + (2.0 * (th - grid[i]) / den if den > 0 else 0.0)


@numba.njit(cache=True)
def profile_times(profile, theta):
    """:func:`profile_time` (open: clipped) of every theta (N,)."""
    out = np.empty(theta.shape[0])
    for j in range(theta.shape[0]):
        out[j] = profile_time(profile, False, theta[j])
    return out


@numba.njit(cache=True)
def profile_at_time(profile, t):
    """(theta, theta_dot, theta_ddot) at time t [s] (clipped to the duration); the same formulas as
    :meth:`pathmotion.planning.profile.Profile.state_at_time`."""
    times, grid, u = profile.times, profile.grid, profile.u
    t = min(max(t, 0.0), times[-1])
    i = min(max(np.searchsorted(times, t, side="right") - 1, 0), len(grid) - 2)
    tau = t - times[i]
    if tau < 0.0:  # a hold at the start (a dwell): at rest
        return grid[i], 0.0, 0.0
    v0, v1 = np.sqrt(profile.x[i]), np.sqrt(profile.x[i + 1])
    if v0 + v1 > 0.0 and tau > 2.0 * (grid[i + 1] - grid[i]) / (v0 + v1) + HOLD_ROUNDING:
        return grid[i + 1], 0.0, 0.0  # arrived at a stop with a hold (a dwell): at rest until the departure
    theta = min(grid[i] + v0 * tau + 0.5 * u[i] * tau * tau, grid[i + 1])
    return theta, np.sqrt(profile_x(grid, profile.x, u, i, theta)), u[i]


# --- transverse coordinates and the two control laws ---------------------------------------------------------


@numba.njit(cache=True)
def transverse_coordinates(dphi, ddphi, y, ydot, theta_dot, basis):
    """z = (H y)[j != k], z_dot = (H ydot + theta_dot H' y)[j != k] (H the Householder reflection, symmetric)."""
    k, sigma = basis.k, basis.sigma
    speed = np.sqrt(np.dot(dphi, dphi))
    t = dphi / speed
    dt = (ddphi - t * np.dot(t, ddphi)) / speed
    w = t.copy()
    w[k] -= sigma
    s = np.dot(w, w)
    wy = np.dot(w, y)
    wyd = np.dot(w, ydot)
    dty = np.dot(dt, y)
    wdt = np.dot(w, dt)
    n = y.shape[0]
    z = np.empty(n - 1)
    zd = np.empty(n - 1)
    m = 0
    for j in range(n):
        if j == k:
            continue
        z[m] = y[j] - 2.0 * wy / s * w[j]
        dhy = -2.0 / s * (dt[j] * wy + w[j] * dty) + 4.0 * wdt * wy / (s * s) * w[j]
        zd[m] = ydot[j] - 2.0 * wyd / s * w[j] + theta_dot * dhy
        m += 1
    return z, zd


@numba.njit(cache=True)
def transverse_state(path, profile, basis, proj, q, qd, guess):
    """(theta, theta_dot, z, z_dot, I) of the measured q, qd (n,): the projection near ``guess``,
    theta_dot = Phi'^T qd / max(|Phi'|^2 - Phi''^T y, |Phi'|^2 / 2), the transverse coordinates and
    I = theta_dot^2 - x*(theta)."""
    theta, ev = project(path, q, guess, proj)
    phi, dphi, ddphi = ev[0], ev[1], ev[2]
    y = q - phi
    d2 = np.dot(dphi, dphi)
    den = max(d2 - np.dot(ddphi, y), 0.5 * d2)  # far from the path the section is ill-defined: stay finite
    theta_dot = np.dot(dphi, qd) / den
    ydot = qd - dphi * theta_dot
    z, zd = transverse_coordinates(dphi, ddphi, y, ydot, theta_dot, basis)
    x_star, _ = profile_state(profile, path.closed, theta)
    return theta, theta_dot, z, zd, theta_dot * theta_dot - x_star


@numba.njit(cache=True)
def orbital_command(path, profile, basis, proj, gain, q, qd, guess, ts, xi, x_perp, v):
    """One sample of the orbital law. Writes the commanded acceleration v (n,) [rad/s^2] and the state
    x_perp = (xi, z, z_dot, I, dv_{k-delay}, ..., dv_{k-1}) (gain.shape[2],); xi = (int z dt, int I dt) (n,) or
    (0,) is advanced by ts (z, I) first (in place); the commands in flight (the feedback parts dv = v - v* of
    the last ``delay`` commands, a design for a delayed command) are shifted and the new one stored last.
    Returns (theta, theta_dot); theta is unwrapped on closed paths.

    gain (M, n, d) on the path grid (linear in theta between grid points); the feedforward
    v* = Phi' u* + Phi'' x* is taken at theta_m = theta + theta_dot ts (delay + 1/2), the middle of the hold
    in which the command will act."""
    grid, closed = path.grid, path.closed
    lo, hi = grid[0], grid[-1]
    theta, theta_dot, z, zd, speed_error = transverse_state(path, profile, basis, proj, q, qd, guess)
    m = q.shape[0] - 1
    ni = xi.shape[0]
    if ni > 0:
        for j in range(m):
            xi[j] += ts * z[j]
            x_perp[j] = xi[j]
        xi[m] += ts * speed_error
        x_perp[m] = xi[m]
    for j in range(m):
        x_perp[ni + j] = z[j]
        x_perp[ni + m + j] = zd[j]
    x_perp[ni + 2 * m] = speed_error
    th = wrap(theta, lo, hi, closed)
    i = piece(grid, th)
    w = (th - grid[i]) / (grid[i + 1] - grid[i])
    # the command is applied from ``delay`` samples on (the commands in flight), over one hold: its middle
    delay = (x_perp.shape[0] - (ni + 2 * m + 1)) // (m + 1)
    theta_m = theta + (0.5 + delay) * ts * theta_dot
    if not closed:
        theta_m = min(theta_m, hi)
    ev_m = evaluate_at(path, theta_m)
    x_m, u_m = profile_state(profile, closed, theta_m)
    n = m + 1
    for r in range(n):
        fb = 0.0
        for c in range(x_perp.shape[0]):
            fb -= ((1.0 - w) * gain[i, r, c] + w * gain[i + 1, r, c]) * x_perp[c]
        v[r] = ev_m[1, r] * u_m + ev_m[2, r] * x_m + fb
    # commands in flight (a design for a delayed command): shift them, the newest feedback part last
    core = ni + 2 * m + 1
    size = x_perp.shape[0]
    if size > core:
        for c in range(core, size - n):
            x_perp[c] = x_perp[c + n]
        for r in range(n):
            x_perp[size - n + r] = v[r] - (ev_m[1, r] * u_m + ev_m[2, r] * x_m)
    return theta, theta_dot


@numba.njit(cache=True)
def clock_command(path, profile, t_ref, ts, q, qd, kp, kd, ki, xi_q, v):
    """Clock play of the plan at planned time t_ref [s]: writes v (n,) = a_ref - kd e' - kp e - ki xi_q,
    e = q - q_ref(t_ref), after advancing xi_q (n,) by ts times the part of e across the planned velocity (all
    of e at rest; in place). a_ref = (qd_ref(t_ref + ts) - qd_ref(t_ref)) / ts, the planned acceleration
    averaged over the sample the command is held for: the held command changes the speed as the plan does
    over it, also across an arrival at a stop, a departure or the plan's end (past the end a_ref = 0 and
    q_ref = Phi(theta_end)). Returns the planned (theta, theta_dot) at t_ref."""
    th0, thd0, _ = profile_at_time(profile, t_ref)
    th1, thd1, _ = profile_at_time(profile, t_ref + ts)
    ev0 = evaluate_at(path, th0)
    ev1 = evaluate_at(path, th1)
    e = q - ev0[0]
    # integrate the error across the motion only (a lag along the path would wind the integrator up and
    # overshoot the stop); at rest all of it
    speed2 = np.dot(ev0[1], ev0[1]) * thd0 * thd0
    along = np.dot(e, ev0[1]) * thd0 / speed2 if speed2 > REST_SPEED2 else 0.0
    for r in range(q.shape[0]):
        ed = qd[r] - ev0[1, r] * thd0
        xi_q[r] += ts * (e[r] - along * ev0[1, r] * thd0)
        ff = (ev1[1, r] * thd1 - ev0[1, r] * thd0) / ts
        v[r] = ff - kd * ed - kp * e[r] - ki * xi_q[r]
    return th0, thd0
