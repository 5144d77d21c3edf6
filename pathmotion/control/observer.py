"""Disturbance observer of the orbital controller, and its gain designed on the sampled, delayed loop.

The computed-torque loop tau = M(q) v + C(q, qd) qd + G(q) (nominal model) makes the arm q_ddot = v only when
the model is right. The observer estimates the torque the model lacks from the measured speeds and the torque
applied over the last sample,

    delta_k = tau_applied - M(q) a - C(q, qd) qd - G(q),   a = (qd_k - qd_k-1) / Ts   (model at the sample's middle)
    delta_hat_k = delta_hat_k-1 + g (delta_k - delta_hat_k-1),       tau = tau_law + delta_hat

(an unmodelled payload's gravity and inertia, friction, link inertia errors). tau_applied is the command
``delay`` samples old, saturated at the torque limits, so the estimate measures the plant and never winds up
against a limit. A constant load is taken up within a few samples instead of the integral action's 1/integral_rate.

The gain g. On one transverse direction the law is the triple integrator chain (xi, z, z_dot) closed by the
orbital gains (the sampled design's discrete LQR with the commands in flight, or the continuous gains sampled),
and a plant whose inertia is r times the model's turns the command u into the acceleration u / r. With the
observer the loop's gain on a lighter plant grows by (1/r - 1) Q, Q the observer's filter behind delay + 1
samples: a fast observer with a delay is what makes a plant lighter than the model oscillate. g is the largest
per-sample gain with which that sampled loop (:func:`chain_loop`) is stable for every inertia ratio r in
[1 / F, F], F = ``OrbitalGains.observer_range``: the robustness is stated in the plant's terms, and g follows
from the sample time, the delay and the outer gains; 0 where the loop without observer already fails that
range (there the observer is off).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin

from .gains import OrbitalGains
from .riccati import sampled_cost, with_delay

#: Inertia ratios r in [1/F, F] on which the sampled loop's stability is checked (log-spaced) [-].
RATIO_POINTS = 33
#: Bisection steps of the observer gain (to 2^-16).
GAIN_BISECTIONS = 16
#: Doubling steps of the discrete Riccati solution (quadratic convergence: far more than needed) and its tolerance.
DOUBLING_STEPS = 60
DOUBLING_TOLERANCE = 1e-12
#: Index of delta_hat in the scalar loop's state (:func:`_chain_step`).
ESTIMATE = 5
#: Spectral radius below which the sampled loop counts as stable [-].
STABLE_RADIUS = 1.0 - 1e-9


def chain_feedback(gains: OrbitalGains, sample_time: float, delay: int, sampled: bool) -> np.ndarray:
    """The orbital law's gains (3 + delay,) on one transverse direction, state (xi, z, z_dot, dv in flight):
    the discrete LQR of the triple integrator xi' = z, z'' = dv sampled at ``sample_time`` [s] with the delay in
    the model and the exactly sampled cost of :func:`.orbital.lqr_weights`' chain weights (``sampled``), or the
    continuous gains (w_i w^2, w^2 + 2 zeta w w_i, w_i + 2 zeta w) held over the sample (no commands in flight)."""
    if not sampled:
        kp, kd, ki = gains.clock_gains
        return np.concatenate([[ki, kp, kd], np.zeros(delay)])
    a = np.zeros((1, 3, 3))
    a[0, 0, 1] = a[0, 1, 2] = 1.0
    b = np.zeros((1, 3, 1))
    b[0, 2, 0] = 1.0
    phi, gamma, w = sampled_cost(a, b, np.diag(gains.chain_weights)[None], sample_time)
    phi, gamma = with_delay(phi, gamma, delay)
    size = phi.shape[1]
    q, s, r = np.zeros((size, size)), np.zeros((size, 1)), np.array([[sample_time]])
    if delay == 0:
        q[:], s[:], r = w[0, :3, :3], w[0, :3, 3:], r + w[0, 3:, 3:]
    else:
        q[:4, :4] = w[0]
    p = stationary_riccati(phi[0], gamma[0], q, r, s)
    return np.linalg.solve(r + gamma[0].T @ p @ gamma[0], gamma[0].T @ p @ phi[0] + s.T)[0]


def stationary_riccati(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The stabilizing solution P (d, d) of the discrete algebraic Riccati equation of the cost x^T Q x + 2 x^T S u +
    u^T R u, a (d, d), b (d, m), by the structure-preserving doubling algorithm (Chu, Fan, Lin 2005; quadratic
    convergence, no inverse of A: the delay's shift blocks are singular) after removing the cross term
    (A - B R^-1 S^T, Q - S R^-1 S^T). tests/test_control_observer.py checks it against scipy."""
    r_inv = np.linalg.inv(r)
    ak = a - b @ r_inv @ s.T
    hk = q - s @ r_inv @ s.T
    gk = b @ r_inv @ b.T
    eye = np.eye(len(a))
    for _ in range(DOUBLING_STEPS):
        w = np.linalg.inv(eye + gk @ hk)
        h_next = hk + ak.T @ hk @ w @ ak
        gk, ak = gk + ak @ w @ gk @ ak.T, ak @ w @ ak
        done = np.max(np.abs(h_next - hk)) <= DOUBLING_TOLERANCE * max(np.max(np.abs(h_next)), 1.0)
        hk = h_next
        if done:
            break
    return 0.5 * (hk + hk.T)


