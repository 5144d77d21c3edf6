"""A ``type = "task"`` path with joint moves (MoveJ / MoveAbsJ) or dwells (WaitTime) among its segments: the scenario's
segments turned into the items of :func:`pathmotion.lift.chain.lift_chain` (runs of task segments, joint moves,
dwells) and its ``[[path.blends]]`` into task-corner blends and joint zones (docs/geometry.md, "Joint moves and
dwells"); with optimal blends at task corners, the request of their search per task run (:mod:`.chain_blends`,
docs/program.md, "Optimal blends in a program")."""

from __future__ import annotations

import logging

import numpy as np

from ..errors import ScenarioError
from ..geometry import TaskPath, blended_corners, with_blends
from ..io.rapid import quaternion_matrix
from ..lift.chain import Dwell, JointMove, TaskRun, lift_chain
from ..lift.joint_move import PiecewiseJointPath, check_joint_target
from ..robot import Robot, fk
from .blend_request import BlendRequest, ChainBlendRequest
from .program import start_configuration, start_rotation, task_orientation
from .segments import task_segments

log = logging.getLogger(__name__)


def _chain_items(spec, robot: Robot, q_prev) -> tuple[list, list[int]]:
    """(items for :func:`~pathmotion.lift.chain.lift_chain`, the item of each of path.segments) of a task path
    with joint moves or dwells, starting at ``q_prev`` (n,) [rad] or None: consecutive line/arc/circle segments
    form one TaskRun; a run whose segments carry quaternions turns the tool from where the previous motion
    left it, one without keeps ``path.orientation``."""
    items, owner, run, prev_end = [], [], [], None
    prev_rot = start_rotation(spec)
    if q_prev is not None and len(q_prev) == robot.n:
        prev_end = fk(robot, q_prev)[0]

    def close_run():
        nonlocal prev_rot
        if run:
            first = run[0][0]
            segs = task_segments([s for _, s in run], prev_end, first)
            where = f"path.segments[{first}..{run[-1][0]}]" if len(run) > 1 else f"path.segments[{first}]"
            start = prev_rot if run[0][1].quaternion is not None else start_rotation(spec)
            task = TaskPath(tuple(segs), task_orientation(start, [s for _, s in run], segs))
            items.append(TaskRun(task, None, where))
            prev_rot = task.orientation(task.length)[0]
            run.clear()
            return segs[-1].end_point
        return prev_end

    for k, seg in enumerate(spec.segments):
        program = getattr(seg, "program", None)
        where = f"path.segments[{k}]" + ("" if program is None else f" (line {program.line}, target {program.target})")
        if seg.type in ("line", "arc", "circle"):
            run.append((k, seg))
            owner.append(len(items))
            continue
        prev_end = close_run()
        owner.append(len(items))
        if seg.type == "dwell":
            items.append(Dwell(seg.time, where))
        elif seg.end is not None:
            end = check_joint_target(robot, seg.end, where)
            items.append(JointMove(end, None, where))
            prev_end, prev_rot = fk(robot, end)
        else:
            pose = seg.end_pose
            rotation = quaternion_matrix(pose.quaternion, f"{where}.end_pose.quaternion")
            items.append(JointMove(None, (np.asarray(pose.position, float), rotation, pose.robconf), where))
            prev_end, prev_rot = np.asarray(pose.position, float), rotation
    close_run()
    return items, owner


def _chain_corners(items: list, owner: list[int]) -> list[tuple]:
    """What each connection of path.segments is in the chain: ("run", item, its local connection), ("zone", motion
    connection: between motion items m and m + 1, dwells not counted) or ("dwell",)."""
    motion = [i for i, it in enumerate(items) if not isinstance(it, Dwell)]
    out = []
    for c in range(len(owner) - 1):
        a, b = owner[c], owner[c + 1]
        if isinstance(items[a], Dwell) or isinstance(items[b], Dwell):
            out.append(("dwell",))
        elif a == b:
            out.append(("run", a, c - owner.index(a)))
        else:
            out.append(("zone", motion.index(a)))
    return out


def _picked(blend, k: int, corners: list, sharp: set) -> list[int]:
    """The connections ``path.blends[k]`` blends: with corner = "all", every sharp corner inside a task run and,
    for a g2 or optimal blend, every connection with a joint move; else its own (ScenarioError where it cannot
    be blended: a dwell, or a circle at a joint move)."""
    where = f"path.blends[{k}]"
    if blend.corner == "all":
        return [c for c, kind in enumerate(corners)
                if c in sharp or (kind[0] == "zone" and blend.type in ("g2", "optimal"))]
    c = blend.corner - 1
    if not 0 <= c < len(corners):
        raise ScenarioError(f"{where}.corner = {blend.corner}: the path has {len(corners)} connection(s), "
                            f"numbered 1..{len(corners)} (1 = between segments 1 and 2)")
    if corners[c][0] == "dwell":
        raise ScenarioError(f"{where}: corner {blend.corner} is at a dwell, where the motion stops; remove "
                            "the blend")
    if corners[c][0] == "zone" and blend.type not in ("g2", "optimal"):
        raise ScenarioError(f"{where}: corner {blend.corner} joins a joint move; its zone is type = 'g2' "
                            "with tolerance = the zone [m]")
    return [c]


