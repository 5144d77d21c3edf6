"""Reduced dynamics along a path: tau = alpha(theta) theta_ddot + beta(theta) theta_dot^2 + gamma(theta).

With q = Phi(theta), qd = Phi' theta_dot and qdd = Phi' theta_ddot + Phi'' theta_dot^2, inverse
dynamics is affine in (theta_ddot, theta_dot^2). Three RNEA calls per point give the coefficients:

    gamma = RNEA(Phi, 0, 0)                  (gravity)
    alpha = RNEA(Phi, 0, Phi') - gamma       (= M(Phi) Phi')
    beta  = RNEA(Phi, Phi', Phi'') - gamma   (= M(Phi) Phi'' + C(Phi, Phi') Phi')

The second uses that RNEA is linear in qdd at qd = 0; the third that it is quadratic in qd and
linear in qdd, so RNEA(Phi, Phi' s, Phi'' s^2) - gamma = s^2 beta for any s. The three run as one
compiled batch (fast_rnea.py: gravity alone, then the two gravity-free passes, sharing the kinematics)
where the model allows, else as Pinocchio calls point by point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import pinocchio as pin

from ..errors import InfeasibleError, PathError, require_finite
from ..robot import Robot, rnea
from .fast_rnea import reduced_batch, supported

#: What to change when a coefficient overflows (one place for the three checks).
_CHANGE_DYNAMICS = ("lower the payload mass or move its centre of mass nearer the flange (robot.payload), or check the "
                    "URDF's masses and inertias")


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
    names = robot.joint_names
    for value, what in ((q, "Phi(theta)"), (dq, "Phi'(theta)"), (ddq, "Phi''(theta)")):
        require_finite(value, f"the joint path's {what}", "the path passes a singularity or its points are not "
                       "finite; move the path away from it or sample it differently", PathError, names)
    with np.errstate(all="ignore"):
        if supported(robot):
            alpha, beta, gamma = reduced_batch(robot, q, dq, ddq)
        else:
            zero = np.zeros_like(q)
            gamma = rnea(robot, q, zero, zero)
            alpha = rnea(robot, q, zero, dq) - gamma
            beta = rnea(robot, q, dq, ddq) - gamma
    require_finite(gamma, "reduced dynamics gamma (gravity torque)", _CHANGE_DYNAMICS, InfeasibleError, names)
    require_finite(alpha, "reduced dynamics alpha (M Phi')", _CHANGE_DYNAMICS, InfeasibleError, names)
    require_finite(beta, "reduced dynamics beta (M Phi'' + C Phi')", _CHANGE_DYNAMICS, InfeasibleError, names)
    return ReducedDynamics(alpha, beta, gamma)


def _rnea_derivatives(model, data, q, v, a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dtau/dq, dtau/dqd, M) (n, n) at one point (Pinocchio's analytic RNEA derivatives; M
    symmetrized, armature included)."""
    dq, dv, m = pin.computeRNEADerivatives(model, data, q, v, a)
    m = np.triu(m) + np.triu(m, 1).T
    return np.array(dq), np.array(dv), m


def torque_derivative(robot: Robot, q, qd, qdd, qddd) -> np.ndarray:
    """d tau / dt (N, n) [N m/s] = dtau/dq qd + dtau/dqd qdd + M qddd along a motion; inputs (N, n)."""
    model, data = robot.model, robot.data
    out = np.empty_like(np.asarray(q, float))
    for k in range(len(out)):
        dq, dv, m = _rnea_derivatives(model, data, q[k], qd[k], qdd[k])
        out[k] = dq @ qd[k] + dv @ qdd[k] + m @ qddd[k]
    return out


def reduced_derivatives(robot: Robot, q, dq, ddq, dddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(alpha', beta', gamma') (N, n): the theta-derivatives of the reduced dynamics, exact from the
    RNEA derivatives and Phi''' (gamma' = d_q RNEA(Phi, 0, 0) Phi'; alpha' = d_q RNEA(Phi, 0, Phi')
    Phi' + M Phi'' - gamma'; beta' = d_q RNEA(Phi, Phi', Phi'') Phi' + d_qd RNEA(...) Phi'' + M Phi''' - gamma')."""
    model, data = robot.model, robot.data
    n = robot.n
    out = np.empty((3,) + np.shape(q))
    zero = np.zeros(n)
    for k in range(len(q)):
        g_q, _, m = _rnea_derivatives(model, data, q[k], zero, zero)
        gamma_p = g_q @ dq[k]
        a_q, _, _ = _rnea_derivatives(model, data, q[k], zero, dq[k])
        b_q, b_v, _ = _rnea_derivatives(model, data, q[k], dq[k], ddq[k])
        out[0, k] = a_q @ dq[k] + m @ ddq[k] - gamma_p
        out[1, k] = b_q @ dq[k] + b_v @ ddq[k] + m @ dddq[k] - gamma_p
        out[2, k] = gamma_p
    return out[0], out[1], out[2]