def _chain_step(x: np.ndarray, k: np.ndarray, ts: float, delay: int, gain: float, inv_ratio: float) -> np.ndarray:
    """One sample of the scalar loop, state (xi, z, z_dot, z_dot before, u applied before, delta_hat, u in flight
    (delay), dv in flight (delay)), in the order the controller computes it."""
    xi, z, zd, zd_before, u_before, est = x[:6]
    u_flight, dv_flight = x[6:6 + delay], x[6 + delay:]
    est = est + gain * (u_before - (zd - zd_before) / ts - est)
    xi = xi + ts * z
    dv = -(k[:3] @ np.array([xi, z, zd]) + k[3:] @ dv_flight)
    u = dv + est
    applied = u_flight[0] if delay else u
    acc = applied * inv_ratio
    return np.concatenate([[xi, z + ts * zd + 0.5 * ts * ts * acc, zd + ts * acc, zd, applied, est],
                           np.append(u_flight[1:], u) if delay else [], np.append(dv_flight[1:], dv) if delay else []])


def chain_loop(k: np.ndarray, sample_time: float, delay: int) -> tuple[np.ndarray, ...]:
    """(A00, Ag, As, Ags): the one-sample map of the scalar loop (:func:`_chain_step`) with the orbital gains k is
    A00 + g Ag + s As + g s Ags for observer gain g and inverse inertia ratio s = 1/r (it is bilinear in both)."""
    size = 6 + 2 * delay
    eye = np.eye(size)

    def matrix(g: float, s: float) -> np.ndarray:
        return np.column_stack([_chain_step(e, k, sample_time, delay, g, s) for e in eye])

    a00, a10, a01, a11 = matrix(0.0, 0.0), matrix(1.0, 0.0), matrix(0.0, 1.0), matrix(1.0, 1.0)
    return a00, a10 - a00, a01 - a00, a11 - a10 - a01 + a00


def loop_radius(parts: tuple[np.ndarray, ...], gain: float, ratios: np.ndarray) -> np.ndarray:
    """Spectral radius (R,) of the scalar loop for observer gain ``gain`` and inertia ratios ``ratios`` (R,). With
    gain 0 the estimate is a constant input (its row is the identity's: an eigenvalue 1 that is not the loop's):
    the loop is the matrix without it."""
    a00, ag, as_, ags = parts
    s = (1.0 / np.asarray(ratios, float))[:, None, None]
    a = a00 + gain * ag + s * (as_ + gain * ags)
    if gain == 0.0:
        keep = np.delete(np.arange(a.shape[1]), ESTIMATE)
        a = a[:, keep][:, :, keep]
    return np.max(np.abs(np.linalg.eigvals(a)), axis=1)


