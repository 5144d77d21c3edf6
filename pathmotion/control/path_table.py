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

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .. import defaults
from ..errors import SimulationError
from ..lift.joint_path import JointPath
from .kernels import PathArrays, Projection, evaluate_at, project

#: Grid points closer than this fraction of the domain's length to a break are dropped (the break stays).
BREAK_MERGE = 1e-9

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


def _interval_ends(path: JointPath, grid: np.ndarray, breaks: list) -> tuple[tuple, tuple]:
    """(Phi, Phi', Phi'') at the start (right-sided) and end (left-sided) of each interval of ``grid`` (M,), each
    (M-1, n). The path is evaluated once per grid point: both sides only at ``breaks`` and at the domain's end
    (elsewhere the path is smooth and the end of one interval is the start of the next), halving the cost of a
    path lifted by inverse kinematics."""
    start = path.evaluate(grid[:-1], side="right")
    two_sided = np.nonzero(np.isin(grid[1:], breaks))[0]
    ends_at = np.append(two_sided, len(grid) - 2)  # intervals whose end needs the left-sided value
    end_values = path.evaluate(grid[1:][ends_at], side="left")
    ends = []
    for s, e in zip(start, end_values):
        out = np.empty_like(s)
        out[:-1] = s[1:]
        out[ends_at] = e
        ends.append(out)
    return start, tuple(ends)


@dataclass(frozen=True, eq=False)
class PathTable:
    """Tabulated q = Phi(theta).

    grid (M,) theta values; coeffs (M-1, 6, n) quintic coefficients in s = (theta - grid[i]) / h_i;
    domain, closed as the path's; kinks (K,) the path's kinks (theta where Phi' jumps). Build with
    :meth:`from_path`.
    """

    grid: np.ndarray
    coeffs: np.ndarray
    domain: tuple[float, float]
    closed: bool
    n: int
    kinks: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def from_path(cls, path: JointPath, points: int = defaults.PATH_TABLE_POINTS) -> "PathTable":
        """Tabulate ``path`` on ``points`` evenly spaced theta values plus its breaks and kinks."""
        if points < 2:
            raise SimulationError(f"path table needs at least 2 points, got {points}")
        lo, hi = path.domain
        extra = [b for b in (*path.breaks, *path.kinks) if lo < b < hi]
        grid = np.unique(np.concatenate([np.linspace(lo, hi, points), extra]))
        if extra:  # drop grid points too close to a break (keep the break itself)
            near = np.min(np.abs(grid[:, None] - np.asarray(extra)[None, :]), axis=1)
            is_break = np.isin(grid, extra)
            grid = grid[(near > BREAK_MERGE * (hi - lo)) | is_break]
        left, right = _interval_ends(path, grid, extra)
        h = np.diff(grid)[:, None]
        data = np.stack(
            [left[0], left[1] * h, left[2] * h**2, right[0], right[1] * h, right[2] * h**2], axis=1
        )  # (M-1, 6, n)
        coeffs = np.einsum("kj,mjn->mkn", _HERMITE5, data)
        if not np.all(np.isfinite(coeffs)):
            raise SimulationError("the joint path returned NaN or inf while tabulating it for the controller")
        kinks = np.array(sorted(k for k in path.kinks if lo < k < hi), dtype=float)
        return cls(grid=grid, coeffs=coeffs, domain=(float(lo), float(hi)), closed=bool(path.closed), n=path.n,
                   kinks=kinks)

    @property
    def length(self) -> float:
        return self.domain[1] - self.domain[0]

    @cached_property
    def speed2_scale(self) -> float:
        """max over the grid of |Phi'|^2 [rad^2 per unit theta^2], the scale of "Phi' = 0" tests."""
        return float(np.max(np.sum(self.coeffs[:, 1, :] ** 2, axis=1) / np.diff(self.grid) ** 2))

    @cached_property
    def arrays(self) -> PathArrays:
        """The table as the compiled kernels take it."""
        return PathArrays(np.ascontiguousarray(self.grid, float), np.ascontiguousarray(self.coeffs, float),
                          bool(self.closed), np.ascontiguousarray(self.kinks, float))

    def projection(self, iterations: int = defaults.PROJECTION_ITERATIONS) -> Projection:
        """Projection settings with the tolerance and the largest step scaled by the domain's length."""
        return Projection(int(iterations), defaults.PROJECTION_TOLERANCE * self.length,
                          defaults.PROJECTION_MAX_STEP * self.length)

    @cached_property
    def _guess_limits(self) -> tuple[float, float, float]:
        """(largest move of :meth:`next_guess`, domain start, domain end)."""
        return defaults.PROJECTION_MAX_STEP * self.length, float(self.domain[0]), float(self.domain[1])

    def next_guess(self, theta: float, theta_dot: float, dt: float) -> float:
        """theta + theta_dot dt, the move limited to PROJECTION_MAX_STEP of the length, inside an open domain."""
        limit, lo, hi = self._guess_limits
        guess = theta + min(max(theta_dot * dt, -limit), limit)
        return guess if self.closed else min(max(guess, lo), hi)

    def wrap(self, theta: float) -> float:
        """theta mapped into the domain: modulo the period for closed paths, clipped for open ones."""
        lo, hi = self.domain
        if self.closed:
            return lo + (theta - lo) % (hi - lo)
        return min(max(theta, lo), hi)

    def evaluate_scalar(self, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Phi, Phi', Phi'') at one theta (wrapped/clipped into the domain), each (n,)."""
        out = evaluate_at(self.arrays, float(theta))
        return out[0], out[1], out[2]

    def project(self, q: np.ndarray, theta_guess: float, iterations: int, tol: float, max_step: float):
        """Compiled projection core; see :func:`pathmotion.control.transverse.project`."""
        theta, ev = project(self.arrays, np.ascontiguousarray(q, dtype=float), float(theta_guess),
                            Projection(int(iterations), float(tol), float(max_step)))
        return theta, (ev[0], ev[1], ev[2])

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
