"""Velocity profile along a path: x(theta) = theta_dot^2, piecewise linear in theta.

Between grid points theta_i and theta_{i+1} the path acceleration u_i = theta_ddot is constant,
so x(theta) = x_i + 2 u_i (theta - theta_i) exactly and time is analytic:

    t_{i+1} - t_i = 2 (theta_{i+1} - theta_i) / (sqrt(x_i) + sqrt(x_{i+1}))
    theta(t) = theta_i + sqrt(x_i) tau + u_i tau^2 / 2,   tau = t - t_i

This is the representation every time-optimal planner here returns and every consumer
(trajectory sampling, controllers) reads. :func:`piece_x` is the one lookup of x on a piece; the
controllers' compiled kernels (control/kernels.py) compile this same function.

Smooth profiles (third-order limits: jerk, torque rate) also carry ``u_nodes`` (K,): theta_ddot at
the grid points, linear between them in a per-interval coordinate xi (planning/smooth.py: the cube
root of the distance to the nearest rest point on that side, so the constant-jerk S-curve start
x ~ s^(4/3) is represented exactly; theta itself where no rest point is near). x follows in closed
form, theta_dddot = du/dtheta theta_dot, times by Gauss-Legendre quadrature in xi, theta(t) by
Newton's method. ``u`` stays the chord (x_{i+1} - x_i) / (2 Delta_i) for consumers that read
piecewise-linear x (the controllers).

Dwells (``holds``, (K,) [s]): the motion waits at rest at a grid point (x = 0 there) before it goes on.
``times`` are departure times (arrival plus the hold), so t*(theta) = times[i] + the motion time from
grid[i] holds on every interval, and a time inside a hold gives theta = grid[i], theta_dot = theta_ddot = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import PathmotionError
from . import smooth


#: Time [s] past an interval's planned motion time that is a hold (a dwell), not round-off.
HOLD_ROUNDING = 1e-12


def piece_x(grid, x, u, i, theta):
    """x(theta) = max(x_i + 2 u_i (theta - theta_i), 0) on piece i (scalars, or arrays of i and theta).

    Plain numpy, so that control/kernels.py can compile it with numba as its scalar lookup."""
    return np.maximum(x[i] + 2.0 * u[i] * (theta - grid[i]), 0.0)


@dataclass(frozen=True, eq=False)
class Profile:
    """grid (K,) increasing theta values; x (K,) = theta_dot^2 >= 0 at the grid points."""

    grid: np.ndarray
    x: np.ndarray
    u_nodes: np.ndarray | None = None
    holds: np.ndarray | None = None

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
        if self.u_nodes is not None:
            un = np.asarray(self.u_nodes, dtype=float)
            if un.shape != x.shape or not np.all(np.isfinite(un)):
                raise PathmotionError(f"profile: u_nodes {un.shape} must be finite and shaped like x {x.shape}")
            object.__setattr__(self, "u_nodes", un)
        if self.holds is not None:
            holds = np.asarray(self.holds, dtype=float)
            if holds.shape != x.shape or not np.all(np.isfinite(holds)) or np.any(holds < 0):
                raise PathmotionError(f"profile: holds {holds.shape} must be finite, >= 0 and shaped like x {x.shape}")
            if np.any((holds > 0) & (x > 0)):
                i = int(np.argmax((holds > 0) & (x > 0)))
                raise PathmotionError(f"profile: a hold at theta = {grid[i]:.6g} where the motion does not stop "
                                      f"(theta_dot^2 = {x[i]:.3g}); a dwell needs a stop")
            object.__setattr__(self, "holds", holds)

    @cached_property
    def coords(self) -> tuple[np.ndarray, np.ndarray]:
        """Smooth profiles: (origin, sign) of each interval's xi (planning/smooth.py)."""
        return _coords(self)

    @property
    def smooth(self) -> bool:
        """theta_ddot is continuous (piecewise linear in theta; see the module docstring)."""
        return self.u_nodes is not None

    @cached_property
    def u(self) -> np.ndarray:
        """Constant path acceleration theta_ddot on each interval, (K-1,)."""
        return np.diff(self.x) / (2.0 * np.diff(self.grid))

    @cached_property
    def intervals(self) -> np.ndarray:
        """Motion time of each interval [s], (K-1,) (holds excluded)."""
        if self.smooth:
            return _smooth_interval_times(self)
        sq = np.sqrt(self.x)
        return 2.0 * np.diff(self.grid) / (sq[:-1] + sq[1:])

    @cached_property
    def times(self) -> np.ndarray:
        """Time [s] at which the motion leaves each grid point, (K,): 0 at the start, plus the holds so far."""
        times = np.concatenate([[0.0], np.cumsum(self.intervals)])
        return times if self.holds is None else times + np.cumsum(self.holds)

    @cached_property
    def motion(self) -> "Profile":
        """The same motion without the holds."""
        return self if self.holds is None else Profile(self.grid, self.x, self.u_nodes)

    def holds_at(self, theta) -> np.ndarray:
        """The hold [s] at each theta (N,): a grid point's hold where theta is that grid point, else 0."""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        out = np.zeros(len(th))
        if self.holds is not None:
            for i in np.nonzero(self.holds)[0]:
                out[np.abs(th - self.grid[i]) <= 1e-12 * max(1.0, abs(self.grid[i]))] += self.holds[i]
        return out

    def with_holds(self, dwells) -> "Profile":
        """This profile waiting ``time`` [s] at rest at each (theta [m], time) of ``dwells`` (theta on the grid)."""
        holds = np.zeros_like(self.x) if self.holds is None else self.holds.copy()
        for theta, wait in dwells:
            i = int(np.argmin(np.abs(self.grid - theta)))
            if abs(self.grid[i] - theta) > 1e-9 * max(1.0, abs(theta)):
                raise PathmotionError(f"profile: the dwell at theta = {theta:.6g} is not a grid point")
            holds[i] += wait
        return Profile(self.grid, self.x, self.u_nodes, holds)

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def _interval(self, theta) -> np.ndarray:
        return np.clip(np.searchsorted(self.grid, theta, side="right") - 1, 0, len(self.grid) - 2)

    def x_at(self, theta) -> np.ndarray:
        """x = theta_dot^2 at theta (linear interpolation is exact here)."""
        th = np.asarray(theta, dtype=float)
        i = self._interval(th)
        if self.smooth:
            return _smooth_state(self, i, th)[0]
        return piece_x(self.grid, self.x, self.u, i, th)

    def theta_dot_at(self, theta) -> np.ndarray:
        return np.sqrt(self.x_at(theta))

    def theta_ddot_at(self, theta) -> np.ndarray:
        """u on the interval containing theta (right-continuous)."""
        th = np.asarray(theta, dtype=float)
        if self.smooth:
            i = self._interval(th)
            return _smooth_state(self, i, th)[1]
        return self.u[self._interval(th)]

    def state_at_time(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta, theta_dot, theta_ddot) at times t [s] (clipped to [0, duration])."""
        return self.state3_at_time(t)[:3]

    def state3_at_time(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(theta, theta_dot, theta_ddot, theta_dddot) at times t [s] (clipped to [0, duration]);
        theta_dddot is 0 inside the intervals of a non-smooth profile."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        i = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.grid) - 2)
        tau = t - self.times[i]
        if self.holds is not None:
            return _with_rest(self, i, tau)
        if self.smooth:  # vectorized over intervals: a scalar time goes through as one element
            out = _smooth_at_time(self, np.atleast_1d(i), np.atleast_1d(tau))
            return tuple(v.reshape(t.shape) for v in out)
        v0 = np.sqrt(self.x[i])
        u = self.u[i]
        theta = np.minimum(self.grid[i] + v0 * tau + 0.5 * u * tau**2, self.grid[i + 1])
        theta_dot = np.sqrt(piece_x(self.grid, self.x, self.u, i, theta))
        return theta, theta_dot, u, np.zeros_like(theta)

    def scaled(self, factor: float) -> "Profile":
        """The same shape with theta_dot multiplied by ``factor`` (x by factor^2); the holds unchanged."""
        return Profile(self.grid, self.x * factor**2, None if self.u_nodes is None else self.u_nodes * factor**2,
                       self.holds)


def _with_rest(p: Profile, i: np.ndarray, tau: np.ndarray):
    """state3_at_time of a profile with holds: the motion state at tau (clipped to interval i's motion), and
    rest (theta at the grid point, zero rates) before the interval's departure or after its arrival."""
    period = p.intervals[i]
    before, after = tau < 0.0, tau > period + HOLD_ROUNDING
    moving = p.motion
    clipped = moving.times[i] + np.clip(tau, 0.0, period)
    theta, theta_dot, theta_ddot, jerk = (np.array(v, dtype=float) for v in moving.state3_at_time(clipped))
    rest = before | after
    theta = np.where(before, p.grid[i], np.where(after, p.grid[i + 1], theta))
    return (theta, np.where(rest, 0.0, theta_dot), np.where(rest, 0.0, np.broadcast_to(theta_ddot, theta.shape)),
            np.where(rest, 0.0, jerk))


#: Gauss-Legendre nodes and weights on [0, 1] for the smooth profile's interval times.
_GL_T, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_T, _GL_W = 0.5 * (_GL_T + 1.0), 0.5 * _GL_W
#: Newton iterations for theta(t) inside a smooth interval.
NEWTON_STEPS = 8


def _coords(p: Profile):
    return smooth.coordinates(p.grid, p.x <= 0.0)


def _smooth_state(p: Profile, i, theta):
    """(x, u, theta_dddot) at theta in interval i."""
    origin, sign = p.coords
    return smooth.state(p.grid, p.x, p.u_nodes, origin, sign, i, theta)


def _rate(p: Profile, i, lam):
    """(theta, dt/dlambda) at the fraction lambda of interval i's xi range: integrand of its time."""
    origin, sign = p.coords
    o, sg = origin[i], sign[i]
    xi0 = smooth.xi_of(o, sg, p.grid[i])
    dxi = smooth.xi_of(o, sg, p.grid[i + 1]) - xi0
    xi = xi0 + lam * dxi
    th = np.clip(smooth.theta_of(o, sg, xi), p.grid[i], p.grid[i + 1])
    x = _smooth_state(p, i, th)[0]
    dth = smooth.dtheta_dxi(sg, xi) * dxi
    with np.errstate(divide="ignore", invalid="ignore"):
        return th, dth / np.sqrt(x)


def _smooth_interval_times(p: Profile) -> np.ndarray:
    """Duration of every interval (K-1,) [s], by Gauss-Legendre quadrature in its xi (the integrand
    stays finite at a rest point, where x ~ xi^4 and d theta / d xi ~ xi^2)."""
    origin, sign = p.coords
    return smooth.interval_times(p.grid, p.x, p.u_nodes, origin, sign, _GL_T, _GL_W)


def _smooth_at_time(p: Profile, i: np.ndarray, tau: np.ndarray):
    """(theta, theta_dot, theta_ddot, theta_dddot) at tau after the start of interval i: Newton's
    method on the fraction lambda of the interval's xi range (t(lambda) by quadrature)."""
    period = p.intervals[i]
    lam = np.clip(tau / np.where(period > 0, period, 1.0), 0.0, 1.0)
    for _ in range(NEWTON_STEPS):
        _, rate = _rate(p, i[:, None], lam[:, None] * _GL_T[None, :])
        t_lam = lam * np.sum(_GL_W * rate, axis=1)
        _, r_end = _rate(p, i, lam)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (t_lam - tau) / r_end
        lam = np.clip(lam - np.where(np.isfinite(step), step, 0.0), 0.0, 1.0)
    theta, _ = _rate(p, i, lam)
    x, u, jerk = _smooth_state(p, i, theta)
    return theta, np.sqrt(x), u, jerk
