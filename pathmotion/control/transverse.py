"""Projection onto the path and transverse coordinates of the orbital controller.

Coordinates near the path (see docs/control.md):

    q = Phi(theta) + E(theta) z          theta: projection of q on the path, Phi'(theta)^T (q - Phi) = 0
    x_perp = (z, z_dot, I),  I = theta_dot^2 - x*(theta)

E(theta) (n x (n-1)) is an orthonormal basis of the complement of Phi'(theta): the columns (all but
column k) of the Householder reflection H = I - 2 w w^T / (w^T w), w = t - sigma e_k, t = Phi'/|Phi'|,
which maps sigma e_k onto t. It is smooth in theta as long as t stays away from sigma e_k; (k, sigma)
is chosen once per path to maximize that distance.

The exact time derivatives (used by the controller, not linearized; compiled in
:func:`.kernels.transverse_state`):

    theta_dot = Phi'^T q_dot / (|Phi'|^2 - Phi''^T y)       y = q - Phi(theta)
    z = E^T y,   z_dot = E^T (q_dot - Phi' theta_dot) + theta_dot E'^T y

Shapes: q, qd (n,); z, z_dot (n-1,); x_perp (2n-1,).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..errors import SimulationError
from .kernels import Basis
from .path_table import PathTable
from .profile_lookup import ProfileLookup

#: |Phi'| below which the path is taken to stop (no projection, no basis) [rad per unit theta].
ZERO_SPEED = 1e-12
#: Smallest |t - sigma e_k|^2 along the path the basis accepts (|t - sigma e_k| >= 0.2) [-].
MIN_AXIS_MARGIN = 0.04


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
        if np.any(speed <= ZERO_SPEED):
            i = int(np.argmax(speed <= ZERO_SPEED))
            raise SimulationError(
                f"the joint path has Phi'(theta) = 0 at theta = {theta[i]:.6g}: the projection onto the path "
                "is undefined there; remove the repeated point or the cusp"
            )
        t = dphi / speed[:, None]
        # distance^2 of t from +e_k is 2 - 2 t_k, from -e_k 2 + 2 t_k
        margin_plus = 2.0 - 2.0 * np.max(t, axis=0)
        margin_minus = 2.0 + 2.0 * np.min(t, axis=0)
        best_plus, best_minus = np.max(margin_plus), np.max(margin_minus)
        if max(best_plus, best_minus) < MIN_AXIS_MARGIN:  # the tangent comes near every axis
            raise SimulationError("cannot build a smooth transverse basis along this path (tangent visits every axis)")
        if best_plus >= best_minus:
            return cls(int(np.argmax(margin_plus)), 1.0)
        return cls(int(np.argmax(margin_minus)), -1.0)

    @property
    def arrays(self) -> Basis:
        """The basis as the compiled kernels take it."""
        return Basis(int(self.k), float(self.sigma))

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


def project(table: PathTable, q: np.ndarray, theta_guess: float,
            iterations: int = defaults.PROJECTION_ITERATIONS) -> tuple[float, tuple]:
    """Local projection of q onto the path near ``theta_guess``: argmin |q - Phi(theta)|^2.

    Newton on g(theta) = Phi'^T (q - Phi) = 0 (Gauss-Newton when the curvature term would make the
    step uphill), each step at most ``PROJECTION_MAX_STEP`` of the path length and halved until the
    distance does not grow, so theta moves continuously and never jumps across the path. Where
    Phi' = 0 (clamped spline ends) theta is nudged into the interior first. Open paths: theta is
    clipped to the domain; closed paths: theta is not wrapped (the caller counts laps).
    Returns theta and (Phi, Phi', Phi'') there. (Compiled: :func:`.kernels.project`.)
    """
    return table.project(q, theta_guess, *table.projection(iterations))


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
    xu = profile.states(theta)
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
