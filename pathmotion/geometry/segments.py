"""Path segments, each parameterized by its own arc length s in [0, length] [m].

Every segment returns, vectorized over s (N,):

    p(s)  (N, 3) [m]      p'(s) = unit tangent  (N, 3) [-]      p''(s) = curvature vector  (N, 3) [1/m]

The derivatives are the exact derivatives of the returned position. Segment types:

* :class:`Line` -- straight line from ``start`` to ``end``.
* :class:`Arc` -- circular arc in any plane: centre, start point, plane normal and a signed sweep
  angle (right-hand rule about the normal); or :meth:`Arc.through_points`.
* :class:`Circle` -- a full circle (an :class:`Arc` with sweep +-2 pi); :meth:`Circle.from_centre`
  and :meth:`Circle.horizontal` take a radius and a start angle.
* :class:`BezierSegment` -- a quintic Bezier curve reparameterized by arc length (numerically, to
  ~1e-13 m), used for curvature-continuous blends.

Degenerate input raises :class:`~pathmotion.errors.PathError` naming the segment and what to change.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from math import comb
from typing import ClassVar

import numpy as np

from .. import defaults
from ..errors import PathError
from . import bezier_arc_length, bezier_batch, bezier_polyval

#: A direction vector shorter than this [m or -] has no direction.
ZERO_LENGTH = 1e-12
#: Closest-point Newton iteration: converged when the step is below this times max(1, length) [-].
NEWTON_ROUNDING = 1e-15
#: Arc: |cos| between radius and plane normal above 1 - this means the normal lies along the radius [-].
NORMAL_ALONG_RADIUS = 1e-9
#: Arc: |cos| between radius and plane normal above this means the start point is off the plane
#: (1e-6 = 5.7e-5 deg: more than rounding, less than any intended geometry) [-].
OFF_PLANE_COS = 1e-6
#: A sweep may exceed one turn, and a Circle's sweep differ from 2 pi, by this relative rounding [-].
TURN_ROUNDING = 1e-12
#: Arc.through_points: |ab x ac| below this times max(|ab|, |ac|)^2 means collinear points [-].
COLLINEAR_SINE = 1e-12
#: Stand-in for a zero scale in relative tests, so that they never divide by zero.
NONZERO = 1e-300
#: Start angles are measured from world x projected on the plane, unless that projection is shorter
#: than this (normal nearly along x); then from world y [-].
REFERENCE_AXIS_MIN = 1e-6
#: Bezier: a speed |dp/du| below this fraction of the largest one is a cusp [-].
CUSP_SPEED_RATIO = 1e-9
#: Bezier arc-length inversion: converged when |s(u) - s| is below this times max(1, length) [-].
ARC_LENGTH_ROUNDING = 1e-13
#: Curvature maxima below this are no peaks [1/m] (a radius of 1 km: a straight piece's rounding noise).
PEAK_MIN_CURVATURE = 1e-3
#: Samples of the Bezier parameter in which curvature maxima are looked for [-], then rounds of samples across each
#: peak's bracket (each round narrows it (PEAK_REFINE_SAMPLES - 1) / 2 times: 2^-11 to 2e-9 in u) [-].
PEAK_SAMPLES = 2049
PEAK_REFINE_SAMPLES = 33
PEAK_REFINE_ROUNDS = 4

_TWO_PI = 2.0 * np.pi


def as_point(name: str, value, where: str) -> np.ndarray:
    """``value`` as a finite (3,) float array, or a PathError naming ``name`` in ``where``."""
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise PathError(f"{where}: {name} must be 3 numbers [m], got {value!r}") from exc
    if arr.shape != (3,):
        raise PathError(f"{where}: {name} must be 3 numbers (x, y, z), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise PathError(f"{where}: {name} = {arr.tolist()} contains NaN or inf; give finite numbers")
    arr.flags.writeable = False
    return arr


def as_scalar(name: str, value, where: str) -> float:
    """``value`` as a finite float, or a PathError naming ``name`` in ``where``."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise PathError(f"{where}: {name} must be a number, got {value!r}") from exc
    if not np.isfinite(x):
        raise PathError(f"{where}: {name} = {x} is not finite; give a finite number")
    return x


