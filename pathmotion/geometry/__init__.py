"""Task-space geometry: segments, the chained TaskPath with one path coordinate, tool orientation,
transition circles and G2 blends at corners, and the thesis' paths. Pure numpy; no robot."""

from .blends import (blended_corners, g2_control_points, g2_deviation, largest_g2_tolerance, largest_transition_radius,
                     with_blends, with_g2_blend, with_g2_blends, with_transition, with_transitions)
from .chain import Connection, TaskPath, describe_point
from .deviation import Deviation, certified_max, distance_to_segments, max_deviation
from .library import (circle_with_radial_line, circle_with_radial_line_transition, circle_with_vertical_circle,
                      horizontal_circle, thesis_circle)
from .orientation import FixedOrientation, SlerpOrientation, smoothstep5
from .sampled import HermiteSegment
from .segments import Arc, BezierSegment, Circle, Line, Segment
from .waypoints import waypoint_path

__all__ = [
    "Arc", "BezierSegment", "Circle", "Connection", "Deviation", "FixedOrientation", "HermiteSegment", "Line", "Segment",
    "SlerpOrientation", "TaskPath", "blended_corners", "certified_max", "circle_with_radial_line", "circle_with_radial_line_transition",
    "circle_with_vertical_circle", "describe_point",
    "distance_to_segments", "g2_control_points", "g2_deviation", "horizontal_circle", "largest_g2_tolerance",
    "largest_transition_radius", "max_deviation", "smoothstep5", "thesis_circle", "waypoint_path", "with_blends", "with_g2_blend",
    "with_g2_blends", "with_transition", "with_transitions",
]
