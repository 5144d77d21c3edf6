"""A joint path tabulated for a real-time controller: quintic Hermite pieces in theta.

A controller evaluates q = Phi(theta), Phi', Phi'' a few times per sample. Evaluating the path itself
can cost 0.1 ms (a scipy spline) to milliseconds (a task path lifted by inverse kinematics), so the
controller reads a table instead, as a real robot controller would: Phi, Phi', Phi'' at ``points``
values of theta (evenly spaced, with every break and kink added), joined by the quintic Hermite
polynomial that matches all three at both ends of each interval. Inside one smooth piece of the
path the error is O(h^6 Phi^(6)); across a jump of Phi''' it is O(h^3) (h = grid step). The table
keeps both one-sided values at breaks, so no interval straddles a jump of Phi' or Phi''.

Shapes: theta () or (N,); Phi, Phi', Phi'' (n,) or (N, n).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import defaults
from ..errors import SimulationError
from ..joint_path import JointPath

# Quintic Hermite: p(s) = sum_k c_k s^k on s in [0, 1] from (p0, p0', p0'', p1, p1', p1'') with the
# derivatives already scaled by the interval length h (p' -> h p', p'' -> h^2 p'').
_HERMITE5 = np.array(
    [  # rows: c0..c5; columns: p0, d0, a0, p1, d1, a1
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
        [-10.0, -6.0, -1.5, 10.0, -4.0, 0.5],
        [15.0, 8.0, 1.5, -15.0, 7.0, -1.0],
        [-6.0, -3.0, -0.5, 6.0, -3.0, 0.5],
    ]
)


@dataclass(frozen=True, eq=False)
class PathTable:
    """Tabulated q = Phi(theta).

    grid (M,) theta values; coeffs (M-1, 6, n) quintic coefficients in s = (theta - grid[i]) / h_i;
    domain, closed as the path's. Build with :meth:`from_path`.
    """

    grid: np.ndarray
    coeffs: np.ndarray
    domain: tuple[float, float]
    closed: bool
    n: int

    @classmethod
    def from_path(cls, path: JointPath, points: int = defaults.PATH_TABLE_POINTS) -> "PathTable":
        """Tabulate ``path`` on ``points`` evenly spaced theta values plus its breaks and kinks."""
        if points < 2:
            raise SimulationError(f"path table needs at least 2 points, got {points}")
        lo, hi = path.domain
        extra = [b for b in (*path.breaks, *path.kinks) if lo < b < hi]
        grid = np.unique(np.concatenate([np.linspace(lo, hi, points), extra]))
        # drop grid points closer than 1e-9 of the length to a break (keep the break itself)
        if extra:
            near = np.min(np.abs(grid[:, None] - np.asarray(extra)[None, :]), axis=1)
            is_break = np.isin(grid, extra)
            grid = grid[(near > 1e-9 * (hi - lo)) | is_break]
        left = path.evaluate(grid[:-1], side="right")  # start of each interval
        right = path.evaluate(grid[1:], side="left")  # end of each interval
        h = np.diff(grid)[:, None]
        data = np.stack(
            [left[0], left[1] * h, left[2] * h**2, right[0], right[1] * h, right[2] * h**2], axis=1
        )  # (M-1, 6, n)
        coeffs = np.einsum("kj,mjn->mkn", _HERMITE5, data)
        if not np.all(np.isfinite(coeffs)):
            raise SimulationError("the joint path returned NaN or inf while tabulating it for the controller")
        return cls(grid=grid, coeffs=coeffs, domain=(float(lo), float(hi)), closed=bool(path.closed), n=path.n)

    @property
    def length(self) -> float:
        return self.domain[1] - self.domain[0]

    @cached_property
    def speed2_scale(self) -> float:
        """max over the grid of |Phi'|^2 [rad^2 per unit theta^2], the scale of "Phi' = 0" tests."""
        return float(np.max(np.sum(self.coeffs[:, 1, :] ** 2, axis=1) / np.diff(self.grid) ** 2))

    def theta_rate(self, dphi: np.ndarray, qd: np.ndarray) -> float:
        """theta_dot = Phi'^T qd / |Phi'|^2 (0 where Phi' vanishes, e.g. at clamped ends)."""
        d2 = dphi @ dphi
        return float(dphi @ qd) / d2 if d2 > 1e-12 * self.speed2_scale else 0.0

    def next_guess(self, theta: float, theta_dot: float, dt: float) -> float:
        """theta + theta_dot dt, the move limited to PROJECTION_MAX_STEP of the length, inside an open domain."""
        limit = defaults.PROJECTION_MAX_STEP * self.length
        guess = theta + min(max(theta_dot * dt, -limit), limit)
        return guess if self.closed else min(max(guess, self.domain[0]), self.domain[1])

    def wrap(self, theta: float) -> float:
        """theta mapped into the domain: modulo the period for closed paths, clipped for open ones."""
        lo, hi = self.domain
        if self.closed:
            return lo + (theta - lo) % (hi - lo)
        return min(max(theta, lo), hi)

    def evaluate_scalar(self, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Phi, Phi', Phi'') at one theta (wrapped/clipped into the domain), each (n,)."""
        theta = self.wrap(theta)
        grid = self.grid
        i = min(max(bisect.bisect_right(grid, theta) - 1, 0), len(grid) - 2)
        h = grid[i + 1] - grid[i]
        s = (theta - grid[i]) / h
        s2 = s * s
        s3 = s2 * s
        s4 = s3 * s
        basis = np.array(
            [
                [1.0, s, s2, s3, s4, s4 * s],
                [0.0, 1.0 / h, 2.0 * s / h, 3.0 * s2 / h, 4.0 * s3 / h, 5.0 * s4 / h],
                [0.0, 0.0, 2.0 / h**2, 6.0 * s / h**2, 12.0 * s2 / h**2, 20.0 * s3 / h**2],
            ]
        )
        out = basis @ self.coeffs[i]
        return out[0], out[1], out[2]

    def evaluate(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Phi, Phi', Phi'') at theta (N,) (wrapped/clipped into the domain), each (N, n)."""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        lo, hi = self.domain
        th = lo + (th - lo) % (hi - lo) if self.closed else np.clip(th, lo, hi)
        i = np.clip(np.searchsorted(self.grid, th, side="right") - 1, 0, len(self.grid) - 2)
        h = (self.grid[i + 1] - self.grid[i])[:, None]
        s = ((th - self.grid[i]) / h[:, 0])[:, None]
        k = np.arange(6)
        powers = s ** k  # (N, 6)
        d1 = np.concatenate([np.zeros_like(s), k[1:] * s ** (k[1:] - 1)], axis=1) / h
        d2 = np.concatenate([np.zeros((len(s), 2)), (k[2:] * (k[2:] - 1)) * s ** (k[2:] - 2)], axis=1) / h**2
        c = self.coeffs[i]  # (N, 6, n)
        return (np.einsum("nk,nkj->nj", powers, c), np.einsum("nk,nkj->nj", d1, c),
                np.einsum("nk,nkj->nj", d2, c))