def unit(name: str, value, where: str) -> np.ndarray:
    """``value`` normalized to length 1; PathError if it is (nearly) zero."""
    v = np.array(as_point(name, value, where))
    n = np.linalg.norm(v)
    if n < ZERO_LENGTH:
        raise PathError(f"{where}: {name} = {v.tolist()} has zero length; give a non-zero direction")
    v = v / n
    v.flags.writeable = False
    return v


def _fmt(v) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in np.asarray(v, float)) + ")"


def _as_s(s) -> np.ndarray:
    return np.atleast_1d(np.asarray(s, dtype=float))


class Segment:
    """Base class of path segments; subclasses are frozen dataclasses.

    Subclasses implement ``length``, :meth:`evaluate` and :meth:`describe`; they may override
    :meth:`closest` (exact formulas) and :meth:`trimmed`.
    """

    kind: ClassVar[str] = "segment"

    @property
    def length(self) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def evaluate(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        """(p, p', p'') at arc length s (N,), each (N, 3); s is clipped to [0, length]."""
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - abstract
        """Short human-readable description used in error messages."""
        raise NotImplementedError

    def evaluate3(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        """(p, p', p'', p''') at arc length s (N,), each (N, 3); p''' [1/m^2] is exact (for jerk limits)."""
        raise NotImplementedError

    @property
    def plane_normal(self) -> np.ndarray | None:
        """Unit normal (3,) of the plane the segment lies in, or None for a straight line."""
        return None

    @property
    def curvature_peaks(self) -> tuple[float, ...]:
        """Arc lengths s [m] of the interior local maxima of the curvature, where the planner grades its grid (a
        peak narrower than a grid step is otherwise unseen); () where the curvature is constant (lines, arcs)."""
        return ()

    def _end(self, which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p, dp, ddp = self.evaluate(0.0 if which == 0 else self.length)
        return p[0], dp[0], ddp[0]

    @property
    def start_point(self) -> np.ndarray:
        """p(0) (3,) [m]."""
        return self._end(0)[0]

    @property
    def end_point(self) -> np.ndarray:
        """p(length) (3,) [m]."""
        return self._end(1)[0]

    @property
    def start_frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(point, unit tangent, curvature vector) at s = 0, each (3,)."""
        return self._end(0)

    @property
    def end_frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(point, unit tangent, curvature vector) at s = length, each (3,)."""
        return self._end(1)

    def closest(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Closest point of the segment to each of ``points`` (N, 3): (s (N,), distance (N,) [m]).

        Generic version: best of 129 samples, then Newton on (p(s) - x) . p'(s) = 0, and the ends.
        """
        x = np.atleast_2d(np.asarray(points, float))
        grid = np.linspace(0.0, self.length, 129)
        pg = self.evaluate(grid)[0]
        d2 = np.sum((x[:, None, :] - pg[None, :, :]) ** 2, axis=2)
        s = grid[np.argmin(d2, axis=1)]
        for _ in range(30):
            p, dp, ddp = self.evaluate(s)
            r = p - x
            g = np.sum(r * dp, axis=1)
            h = 1.0 + np.sum(r * ddp, axis=1)
            step = np.where(h > 0.1, g / np.where(h > 0.1, h, 1.0), g)
            s = np.clip(s - step, 0.0, self.length)
            if np.max(np.abs(step)) < NEWTON_ROUNDING * max(1.0, self.length):
                break
        return self._nearer_than_ends(s, x)

    def _nearer_than_ends(self, s: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(s (N,), distance (N,) [m]): for each point of ``x`` (N, 3), the nearest of its candidate ``s``
        (N,) and the segment's two ends."""
        cand = np.stack([s, np.zeros_like(s), np.full_like(s, self.length)], axis=1)
        dist = np.stack([np.linalg.norm(self.evaluate(c)[0] - x, axis=1) for c in cand.T], axis=1)
        k = np.argmin(dist, axis=1)
        rows = np.arange(len(x))
        return cand[rows, k], dist[rows, k]

    def trimmed(self, s0: float, s1: float) -> "Segment":
        """The part of this segment between arc lengths s0 < s1, as a new segment."""
        raise PathError(f"{self.describe()} cannot be trimmed; blends can only cut lines and arcs")


@dataclass(frozen=True, eq=False)
class Line(Segment):
    """Straight line from ``start`` to ``end`` (each (3,) [m])."""

    start: np.ndarray
    end: np.ndarray
    kind: ClassVar[str] = "line"
    _t: np.ndarray = field(init=False, repr=False)
    _length: float = field(init=False, repr=False)

    def __post_init__(self):
        where = "Line"
        a = as_point("start", self.start, where)
        b = as_point("end", self.end, where)
        length = float(np.linalg.norm(b - a))
        if length < defaults.MIN_SEGMENT_LENGTH:
            raise PathError(f"Line from {_fmt(a)} to {_fmt(b)} has zero length ({length:.3g} m); "
                            "give distinct start and end points or remove the segment")
        t = (b - a) / length
        t.flags.writeable = False
        object.__setattr__(self, "start", a)
        object.__setattr__(self, "end", b)
        object.__setattr__(self, "_t", t)
        object.__setattr__(self, "_length", length)

    @property
    def length(self) -> float:
        return self._length

    @property
    def direction(self) -> np.ndarray:
        """Unit direction (3,)."""
        return self._t

    def describe(self) -> str:
        return f"Line {_fmt(self.start)} -> {_fmt(self.end)}"

    def evaluate(self, s):
        s = np.minimum(np.maximum(_as_s(s), 0.0), self._length)  # np.clip, without its overhead (blend sizing)
        p = self.start + s[:, None] * self._t
        t = np.empty_like(p)
        t[:] = self._t
        return p, t, np.zeros_like(p)

    def evaluate3(self, s):
        p, dp, ddp = self.evaluate(s)
        return p, dp, ddp, np.zeros_like(p)

    def _end(self, which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # evaluate's numbers at 0 or the length without its arrays (every path construction classifies each joint)
        return self.start + (0.0 if which == 0 else self._length) * self._t, self._t.copy(), np.zeros(3)

    def point(self, s: float) -> np.ndarray:
        """The point (3,) [m] at arc length ``s`` [m], clipped to [0, length]: evaluate's for one s, without
        its arrays (the blend sizing builds some 50 000 blends per corner)."""
        return self.start + min(max(float(s), 0.0), self._length) * self._t

    def closest(self, points):
        x = np.atleast_2d(np.asarray(points, float))
        # the dot product written out (BLAS rounds it differently on different CPUs, and
        # geometry/quintic_deviation.py repeats these operations compiled); np.clip without its overhead
        d, t = x - self.start, self._t
        s = np.minimum(np.maximum(d[:, 0] * t[0] + d[:, 1] * t[1] + d[:, 2] * t[2], 0.0), self._length)
        r = self.start + s[:, None] * t - x
        return s, np.sqrt(np.add.reduce(r * r, axis=1))  # np.linalg.norm(r, axis=1), bit for bit

    def trimmed(self, s0, s1):
        return Line(self.evaluate(s0)[0][0], self.evaluate(s1)[0][0])


@dataclass(frozen=True, eq=False)
class Arc(Segment):
    """Circular arc: ``centre`` (3,) [m], ``start`` point (3,) [m], plane ``normal`` (3,),
    ``sweep`` [rad], signed: positive turns right-handed about ``normal``.

    The radius is |start - centre|; start - centre must be perpendicular to the normal.
    """

    centre: np.ndarray
    start: np.ndarray
    normal: np.ndarray
    sweep: float
    kind: ClassVar[str] = "arc"
    radius: float = field(init=False)
    _u: np.ndarray = field(init=False, repr=False)
    _v: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        where = type(self).__name__
        c = as_point("centre", self.centre, where)
        a = as_point("start", self.start, where)
        n = unit("normal", self.normal, where)
        sweep = as_scalar("sweep", self.sweep, where)
        d = a - c
        radius = float(np.linalg.norm(d))
        if radius < defaults.MIN_SEGMENT_LENGTH:
            raise PathError(f"{where} with centre {_fmt(c)}: radius is {radius:.3g} m (start point at the "
                            "centre); give a start point away from the centre")
        u = d / radius
        off = float(abs(u @ n))
        if off > 1.0 - NORMAL_ALONG_RADIUS:
            raise PathError(f"{where} with centre {_fmt(c)}: the plane normal {_fmt(n)} is parallel to the "
                            "radius (start - centre); give a normal perpendicular to the radius")
        if off > OFF_PLANE_COS:
            raise PathError(f"{where} with centre {_fmt(c)}: start point {_fmt(a)} is not in the plane through "
                            f"the centre with normal {_fmt(n)} (radius makes {np.degrees(np.arccos(off)):.4g} deg "
                            "with the normal); give a normal perpendicular to start - centre")
        if abs(sweep) * radius < defaults.MIN_SEGMENT_LENGTH:
            raise PathError(f"{where} with centre {_fmt(c)}: sweep {sweep:.3g} rad gives zero length; "
                            "give a non-zero sweep angle")
        if abs(sweep) > _TWO_PI * (1.0 + TURN_ROUNDING):
            raise PathError(f"{where} with centre {_fmt(c)}: sweep {sweep:.6g} rad exceeds one turn (2 pi); "
                            "split it into a Circle and an Arc")
        v = np.cross(n, u)
        for arr in (u, v):
            arr.flags.writeable = False
        object.__setattr__(self, "centre", c)
        object.__setattr__(self, "start", a)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "sweep", sweep)
        object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "_u", u)
        object.__setattr__(self, "_v", v)

    @classmethod
    def through_points(cls, p0, p1, p2) -> "Arc":
        """Arc from ``p0`` through ``p1`` to ``p2`` (each (3,) [m])."""
        where = "Arc.through_points"
        a, b, c = (as_point(nm, v, where) for nm, v in (("p0", p0), ("p1", p1), ("p2", p2)))
        ab, ac = b - a, c - a
        nvec = np.cross(ab, ac)
        scale = max(np.linalg.norm(ab), np.linalg.norm(ac), NONZERO)
        if np.linalg.norm(nvec) < COLLINEAR_SINE * scale ** 2:
            raise PathError(f"{where}: points {_fmt(a)}, {_fmt(b)}, {_fmt(c)} are collinear or coincide; "
                            "give three distinct points not on one line (or use a Line)")
        n2 = nvec @ nvec
        centre = a + (np.cross(nvec, ab) * (ac @ ac) + np.cross(ac, nvec) * (ab @ ab)) / (2.0 * n2)
        normal = nvec / np.sqrt(n2)
        u = (a - centre) / np.linalg.norm(a - centre)
        v = np.cross(normal, u)
        w = c - centre
        sweep = float(np.arctan2(w @ v, w @ u)) % _TWO_PI
        return cls(centre, a, normal, sweep)

    @property
    def length(self) -> float:
        return abs(self.sweep) * self.radius

    @property
    def plane_normal(self) -> np.ndarray:
        return self.normal

    @property
    def curvature(self) -> float:
        """1 / radius [1/m]."""
        return 1.0 / self.radius

    def describe(self) -> str:
        return (f"{type(self).__name__} centre {_fmt(self.centre)} radius {self.radius:.4g} m "
                f"normal {_fmt(self.normal)} sweep {np.degrees(self.sweep):.4g} deg")

    def _angle(self, s):
        return np.sign(self.sweep) * np.clip(_as_s(s), 0.0, self.length) / self.radius

    def evaluate(self, s):
        phi = self._angle(s)
        c, sn = np.cos(phi)[:, None], np.sin(phi)[:, None]
        radial = c * self._u + sn * self._v
        p = self.centre + self.radius * radial
        dp = np.sign(self.sweep) * (-sn * self._u + c * self._v)
        return p, dp, -radial / self.radius

    def evaluate3(self, s):
        """p''' = -p' / r^2: the curvature vector -radial / r turns with the tangent."""
        p, dp, ddp = self.evaluate(s)
        return p, dp, ddp, -dp / self.radius ** 2

    def closest(self, points):
        x = np.atleast_2d(np.asarray(points, float))
        d = x - self.centre
        h = d @ self.normal
        X, Y = d @ self._u, np.sign(self.sweep) * (d @ self._v)
        rho = np.hypot(X, Y)
        t = np.mod(np.arctan2(Y, X), _TWO_PI)
        on_arc = t <= abs(self.sweep)
        d_in = np.sqrt((rho - self.radius) ** 2 + h ** 2)
        p0, p1 = self.evaluate(0.0)[0][0], self.evaluate(self.length)[0][0]
        d0, d1 = np.linalg.norm(x - p0, axis=1), np.linalg.norm(x - p1, axis=1)
        s_end = np.where(d0 <= d1, 0.0, self.length)
        dist = np.where(on_arc, d_in, np.minimum(d0, d1))
        return np.where(on_arc, t * self.radius, s_end), dist

    def trimmed(self, s0, s1):
        return Arc(self.centre, self.evaluate(s0)[0][0], self.normal,
                   np.sign(self.sweep) * (s1 - s0) / self.radius)


def _reference_axis(normal: np.ndarray) -> np.ndarray:
    """Unit vector in the plane with ``normal`` from which start angles are measured: the
    projection of world x, or of world y when the normal is (nearly) along x."""
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        e = axis - (axis @ normal) * normal
        if np.linalg.norm(e) > REFERENCE_AXIS_MIN:
            return e / np.linalg.norm(e)
    raise AssertionError("unreachable: x and y cannot both be parallel to a unit normal")


@dataclass(frozen=True, eq=False)
class Circle(Arc):
    """Full circle: an :class:`Arc` with ``sweep`` = +2 pi (right-handed about ``normal``) or -2 pi."""

    sweep: float = _TWO_PI
    kind: ClassVar[str] = "circle"

    def __post_init__(self):
        super().__post_init__()
        if abs(abs(self.sweep) - _TWO_PI) > _TWO_PI * TURN_ROUNDING:
            raise PathError(f"Circle centre {_fmt(self.centre)}: sweep must be +-2 pi, got {self.sweep:.6g} rad; "
                            "use an Arc for part of a circle")

    @classmethod
    def from_centre(cls, centre, radius: float, normal, start_angle: float = 0.0,
                    direction: int = 1) -> "Circle":
        """Circle with ``centre`` (3,) [m], ``radius`` [m], plane ``normal`` (3,), starting at
        ``start_angle`` [rad] measured right-handed about the normal from the projection of world x
        on the plane (world y if the normal is along x); ``direction`` +1 runs right-handed about
        the normal, -1 the other way."""
        where = "Circle"
        c = as_point("centre", centre, where)
        n = unit("normal", normal, where)
        r = as_scalar("radius", radius, where)
        ang = as_scalar("start_angle", start_angle, where)
        if r <= defaults.MIN_SEGMENT_LENGTH:
            raise PathError(f"Circle centre {_fmt(c)}: radius {r:.3g} m must be positive")
        if direction not in (1, -1):
            raise PathError(f"Circle centre {_fmt(c)}: direction must be +1 or -1, got {direction!r}")
        e1 = _reference_axis(n)
        e2 = np.cross(n, e1)
        start = c + r * (np.cos(ang) * e1 + np.sin(ang) * e2)
        return cls(c, start, n, direction * _TWO_PI)

    @classmethod
    def horizontal(cls, centre, radius: float, start_angle: float = 0.0, direction: int = 1) -> "Circle":
        """Circle in the horizontal plane through ``centre`` (normal +z); ``start_angle`` [rad]
        from world x towards world y; ``direction`` +1 counter-clockwise seen from above."""
        return cls.from_centre(centre, radius, (0.0, 0.0, 1.0), start_angle, direction)

    def trimmed(self, s0, s1):
        return Arc.trimmed(self, s0, s1)


#: Gauss-Legendre rule used for the arc length of Bezier segments: panels on [0, 1], nodes each.
_GL_PANELS = 32
#: The values of u where a BezierSegment's speed is checked for a cusp, and those of its arc-length table (shared,
#: read-only).
_CUSP_U, _TABLE_U = np.linspace(0.0, 1.0, 2049), np.linspace(0.0, 1.0, 257)
_CUSP_U.flags.writeable = _TABLE_U.flags.writeable = False
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(12)


#: _power_basis' integers: (-1)^(k-i) C(k, i) for i <= k, else 0 (6, 6), and C(5, k) (6,).
_POWER_SIGNED = np.array([[(-1) ** (k - i) * comb(k, i) if i <= k else 0 for i in range(6)] for k in range(6)], float)
_POWER_SCALE = np.array([comb(5, k) for k in range(6)], float)
#: curvature_peaks' samples of u and of each peak's bracket (PEAK_SAMPLES, PEAK_REFINE_SAMPLES).
_PEAK_U = np.linspace(0.0, 1.0, PEAK_SAMPLES)
_PEAK_OFFSETS = np.linspace(-1.0, 1.0, PEAK_REFINE_SAMPLES)
#: k! / (k - order)! for k = order .. 5, per order: the factors of d^order u^k / du^order.
_DERIVATIVE_FACTORS = tuple(np.array([np.prod(np.arange(k - order + 1, k + 1)) for k in range(order, 6)], float)
                            for order in range(6))


@dataclass(frozen=True, eq=False)
class BezierSegment(Segment):
    """Quintic Bezier curve X(u), u in [0, 1], with control points (6, 3) [m], reparameterized by
    arc length.

    s(u) = int_0^u |X'(v)| dv is computed with a composite Gauss-Legendre rule (32 panels of 12
    nodes: exact to rounding for this smooth integrand) and inverted by Newton's method to
    |s(u) - s| < 1e-13 max(1, length), both compiled (:mod:`.bezier_arc_length`). Then, with T = X'/|X'|,

        p(s) = X(u(s))      p'(s) = T      p''(s) = (X'' - (X''.T) T) / |X'|^2

    are the exact derivatives of the returned position (du/ds = 1/|X'|), so theta stays true arc
    length on blends and |p'| = 1 everywhere.
    """

    control_points: np.ndarray
    kind: ClassVar[str] = "bezier"
    _coef: np.ndarray = field(init=False, repr=False)
    _panel_s: np.ndarray = field(init=False, repr=False)
    _table_u: np.ndarray = field(init=False, repr=False)
    _table_s: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        b = np.array(self.control_points, dtype=float)
        if b.shape != (6, 3):
            raise PathError(f"BezierSegment: control_points must be a (6, 3) array, got shape {b.shape}")
        if not np.all(np.isfinite(b)):
            raise PathError("BezierSegment: control points contain NaN or inf; give finite numbers")
        b.flags.writeable = False
        coef = self._power_basis(b)
        object.__setattr__(self, "control_points", b)
        object.__setattr__(self, "_coef", coef)
        slowest, k, fastest = bezier_polyval.speed_range(coef, _CUSP_U, _DERIVATIVE_FACTORS[1])
        if slowest < CUSP_SPEED_RATIO * max(fastest, NONZERO):
            raise PathError(f"BezierSegment {self.describe()}: the curve stops (cusp) near u = {_CUSP_U[k]:.3g}; "
                            "the blend is degenerate (tangents nearly opposite?)")
        object.__setattr__(self, "_panel_s", bezier_arc_length.panel_edges(coef, _GL_PANELS, _GL_NODES, _GL_WEIGHTS))
        object.__setattr__(self, "_table_u", _TABLE_U)
        object.__setattr__(self, "_table_s", self._arc_length(_TABLE_U))

    def describe(self) -> str:
        b = self.control_points
        return f"Bezier blend {_fmt(b[0])} -> {_fmt(b[-1])}"

    @staticmethod
    def _power_basis(b: np.ndarray) -> np.ndarray:
        """Monomial coefficients (6, 3) of the Bezier curve with control points b (6, 3):
        X(u) = sum_k coef[k] u^k, coef[k] = C(5, k) sum_i (-1)^(k-i) C(k, i) b_i (compiled)."""
        return bezier_polyval.power_basis(np.ascontiguousarray(b, dtype=float), _POWER_SIGNED, _POWER_SCALE)

    @staticmethod
    def _polyval(coef: np.ndarray, u, order: int = 0) -> np.ndarray:
        """d^order X / du^order (N, 3) at u (N,) by Horner's rule from monomial coefficients."""
        return bezier_polyval.polyval(coef, _as_s(u), _DERIVATIVE_FACTORS[order], order)

    def curve(self, u, order: int = 2) -> tuple[np.ndarray, ...]:
        """(X, X', X'') at the Bezier parameter u (N,), each (N, 3); ``order=3`` appends X'''."""
        return tuple(self._polyval(self._coef, u, k) for k in range(order + 1))

    def _curvature_squared(self, u) -> np.ndarray:
        """|X' x X''|^2 / |X'|^6 [1/m^2] (N,) at u (N,), by Lagrange's identity (its terms compiled)."""
        num, g2 = bezier_polyval.curvature_terms(self._coef, _as_s(u), _DERIVATIVE_FACTORS[1], _DERIVATIVE_FACTORS[2])
        return num / g2 ** 3

    @cached_property
    def curvature_peaks(self) -> tuple[float, ...]:
        """The curvature's interior local maxima above PEAK_MIN_CURVATURE, found on PEAK_SAMPLES values of u and
        refined PEAK_REFINE_ROUNDS times on PEAK_REFINE_SAMPLES between the neighbours of the largest (a near-cusp's
        peak is a few um of arc wide where it is thousands of 1/m high, but its width in u is not: the search found
        one of 25000 1/m, 0.07 mm wide at half height)."""
        at = bezier_polyval.curvature_peak_parameters(self._coef, _PEAK_U, _DERIVATIVE_FACTORS[1],
                                                      _DERIVATIVE_FACTORS[2], PEAK_MIN_CURVATURE ** 2,
                                                      _PEAK_OFFSETS, PEAK_REFINE_ROUNDS, 3.0)
        if at.size == 0:
            return ()
        return tuple(float(s) for s in self._arc_length(at))

    def _arc_length(self, u):
        """s(u) [m] (N,) at u (N,), clipped to [0, 1]."""
        return bezier_arc_length.arc_lengths(self._coef, self._panel_s, np.asarray(u, float), _GL_NODES, _GL_WEIGHTS)

    @property
    def length(self) -> float:
        return float(self._panel_s[-1])

    def parameter(self, s) -> np.ndarray:
        """Bezier parameter u (N,) at arc length s (N,) [m]."""
        s = np.clip(_as_s(s), 0.0, self.length)
        return bezier_arc_length.parameters(self._coef, self._panel_s, self._table_u, self._table_s, s,
                                            ARC_LENGTH_ROUNDING * max(1.0, self.length), _GL_NODES, _GL_WEIGHTS)

    @cached_property
    def _frames(self) -> tuple:
        """Segment._end at both ends, evaluated once, in one compiled call (every path built from this segment
        classifies its joints): :func:`~pathmotion.geometry.bezier_batch.evaluate_many`, evaluate's floats."""
        length = self.length
        p, dp, ddp = bezier_batch.evaluate_many(
            self._coef[None], self._panel_s[None], self._table_u, self._table_s[None], np.array([length]),
            np.array([ARC_LENGTH_ROUNDING * max(1.0, length)]), np.zeros(2, np.int64), np.array([0.0, length]),
            _GL_NODES, _GL_WEIGHTS, *_DERIVATIVE_FACTORS[:3])
        return tuple((p[k], dp[k], ddp[k]) for k in (0, 1))

    def _end(self, which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return tuple(a.copy() for a in self._frames[which])

    def evaluate(self, s):
        u = self.parameter(s)
        x, dx, ddx = self.curve(u)
        g = np.linalg.norm(dx, axis=1)[:, None]
        t = dx / g
        return x, t, (ddx - np.sum(ddx * t, axis=1)[:, None] * t) / g ** 2

    def evaluate3(self, s):
        """Adds p''' = (dk/du) / g with k = p'' = (X'' - (X''.T) T) / g^2, g = |X'|, dT/du = g k and
        dg/du = X''.T, so dk/du = (X''' - (X'''.T) T - (X''.dT/du) T - (X''.T) dT/du) / g^2 - 2 k (dg/du) / g."""
        u = self.parameter(s)
        x, dx, ddx, dddx = self.curve(u, 3)
        g = np.linalg.norm(dx, axis=1)[:, None]
        t = dx / g
        a_t = np.sum(ddx * t, axis=1)[:, None]
        k = (ddx - a_t * t) / g ** 2
        dt_du = g * k
        dk_du = ((dddx - np.sum(dddx * t, axis=1)[:, None] * t - np.sum(ddx * dt_du, axis=1)[:, None] * t
                  - a_t * dt_du) / g ** 2 - 2.0 * k * a_t / g)
        return x, t, k, dk_du / g


class StackedSegments:
    """The lines and quintic blends of a chain of ``segments`` stacked into arrays, so that (p, p', p'') at many
    points of many of them take a few array operations and one compiled call (:mod:`.bezier_batch`) instead of a
    call per segment: the same floats as each segment's :meth:`~Segment.evaluate`. Other segments (arcs) are left
    to their own evaluate."""

    def __init__(self, segments: tuple[Segment, ...]):
        kinds = [type(seg) for seg in segments]
        self.line = np.array([k is Line for k in kinds], bool)
        self.bezier = np.array([k is BezierSegment for k in kinds], bool)
        lines = [seg for seg in segments if type(seg) is Line]
        self.start = np.zeros((len(segments), 3))
        self.direction = np.zeros((len(segments), 3))
        self.line_length = np.zeros(len(segments))
        at = np.flatnonzero(self.line)
        if lines:
            self.start[at] = [seg.start for seg in lines]
            self.direction[at] = [seg.direction for seg in lines]
            self.line_length[at] = [seg.length for seg in lines]
        beziers = [seg for seg in segments if type(seg) is BezierSegment]
        self.bezier_index = np.cumsum(self.bezier) - 1  # segment -> its row in the Bezier stacks
        self.coef = np.array([seg._coef for seg in beziers], float).reshape(-1, 6, 3)
        self.edges = np.array([seg._panel_s for seg in beziers], float).reshape(len(beziers), _GL_PANELS + 1)
        self.table_u = beziers[0]._table_u if beziers else np.zeros(0)
        self.table_s = np.array([seg._table_s for seg in beziers], float).reshape(len(beziers), len(self.table_u))
        self.bezier_length = np.array([seg.length for seg in beziers], float)
        self.tols = ARC_LENGTH_ROUNDING * np.maximum(1.0, self.bezier_length)

    def evaluate(self, s: np.ndarray, k: np.ndarray, out: np.ndarray) -> np.ndarray:
        """out[:, i] = (p, p', p'') at arc length s[i] [m] of segment k[i] for every i on a line or blend; the mask
        (N,) of those i (the others are left to the caller)."""
        line, bez = self.line[k], self.bezier[k]
        if line.any():
            i = np.flatnonzero(line)
            kk = k[i]
            si = np.minimum(np.maximum(s[i], 0.0), self.line_length[kk])
            out[0, i] = self.start[kk] + si[:, None] * self.direction[kk]
            out[1, i] = self.direction[kk]
            out[2, i] = 0.0
        if bez.any():
            i = np.flatnonzero(bez)
            out[:, i] = bezier_batch.evaluate_many(
                self.coef, self.edges, self.table_u, self.table_s, self.bezier_length, self.tols,
                self.bezier_index[k[i]], np.ascontiguousarray(s[i]), _GL_NODES, _GL_WEIGHTS, *_DERIVATIVE_FACTORS[:3])
        return line | bez

    def line_distance(self, points: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Distance [m] (N,) of points (N, 3) from the lines k (N,): Line.closest's operations, per pair."""
        t = self.direction[k]
        d = points - self.start[k]
        s = np.minimum(np.maximum(d[:, 0] * t[:, 0] + d[:, 1] * t[:, 1] + d[:, 2] * t[:, 2], 0.0), self.line_length[k])
        r = self.start[k] + s[:, None] * t - points
        return np.sqrt(np.add.reduce(r * r, axis=1))
