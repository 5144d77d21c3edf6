"""Replacing a sharp corner (or a curvature jump) by a transition segment.

Two kinds of transition, both cutting the two neighbouring segments A (ending at the corner) and B
(starting there) and inserting one new segment between the cut points:

**Transition circle** (the thesis' method, chapter 7.2): a circular arc of radius r_t tangent to
both neighbours, for planar line-line, line-arc and arc-arc corners. Its centre C lies at distance
r_t from both neighbours on the inside of the turn: with m = t_A x t_B / |t_A x t_B| the corner's
plane normal (the turn is left-handed about m) and n(s) = m x t(s) the inward normal,

    p_A(L_A - a) + r_t n_A(L_A - a) = p_B(b) + r_t n_B(b)

is solved for the cut lengths (a, b) by Newton's method (closed form a = b = r_t tan(delta/2) for
two lines, delta = angle between the tangents, is the starting guess). The result is G1: the
tangent is continuous, the curvature jumps (0 -> 1/r_t on a line), so Phi'' jumps at both ends.

For two lines meeting at angle delta (interior angle phi = pi - delta) the arc's midpoint is
farthest from the original path: distance r_t (1 - sin(phi/2)) to the nearest line (and
r_t (1/sin(phi/2) - 1) to the corner point itself); see docs/geometry.md.

**G2 blend**: a quintic Bezier curve X(u), u in [0, 1], that matches position, unit tangent and
curvature vector of both neighbours at the cut points, so tangent and curvature (hence Phi' and
Phi'') are continuous. Why a quintic Bezier: it is the lowest-degree polynomial that meets
position, tangent and curvature at both ends with free end speeds (6 conditions per end pair);
it works in 3-D and for line and arc neighbours alike (a clothoid pair only joins lines or needs
Fresnel integrals per arc case), and it admits a simple Lipschitz bound for the guarantee below.
With the cut length a on both sides, the end speeds lambda = 5/2 * shape * a and tangents t,
curvature vectors k of the neighbours at the cuts:

    b0 = p_A           b1 = b0 + lambda/5 t_A      b2 = b0 + 2 lambda/5 t_A + lambda^2/20 k_A
    b5 = p_B           b4 = b5 - lambda/5 t_B      b3 = b5 - 2 lambda/5 t_B + lambda^2/20 k_B

so X'(0) = lambda t_A, X''(0) = lambda^2 k_A (zero tangential acceleration), and the curvature
vector (X'' - (X''.T)T)/|X'|^2 equals k_A at u = 0 (k_B at u = 1). For a line-line corner all six
points lie on the two lines, and with shape = 1 b2 = b3 = corner point.

*Deviation guarantee.* d(x) = distance from x to the original path is 1-Lipschitz; along X it is
K-Lipschitz in u with K = 5 max_i |b_{i+1} - b_i| (X' is a convex combination of
5 (b_{i+1} - b_i)). Replacing the whole path by the two neighbours A and B only increases d, so
:func:`~pathmotion.geometry.deviation.certified_max` of u -> dist(X(u), A u B) bounds the true
deviation from above. The cut length a is the largest (by bisection) whose certified upper bound
is <= tolerance, so the deviation is <= tolerance by construction (and >= tolerance (1 - 1e-4)
minus the bisection resolution, i.e. the blend is as large as the tolerance allows).

*Path coordinate.* The Bezier is reparameterized by arc length (see
:class:`~pathmotion.geometry.segments.BezierSegment`), so theta remains arc length.

Orientation keys that fall in a replaced stretch are mapped linearly onto the new segment; keys
after it move by the change of length.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Iterable, Mapping

import numpy as np

from .. import defaults
from ..errors import PathError
from .chain import Connection, TaskPath, classify, cross3
from .deviation import BOUND_ROUNDING, Deviation, certified_max, distance_to_segments
from . import blend_sizing
from .quintic_deviation import _line_arrays, _samples, bezier_lines_max, bezier_pieces_lines_max, g2_lines_cut
from .segments import _POWER_SCALE, _POWER_SIGNED, Arc, BezierSegment, Line, Segment, _fmt

log = logging.getLogger(__name__)

_FULL = 1.0 - 1e-6  # a single blend may use all of a neighbour but this sliver
#: A departure's (arrival's) total cut may differ from its neighbour's length by this times max(1, length) [-]
#: (rounding of the run it derives).
_END_ROUNDING = 1e-9
_FIFTHS = np.arange(6) / 5.0  # the offset pieces' control points are evenly spaced along the line
#: |t_A x t_B| below this: the tangents are (anti)parallel, the path reverses at the corner [-].
REVERSAL_SINE = 1e-9
#: Fillet Newton iteration: converged when the closure error is below this times max(1, |p_A|) [-]
#: (the error is a difference of positions of size |p_A|, so this is rounding).
FILLET_ROUNDING = 1e-13
#: A fillet arc must end on the outgoing segment to this times max(1, radius) [-].
FILLET_CLOSURE = 1e-9
#: Rounding guard of _down: the value is scaled by 1 - this before flooring, so a product that rounds
#: up to the next digit is still rounded down [-].
ROUND_DOWN_GUARD = 1e-15


@dataclass(frozen=True)
class _Corner:
    """Connection ``conn`` of ``path`` with neighbours A, B and the largest cuts allowed [m]."""

    conn: Connection
    A: Segment
    B: Segment
    max_a: float
    max_b: float

    def where(self) -> str:
        return self.conn.describe()


class _Draft:
    """A path being blended from its last corner to its first: its segments and the theta maps of the edits so far,
    a :class:`TaskPath` only at the end (:meth:`path`). Connection k (classified on demand) and every theta before
    it are the original path's while only connections after k were edited, so a program of N corners costs O(N),
    not N paths of N connections each."""

    def __init__(self, path: TaskPath, segments: tuple | None = None, maps: list | None = None):
        self.original = path
        self.segments = path.segments if segments is None else segments
        self.maps = [] if maps is None else maps  # shared along the chain of drafts: each is used once
        self.closed = path.closed

    def connection(self, index: int) -> Connection:
        """Connection ``index`` of the current segments (only valid before any edit at index or below)."""
        if not 0 <= index < len(self.segments) - 1:
            return self.original.connection(index)
        return classify(self.segments[index], self.segments[index + 1], index, self.original.offsets[index + 1])

    def with_segments(self, segments, theta_map=None) -> "_Draft":
        if theta_map is not None:
            self.maps.append(theta_map)
        return _Draft(self.original, tuple(segments), self.maps)

    def path(self) -> TaskPath:
        """The blended :class:`TaskPath` (its tool orientation's keys mapped by every edit, in order)."""
        if not self.maps and self.segments is self.original.segments:
            return self.original

        def mapped(th):
            for fn in self.maps:
                th = fn(th)
            return th

        orient = self.original.tool_orientation
        return TaskPath(self.segments, orient if not self.maps else orient.remapped(mapped))


def _corner(path: TaskPath, index: int, kinds: tuple[str, ...], what: str,
            shared: tuple[bool, bool] = (False, False)) -> _Corner:
    if not isinstance(index, (int, np.integer)):
        raise PathError(f"{what}: corner must be a connection index (int), got {index!r}")
    conn = path.connection(int(index))
    if conn.kind not in kinds:
        raise PathError(f"{what}: {conn.describe()} is {conn.kind}; only {' or '.join(kinds)} connections "
                        "can be blended")
    A, B = path.segments[index], path.segments[index + 1]
    fa = _FULL * (defaults.SHARED_SEGMENT_FRACTION if shared[0] else 1.0)
    fb = _FULL * (defaults.SHARED_SEGMENT_FRACTION if shared[1] else 1.0)
    return _Corner(conn, A, B, fa * A.length, fb * B.length)


def _replace(path: TaskPath, corner: _Corner, a: float, b: float, blend: Segment | tuple[Segment, ...]) -> TaskPath:
    """``path`` with the last ``a`` of A and the first ``b`` of B replaced by ``blend`` (one segment,
    or a tuple of consecutive ones); ``a`` = A's length replaces all of A (a departure), likewise B."""
    i, A, B = corner.conn.index, corner.A, corner.B
    t0, t1 = corner.conn.theta - a, corner.conn.theta + b
    pieces = tuple(blend) if isinstance(blend, tuple) else (blend,)
    new_len = sum(seg.length for seg in pieces)

    def theta_map(th):
        th = np.asarray(th, float)
        return np.where(th <= t0, th, np.where(th >= t1, th + new_len - (t1 - t0),
                                               t0 + (th - t0) * new_len / (t1 - t0)))

    head = (A.trimmed(0.0, A.length - a),) if a < A.length else ()  # a departure replaces all of A
    tail = (B.trimmed(b, B.length),) if b < B.length else ()
    segs = path.segments[:i] + head + pieces + tail + path.segments[i + 2:]
    return path.with_segments(segs, theta_map)


def _plane_normal(corner: _Corner, what: str) -> np.ndarray:
    """Unit normal m of the corner's plane (the turn is right-handed about m); PathError if the
    corner is not planar or reverses."""
    _, tA, _ = corner.A.end_frame
    _, tB, _ = corner.B.start_frame
    m = np.cross(tA, tB)
    if np.linalg.norm(m) < REVERSAL_SINE:
        raise PathError(f"{what}: at {corner.where()} the path reverses direction; no circle can round it "
                        "(insert a short segment or stop there)")
    m = m / np.linalg.norm(m)
    for name, seg in (("incoming", corner.A), ("outgoing", corner.B)):
        n = seg.plane_normal
        tilt = float(np.linalg.norm(np.cross(n, m))) if n is not None else 0.0
        if tilt > defaults.PLANARITY_TOLERANCE:
            apart = np.degrees(np.arcsin(min(tilt, 1.0)))
            raise PathError(f"{what}: at {corner.where()} the {name} segment ({seg.describe()}) is not in the "
                            f"corner's plane (normal {_fmt(m)}; the planes are {apart:.3g} deg apart, sine {tilt:.3g} "
                            f"> {defaults.PLANARITY_TOLERANCE:g}); a transition circle needs a planar corner: make the "
                            "points coplanar, or use a G2 blend (with_g2_blend; type = \"g2\" in a scenario), which "
                            "works in 3-D")
    return m


def _fillet(corner: _Corner, m: np.ndarray, radius: float) -> tuple[float, float, Arc] | None:
    """Cut lengths (a, b) and the tangent arc of ``radius``, or None if it does not fit."""
    A, B = corner.A, corner.B
    LA = A.length
    a = b = radius * np.tan(0.5 * corner.conn.angle)
    for _ in range(60):
        pA, tA, kA = (x[0] for x in A.evaluate(LA - a))
        pB, tB, kB = (x[0] for x in B.evaluate(b))
        F = pA + radius * np.cross(m, tA) - pB - radius * np.cross(m, tB)
        # converged to rounding: F is a difference of positions of size |pA|
        if np.linalg.norm(F) < FILLET_ROUNDING * max(1.0, float(np.linalg.norm(pA))):
            break
        J = np.column_stack([-(tA + radius * np.cross(m, kA)), tB + radius * np.cross(m, kB)])
        step = np.linalg.lstsq(J, -F, rcond=None)[0]
        a, b = a + step[0], b - step[1]
        if not (np.isfinite(a) and np.isfinite(b)) or a < 0 or b < 0 or a > LA or b > B.length:
            return None
    else:
        return None
    if not (0.0 < a <= corner.max_a and 0.0 < b <= corner.max_b):
        return None
    sweep = float(np.arctan2(np.cross(tA, tB) @ m, tA @ tB))
    if sweep <= 0.0:
        return None
    arc = Arc(pA + radius * np.cross(m, tA), pA, m, sweep)
    if np.linalg.norm(arc.end_point - pB) > FILLET_CLOSURE * max(1.0, radius):
        return None
    return float(a), float(b), arc


def _down(x: float, digits: int = 6) -> str:
    """``x`` > 0 rounded DOWN to ``digits`` significant digits, so a value quoted as "the largest
    that fits" does fit when the user copies it."""
    if x <= 0.0:
        return f"{x:.{digits}g}"
    scale = 10.0 ** (digits - 1 - int(np.floor(np.log10(x))))
    return f"{np.floor(x * scale * (1 - ROUND_DOWN_GUARD)) / scale:.{digits}g}"


def _largest(ok, start: float, bisections: int = 50) -> float:
    """Largest x > 0 with ok(x), assuming ok holds below some threshold; 0.0 if ok(start) fails
    and ok(start * 2**-40) fails too."""
    lo, hi = 0.0, start
    while not ok(hi):
        hi *= 0.5
        if hi < start * 2.0 ** -40:
            return 0.0
    lo, hi = hi, 2.0 * hi
    for _ in range(200):
        if not ok(hi):
            break
        lo, hi = hi, 2.0 * hi
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _largest_between(ok, lo: float, hi: float, scan: int = 24, bisections: int = 36) -> float:
    """Largest x in (lo, hi) with ok(x), where ok may fail near lo too (a racing blend's outer corner
    can be out of tolerance while its corner quintic is small): the largest ok point of a geometric
    scan from hi down towards lo, refined by bisection against the next scan point; lo if none."""
    if lo <= 0.0:
        return _largest(ok, hi, bisections)
    xs = lo + (hi - lo) * np.geomspace(1.0, 1e-6, scan)
    for k, x in enumerate(xs[1:], start=1):
        if ok(x):
            good, bad = x, xs[k - 1]
            for _ in range(bisections):
                mid = 0.5 * (good + bad)
                good, bad = (mid, bad) if ok(mid) else (good, mid)
            return float(good)
    return lo


def _transition_radius_limit(corner: _Corner, m: np.ndarray) -> float:
    return _largest(lambda r: _fillet(corner, m, r) is not None, min(corner.max_a, corner.max_b))


def largest_transition_radius(path: TaskPath, corner: int) -> float:
    """Largest transition-circle radius [m] that fits at connection ``corner`` (a sharp corner)."""
    c = _corner(path, corner, ("corner",), "largest_transition_radius")
    return _transition_radius_limit(c, _plane_normal(c, "largest_transition_radius"))


def _with_transition(path: TaskPath, c: _Corner, radius: float) -> TaskPath:
    what = "with_transition"
    r = float(radius) if np.isscalar(radius) else np.nan
    if not np.isfinite(r) or r <= 0:
        raise PathError(f"{what}: transition radius must be a positive number [m], got {radius!r}")
    m = _plane_normal(c, what)
    fit = _fillet(c, m, r)
    if fit is None:
        r_max = _transition_radius_limit(c, m)
        raise PathError(f"{what}: a transition circle of radius {r:.6g} m does not fit at {c.where()}: it would "
                        f"need more than the neighbouring segments allow (cuts <= {c.max_a:.6g} m and "
                        f"{c.max_b:.6g} m); the largest radius that fits is {_down(r_max)} m")
    a, b, arc = fit
    return _replace(path, c, a, b, arc)


def blended_corners(path: TaskPath, where: str, closing: bool = False) -> list[int]:
    """The connection indices of ``path``'s sharp corners a blend can round: every corner but a reversal
    (Connection.reverses; the motion stops there), the closing one too (index len(path.connections)) if
    ``closing`` and the path is closed. A reversal left sharp is logged as a warning prefixed with ``where``."""
    conns = list(path.connections) + ([path.closure] if closing and path.closure is not None else [])
    sharp = [c for c in conns if c.kind == "corner"]
    turned = [c for c in sharp if c.reverses]
    if turned:
        log.warning("%s: the path turns back at %s; no blend can round %s, so %s sharp and the motion stops there",
                    where, "; ".join(c.describe() for c in turned), "it" if len(turned) == 1 else "them",
                    "it stays" if len(turned) == 1 else "they stay")
    return [c.index for c in sharp if not c.reverses]


def _selected(path: TaskPath, corners: Iterable[int] | None, kinds: tuple[str, ...]) -> list[int]:
    if corners is None:
        return [c.index for c in path.connections if c.kind in kinds]
    return sorted({int(k) for k in corners})


def _apply_all(path: TaskPath, corners: list[int], kinds: tuple[str, ...], what: str, one) -> TaskPath:
    """Apply ``one(path, corner)`` at each of ``corners`` from the last to the first (so earlier
    indices stay valid); a segment blended at both ends gives each blend at most
    SHARED_SEGMENT_FRACTION of its length."""
    chosen = set(corners)
    out = _Draft(path)
    for k in sorted(chosen, reverse=True):
        c = _corner(path, k, kinds, what, shared=(k - 1 in chosen, k + 1 in chosen))
        c = _Corner(out.connection(k), out.segments[k], out.segments[k + 1], c.max_a, c.max_b)
        out = one(out, c)
    return out.path()


def with_transition(path: TaskPath, corner: int, radius: float) -> TaskPath:
    """``path`` with the sharp corner at connection ``corner`` replaced by a circular arc of
    ``radius`` [m] tangent to both neighbours (planar line/arc corners).

    PathError if the corner is not sharp, not planar, or the circle does not fit (the message gives
    the largest radius that does)."""
    return _with_transition(path, _corner(path, corner, ("corner",), "with_transition"), radius)


def with_transitions(path: TaskPath, radius: float, corners: Iterable[int] | None = None) -> TaskPath:
    """:func:`with_transition` at every sharp corner (or at the connection indices ``corners``)."""
    sel = _selected(path, corners, ("corner",))
    return _apply_all(path, sel, ("corner",), "with_transitions", lambda p, c: _with_transition(p, c, radius))


# --- G2 blend ---------------------------------------------------------------------------------
def g2_control_points(A: Segment, B: Segment, cut: float, shape: float = defaults.G2_BLEND_SHAPE) -> np.ndarray:
    """Control points (6, 3) [m] of the quintic G2 blend that cuts ``cut`` [m] from the end of A and
    the start of B (see the module docstring)."""
    start, end = (tuple(x[0] for x in A.evaluate(A.length - cut)), tuple(x[0] for x in B.evaluate(cut)))
    return _hermite_points(start, end, 2.5 * shape * cut, 2.5 * shape * cut)


def g2_deviation(A: Segment, B: Segment, cut: float, shape: float = defaults.G2_BLEND_SHAPE,
                 stop_above: float = np.inf, stop_below: float = -np.inf) -> Deviation:
    """Certified largest distance [m] of the G2 blend with ``cut`` from the original segments A, B
    (``lower``/``upper`` bracket; ``theta`` holds the Bezier parameter u of the maximum; ``stop_above``,
    ``stop_below``: see certified_max)."""
    return _shaped_deviation(A, B, g2_control_points(A, B, cut, shape), stop_above, stop_below)


def _check_shape(shape: float, what: str) -> float:
    s = float(shape)
    if not (np.isfinite(s) and 0.0 < s <= 1.0):
        raise PathError(f"{what}: shape must be in (0, 1], got {shape!r}")
    return s


def _g2_cut(A: Segment, B: Segment, tol: float, shape: float, cut_max: float) -> float:
    """The largest cut [m] (to ~1e-11 relative, searched down from ``cut_max``) whose G2 blend's certified
    deviation is <= ``tol`` [m]; 0.0 if none. Two lines: the same search compiled in one call."""
    if isinstance(A, Line) and isinstance(B, Line):
        return g2_lines_cut((A, B), shape, tol, cut_max, bisections=36)

    def ok(cut):
        return g2_deviation(A, B, cut, shape, stop_above=tol, stop_below=tol).upper <= tol

    return _largest(ok, cut_max, bisections=36)


def _with_g2_blend(path: TaskPath, c: _Corner, tolerance: float, shape: float) -> TaskPath:
    what = "with_g2_blend"
    tol = float(tolerance) if np.isscalar(tolerance) else np.nan
    if not np.isfinite(tol) or tol <= 0:
        raise PathError(f"{what}: tolerance must be a positive distance [m], got {tolerance!r}")
    shape = _check_shape(shape, what)
    if c.conn.reverses:
        raise PathError(f"{what}: at {c.where()} the path reverses direction; no blend can round it (insert a short "
                        "sideways segment, or leave the corner sharp: the motion stops there)")
    cut_max = min(c.max_a, c.max_b)
    # the bound refined only until it is known on which side of tol it lies (the same answer as the converged
    # bound's), converged for the message only
    if g2_deviation(c.A, c.B, cut_max, shape, stop_above=tol, stop_below=tol).upper <= tol:
        full = g2_deviation(c.A, c.B, cut_max, shape)
        raise PathError(f"{what}: tolerance {tol:.6g} m is too large at {c.where()}: even the largest G2 blend the "
                        f"neighbouring segments allow (cutting {cut_max:.6g} m from each) deviates only "
                        f"{full.upper:.6g} m; give a tolerance below {_down(full.upper)} m")

    cut = _g2_cut(c.A, c.B, tol, shape, cut_max)
    if cut <= 0.0:
        raise PathError(f"{what}: no G2 blend within {tol:.6g} m found at {c.where()}; give a larger tolerance")
    return _replace(path, c, cut, cut, BezierSegment(g2_control_points(c.A, c.B, cut, shape)))


def with_g2_blend(path: TaskPath, corner: int, tolerance: float,
                  shape: float = defaults.G2_BLEND_SHAPE) -> TaskPath:
    """``path`` with connection ``corner`` (a sharp corner, or a tangent joint with a curvature
    jump) replaced by the largest quintic G2 blend whose distance from the original path is at most
    ``tolerance`` [m] (guaranteed; see the module docstring). Works in 3-D.

    PathError if the tolerance cannot be used up because the neighbours are too short (the message
    gives the largest tolerance that fits)."""
    kinds = ("corner", "tangent")
    return _with_g2_blend(path, _corner(path, corner, kinds, "with_g2_blend"), tolerance, shape)


def with_g2_blends(path: TaskPath, tolerance: float, corners: Iterable[int] | None = None,
                   shape: float = defaults.G2_BLEND_SHAPE) -> TaskPath:
    """:func:`with_g2_blend` at every sharp corner (or at the connection indices ``corners``, which
    may also name tangent joints)."""
    kinds = ("corner",) if corners is None else ("corner", "tangent")
    sel = _selected(path, corners, kinds)
    return _apply_all(path, sel, kinds, "with_g2_blends", lambda p, c: _with_g2_blend(p, c, tolerance, shape))


def with_blends(path: TaskPath, blends: Mapping[int, tuple[str, float]],
                names: Mapping[int, str] | None = None) -> TaskPath:
    """Mixed blends in one pass: ``blends`` maps a connection index to ("circle", radius [m]),
    ("g2", tolerance [m]) or ("g2_shape", G2Shape) (an asymmetric blend found for this path with
    the same shared flags, e.g. by planning/blend_search.py); the shared-segment rule of :func:`with_transitions` holds across kinds (a
    segment blended at both ends gives each blend at most SHARED_SEGMENT_FRACTION of its length).
    A PathError is prefixed with ``names[index]`` (e.g. the scenario key) when given."""
    chosen = set(blends)
    out = _Draft(path)
    for k in sorted(chosen, reverse=True):
        kind, value = blends[k]
        try:
            if kind not in ("circle", "g2", "g2_shape"):
                raise PathError(f"with_blends: blend type {kind!r} at connection {k}; give 'circle', 'g2' or "
                                "'g2_shape'")
            if kind == "g2_shape":
                out = with_shaped_g2_blend(out, k, value)
                continue
            kinds = ("corner",) if kind == "circle" else ("corner", "tangent")
            c = _corner(path, k, kinds, "with_blends", shared=(k - 1 in chosen, k + 1 in chosen))
            c = _Corner(out.connection(k), out.segments[k], out.segments[k + 1], c.max_a, c.max_b)
            out = (_with_transition(out, c, value) if kind == "circle"
                   else _with_g2_blend(out, c, value, defaults.G2_BLEND_SHAPE))
        except PathError as exc:
            if names is None or k not in names:
                raise
            raise exc.in_context(names[k]) from exc
    return out.path()


def largest_g2_tolerance(path: TaskPath, corner: int, shape: float = defaults.G2_BLEND_SHAPE) -> float:
    """Certified deviation [m] of the largest G2 blend the neighbours of ``corner`` allow: tolerances
    below this fit."""
    c = _corner(path, corner, ("corner", "tangent"), "largest_g2_tolerance")
    return g2_deviation(c.A, c.B, min(c.max_a, c.max_b), _check_shape(shape, "largest_g2_tolerance")).upper


# --- asymmetric (shaped) G2 blend, and its racing-line form --------------------------------------
@dataclass(frozen=True)
class G2Shape:
    """An asymmetric G2 blend: it replaces the last ``entry`` [m] of A and the first ``exit`` [m] of
    B; ``shape_entry``, ``shape_exit`` in (0, 1] are the end-speed shapes of its corner quintic
    (lambda = 5/2 shape cut on each side; the symmetric blend has entry = exit and one shape);
    ``deviation``: its certified deviation bound [m], nan where it was not bounded (:func:`g2_shape_for_tolerance`
    with ``certify=False``: the blend search's candidates). Two shapes are equal when their geometry is (the
    deviation, a function of it at a given corner, is not compared).

    With every offset, slope and bend 0 it is one quintic. Otherwise (two lines only) it is the
    racing line: on each side an *offset piece* over ``run_entry`` [m] of A, a quintic whose lateral
    offset w(s) OUTSIDE the turn rises from the line (w = w' = w'' = 0) to ``offset_entry`` [m] with
    slope ``slope_entry`` (dw/dd [-], d the distance from the corner: > 0 means the offset falls
    towards the corner, the path already turning in) and ``bend_entry`` (d2w/dd2 [1/m]); the corner
    quintic from its end to the exit piece's start (matching position, tangent and curvature vector
    there); the exit piece back onto B (``offset_exit``, ``slope_exit``, ``bend_exit``,
    ``run_exit``). With slope = bend = 0 an offset piece is the S-curve to the parallel line A'
    ``offset`` outside. Every join is G2, and the corner quintic may be larger for the same
    deviation (see :func:`g2_blend_pieces`).

    ``rise_entry`` / ``rise_exit`` = (rise [m], rise slope [-], rise bend [1/m]): the same profile
    out of the corner's plane, along its normal m = t_A x t_B / |t_A x t_B| (up at a left turn in a
    horizontal plane), so an offset piece may leave the plane (the free-shape optimum does: at
    120 deg / 10 mm it rises to the tube's edge before the corner, instead of moving out, and sinks
    below the plane after it; `benchmarks/replan_optimum.py 120 0.01 --profile` prints its profile).

    ``departure`` (entry side) / ``arrival`` (exit side): None, or the offset piece runs over all of A
    from its start (to the end of B) and leaves (reaches) that point off the line: (lateral c1, lateral
    c2, normal c1, normal c2) [m], the piece's Bernstein coefficients next to that end (next to it
    first; its own coefficient there is 0: the path still starts and ends at the given points). Only
    where the motion rests (a path's start or end at zero speed): a tangent or curvature that jumps
    there costs nothing, and the optimum leaves the start at an angle (60 deg / 10 mm: 2.8 % faster)."""

    entry: float
    exit: float
    shape_entry: float
    shape_exit: float
    deviation: float = field(compare=False)
    offset_entry: float = 0.0
    offset_exit: float = 0.0
    run_entry: float = 0.0
    run_exit: float = 0.0
    slope_entry: float = 0.0
    slope_exit: float = 0.0
    bend_entry: float = 0.0
    bend_exit: float = 0.0
    rise_entry: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rise_exit: tuple[float, float, float] = (0.0, 0.0, 0.0)
    departure: tuple[float, float, float, float] | None = None
    arrival: tuple[float, float, float, float] | None = None

    @property
    def sides(self) -> tuple[bool, bool]:
        """Whether the entry / exit side has an offset piece."""
        return (_has_piece(self.offset_entry, self.slope_entry, self.bend_entry, *self.rise_entry),
                _has_piece(self.offset_exit, self.slope_exit, self.bend_exit, *self.rise_exit))

    @property
    def planar(self) -> bool:
        """The blend stays in the corner's plane (no rise on either side, nor at a free end)."""
        return (not any(self.rise_entry) and not any(self.rise_exit)
                and not any(v for free in (self.departure, self.arrival) if free is not None for v in free[2:]))

    @property
    def racing(self) -> bool:
        """The blend leaves the lines first (an offset piece before or after the corner quintic)."""
        return any(self.sides)


def _has_piece(*profile: float) -> bool:
    """An offset piece is needed when any of its offsets, slopes and bends is nonzero."""
    return any(v != 0.0 for v in profile)


def g2_shaped_control_points(A: Segment, B: Segment, entry: float, exit: float, shape_entry: float,
                             shape_exit: float) -> np.ndarray:
    """Control points (6, 3) [m] of the quintic G2 blend cutting ``entry`` from the end of A and
    ``exit`` from the start of B, with end speeds 5/2 shape cut on each side (module docstring; with
    entry = exit and one shape this is :func:`g2_control_points`)."""
    pA, tA, kA = (x[0] for x in A.evaluate(A.length - entry))
    pB, tB, kB = (x[0] for x in B.evaluate(exit))
    return _hermite_points((pA, tA, kA), (pB, tB, kB), 2.5 * shape_entry * entry, 2.5 * shape_exit * exit)


def _hermite_points(start: tuple, end: tuple, la: float, lb: float) -> np.ndarray:
    """Control points (6, 3) [m] of the quintic from the state ``start`` = (p, unit tangent,
    curvature vector) to ``end`` with end speeds ``la``, ``lb`` [m] and zero tangential acceleration:
    X'(0) = la t, X''(0) = la^2 k (so its curvature vector there is k), likewise at u = 1."""
    (pA, tA, kA), (pB, tB, kB) = start, end
    return np.array([pA, pA + la / 5 * tA, pA + 2 * la / 5 * tA + la ** 2 / 20 * kA,
                     pB - 2 * lb / 5 * tB + lb ** 2 / 20 * kB, pB - lb / 5 * tB, pB])


@dataclass(frozen=True)
class _Racing:
    """The offset lines of a racing blend at a line-line corner: A' = A moved ``w_a`` outward and
    ``v_a`` along the corner's normal ``up``, B' likewise; A' ends and B' starts at their closest
    points (their corner when they meet; different rises make them skew), ``shift_a`` [m] along t_A
    from A's end point (projected) and ``shift_b`` along t_B from B's start; ``A``, ``B``: A' and B'
    as Lines."""

    A: Line
    B: Line
    out_a: np.ndarray
    out_b: np.ndarray
    shift_a: float
    shift_b: float
    up: np.ndarray


def _racing_lines(A: Segment, B: Segment, w_a: float, w_b: float, what: str, v_a: float = 0.0,
                  v_b: float = 0.0) -> _Racing:
    if not (isinstance(A, Line) and isinstance(B, Line)):
        raise PathError(f"{what}: a racing blend (offset > 0) needs two line neighbours, got {A.kind} and {B.kind}; "
                        "give offsets 0 there")
    racing = _offset_lines(A, B, w_a, w_b, v_a, v_b)
    if racing is None:
        raise PathError(f"{what}: a racing blend needs a corner that turns (the lines are parallel)")
    return racing


@lru_cache(maxsize=16)  # a sizing builds ~20 blends with the same offset lines; the path of its shape builds them again
def _offset_lines(A: Line, B: Line, w_a: float, w_b: float, v_a: float, v_b: float) -> _Racing | None:
    """_racing_lines' answer, None where the lines are parallel (cached whichever caller asks: ``what`` only names
    it in the errors)."""
    c, tA, tB = A.end, A.direction, B.direction
    m = cross3(tA, tB)  # np.cross's floats (chain.cross3)
    if np.linalg.norm(m) < REVERSAL_SINE:
        return None
    m = m / np.linalg.norm(m)
    out_a, out_b = -cross3(m, tA), -cross3(m, tB)  # outside the turn
    # c + w_a out_a + v_a m + s tA = c + w_b out_b + v_b m + t tB (least squares: closest points when skew)
    s, t = np.linalg.lstsq(np.column_stack([tA, -tB]), w_b * out_b - w_a * out_a + (v_b - v_a) * m, rcond=None)[0]
    ca, cb = c + w_a * out_a + v_a * m + s * tA, c + w_b * out_b + v_b * m + t * tB
    reach = 2.0 * (A.length + B.length)  # longer than any cut, so evaluating A', B' never clamps
    return _Racing(Line(ca - reach * tA, ca), Line(cb, cb + reach * tB), out_a, out_b, float(s), float(-t), m)


def _piece_offsets(offset: float, slope: float, bend: float, run: float, towards_corner: bool) -> np.ndarray:
    """Bernstein coefficients (6,) [m] of an offset piece's lateral offset w(u) over ``run`` [m]: on
    the line (w = w' = w'' = 0) at its far end, ``offset`` with dw/dd = ``slope`` and d2w/dd2 =
    ``bend`` [1/m] at its corner end (d: distance from the corner); ``towards_corner``: the piece
    ends at the corner (entry side), else it starts there (exit side)."""
    near = offset + slope * run / 5.0  # w'(u) at the corner end is -slope run (entry), slope run (exit)
    third = 2.0 * near - offset + bend * run ** 2 / 20.0
    w = np.array([offset, near, third, 0.0, 0.0, 0.0])
    return w[::-1].copy() if towards_corner else w


def _graph_frame(t: np.ndarray, out: np.ndarray, dw: float, bend: float, up: np.ndarray, dv: float = 0.0,
                 rise_bend: float = 0.0) -> tuple:
    """(unit tangent, curvature vector) of the graph x(s) = line(s) + w(s) out + v(s) up where w' = ``dw``,
    w'' = ``bend`` [1/m], v' = ``dv``, v'' = ``rise_bend`` [1/m] (the same at every point of the line)."""
    d = t + dw * out + dv * up
    speed2 = float(d @ d)
    T = d / np.sqrt(speed2)
    acc = bend * out + rise_bend * up
    return T, (acc - (acc @ T) * T) / speed2


class _BlendPieces:
    """g2_blend_pieces at one corner for every size of its corner quintic: what does not depend on the
    inner cuts (the offset lines, the joins' tangents and curvatures, the offset pieces' profiles) is
    computed once, so the sizing's ~40 builds per shape cost only the cut-dependent operations (the same
    operations, in the same order, as building each from scratch: the same floats)."""

    def __init__(self, A: Segment, B: Segment, shape_entry: float, shape_exit: float, offsets, runs, what: str,
                 slopes, bends, rises, departure=None, arrival=None):
        self.A, self.B, self.shapes, self.what = A, B, (shape_entry, shape_exit), what
        self.has = (_has_piece(offsets[0], slopes[0], bends[0], *rises[0]),
                    _has_piece(offsets[1], slopes[1], bends[1], *rises[1]))
        if not any(self.has):
            return
        self.free = (departure, arrival)
        self.runs, self.offsets, self.slopes, self.bends, self.rises = runs, offsets, slopes, bends, rises
        r = self.r = _racing_lines(A, B, offsets[0], offsets[1], what, rises[0][0], rises[1][0])
        tA, tB = A.direction, B.direction
        self.start_frame = _graph_frame(tA, r.out_a, -slopes[0], bends[0], r.up, -rises[0][1], rises[0][2])
        self.end_frame = _graph_frame(tB, r.out_b, slopes[1], bends[1], r.up, rises[1][1], rises[1][2])
        # per side: the products that place its piece's start and build its points, when its run is fixed
        self.fixed = [self._side(side, runs[side]) if self.has[side] and self.free[side] is None else None
                      for side in (0, 1)]

    def _side(self, side: int, run: float) -> tuple:
        """(the products subtracted from the join point, in order; the terms added to the piece's start, in
        order) for ``side``'s offset piece of ``run`` [m]."""
        r, entry = self.r, side == 0
        t, out = (self.A.direction, r.out_a) if entry else (self.B.direction, r.out_b)
        w = _piece_offsets(self.offsets[side], self.slopes[side], self.bends[side], run, towards_corner=entry)
        v = _piece_offsets(*self.rises[side], run, towards_corner=entry)
        free = self.free[side]
        if free is not None:  # the coefficients next to A's start (index 0 stays 0), or B's end first
            if entry:
                w[1:3], v[1:3] = free[:2], free[2:]
            else:
                w[4:2:-1], v[4:2:-1] = free[:2], free[2:]
        back = ((run * t,) if entry else ()) + (self.offsets[side] * out, self.rises[side][0] * r.up)
        return back, ((_FIFTHS * run)[:, None] * t, w[:, None] * out, v[:, None] * r.up)

    def __call__(self, inner_entry: float, inner_exit: float):
        """(control points of each piece, (6, 3) [m] each, in path order; entry, exit [m]): see g2_blend_pieces."""
        if not any(self.has):
            return ((g2_shaped_control_points(self.A, self.B, inner_entry, inner_exit, *self.shapes),), inner_entry,
                    inner_exit)
        r, A, B = self.r, self.A, self.B
        pA, pB = r.A.point(r.A.length - inner_entry), r.B.point(inner_exit)
        corner = _hermite_points((pA, *self.start_frame), (pB, *self.end_frame), 2.5 * self.shapes[0] * inner_entry,
                                 2.5 * self.shapes[1] * inner_exit)
        pieces, entry, exit = [corner], inner_entry - r.shift_a, inner_exit - r.shift_b
        runs = (float((pA - A.start) @ A.direction) if self.free[0] is not None else self.runs[0],
                float((B.end - pB) @ B.direction) if self.free[1] is not None else self.runs[1])
        for side in (0, 1):
            if self.free[side] is not None and not (self.has[side] and runs[side] > 0.0):
                raise PathError(f"{self.what}: a {('departure', 'arrival')[side]} needs an offset piece on that side "
                                f"and room for it (run {runs[side]:.6g} m); give an offset or rise there, or a smaller "
                                "blend")
        for side, join in ((0, pA), (1, pB)):
            if not self.has[side]:
                continue
            back, terms = self.fixed[side] or self._side(side, runs[side])
            x = join
            for term in back:  # the piece's start: the join moved back along the line, in, and down
                x = x - term
            for term in terms:  # start + u run t + w(u) out + v(u) up
                x = x + term
            if side == 0:
                pieces.insert(0, x)
                entry += runs[0]
            else:
                pieces.append(x)
                exit += runs[1]
        return tuple(pieces), float(entry), float(exit)


def g2_blend_pieces(A: Segment, B: Segment, inner_entry: float, inner_exit: float, shape_entry: float,
                    shape_exit: float, offsets: tuple[float, float] = (0.0, 0.0),
                    runs: tuple[float, float] = (0.0, 0.0), what: str = "g2_blend_pieces",
                    slopes: tuple[float, float] = (0.0, 0.0), bends: tuple[float, float] = (0.0, 0.0),
                    rises: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), departure=None, arrival=None):
    """(control points of each quintic piece, (6, 3) [m] each, in path order; entry, exit [m]): the
    blend's pieces and its total cuts on A and B. Without offsets, slopes and bends, one quintic
    cutting ``inner_entry`` / ``inner_exit``. Otherwise (two lines only; see G2Shape) the corner
    quintic runs from the point ``inner_entry`` before the corner of the offset lines A', B' (A, B
    moved ``offsets`` (w_A, w_B) [m] outside) to the point ``inner_exit`` after it, matching the
    tangents and curvatures that ``slopes`` [-] and ``bends`` [1/m] give the offset pieces of
    ``runs`` (l_A, l_B) [m] there, which join A to it and it to B; ``rises``: per side (rise [m],
    slope [-], bend [1/m]) of the same profile along the corner's normal; a side whose profiles are
    all 0 has no offset piece. ``departure`` / ``arrival`` (see G2Shape): that side's piece runs from
    A's start (to B's end) instead of over its run, with those coefficients next to that end."""
    return _BlendPieces(A, B, shape_entry, shape_exit, offsets, runs, what, slopes, bends, rises, departure,
                        arrival)(inner_entry, inner_exit)


