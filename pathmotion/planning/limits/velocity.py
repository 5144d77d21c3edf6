"""Joint velocity limit: |Phi'_j| theta_dot <= qd_max_j, a bound on x (order 1)."""

from __future__ import annotations

import numpy as np

from ...io.schema import LIMITS
from .base import Limit, LimitChoice, RowForm, safe_ratio_bound


class VelocityLimit(Limit):
    """qd_max [rad/s] (n,): the robot's joint speed limits times ``velocity_scale``."""

    name = "velocity"
    order = 1
    names = LIMITS["velocity"]
    keys = names.keys

    def __init__(self, qd_max: np.ndarray):
        self.qd_max = np.asarray(qd_max, float)

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice):
        return cls(robot.limits.velocity * choice.scale) if choice.on else None

    def bound(self, points, scale):
        return safe_ratio_bound((self.qd_max * scale) ** 2, points.dq).min(axis=1)

    def certify_row_form(self, ctx):
        g = tuple((pts.dq / self.qd_max) ** 2 for pts in (ctx.right, ctx.left))
        return RowForm(None, g, None, np.ones(len(self.qd_max)), squared=True)

    def enforced(self) -> list[float]:
        """qd_max [rad/s] per joint."""
        return self.qd_max.tolist()

    def ratios(self, samples, robot):
        return np.abs(samples.qd) / self.qd_max
