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


def _batched(robot: Robot, fn, arrays, shape: tuple = None) -> np.ndarray:
    """Call ``fn(model, data, *row)`` for every row of the (N, n) ``arrays``; outputs of ``shape``
    per row (default (n,)); a single configuration in, a single result out."""
    rows, single = _args(robot, *arrays)
    model, data = robot.model, robot.data
    out = np.empty((len(rows[0]),) + ((robot.n,) if shape is None else shape))
    for k in range(len(rows[0])):
        out[k] = fn(model, data, *(r[k] for r in rows))
    return out[0] if single else out


def _symmetric_crba(model, data, q):
    m = pin.crba(model, data, q)  # upper triangle only
    return np.triu(m) + np.triu(m, 1).T


def rnea(robot: Robot, q, qd, qdd) -> np.ndarray:
    """Inverse dynamics tau = M(q) qdd + C(q, qd) qd + G(q) [N m]."""
    return _batched(robot, pin.rnea, (q, qd, qdd))


def gravity(robot: Robot, q) -> np.ndarray:
    """Gravity torques G(q) [N m]."""
    return _batched(robot, pin.computeGeneralizedGravity, (q,))


def mass_matrix(robot: Robot, q) -> np.ndarray:
    """Joint-space inertia matrix M(q), symmetric [kg m^2]."""
    return _batched(robot, _symmetric_crba, (q,), (robot.n, robot.n))


def coriolis_matrix(robot: Robot, q, qd) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, qd) (Pinocchio's, with Mdot - 2C skew-symmetric)."""
    return _batched(robot, pin.computeCoriolisMatrix, (q, qd), (robot.n, robot.n))


def aba(robot: Robot, q, qd, tau) -> np.ndarray:
    """Forward dynamics qdd = M^-1 (tau - C qd - G) by the articulated-body algorithm [rad/s^2]."""
    return _batched(robot, pin.aba, (q, qd, tau))


def kinetic_energy(robot: Robot, q, qd) -> np.ndarray:
    """Kinetic energy 0.5 qd^T M(q) qd [J], () or (N,)."""
    return _batched(robot, pin.computeKineticEnergy, (q, qd), ())


def potential_energy(robot: Robot, q) -> np.ndarray:
    """Potential energy in the robot's gravity field [J], () or (N,)."""
    return _batched(robot, pin.computePotentialEnergy, (q,), ())
