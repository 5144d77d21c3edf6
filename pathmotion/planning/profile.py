"""Velocity profile along a path: x(theta) = theta_dot^2, piecewise linear in theta.

Between grid points theta_i and theta_{i+1} the path acceleration u_i = theta_ddot is constant,
so x(theta) = x_i + 2 u_i (theta - theta_i) exactly and time is analytic:

    t_{i+1} - t_i = 2 (theta_{i+1} - theta_i) / (sqrt(x_i) + sqrt(x_{i+1}))
    theta(t) = theta_i + sqrt(x_i) tau + u_i tau^2 / 2,   tau = t - t_i

This is the representation every time-optimal planner here returns and every consumer
(trajectory sampling, controllers) reads. :func:`piece_x` is the one lookup of x on a piece; the
controllers' compiled kernels (control/kernels.py) compile this same function.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import PathmotionError


def piece_x(grid, x, u, i, theta):
    """x(theta) = max(x_i + 2 u_i (theta - theta_i), 0) on piece i (scalars, or arrays of i and theta).

    Plain numpy, so that control/kernels.py can compile it with numba as its scalar lookup."""
    return np.maximum(x[i] + 2.0 * u[i] * (theta - grid[i]), 0.0)


@dataclass(frozen=True, eq=False)
class Profile:
    """grid (K,) increasing theta values; x (K,) = theta_dot^2 >= 0 at the grid points."""

    grid: np.ndarray
    x: np.ndarray

    def __post_init__(self):
        grid = np.asarray(self.grid, dtype=float)
        x = np.asarray(self.x, dtype=float)
        if grid.ndim != 1 or grid.shape != x.shape or len(grid) < 2:
            raise PathmotionError(f"profile: grid {grid.shape} and x {x.shape} must be equal 1-D arrays of >= 2")
        if not np.all(np.isfinite(x)) or not np.all(np.isfinite(grid)):
            raise PathmotionError("profile contains NaN or inf")
        if np.any(np.diff(grid) <= 0):
            raise PathmotionError("profile grid must be strictly increasing")
        x = np.maximum(x, 0.0)
        both_zero = (x[:-1] <= 0) & (x[1:] <= 0)
        if np.any(both_zero):
            i = int(np.argmax(both_zero))
            raise PathmotionError(
                f"profile stops on the whole interval theta in [{grid[i]:.6g}, {grid[i + 1]:.6g}]: "
                "the path cannot be traversed there (limits too tight?)"
            )
        object.__setattr__(self, "grid", grid)
        object.__setattr__(self, "x", x)

    @cached_property
    def u(self) -> np.ndarray:
        """Constant path acceleration theta_ddot on each interval, (K-1,)."""
        return np.diff(self.x) / (2.0 * np.diff(self.grid))

    @cached_property
    def times(self) -> np.ndarray:
        """Time at each grid point [s], (K,), starting at 0."""
        sq = np.sqrt(self.x)
        dt = 2.0 * np.diff(self.grid) / (sq[:-1] + sq[1:])
        return np.concatenate([[0.0], np.cumsum(dt)])

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def _interval(self, theta) -> np.ndarray:
        return np.clip(np.searchsorted(self.grid, theta, side="right") - 1, 0, len(self.grid) - 2)

    def x_at(self, theta) -> np.ndarray:
        """x = theta_dot^2 at theta (linear interpolation is exact here)."""
        th = np.asarray(theta, dtype=float)
        i = self._interval(th)
        return piece_x(self.grid, self.x, self.u, i, th)

    def theta_dot_at(self, theta) -> np.ndarray:
        return np.sqrt(self.x_at(theta))

    def theta_ddot_at(self, theta) -> np.ndarray:
        """u on the interval containing theta (right-continuous)."""
        return self.u[self._interval(np.asarray(theta, dtype=float))]

    def state_at_time(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta, theta_dot, theta_ddot) at times t [s] (clipped to [0, duration])."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        i = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.grid) - 2)
        tau = t - self.times[i]
        v0 = np.sqrt(self.x[i])
        u = self.u[i]
        theta = np.minimum(self.grid[i] + v0 * tau + 0.5 * u * tau**2, self.grid[i + 1])
        theta_dot = np.sqrt(piece_x(self.grid, self.x, self.u, i, theta))
        return theta, theta_dot, u

    def scaled(self, factor: float) -> "Profile":
        """The same shape with theta_dot multiplied by ``factor`` (x by factor^2)."""
        return Profile(self.grid, self.x * factor**2)
