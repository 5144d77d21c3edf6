"""The closed loop's monitor of the true state, compiled (numba): one call per sample.

It projects the true q onto the path near the previous theta (the same local projection as the orbital
controller, :func:`pathmotion.control.kernels.project`), and returns what the end rules need
(docs/control.md, "Failure rules"). At a kink of the path (Phi' jumps, e.g. a sharp corner the plan stops
at) the local projection cannot pass from one side to the other when the two tangents make more than 90
degrees in joint space: near a kink it also projects from just past it on either side and keeps the
nearest point. A point behind the current theta is taken only if it is at most BACKWARD_RATIO of the
distance: where a path turns back over its own configurations (a pick or place point reached and left along
the same line) both halves are equally near, and round-off must not send theta back along the outbound half.
"""

from __future__ import annotations

import numba
import numpy as np

from ..control.kernels import project, wrap

#: How far past a kink the extra projections start, as a fraction of the projection's largest step [-].
KINK_OFFSET = 1e-6
#: A projection across a kink to a smaller theta replaces the current one only when its squared distance is
#: below this fraction of the current one (half the distance) [-].
BACKWARD_RATIO = 0.25


@numba.njit(cache=True)
def monitor_state(path, q, qd, guess, proj, speed_limit, speed_eps):
    """(theta, theta_dot, deviation, along, speed2, ok) of the true state q, qd (n,) on ``path`` (PathArrays):

    theta the projection (unwrapped on closed paths), theta_dot = Phi'^T qd / |Phi'|^2 (0 where Phi' = 0),
    deviation = max_j |q - Phi(theta)| [rad], along = Phi'^T (q - Phi) / |Phi'|^2 (how far past an end of the
    domain the robot is, in theta), speed2 = |Phi'|^2, ok = False on NaN/inf or |qd_j| > speed_limit_j.
    Where speed2 <= speed_eps (clamped spline ends) theta_dot and along are 0."""
    n = q.shape[0]
    ok = True
    for j in range(n):
        if not (np.isfinite(q[j]) and abs(qd[j]) <= speed_limit[j]):
            ok = False
    if not ok:
        return guess, 0.0, np.inf, 0.0, 0.0, False
    grid = path.grid
    max_step = proj.max_step
    theta, ev = project(path, q, guess, proj)
    y = q - ev[0]
    best = np.dot(y, y)
    near = wrap(theta, grid[0], grid[-1], path.closed)
    for kink in path.kinks:
        if abs(near - kink) < max_step:
            for side in (-1.0, 1.0):
                start = theta + (kink - near) + side * KINK_OFFSET * max_step
                th2, ev2 = project(path, q, start, proj)
                y2 = q - ev2[0]
                d2 = np.dot(y2, y2)
                if d2 < best and (th2 >= theta or d2 < BACKWARD_RATIO * best):
                    theta, ev, y, best = th2, ev2, y2, d2
    dphi = ev[1]
    speed2 = np.dot(dphi, dphi)
    dev = 0.0
    for j in range(n):
        dev = max(dev, abs(y[j]))
    if speed2 > speed_eps:
        return theta, np.dot(dphi, qd) / speed2, dev, np.dot(dphi, y) / speed2, speed2, True
    return theta, 0.0, dev, 0.0, speed2, True
