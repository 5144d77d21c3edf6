"""Torque laws shared by the controllers: computed torque and PD + gravity.

Both take the nominal Pinocchio model (what the controller believes), never the plant's.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def computed_torque(model: pin.Model, data: pin.Data, q: np.ndarray, qd: np.ndarray, v: np.ndarray) -> np.ndarray:
    """tau = M(q) v + C(q, qd) qd + G(q) (one RNEA call) for the commanded acceleration v (n,) [rad/s^2]."""
    return pin.rnea(model, data, q, qd, v)


def pd_gravity(model: pin.Model, data: pin.Data, q: np.ndarray, qd: np.ndarray, q_ref: np.ndarray,
               qd_ref: np.ndarray, kp: np.ndarray, kd: np.ndarray) -> np.ndarray:
    """tau = Kp (q_ref - q) + Kd (qd_ref - qd) + G(q); kp [N m/rad], kd [N m s/rad], (n,)."""
    return kp * (q_ref - q) + kd * (qd_ref - qd) + pin.computeGeneralizedGravity(model, data, q)