@functools.lru_cache(maxsize=64)
def observer_gain(gains: OrbitalGains, sample_time: float, delay: int, sampled: bool = True) -> float:
    """The largest per-sample gain g in [0, 1] of the disturbance observer with which the sampled loop of one
    transverse direction (:func:`chain_loop`) is stable for every plant inertia between 1/F and F times the
    model's, F = ``gains.observer_range`` (inf: 0, no observer); 0 where the loop without the observer is not."""
    ratio = gains.observer_range
    if not math.isfinite(ratio):
        return 0.0
    parts = chain_loop(chain_feedback(gains, sample_time, delay, sampled), sample_time, delay)
    ratios = np.geomspace(1.0 / ratio, ratio, RATIO_POINTS)

    def stable(g: float) -> bool:
        return bool(np.all(loop_radius(parts, g, ratios) < STABLE_RADIUS))

    if not stable(0.0):
        return 0.0
    if stable(1.0):
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(GAIN_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


class DisturbanceObserver:
    """Running estimate delta_hat (n,) [N m] of the torque the nominal model lacks (module docstring), with the
    per-sample ``gain`` (0: off) and the command applied ``delay`` samples late. With a ``payload`` estimator
    (:class:`.payload.PayloadEstimator`) the residual first updates the payload estimate, and the observer sees
    only what the estimated payload does not explain (the controller's model is then nominal + payload). Per
    sample: :meth:`measure` with the sensor's (q, qd), then :meth:`command` with the law's torque."""

    def __init__(self, model: pin.Model, sample_time: float, gain: float, delay: int, torque_limit: np.ndarray,
                 payload=None):
        self.model, self.data = model, model.createData()
        self.ts, self.gain, self.delay, self.limit = float(sample_time), float(gain), int(delay), torque_limit
        self.payload = payload
        self.active = self.gain > 0.0 or payload is not None
        self.estimate = np.zeros(len(torque_limit))
        self.previous: tuple[np.ndarray, np.ndarray] | None = None
        self.applied: list[np.ndarray] = []  # the commands still to act, oldest (acting now) first
        self.offsets: list[np.ndarray] = []  # the law's torque offsets beyond the model in them (friction)

    def measure(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Update the estimates with the sample that just ended (nothing on the first call)."""
        if not self.active:
            return
        if self.previous is not None and self.applied:
            q0, qd0 = self.previous
            acc = (qd - qd0) / self.ts
            q_mid, qd_mid = 0.5 * (q + q0), 0.5 * (qd + qd0)
            delta = self.applied[0] - pin.rnea(self.model, self.data, q_mid, qd_mid, acc)
            if self.payload is not None:
                delta = self.payload.update(q_mid, qd_mid, acc, delta) - self.offsets[0]
            if self.gain > 0.0:
                self.estimate += self.gain * (delta - self.estimate)
            if len(self.applied) > self.delay:
                self.applied.pop(0)
                self.offsets.pop(0)
        self.previous = (q.copy(), qd.copy())

    def command(self, tau: np.ndarray, offset: np.ndarray | None = None) -> np.ndarray:
        """The law's torque tau (n,) plus the estimate; its saturated value is kept for the sample it acts in, with
        ``offset`` (n,) [N m], the part of tau that is not the model's torque at the measured state (the friction
        compensated at the planned velocity): the observer estimates what the law's model AND offset miss."""
        if not self.active:
            return tau
        tau = tau + self.estimate
        self.applied.append(np.clip(tau, -self.limit, self.limit))
        self.offsets.append(np.zeros(len(tau)) if offset is None else offset)
        return tau
