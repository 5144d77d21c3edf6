"""Joint jerk limit: |q'''_j| <= J_j with q''' = Phi''' theta_dot^3 + 3 Phi'' theta_dot theta_ddot
+ Phi' theta_dddot = sqrt(x) (Phi''' x + 3 Phi'' u + Phi' u'), u' = d theta_ddot / d theta (order 3)."""

from __future__ import annotations

import numpy as np

from ...io.schema import LIMITS
from .base import Rows3
from .third import PerJointThirdOrder


class JerkLimit(PerJointThirdOrder):
    """J [rad/s^3] (n,): ``[limits] jerk`` or the robot's, times ``jerk_scale``; on with ``use_jerk``."""

    name = "jerk"
    robot_key = "jerk"
    names = LIMITS["jerk"]
    keys = names.keys
    unit = "rad/s^3"

    def rows3(self, points, scale):
        return Rows3(points.dq, 3.0 * points.ddq, points.dddq, np.zeros_like(points.dq), self.values * scale)

    def ratios(self, samples, robot):
        return np.abs(samples.qddd) / self.values
