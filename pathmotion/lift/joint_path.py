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
        th, scalar = self._check_theta(theta)
        s = self._spline
        out = (s(th), s(th, 1), s(th, 2))
        return tuple(o[0] for o in out) if scalar else out

    def evaluate3(self, theta, side: str = "right"):
        """Adds Phi''' (piecewise constant, 6 x the cubic coefficient of each piece); at an interior
        knot ``side="right"`` takes the piece that starts there, ``side="left"`` the one that ends there."""
        th, scalar = self._check_theta(theta)
        s = self._spline
        idx = np.searchsorted(s.x, th, side="right" if side == "right" else "left") - 1
        idx = np.clip(idx, 0, len(s.x) - 2)
        out = (s(th), s(th, 1), s(th, 2), 6.0 * s.c[0, idx])
        return tuple(o[0] for o in out) if scalar else out