def _shaped_deviation(A: Segment, B: Segment, b: np.ndarray, stop_above: float = np.inf,
                      stop_below: float = -np.inf) -> Deviation:
    if isinstance(A, Line) and isinstance(B, Line):  # the same numbers, compiled (the search's inner loop)
        return bezier_lines_max(b, (A, B), stop_above=stop_above, stop_below=stop_below)
    coef = BezierSegment._power_basis(b)
    lip = 5.0 * float(np.max(np.linalg.norm(np.diff(b, axis=0), axis=1)))
    return certified_max(lambda u: distance_to_segments(BezierSegment._polyval(coef, u), (A, B)),
                         0.0, 1.0, lip, stop_above=stop_above, stop_below=stop_below)


def _pieces_deviation(A: Segment, B: Segment, pieces, stop_above: float = np.inf,
                      stop_below: float = -np.inf) -> float:
    """Certified upper bound [m] of the pieces' largest distance from A u B: the largest of each
    piece's certified bound (stops once one is above ``stop_above``; a piece's bound is refined only until
    it is at most ``stop_below``, see certified_max)."""
    if isinstance(A, Line) and isinstance(B, Line):  # the same float, in one compiled call
        return bezier_pieces_lines_max(pieces, (A, B), stop_above=stop_above, stop_below=stop_below)
    upper = 0.0
    for b in pieces:
        upper = max(upper, _shaped_deviation(A, B, b, stop_above=stop_above, stop_below=stop_below).upper)
        if upper > stop_above:
            break
    return upper


