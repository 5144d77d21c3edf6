"""The orbital control law of one sample, compiled (numba): projection -> transverse state -> v.

It composes the pieces the rest of :mod:`pathmotion.control` defines one by one (and tests against
independent references): :func:`~.transverse.project`, theta_dot and the transverse coordinates of
:func:`~.transverse.transverse_state`, the profile x*(theta), u*(theta) of
:class:`~.profile_lookup.ProfileLookup`, the gain K(theta) of :meth:`~.orbital.OrbitalDesign.gain_at` and
the feedforward at theta_m = theta + theta_dot Ts / 2. One compiled call per sample instead of a dozen
numpy calls on 6-vectors; tests/test_control_orbital.py checks it equals that composition.
"""

from __future__ import annotations

import numba
import numpy as np

from .path_table import _evaluate_one, _project_one, _wrapped
from .transverse import _coordinates


@numba.njit(cache=True)
def profile_state(grid, x, u, closed, theta):
    """(x*, u*) of a piecewise-linear x = theta_dot^2 (grid, x (M,), u (M-1,)) at theta (wrapped if closed)."""
    lo, hi = grid[0], grid[-1]
    th = _wrapped(theta, lo, hi, closed)
    i = min(max(np.searchsorted(grid, th, side="right") - 1, 0), len(grid) - 2)
    return max(x[i] + 2.0 * u[i] * (th - grid[i]), 0.0), u[i]


@numba.njit(cache=True)
def orbital_command(grid, coeffs, closed, q, qd, guess, iterations, tol, max_step, k, sigma,
                    pgrid, px, pu, gain, xi, ts, x_perp, v):
    """One sample of the orbital law. Writes the commanded acceleration v (n,) [rad/s^2] and the state
    x_perp = (xi, z, z_dot, I) (gain.shape[2],); xi = (int z dt, int I dt) (n,) or (0,) is advanced by
    ts (z, I) first (in place). Returns (theta, theta_dot); theta is unwrapped on closed paths.

    gain (M, n, d) on the table grid (linear in theta between grid points)."""
    lo, hi = grid[0], grid[-1]
    theta, ev = _project_one(grid, coeffs, closed, q, guess, iterations, tol, max_step)
    phi, dphi, ddphi = ev[0], ev[1], ev[2]
    n = q.shape[0]
    y = q - phi
    d2 = np.dot(dphi, dphi)
    den = max(d2 - np.dot(ddphi, y), 0.5 * d2)
    theta_dot = np.dot(dphi, qd) / den
    ydot = qd - dphi * theta_dot
    z, zd = _coordinates(dphi, ddphi, y, ydot, theta_dot, k, sigma)
    m = n - 1
    ni = xi.shape[0]
    x_star, _ = profile_state(pgrid, px, pu, closed, theta)
    speed_error = theta_dot * theta_dot - x_star
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
    # gain at theta, linear between grid points
    th = _wrapped(theta, lo, hi, closed)
    i = min(max(np.searchsorted(grid, th, side="right") - 1, 0), len(grid) - 2)
    w = (th - grid[i]) / (grid[i + 1] - grid[i])
    # feedforward at the middle of the hold interval
    theta_m = theta + 0.5 * ts * theta_dot
    if not closed:
        theta_m = min(theta_m, hi)
    ev_m = _evaluate_one(grid, coeffs, _wrapped(theta_m, lo, hi, closed))
    x_m, u_m = profile_state(pgrid, px, pu, closed, theta_m)
    dim = x_perp.shape[0]
    for r in range(n):
        acc = ev_m[1, r] * u_m + ev_m[2, r] * x_m
        for c in range(dim):
            acc -= ((1.0 - w) * gain[i, r, c] + w * gain[i + 1, r, c]) * x_perp[c]
        v[r] = acc
    return theta, theta_dot


@numba.njit(cache=True)
def profile_at_time(times, grid, x, u, t):
    """(theta, theta_dot, theta_ddot) of a piecewise-linear x = theta_dot^2 at time t [s] (clipped to the
    profile's duration); the same formulas as :meth:`pathmotion.planning.profile.Profile.state_at_time`."""
    t = min(max(t, 0.0), times[-1])
    i = min(max(np.searchsorted(times, t, side="right") - 1, 0), len(grid) - 2)
    tau = t - times[i]
    theta = min(grid[i] + np.sqrt(x[i]) * tau + 0.5 * u[i] * tau * tau, grid[i + 1])
    return theta, np.sqrt(max(x[i] + 2.0 * u[i] * (theta - grid[i]), 0.0)), u[i]


@numba.njit(cache=True)
def clock_command(grid, coeffs, closed, times, pgrid, px, pu, t_ref, ts, q, qd, kp, kd, ki, xi_q, v):
    """Clock play of the plan at planned time t_ref [s]: writes v (n,) = a_ref(t_ref + ts/2) - kd e' - kp e -
    ki xi_q, e = q - q_ref(t_ref), after advancing xi_q (n,) by ts times the part of e across the planned
    velocity (all of e at rest; in place); past the end of the plan a_ref = 0 and q_ref = Phi(theta_end).
    Returns the planned (theta, theta_dot) at t_ref."""
    lo, hi = grid[0], grid[-1]
    th0, thd0, _ = profile_at_time(times, pgrid, px, pu, t_ref)
    th1, thd1, thdd1 = profile_at_time(times, pgrid, px, pu, t_ref + 0.5 * ts)
    ev0 = _evaluate_one(grid, coeffs, _wrapped(th0, lo, hi, closed))
    ev1 = _evaluate_one(grid, coeffs, _wrapped(th1, lo, hi, closed))
    moving = t_ref + 0.5 * ts < times[-1]
    n = q.shape[0]
    e = q - ev0[0]
    # integrate the error across the motion only (a lag along the path would wind the integrator up and
    # overshoot the stop); at rest all of it
    speed2 = np.dot(ev0[1], ev0[1]) * thd0 * thd0
    along = np.dot(e, ev0[1]) * thd0 / speed2 if speed2 > 1e-12 else 0.0
    for r in range(n):
        ed = qd[r] - ev0[1, r] * thd0
        xi_q[r] += ts * (e[r] - along * ev0[1, r] * thd0)
        ff = ev1[1, r] * thdd1 + ev1[2, r] * thd1 * thd1 if moving else 0.0
        v[r] = ff - kd * ed - kp * e[r] - ki * xi_q[r]
    return th0, thd0
