"""Reduced dynamics along a path: tau = alpha(theta) theta_ddot + beta(theta) theta_dot^2 + gamma(theta).

With q = Phi(theta), qd = Phi' theta_dot and qdd = Phi' theta_ddot + Phi'' theta_dot^2, inverse
dynamics is affine in (theta_ddot, theta_dot^2). Three RNEA calls per point give the coefficients:

    gamma = RNEA(Phi, 0, 0)                  (gravity)
    alpha = RNEA(Phi, 0, Phi') - gamma       (= M(Phi) Phi')
    beta  = RNEA(Phi, Phi', Phi'') - gamma   (= M(Phi) Phi'' + C(Phi, Phi') Phi')

The second uses that RNEA is linear in qdd at qd = 0; the third that it is quadratic in qd and
linear in qdd, so RNEA(Phi, Phi' s, Phi'' s^2) - gamma = s^2 beta for any s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..robot import Robot, rnea


@dataclass(frozen=True, eq=False)
class ReducedDynamics:
    """alpha [N m s^2 per unit theta], beta [N m s^2 per unit theta^2], gamma [N m]; each (N, n)."""

    alpha: np.ndarray
    beta: np.ndarray
    gamma: np.ndarray

    def torque(self, theta_ddot, theta_dot_squared) -> np.ndarray:
        """tau (N, n) [N m] for theta_ddot and theta_dot^2 of shape (N,) (or scalars)."""
        u = np.asarray(theta_ddot, dtype=float)[..., None]
        x = np.asarray(theta_dot_squared, dtype=float)[..., None]
        return self.alpha * u + self.beta * x + self.gamma


def reduced_dynamics(robot: Robot, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> ReducedDynamics:
    """Coefficients at N path points: q = Phi, dq = Phi', ddq = Phi'' of shape (N, n)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    dq = np.atleast_2d(np.asarray(dq, dtype=float))
    ddq = np.atleast_2d(np.asarray(ddq, dtype=float))
    zero = np.zeros_like(q)
    gamma = rnea(robot, q, zero, zero)
    alpha = rnea(robot, q, zero, dq) - gamma
    beta = rnea(robot, q, dq, ddq) - gamma
    return ReducedDynamics(alpha, beta, gamma)
