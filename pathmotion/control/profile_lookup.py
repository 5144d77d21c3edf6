"""Scalar look-ups of a planned profile x*(theta) = theta_dot^2 for a controller running per sample.

:class:`~pathmotion.planning.profile.Profile` is vectorized (numpy per call, ~10 us); a controller asks
for one theta at a time, so this wraps the compiled :func:`~.kernels.profile_state` (the same
piecewise-linear x*). It adds the planned time t*(theta) at any theta (exact for piecewise-linear x):

    t*(theta) = t_i + 2 (theta - theta_i) / (sqrt(x_i) + sqrt(x*(theta)))
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..planning.profile import Profile
from .kernels import ProfileArrays, profile_state, profile_states, profile_time, profile_times


@dataclass(frozen=True, eq=False)
class ProfileLookup:
    """x*, u* = theta_ddot*, t* of a profile at one theta; ``closed`` wraps theta by the period."""

    profile: Profile
    closed: bool = False

    @cached_property
    def arrays(self) -> ProfileArrays:
        """The profile as the compiled kernels take it."""
        p = self.profile
        return ProfileArrays(*(np.ascontiguousarray(a, dtype=float) for a in (p.times, p.grid, p.x, p.u)))

    @property
    def domain(self) -> tuple[float, float]:
        return float(self.profile.grid[0]), float(self.profile.grid[-1])

    @property
    def duration(self) -> float:
        return self.profile.duration

    def state(self, theta: float) -> tuple[float, float]:
        """(x*, u*) at theta: planned theta_dot^2 and theta_ddot (right-continuous)."""
        x, u = profile_state(self.arrays, self.closed, float(theta))
        return float(x), float(u)

    def states(self, theta: np.ndarray) -> np.ndarray:
        """:meth:`state` of each theta (N,): (N, 2) rows (x*, u*)."""
        return profile_states(self.arrays, self.closed, np.ascontiguousarray(theta, dtype=float))

    def time(self, theta: float) -> float:
        """Planned time t*(theta) [s] from the start of the profile (within one period if closed)."""
        return float(profile_time(self.arrays, self.closed, float(theta)))

    def times(self, theta: np.ndarray) -> np.ndarray:
        """:meth:`time` of each theta (N,) inside the domain."""
        return profile_times(self.arrays, np.ascontiguousarray(theta, dtype=float))