def _check_racing(offsets, runs, tol: float, what: str, slopes=(0.0, 0.0), bends=(0.0, 0.0),
                  rises=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))) -> tuple:
    """Validated (offsets, runs, slopes, bends, rises), each a pair (entry, exit) (a rise: (rise,
    slope, bend)); the run of a side without an offset piece is 0."""
    w, ell, sl, be = (tuple(float(v) for v in pair) for pair in (offsets, runs, slopes, bends))
    ri = tuple(tuple(float(v) for v in side) for side in rises)
    for i, side in enumerate(("entry", "exit")):
        if len(ri[i]) != 3 or not all(np.isfinite(ri[i])) or not abs(ri[i][0]) < tol:
            raise PathError(f"{what}: the {side} rise must be (rise in (-tolerance, tolerance) = (-{tol:.6g}, "
                            f"{tol:.6g}) m, slope, bend), finite numbers, got {rises[i]!r}")
        if not (np.isfinite(w[i]) and 0.0 <= w[i] < tol):
            raise PathError(f"{what}: the {side} offset must be in [0, tolerance = {tol:.6g} m), got {w[i]!r} m")
        if not (np.isfinite(sl[i]) and np.isfinite(be[i])):
            raise PathError(f"{what}: the {side} slope and bend must be finite numbers, got {sl[i]!r} and {be[i]!r}")
        if _has_piece(w[i], sl[i], be[i], *ri[i]) and not (np.isfinite(ell[i]) and ell[i] > 0.0):
            raise PathError(f"{what}: the {side} offset piece needs a positive run [m] with offset {w[i]:.6g} m "
                            f"and rise {ri[i][0]:.6g} m, got {ell[i]!r}; give a run > 0, or offset, rise, slopes "
                            "and bends 0 there")
    ell = tuple(ell[i] if _has_piece(w[i], sl[i], be[i], *ri[i]) else 0.0 for i in range(2))  # no piece, no run
    return w, ell, sl, be, ri


