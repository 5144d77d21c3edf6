"""The free-shape optimum's own TCP path as a task path, to plan along.

A free-shape solution (:mod:`.free_shape`) moves the joints with a piecewise-constant acceleration
u_k on each interval [t_k, t_k+1], so its TCP path p(q(t)) is smooth on each interval and its
curvature jumps where u switches (the optimum holds several joints at their acceleration limits and
switches them together). :func:`optimum_task_path` rebuilds that path exactly enough to plan along:
the sharp path's lines where the tube has radius 0 (outside a corner-confined tube's spans), and one
quintic Bezier per interval where it has one, the Hermite quintic of the interval's end states

    X(0) = p_k     X'(0) = h v_k     X''(0) = h^2 a_k+        (h = t_k+1 - t_k)
    X(1) = p_k+1   X'(1) = h v_k+1   X''(1) = h^2 a_k+1-

with v = J qd and a = J u + Jdot qd from the interval's own u (so a jumps between pieces like the
optimum's); an interval that starts or ends at rest is written in the squared time from its resting
end, in which q is linear (in time its speed vanishes there). Where a tube meets a line, the tangent
is turned onto the line (the NLP imposes the line only at its nodes and interval points, so its
velocity there may lean off it by a milliradian, a kink the planner would stop at).

What it is for: planning along this path with pathmotion's planner must give (up to the planner's
grid and the orientation, which the NLP fixes only at its nodes and midpoints) the solution's own
duration or less, since the solution's timing is one feasible timing of the path. That cross-checks
the two algorithms (tests), and measures where a blend family loses time
(benchmarks/replan_optimum.py; docs/study.md, "The optimal blend's search").
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import PathError

#: A span's first and last node must lie this close to the sharp path [m] (radius-0 phase nodes: rounding).
ON_LINE_TOLERANCE = 1e-7
#: A node whose joint speeds are all below this fraction of the motion's largest is at rest [-].
REST_FRACTION = 1e-9


def _hermite_pieces(robot, motion, first: int, last: int) -> list[np.ndarray]:
    """Control points (6, 3) [m] of one quintic per interval first .. last - 1 of ``motion``: in time
    (X' = h J qd, X'' = h^2 (J u + Jdot qd) at both ends), or, on an interval that starts or ends at
    rest, in sigma = t^2 / h^2 (resting start: q = q_k + sigma u h^2 / 2) or 1 - (h - t)^2 / h^2
    (resting end: q = q_k+1 + (1 - sigma) u h^2 / 2), in which q is linear with dq = dq/dsigma =
    +-u h^2 / 2, so X' = J dq and X'' = Jdot(dq) dq (in time X' vanishes at the resting end: a cusp)."""
    from ..robot.kinematics import fk, frame_acceleration_bias, jacobian

    nodes = slice(first, last + 1)
    q, qd, u = motion.q[nodes], motion.qd[nodes], motion.u[first:last]  # (K + 1, n), (K + 1, n), (K, n)
    h = np.diff(motion.t[nodes])[:, None]  # (K, 1)
    p = fk(robot, q)[0]  # (K + 1, 3): last > first, so always a batch
    J = jacobian(robot, q)[:, :3]  # (K + 1, 3, n)
    bias = frame_acceleration_bias(robot, q, qd)[:, :3]  # Jdot qd, (K + 1, 3)
    # in time: X' = h J qd, X'' = h^2 (J u + Jdot qd), with the interval's u at both of its ends
    d0, d1 = h * np.einsum("kij,kj->ki", J[:-1], qd[:-1]), h * np.einsum("kij,kj->ki", J[1:], qd[1:])
    a0 = h ** 2 * (np.einsum("kij,kj->ki", J[:-1], u) + bias[:-1])
    a1 = h ** 2 * (np.einsum("kij,kj->ki", J[1:], u) + bias[1:])
    still = REST_FRACTION * max(float(np.max(np.abs(motion.qd))), np.finfo(float).tiny)
    resting = np.max(np.abs(qd), axis=1) <= still  # (K + 1,)
    for k in np.flatnonzero(resting[:-1] | resting[1:]):  # in sigma: q linear, dq = +-u h^2 / 2
        dq = 0.5 * h[k, 0] ** 2 * u[k] * (1.0 if resting[k] else -1.0)
        d0[k], d1[k] = J[k] @ dq, J[k + 1] @ dq
        a0[k], a1[k] = (frame_acceleration_bias(robot, q[k + i], dq)[:3] for i in (0, 1))
    b0, b5 = p[:-1], p[1:]
    pieces = np.stack([b0, b0 + d0 / 5, b0 + 2 * d0 / 5 + a0 / 20, b5 - 2 * d1 / 5 + a1 / 20, b5 - d1 / 5, b5], axis=1)
    return list(pieces)


def _along(piece: np.ndarray, t: np.ndarray, at_start: bool) -> None:
    """Turn ``piece``'s end tangent onto the unit direction ``t`` (in place), keeping its speed
    component along t and its second derivative."""
    if at_start:
        d, acc = 5 * (piece[1] - piece[0]), 20 * (piece[2] - 2 * piece[1] + piece[0])
        d = (d @ t) * t
        piece[1] = piece[0] + d / 5
        piece[2] = piece[0] + 2 * d / 5 + acc / 20
    else:
        d, acc = 5 * (piece[5] - piece[4]), 20 * (piece[5] - 2 * piece[4] + piece[3])
        d = (d @ t) * t
        piece[4] = piece[5] - d / 5
        piece[3] = piece[5] - 2 * d / 5 + acc / 20


def _runs(phases: Sequence) -> list[tuple[int, int]]:
    """(first, last) phase indices of each maximal run of phases with a tube (radius > 0)."""
    runs, i = [], 0
    while i < len(phases):
        if phases[i].radius > 0.0:
            j = i
            while j + 1 < len(phases) and phases[j + 1].radius > 0.0:
                j += 1
            runs.append((i, j))
            i = j + 1
        else:
            i += 1
    return runs


def optimum_task_path(robot, points, phases: Sequence, motion, rotation=None):
    """The TCP path of the free-shape ``motion`` (a :class:`~.free_shape.Guess`, e.g.
    ``FreeShapeSolution.motion``) on ``phases`` (its :func:`~.free_shape.tube_phases`) along the
    polyline ``points`` (m, 3) [m], tool ``rotation`` (3, 3) (default tool down), as a TaskPath with
    theta = arc length: the sharp path's lines where the tube has radius 0 (corner-confined), one
    quintic per NLP interval where it has one (module docstring), the tangent at a line's joint turned
    onto the line. PathError when the motion leaves the sharp path where its tube has radius 0."""
    from .. import defaults
    from ..geometry import FixedOrientation, TaskPath
    from ..geometry.segments import BezierSegment
    from ..robot.kinematics import fk
    from .free_shape import Polyline

    line = Polyline(points)
    R = np.array(defaults.TOOL_DOWN_ROTATION) if rotation is None else np.asarray(rotation, float)
    if len(motion.breaks) != len(phases) + 1:
        raise PathError(f"optimum path: the motion has {len(motion.breaks) - 1} phases, {len(phases)} given; give "
                        "the phases it was solved on (free_shape.tube_phases with its delta and spans)")
    nodes = motion.breaks[-1]
    segments, at = [], np.asarray(line.points[0], float)  # built from the start, ``at``: the last point placed
    for i, j in _runs(phases):
        first = motion.breaks[i]
        # the first node inside the radius-0 phase after the run (capped at that phase's end)
        last = nodes if j + 1 == len(phases) else min(motion.breaks[j + 1] + 1, motion.breaks[j + 2])
        ends = fk(robot, motion.q[[first, last]])[0]
        for node, end, side in ((first, ends[0], i - 1), (last, ends[1], j + 1)):
            if 0 <= side < len(phases) and line.distance(end[None])[0] > ON_LINE_TOLERANCE:
                raise PathError(f"optimum path: the motion is {line.distance(end[None])[0]:.3g} m off the sharp path "
                                f"at node {node}, where its tube has radius 0; give the points and phases it was "
                                "solved on")
        if first > 0:  # the sharp path up to the run: the lines from the last point placed
            segments += _lines_between(line, at, ends[0], phases[i].segment)
        pieces = _hermite_pieces(robot, motion, first, last)
        if first > 0:
            _along(pieces[0], line.directions[phases[i].segment], at_start=True)
        if last < nodes:
            _along(pieces[-1], line.directions[phases[j].segment], at_start=False)
        segments += [BezierSegment(p) for p in pieces]
        at = ends[1]
    if not segments or np.linalg.norm(at - line.points[-1]) > 0.0:
        segments += _lines_between(line, at, line.points[-1], len(line.lengths) - 1)
    return TaskPath(tuple(segments), FixedOrientation(R))


def _lines_between(line, a: np.ndarray, b: np.ndarray, segment_b: int) -> list:
    """Lines along the polyline from the point ``a`` on it to the point ``b`` on segment ``segment_b``
    (through the corners between), skipping pieces shorter than a micrometre."""
    from ..geometry import Line

    pts = [np.asarray(a, float)]
    seg_a = int(np.argmin([np.linalg.norm(np.cross(a - P, t)) + max(0.0, -(a - P) @ t) + max(0.0, (a - P) @ t - L)
                           for P, t, L in zip(line.points[:-1], line.directions, line.lengths)]))
    pts += [line.points[k + 1] for k in range(seg_a, segment_b)]
    pts.append(np.asarray(b, float))
    return [Line(p, q) for p, q in zip(pts[:-1], pts[1:]) if np.linalg.norm(q - p) > 1e-6]


__all__ = ["optimum_task_path"]
