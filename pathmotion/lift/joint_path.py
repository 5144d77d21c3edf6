"""Joint-space paths q = Phi(theta): the virtual holonomic constraint every later stage takes.

A :class:`JointPath` maps the path coordinate theta (one coordinate for the whole chain, in
``domain``) to joint positions, with first and second derivatives:

    q = Phi(theta)  (N, n)      Phi'(theta)  (N, n) [rad/unit theta]      Phi''(theta)  (N, n)

``kinks`` lists the theta values where Phi' jumps (sharp task-space corners without a blend):
any admissible motion must stop there. ``breaks`` lists every segment connection (kinks
included), for segment-by-segment planning. ``peaks`` lists the theta values of the task path's
curvature peaks inside its segments, where the planner grades its grid as at breaks. ``dwells`` lists
(theta, time [s]) where the motion waits at rest (each theta a kink or an end). At a break,
``side="right"`` (default) evaluates the segment that starts there and ``side="left"`` the one that ends
there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline

from ..errors import PathError, check_finite

#: Slack of the theta-range check, relative to max(1, domain length): round-off of a caller's theta
#: (e.g. a grid ending at hi computed as a sum) is clipped, a real overshoot is an error [-].
DOMAIN_SLACK = 1e-9
#: Largest joint difference [rad] at which two consecutive waypoints are the same point (the clamped
#: spline through them would have a zero-length knot interval).
SAME_WAYPOINT = 1e-12


@dataclass(frozen=True, eq=False)
class JointPath:
    """Base class: subclasses implement :meth:`evaluate`."""

    n: int
    domain: tuple[float, float]
    closed: bool = False
    kinks: tuple[float, ...] = ()
    breaks: tuple[float, ...] = ()
    joint_names: tuple[str, ...] | None = None
    peaks: tuple[float, ...] = ()
    dwells: tuple[tuple[float, float], ...] = ()

    def evaluate(self, theta, side: str = "right") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Phi, Phi', Phi'') at ``theta`` (scalar or (N,)); each (N, n), or (n,) for a scalar."""
        raise NotImplementedError

    def evaluate_sides(self, theta, at) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """(evaluate(theta, "right"), evaluate(theta[at], "left")) at ``theta`` (N,) and the indices ``at`` (k,) into
        it (a plan's grid and its breaks, where Phi' and Phi'' may differ from either side); each (N, n), (k, n)."""
        theta = np.atleast_1d(np.asarray(theta, float))
        return self.evaluate(theta, "right"), self.evaluate(theta[np.asarray(at, int)], "left")

    def evaluate3(self, theta, side: str = "right") -> tuple[np.ndarray, ...]:
        """(Phi, Phi', Phi'', Phi''') at ``theta``; each (N, n), or (n,) for a scalar. Phi''' is
        exact, for jerk and torque-rate limits: joint jerk = Phi''' theta_dot^3
        + 3 Phi'' theta_dot theta_ddot + Phi' theta_dddot."""
        raise NotImplementedError(f"{type(self).__name__} does not provide the third derivative Phi'''")

    def __call__(self, theta, side: str = "right") -> np.ndarray:
        return self.evaluate(theta, side)[0]

    @property
    def length(self) -> float:
        return self.domain[1] - self.domain[0]

    def _check_theta(self, theta) -> tuple[np.ndarray, bool]:
        th = np.asarray(theta, dtype=float)
        check_finite("theta", th)
        scalar = th.ndim == 0
        th = np.atleast_1d(th)
        lo, hi = self.domain
        tol = DOMAIN_SLACK * max(1.0, abs(hi - lo))
        if np.any(th < lo - tol) or np.any(th > hi + tol):
            bad = th[(th < lo - tol) | (th > hi + tol)][0]
            raise PathError(f"theta = {bad:.6g} is outside the path's range [{lo:.6g}, {hi:.6g}]")
        return np.clip(th, lo, hi), scalar


