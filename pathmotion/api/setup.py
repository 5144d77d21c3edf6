"""Scenario -> :class:`Setup`: parse, build the robot, the task path and the joint path. Nothing here plans.

A scenario that asks for optimal blends or ``torque_reserve = "auto"`` is built up to the searches these
need (they plan, and the reserve search simulates); :func:`pathmotion.api.searches.search` runs them.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import defaults
from ..errors import PathmotionError, ScenarioError, UnreachableError
from ..geometry import TaskPath, blended_corners, waypoint_path, with_blends
from ..io.files import read_input
from ..io.scenario import Scenario, degrees_hint, parse_scenario, unit_slips, velocity_slip
from ..io.waypoints import load_waypoints_csv
from ..lift.constraint import lift
from ..lift.joint_path import JointPath, SplineJointPath
from ..planning import PlanSettings
from ..planning.limits import limit_choices
from ..robot import Payload, Robot, Tool, builtin_robot_names, load_robot
from .blend_request import BlendRequest, ChainBlendRequest
from .chain import chain_setup, is_chain
from .program import check_program, start_configuration, start_rotation, task_orientation
from .reserve import AUTO, ReserveSearch
from .segments import task_segments

log = logging.getLogger(__name__)

#: Distance [m] within which a lift failure is reported "at waypoint k" rather than between two.
NEAR_WAYPOINT = 1e-3


@dataclass(frozen=True, eq=False)
class Setup:
    """A validated scenario turned into objects: robot, joint path (and the task path it came from, and
    the path before blends), planner settings.

    Searches not yet run: ``blend_request`` (optimal blends; ``path`` and ``task_path`` are None until
    :func:`~pathmotion.api.searches.search` finds them) and, with ``torque_reserve = "auto"``, a None
    ``reserve_search``. After the search, ``plan_settings`` hold the reserve it chose, ``reserve_search``
    its record and ``reserve_run`` the (plan, simulation or None) of that reserve, which
    :func:`~pathmotion.api.plan.plan_scenario` and :func:`~pathmotion.api.simulate.simulate_scenario`
    return instead of running again."""

    scenario: Scenario
    scenario_text: str
    base_dir: Path
    robot: Robot
    path: JointPath | None
    task_path: TaskPath | None
    original_task_path: TaskPath | None
    plan_settings: PlanSettings
    blend_request: BlendRequest | ChainBlendRequest | None = None
    reserve_search: ReserveSearch | None = None
    reserve_run: tuple | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def pending(self) -> tuple[str, ...]:
        """The searches this setup still needs before it can be planned ("optimal blends",
        "torque_reserve = auto"); empty when none."""
        out = ("optimal blends",) if self.blend_request is not None else ()
        if self.scenario.limits.torque_reserve == AUTO and self.reserve_search is None:
            out += ('torque_reserve = "auto"',)
        return out

    def require_searched(self, what: str) -> None:
        """Raise a ScenarioError naming ``what`` needs the searches of :attr:`pending` first."""
        if self.pending:
            raise ScenarioError(f"{what}: scenario {self.name!r} asks for {' and '.join(self.pending)}; run "
                                "pathmotion.api.search(setup) first (it plans, and for the reserve simulates)")


# ------------------------------------------------------------------------------------- the robot
def _rpy(rpy) -> np.ndarray:
    import pinocchio as pin

    return pin.rpy.rpyToMatrix(*map(float, rpy))


def build_robot(scenario: Scenario, base_dir: Path) -> Robot:
    """The scenario's robot with its payload, tool and limit overrides."""
    spec = scenario.robot
    name = spec.name
    if name.lower() not in builtin_robot_names():
        name = os.path.abspath(base_dir / name)  # a URDF path, relative to the scenario file (not resolved:
        # a symlink loop must reach read_input, which names it)
    limits = None if spec.limits is None else str(base_dir / spec.limits)
    robot = load_robot(name, limits,
                       payload=Payload(spec.payload.mass, spec.payload.com, spec.payload.inertia),
                       tool=Tool(spec.tool.translation, tuple(map(tuple, _rpy(spec.tool.rotation_rpy)))),
                       flange_frame=spec.flange_frame, locked_joints=dict(spec.locked_joints))
    lim = scenario.limits
    changes = {}
    for key in ("velocity", "acceleration", "torque"):
        value = getattr(lim, key)
        if value is not None:
            if len(value) != robot.n:
                raise ScenarioError(f"limits.{key} has {len(value)} values; {robot.name} has {robot.n} joints "
                                    f"{list(robot.joint_names)}")
            changes[key] = np.asarray(value, float)
    if changes:
        robot = robot.with_limits(dataclasses.replace(robot.limits, **changes))
    log.info("robot %s loaded: %d joints %s", robot.name, robot.n, ", ".join(robot.joint_names))
    if changes:
        log.debug("scenario limit overrides: %s", {k: v.tolist() for k, v in changes.items()})
    return robot


