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

import numba
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


@numba.njit(cache=True)
def _evaluate_one(grid, coeffs, theta):
    """(3, n): Phi, Phi', Phi'' at one theta inside [grid[0], grid[-1]] (compiled: ~1 us per call)."""
    i = min(max(np.searchsorted(grid, theta, side="right") - 1, 0), len(grid) - 2)
    h = grid[i + 1] - grid[i]
    s = (theta - grid[i]) / h
    c = coeffs[i]
    n = c.shape[1]
    out = np.empty((3, n))
    for j in range(n):
        c0, c1, c2, c3, c4, c5 = c[0, j], c[1, j], c[2, j], c[3, j], c[4, j], c[5, j]
        out[0, j] = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
        out[1, j] = (c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))) / h
        out[2, j] = (2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5))) / (h * h)
    return out


@numba.njit(cache=True)
def _wrapped(theta, lo, hi, closed):
    if closed:
        return lo + (theta - lo) % (hi - lo)
    return min(max(theta, lo), hi)


@numba.njit(cache=True)
def _project_one(grid, coeffs, closed, q, theta, iterations, tol, max_step):
    """Compiled core of :func:`pathmotion.control.transverse.project` (same algorithm, see there)."""
    lo, hi = grid[0], grid[-1]
    ev = _evaluate_one(grid, coeffs, _wrapped(theta, lo, hi, closed))
    y = q - ev[0]
    dist = np.dot(y, y)
    for _ in range(iterations):
        d2 = np.dot(ev[1], ev[1])
        if d2 <= 1e-24:
            step = 1e-3 * max_step
            if not closed and theta >= hi:
                step = -step
        else:
            curv = d2 - np.dot(ev[2], y)
            step = np.dot(ev[1], y) / (curv if curv > 0.5 * d2 else d2)
            step = min(max(step, -max_step), max_step)
            if abs(step) <= tol:
                break
        accepted = False
        new = theta
        ev_new = ev
        y_new = y
        dist_new = dist
        for _halve in range(8):
            new = theta + step
            if not closed:
                new = min(max(new, lo), hi)
            ev_new = _evaluate_one(grid, coeffs, _wrapped(new, lo, hi, closed))
            y_new = q - ev_new[0]
            dist_new = np.dot(y_new, y_new)
            if dist_new <= dist * (1.0 + 1e-12) + 1e-300:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            break
        theta, ev, y, dist = new, ev_new, y_new, dist_new
    return theta, ev


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
        out = _evaluate_one(self.grid, self.coeffs, self.wrap(float(theta)))
        return out[0], out[1], out[2]

    def project(self, q: np.ndarray, theta_guess: float, iterations: int, tol: float, max_step: float):
        """Compiled projection core; see :func:`pathmotion.control.transverse.project`."""
        theta, ev = _project_one(self.grid, self.coeffs, self.closed, np.ascontiguousarray(q, dtype=float),
                                 float(theta_guess), iterations, tol, max_step)
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
