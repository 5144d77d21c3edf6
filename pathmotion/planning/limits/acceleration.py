"""Joint acceleration limit: -qdd_max <= Phi' u + Phi'' x <= qdd_max (order 2)."""

from __future__ import annotations

import numpy as np

from ...io.schema import LIMITS
from .base import Limit, LimitChoice, RowForm, Rows


class AccelerationLimit(Limit):
    """qdd_max [rad/s^2] (n,): the robot's joint acceleration limits times ``acceleration_scale``
    (off when the robot gives none)."""

    name = "acceleration"
    order = 2
    names = LIMITS["acceleration"]
    keys = names.keys

    def __init__(self, qdd_max: np.ndarray):
        self.qdd_max = np.asarray(qdd_max, float)

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice):
        if not choice.on or robot.limits.acceleration is None:
            return None
        return cls(robot.limits.acceleration * choice.scale)

    def rows(self, points, scale, x_ref=None):
        lim = self.qdd_max * scale
        return Rows(points.dq, points.ddq, np.zeros_like(points.dq), -lim, lim)

    def certify_row_form(self, ctx):
        r, l = ctx.right, ctx.left
        # b = Phi'': its slope jumps with Phi''' at a knot
        return RowForm((r.dq, l.dq), (r.ddq, l.ddq), None, self.qdd_max, knot_jumps=(None, ctx.knots[1], None))

    def enforced(self) -> list[float]:
        """qdd_max [rad/s^2] per joint."""
        return self.qdd_max.tolist()

    def ratios(self, samples, robot):
        return np.abs(samples.qdd) / self.qdd_max
