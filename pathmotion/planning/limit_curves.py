"""Each active limit's own maximum-velocity curve, for the phase-plane figure.

The planner's curve (``LimitCurves.x_max``) is the point-wise bound of all limits together. Here each
limit of order 1 or 2 gets its own: at grid point theta_k, the largest x = theta_dot^2 for which some
u = theta_ddot meets that limit alone (velocity and TCP speed: their bound on x; acceleration, torque
with its reserve, the torque-speed envelope: their rows lo <= a u + b x + c <= hi), on both sides of
each point (the smaller is kept, as the planner does at path corners), with unit scale factors (the
limits as the user set them, not as the verify-and-tighten loop lowered them locally).

The envelope's rows are linearized around a reference x (a tangent of the convex falling part, an
inner bound exact at the reference): its curve is relinearized at itself until it settles. Each step
stays feasible for the exact envelope and cannot fall, so it converges up to the exact curve.

Third-order limits (jerk, torque rate) bound how fast theta_ddot may change, not the speed at a point:
they have no such curve (the figure shows their effect as the second-order optimum next to the
jerk-limited one). What they do bound is the speed of steady motion: at a constant path speed
(theta_ddot = theta_dddot = 0) joint jerk is Phi''' theta_dot^3 and torque rate sqrt(x) (beta' x +
gamma'). :func:`steady_curves` gives, per third-order limit, the largest constant speed up to which
that stays within the limit (a fine geometric scan in x, refined by bisection). It is not a bound (the
motion may pass above it while it speeds up or slows down), but where the path stays curved the
jerk-limited optimum cannot stay above it for long.
"""

from __future__ import annotations

import numpy as np

from ..lift.joint_path import JointPath
from ..robot import Robot
from .limit_rows import limit_rows
from .limits import EffectiveLimits, PathPoints
from .grid_data import grid_breaks, sample_grid
from .planner import PlanSettings, effective_limits
from .topp import maximum_velocity_curve

#: Largest x = theta_dot^2 written for an unbounded point (the figure clips at its own headroom).
X_UNBOUNDED = 1e12
#: Relinearizing a curve at itself stops when no point moves by more than this, relative [-] ...
SETTLE_TOLERANCE = 1e-10
#: ... or after this many rounds.
SETTLE_ROUNDS = 30


def _side_curve(points: PathPoints, limits: EffectiveLimits) -> np.ndarray:
    """x_max (K,) of ``limits`` (one limit) at ``points``, relinearized until it settles."""
    k, n = len(points.theta), points.q.shape[1]
    scale = limits.unit_scale(k, n)
    x = maximum_velocity_curve(limit_rows(points, limits, scale, X_UNBOUNDED))
    if not limits.relinearize:
        return x
    for _ in range(SETTLE_ROUNDS):
        new = maximum_velocity_curve(limit_rows(points, limits, scale, X_UNBOUNDED, np.minimum(x, X_UNBOUNDED)))
        settled = np.all(np.abs(new - x) <= SETTLE_TOLERANCE * np.maximum(np.abs(x), 1.0))
        x = new
        if settled:
            break
    return x


def _sides(path: JointPath, robot: Robot, theta: np.ndarray) -> list[PathPoints]:
    """Path points at ``theta`` (K,) seen from the interval after and before each point (the two differ at the
    path's breaks only, where the left side is evaluated; elsewhere it shares the right side's data)."""
    theta = np.asarray(theta, float)
    sampled = sample_grid(path, robot, theta, grid_breaks(path, theta))
    return [sampled.right, sampled.left]


def limit_curves(path: JointPath, robot: Robot, settings: PlanSettings, theta: np.ndarray,
                 sides: tuple[PathPoints, PathPoints] | None = None) -> dict[str, np.ndarray]:
    """{limit name: theta_dot_max (K,)} at ``theta`` (K,) for every active limit of order 1 or 2, in
    registry order; theta_dot_max is sqrt(X_UNBOUNDED) where the limit alone does not bound the speed.
    ``sides``: the path data (right side, left side) at ``theta`` when the caller has them (a plan's
    ``path_points``), else the path is evaluated."""
    if sides is None or not np.array_equal(sides[0].theta, theta):
        sides = _sides(path, robot, theta)
    out = {}
    for lim in effective_limits(robot, settings):
        if lim.order > 2:
            continue
        single = EffectiveLimits((lim,))
        x = np.minimum(*(_side_curve(points, single) for points in sides))
        out[lim.name] = np.sqrt(np.clip(x, 0.0, X_UNBOUNDED))
    return out


#: The steady-speed scan: x from STEADY_X_MIN to X_UNBOUNDED in this many geometric steps, then bisections.
STEADY_X_MIN = 1e-10
STEADY_SCAN = 400
STEADY_BISECTIONS = 60


def _steady_side(points: PathPoints, lim) -> np.ndarray:
    """x (K,): the largest x with |sqrt(x') (b x' + c)| <= lim for every x' in [0, x] (the limit's value at
    constant speed: its rows3 with u = u' = 0), smallest over its columns; X_UNBOUNDED where never reached."""
    k, n = len(points.theta), points.q.shape[1]
    rows = lim.rows3(points, np.ones((k, lim.columns(n))))
    b, c = rows.b[..., None], rows.c[..., None]
    bound = np.broadcast_to(rows.lim, rows.b.shape)[..., None]

    def within(x):
        return np.abs(np.sqrt(x) * (b * x + c)) <= bound

    scan = np.geomspace(STEADY_X_MIN, X_UNBOUNDED, STEADY_SCAN)
    ok = within(scan)  # (K, m, S)
    reached = ~ok.all(axis=2)
    first = np.argmin(ok, axis=2)  # the first x of the scan over the limit (where reached)
    hi = scan[first]
    lo = np.where(first > 0, scan[np.maximum(first - 1, 0)], 0.0)
    for _ in range(STEADY_BISECTIONS):
        mid = 0.5 * (lo + hi)
        good = within(mid[..., None])[..., 0]
        lo, hi = np.where(good, mid, lo), np.where(good, hi, mid)
    return np.where(reached, lo, X_UNBOUNDED).min(axis=1)


def steady_curves(path: JointPath, robot: Robot, settings: PlanSettings, theta: np.ndarray) -> dict[str, np.ndarray]:
    """{limit name: theta_dot (K,)} at ``theta`` (K,) for every active third-order limit: the largest
    constant path speed within that limit (see the module docstring; not a bound on the motion); the path is
    evaluated only when there is one."""
    third = [lim for lim in effective_limits(robot, settings) if lim.order == 3]
    if not third:
        return {}
    sides = _sides(path, robot, theta)
    out = {}
    for lim in third:
        x = np.minimum(*(_steady_side(points, lim) for points in sides))
        out[lim.name] = np.sqrt(np.clip(x, 0.0, X_UNBOUNDED))
    return out
