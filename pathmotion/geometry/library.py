"""The thesis' task-space paths (chapters 6 and 7), with IRB140-reachable defaults from
:mod:`pathmotion.defaults` (circle centre (0.5, 0, 0.5) m, radius 0.1 m).

* :func:`horizontal_circle` -- one turn of a horizontal circle (closed, smooth).
* :func:`circle_with_radial_line` -- the circle followed by a straight line along its radius,
  a 90 degree corner (chapter 7's sharp-corner case; add a transition with
  :func:`~pathmotion.geometry.blends.with_transition` at connection 0).
* :func:`circle_with_radial_line_transition` -- the same with the corner replaced by the
  thesis' transition circle (r_t = 0.04 m).
* :func:`circle_with_vertical_circle` -- the circle followed by a vertical circle through the
  same point with the same tangent: a "tangent" connection (G1, curvature jump).
"""

from __future__ import annotations

import numpy as np

from .. import defaults
from .blends import with_transition
from .chain import TaskPath
from .orientation import FixedOrientation, Orientation
from .segments import Circle, Line, as_point, as_scalar


def _orientation(orientation: Orientation | None) -> Orientation:
    return FixedOrientation() if orientation is None else orientation


def thesis_circle(centre=defaults.THESIS_CIRCLE_CENTRE, radius: float = defaults.THESIS_CIRCLE_RADIUS,
                  start_angle: float = 0.0, direction: int = 1) -> Circle:
    """The horizontal circle segment: ``centre`` (3,) [m] (its z is the height), ``radius`` [m],
    start at ``start_angle`` [rad] from world x, ``direction`` +1 = counter-clockwise from above."""
    return Circle.horizontal(centre, radius, start_angle, direction)


def horizontal_circle(centre=defaults.THESIS_CIRCLE_CENTRE, radius: float = defaults.THESIS_CIRCLE_RADIUS,
                      start_angle: float = 0.0, direction: int = 1,
                      orientation: Orientation | None = None) -> TaskPath:
    """One turn of the horizontal circle (closed path, smooth closure)."""
    return TaskPath((thesis_circle(centre, radius, start_angle, direction),), _orientation(orientation))


def circle_with_radial_line(centre=defaults.THESIS_CIRCLE_CENTRE, radius: float = defaults.THESIS_CIRCLE_RADIUS,
                            line_length: float = defaults.THESIS_LINE_LENGTH, inward: bool = True,
                            start_angle: float = 0.0, direction: int = 1,
                            orientation: Orientation | None = None) -> TaskPath:
    """The horizontal circle, then a straight line of ``line_length`` [m] from its start point along
    the radius: towards the centre (``inward``, default; reaches the centre when line_length =
    radius) or away from it. Connection 0 is a 90 degree corner."""
    circle = thesis_circle(centre, radius, start_angle, direction)
    length = as_scalar("line_length", line_length, "circle_with_radial_line")
    p = circle.start_point
    radial = (p - circle.centre) / circle.radius
    end = p + (-1.0 if inward else 1.0) * length * radial
    return TaskPath((circle, Line(p, end)), _orientation(orientation))


def circle_with_radial_line_transition(transition_radius: float = defaults.THESIS_TRANSITION_RADIUS,
                                       **kwargs) -> TaskPath:
    """:func:`circle_with_radial_line` (``kwargs`` passed on) with its 90 degree corner replaced by a
    transition circle of ``transition_radius`` [m] (thesis chapter 7.2)."""
    return with_transition(circle_with_radial_line(**kwargs), 0, transition_radius)


def circle_with_vertical_circle(centre=defaults.THESIS_CIRCLE_CENTRE,
                                radius: float = defaults.THESIS_CIRCLE_RADIUS,
                                vertical_radius: float = defaults.THESIS_VERTICAL_CIRCLE_RADIUS,
                                up: bool = True, start_angle: float = 0.0, direction: int = 1,
                                orientation: Orientation | None = None) -> TaskPath:
    """The horizontal circle, then a full vertical circle of ``vertical_radius`` [m] through its start
    point, tangent to it there (the vertical circle's plane contains the horizontal tangent and
    world z; its centre is above the point if ``up``, else below). Connection 0 is "tangent": same
    tangent, curvature vector jumps from 1/radius (horizontal, towards the centre) to
    1/vertical_radius (vertical)."""
    circle = thesis_circle(centre, radius, start_angle, direction)
    p, t, _ = circle.start_frame
    r_v = as_scalar("vertical_radius", vertical_radius, "circle_with_vertical_circle")
    z = np.array([0.0, 0.0, 1.0]) * (1.0 if up else -1.0)
    vc = p + r_v * z
    # right-handed about n = (p - vc) x t / r_v ... runs along t at p
    normal = np.cross(p - vc, t)
    vertical = Circle(as_point("vertical centre", vc, "circle_with_vertical_circle"), p, normal, 2.0 * np.pi)
    return TaskPath((circle, vertical), _orientation(orientation))