def _check_free_end(free, name: str, what: str):
    """``free`` (a departure or arrival: four finite coefficients [m]) as a tuple of floats, or None."""
    if free is None:
        return None
    try:
        out = tuple(float(v) for v in free)
    except (TypeError, ValueError):
        out = ()
    if len(out) != 4 or not all(np.isfinite(out)):
        raise PathError(f"{what}: the {name} must be four finite Bernstein coefficients [m] (lateral c1, c2, normal c1, "
                        f"c2), got {free!r}; give None to join the line G2")
    return out


def g2_shape_for_tolerance(path: TaskPath, corner: int, tolerance: float, balance: float, shape_entry: float,
                           shape_exit: float, shared: tuple[bool, bool] = (False, False),
                           offsets: tuple[float, float] = (0.0, 0.0), runs: tuple[float, float] = (0.0, 0.0),
                           slopes: tuple[float, float] = (0.0, 0.0),
                           bends: tuple[float, float] = (0.0, 0.0),
                           rises: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), departure=None,
                           arrival=None, certify: bool = True) -> G2Shape:
    """The largest asymmetric G2 blend at connection ``corner`` whose corner quintic has
    entry / (entry + exit) = ``balance`` in (0, 1) and whose certified deviation is <= ``tolerance``
    [m] (or, if even the largest the neighbours allow deviates less, that one). ``offsets`` (w_A,
    w_B) in [0, tolerance) [m], ``runs`` (l_A, l_B) [m], ``slopes`` [-] and ``bends`` [1/m]: the
    racing line of :class:`G2Shape` (its corner quintic is sized; the offset pieces are fixed).
    ``shared``: the neighbour before / after is blended at its other end too (then a blend may use
    SHARED_SEGMENT_FRACTION of it). ``rises``: per side (rise [m], slope [-], bend [1/m]) of the offset
    pieces along the corner's normal (see G2Shape). ``departure`` / ``arrival``: see G2Shape; the
    corner quintic is sized as for the blend joined to the line with that side's run, and the piece
    then runs on to the path's end (the shape's run is its full length). ``certify=False``: its ``deviation`` is nan
    instead of the blend's precise certified bound (the sizing alone already keeps it within ``tolerance``; at 0.1 mm
    the precise bound of a racing line costs about as much as a plan, so the blend search bounds only the shapes it
    returns: the same call with ``certify=True`` gives the same shape with its bound)."""
    what = "g2_shape_for_tolerance"
    departure, arrival = _check_free_end(departure, "departure", what), _check_free_end(arrival, "arrival", what)
    c = _corner(path, corner, ("corner", "tangent"), what, shared=shared)
    tol = float(tolerance)
    if not (np.isfinite(tol) and tol > 0):
        raise PathError(f"{what}: tolerance must be a positive distance [m], got {tolerance!r}")
    if not 0.0 < balance < 1.0:
        raise PathError(f"{what}: balance (entry share of the blend) must be in (0, 1), got {balance!r}")
    sa, sb = _check_shape(shape_entry, what), _check_shape(shape_exit, what)
    offsets, runs, slopes, bends, rises = _check_racing(offsets, runs, tol, what, slopes, bends, rises)
    pieces_at = _BlendPieces(c.A, c.B, sa, sb, offsets, runs, what, slopes, bends, rises, departure, arrival)
    racing = any(pieces_at.has)

    def build(size):
        return pieces_at(balance * size, (1 - balance) * size)

    if not racing:
        if departure is not None or arrival is not None:
            raise PathError(f"{what}: a departure or arrival needs an offset piece on its side; give an offset or rise")
        size_min, size_max = 0.0, min(c.max_a / balance, c.max_b / (1 - balance))
    else:  # the total cuts are affine in the size: entry(size) = e0 + balance size, exit(size) = x0 + (1 - balance) size
        # (of the blend joined to both lines: its runs bound the corner quintic, and a free end's piece then
        # runs on from there to the path's end, at least as far as its run)
        joined = pieces_at if departure is None and arrival is None else _BlendPieces(
            c.A, c.B, sa, sb, offsets, runs, what, slopes, bends, rises)  # g2_blend_pieces without the free ends
        _, e0, x0 = joined(0.0, 0.0)
        size_min = max(0.0, -e0 / balance, -x0 / (1 - balance))  # both cuts > 0
        size_max = min((c.max_a - e0) / balance, (c.max_b - x0) / (1 - balance))
    if not size_max > size_min:
        raise PathError(f"{what}: the offset pieces ({runs[0]:.6g} m, {runs[1]:.6g} m) leave no room for a blend at "
                        f"{c.where()} (cuts <= {c.max_a:.6g} m and {c.max_b:.6g} m); give shorter runs")

    def ok(size):
        return _pieces_deviation(c.A, c.B, build(size)[0], stop_above=tol, stop_below=tol) <= tol

    compiled = _compiled_sizing(c, pieces_at, sa, sb)
    size = np.nan
    if compiled is not None:  # the same size, in one compiled call (geometry/blend_sizing.py)
        size = blend_sizing.largest_size(size_min, size_max, _SIZING_SCAN, _SIZING_BISECTIONS, tol, balance,
                                         *compiled)
    if np.isnan(size):  # in Python: no compiled sizing here, or a free end's piece with no room (its error)
        size = size_max if ok(size_max) else _largest_between(ok, size_min, size_max, _SIZING_SCAN.size,
                                                                _SIZING_BISECTIONS)
    if size <= size_min:
        raise PathError(f"{what}: no G2 blend within {tol:.6g} m found at {c.where()}; give a larger tolerance"
                        + (" or smaller offsets, slopes and bends" if racing else ""))
    pieces, entry, exit = build(size)
    if departure is not None or arrival is not None:  # a free end's run: its total cut less the corner quintic's
        r = pieces_at.r
        runs = (entry - balance * size + r.shift_a if departure is not None else runs[0],
                exit - (1 - balance) * size + r.shift_b if arrival is not None else runs[1])
    deviation = _pieces_deviation(c.A, c.B, pieces) if certify else float("nan")
    return G2Shape(entry, exit, sa, sb, deviation, *offsets, *runs, *slopes, *bends, *rises, departure, arrival)


