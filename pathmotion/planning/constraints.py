"""Every limit in one canonical per-point form, linear in u = theta_ddot and x = theta_dot^2.

At each path point k, rows r = 0..m-1:

    lo[k, r] <= a[k, r] u + b[k, r] x + c[k, r] <= hi[k, r]        and   0 <= x <= x_max[k]

joint acceleration  (a, b, c) = (Phi'_j, Phi''_j, 0),        lo/hi = -/+ qdd_max_j
joint torque        (a, b, c) = (alpha_j, beta_j, gamma_j),  lo/hi = -/+ tau_max_j
joint velocity      x_max <= qd_max_j^2 / Phi'_j^2           (a pure bound on x)
TCP speed           x_max <= v_max^2 / |J_v Phi'|^2          (a pure bound on x)

A new limit is one more function returning rows (or a bound on x). ``scale`` arrays of shape
(K, n) (or (K,) for the TCP speed) multiply the limits point by point: the verify-and-tighten loop
uses them to tighten limits locally.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .reduced import ReducedDynamics


@dataclass(frozen=True)
class EffectiveLimits:
    """Limits the planner enforces (robot limits times the user's scale factors); None = off.

    velocity [rad/s] (n,), acceleration [rad/s^2] (n,), torque [N m] (n,), tcp_speed [m/s].
    """

    velocity: np.ndarray | None
    acceleration: np.ndarray | None
    torque: np.ndarray | None
    tcp_speed: float | None = None


@dataclass(frozen=True, eq=False)
class LimitScale:
    """Point-wise factors (<= 1) on each limit: velocity, acceleration, torque (K, n); tcp (K,)."""

    velocity: np.ndarray
    acceleration: np.ndarray
    torque: np.ndarray
    tcp: np.ndarray

    @classmethod
    def ones(cls, k: int, n: int) -> "LimitScale":
        return cls(np.ones((k, n)), np.ones((k, n)), np.ones((k, n)), np.ones(k))


@dataclass(frozen=True, eq=False)
class PointConstraints:
    """Canonical form at K points: a, b, c, lo, hi (K, m); x_max (K,) (inf where unbounded).

    ``row_kind`` (m,) ("acceleration" | "torque") and ``row_joint`` (m,) name each row.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    x_max: np.ndarray
    row_kind: tuple[str, ...]
    row_joint: tuple[int, ...]


def velocity_bound(dq: np.ndarray, qd_max: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """x_max (K,) from |Phi'_j| theta_dot <= qd_max_j (inf where Phi' = 0)."""
    lim = (qd_max * scale) ** 2
    with np.errstate(divide="ignore"):
        bound = np.where(dq != 0.0, lim / np.where(dq != 0.0, dq**2, 1.0), np.inf)
    return bound.min(axis=1)


def tcp_speed_bound(tcp_gain: np.ndarray, v_max: float, scale: np.ndarray) -> np.ndarray:
    """x_max (K,) from |J_v Phi'| theta_dot <= v_max; ``tcp_gain`` = |J_v Phi'| (K,) [m per unit theta]."""
    with np.errstate(divide="ignore"):
        return np.where(tcp_gain > 0, (v_max * scale) ** 2 / np.where(tcp_gain > 0, tcp_gain**2, 1.0), np.inf)


def acceleration_rows(dq, ddq, qdd_max, scale):
    """Rows (a, b, c, lo, hi), each (K, n): -qdd_max <= Phi' u + Phi'' x <= qdd_max."""
    lim = qdd_max * scale
    return dq, ddq, np.zeros_like(dq), -lim, lim


def torque_rows(red: ReducedDynamics, tau_max, scale):
    """Rows (a, b, c, lo, hi), each (K, n): -tau_max <= alpha u + beta x + gamma <= tau_max."""
    lim = tau_max * scale
    return red.alpha, red.beta, red.gamma, -lim, lim


def point_constraints(
    dq: np.ndarray,
    ddq: np.ndarray,
    limits: EffectiveLimits,
    scale: LimitScale,
    reduced: ReducedDynamics | None = None,
    tcp_gain: np.ndarray | None = None,
    x_cap: float = np.inf,
) -> PointConstraints:
    """Assemble the canonical form from path derivatives dq, ddq (K, n) and the active limits.

    ``reduced`` is needed when the torque limit is on, ``tcp_gain`` when the TCP speed limit is.
    ``x_cap`` bounds x where no limit does.
    """
    k, n = dq.shape
    x_max = np.full(k, float(x_cap))
    if limits.velocity is not None:
        x_max = np.minimum(x_max, velocity_bound(dq, limits.velocity, scale.velocity))
    if limits.tcp_speed is not None:
        x_max = np.minimum(x_max, tcp_speed_bound(tcp_gain, limits.tcp_speed, scale.tcp))
    blocks, kinds, joints = [], [], []
    if limits.acceleration is not None:
        blocks.append(acceleration_rows(dq, ddq, limits.acceleration, scale.acceleration))
        kinds += ["acceleration"] * n
        joints += list(range(n))
    if limits.torque is not None:
        blocks.append(torque_rows(reduced, limits.torque, scale.torque))
        kinds += ["torque"] * n
        joints += list(range(n))
    if blocks:
        a, b, c, lo, hi = (np.concatenate([blk[i] for blk in blocks], axis=1) for i in range(5))
    else:
        a = b = c = lo = hi = np.zeros((k, 0))
    return PointConstraints(a, b, c, lo, hi, x_max, tuple(kinds), tuple(joints))
