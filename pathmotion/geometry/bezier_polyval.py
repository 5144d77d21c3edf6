"""A quintic's points and derivatives by Horner's rule, compiled (numba): BezierSegment's evaluation, which
every plan of a blended path repeats (its curvature peaks, its points for the lift), some 100 000 times per
corner in the blend search. In numpy each evaluation was seven calls on a few hundred points, mostly per-call
overhead. The operations are numpy's, element by element, in the same order (out = fac[-1] coef[5], then
out = out u + fac[k - order] coef[k] for k = 4 .. order): the same floats.
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
