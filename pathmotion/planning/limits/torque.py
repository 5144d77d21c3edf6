"""Joint torque limit: -tau_max <= alpha u + beta x + gamma <= tau_max (order 2), with the reduced
dynamics alpha, beta, gamma of planning/reduced.py."""

from __future__ import annotations

import numpy as np

from ...errors import InfeasibleError
from ..reduced import reduced_dynamics
from .base import Limit, LimitChoice, PathPoints, Rows


def _reduced_arrays(robot, q, dq, ddq):
    r = reduced_dynamics(robot, q, dq, ddq)
    return r.alpha, r.beta, r.gamma


def reduced(points: PathPoints):
    """(alpha, beta, gamma), each (K, n), at ``points`` (computed once per side)."""
    return points.cached("reduced_dynamics", _reduced_arrays)


class TorqueLimit(Limit):
    """tau_max [N m] (n,): the robot's joint torque limits times ``torque_scale``."""

    name = "torque"
    order = 2
    needs_torque = True
    settings_keys = {"torque": "on", "torque_scale": "scale"}
    scenario_keys = {"use_torque": "on", "torque_scale": "scale"}

    def __init__(self, tau_max: np.ndarray):
        self.tau_max = np.asarray(tau_max, float)

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice):
        return cls(robot.limits.torque * choice.scale) if choice.on else None

    def rows(self, points, scale, x_ref=None):
        alpha, beta, gamma = reduced(points)
        lim = self.tau_max * scale
        return Rows(alpha, beta, gamma, -lim, lim)

    def check(self, points, joint_names):
        gamma = reduced(points)[2]
        over = np.abs(gamma) > self.tau_max
        if np.any(over):
            k, j = np.argwhere(over)[0]
            raise InfeasibleError(
                f"gravity torque of {joint_names[j]} at theta = {points.theta[k]:.6g} is {gamma[k, j]:.6g} N m, "
                f"beyond its limit +-{self.tau_max[j]:.6g} N m: the arm cannot hold the path there (nor stop on "
                "it); lower the payload, raise the torque limit or move the path"
            )

    def ratios(self, samples, robot):
        return np.abs(samples.tau) / self.tau_max
