"""Fast scalar look-ups of a planned profile x*(theta) = theta_dot^2 for a controller running per sample.

:class:`~pathmotion.planning.profile.Profile` is vectorized (numpy per call, ~10 us); a controller
asks for one theta at a time, so this keeps the same piecewise-linear x* as Python lists with
``bisect``. It adds the planned time t*(theta) at any theta (exact for piecewise-linear x):

    t*(theta) = t_i + 2 (theta - theta_i) / (sqrt(x_i) + sqrt(x*(theta)))
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np

from ..planning.profile import Profile


@dataclass(frozen=True, eq=False)
class ProfileLookup:
    """x*, u* = theta_ddot*, t* of a profile at one theta; ``closed`` wraps theta by the period."""

    profile: Profile
    closed: bool = False

    def __post_init__(self):
        p = self.profile
        object.__setattr__(self, "_grid", [float(g) for g in p.grid])
        object.__setattr__(self, "_x", [float(v) for v in p.x])
        object.__setattr__(self, "_u", [float(v) for v in p.u])
        object.__setattr__(self, "_t", [float(v) for v in p.times])

    @property
    def domain(self) -> tuple[float, float]:
        return self._grid[0], self._grid[-1]

    @property
    def duration(self) -> float:
        return self._t[-1]

    def _locate(self, theta: float) -> tuple[int, float]:
        lo, hi = self._grid[0], self._grid[-1]
        if self.closed:
            theta = lo + (theta - lo) % (hi - lo)
        else:
            theta = min(max(theta, lo), hi)
        i = min(max(bisect.bisect_right(self._grid, theta) - 1, 0), len(self._grid) - 2)
        return i, theta

    def state(self, theta: float) -> tuple[float, float]:
        """(x*, u*) at theta: planned theta_dot^2 and theta_ddot (right-continuous)."""
        i, theta = self._locate(theta)
        u = self._u[i]
        return max(self._x[i] + 2.0 * u * (theta - self._grid[i]), 0.0), u

    def time(self, theta: float) -> float:
        """Planned time t*(theta) [s] from the start of the profile (within one period if closed)."""
        i, theta = self._locate(theta)
        xi = self._x[i]
        x = max(xi + 2.0 * self._u[i] * (theta - self._grid[i]), 0.0)
        den = np.sqrt(xi) + np.sqrt(x)
        return self._t[i] + (2.0 * (theta - self._grid[i]) / den if den > 0 else 0.0)

    def times(self, theta: np.ndarray) -> np.ndarray:
        """Vectorized :meth:`time` for theta (N,) inside the domain."""
        p = self.profile
        th = np.asarray(theta, dtype=float)
        i = np.clip(np.searchsorted(p.grid, th, side="right") - 1, 0, len(p.grid) - 2)
        x = np.maximum(p.x[i] + 2.0 * p.u[i] * (th - p.grid[i]), 0.0)
        den = np.sqrt(p.x[i]) + np.sqrt(x)
        return p.times[i] + np.divide(2.0 * (th - p.grid[i]), den, out=np.zeros_like(th), where=den > 0)
