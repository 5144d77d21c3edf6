"""Joint torque limit: -tau_max <= alpha u + beta x + gamma <= tau_max (order 2), with the reduced
dynamics alpha, beta, gamma of planning/reduced.py.

A feedback reserve r in [0, 0.5) (``torque_reserve``) keeps r tau_max of every joint free for the
controller: the planner enforces (1 - r) tau_max, and the torque ratio is reported against that
reduced (enforced) limit, so ratio <= 1 means the reserve is intact.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ... import defaults
from ...errors import InfeasibleError, ScenarioError
from ...io.schema import LIMITS
from ..fast_rnea import reduced_batch, supported
from ..reduced import reduced_dynamics
from .base import Limit, LimitChoice, PathPoints, RowForm, Rows

#: The reserve must stay below this fraction of the torque limit [-].
MAX_RESERVE = defaults.MAX_TORQUE_RESERVE


def _reduced_arrays(robot, q, dq, ddq):
    r = reduced_dynamics(robot, q, dq, ddq)
    return r.alpha, r.beta, r.gamma


def reduced(points: PathPoints):
    """(alpha, beta, gamma), each (K, n), at ``points`` (computed once per side)."""
    return points.cached("reduced_dynamics", _reduced_arrays)


def check_reserve(value) -> float:
    """The reserve as a float in [0, MAX_RESERVE), or a ScenarioError naming the key."""
    if isinstance(value, str):
        raise ScenarioError(f"limits.torque_reserve = {value!r}: the planner takes a number in [0, {MAX_RESERVE}); "
                            "'auto' is resolved before planning, by pathmotion.api.resolve_torque_reserve (a search "
                            "over closed-loop runs)")
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not (
            np.isfinite(value) and 0.0 <= value < MAX_RESERVE):
        raise ScenarioError(f"limits.torque_reserve must be a number in [0, {MAX_RESERVE}) (a fraction of each "
                            f"torque limit kept free for feedback), got {value!r}")
    return float(value)


def torque_reserve(choices) -> float:
    """The reserve of the torque limit's choice in ``choices`` {name: LimitChoice} (0 when not given)."""
    choice = choices.get(TorqueLimit.name)
    return 0.0 if choice is None or choice.value is None else float(choice.value)


def _beta_jump(ctx) -> np.ndarray:
    """The jump of beta' = (M Phi'' + C(Phi, Phi') Phi')' at the path's knots on the grid (k, n): M(Phi) times
    the jump of Phi''' (the only term with Phi'''), i.e. alpha = M Phi' evaluated with Phi' := that jump."""
    index, jump = ctx.knots
    if not len(index):
        return jump
    q = ctx.right.q[index]
    if supported(ctx.robot):  # finite inputs (the grid data): the compiled batch without reduced_dynamics' checks
        return reduced_batch(ctx.robot, q, jump, np.zeros_like(jump))[0]
    return reduced_dynamics(ctx.robot, q, jump, np.zeros_like(jump)).alpha


class TorqueLimit(Limit):
    """tau_max [N m] (n,): the robot's joint torque limits times ``torque_scale`` times
    (1 - ``torque_reserve``)."""

    name = "torque"
    order = 2
    needs_torque = True
    names = LIMITS["torque"]
    keys = names.keys
    extra_summary_keys = tuple(k.key for k in names.settings)  # torque_reserve

    def __init__(self, tau_max: np.ndarray, reserve: float = 0.0):
        self.tau_max = np.asarray(tau_max, float)
        self.reserve = float(reserve)

    @classmethod
    def default_choice(cls) -> LimitChoice:
        return LimitChoice(value=defaults.TORQUE_RESERVE)

    @classmethod
    def check_choice(cls, choice: LimitChoice) -> LimitChoice:
        reserve = check_reserve(0.0 if choice.value is None else choice.value)
        super().check_choice(replace(choice, value=None))
        return replace(choice, value=reserve)

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice):
        if not choice.on:
            return None
        reserve = 0.0 if choice.value is None else float(choice.value)
        return cls(robot.limits.torque * choice.scale * (1.0 - reserve), reserve)

    def enforced(self) -> list[float]:
        """tau_max [N m] per joint, scale and reserve applied."""
        return self.tau_max.tolist()

    def summary_values(self) -> dict:
        return {self.extra_summary_keys[0]: self.reserve}

    def rows(self, points, scale, x_ref=None):
        alpha, beta, gamma = reduced(points)
        lim = self.tau_max * scale
        return Rows(alpha, beta, gamma, -lim, lim)

    def check(self, points, joint_names):
        gamma = reduced(points)[2]
        over = np.abs(gamma) > self.tau_max
        if np.any(over):
            k, j = np.argwhere(over)[0]
            kept = f" (with the reserve {self.reserve:g} kept free)" if self.reserve else ""
            raise InfeasibleError(
                f"gravity torque of {joint_names[j]} at theta = {points.theta[k]:.6g} is {gamma[k, j]:.6g} N m, "
                f"beyond its limit +-{self.tau_max[j]:.6g} N m{kept}: the arm cannot hold the path there (nor stop "
                "on it); lower the payload or the torque reserve, raise the torque limit or move the path"
            )

    def certify_row_form(self, ctx):
        (ar, br, gr), (al, bl, gl) = reduced(ctx.right), reduced(ctx.left)
        return RowForm((ar, al), (br, bl), (gr, gl), self.tau_max, knot_jumps=(None, _beta_jump(ctx), None))

    def ratios(self, samples, robot):
        return np.abs(samples.tau) / self.tau_max
