"""Projection onto the path and transverse coordinates of the orbital controller.

Coordinates near the path (see docs/control.md):

    q = Phi(theta) + E(theta) z          theta: projection of q on the path, Phi'(theta)^T (q - Phi) = 0
    x_perp = (z, z_dot, I),  I = theta_dot^2 - x*(theta)

E(theta) (n x (n-1)) is an orthonormal basis of the complement of Phi'(theta): the columns (all but
column k) of the Householder reflection H = I - 2 w w^T / (w^T w), w = t - sigma e_k, t = Phi'/|Phi'|,
which maps sigma e_k onto t. It is smooth in theta as long as t stays away from sigma e_k; (k, sigma)
is chosen once per path to maximize that distance.

The exact time derivatives (used by the controller, not linearized):

    theta_dot = Phi'^T q_dot / (|Phi'|^2 - Phi''^T y)       y = q - Phi(theta)
    z = E^T y,   z_dot = E^T (q_dot - Phi' theta_dot) + theta_dot E'^T y

Shapes: q, qd (n,); z, z_dot (n-1,); x_perp (2n-1,).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .. import defaults
from ..errors import SimulationError
from .path_table import PathTable
from .profile_lookup import ProfileLookup


@dataclass(frozen=True)
class TransverseBasis:
    """The fixed reflection axis sigma e_k of the Householder basis E(theta)."""

    k: int
    sigma: float

    @classmethod
    def for_table(cls, table: PathTable, theta: np.ndarray | None = None) -> "TransverseBasis":
        """Choose (k, sigma) so that the unit tangent stays farthest from sigma e_k along the path
        (at ``theta``, default the table grid)."""
        theta = table.grid if theta is None else np.asarray(theta, dtype=float)
        _, dphi, _ = table.evaluate(theta)
        speed = np.linalg.norm(dphi, axis=1)
        if np.any(speed <= 1e-12):
            i = int(np.argmax(speed <= 1e-12))
            raise SimulationError(
                f"the joint path has Phi'(theta) = 0 at theta = {theta[i]:.6g}: the projection onto the path "
                "is undefined there; remove the repeated point or the cusp"
            )
        t = dphi / speed[:, None]
        # distance^2 of t from +e_k is 2 - 2 t_k, from -e_k 2 + 2 t_k
        margin_plus = 2.0 - 2.0 * np.max(t, axis=0)
        margin_minus = 2.0 + 2.0 * np.min(t, axis=0)
        best_plus, best_minus = np.max(margin_plus), np.max(margin_minus)
        if max(best_plus, best_minus) < 0.04:  # |t - sigma e_k| < 0.2 for every choice
            raise SimulationError("cannot build a smooth transverse basis along this path (tangent visits every axis)")
        if best_plus >= best_minus:
            return cls(int(np.argmax(margin_plus)), 1.0)
        return cls(int(np.argmax(margin_minus)), -1.0)

    def frames(self, dphi: np.ndarray, ddphi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E (N, n, n-1) and E' = dE/dtheta (N, n, n-1) from Phi', Phi'' (N, n)."""
        n = dphi.shape[1]
        speed = np.linalg.norm(dphi, axis=1, keepdims=True)
        t = dphi / speed
        dt = (ddphi - t * np.sum(t * ddphi, axis=1, keepdims=True)) / speed
        w = t.copy()
        w[:, self.k] -= self.sigma
        s = np.sum(w * w, axis=1)[:, None, None]
        ww = w[:, :, None] * w[:, None, :]
        h = np.eye(n)[None] - 2.0 * ww / s
        wdw = np.sum(w * dt, axis=1)[:, None, None]
        dh = -2.0 * (dt[:, :, None] * w[:, None, :] + w[:, :, None] * dt[:, None, :]) / s + 4.0 * wdw * ww / s**2
        keep = [j for j in range(n) if j != self.k]
        return h[:, :, keep], dh[:, :, keep]

    def coordinates(self, dphi, ddphi, y, ydot, theta_dot) -> tuple[np.ndarray, np.ndarray]:
        """z = E^T y and z_dot = E^T ydot + theta_dot E'^T y for one point, each (n-1,)."""
        return _coordinates(np.ascontiguousarray(dphi, dtype=float), np.ascontiguousarray(ddphi, dtype=float),
                            np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(ydot, dtype=float),
                            float(theta_dot), self.k, self.sigma)


@numba.njit(cache=True)
def _coordinates(dphi, ddphi, y, ydot, theta_dot, k, sigma):
    """Compiled z = (H y)[j != k], z_dot = (H ydot + theta_dot H' y)[j != k] (H, H' symmetric)."""
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


