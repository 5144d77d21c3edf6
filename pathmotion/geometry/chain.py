"""TaskPath: segments joined end to end, with one path coordinate theta for the whole chain.

theta is the cumulative arc length [m] over the chain, domain (0, L). Segment k covers
[breaks_k, breaks_{k+1}]. At a break, ``side="right"`` evaluates the segment that starts there
and ``side="left"`` the one that ends there. Scalar theta gives un-batched results ((3,), (3, 3)),
an (N,) array gives (N, 3), (N, 3, 3), as :class:`pathmotion.lift.JointPath` does.

Connections are classified as

* ``"corner"``  -- the tangents differ by more than ``defaults.CORNER_ANGLE_TOLERANCE`` (sharp corner:
  p' jumps, so any motion must stop there),
* ``"tangent"`` -- G1: same tangent, but the curvature vector jumps by more than
  ``defaults.CURVATURE_JUMP_TOLERANCE`` (p'' and hence Phi'' jump),
* ``"smooth"``  -- G2: tangent and curvature vector continuous.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np

from .. import defaults
from ..errors import PathError
from .orientation import FixedOrientation, Orientation
from .segments import Segment, StackedSegments, _fmt

#: A path coordinate up to this times max(1, length) outside [0, length] is rounding, not an error [-].
THETA_ROUNDING = 1e-9

Side = Literal["right", "left"]
ConnectionKind = Literal["corner", "tangent", "smooth"]


@dataclass(frozen=True)
class Connection:
    """The joint between segment ``index`` and the next one (for the closing joint of a closed
    path: between the last segment and segment 0).

    theta [m]; kind "corner" | "tangent" | "smooth"; angle between the two tangents [rad];
    curvature_jump = |k_after - k_before| of the curvature vectors [1/m]; position (3,) [m].
    """

    index: int
    theta: float
    kind: ConnectionKind
    angle: float
    curvature_jump: float
    position: tuple[float, float, float]

    @property
    def reverses(self) -> bool:
        """The path turns back here (angle within ``defaults.CORNER_ANGLE_TOLERANCE`` of 180 deg): no blend can
        round it, so the motion stops."""
        return self.angle > np.pi - defaults.CORNER_ANGLE_TOLERANCE

    def describe(self) -> str:
        """'connection i (after segment i + 1) at theta = ...': the index as the Python API takes it (0-based), the
        segment as a scenario counts them (1-based; a scenario's ``corner = i + 1``)."""
        return (f"connection {self.index} (after segment {self.index + 1}) at theta = {self.theta:.6g} m, position "
                f"{_fmt(self.position)}, {self.kind} (angle {np.degrees(self.angle):.4g} deg)")


def cross3(a, b) -> np.ndarray:
    """np.cross of two 3-vectors ``a``, ``b`` (3,): its operations (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0), the
    same floats, without its per-call overhead (about 20 us; every blended path a search plans classifies its
    connections)."""
    a0, a1, a2 = (float(x) for x in a)
    b0, b1, b2 = (float(x) for x in b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def classify(before: Segment, after: Segment, index: int, theta: float) -> Connection:
    """Connection between the end of ``before`` and the start of ``after``."""
    p0, t0, k0 = before.end_frame
    _, t1, k1 = after.start_frame
    angle = float(np.arctan2(np.linalg.norm(cross3(t0, t1)), t0 @ t1))
    jump = float(np.linalg.norm(k1 - k0))
    if angle > defaults.CORNER_ANGLE_TOLERANCE:
        kind = "corner"
    elif jump > defaults.CURVATURE_JUMP_TOLERANCE:
        kind = "tangent"
    else:
        kind = "smooth"
    return Connection(index, float(theta), kind, angle, jump, tuple(float(x) for x in p0))


def segment_groups(k: np.ndarray):
    """(j, indices) for each distinct segment index j in ``k`` (N,) int, indices (into k) in their order: one sort,
    so evaluating N points on a path of S segments costs O(N log N), not O(N S)."""
    if k.size and np.all(k[1:] >= k[:-1]):  # sorted thetas (the usual case): contiguous runs
        order = np.arange(k.size)
        sk = k
    else:
        order = np.argsort(k, kind="stable")
        sk = k[order]
    starts = np.flatnonzero(np.concatenate([[True], sk[1:] != sk[:-1]])) if k.size else np.array([], int)
    ends = np.append(starts[1:], k.size)
    for a, b in zip(starts, ends):
        yield int(sk[a]), order[a:b]


@dataclass(frozen=True, eq=False)
class TaskPath:
    """A chain of segments (tuple of :class:`~pathmotion.geometry.segments.Segment`) and a tool
    orientation (:class:`FixedOrientation` by default, tool pointing down).

    Consecutive segments must meet within ``defaults.PATH_GAP_TOLERANCE``; key orientations must lie
    in the domain.
    """

    segments: tuple[Segment, ...]
    tool_orientation: Orientation = field(default_factory=FixedOrientation)
    offsets: np.ndarray = field(init=False, repr=False)
    connections: tuple[Connection, ...] = field(init=False)
    closure: Connection | None = field(init=False)

    def __post_init__(self):
        segs = tuple(self.segments)
        if not segs:
            raise PathError("TaskPath needs at least one segment")
        for k, seg in enumerate(segs):
            if not isinstance(seg, Segment):
                raise PathError(f"TaskPath: item {k} is a {type(seg).__name__}, not a path segment")
        for k in range(len(segs) - 1):
            gap = float(np.linalg.norm(segs[k + 1].start_point - segs[k].end_point))
            if gap > defaults.PATH_GAP_TOLERANCE:
                raise PathError(f"segments {k} ({segs[k].describe()}) and {k + 1} ({segs[k + 1].describe()}) do not "
                                f"meet: gap {gap:.3g} m > {defaults.PATH_GAP_TOLERANCE:g} m; make segment {k + 1} start "
                                f"where segment {k} ends, {_fmt(segs[k].end_point)}")
        offsets = np.concatenate([[0.0], np.cumsum([s.length for s in segs])])
        offsets.flags.writeable = False
        conns = tuple(classify(segs[k], segs[k + 1], k, offsets[k + 1]) for k in range(len(segs) - 1))
        closed = np.linalg.norm(segs[-1].end_point - segs[0].start_point) <= defaults.PATH_GAP_TOLERANCE
        closure = classify(segs[-1], segs[0], len(segs) - 1, offsets[-1]) if closed else None
        keys = np.asarray(self.tool_orientation.key_thetas())
        tol = THETA_ROUNDING * max(1.0, offsets[-1])
        if keys.size and (keys.min() < -tol or keys.max() > offsets[-1] + tol):
            raise PathError(f"key orientations at theta = {keys.tolist()} lie outside the path's range "
                            f"[0, {offsets[-1]:.6g}] m; put every key on the path")
        object.__setattr__(self, "segments", segs)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "connections", conns)
        object.__setattr__(self, "closure", closure)

    # --- scalar properties -----------------------------------------------------------------
    @property
    def length(self) -> float:
        """Total arc length L [m]."""
        return float(self.offsets[-1])

    @property
    def domain(self) -> tuple[float, float]:
        """(0, L) [m]."""
        return (0.0, self.length)

    @property
    def breaks(self) -> tuple[float, ...]:
        """theta [m] of every interior segment connection."""
        return tuple(float(x) for x in self.offsets[1:-1])

    @property
    def kinks(self) -> tuple[float, ...]:
        """theta [m] of the interior sharp corners (the closing joint is in :attr:`closure`)."""
        return tuple(c.theta for c in self.connections if c.kind == "corner")

    @property
    def curvature_peaks(self) -> tuple[float, ...]:
        """theta [m] of the curvature peaks inside the segments (Segment.curvature_peaks), in order."""
        return tuple(float(o) + s for seg, o in zip(self.segments, self.offsets) for s in seg.curvature_peaks)

    @property
    def closed(self) -> bool:
        """True if the end point is the start point (within the gap tolerance); :attr:`closure`
        then says whether the closing joint is a corner, tangent or smooth."""
        return self.closure is not None

    # --- evaluation -------------------------------------------------------------------------
    def _theta(self, theta) -> tuple[np.ndarray, bool]:
        th = np.asarray(theta, dtype=float)
        scalar = th.ndim == 0
        th = np.atleast_1d(th)
        if th.ndim != 1:
            raise PathError(f"theta must be a scalar or a 1-D array, got shape {th.shape}")
        if not np.all(np.isfinite(th)):
            raise PathError("theta contains NaN or inf; give finite path coordinates [m]")
        tol = THETA_ROUNDING * max(1.0, self.length)
        bad = (th < -tol) | (th > self.length + tol)
        if np.any(bad):
            raise PathError(f"theta = {th[bad][0]:.6g} m is outside the path's range [0, {self.length:.6g}] m")
        return np.clip(th, 0.0, self.length), scalar

    def _index(self, th: np.ndarray, side: str) -> np.ndarray:
        if side not in ("right", "left"):
            raise PathError(f"side must be 'right' or 'left', got {side!r}")
        k = np.searchsorted(self.offsets, th, side="right" if side == "right" else "left") - 1
        return np.clip(k, 0, len(self.segments) - 1)

    def segment_index(self, theta, side: Side = "right"):
        """Index of the segment evaluated at theta (int for a scalar, (N,) int array otherwise)."""
        th, scalar = self._theta(theta)
        k = self._index(th, side)
        return int(k[0]) if scalar else k

    def evaluate(self, theta, side: Side = "right") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p [m], dp/dtheta [-], d2p/dtheta2 [1/m]) at theta [m]; each (N, 3), or (3,) for a scalar."""
        th, scalar = self._theta(theta)
        k = self._index(th, side)
        out = np.empty((3, len(th), 3))
        s = th - self.offsets[k]
        rest = np.flatnonzero(~self._stacked.evaluate(s, k, out))  # lines and blends at once, the others here
        for j, m in segment_groups(k[rest]):
            out[:, rest[m]] = self.segments[j].evaluate(s[rest[m]])
        return tuple(o[0] for o in out) if scalar else tuple(out)

    @cached_property
    def _stacked(self) -> StackedSegments:
        return StackedSegments(self.segments)

    def orientation(self, theta, side: Side = "right") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R (N, 3, 3), w (N, 3) [rad/m], dw (N, 3) [rad/m^2]): tool rotation, its angular velocity
        per unit theta in world axes (dR/dtheta = [w]x R) and dw/dtheta. The orientation is C2 in
        theta, so ``side`` (checked, for symmetry with :meth:`evaluate`) gives the same values."""
        th, scalar = self._theta(theta)
        self._index(th, side)
        out = self.tool_orientation.evaluate(th)
        return tuple(o[0] for o in out) if scalar else out

    def pose(self, theta, side: Side = "right"):
        """(p, dp, ddp, R, w, dw) at theta; see :meth:`evaluate` and :meth:`orientation`."""
        return self.evaluate(theta, side) + self.orientation(theta, side)

    def evaluate3(self, theta, side: Side = "right") -> tuple[np.ndarray, ...]:
        """(p, dp, ddp, dddp) at theta: :meth:`evaluate` plus d3p/dtheta3 [1/m^2], each (N, 3) or (3,)."""
        th, scalar = self._theta(theta)
        k = self._index(th, side)
        out = np.empty((4, len(th), 3))
        for j, m in segment_groups(k):
            out[:, m] = self.segments[j].evaluate3(th[m] - self.offsets[j])
        return tuple(o[0] for o in out) if scalar else tuple(out)

    def pose3(self, theta, side: Side = "right"):
        """(p, dp, ddp, dddp, R, w, dw, ddw) at theta: :meth:`pose` plus the third derivatives
        d3p/dtheta3 [1/m^2] and d2w/dtheta2 [rad/m^3] (both exact, for jerk limits)."""
        th, scalar = self._theta(theta)
        self._index(th, side)
        rot = self.tool_orientation.evaluate3(th)
        if scalar:
            rot = tuple(o[0] for o in rot)
        return self.evaluate3(theta, side) + tuple(rot)

    def connection(self, index: int) -> Connection:
        """Connection ``index`` (between segments index and index + 1), or a PathError."""
        if not 0 <= index < len(self.connections):
            raise PathError(f"connection {index} does not exist: the path has {len(self.segments)} segments, "
                            f"so connections 0..{len(self.connections) - 1}")
        return self.connections[index]

    def with_segments(self, segments, theta_map=None) -> "TaskPath":
        """A new path with ``segments`` and the tool orientation keys mapped by ``theta_map``
        (an increasing function of old theta, for edits that change the length)."""
        orient = self.tool_orientation if theta_map is None else self.tool_orientation.remapped(theta_map)
        return TaskPath(tuple(segments), orient)

    def describe(self) -> str:
        lines = [f"TaskPath: {len(self.segments)} segments, length {self.length:.6g} m"
                 + (f", closed ({self.closure.kind})" if self.closed else "")]
        for k, seg in enumerate(self.segments):
            lines.append(f"  [{k}] theta {self.offsets[k]:.6g}..{self.offsets[k + 1]:.6g}: {seg.describe()}")
        lines += [f"  {c.describe()}" for c in self.connections]
        return "\n".join(lines)


def describe_point(task_path, theta: float, p) -> str:
    """'path point at theta = ... m (segment k), position (x, y, z) m' for error messages: theta [m], p (3,)
    [m] the TCP position there; the segment (1-based) only for paths that have segments."""
    seg = ""
    if hasattr(task_path, "segment_index"):
        seg = f" (segment {int(task_path.segment_index(theta)) + 1})"
    return f"path point at theta = {theta:.4f} m{seg}, position ({p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}) m"
