"""Lift a chain of task runs, joint moves and dwells to one :class:`~.joint_move.PiecewiseJointPath`.

Items, in order: :class:`TaskRun` (a TaskPath, lifted by :func:`~.constraint.lift` from the configuration the
chain has reached), :class:`JointMove` (linear in the joints to a configuration or to a pose solved by IK on
its robconf) and :class:`Dwell` (a wait at rest where the previous item ends). theta runs on across the items.

Connections: after a dwell, or where Phi' jumps (a joint move meets anything that does not continue its joint
velocity direction and rate), the motion stops (a kink). A zone (``zones``: item connection -> tolerance [m])
replaces a connection that involves a joint move by a :class:`~.joint_move.JointBlend` over
[theta_c - d_before, theta_c + d_after], d = the theta in which the TCP travels about the tolerance (at most
``ZONE_CUT`` of the piece it cuts), shrunk by halves until the blend's TCP stays within the tolerance of the sharp TCP path: the largest distance of
``ZONE_SAMPLES`` blend TCP samples from a polyline through 4 * ``ZONE_SAMPLES`` sharp TCP samples (to the chords
near each sample's theta), plus half the largest step between blend samples (a sampled bound, not a certified
one).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from .. import defaults
from ..errors import PathError, PathmotionError, UnreachableError
from ..geometry import FixedOrientation, TaskPath
from ..robot import Robot, fk, ik, jacobian
from ..robot.robconf import ik_robconf
from .constraint import PathCheck, lift
from .joint_move import (JointBlend, LinearJointPath, Piece, PiecewiseJointPath, check_joint_target, tcp_arc_length,
                         tcp_trace)

log = logging.getLogger(__name__)

#: Largest share of a piece a zone blend may cut (below half: two zones never meet) [-].
ZONE_CUT = 0.49
#: Halvings of a zone blend's size before its TCP deviation is accepted as not meeting the tolerance.
ZONE_SHRINKS = 30
#: Samples of a zone blend's TCP (the sharp TCP path it is measured against: 4 times as many), and the share of
#: the sharp polyline's chords on either side of a sample's own that its distance is taken to [-].
ZONE_SAMPLES = 100
ZONE_WINDOW = 0.25
#: A joint move whose TCP moves less than this [m] (a reorientation about the TCP) gets the theta length
#: ``REORIENT_LENGTH`` per radian of its largest joint motion [m/rad] instead of its TCP arc length.
STILL_TCP = 1e-6
REORIENT_LENGTH = 0.1
#: Phi' of two pieces that differ by less than this relative to their size is continuous (no stop) [-].
SAME_RATE = 1e-9
#: Largest joint difference [rad] between where a joint move ends and where the lift of the next task run starts.
SAME_CONFIGURATION = 1e-6


@dataclass(frozen=True)
class TaskRun:
    """path: the task segments (blends applied); original: before blends (or None); where: scenario keys."""

    path: TaskPath
    original: TaskPath | None
    where: str


@dataclass(frozen=True)
class JointMove:
    """end (n,) [rad], or pose = (position (3,) [m], rotation (3, 3), robconf (4,) or None: the IK branch
    nearest the move's start)."""

    end: np.ndarray | None
    pose: tuple | None
    where: str


@dataclass(frozen=True)
class Dwell:
    time: float
    where: str


def _joint_end(robot: Robot, item: JointMove, q0: np.ndarray) -> np.ndarray:
    if item.end is not None:
        return check_joint_target(robot, item.end, item.where)
    position, rotation, robconf = item.pose
    if robconf is not None:
        q = ik_robconf(robot, position, rotation, robconf, where=item.where)  # the quadrants fix the turns
    else:
        try:
            q = ik(robot, position, rotation, q0)
        except UnreachableError as exc:
            raise exc.in_context(item.where) from exc
    return check_joint_target(robot, q, item.where)


def _joint_piece(robot: Robot, item: JointMove, q0: np.ndarray, theta: float) -> Piece:
    q1 = _joint_end(robot, item, q0)
    span = float(np.max(np.abs(q1 - q0)))
    if span < SAME_CONFIGURATION:
        raise PathError(f"{item.where}: the joint move ends where it starts ({np.round(q1, 6).tolist()} rad); "
                        "remove it or give another end")
    length = tcp_arc_length(robot, q0, q1)
    if length < STILL_TCP:
        length = REORIENT_LENGTH * span
        log.info("%s: the TCP stays in place; theta length %.4g m (%g m per rad of joint motion)", item.where,
                 length, REORIENT_LENGTH)
    path = LinearJointPath(n=robot.n, domain=(theta, theta + length), q0=q0, q1=q1, joint_names=robot.joint_names)
    return Piece(path, theta, theta + length, 0.0, "joint", item.where)


def _task_piece(robot: Robot, item: TaskRun, q0, theta: float, follows: bool) -> Piece:
    try:
        path = lift(robot, item.path, q0, original=item.original)
    except PathmotionError as exc:  # its theta and segment number count from the run's start
        raise exc.in_context(f"{item.where} (theta and segment counted from its start)") from exc
    if follows:  # it must start where the chain is
        start = path.evaluate(0.0)[0]
        if np.max(np.abs(start - q0)) > SAME_CONFIGURATION:
            r0, r1 = fk(robot, q0)[1], item.path.orientation(0.0)[0]
            angle = np.degrees(np.arccos(np.clip((np.trace(r0.T @ r1) - 1) / 2, -1, 1)))
            why = (f"the tool orientation differs by {angle:.3g} deg from the previous segment's end pose; make the "
                   "path's orientation match it" if angle > 1e-4 else
                   f"the lift starts on another IK branch ({np.round(start, 4).tolist()} rad); end the joint move "
                   "before it on the branch the task path continues on")
            raise PathError(f"{item.where}: the task path does not start where the segment before it ends "
                            f"({np.round(q0, 4).tolist()} rad): {why}")
    return Piece(path, theta, theta + path.length, theta, "task", item.where)


def lift_chain(robot: Robot, items, q_start=None, zones=None) -> PiecewiseJointPath:
    """The joint path of ``items`` (TaskRun, JointMove, Dwell) in order from ``q_start`` (n,) [rad] (needed when
    the chain starts with a joint move); ``zones``: {i: tolerance [m]} blends the connection between motion items
    i and i + 1 (counted over the TaskRun and JointMove items only)."""
    q = None if q_start is None else np.asarray(q_start, dtype=float)
    theta, pieces, dwells, stops = 0.0, [], [], []
    for item in items:
        if isinstance(item, Dwell):
            dwells.append((theta, float(item.time)))
            stops.append(theta)
            continue
        if isinstance(item, JointMove):
            if q is None:
                raise PathError(f"{item.where}: the path starts with a joint move, which needs a start: give "
                                "path.start_configuration = [joint values, rad]")
            piece = _joint_piece(robot, item, q, theta)
        else:
            piece = _task_piece(robot, item, q, theta, bool(pieces))
        pieces.append(piece)
        theta = piece.hi
        q = piece.path.evaluate(piece.hi - piece.shift, side="left")[0]
    if not pieces:
        raise PathError("path.segments: the path has no motion (dwells only); add a segment that moves")
    kinks = [theta_c for theta_c in _joint_kinks(pieces) if theta_c not in stops]
    kinks += [s for s in stops if 0.0 < s < theta]
    sharp = list(pieces)
    for index, tol in sorted((zones or {}).items()):
        if not 0 <= index < len(sharp) - 1 or sharp[index].hi in stops:
            raise PathError(f"zone {index}: no connection between two motion items there (or a dwell stops the "
                            f"motion there); the chain has {len(sharp) - 1} connections")
        pieces = _with_zone(robot, pieces, sharp, index, tol, kinks)
    return _assemble(robot, pieces, sharp, sorted(set(kinks)), tuple(dwells), bool(zones))


def _joint_kinks(pieces) -> list[float]:
    """theta of the connections where Phi' jumps between a joint move and its neighbour."""
    out = []
    for a, b in zip(pieces[:-1], pieces[1:]):
        if a.kind == "task" and b.kind == "task":
            continue
        left = a.path.evaluate(a.hi - a.shift, side="left")[1]
        right = b.path.evaluate(b.lo - b.shift)[1]
        if np.max(np.abs(left - right)) > SAME_RATE * max(np.max(np.abs(left)), np.max(np.abs(right))):
            out.append(a.hi)
    return out


def _cut(piece: Piece, at_end: bool) -> float:
    """Largest theta [m] a zone may cut from ``piece`` at its end (or start): ZONE_CUT of the piece, or of its
    last (first) segment for a task piece."""
    if piece.kind == "task":
        segs = piece.path.task_path.segments
        return ZONE_CUT * (segs[-1] if at_end else segs[0]).length
    return ZONE_CUT * (piece.hi - piece.lo)


def _polyline_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance (M,) [m] of points (M, 3), taken along the polyline (K, 3) over the same theta range, to its chords
    within ZONE_WINDOW of the chord at the same fraction of the range: a subset of the chords, so never below the
    distance to the whole polyline (an upper bound, as the zone's check needs)."""
    a, ab = line[:-1], np.diff(line, axis=0)
    count = len(ab)
    centre = np.round(np.linspace(0.0, count - 1, len(points))).astype(int)
    width = max(1, int(ZONE_WINDOW * count))
    idx = np.clip(centre[:, None] + np.arange(-width, width + 1)[None], 0, count - 1)  # (M, W)
    a, ab = a[idx], ab[idx]  # (M, W, 3)
    rel = points[:, None] - a
    t = np.clip(np.sum(rel * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=2), 1e-300), 0.0, 1.0)
    return np.sqrt(np.min(np.sum((rel - t[..., None] * ab) ** 2, axis=2), axis=1))


def _tcp_rate(robot: Robot, piece: Piece, theta: float, side: str) -> float:
    """|dp/dtheta| [-] of the TCP at theta on ``piece``: 1 on a task piece (theta is its arc length), |J_v Phi'|
    on a joint move (so a zone of d [m] starts about d of TCP travel before the corner, as the controller's)."""
    if piece.kind == "task":
        return 1.0
    q, dq, _ = piece.path.evaluate(theta - piece.shift, side=side)
    return max(float(np.linalg.norm(jacobian(robot, q)[:3] @ dq)), STILL_TCP)


def _with_zone(robot: Robot, pieces: list, sharp: list, index: int, tol: float, kinks: list) -> list:
    """``pieces`` with the connection between motion pieces ``index`` and ``index + 1`` replaced by a JointBlend
    whose TCP stays within ``tol`` [m] of the sharp TCP path (``sharp``: the pieces before any zone)."""
    theta_c = sharp[index].hi
    at = next(k for k, p in enumerate(pieces) if p.hi == theta_c)
    a, b = pieces[at], pieces[at + 1]
    where = f"{a.where} -> {b.where}"
    if theta_c not in kinks and a.kind == b.kind == "task":
        raise PathError(f"{where}: no joint move at this connection")
    size_a = min(tol / _tcp_rate(robot, a, theta_c, "left"), _cut(sharp[index], True), a.hi - a.lo - 1e-9)
    size_b = min(tol / _tcp_rate(robot, b, theta_c, "right"), _cut(sharp[index + 1], False), b.hi - b.lo - 1e-9)
    corner = PiecewiseJointPath(n=robot.n, domain=(sharp[index].lo, sharp[index + 1].hi),
                                pieces=(sharp[index], sharp[index + 1]))  # the two sharp neighbours
    for _ in range(ZONE_SHRINKS):
        lo, hi = theta_c - size_a, theta_c + size_b
        start = a.path.evaluate(lo - a.shift)
        end = b.path.evaluate(hi - b.shift)
        blend = JointBlend.between(lo, hi, start, end, robot.joint_names)
        tcp = fk(robot, blend.evaluate(np.linspace(lo, hi, ZONE_SAMPLES))[0])[0]
        sharp_tcp = fk(robot, corner.evaluate(np.linspace(lo, hi, 4 * ZONE_SAMPLES))[0])[0]
        step = float(np.max(np.linalg.norm(np.diff(tcp, axis=0), axis=1)))  # the distance is 1-Lipschitz in p
        deviation = float(np.max(_polyline_distance(tcp, sharp_tcp))) + 0.5 * step
        q = blend.evaluate(np.linspace(lo, hi, ZONE_SAMPLES))[0]
        inside = bool(np.all((q >= robot.limits.lower) & (q <= robot.limits.upper)))
        if deviation <= tol and inside:
            break
        size_a, size_b = 0.5 * size_a, 0.5 * size_b
    else:
        raise PathError(f"{where}: no zone blend keeps the TCP within {tol:g} m of the path and the joints in their "
                        f"ranges ({deviation:.3g} m at the smallest); give a larger zone or a fine point")
    log.info("%s: joint zone blend over theta [%.6g, %.6g] m, TCP deviation %.3g m (zone %g m)", where, lo, hi,
             deviation, tol)
    if theta_c in kinks:
        kinks.remove(theta_c)
    middle = Piece(blend, lo, hi, 0.0, "blend", f"zone of {where}")
    return pieces[:at] + [replace(a, hi=lo), middle, replace(b, lo=hi)] + pieces[at + 2:]


def _traces(robot: Robot, pieces, step: float, sharp: bool = False) -> list:
    """The TCP trace segments of ``pieces``: a task piece's own segments (trimmed to its range; ``sharp``: all
    segments of its path before blends), a joint or blend piece's FK trace."""
    segs = []
    for piece in pieces:
        if sharp and piece.kind == "task":
            task = piece.path.original_task_path or piece.path.task_path
            segs.extend(task.segments)
            continue
        if piece.kind != "task":
            label = "joint move" if piece.kind == "joint" else "joint zone blend"
            segs.append(tcp_trace(robot, piece.path, piece.lo - piece.shift, piece.hi - piece.shift, step,
                                  f"{label} ({piece.where})"))
            continue
        task = piece.path.task_path
        lo, hi = piece.lo - piece.shift, piece.hi - piece.shift
        for seg, start in zip(task.segments, task.offsets[:-1]):
            s0, s1 = max(lo - start, 0.0), min(hi - start, seg.length)
            if s1 - s0 > defaults.MIN_SEGMENT_LENGTH:
                segs.append(seg if (s0 <= 0.0 and s1 >= seg.length) else seg.trimmed(s0, s1))
    return segs


def _assemble(robot: Robot, pieces, sharp, kinks, dwells, zoned: bool) -> PiecewiseJointPath:
    """The PiecewiseJointPath of ``pieces`` with its breaks, kinks, peaks and TCP traces."""
    step = defaults.LIFT_REFERENCE_STEP
    orientation = next((p.path.task_path.tool_orientation for p in pieces if p.kind == "task"), FixedOrientation())
    trace = TaskPath(tuple(_traces(robot, pieces, step)), orientation)
    blended = zoned or any(p.kind == "task" and p.path.original_task_path is not None for p in pieces)
    original = None
    if blended:
        original = TaskPath(tuple(_traces(robot, sharp, step, sharp=True)), orientation)
    breaks, peaks = set(p.lo for p in pieces[1:]), []
    for p in pieces:
        if p.kind == "task":
            breaks |= {b + p.shift for b in p.path.breaks if p.lo < b + p.shift < p.hi}
            kinks = kinks + [k + p.shift for k in p.path.kinks if p.lo < k + p.shift < p.hi]
            peaks += [k + p.shift for k in p.path.peaks if p.lo < k + p.shift < p.hi]
    return PiecewiseJointPath(
        check=_chain_check(robot, pieces, sorted(set(kinks)), step),
        n=robot.n, domain=(pieces[0].lo, pieces[-1].hi), kinks=tuple(sorted(set(kinks))),
        breaks=tuple(sorted(breaks | set(kinks))), joint_names=robot.joint_names, peaks=tuple(sorted(peaks)),
        pieces=tuple(pieces), robot=robot, task_path=trace, original_task_path=original, dwells=dwells)


def _chain_check(robot: Robot, pieces, kinks, step: float) -> PathCheck:
    """The chain's PathCheck: each task run's own (its theta moved onto the chain; it covers the whole run, the
    parts zones replaced included) and, along each joint move and zone blend sampled ``step`` [m] apart, the
    smallest Jacobian singular value and joint-range margin (a joint move may pass a singularity: no IK there)."""
    rows, passages, samples = [], [], 0
    lim = robot.limits
    for piece in pieces:
        s = piece.shift
        if piece.kind == "task":
            c = piece.path.check
            rows.append((c.min_singular_value, c.min_singular_theta + s, c.range_margin, c.range_margin_theta + s,
                         c.range_margin_joint))
            passages += [replace(ps, theta=ps.theta + s, region=(ps.region[0] + s, ps.region[1] + s),
                                 speed_limit_theta=ps.speed_limit_theta + s) for ps in c.wrist_passages]
            samples += c.samples
            continue
        theta = np.linspace(piece.lo, piece.hi, max(int(np.ceil((piece.hi - piece.lo) / step)), 8) + 1)
        q = piece.path.evaluate(theta - s)[0]
        sv = np.linalg.svd(jacobian(robot, q), compute_uv=False)[:, -1]
        margin = np.minimum(q - lim.lower, lim.upper - q)
        k, j = np.unravel_index(np.argmin(margin), margin.shape)
        i = int(np.argmin(sv))
        rows.append((float(sv[i]), float(theta[i]), float(margin[k, j]), float(theta[k]), lim.names[j]))
        samples += len(theta)
    sv_row = min(rows, key=lambda r: r[0])
    margin_row = min(rows, key=lambda r: r[2])
    return PathCheck(sv_row[0], sv_row[1], margin_row[2], margin_row[3], margin_row[4], tuple(kinks), samples,
                     tuple(passages))