def project(table: PathTable, q: np.ndarray, theta_guess: float,
            iterations: int = defaults.PROJECTION_ITERATIONS) -> tuple[float, tuple]:
    """Local projection of q onto the path near ``theta_guess``: argmin |q - Phi(theta)|^2.

    Newton on g(theta) = Phi'^T (q - Phi) = 0 (Gauss-Newton when the curvature term would make the
    step uphill), each step at most ``PROJECTION_MAX_STEP`` of the path length and halved until the
    distance does not grow, so theta moves continuously and never jumps across the path. Where
    Phi' = 0 (clamped spline ends) theta is nudged into the interior first. Open paths: theta is
    clipped to the domain; closed paths: theta is not wrapped (the caller counts laps).
    Returns theta and (Phi, Phi', Phi'') there. (Compiled with numba: it runs twice per sample.)
    """
    return table.project(q, theta_guess, iterations, defaults.PROJECTION_TOLERANCE * table.length,
                         defaults.PROJECTION_MAX_STEP * table.length)


@dataclass(frozen=True)
class TransverseState:
    """theta (unwrapped on closed paths), theta_dot, y = q - Phi(theta) (n,), x_perp = (z, z_dot, I)
    (2n-1,), and Phi, Phi', Phi'' at theta (n,)."""

    theta: float
    theta_dot: float
    y: np.ndarray
    x_perp: np.ndarray
    phi: np.ndarray
    dphi: np.ndarray
    ddphi: np.ndarray


def transverse_state(table: PathTable, basis: TransverseBasis, profile: ProfileLookup,
                     q: np.ndarray, qd: np.ndarray, theta_guess: float) -> TransverseState:
    """Project (q, qd) onto the path and return its transverse coordinates (module docstring)."""
    theta, (phi, dphi, ddphi) = project(table, q, theta_guess)
    y = q - phi
    den = dphi @ dphi - ddphi @ y
    den = max(den, 0.5 * (dphi @ dphi))  # far from the path the section is ill-defined: stay finite
    theta_dot = (dphi @ qd) / den
    ydot = qd - dphi * theta_dot
    z, zdot = basis.coordinates(dphi, ddphi, y, ydot, theta_dot)
    x_star, _ = profile.state(theta)
    x_perp = np.concatenate([z, zdot, [theta_dot * theta_dot - x_star]])
    return TransverseState(theta, theta_dot, y, x_perp, phi, dphi, ddphi)


def transverse_linearization(table: PathTable, basis: TransverseBasis, profile: ProfileLookup,
                             theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A(theta) (N, 2n-1, 2n-1) and B(theta) (N, 2n-1, n) of d x_perp/dt = A x_perp + B dv.

    Linearization of q_ddot = v (the computed-torque inner loop) about the planned motion, with
    v = v*(theta) + dv, v* = Phi' u* + Phi'' x* (docs/control.md, "transverse linearization"):

        dz_ddot = E^T b,   dI_dot = 2 theta_dot* p^T b,   p = Phi'/|Phi'|^2
        b = dv - (x* E'' + u* E') dz - 2 theta_dot* E' dz_dot - Phi'' dI

    E'' is the central difference of the analytic E' over ``theta`` (which must be increasing).
    """
    theta = np.asarray(theta, dtype=float)
    _, dphi, ddphi = table.evaluate(theta)
    e, de = basis.frames(dphi, ddphi)
    dde = np.gradient(de, theta, axis=0)
    n = table.n
    m = n - 1
    xu = np.array([profile.state(th) for th in theta])
    x_star, u_star = xu[:, 0], xu[:, 1]
    theta_dot = np.sqrt(x_star)
    p = dphi / np.sum(dphi * dphi, axis=1, keepdims=True)
    # rows of the "acceleration map" N = [E^T; p^T] applied to the bracket b
    nmat = np.concatenate([np.transpose(e, (0, 2, 1)), p[:, None, :]], axis=1)  # (N, n, n)
    kz = x_star[:, None, None] * dde + u_star[:, None, None] * de  # (N, n, m)
    a_z = -nmat @ kz  # (N, n, m)
    a_zd = -2.0 * theta_dot[:, None, None] * (nmat @ de)  # (N, n, m)
    a_i = -(nmat @ ddphi[:, :, None])  # (N, n, 1)
    rows = np.concatenate([a_z, a_zd, a_i], axis=2)  # d(z_ddot, theta_ddot)/d x_perp, (N, n, 2m+1)
    big = len(theta)
    a = np.zeros((big, 2 * m + 1, 2 * m + 1))
    a[:, :m, m:2 * m] = np.eye(m)
    a[:, m:2 * m, :] = rows[:, :m, :]
    a[:, 2 * m, :] = 2.0 * theta_dot[:, None] * rows[:, m, :]
    b = np.zeros((big, 2 * m + 1, n))
    b[:, m:2 * m, :] = nmat[:, :m, :]
    b[:, 2 * m, :] = 2.0 * theta_dot[:, None] * nmat[:, m, :]
    return a, b
