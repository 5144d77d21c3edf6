"""Where a path passes its programmed targets: the path coordinate of the point nearest each target.

A blended path no longer passes a zone's target (it cuts the corner), and its path coordinate is
shifted by every blend before; a fine point's target it passes exactly. :func:`target_thetas` walks
the targets in order along the path and returns, for each, theta of the path point nearest to it.
"""

from __future__ import annotations

import numpy as np

from .chain import TaskPath

#: Samples of each search window between consecutive targets [-].
WINDOW_SAMPLES = 64
#: A window reaches the sharp path's distance between the targets past the last match plus this share of
#: the shorter neighbouring segment: a blend shortens the path between two targets, and a target the path
#: comes back to (up, down, up again) lies at least two segments further on [-].
WINDOW_SLACK = 0.5
#: Newton steps refining each match (the distance is smooth there) [-].
NEWTON_STEPS = 4


def target_thetas(path: TaskPath, points, spacing) -> np.ndarray:
    """theta (K,) [m] on ``path`` of the point nearest each of ``points`` (K, 3) [m], in order, the first
    at theta = 0 and the last at the path's end; ``spacing`` (K - 1,) [m] the path length between
    consecutive targets before blending (the sharp path's segment lengths)."""
    pts = np.asarray(points, float)
    out = np.zeros(len(pts))
    out[-1] = path.length
    for k in range(1, len(pts) - 1):
        lo = out[k - 1]
        hi = min(path.length, lo + float(spacing[k - 1]) + WINDOW_SLACK * min(float(spacing[k - 1]), float(spacing[k])))
        grid = np.linspace(lo, hi, WINDOW_SAMPLES)
        p = path.evaluate(grid)[0]
        th = float(grid[int(np.argmin(np.linalg.norm(p - pts[k], axis=1)))])
        for _ in range(NEWTON_STEPS):
            p, dp, ddp = path.evaluate(th)
            grad, curv = (p - pts[k]) @ dp, dp @ dp + (p - pts[k]) @ ddp
            if curv <= 0.0:
                break
            th = float(np.clip(th - grad / curv, lo, hi))
        out[k] = th
    return out


__all__ = ["target_thetas"]
