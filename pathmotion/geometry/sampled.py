"""A space curve given by samples of its position and first two derivatives: the TCP trace of a joint move.

:class:`HermiteSegment` interpolates samples s_k (K,), p (K, 3), p' (K, 3), p'' (K, 3) by a quintic Hermite
polynomial on each interval: p, p' and p'' are continuous and equal the samples at every s_k, and the
interpolation error is O(h^6) for a smooth curve (h the sample spacing). Its parameter s runs over
[0, length] but need not be the arc length: p' is the given derivative, not a unit tangent. The lift gives
it the forward kinematics of a joint-space line and its exact derivatives (pathmotion/lift/joint_move.py):
geometry never calls the robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..errors import PathError
from .segments import NEWTON_ROUNDING, Segment, _as_s, _fmt

#: Closest-point Newton iterations, and the samples per interval of the starting search.
NEWTON_STEPS = 30
START_SAMPLES = 4
#: Newton steps where d2/ds2 of the half squared distance exceeds this times |p'|^2 [-] (a point near the centre
#: of curvature has a flat distance: Newton there, not gradient steps, which crawl).
CONVEX = 1e-9


@dataclass(frozen=True, eq=False)
class HermiteSegment(Segment):
    """Quintic Hermite curve through samples: s (K,) strictly increasing from 0 [m of path coordinate];
    p (K, 3) [m]; dp (K, 3) = dp/ds [-]; ddp (K, 3) = d2p/ds2 [1/m]. ``label`` names it in messages."""

    s: np.ndarray
    p: np.ndarray
    dp: np.ndarray
    ddp: np.ndarray
    label: str = "sampled curve"
    kind: ClassVar[str] = "sampled"
    _coeffs: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        s = np.asarray(self.s, dtype=float)
        arrays = [np.asarray(a, dtype=float) for a in (self.p, self.dp, self.ddp)]
        if s.ndim != 1 or len(s) < 2 or s[0] != 0.0 or np.any(np.diff(s) <= 0):
            raise PathError(f"{self.label}: samples s must start at 0 and increase strictly (K >= 2)")
        if any(a.shape != (len(s), 3) for a in arrays) or not all(np.all(np.isfinite(a)) for a in arrays):
            raise PathError(f"{self.label}: p, p', p'' must be finite ({len(s)}, 3) arrays")
        h = np.diff(s)[:, None]
        p0, p1 = arrays[0][:-1], arrays[0][1:]
        v0, v1 = h * arrays[1][:-1], h * arrays[1][1:]
        a0, a1 = h * h * arrays[2][:-1], h * h * arrays[2][1:]
        dp = p1 - p0
        c3 = 10 * dp - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
        c4 = -15 * dp + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
        c5 = 6 * dp - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
        coeffs = np.stack([p0, v0, 0.5 * a0, c3, c4, c5], axis=1)  # (K-1, 6, 3) in t = (s - s_k) / h
        for name, a in zip(("s", "p", "dp", "ddp"), [s] + arrays):
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        object.__setattr__(self, "_coeffs", coeffs)

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def _derivatives(self, s, order: int) -> tuple[np.ndarray, ...]:
        """(p, p', ..., p^(order)) at s (N,), each (N, 3)."""
        s = np.clip(_as_s(s), 0.0, self.length)
        i = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        h = (self.s[i + 1] - self.s[i])[:, None]
        t = ((s - self.s[i]) / h[:, 0])[:, None]
        c = self._coeffs[i]
        out = []
        for d in range(order + 1):  # d-th derivative of sum c_k t^k, by Horner, divided by h^d
            acc = np.zeros((len(s), 3))
            for k in range(5, d - 1, -1):
                factor = np.prod(np.arange(k - d + 1, k + 1)) if d else 1.0
                acc = acc * t + factor * c[:, k]
            out.append(acc / h**d)
        return tuple(out)

    def evaluate(self, s):
        return self._derivatives(s, 2)

    def evaluate3(self, s):
        return self._derivatives(s, 3)

    def closest(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(s (N,), distance (N,) [m]) of the closest point to each of ``points`` (N, 3): the best sample, then
        Newton on (p(s) - x) . p'(s) = 0 (with |p'|^2 in the Hessian: s is not the arc length), and the ends."""
        x = np.atleast_2d(np.asarray(points, float))
        grid = np.unique(np.concatenate([np.linspace(a, b, START_SAMPLES + 1)
                                         for a, b in zip(self.s[:-1], self.s[1:])]))
        pg = self.evaluate(grid)[0]
        s = grid[np.argmin(np.sum((x[:, None, :] - pg[None]) ** 2, axis=2), axis=1)]
        reach = float(np.max(np.diff(grid)))
        for _ in range(NEWTON_STEPS):
            p, dp, ddp = self.evaluate(s)
            r = p - x
            g = np.sum(r * dp, axis=1)
            h = np.sum(dp * dp, axis=1) + np.sum(r * ddp, axis=1)
            scale = np.maximum(np.sum(dp * dp, axis=1), 1e-300)
            convex = h > CONVEX * scale  # Newton where the squared distance curves up, else a gradient step
            step = np.where(convex, g / np.where(convex, h, 1.0), g / scale)
            step = np.clip(step, -reach, reach)
            s = np.clip(s - step, 0.0, self.length)
            if np.max(np.abs(step)) < NEWTON_ROUNDING * max(1.0, self.length):
                break
        return self._nearer_than_ends(s, x)

    def describe(self) -> str:
        return f"{self.label} from {_fmt(self.p[0])} to {_fmt(self.p[-1])} (length {self.length:.4g} m)"
