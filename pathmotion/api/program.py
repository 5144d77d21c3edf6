"""A ``type = "task"`` path as a robot program: the tool orientation its segments' quaternions give, the start
configuration its start pose and robconf give, the ConfL / ConfJ check at each target, and where the plan passes
each target (for moves.csv). docs/program.md describes the keys."""

from __future__ import annotations

import logging

import numpy as np

from .. import defaults
from ..errors import PathmotionError, ScenarioError, UnreachableError
from ..geometry import FixedOrientation, SlerpOrientation
from ..geometry.orientation import zoned_keys
from ..geometry.targets import target_thetas
from ..geometry.waypoints import waypoint_rotations
from ..io.rapid import quaternion_matrix
from ..lift.joint_path import JointPath
from ..lift.program import TargetConf, check_targets
from ..robot import Robot, fk
from ..robot.ik import has_closed_form, ik
from ..robot.robconf import ik_robconf
from .segments import task_segments

log = logging.getLogger(__name__)


def start_rotation(spec) -> np.ndarray:
    """The tool rotation (3, 3) at a task path's start: ``path.orientation``."""
    return np.array(defaults.TOOL_DOWN_ROTATION) if spec.orientation == "down" else np.asarray(spec.orientation, float)


def task_orientation(start: np.ndarray, specs, segs: list):
    """The tool orientation along the line/arc/circle ``specs`` (geometry ``segs``) starting with rotation
    ``start`` (3, 3): fixed, or with segment quaternions a slerp through each segment's end orientation,
    blended over each ``orientation_zone``."""
    if specs[0].quaternion is None:
        return FixedOrientation(start)
    ends = waypoint_rotations([s.quaternion for s in specs], len(segs), "path.segments quaternion")
    thetas = np.concatenate([[0.0], np.cumsum([s.length for s in segs])])
    zones = [0.0] + [s.orientation_zone for s in specs]
    keys, rots = zoned_keys(thetas, np.concatenate([start[None], ends]), zones)
    try:
        return SlerpOrientation(tuple(keys), rots)
    except PathmotionError as exc:
        raise ScenarioError(f"path.segments quaternions: {exc}") from None


def start_configuration(spec, robot: Robot) -> np.ndarray | None:
    """The configuration (n,) [rad] a task path starts from: ``start_configuration``, or the IK of ``start_pose`` on
    its robconf (the branch nearest the zero configuration without one, or on an arm without the closed form);
    None when neither is given."""
    if spec.start_configuration is not None:
        return np.asarray(spec.start_configuration, float)
    pose = getattr(spec, "start_pose", None)
    if pose is None:
        return None
    program = spec.start_program
    where = "path.start_pose" + ("" if program is None else f" (line {program.line}, target {program.target})")
    rotation = quaternion_matrix(pose.quaternion, f"{where}.quaternion")
    position = np.asarray(pose.position, float)
    if pose.robconf is not None and robot.n == 6 and has_closed_form(robot):
        return ik_robconf(robot, position, rotation, pose.robconf, where)
    try:
        return ik(robot, position, rotation, np.clip(np.zeros(robot.n), robot.limits.lower, robot.limits.upper))
    except UnreachableError as exc:
        raise exc.in_context(where) from exc


def program_targets(spec) -> list[TargetConf]:
    """The program targets of a task path whose segments carry program moves: the start, then each segment's
    end; [] when they carry none."""
    if spec.type != "task":
        return []
    moves = [spec.start_program] + [getattr(s, "program", None) for s in spec.segments]
    if all(m is None for m in moves):
        return []
    return [TargetConf("the path's start" if m is None else f"line {m.line}, target {m.target}",
                       None if m is None else m.robconf, True if m is None else m.conf) for m in moves]


def program_thetas(spec, robot: Robot, path: JointPath) -> tuple[np.ndarray, list[float]]:
    """(theta (K + 1,) [m] where the planned ``path`` passes the start and each of the K segments' ends of a
    ``type = "task"`` path (geometry.targets.target_thetas on its TCP path; a dwell's is the previous one's), the
    K segments' lengths before blending [m] (a joint move's: its TCP arc length; a dwell's: 0))."""
    prev = fk(robot, path(path.domain[0]))[0]
    points, spacing, lengths = [prev], [], []
    joints = iter(p.path.domain for p in getattr(path, "pieces", ()) if p.kind == "joint")
    for k, seg in enumerate(spec.segments):
        if seg.type == "dwell":
            lengths.append(0.0)
            continue
        if seg.type == "joint":
            prev = (np.asarray(seg.end_pose.position, float) if seg.end_pose is not None
                    else fk(robot, np.asarray(seg.end, float))[0])
            lo, hi = next(joints)
            length = hi - lo
        else:
            geo = task_segments([seg], prev, k)[0]
            prev, length = geo.end_point, geo.length
        points.append(prev)
        spacing.append(length)
        lengths.append(length)
    task = getattr(path, "task_path", None)
    if task is None:
        raise ScenarioError("program targets need a task path")
    motion = iter(target_thetas(task, np.array(points), spacing))
    out = [next(motion)]
    for seg in spec.segments:
        out.append(out[-1] if seg.type == "dwell" else next(motion))
    return np.array(out), lengths


def axis_times(spec, robot: Robot, path: JointPath) -> list[float]:
    """Per segment of a ``type = "task"`` path: a joint move's slowest-axis time at max speed [s],
    max_i |q_i(end) - q_i(start)| / qd_max_i over the move before blending (the robot's velocity limits); 0 for
    the other segments."""
    joints = iter(p.path for p in getattr(path, "pieces", ()) if p.kind == "joint")
    out = []
    for seg in spec.segments:
        if seg.type != "joint":
            out.append(0.0)
            continue
        move = next(joints)
        lo, hi = move.domain
        dq = np.abs(np.asarray(move(hi), float) - np.asarray(move(lo), float))
        out.append(float(np.max(dq / np.asarray(robot.limits.velocity, float))))
    return out


def check_program(spec, robot: Robot, path: JointPath) -> None:
    """The ConfL / ConfJ \\On check of a program path's targets (lift.program.check_targets); nothing without
    program moves."""
    targets = program_targets(spec)
    if targets:
        check_targets(robot, path, program_thetas(spec, robot, path)[0], targets)


__all__ = ["axis_times", "check_program", "program_targets", "program_thetas", "start_configuration", "start_rotation",
           "task_orientation"]