def _chain_blends(spec, items: list, owner: list[int]) -> tuple[dict, dict]:
    """({item: {local connection: (kind, value, k of path.blends[k])}} of the task runs' corners, {motion
    connection: tolerance [m]} of the joint-move zones) from path.blends; ScenarioError for what a chain cannot
    blend. An optimal blend at a joint move is that connection's joint-space zone within its tolerance (logged:
    the zone is not searched)."""
    corners = _chain_corners(items, owner)
    sharp = {c for c, kind in enumerate(corners) if kind[0] == "run"
             and kind[2] in blended_corners(items[kind[1]].path, f"path.segments (connection {c + 1})")}
    run_blends: dict[int, dict] = {}
    zones: dict[int, float] = {}
    chosen: dict[int, int] = {}
    for k, blend in enumerate(spec.blends):
        value = blend.radius if blend.type == "circle" else blend.tolerance
        for c in _picked(blend, k, corners, sharp):
            if c in chosen:
                raise ScenarioError(f"path.blends[{k}]: connection {c + 1} is already blended by "
                                    f"path.blends[{chosen[c]}]; give one blend per corner")
            chosen[c] = k
            kind = corners[c]
            if kind[0] == "run":
                run_blends.setdefault(kind[1], {})[kind[2]] = (blend.type.value, value, k)
                continue
            zones[kind[1]] = value
            if blend.type == "optimal":
                log.info("path.blends[%d] at connection %d (a joint move): the joint-space zone within %g m, not "
                         "searched (optimal blends are searched at the corners between task segments)", k, c + 1,
                         value)
    return run_blends, zones


def is_chain(spec) -> bool:
    """Whether a path spec is a chain: a ``type = "task"`` path with joint moves or dwells among its segments."""
    return spec.type == "task" and any(seg.type in ("joint", "dwell") for seg in spec.segments)


def _run_request(spec, run: TaskRun, blends: dict, first: int) -> BlendRequest:
    """The BlendRequest of a task run's optimal corners (``blends`` {local connection: (kind, value, k)}; the
    run's first segment is path.segments[``first``])."""
    names = {c: f"path.blends[{k}] (corner {first + c + 1})" for c, (_, _, k) in blends.items()}
    optimal = {c: value for c, (kind, value, _) in blends.items() if kind == "optimal"}
    others = {c: (kind, value) for c, (kind, value, _) in blends.items() if kind != "optimal"}
    return BlendRequest(run.path, others, optimal, names,
                        planar=tuple(c for c in optimal if spec.blends[blends[c][2]].planar),
                        joined=tuple(c for c in optimal if spec.blends[blends[c][2]].join_ends),
                        searches={c: spec.blends[blends[c][2]].search for c in optimal})


def chain_setup(spec, robot: Robot) -> tuple[PiecewiseJointPath | None, ChainBlendRequest | None]:
    """(the PiecewiseJointPath, None) of a ``type = "task"`` path whose segments include joint moves or dwells;
    (None, its ChainBlendRequest) when it asks for optimal blends at corners between task segments."""
    q_start = start_configuration(spec, robot)
    items, owner = _chain_items(spec, robot, q_start)
    run_blends, zones = _chain_blends(spec, items, owner)
    runs = {}
    for i, blends in run_blends.items():
        run = items[i]
        if any(kind == "optimal" for kind, _, _ in blends.values()):
            runs[i] = _run_request(spec, run, blends, owner.index(i))
            continue
        names = {c: f"path.blends[{k}] (corner {c + 1} of {run.where})" for c, (_, _, k) in blends.items()}
        items[i] = TaskRun(with_blends(run.path, {c: b[:2] for c, b in blends.items()}, names), run.path, run.where)
    log.info("lift: a chain of %d task runs, %d joint moves, %d dwells, %d joint zones%s",
             sum(isinstance(i, TaskRun) for i in items), sum(isinstance(i, JointMove) for i in items),
             sum(isinstance(i, Dwell) for i in items), len(zones),
             f", optimal blends to search in {len(runs)} task run(s)" if runs else "")
    if runs:
        return None, ChainBlendRequest(tuple(items), runs, zones, q_start)
    return lift_chain(robot, items, q_start, zones), None
