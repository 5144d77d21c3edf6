"""The geometry of ``[[path.segments]]`` of type line, arc and circle: each a segment starting where the previous
one ends (or at its own ``start``)."""

from __future__ import annotations

import numpy as np

from ..errors import PathmotionError, ScenarioError
from ..geometry import Arc, Circle, Line

#: Largest difference between a circle's given radius and its centre-to-start distance [m]
#: (a scenario's numbers are typed by hand: 1 um is far below any path tolerance, far above round-off).
RADIUS_MATCH = 1e-6


def _segment(s, start, where: str):
    """One task segment of ``path.segments`` (``start``: its start point, given or the previous end)."""
    if s.type == "line":
        if start is None:
            raise ScenarioError(f"{where}: the first line needs a start point")
        return Line(start, s.end)
    if s.type == "arc":
        if start is None:
            raise ScenarioError(f"{where}: the first arc needs a start point")
        return Arc(np.asarray(s.center, float), np.asarray(start, float), np.asarray(s.normal, float), float(s.sweep))
    # circle: through the given or previous end point, else at start_angle
    if start is not None:
        seg = Circle(np.asarray(s.center, float), np.asarray(start, float), np.asarray(s.normal, float))
    else:
        seg = Circle.from_centre(s.center, s.radius, s.normal, s.start_angle)
    if abs(seg.radius - s.radius) > RADIUS_MATCH:
        raise ScenarioError(f"{where}: the start point is {seg.radius:.6g} m from the centre, not the "
                            f"radius {s.radius:.6g} m; fix radius or centre")
    return seg


def task_segments(specs, prev_end=None, first: int = 0) -> list:
    """The geometry segments of line/arc/circle ``specs`` (path.segments[first], ...); ``prev_end`` (3,) [m]: where
    the path is before them (the default start of the first one)."""
    segs = []
    for k, s in enumerate(specs, start=first):
        where = f"path.segments[{k}]"
        start = s.start if getattr(s, "start", None) is not None else prev_end
        try:
            seg = _segment(s, start, where)
        except ScenarioError:
            raise
        except PathmotionError as exc:
            raise exc.in_context(where) from exc
        segs.append(seg)
        prev_end = seg.end_point
    return segs
