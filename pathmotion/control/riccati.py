"""Riccati differential equation of a linear time-varying system, integrated backward in time.

    -dP/dt = A^T P + P A - P B R^-1 B^T P + Q,        K = R^-1 B^T P

A, B, Q are given at increasing times (M,) and interpolated linearly between them. Open horizon:
P(T) = P_end, integrated back to t = 0. Periodic (A, B, Q of period T): the backward map over one
period is iterated from P_end until P(0) = P(T) to ``defaults.RICCATI_TOLERANCE`` (the periodic
solution of a stabilizable and detectable periodic system attracts the backward iteration;
Bittanti, Colaneri, De Nicolao, "The periodic Riccati equation", 1991).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from .. import defaults
from ..errors import SimulationError

#: Absolute tolerance of the integration relative to the relative one times the scale of Q [-].
ABSOLUTE_FRACTION = 1e-3
#: Floor of the norm a change of P is measured against (P = 0) [-].
TINY = 1e-300


def _interpolator(times: np.ndarray, values: np.ndarray):
    def at(t: float) -> np.ndarray:
        i = min(max(int(np.searchsorted(times, t, side="right")) - 1, 0), len(times) - 2)
        w = (t - times[i]) / (times[i + 1] - times[i])
        w = min(max(w, 0.0), 1.0)
        return values[i] + w * (values[i + 1] - values[i])

    return at


@numba.njit(cache=True)
def _riccati_rate(p, a, s, q):
    """dP/dt = -(A^T P + P A - P S P + Q), S = B R^-1 B^T."""
    pa = p @ a
    return -(pa + pa.T - p @ s @ p + q)


@numba.njit(cache=True)
def _rk4_sweep(times, a, s, q, p_final, max_step):
    """P at ``times`` (M, d, d), integrated backward from P(times[-1]) = p_final with classical RK4, at least
    one step per interval and steps <= max_step [s]; A, S, Q linear in t inside each interval."""
    big = len(times)
    out = np.empty((big, p_final.shape[0], p_final.shape[1]))
    p = p_final.copy()
    out[big - 1] = p
    for i in range(big - 2, -1, -1):
        span = times[i + 1] - times[i]
        steps = max(1, int(np.ceil(span / max_step)))
        h = span / steps
        da, ds, dq = a[i + 1] - a[i], s[i + 1] - s[i], q[i + 1] - q[i]
        for j in range(steps):  # from w1 down to w0 (fractions of the interval)
            w1 = 1.0 - j / steps
            wm = w1 - 0.5 / steps
            w0 = w1 - 1.0 / steps
            a1, s1, q1 = a[i] + w1 * da, s[i] + w1 * ds, q[i] + w1 * dq
            am, sm, qm = a[i] + wm * da, s[i] + wm * ds, q[i] + wm * dq
            a0, s0, q0 = a[i] + w0 * da, s[i] + w0 * ds, q[i] + w0 * dq
            k1 = _riccati_rate(p, a1, s1, q1)
            k2 = _riccati_rate(p - 0.5 * h * k1, am, sm, qm)
            k3 = _riccati_rate(p - 0.5 * h * k2, am, sm, qm)
            k4 = _riccati_rate(p - h * k3, a0, s0, q0)
            p = p - h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            p = 0.5 * (p + p.T)
        out[i] = p
    return out


def solve_riccati(times: np.ndarray, a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray,
                  p_end: np.ndarray, periodic: bool = False) -> np.ndarray:
    """P at ``times`` (M, d, d). a, q (M, d, d); b (M, d, m); r (m, m) positive definite. Compiled classical RK4
    with steps of at most ``defaults.RICCATI_KNOT_TIME`` (tests/test_control_riccati.py checks it against scipy's
    adaptive RK45 at ``defaults.RICCATI_TOLERANCE``)."""
    times = np.asarray(times, dtype=float)
    if np.any(np.diff(times) <= 0):
        raise SimulationError("Riccati equation: the times of the planned motion must increase")
    r_inv = np.linalg.inv(r)
    s = b @ r_inv[None] @ np.transpose(b, (0, 2, 1))  # B R^-1 B^T, (M, d, d)
    a, s, q = (np.ascontiguousarray(x, dtype=float) for x in (a, s, q))

    def sweep(p_final: np.ndarray) -> np.ndarray:
        p = _rk4_sweep(times, a, s, q, np.ascontiguousarray(p_final, dtype=float), defaults.RICCATI_KNOT_TIME)
        if not np.all(np.isfinite(p)):
            raise SimulationError("Riccati equation could not be integrated (P became infinite); lower the "
                                  "orbital gains' bandwidth or shorten defaults.RICCATI_KNOT_TIME")
        return p

    p = sweep(p_end)
    if not periodic:
        return p
    for _ in range(defaults.RICCATI_MAX_PERIODS):
        p_new = sweep(p[0])
        change = np.max(np.abs(p_new[0] - p[0])) / max(np.max(np.abs(p_new[0])), TINY)
        p = p_new
        if change < defaults.RICCATI_TOLERANCE * 10:
            return p
    raise SimulationError(
        f"periodic Riccati equation did not converge in {defaults.RICCATI_MAX_PERIODS} periods; "
        "the transverse linearization may not be stabilizable with these weights (raise the bandwidth)"
    )


def solve_riccati_adaptive(times: np.ndarray, a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray,
                           p_end: np.ndarray) -> np.ndarray:
    """The open-horizon P at ``times`` (M, d, d) by scipy's adaptive RK45 at ``defaults.RICCATI_TOLERANCE``: the
    independent reference of :func:`solve_riccati` (slow: a Python right-hand side)."""
    d = a.shape[1]
    s = b @ np.linalg.inv(r)[None] @ np.transpose(b, (0, 2, 1))
    a_at, s_at, q_at = _interpolator(times, a), _interpolator(times, s), _interpolator(times, q)

    def rhs(t, p_flat):
        p = p_flat.reshape(d, d)
        pa = p @ a_at(t)
        return (-(pa + pa.T - p @ s_at(t) @ p + q_at(t))).ravel()

    scale = max(float(np.max(np.abs(q))), 1.0)
    sol = solve_ivp(rhs, (times[-1], times[0]), p_end.ravel(), t_eval=times[::-1], method="RK45",
                    rtol=defaults.RICCATI_TOLERANCE, atol=defaults.RICCATI_TOLERANCE * scale * ABSOLUTE_FRACTION)
    p = sol.y.T[::-1].reshape(len(times), d, d)
    return 0.5 * (p + np.transpose(p, (0, 2, 1)))


#: Batched matrix exponential: the 1-norm each matrix is scaled below before the squarings [-]; the degree-12 Taylor
#: polynomial then has a truncation error of at most 0.5^13 / 13! = 2e-14 relative.
EXPM_NORM = 0.5
#: 1/j!, j = 0..12: the Taylor coefficients of the exponential.
_TAYLOR = 1.0 / np.cumprod(np.concatenate([[1.0], np.arange(1.0, 13.0)]))


def expm_batched(m: np.ndarray) -> np.ndarray:
    """e^M for a stack of matrices m (N, k, k): scaling and squaring of the degree-12 Taylor polynomial, evaluated
    Paterson-Stockmeyer style in powers of X^4 (five batched products), with one scaling for the whole stack (by
    its largest 1-norm). Several times faster than scipy.linalg.expm on the stacks of small matrices the sampled
    design needs (one per sample); tests/test_control_discrete.py checks it against scipy."""
    norm = float(np.max(np.sum(np.abs(m), axis=-2))) if m.size else 0.0
    squarings = int(max(0, np.ceil(np.log2(max(norm, TINY) / EXPM_NORM))))
    x = m / 2.0**squarings
    x2 = x @ x
    x3 = x2 @ x
    x4 = x2 @ x2
    diag = np.arange(m.shape[-1])
    c = _TAYLOR

    def block(j: int, top: np.ndarray | None = None) -> np.ndarray:
        """c_j I + c_j+1 X + c_j+2 X^2 + c_j+3 X^3 (+ top), in place on one new array."""
        out = np.multiply(x3, c[j + 3]) if top is None else np.add(top, np.multiply(x3, c[j + 3]), out=top)
        out += c[j + 1] * x
        out += c[j + 2] * x2
        out[..., diag, diag] += c[j]
        return out

    inner = block(4, x4 @ block(8, np.multiply(x4, c[12])))
    out = block(0, x4 @ inner)
    for _ in range(squarings):
        out = out @ out
    return out


def discretize(a: np.ndarray, b: np.ndarray, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretization of dx/dt = A x + B u over one sample: (Phi (N, d, d), Gamma (N, d, m))
    with Phi = e^(A Ts), Gamma = int_0^Ts e^(A s) ds B (Van Loan: the exponential of [[A, B], [0, 0]] Ts)."""
    big, d, m = b.shape
    block = np.zeros((big, d + m, d + m))
    block[:, :d, :d], block[:, :d, d:] = a, b
    ex = expm(block * sample_time)
    return ex[:, :d, :d], ex[:, :d, d:]