@dataclass(frozen=True, eq=False)
class SplineJointPath(JointPath):
    """Clamped cubic spline through joint waypoints, knots evenly spaced on theta in [0, 1].

    The same input toppra's ``SplineInterpolator`` takes with ``bc_type="clamped"``.
    """

    waypoints: np.ndarray | None = None
    _spline: CubicSpline | None = None

    @classmethod
    def from_waypoints(cls, waypoints, joint_names=None) -> "SplineJointPath":
        """waypoints: (K, n) joint positions [rad], K >= 2."""
        try:
            wp = np.asarray(waypoints, dtype=float)
        except (TypeError, ValueError) as exc:
            raise PathError(f"joint waypoints must be K >= 2 rows of n numbers [rad] each ({exc})") from None
        if wp.ndim != 2 or wp.shape[0] < 2:
            raise PathError(f"joint waypoints must be a (K >= 2, n) array, got shape {wp.shape}")
        check_finite("joint waypoints", wp)
        repeated = np.all(np.abs(np.diff(wp, axis=0)) < SAME_WAYPOINT, axis=1)
        if np.any(repeated):
            k = int(np.argmax(repeated))
            raise PathError(f"joint waypoints {k} and {k + 1} are identical; remove the repeated waypoint")
        knots = np.linspace(0.0, 1.0, len(wp))
        spline = CubicSpline(knots, wp, bc_type="clamped")
        return cls(n=wp.shape[1], domain=(0.0, 1.0), waypoints=wp, _spline=spline,
                   joint_names=None if joint_names is None else tuple(joint_names))

    @property
    def knots(self) -> tuple[float, ...]:
        """Interior knots: the third derivative jumps there, so the planner puts them on its grid."""
        return tuple(float(k) for k in self._spline.x[1:-1])

    def evaluate(self, theta, side: str = "right"):
        return self.evaluate3(theta, side)[:3]

    def evaluate3(self, theta, side: str = "right"):
        """Adds Phi''' (piecewise constant, 6 x the cubic coefficient of each piece); at an interior
        knot ``side="right"`` takes the piece that starts there, ``side="left"`` the one that ends there.
        Phi, Phi', Phi'' are the spline's own values (scipy's PPoly evaluation, in one compiled pass)."""
        th, scalar = self._check_theta(theta)
        s = self._spline
        if s.c.shape[0] != 4:
            raise PathError(f"SplineJointPath: a cubic's 4 coefficients per piece, got {s.c.shape[0]}")
        out = _spline_kernel(np.ascontiguousarray(s.c, float), np.ascontiguousarray(s.x, float),
                             np.ascontiguousarray(th, float), side != "right")
        return tuple(o[0] for o in out) if scalar else out


@njit(cache=True, nogil=True)
def _spline_kernel(c, x, theta, left):
    """(Phi, Phi', Phi'', Phi''') (N, n) of the piecewise cubic with coefficients ``c`` (4, m - 1, n) (highest
    power first) on the breakpoints ``x`` (m,) at ``theta`` (N,) within [x[0], x[-1]]: the operations of scipy's
    PPoly evaluation (the piece with x[i] <= theta < x[i + 1], the last one closed on the right; each derivative's
    sum over powers in increasing order from 0.0, term c z prefactor, z = 1, s, s s, (s s) s), bit for bit.
    Phi''' = 6 c[0] of that piece, or at a breakpoint with ``left`` of the piece that ends there."""
    m, n = x.shape[0], c.shape[2]
    size = theta.shape[0]
    out = (np.empty((size, n)), np.empty((size, n)), np.empty((size, n)), np.empty((size, n)))
    for p in range(size):
        t = theta[p]
        if t >= x[m - 1]:
            i = m - 2
        elif t < x[0]:
            i = 0
        else:  # the last breakpoint at or below t
            lo, hi = 0, m - 2
            while lo < hi:
                mid = (lo + hi + 1) // 2
                if x[mid] <= t:
                    lo = mid
                else:
                    hi = mid - 1
            i = lo
        j = i - 1 if left and i > 0 and t == x[i] else i
        s = t - x[i]
        z2 = s * s
        z3 = z2 * s
        for col in range(n):
            c0, c1, c2, c3 = c[0, i, col], c[1, i, col], c[2, i, col], c[3, i, col]
            out[0][p, col] = (((0.0 + c3 * 1.0 * 1.0) + c2 * s * 1.0) + c1 * z2 * 1.0) + c0 * z3 * 1.0
            out[1][p, col] = ((0.0 + c2 * 1.0 * 1.0) + c1 * s * 2.0) + c0 * z2 * 3.0
            out[2][p, col] = (0.0 + c1 * 1.0 * 2.0) + c0 * s * 6.0
            out[3][p, col] = 6.0 * c[0, j, col]
    return out