#: The sizing's scan (_largest_between) and bisections.
_SIZING_SCAN = np.geomspace(1.0, 1e-6, 24)
_SIZING_BISECTIONS = 36


def _compiled_sizing(c: _Corner, pieces_at: _BlendPieces, sa: float, sb: float) -> tuple | None:
    """The arguments after ``balance`` of :func:`~pathmotion.geometry.blend_sizing.largest_size` for the blends
    ``pieces_at`` builds at the corner ``c`` between two lines (free ends included); None elsewhere (the sizing then
    runs in Python)."""
    if not (isinstance(c.A, Line) and isinstance(c.B, Line)):
        return None
    zero = np.zeros(3)
    frees, free, far_ends = np.zeros(2, np.bool_), np.zeros((2, 4)), np.zeros((2, 2, 3))
    profile, axes = np.zeros((2, 6)), np.zeros((2, 3, 3))
    if any(pieces_at.has):
        r = pieces_at.r
        ends, frames = (r.A, r.B), (pieces_at.start_frame, pieces_at.end_frame)
        for side, (line, far, out) in enumerate(((c.A, c.A.start, r.out_a), (c.B, c.B.end, r.out_b))):
            if pieces_at.free[side] is not None:
                frees[side], free[side], far_ends[side] = True, pieces_at.free[side], (far, line.direction)
                profile[side] = (pieces_at.offsets[side], pieces_at.slopes[side], pieces_at.bends[side],
                                 *pieces_at.rises[side])
                axes[side] = (line.direction, out, r.up)
    else:
        ends, frames = (c.A, c.B), ((c.A.direction, zero), (c.B.direction, zero))
    lines = np.array([[line.start, line.direction, (line.length, 0.0, 0.0)] for line in ends], float)
    backs, n_backs, terms = np.zeros((2, 3, 3)), np.zeros(2, np.int64), np.zeros((2, 3, 6, 3))
    for side in (0, 1):
        if pieces_at.has[side] and not frees[side]:
            back, term = pieces_at.fixed[side]
            backs[side, :len(back)], n_backs[side], terms[side] = back, len(back), term
    return (lines, np.array(frames, float), np.array([2.5 * sa, 2.5 * sb]), np.array(pieces_at.has), backs, n_backs,
            terms, 2.0, frees, free, far_ends, profile, axes, _POWER_SIGNED, _POWER_SCALE, *_line_arrays((c.A, c.B)),
            _samples(256), float(defaults.DEVIATION_RELATIVE_ACCURACY), 60, defaults.DEVIATION_MAX_INTERVALS,
            BOUND_ROUNDING)


