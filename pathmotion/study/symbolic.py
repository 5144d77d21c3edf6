"""CasADi for the symbolic builders of the study layer (the free-shape optimum, the symbolic dynamics):
the module, imported on first use (an optional dependency), and the rotation expression both need."""

from __future__ import annotations

import numpy as np

from ..errors import PathmotionError


def casadi_module():
    """The ``casadi`` module, or a PathmotionError saying how to install it."""
    try:
        import casadi
    except ImportError:  # pragma: no cover - depends on the environment
        raise PathmotionError('the free-shape optimum needs CasADi: pip install "pathmotion[optimal]"') from None
    return casadi


def rodrigues(ca, axis: np.ndarray, angle):
    """Rotation about the unit ``axis`` (3,) by ``angle`` [rad] (a CasADi expression), (3, 3)."""
    k = ca.DM(axis)
    K = ca.skew(k)
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * (K @ K)
