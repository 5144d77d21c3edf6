"""Joint torque-rate limit: |d tau_j / dt| <= R_j with d tau / dt = sqrt(x) (alpha u' + (alpha' + 2 beta) u
+ beta' x + gamma') (order 3); alpha', beta', gamma' exact from the RNEA derivatives and Phi'''."""

from __future__ import annotations

import numpy as np

from ...io.schema import LIMITS
from ..reduced import reduced_derivatives
from .base import Rows3
from .third import PerJointThirdOrder
from .torque import reduced


def _derivatives(points):
    """(alpha', beta', gamma') (K, n) at ``points``, computed once per side."""
    return points.cached("reduced_derivatives", reduced_derivatives, third=True)


class TorqueRateLimit(PerJointThirdOrder):
    """R [N m/s] (n,): ``[limits] torque_rate`` or the robot's; on with ``use_torque_rate``."""

    name = "torque_rate"
    robot_key = "torque_rate"
    names = LIMITS["torque_rate"]
    keys = names.keys
    unit = "N m/s"
    needs_torque = True

    def rows3(self, points, scale):
        alpha, beta, _ = reduced(points)
        alpha_p, beta_p, gamma_p = _derivatives(points)
        return Rows3(alpha, alpha_p + 2.0 * beta, beta_p, gamma_p, self.values * scale)

    def ratios(self, samples, robot):
        return np.abs(samples.tau_dot) / self.values
