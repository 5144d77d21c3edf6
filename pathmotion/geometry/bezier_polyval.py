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