def _shape_pieces(c: _Corner, shape: G2Shape, what: str):
    """The pieces of ``shape`` at corner ``c`` (its corner quintic's cuts recovered from the totals)."""
    offsets, runs = (shape.offset_entry, shape.offset_exit), (shape.run_entry, shape.run_exit)
    slopes, bends = (shape.slope_entry, shape.slope_exit), (shape.bend_entry, shape.bend_exit)
    if not shape.racing:
        return g2_blend_pieces(c.A, c.B, shape.entry, shape.exit, shape.shape_entry, shape.shape_exit)[0]
    r = _racing_lines(c.A, c.B, *offsets, what, shape.rise_entry[0], shape.rise_exit[0])
    has = shape.sides
    inner = (shape.entry - (runs[0] if has[0] else 0.0) + r.shift_a,
             shape.exit - (runs[1] if has[1] else 0.0) + r.shift_b)
    return g2_blend_pieces(c.A, c.B, *inner, shape.shape_entry, shape.shape_exit, offsets, runs, what, slopes,
                           bends, (shape.rise_entry, shape.rise_exit), shape.departure, shape.arrival)[0]


def with_shaped_g2_blend(path: TaskPath, corner: int, shape: G2Shape) -> TaskPath:
    """``path`` with connection ``corner`` replaced by the asymmetric G2 blend ``shape`` (one quintic,
    or the racing line's offset piece, corner quintic and offset piece)."""
    what = "with_shaped_g2_blend"
    c = _corner(path, corner, ("corner", "tangent"), what)
    ends = (shape.departure is not None, shape.arrival is not None)
    if (ends[0] and (corner != 0 or path.closed)) or (ends[1] and (corner != len(path.segments) - 2 or path.closed)):
        raise PathError(f"{what}: a departure (arrival) leaves the path's start (reaches its end) at {c.where()}, which "
                        "is not the first (last) corner of an open path; give departure / arrival None")
    fits = [0 < cut < seg.length or (free and abs(cut - seg.length) <= _END_ROUNDING * max(1.0, seg.length))
            for cut, seg, free in ((shape.entry, c.A, ends[0]), (shape.exit, c.B, ends[1]))]
    if not all(fits):
        raise PathError(f"{what}: cuts {shape.entry:.6g} m / {shape.exit:.6g} m do not fit at "
                        f"{c.where()} (neighbours {c.A.length:.6g} m and {c.B.length:.6g} m)")
    pieces = _shape_pieces(c, shape, what)
    cuts = (c.A.length if ends[0] else shape.entry, c.B.length if ends[1] else shape.exit)
    return _replace(path, c, *cuts, tuple(BezierSegment(b) for b in pieces))


def with_shaped_g2_blends(path: TaskPath, shapes: dict[int, G2Shape]) -> TaskPath:
    """``path`` with each connection k of ``shapes`` replaced by the blend shapes[k] (applied from the
    last to the first, so the indices stay valid; shapes computed on ``path`` with ``shared`` flags
    for neighbouring blended corners never overlap)."""
    out = _Draft(path)
    for k in sorted(shapes, reverse=True):
        out = with_shaped_g2_blend(out, k, shapes[k])
    return out.path()


__all__ = ["G2Shape", "blended_corners", "g2_blend_pieces", "g2_control_points", "g2_deviation", "g2_shape_for_tolerance", "g2_shaped_control_points",
           "largest_g2_tolerance", "largest_transition_radius", "with_g2_blend", "with_g2_blends",
           "with_shaped_g2_blend", "with_shaped_g2_blends", "with_transition", "with_transitions"]