def reach_bound(robot: Robot) -> float:
    """An upper bound [m] of the TCP's distance from the base origin: the lengths of the kinematic chain
    (every joint placement, the flange frame and the tool) added up."""
    model = robot.model
    links = sum(float(np.linalg.norm(model.jointPlacements[i].translation)) for i in range(1, model.njoints))
    flange = model.frames[model.getFrameId(robot.flange_frame)].placement.translation
    return links + float(np.linalg.norm(flange)) + float(np.linalg.norm(robot.tool.translation))


# ------------------------------------------------------------------------------------- the paths
def _waypoints_where(spec) -> str:
    """The scenario key a waypoint path's errors name: ``path.file <name>`` or ``path.points``."""
    return f"path.file {spec.file}" if spec.file is not None else "path.points"


def _waypoint_task_path(spec, base_dir: Path) -> tuple[TaskPath, TaskPath | None]:
    """(task path, the path before blends or None) of a ``type = "waypoints"`` path."""
    where = _waypoints_where(spec)
    if spec.file is not None:
        points, orientations = load_waypoints_csv(base_dir / spec.file)
    else:
        points, orientations = np.asarray(spec.points, float), None
    fixed = None
    if spec.orientation is not None:
        if orientations is not None:
            raise ScenarioError(f"{where}: the points carry orientations, so path.orientation must not be given too; "
                                "remove one of them")
        fixed = None if spec.orientation == "down" else np.asarray(spec.orientation, float)
    tol = 0.0 if spec.blend == "optimal" else spec.blend_tolerance  # optimal: searched on the sharp path
    try:
        task = waypoint_path(points, orientations, tol, fixed, where=where)
        sharp = task if tol == 0.0 else waypoint_path(points, orientations, 0.0, fixed, where=where)
        original = sharp if spec.blend_tolerance > 0 else None
    except PathmotionError as exc:
        raise ScenarioError(str(exc)) from exc
    return task, original


def _waypoint_request(spec, task: TaskPath) -> BlendRequest | None:
    """The optimal blends of a waypoint path with ``blend = "optimal"`` (None when it has no corner)."""
    where = _waypoints_where(spec)
    corners = blended_corners(task, where) if spec.blend == "optimal" else []
    if not corners:
        return None
    names = {c: f"{where} (blend_tolerance {spec.blend_tolerance:g} m at waypoint {c + 1})" for c in corners}
    return BlendRequest(task, {}, dict.fromkeys(corners, spec.blend_tolerance), names,
                        searches=dict.fromkeys(corners, spec.search))


def _chosen_blends(spec, task: TaskPath) -> dict[int, int]:
    """{connection index (0-based): k of path.blends[k]} of a segment path."""
    chosen: dict[int, int] = {}
    conns = list(task.connections) + ([task.closure] if task.closure is not None else [])
    for k, blend in enumerate(spec.blends):
        if blend.corner == "all":
            corners = blended_corners(task, f'path.blends[{k}] (corner = "all")', closing=True)
        else:
            if not 1 <= blend.corner <= len(conns):
                closing = (f", {len(conns)} = the closing corner between the last and the first segment"
                           if task.closure is not None else "")
                raise ScenarioError(f"path.blends[{k}].corner = {blend.corner}: the path has {len(conns)} "
                                    f"connection(s), numbered 1..{len(conns)} (1 = between segments 1 and 2"
                                    f"{closing})")
            corners = [blend.corner - 1]
        for c in corners:
            if c in chosen:
                raise ScenarioError(f"path.blends[{k}]: connection {c + 1} is already blended by "
                                    f"path.blends[{chosen[c]}]; give one blend per corner")
            chosen[c] = k
    return chosen


