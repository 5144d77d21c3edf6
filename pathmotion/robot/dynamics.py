"""Rigid-body dynamics from Pinocchio, for one configuration or a batch.

All functions take q, qd, qdd, tau of shape (n,) or (N, n) and return the same leading shape:
RNEA torques [N m] (N, n); mass matrices (N, n, n); Coriolis matrices C(q, qd) with
C qd = centrifugal + Coriolis torques (N, n, n); gravity torques (N, n); ABA accelerations (N, n).
Pinocchio has no vectorized batch call from Python, so the loop runs over Pinocchio's C++
functions with preallocated outputs.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .kinematics import _as_batch
from .model import Robot


def _args(robot, *arrays):
    out = []
    single = None
    for a in arrays:
        b, s = _as_batch(a, robot.n)
        single = s if single is None else single
        out.append(b)
    lens = {len(b) for b in out}
    if len(lens) > 1:
        from ..errors import PathmotionError

        raise PathmotionError(f"batched arrays have different lengths {sorted(lens)}")
    return out, single


def rnea(robot: Robot, q, qd, qdd) -> np.ndarray:
    """Inverse dynamics tau = M(q) qdd + C(q, qd) qd + G(q)."""
    (qs, qds, qdds), single = _args(robot, q, qd, qdd)
    model, data = robot.model, robot.data
    out = np.empty_like(qs)
    for k in range(len(qs)):
        out[k] = pin.rnea(model, data, qs[k], qds[k], qdds[k])
    return out[0] if single else out


def gravity(robot: Robot, q) -> np.ndarray:
    """Gravity torques G(q)."""
    (qs,), single = _args(robot, q)
    model, data = robot.model, robot.data
    out = np.empty_like(qs)
    for k in range(len(qs)):
        out[k] = pin.computeGeneralizedGravity(model, data, qs[k])
    return out[0] if single else out


def mass_matrix(robot: Robot, q) -> np.ndarray:
    """Joint-space inertia matrix M(q), symmetric."""
    (qs,), single = _args(robot, q)
    model, data = robot.model, robot.data
    out = np.empty((len(qs), robot.n, robot.n))
    for k in range(len(qs)):
        m = pin.crba(model, data, qs[k])
        out[k] = np.triu(m) + np.triu(m, 1).T
    return out[0] if single else out


def coriolis_matrix(robot: Robot, q, qd) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, qd) (Pinocchio's, with Mdot - 2C skew-symmetric)."""
    (qs, qds), single = _args(robot, q, qd)
    model, data = robot.model, robot.data
    out = np.empty((len(qs), robot.n, robot.n))
    for k in range(len(qs)):
        out[k] = pin.computeCoriolisMatrix(model, data, qs[k], qds[k])
    return out[0] if single else out


def aba(robot: Robot, q, qd, tau) -> np.ndarray:
    """Forward dynamics qdd = M^-1 (tau - C qd - G) by the articulated-body algorithm."""
    (qs, qds, taus), single = _args(robot, q, qd, tau)
    model, data = robot.model, robot.data
    out = np.empty_like(qs)
    for k in range(len(qs)):
        out[k] = pin.aba(model, data, qs[k], qds[k], taus[k])
    return out[0] if single else out


def kinetic_energy(robot: Robot, q, qd) -> np.ndarray:
    """Kinetic energy 0.5 qd^T M(q) qd [J], () or (N,)."""
    (qs, qds), single = _args(robot, q, qd)
    model, data = robot.model, robot.data
    out = np.array([pin.computeKineticEnergy(model, data, qs[k], qds[k]) for k in range(len(qs))])
    return out[0] if single else out


def potential_energy(robot: Robot, q) -> np.ndarray:
    """Potential energy in the robot's gravity field [J], () or (N,)."""
    (qs,), single = _args(robot, q)
    model, data = robot.model, robot.data
    out = np.array([pin.computePotentialEnergy(model, data, qs[k]) for k in range(len(qs))])
    return out[0] if single else out
