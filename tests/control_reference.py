"""Independent numpy references of the compiled controller kernels (pathmotion.control.kernels).

They share no code with the kernels: the path is evaluated by PathTable.evaluate (vectorized numpy), the
projection is a plain Newton iteration on g(theta) = Phi'^T (q - Phi) to convergence, the transverse
basis is the matrix form E, E' of TransverseBasis.frames, and the profile is the planning Profile's own
numpy x_at / theta_ddot_at.
"""

from __future__ import annotations

import numpy as np

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