def _segment_task_path(spec) -> tuple[TaskPath, TaskPath | None, BlendRequest | None]:
    """(task path with its blends, or with every corner sharp when optimal blends are asked for; the path
    before blends or None; the optimal blends' request or None) of a segment path."""
    segs = task_segments(spec.segments)
    task = TaskPath(tuple(segs), task_orientation(start_rotation(spec), spec.segments, segs))
    original = task if spec.blends else None
    chosen = _chosen_blends(spec, task)
    blends = {c: (spec.blends[k].type, spec.blends[k].radius if spec.blends[k].type == "circle"
                  else spec.blends[k].tolerance) for c, k in chosen.items()}
    if task.closure is not None and len(task.connections) in blends:
        task = split_first_segment(task, len(task.connections))
    names = {c: f"path.blends[{k}] (corner {c + 1})" for c, k in chosen.items()}
    optimal = {c: v for c, (kind, v) in blends.items() if kind == "optimal"}
    if not optimal:
        return with_blends(task, blends, names), original, None
    # shapes searched with the other corners left sharp, then everything applied in one pass
    others = {c: b for c, b in blends.items() if c not in optimal}
    request = BlendRequest(task, others, optimal, names,
                           planar=tuple(c for c in optimal if spec.blends[chosen[c]].planar),
                           joined=tuple(c for c in optimal if spec.blends[chosen[c]].join_ends),
                           searches={c: spec.blends[chosen[c]].search for c in optimal})
    return task, original, request


def split_first_segment(task: TaskPath, closing: int) -> TaskPath:
    """A closed path whose closing corner (connection ``closing``, 0-based) is to be blended, made to start
    and end in the middle of its first segment: the closing corner becomes an interior connection with the
    same number (segments [second half of 1, 2, ..., N, first half of 1]), and the new closure is smooth.
    Each half of segment 1 is half its length, the share a segment blended at both ends gives each blend."""
    if task.tool_orientation.key_thetas():
        raise ScenarioError(f"path.blends: blending the closing corner (corner {closing + 1}) moves the path's start "
                            "to the middle of segment 1, which would shift the orientation keys; blend the interior "
                            "corners only, or start the path in the middle of a segment")
    first = task.segments[0]
    half = 0.5 * first.length
    segs = (first.trimmed(half, first.length),) + task.segments[1:] + (first.trimmed(0.0, half),)
    return TaskPath(segs, task.tool_orientation)


def _near_waypoint(task: TaskPath, original: TaskPath | None, position) -> str:
    """Where a lift failure at TCP ``position`` (3,) [m] lies among the waypoints: 'at waypoint k' (within
    NEAR_WAYPOINT of it) or 'between waypoints k and k + 1' (0-based, the rows of the list)."""
    pos = np.asarray(position, float)
    ref = original if original is not None else task
    points = np.array([ref.segments[0].start_point] + [s.end_point for s in ref.segments])
    near = np.linalg.norm(points - pos, axis=1)
    if near.min() < NEAR_WAYPOINT:
        return f"at waypoint {int(np.argmin(near))}"
    a, b = points[:-1], points[1:]
    t = np.clip(np.einsum("ij,ij->i", pos - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + t[:, None] * (b - a) - pos, axis=1)))
    return f"between waypoints {k} and {k + 1}"


def lift_task_path(scenario: Scenario, robot: Robot, task: TaskPath, original: TaskPath | None) -> JointPath:
    """The scenario's task path lifted to joint space (from ``path.start_configuration`` when given); a
    waypoint path's errors name the waypoint or the two waypoints the failure lies at or between. A closed
    path not planned as a periodic cycle is an open motion (run once, rest to rest or with given speeds)."""
    spec = scenario.path
    q_start = start_configuration(spec, robot) if spec.type == "task" else (
        None if spec.start_configuration is None else np.asarray(spec.start_configuration, float))
    log.info("lift: IK along the task path (%d segments, %.4g m)", len(task.segments), task.length)
    try:
        path = lift(robot, task, q_start, original=original)
    except UnreachableError as exc:
        if spec.type != "waypoints":
            raise
        where = _waypoints_where(spec)
        if exc.position is not None:
            where = f"{where}: {_near_waypoint(task, original, exc.position)}"
        raise exc.in_context(where) from exc
    log.debug("lifted joint path: theta in [%.6g, %.6g], %d kinks", *path.domain, len(path.kinks))
    if spec.type == "task":
        check_program(spec, robot, path)
    return open_unless_periodic(scenario, path)


def open_unless_periodic(scenario: Scenario, path: JointPath) -> JointPath:
    """``path``, marked open when it is closed but ``plan.periodic`` is off (a closed path run once from
    rest to rest, or with given end speeds, is an open motion)."""
    if path.closed and not scenario.plan.periodic:
        return dataclasses.replace(path, closed=False)
    return path


