"""The torque saturation of the closed loop and the plants, compiled: one kernel both use."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def saturate(tau, limit, out):
    """out = tau clipped to +-limit (n,); returns (all finite, any clipped)."""
    finite, clipped = True, False
    for i in range(tau.shape[0]):
        v = tau[i]
        if not np.isfinite(v):
            finite = False
        if v > limit[i]:
            v, clipped = limit[i], True
        elif v < -limit[i]:
            v, clipped = -limit[i], True
        out[i] = v
    return finite, clipped
