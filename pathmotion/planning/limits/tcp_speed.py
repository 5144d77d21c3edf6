"""TCP speed limit: |J_v Phi'| theta_dot <= v_max, a bound on x (order 1)."""

from __future__ import annotations

import numpy as np

from ...io.schema import LIMITS
from ...robot import jacobian
from .base import Limit, LimitChoice, PathPoints, RowForm, safe_ratio_bound


def _linear_speed(robot, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """|J_v(q) qd| (N,) [m/s per unit of qd]: the TCP's linear speed."""
    jv = jacobian(robot, q)[:, :3, :]
    return np.linalg.norm(np.einsum("kij,kj->ki", jv, qd), axis=1)


def tcp_gain(points: PathPoints) -> np.ndarray:
    """|J_v Phi'| (K,) [m per unit theta]: TCP speed per unit theta_dot (computed once per side)."""
    return points.cached("tcp_gain", lambda robot, q, dq, ddq: (_linear_speed(robot, q, dq),))[0]


class TcpSpeedLimit(Limit):
    """v_max [m/s]: a TCP speed the user gives (``tcp_speed``; off when None)."""

    name = "tcp_speed"
    order = 1
    per_joint = False
    unit = "m/s"
    names = LIMITS["tcp_speed"]
    keys = names.keys

    def __init__(self, v_max: float):
        self.v_max = float(v_max)

    @classmethod
    def default_choice(cls) -> LimitChoice:
        return LimitChoice(on=False)

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice):
        return None if choice.value is None else cls(choice.value)

    def bound(self, points, scale):
        with np.errstate(over="ignore"):  # a speed limit whose square overflows bounds nothing: inf, as meant
            limit_sq = (self.v_max * scale[:, 0]) ** 2
        return safe_ratio_bound(limit_sq, tcp_gain(points))

    def certify_row_form(self, ctx):
        g = tuple((tcp_gain(pts) / self.v_max)[:, None] ** 2 for pts in (ctx.right, ctx.left))
        return RowForm(None, g, None, np.ones(1), squared=True)

    def enforced(self) -> float:
        """v_max [m/s]."""
        return self.v_max

    def ratios(self, samples, robot):
        return (_linear_speed(robot, samples.q, samples.qd) / self.v_max)[:, None]

    def column_name(self, j, joint_names):
        return "TCP"
