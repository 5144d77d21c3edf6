"""Independent numpy references of the compiled controller kernels (pathmotion.control.kernels) and of
pathmotion.control.riccati (scipy's RK45 and expm: slow, for the tests only).

They share no code with the kernels: the path is evaluated by PathTable.evaluate (vectorized numpy), the
projection is a plain Newton iteration on g(theta) = Phi'^T (q - Phi) to convergence, the transverse
basis is the matrix form E, E' of TransverseBasis.frames, and the profile is the planning Profile's own
numpy x_at / theta_ddot_at.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from pathmotion import defaults
from pathmotion.control.riccati import TINY
from pathmotion.planning.profile import Profile


def evaluate(table, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Phi, Phi', Phi'') (n,) at one theta, by the table's numpy evaluation."""
    phi, dphi, ddphi = table.evaluate(np.array([theta]))
    return phi[0], dphi[0], ddphi[0]


def project(table, q: np.ndarray, theta: float, iterations: int = 50) -> float:
    """The local minimum of |q - Phi(theta)| near theta: Newton on Phi'^T (q - Phi) = 0 to convergence."""
    for _ in range(iterations):
        phi, dphi, ddphi = evaluate(table, theta)
        y = q - phi
        step = (dphi @ y) / (dphi @ dphi - ddphi @ y)
        theta += step
        if abs(step) < 1e-15:
            break
    return theta


def profile_state(profile: Profile, theta: float) -> tuple[float, float]:
    """(x*, u*) at theta inside the profile's range."""
    return float(profile.x_at(theta)), float(profile.theta_ddot_at(theta))


def transverse_state(table, basis, profile: Profile, q: np.ndarray, qd: np.ndarray, guess: float):
    """(theta, theta_dot, x_perp = (z, z_dot, I)) of the measured q, qd (n,) (pathmotion.control.transverse):
    theta_dot = Phi'^T qd / (|Phi'|^2 - Phi''^T y), z = E^T y, z_dot = E^T (qd - Phi' theta_dot) + theta_dot E'^T y."""
    theta = project(table, q, guess)
    phi, dphi, ddphi = evaluate(table, theta)
    y = q - phi
    theta_dot = (dphi @ qd) / max(dphi @ dphi - ddphi @ y, 0.5 * (dphi @ dphi))
    e, de = (m[0] for m in basis.frames(dphi[None], ddphi[None]))
    z = e.T @ y
    z_dot = e.T @ (qd - dphi * theta_dot) + theta_dot * de.T @ y
    x_star, _ = profile_state(profile, theta)
    return theta, theta_dot, np.concatenate([z, z_dot, [theta_dot**2 - x_star]])


def orbital_command(design, q, qd, guess, xi, ts):
    """(theta, theta_dot, xi_new, x_perp, v) of one sample of the orbital law (pathmotion.control.orbital):
    xi += ts (z, I); v = Phi'(theta_m) u*(theta_m) + Phi''(theta_m) x*(theta_m) - K(theta) x_perp with
    theta_m = theta + theta_dot ts / 2 and K linear in theta between the gain grid points."""
    table, profile = design.table, design.profile.profile
    theta, theta_dot, x_perp = transverse_state(table, design.basis, profile, q, qd, guess)
    m = table.n - 1
    if len(xi):
        xi = xi + ts * np.concatenate([x_perp[:m], [x_perp[-1]]])
        x_perp = np.concatenate([xi, x_perp])
    theta_m = min(theta + 0.5 * ts * theta_dot, table.domain[1])
    _, dphi_m, ddphi_m = evaluate(table, theta_m)
    x_m, u_m = profile_state(profile, theta_m)
    gain = np.array([np.interp(theta, design.theta, design.gain[:, r, c]) for r in range(table.n)
                     for c in range(design.gain.shape[2])]).reshape(design.gain.shape[1:])
    return theta, theta_dot, xi, x_perp, dphi_m * u_m + ddphi_m * x_m - gain @ x_perp


#: Absolute tolerance of the integration relative to the relative one times the scale of Q [-].
ABSOLUTE_FRACTION = 1e-3


def _interpolator(times: np.ndarray, values: np.ndarray):
    def at(t: float) -> np.ndarray:
        i = min(max(int(np.searchsorted(times, t, side="right")) - 1, 0), len(times) - 2)
        w = (t - times[i]) / (times[i + 1] - times[i])
        w = min(max(w, 0.0), 1.0)
        return values[i] + w * (values[i + 1] - values[i])

    return at


def solve_riccati_adaptive(times: np.ndarray, a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray,
                           p_end: np.ndarray) -> np.ndarray:
    """The open-horizon P at ``times`` (M, d, d) by scipy's adaptive RK45 at ``defaults.RICCATI_TOLERANCE``: the
    independent reference of riccati.solve_riccati (slow: a Python right-hand side)."""
    d = a.shape[1]
    s = b @ np.linalg.inv(r)[None] @ np.transpose(b, (0, 2, 1))
    a_at, s_at, q_at = _interpolator(times, a), _interpolator(times, s), _interpolator(times, q)

    def rhs(t, p_flat):
        p = p_flat.reshape(d, d)
        pa = p @ a_at(t)
        return (-(pa + pa.T - p @ s_at(t) @ p + q_at(t))).ravel()

    scale = max(float(np.max(np.abs(q))), 1.0)
    sol = solve_ivp(rhs, (times[-1], times[0]), p_end.ravel(), t_eval=times[::-1], method="RK45",
                    rtol=defaults.RICCATI_TOLERANCE, atol=defaults.RICCATI_TOLERANCE * scale * ABSOLUTE_FRACTION)
    p = sol.y.T[::-1].reshape(len(times), d, d)
    return 0.5 * (p + np.transpose(p, (0, 2, 1)))


def discretize(a: np.ndarray, b: np.ndarray, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretization of dx/dt = A x + B u over one sample: (Phi (N, d, d), Gamma (N, d, m))
    with Phi = e^(A Ts), Gamma = int_0^Ts e^(A s) ds B (Van Loan: the exponential of [[A, B], [0, 0]] Ts)."""
    big, d, m = b.shape
    block = np.zeros((big, d + m, d + m))
    block[:, :d, :d], block[:, :d, d:] = a, b
    ex = expm(block * sample_time)
    return ex[:, :d, :d], ex[:, :d, d:]


def sampled_cost_van_loan(a: np.ndarray, b: np.ndarray, q: np.ndarray, sample_time: float
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference of riccati.sampled_cost (slow: scipy.linalg.expm per sample on Van Loan's block): Phi, Gamma
    and W from the exponential of [[-C^T, Q_c], [0, C]] Ts (F22 = e^(C Ts), W = F22^T F12)."""
    big, d, m = b.shape
    k = d + m
    h = np.broadcast_to(np.asarray(sample_time, dtype=float), (big,))
    phi, gamma, w = np.empty((big, d, d)), np.empty((big, d, m)), np.empty((big, k, k))
    for i in range(big):
        c = np.zeros((k, k))
        c[:d, :d], c[:d, d:] = a[i], b[i]
        scale = max(float(np.max(np.abs(q[i]))), TINY)  # W is linear in Q: keep the block's norm small
        block = np.zeros((2 * k, 2 * k))
        block[:k, :k], block[:d, k:k + d], block[k:, k:] = -c.T, q[i] / scale, c
        ex = expm(block * h[i])
        f22 = ex[k:, k:]
        phi[i], gamma[i], w[i] = f22[:d, :d], f22[:d, d:], scale * (f22.T @ ex[:k, k:])
    return phi, gamma, 0.5 * (w + np.transpose(w, (0, 2, 1)))
