"""Small joint paths for the planner tests (straight lines, polylines with kinks, periodic splines), and the
dense resample that certified bounds are checked against."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from pathmotion.lift.joint_path import JointPath


@dataclass(frozen=True, eq=False)
class PolylinePath(JointPath):
    """Straight joint-space lines between waypoints, segment k on theta in [k, k+1]; every
    interior waypoint is a break, and a kink where the direction changes."""

    waypoints: np.ndarray | None = None

    @classmethod
    def through(cls, waypoints, closed=False):
        wp = np.asarray(waypoints, float)
        m = len(wp) - 1
        d = np.diff(wp, axis=0)
        kinks = tuple(float(k) for k in range(1, m) if np.linalg.norm(np.cross(d[k - 1][:3], d[k][:3])) > 0
                      or np.linalg.norm(d[k - 1] / np.linalg.norm(d[k - 1]) - d[k] / np.linalg.norm(d[k])) > 1e-12)
        return cls(n=wp.shape[1], domain=(0.0, float(m)), closed=closed, kinks=kinks,
                   breaks=tuple(float(k) for k in range(1, m)), waypoints=wp)

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        m = len(self.waypoints) - 1
        k = np.floor(th).astype(int)
        if side == "left":
            k = np.where((th == np.floor(th)) & (th > 0), k - 1, k)
        k = np.clip(k, 0, m - 1)
        d = self.waypoints[k + 1] - self.waypoints[k]
        q = self.waypoints[k] + (th - k)[:, None] * d
        out = (q, d, np.zeros_like(d))
        return tuple(o[0] for o in out) if scalar else out


@dataclass(frozen=True, eq=False)
class PeriodicSplinePath(JointPath):
    """Periodic cubic spline through waypoints (first == last), theta in [0, 1], closed."""

    spline: CubicSpline | None = None

    @classmethod
    def through(cls, waypoints):
        wp = np.asarray(waypoints, float)
        return cls(n=wp.shape[1], domain=(0.0, 1.0), closed=True,
                   spline=CubicSpline(np.linspace(0, 1, len(wp)), wp, bc_type="periodic"))

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        s = self.spline
        out = (s(th), s(th, 1), s(th, 2))
        return tuple(o[0] for o in out) if scalar else out


def dense_interval_max(path, robot, profile, limits, dt) -> dict:
    """{name: (K - 1, m)} largest ratio of each limit on a ``dt`` time resample, per grid interval (the
    interval found from the sample's time)."""
    from pathmotion.planning import Trajectory
    from pathmotion.planning.verify import sample_ratios

    samples, r = sample_ratios(Trajectory(path, profile, robot), limits, dt)
    k = np.clip(np.searchsorted(profile.times, samples.t, side="right") - 1, 0, len(profile.grid) - 2)
    out = {}
    for name, v in r.items():
        acc = np.full((len(profile.grid) - 1, v.shape[1]), -np.inf)
        np.maximum.at(acc, k, v)
        out[name] = acc
    return out


def assert_bounds_cover(bounds: dict, dense: dict, label) -> None:
    """Every certified interval bound is at least the dense resample's largest ratio there (to 1e-9)."""
    for name, d in dense.items():
        b = bounds[name]
        assert b.shape == d.shape, name
        seen = np.isfinite(d)
        short = d[seen] - b[seen]
        assert short.max() <= 1e-9, (label, name, float(short.max()))


#: A 6-joint spline's waypoints for the controller tests [rad], shape (4, 6).
CONTROL_WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                              [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                              [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                              [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


def trapezoid(v=0.9, a=2.0):
    """Rest-to-rest trapezoid in theta on [0, 1]: top speed ``v`` [1/s], acceleration ``a`` [1/s^2]."""
    from pathmotion.planning.profile import Profile

    ta = v * v / (2 * a)
    return Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))
