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

from .. import defaults
from ..errors import SimulationError

#: Floor of the norm a change of P is measured against (P = 0) [-].
TINY = 1e-300


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


#: Sampled cost: each hold is cut into 2^s equal parts, s the least with theta = (|C h|_1 + |C h|_inf) / 2^s at most
#: this [-] (per sample); the Taylor series on one part are then summed to SERIES_TOLERANCE and doubled s times.
SERIES_NORM = 0.5
#: Bound on the truncated tail of the series relative to the largest term kept (|Q| h or 1) [-]: the unit round-off.
SERIES_TOLERANCE = 2.0**-53
#: Most terms the series may need (theta <= SERIES_NORM needs 13) [-].
MAX_TERMS = 40


def series_terms(theta: float) -> int:
    """Least p with the tail of sum_n theta^n / (n+1)! beyond n = p at most SERIES_TOLERANCE: the certified
    truncation of the series of :func:`sampled_cost` for an operator of norm ``theta`` [-]. The tail is bounded by
    its first term times the geometric factor 1 / (1 - theta / (p+3))."""
    term = 1.0  # theta^n / (n+1)! at n = p + 1
    for p in range(MAX_TERMS):
        term *= theta / (p + 2)
        if theta < p + 3 and term / (1.0 - theta / (p + 3)) <= SERIES_TOLERANCE:
            return p
    raise SimulationError(f"sampled cost: the series for a scaled norm of {theta:g} needs more than {MAX_TERMS} "
                          "terms (the scaling should keep it below SERIES_NORM)")


def sampled_cost(a: np.ndarray, b: np.ndarray, q: np.ndarray, sample_time) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ZOH discretization and the exact sampled cost of the state weight over one sample: with
    x(s) = Phi(s) x_k + Gamma(s) u held,

        int_0^Ts x^T Q x ds = [x_k; u]^T W [x_k; u],   W = int_0^Ts e^(C^T s) Q_c e^(C s) ds

    C = [[A, B], [0, 0]], Q_c = diag(Q, 0), e^(C Ts) = [[Phi, Gamma], [0, I]] (Van Loan 1978, "Computing integrals
    involving the matrix exponential", without his doubled block matrix). Scaling and squaring on the pair
    (G, W): on h0 = Ts / 2^s, with Y = C h0 and L(Z) = Y^T Z + Z Y,

        W(h0) = h0 sum_n L^n(Q_c) / (n+1)!,   G(h0) = [[I + X Psi, Psi B h0], [0, I]],  Psi = sum_j X^j / (j+1)!

    (X = A h0; one product per term of W, L^n(Q_c) symmetric), both truncated where :func:`series_terms` bounds
    the tail by the round-off (|L| <= theta = |Y|_1 + |Y|_inf), then s times W(2h) = W(h) + G^T W(h) G, G(2h) = G^2.
    s is chosen per sample. a, q (N, d, d), b (N, d, m); sample_time [s] scalar or (N,). Returns (Phi (N, d, d),
    Gamma (N, d, m), W (N, d + m, d + m)); the command's own weight (R Ts for a constant R) is not in W.
    tests/control_reference.py's ``sampled_cost_van_loan`` is the reference."""
    big, d, m = b.shape
    k = d + m
    h = np.broadcast_to(np.asarray(sample_time, dtype=float), (big,))
    c = np.zeros((big, k, k))
    c[:, :d, :d], c[:, :d, d:] = a, b
    size = np.abs(c)
    norm = h * (np.max(np.sum(size, axis=-2), axis=-1) + np.max(np.sum(size, axis=-1), axis=-1))
    halvings = np.maximum(np.ceil(np.log2(np.maximum(norm, TINY) / SERIES_NORM)), 0).astype(int)
    h0 = h / 2.0**halvings
    terms = series_terms(float(np.max(norm / 2.0**halvings, initial=0.0)))
    y = np.multiply(c, h0[:, None, None], out=c)
    w = _cost_series(y, 0.5 * (q + np.transpose(q, (0, 2, 1))), terms)  # x^T Q x sees only Q's symmetric part
    w *= h0[:, None, None]
    g = _transition_series(y, d, terms)
    for j in range(int(np.max(halvings, initial=0))):  # doublings of the samples cut more than j times
        sel = np.nonzero(halvings > j)[0]
        gs, ws = g[sel], w[sel]
        w[sel] = ws + np.transpose(gs, (0, 2, 1)) @ (ws @ gs)
        g[sel] = gs @ gs
    return g[:, :d, :d], g[:, :d, d:], 0.5 * (w + np.transpose(w, (0, 2, 1)))


def _cost_series(y: np.ndarray, q: np.ndarray, terms: int) -> np.ndarray:
    """sum_n L^n(Q_c) / (n+1)!, n = 0..terms, L(Z) = Y^T Z + Z Y, for y (N, k, k) and a symmetric q (N, d, d) in the
    top-left corner of Q_c (N, k, k). In place on preallocated stacks: a fresh 1.6 MB array per operation cost
    four times the arithmetic (page faults)."""
    big, d, k = len(y), q.shape[1], y.shape[1]
    z, zy = np.zeros((big, k, k)), np.empty((big, k, k))
    z[:, :d, :d] = q
    w = z.copy()
    for n in range(1, terms + 1):  # z = L^n(Q_c) / (n+1)! = L(previous z) / (n+1); z symmetric: Y^T Z = (Z Y)^T
        np.matmul(z, y, out=zy)
        np.add(zy, np.transpose(zy, (0, 2, 1)), out=z)
        z *= 1.0 / (n + 1)
        w += z
    return w


def _transition_series(y: np.ndarray, d: int, terms: int) -> np.ndarray:
    """G = e^Y (N, k, k) for Y = [[X, V], [0, 0]] (N, k, k), X (d, d): [[I + X Psi, Psi V], [0, I]] with
    Psi = sum_j X^j / (j+1)!, j = 0..terms, by Horner (Psi = I + X/2 (I + X/3 (I + ...)))."""
    big, k = len(y), y.shape[1]
    x, eye = np.ascontiguousarray(y[:, :d, :d]), np.eye(d)
    psi, xpsi = np.empty_like(x), np.empty_like(x)
    psi[:] = eye
    if terms:
        np.multiply(x, 1.0 / (terms + 1), out=psi)
        psi += eye
    for j in range(terms - 1, 0, -1):
        np.matmul(x, psi, out=xpsi)
        np.multiply(xpsi, 1.0 / (j + 1), out=psi)
        psi += eye
    g = np.zeros((big, k, k))
    np.matmul(x, psi, out=xpsi)
    g[:, :d, :d] = xpsi + eye
    g[:, :d, d:] = psi @ y[:, :d, d:]
    g[:, d + np.arange(k - d), d + np.arange(k - d)] = 1.0
    return g


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
