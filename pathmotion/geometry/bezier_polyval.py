"""A quintic's power basis and its points and derivatives by Horner's rule, compiled (numba): BezierSegment's
construction and evaluation, which
every plan of a blended path repeats (its curvature peaks, its points for the lift), some 100 000 times per
corner in the blend search. In numpy each evaluation was seven calls on a few hundred points, mostly per-call
overhead. The operations are numpy's, element by element, in the same order (out = fac[-1] coef[5], then
out = out u + fac[k - order] coef[k] for k = 4 .. order; the power basis's sums in the order of the control
points): the same floats. The certified deviation bound (:mod:`.quintic_deviation`) builds on the same power basis.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def polyval(coef: np.ndarray, u: np.ndarray, fac: np.ndarray, order: int) -> np.ndarray:
    """d^order X / du^order (N, 3) at u (N,), X(u) = sum_k coef[k] u^k (coef (6, 3)); ``fac`` (6 - order,):
    the factors k! / (k - order)! of the coefficients k = order .. 5."""
    out = np.empty((u.shape[0], 3))
    top = fac.shape[0] - 1
    for i in range(u.shape[0]):
        ui = u[i]
        for j in range(3):
            x = fac[top] * coef[5, j]
            for k in range(4, order - 1, -1):
                x = x * ui
                x = x + fac[k - order] * coef[k, j]
            out[i, j] = x
    return out


@numba.njit(cache=True)
def power_basis(b: np.ndarray, signed: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Monomial coefficients coef (6, 3) of the quintic Bezier curve with control points b (6, 3) [m]:
    X(u) = sum_k coef[k] u^k, coef[k] = scale[k] sum_i signed[k, i] b_i (``signed`` (6, 6) = (-1)^(k-i) C(k, i),
    ``scale`` (6,) = C(5, k)), the sum added in the order of i as numpy's ``acc = acc + signed[:, i, None] * b[i]``."""
    acc = np.zeros((6, 3))
    for i in range(6):
        for k in range(6):
            for j in range(3):
                acc[k, j] = acc[k, j] + signed[k, i] * b[i, j]
    coef = np.empty((6, 3))
    for k in range(6):
        for j in range(3):
            coef[k, j] = scale[k] * acc[k, j]
    return coef


@numba.njit(cache=True)
def curvature_terms(coef: np.ndarray, u: np.ndarray, fac1: np.ndarray, fac2: np.ndarray) -> tuple:
    """(g2 X''.X'' - (X'.X'')^2, g2) (N,) each at u (N,), g2 = X'.X', the numerator and the root of the denominator
    of the squared curvature |X' x X''|^2 / |X'|^6 (Lagrange's identity): X' and X'' by :func:`polyval`'s Horner
    loop (``fac1``, ``fac2``: its factors of orders 1 and 2), each dot product summed as numpy's
    einsum("ij,ij->i") sums rows of 3, (x0 y0 + x2 y2) + x1 y1: the same floats as the numpy form. The cube is the
    caller's: numpy's g2 ** 3 is libm's pow, which a compiled cube of a constant exponent (folded into products)
    differs from in the last bit (:func:`curvature_peak_parameters` passes the exponent at run time)."""
    n = u.shape[0]
    num = np.empty(n)
    g2s = np.empty(n)
    d1 = np.empty(3)
    d2 = np.empty(3)
    for i in range(n):
        ui = u[i]
        for j in range(3):
            x = fac1[4] * coef[5, j]
            for k in range(4, 0, -1):
                x = x * ui
                x = x + fac1[k - 1] * coef[k, j]
            d1[j] = x
            y = fac2[3] * coef[5, j]
            for k in range(4, 1, -1):
                y = y * ui
                y = y + fac2[k - 2] * coef[k, j]
            d2[j] = y
        g2 = (d1[0] * d1[0] + d1[2] * d1[2]) + d1[1] * d1[1]
        h2 = (d2[0] * d2[0] + d2[2] * d2[2]) + d2[1] * d2[1]
        dot = (d1[0] * d2[0] + d1[2] * d2[2]) + d1[1] * d2[1]
        num[i] = g2 * h2 - dot * dot
        g2s[i] = g2
    return num, g2s


@numba.njit(cache=True)
def speed_range(coef: np.ndarray, u: np.ndarray, fac1: np.ndarray) -> tuple:
    """(min |X'|, its first index, max |X'|) over u (N,), |X'| [m per unit u] by :func:`polyval`'s Horner loop
    (``fac1``: its factors of order 1) and summed as numpy's np.linalg.norm(axis=1), (x0^2 + x1^2) + x2^2: the same
    floats as np.min, np.argmin and np.max of that norm, without its (N, 3) temporaries."""
    lo, at, hi = np.inf, 0, -np.inf
    for i in range(u.shape[0]):
        ui = u[i]
        s = 0.0
        for j in range(3):
            x = fac1[4] * coef[5, j]
            for k in range(4, 0, -1):
                x = x * ui
                x = x + fac1[k - 1] * coef[k, j]
            s = x * x if j == 0 else s + x * x
        speed = np.sqrt(s)
        if speed < lo:
            lo, at = speed, i
        if speed > hi:
            hi = speed
    return lo, at, hi


@numba.njit(cache=True)
def curvature_peak_parameters(coef: np.ndarray, u: np.ndarray, fac1: np.ndarray, fac2: np.ndarray, floor: float,
                              offsets: np.ndarray, rounds: int, three: float) -> np.ndarray:
    """BezierSegment.curvature_peaks' parameters u (k,) of the squared curvature's interior local maxima above
    ``floor`` on the samples ``u`` (N,), each refined ``rounds`` times: the largest of the samples ``offsets`` (m,)
    across its bracket (half-width u[1] at first, then (m - 1) / 2 times narrower each round; the first of equal
    largest, numpy's argmax). The squared curvature is :func:`curvature_terms`' num / g2^3 with the cube libm's
    pow(g2, e) for the run-time exponent ``three`` (3.0), as numpy's ``g2 ** 3`` computes it (a constant exponent
    would be folded into products, which differ in the last bit): the same floats as the numpy form, in one call
    instead of one per round."""
    num, g2 = curvature_terms(coef, u, fac1, fac2)
    n = u.shape[0]
    k = np.empty(n)
    for i in range(n):
        k[i] = num[i] / g2[i] ** three
    count = 0
    for i in range(1, n - 1):
        if k[i] >= k[i - 1] and k[i] > k[i + 1] and k[i] > floor:
            count += 1
    at = np.empty(count)
    half = np.empty(count)
    c = 0
    for i in range(1, n - 1):
        if k[i] >= k[i - 1] and k[i] > k[i + 1] and k[i] > floor:
            at[c] = u[i]
            half[c] = u[1]
            c += 1
    if count == 0:
        return at
    m = offsets.shape[0]
    trial = np.empty(count * m)
    for _ in range(rounds):
        for a in range(count):
            for b in range(m):
                v = at[a] + half[a] * offsets[b]
                if v < 0.0:
                    v = 0.0
                elif v > 1.0:
                    v = 1.0
                trial[a * m + b] = v
        num, g2 = curvature_terms(coef, trial, fac1, fac2)
        for a in range(count):
            best = 0
            top = num[a * m] / g2[a * m] ** three
            if not np.isnan(top):
                for b in range(1, m):
                    v = num[a * m + b] / g2[a * m + b] ** three
                    if np.isnan(v):
                        best = b
                        break
                    if v > top:
                        top, best = v, b
            at[a] = trial[a * m + best]
            half[a] = half[a] * 2.0 / (m - 1)
    return at
