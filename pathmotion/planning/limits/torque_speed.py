"""The motors' torque-speed envelope: |tau_j| <= tau_max_j g(|qd_j| / qd_max_j), with g = 1 up to the
knee, then linear down to ``at_max_speed`` at the velocity limit (a servo's peak-torque curve).

tau_max is the enforced torque limit (robot x torque_scale x (1 - torque_reserve)); qd_max is the
robot's joint velocity limit (the drive's rated top speed; velocity_scale does not move the curve).

In the planner's variables (u, x = theta_dot^2) the right side is h(x) = min(T, f(x)) with
f(x) = T (1 + c knee - c w sqrt(x)), w = |Phi'_j| / qd_max_j, c = (1 - at_max_speed) / (1 - knee).
h is not convex (concave kink at the knee) but f is convex, so it lies above each of its tangents:
min(T, tangent of f at x_ref) <= h is a certified conservative (inner) linear form. Each side of
|tau| gets the flat row and the tangent row; the tangent is taken at max(x_ref, x_knee), x_ref the
previous solve's x (the planner re-solves until the duration settles), x_knee where the envelope
starts to fall. The verification evaluates g exactly on the resample.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ...io.schema import LIMITS
from ...errors import ScenarioError
from .base import Limit, LimitChoice, Rows
from .torque import TorqueLimit, reduced, torque_reserve

#: A one-sided row's open side [N m] (finite: the projections multiply bounds by coefficients).
OPEN_SIDE = 1e12


def _pair(value, key: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(knee, at_max_speed) tuples from {knee, at_max_speed} (scalars or per-joint lists)."""
    if isinstance(value, Mapping):
        unknown = set(value) - {"knee", "at_max_speed"}
        if unknown:
            raise ScenarioError(f"{key}: unknown key(s) {sorted(unknown)}; give knee and at_max_speed")
        value = (value.get("knee", 0.5), value.get("at_max_speed", 0.5))
    if not (isinstance(value, tuple) and len(value) == 2):
        raise ScenarioError(f"{key} must be a table {{knee = ..., at_max_speed = ...}}, got {value!r}")
    out = []
    for name, v in zip(("knee", "at_max_speed"), value):
        arr = np.atleast_1d(np.asarray(v, dtype=object))
        ok = arr.ndim == 1 and arr.size > 0 and all(
            isinstance(a, (int, float, np.floating)) and not isinstance(a, bool) and np.isfinite(a) and 0 < a <= 1
            for a in arr)
        if not ok:
            raise ScenarioError(f"{key}.{name} must be a number or a per-joint list of numbers in (0, 1], got {v!r}")
        out.append(tuple(float(a) for a in arr))
    return out[0], out[1]


class TorqueSpeedLimit(Limit):
    """Envelope tau_max g(|qd| / qd_max) per joint; value = (knee, at_max_speed) tuples (length 1 or n)."""

    name = "torque_speed"
    order = 2
    needs_torque = True
    relinearize = True
    uses_choices = True
    names = LIMITS["torque_speed"]
    keys = names.keys

    def __init__(self, tau_max: np.ndarray, qd_max: np.ndarray, knee: np.ndarray, at_max_speed: np.ndarray):
        self.tau_max = np.asarray(tau_max, float)
        self.qd_max = np.asarray(qd_max, float)
        self.knee = np.broadcast_to(np.asarray(knee, float), self.tau_max.shape).copy()
        self.at_max_speed = np.broadcast_to(np.asarray(at_max_speed, float), self.tau_max.shape).copy()
        drop = 1.0 - self.at_max_speed
        span = 1.0 - self.knee
        self.slope = np.where(span > 0, drop / np.where(span > 0, span, 1.0), 0.0)  # c

    @classmethod
    def default_choice(cls) -> LimitChoice:
        return LimitChoice(on=False)

    @classmethod
    def check_choice(cls, choice: LimitChoice) -> LimitChoice:
        if choice.value is None:
            return replace(choice, on=False)
        return replace(choice, on=True, value=_pair(choice.value, "limits.torque_speed"))

    @classmethod
    def from_robot(cls, robot, choice: LimitChoice, choices=None):
        if not choice.on or choice.value is None:
            return None
        knee, at_max = choice.value
        for name, v in (("knee", knee), ("at_max_speed", at_max)):
            if len(v) not in (1, robot.n):
                raise ScenarioError(f"limits.torque_speed.{name} has {len(v)} values; give one or one per joint "
                                    f"({robot.n}: {list(robot.joint_names)})")
        choices = choices or {}
        torque = choices.get(TorqueLimit.name, TorqueLimit.default_choice())
        tau = robot.limits.torque * torque.scale * (1.0 - torque_reserve(choices))
        return cls(tau, robot.limits.velocity, knee, at_max)

    def envelope(self, qd: np.ndarray) -> np.ndarray:
        """g(|qd| / qd_max) (N, n) [-] (may fall below 0 beyond the velocity limit)."""
        v = np.abs(qd) / self.qd_max
        return 1.0 - self.slope * np.maximum(v - self.knee, 0.0)

    def tangent(self, dq: np.ndarray, scale: np.ndarray, x_ref: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(T0, T1) (K, n): min(T, T0 + T1 x) <= the envelope in x, tangent at max(x_ref, x_knee)."""
        big = self.tau_max * scale
        w = np.abs(dq) / self.qd_max
        falls = (w > 0) & (self.slope > 0)
        ws = np.where(falls, w, 1.0)
        x_knee = (self.knee / ws) ** 2
        xr = x_knee if x_ref is None else np.maximum(np.asarray(x_ref, float)[:, None], x_knee)
        root = np.sqrt(xr)
        t0 = big * (1.0 + self.slope * self.knee - 0.5 * self.slope * ws * root)
        t1 = -big * self.slope * ws / (2.0 * root)
        return np.where(falls, t0, big), np.where(falls, t1, 0.0)

    def rows(self, points, scale, x_ref=None):
        alpha, beta, gamma = reduced(points)
        big = self.tau_max * scale
        t0, t1 = self.tangent(points.dq, scale, x_ref)
        open_side = np.full_like(big, OPEN_SIDE)
        # flat |tau| <= T; tau <= T0 + T1 x; tau >= -(T0 + T1 x)
        return Rows(np.concatenate([alpha, alpha, alpha], axis=1),
                    np.concatenate([beta, beta - t1, beta + t1], axis=1),
                    np.concatenate([gamma, gamma, gamma], axis=1),
                    np.concatenate([-big, -open_side, -t0], axis=1),
                    np.concatenate([big, t0, open_side], axis=1))

    def enforced(self) -> dict:
        """{"knee", "at_max_speed"}: the envelope's fractions [-] per joint."""
        return {"knee": self.knee.tolist(), "at_max_speed": self.at_max_speed.tolist()}

    def ratios(self, samples, robot):
        g = self.envelope(samples.qd)
        with np.errstate(divide="ignore"):
            return np.where(g > 0, np.abs(samples.tau) / (self.tau_max * np.where(g > 0, g, 1.0)), np.inf)
