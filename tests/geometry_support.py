"""Shared helpers for the geometry tests: finite differences, random corners and a near-cusp Bezier."""

from __future__ import annotations

from math import comb

import numpy as np
from scipy.spatial.transform import Rotation

from pathmotion.geometry import Arc, BezierSegment, Line, TaskPath

FD_STEP = 1e-5


def central_difference(fn, x: np.ndarray, h: float = FD_STEP) -> np.ndarray:
    """Fourth-order central difference of a vectorized fn of x (N,):
    (-f(x+2h) + 8 f(x+h) - 8 f(x-h) + f(x-2h)) / 12h (truncation O(h^4))."""
    return (-fn(x + 2 * h) + 8 * fn(x + h) - 8 * fn(x - h) + fn(x - 2 * h)) / (12.0 * h)


def interior_thetas(path: TaskPath, n: int, seed: int, margin: float = 1e-3) -> np.ndarray:
    """n random theta in the domain, at least ``margin`` from every break and end."""
    rng = np.random.default_rng(seed)
    th = rng.uniform(margin, path.length - margin, 10 * n)
    stops = np.asarray(path.breaks + (0.0, path.length))
    ok = np.min(np.abs(th[:, None] - stops[None, :]), axis=1) > margin
    return np.sort(th[ok][:n])


def incoming(kind: str, length: float, radius: float, left: bool) -> "Line | Arc":
    """Segment ending at the origin with tangent +x: a line, or an arc of ``radius`` curving left
    (centre at +y) or right, of arc length ``length``."""
    if kind == "line":
        return Line((-length, 0.0, 0.0), (0.0, 0.0, 0.0))
    normal = np.array([0.0, 0.0, 1.0 if left else -1.0])
    centre = np.array([0.0, radius if left else -radius, 0.0])
    start = centre + Rotation.from_rotvec(-(length / radius) * normal).apply(-centre)
    return Arc(centre, start, normal, length / radius)


def outgoing(kind: str, length: float, radius: float, left: bool, angle: float) -> "Line | Arc":
    """Segment starting at the origin with tangent (cos angle, sin angle, 0)."""
    t = np.array([np.cos(angle), np.sin(angle), 0.0])
    if kind == "line":
        return Line((0.0, 0.0, 0.0), length * t)
    normal = np.array([0.0, 0.0, 1.0 if left else -1.0])
    centre = radius * np.cross(normal, t)
    return Arc(centre, (0.0, 0.0, 0.0), normal, length / radius)


def near_cusp(eps: float, h: float = 0.05, width: float = 0.1, at=(0.5, 0.0, 0.45)) -> BezierSegment:
    """X(t) = (width (t^3 + eps t), h t^2, 0) + at, t = 2u - 1: a cubic written as a quintic Bezier (control points
    solved from six samples). At t = 0 its speed dips to width eps (per unit t) and its curvature peaks at
    2 h / (width eps)^2: 11111 1/m at eps = 0.03."""
    u = np.linspace(0.0, 1.0, 6)
    t = 2.0 * u - 1.0
    samples = np.stack([width * (t ** 3 + eps * t), h * t ** 2, 0.0 * t], axis=1) + np.asarray(at)
    basis = np.array([[comb(5, i) * v ** i * (1 - v) ** (5 - i) for i in range(6)] for v in u])
    return BezierSegment(np.linalg.solve(basis, samples))
