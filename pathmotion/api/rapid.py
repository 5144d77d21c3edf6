"""A RAPID program's figures for a scenario: the blend tolerances of its zones (``import-rapid``), the flange
kinematics its MoveAbsJ need, and its programmed-speed duration estimate (summary.json's ``rapid_estimate_s``)."""

from __future__ import annotations

import functools

import numpy as np

from ..geometry import Arc, Line
from ..geometry.chain import classify
from ..geometry.blends import g2_deviation
from ..io.rapid import effective_zones, rapid_estimate_s, segments
from ..planning.program_moves import programmed_time
from ..robot import fk, load_robot
from .chain import is_chain
from .program import axis_times, program_thetas
from .setup import Setup

#: Largest share of a neighbouring segment a RAPID zone may cut (below half: two zones never meet).
RAPID_ZONE_CUT = 0.49


def rapid_zone_tolerances(program) -> list:
    """G2 blend tolerance [m] per corner of an imported RAPID program (io.rapid.RapidProgram): the deviation of
    the blend that starts at the zone radius from the target (ABB's corner path starts where the TCP enters the
    zone), the cut kept below RAPID_ZONE_CUT of each neighbour so a segment between two zones keeps a straight
    middle; at a joint move (MoveJ, MoveAbsJ) the zone radius itself (the joint zone's TCP tolerance); None at fine
    points and where the moves join without a corner."""
    segs = [None if mv.joint else Line(start, mv.point) if arc is None else
            Arc(arc.center, start, arc.normal, arc.sweep) for mv, start, arc, _ in segments(program)]
    out = []
    for k, zone in enumerate(effective_zones(program)):
        A, B = segs[k], segs[k + 1]
        if A is None or B is None:  # a joint move's zone: its size
            out.append(zone if zone > 0 else None)
            continue
        cut = min(zone, RAPID_ZONE_CUT * A.length, RAPID_ZONE_CUT * B.length)
        usable = classify(A, B, k, 0.0).kind in ("corner", "tangent") and cut > 0
        out.append(g2_deviation(A, B, cut).upper if usable else None)
    return out


def rapid_flange(robot: str = "irb140"):
    """The flange kinematics io.rapid.parse_rapid needs for MoveAbsJ: joints (6,) [rad] -> (position (3,) [m],
    rotation (3, 3)) of the bare robot ``robot``'s flange in its base frame (the robot is loaded at the first call)."""
    @functools.cache
    def bare():
        return load_robot(robot)

    def flange(joints):
        return fk(bare(), np.asarray(joints, float))
    return flange


def rapid_estimate(setup: Setup) -> float | None:
    """The RAPID program's programmed-speed duration [s]. On a path of task moves: io.rapid.rapid_estimate_s,
    constant speed with zone blending on the path before blends. On a chain (joint moves or WaitTime, whose TCP
    trace is not one segment per move): the sum of the moves' programmed times (planning.program_moves.
    programmed_time, moves.csv's programmed_time_s: a joint move at least its slowest axis at max speed, each
    WaitTime its time), zones not modelled. None when a segment has no programmed time."""
    spec, task = setup.scenario.rapid, setup.scenario.path
    if is_chain(task):
        _, lengths = program_thetas(task, setup.robot, setup.path)
        times = [programmed_time(seg, getattr(seg, "program", None), length, axis)
                 for seg, length, axis in zip(task.segments, lengths, axis_times(task, setup.robot, setup.path))]
        return None if any(t is None for t in times) else float(sum(times))
    path = setup.original_task_path if setup.original_task_path is not None else setup.task_path
    if len(path.segments) != len(spec.speeds):
        return None
    return rapid_estimate_s([s.length for s in path.segments], spec.speeds, spec.zones,
                            [c.angle for c in path.connections])
