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
jerk-limited one instead).
"""

from __future__ import annotations

import numpy as np

from ..joint_path import JointPath
from ..robot import Robot
from .limit_rows import limit_rows
from .limits import EffectiveLimits, PathPoints
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


def limit_curves(path: JointPath, robot: Robot, settings: PlanSettings, theta: np.ndarray) -> dict[str, np.ndarray]:
    """{limit name: theta_dot_max (K,)} at ``theta`` (K,) for every active limit of order 1 or 2, in
    registry order; theta_dot_max is sqrt(X_UNBOUNDED) where the limit alone does not bound the speed."""
    theta = np.asarray(theta, float)
    sides = []
    for side in ("right", "left"):
        q, dq, ddq = path.evaluate(theta, side)
        sides.append(PathPoints(robot, path, theta, q, dq, ddq, side=side))
    out = {}
    for lim in effective_limits(robot, settings):
        if lim.order > 2:
            continue
        single = EffectiveLimits((lim,))
        x = np.minimum(*(_side_curve(points, single) for points in sides))
        out[lim.name] = np.sqrt(np.clip(x, 0.0, X_UNBOUNDED))
    return out