def sampled_cost(a: np.ndarray, b: np.ndarray, q: np.ndarray, sample_time: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ZOH discretization and the exact sampled cost of the state weight over one sample (Van Loan 1978,
    "Computing integrals involving the matrix exponential"): with x(s) = Phi(s) x_k + Gamma(s) u held,

        int_0^Ts x^T Q x ds = [x_k; u]^T W [x_k; u],   W = int_0^Ts [Phi(s), Gamma(s)]^T Q [Phi(s), Gamma(s)] ds

    from the exponential of [[-C^T, Q_c], [0, C]] Ts, C = [[A, B], [0, 0]], Q_c = diag(Q, 0). a, q (N, d, d),
    b (N, d, m). Returns (Phi (N, d, d), Gamma (N, d, m), W (N, d + m, d + m)); the command's own weight
    (R Ts for a constant R) is not in W."""
    big, d, m = b.shape
    k = d + m
    c = np.zeros((big, k, k))
    c[:, :d, :d], c[:, :d, d:] = a, b
    scale = np.maximum(np.max(np.abs(q), axis=(1, 2)), TINY)[:, None, None]  # W is linear in Q: keep the norm small
    block = np.zeros((big, 2 * k, 2 * k))
    block[:, :k, :k] = -np.transpose(c, (0, 2, 1))
    block[:, :d, k:k + d] = q / scale
    block[:, k:, k:] = c
    ex = expm_batched(block * sample_time)
    f22 = ex[:, k:, k:]
    w = scale * (np.transpose(f22, (0, 2, 1)) @ ex[:, :k, k:])
    return f22[:, :d, :d], f22[:, :d, d:], 0.5 * (w + np.transpose(w, (0, 2, 1)))


def with_delay(phi: np.ndarray, gamma: np.ndarray, delay: int) -> tuple[np.ndarray, np.ndarray]:
    """The sampled system with the command applied ``delay`` samples late, its state augmented with the
    commands still in flight: x_aug = (x, u_{k-delay}, ..., u_{k-1}), x+ = Phi x + Gamma u_{k-delay}; the new
    command u_k enters the last slot. Shapes (N, d + delay m, d + delay m) and (N, d + delay m, m)."""
    if delay == 0:
        return phi, gamma
    big, d, m = gamma.shape
    size = d + delay * m
    pa = np.zeros((big, size, size))
    pa[:, :d, :d], pa[:, :d, d:d + m] = phi, gamma
    for j in range(delay - 1):  # each command moves one slot towards the plant
        pa[:, d + j * m + np.arange(m), d + (j + 1) * m + np.arange(m)] = 1.0
    ga = np.zeros((big, size, m))
    ga[:, size - m + np.arange(m), np.arange(m)] = 1.0
    return pa, ga


@numba.njit(cache=True)
def _discrete_sweep(phi, gamma, q, r, cross, p_final, p, k_gain):
    """One backward pass of :func:`solve_discrete_riccati` from P_N = p_final, written into p (N+1, d, d) and
    k_gain (N, m, d) (compiled: a Python loop of small numpy calls cost ~0.1 ms per sample)."""
    big = phi.shape[0]
    p[big] = p_final
    for k in range(big - 1, -1, -1):
        f, g, pn = phi[k], gamma[k], p[k + 1]
        pg = pn @ g
        fpg_s = f.T @ pg + cross[k]
        k_gain[k] = np.linalg.solve(r[k] + g.T @ pg, np.ascontiguousarray(fpg_s.T))
        pk = q[k] + f.T @ pn @ f - fpg_s @ k_gain[k]
        p[k] = 0.5 * (pk + pk.T)


def solve_discrete_riccati(phi: np.ndarray, gamma: np.ndarray, q: np.ndarray, r: np.ndarray, p_end: np.ndarray,
                           periodic: bool = False, cross: np.ndarray | None = None
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Time-varying discrete Riccati recursion of the cost sum x^T Q_k x + 2 x^T S_k u + u^T R_k u, backward from
    P_N = ``p_end``:

        K_k = (R_k + G^T P_{k+1} G)^-1 (G^T P_{k+1} F + S_k^T),   P_k = Q_k + F^T P_{k+1} F - (F^T P_{k+1} G + S_k) K_k

    (F, G) = (phi[k], gamma[k]) (N, d, d), (N, d, m); q (N, d, d) per-sample weights; r (m, m) or (N, m, m);
    cross S (N, d, m) or None (zero). Periodic (the sequence is one period): repeated until P_0 = P_N to
    ``defaults.RICCATI_TOLERANCE``. Returns (P (N+1, d, d), K (N, m, d)); u_k = -K_k x_k."""
    big = len(phi)
    p = np.empty((big + 1, *p_end.shape))
    k_gain = np.empty((big, gamma.shape[2], phi.shape[1]))
    phi, gamma, q = (np.ascontiguousarray(x, dtype=float) for x in (phi, gamma, q))
    r = np.ascontiguousarray(np.broadcast_to(r, (big, *r.shape[-2:])), dtype=float)
    cross = np.zeros(gamma.shape) if cross is None else np.ascontiguousarray(cross, dtype=float)

    def sweep(p_final):
        _discrete_sweep(phi, gamma, q, r, cross, np.ascontiguousarray(p_final, dtype=float), p, k_gain)

    sweep(p_end)
    if not periodic:
        return p, k_gain
    for _ in range(defaults.RICCATI_MAX_PERIODS):
        before = p[0].copy()
        sweep(before)
        if np.max(np.abs(p[0] - before)) <= defaults.RICCATI_TOLERANCE * max(np.max(np.abs(p[0])), TINY):
            return p, k_gain
    raise SimulationError(
        f"periodic discrete Riccati equation did not converge in {defaults.RICCATI_MAX_PERIODS} periods; the sampled "
        "transverse linearization may not be stabilizable at this sample time (shorten it or lower the bandwidth)"
    )