def _joint_waypoint_path(spec, robot: Robot) -> JointPath:
    counts = [len(w) for w in spec.waypoints]
    if any(c != robot.n for c in counts):
        k = next(i for i, c in enumerate(counts) if c != robot.n)
        raise ScenarioError(f"path.waypoints[{k}] has {counts[k]} joint values; {robot.name} has {robot.n} "
                            f"joints {list(robot.joint_names)}: give {robot.n} values [rad] per waypoint")
    wp = np.asarray(spec.waypoints, dtype=float)
    bad = (wp < robot.limits.lower) | (wp > robot.limits.upper)
    if bad.any():
        k, j = np.argwhere(bad)[0]
        raise ScenarioError(f"path.waypoints[{k}]: joint {robot.joint_names[j]} = {wp[k, j]:g} rad is outside "
                            f"its range [{robot.limits.lower[j]:.4f}, {robot.limits.upper[j]:.4f}]"
                            + degrees_hint(wp, robot.limits.lower, robot.limits.upper))
    return SplineJointPath.from_waypoints(wp, robot.joint_names)


def build_path(scenario: Scenario, robot: Robot, base_dir: str | Path = "."
               ) -> tuple[JointPath | None, TaskPath | None, TaskPath | None, BlendRequest | ChainBlendRequest | None]:
    """(joint path, task path, original task path before blends, optimal blends' request) of the scenario;
    joint path and task path are None when optimal blends are still to be searched, the task path and the
    original are None for a joint path, the request None without optimal blends. ``base_dir``: the folder
    relative file names (a waypoint file) refer to."""
    spec = scenario.path
    if spec.type == "joint":
        return open_unless_periodic(scenario, _joint_waypoint_path(spec, robot)), None, None, None
    if is_chain(spec):  # joint moves or dwells among the segments
        path, chain_request = chain_setup(spec, robot)
        if chain_request is not None:
            return None, None, None, chain_request
        check_program(spec, robot, path)
        return path, path.task_path, path.original_task_path, None
    if spec.type == "waypoints":
        task, original = _waypoint_task_path(spec, Path(base_dir))
        request = _waypoint_request(spec, task)
    else:
        task, original, request = _segment_task_path(spec)
    if request is not None:
        return None, None, original, request
    return lift_task_path(scenario, robot, task, original), task, original, None


# ------------------------------------------------------------------------------------- settings
def plan_settings(scenario: Scenario, torque_reserve: float | None = None) -> PlanSettings:
    """The planner's settings from the scenario; ``torque_reserve`` [-] replaces the scenario's (a
    ``"auto"`` reserve is planned at 0, the search's first run, until the reserve search)."""
    lim, p = scenario.limits, scenario.plan
    if torque_reserve is not None or lim.torque_reserve == AUTO:
        lim = lim.model_copy(update={"torque_reserve": 0.0 if torque_reserve is None else float(torque_reserve)})
    periodic = p.periodic
    return PlanSettings(
        grid_points=p.grid_points, duration_tolerance=p.duration_tolerance, limits=limit_choices(lim),
        start=None if periodic else p.start, end=None if periodic else p.end,
        periodic=periodic, connections=p.connections, verify=p.verify, baselines=True,
    )


# ------------------------------------------------------------------------------------- load
def build(scenario: Scenario, base_dir: str | Path = ".", text: str = "") -> Setup:
    """Turn a validated scenario into a :class:`Setup`: load the robot, build the task path, lift it. No
    planning: optimal blends and an "auto" torque reserve are left to :func:`pathmotion.api.searches.search`."""
    base_dir = Path(base_dir)
    robot = build_robot(scenario, base_dir)
    unit_slips(scenario, reach_bound(robot), defaults.RATED_PAYLOAD.get(scenario.robot.name.lower()), robot.name)
    slip = velocity_slip(robot.limits.velocity, robot.joint_names, "limits.velocity" if scenario.limits.velocity
                         else f"limits of {scenario.robot.limits or scenario.robot.name}")
    if slip:
        log.warning("%s", slip)
    path, task, original, request = build_path(scenario, robot, base_dir)
    return Setup(scenario, text, base_dir, robot, path, task, original, plan_settings(scenario), request)


def load(scenario_path: str | Path, overrides: dict[str, Any] | None = None) -> Setup:
    """Read, validate and build a scenario file (``overrides``: key path -> value)."""
    text = read_input(scenario_path, "scenario")
    return build(parse_scenario(text, str(scenario_path), overrides), Path(scenario_path).parent, text)


def load_text(text: str, base_dir: str | Path = ".", overrides: dict[str, Any] | None = None,
              where: str = "scenario") -> Setup:
    """Validate and build a scenario given as TOML text (``where``: its name in errors)."""
    return build(parse_scenario(text, where, overrides), base_dir, text)
