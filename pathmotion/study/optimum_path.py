"""The free-shape optimum's own TCP path as a task path, to plan along (issue 17).

A corner-confined free-shape solution (:mod:`.free_shape`) moves the joints with a piecewise-
constant acceleration u_k on each interval [t_k, t_k+1], so its TCP path p(q(t)) is smooth on each
interval and its curvature jumps where u switches (the optimum holds several joints at their
acceleration limits and switches them together). :func:`optimum_task_path` rebuilds that path
exactly enough to plan along: one quintic Bezier per interval of the corner's spans, the Hermite
quintic of the interval's end states

    X(0) = p_k     X'(0) = h v_k     X''(0) = h^2 a_k+        (h = t_k+1 - t_k)
    X(1) = p_k+1   X'(1) = h v_k+1   X''(1) = h^2 a_k+1-

with v = J qd and a = J u + Jdot qd from the interval's own u (so a jumps between pieces like the
optimum's). The spans begin and end where the solution is on the sharp path (the corner-confined
tube has radius 0 there); the tangent at those two joins is projected onto the line (the NLP
imposes the line only at its nodes and interval points, so its velocity there may lean off it by
a milliradian, a kink the planner would stop at).

What it is for: planning along this path with pathmotion's planner must give (up to the planner's
grid) the solution's own duration or less, since the solution's timing is one feasible timing of the
path. That cross-checks the two algorithms (tests), and it measured where a blend family loses time:
on 120 deg / 10 mm, spans 0.12 m, the 100-interval solution (0.7874 s) re-planned along its own path
takes 0.7878 s; the same path pressed into the corner's plane 0.7936 s (+0.7 %), with the curvature
jumps averaged out 0.7900 s (+0.3 %) (docs/study.md).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import PathError

#: A span's first and last node must lie this close to the sharp path [m] (radius-0 phase nodes: rounding).
ON_LINE_TOLERANCE = 1e-7


def _hermite_pieces(robot, motion, first: int, last: int) -> list[np.ndarray]:
    """Control points (6, 3) [m] of one quintic per interval first .. last - 1 of ``motion``."""
    from ..robot.kinematics import fk, frame_acceleration_bias, jacobian

    pieces = []
    for k in range(first, last):
        h = motion.t[k + 1] - motion.t[k]
        ends = []
        for node in (k, k + 1):
            q, qd = motion.q[node], motion.qd[node]
            J = jacobian(robot, q)[:3]
            acc = J @ motion.u[k] + frame_acceleration_bias(robot, q, qd)[:3]
            ends.append((fk(robot, q)[0], h * (J @ qd), h * h * acc))
        (p0, d0, a0), (p1, d1, a1) = ends
        pieces.append(np.array([p0, p0 + d0 / 5, p0 + 2 * d0 / 5 + a0 / 20, p1 - 2 * d1 / 5 + a1 / 20,
                                p1 - d1 / 5, p1]))
    return pieces


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


def optimum_task_path(robot, points, phases: Sequence, motion, rotation=None):
    """The sharp polyline ``points`` (m, 3) [m] with each corner's span replaced by the TCP path of
    the corner-confined free-shape ``motion`` (a :class:`~.free_shape.Guess`, e.g.
    ``FreeShapeSolution.motion``) on ``phases`` (its :func:`~.free_shape.tube_phases`), tool
    ``rotation`` (3, 3) (default tool down): a TaskPath with theta = arc length (module docstring).
    PathError when the motion leaves the sharp path outside its spans (a whole-tube solution) or a
    span has no radius-0 phase after it."""
    from .. import defaults
    from ..geometry import FixedOrientation, Line, TaskPath
    from ..geometry.blends import _corner, _replace
    from ..geometry.segments import BezierSegment
    from ..robot.kinematics import fk
    from .free_shape import Polyline

    line = Polyline(points)
    R = np.array(defaults.TOOL_DOWN_ROTATION) if rotation is None else np.asarray(rotation, float)
    path = TaskPath(tuple(Line(a, b) for a, b in zip(line.points[:-1], line.points[1:])), FixedOrientation(R))
    if len(motion.breaks) != len(phases) + 1:
        raise PathError(f"optimum path: the motion has {len(motion.breaks) - 1} phases, {len(phases)} given")
    corners = []  # (corner index, first node, last node)
    i = 0
    while i < len(phases):
        if phases[i].radius == 0.0:
            i += 1
            continue
        j = i
        while j + 1 < len(phases) and phases[j + 1].radius > 0.0:
            j += 1
        if j + 1 >= len(phases) or i == 0 or phases[j].segment != phases[i].segment + 1:
            raise PathError("optimum path: a span must run from one segment over one corner to the next with the "
                            "sharp path (radius 0) on both sides: give a corner-confined solution, not a whole tube")
        last = motion.breaks[j + 1] + 1  # the first node inside the radius-0 phase after the span
        corners.append((phases[i].segment, motion.breaks[i], min(last, motion.breaks[j + 2])))
        i = j + 1
    for corner, first, last in reversed(corners):
        pieces = _hermite_pieces(robot, motion, first, last)
        ends = fk(robot, motion.q[[first, last]])[0]
        off = line.distance(ends)
        if np.max(off) > ON_LINE_TOLERANCE:
            raise PathError(f"optimum path: the motion is {np.max(off):.3g} m off the sharp path where the span at "
                            f"corner {corner + 1} begins or ends; give a corner-confined solution")
        tA, tB = line.directions[corner], line.directions[corner + 1]
        _along(pieces[0], tA, at_start=True)
        _along(pieces[-1], tB, at_start=False)
        a = float(line.lengths[corner] - (ends[0] - line.points[corner]) @ tA)
        b = float((ends[1] - line.points[corner + 1]) @ tB)
        c = _corner(path, corner, ("corner",), "optimum_task_path")
        path = _replace(path, c, a, b, tuple(BezierSegment(p) for p in pieces))
    return path


__all__ = ["optimum_task_path"]
