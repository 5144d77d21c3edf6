"""The Python API the CLI is built on: scenario -> robot -> path -> plan -> simulation -> files.

Each CLI subcommand is a few lines over these functions::

    setup = pathmotion.load("scenarios/circle_horizontal.toml")
    result = pathmotion.plan_scenario(setup)
    pathmotion.write_plan(setup, result, "out/plan")
    sim = pathmotion.simulate_scenario(setup, result)
    pathmotion.write_simulation(setup, result, sim, "out/sim")
"""

from __future__ import annotations

import dataclasses
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .io import schema
from .errors import InfeasibleError, PathmotionError, ScenarioError, UnreachableError
from .geometry import (Arc, Circle, FixedOrientation, Line, TaskPath, blended_corners, max_deviation, waypoint_path,
                       with_blends)
from . import defaults
from .io import exports
from .io.atomic import write_json, write_text
from .io.files import read_input
from .io.scenario import Scenario, parse_scenario, unit_slips
from .io.waypoints import load_waypoints_csv
from .lift.joint_path import JointPath, SplineJointPath
from .lift.constraint import lift
from .planning import PlanResult, PlanSettings, plan
from .planning.limits import REGISTRY as LIMIT_REGISTRY, limit_choices
from .robot import Payload, Robot, Tool, builtin_robot_names, fk, load_robot
from .robot.arm import arm_points
from .reserve_search import AUTO, ReserveSearch, ReserveTrial, Verdict, search_reserve

log = logging.getLogger(__name__)

#: Largest difference between a circle's given radius and its centre-to-start distance [m]
#: (a scenario's numbers are typed by hand: 1 um is far below any path tolerance, far above round-off).
RADIUS_MATCH = 1e-6
#: |dq/dtheta| / qd_max below which a path point is treated as not moving the joints [s/rad-of-theta]
#: (its velocity-limited theta_dot is then 1e12, i.e. unlimited).
STILL_PATH_SPEED = 1e-12


@dataclass(frozen=True, eq=False)
class Setup:
    """A validated scenario turned into objects: robot, joint path (and the task path it came
    from, and the path before blends), planner and simulation settings. With ``torque_reserve = "auto"``
    the plan settings hold the reserve the search chose (:func:`resolve_torque_reserve`),
    ``reserve_search`` its record and ``reserve_run`` the (plan, simulation or None) of that reserve, which
    :func:`plan_scenario` and :func:`simulate_scenario` return instead of running again."""

    scenario: Scenario
    scenario_text: str
    base_dir: Path
    robot: Robot
    path: JointPath
    task_path: TaskPath | None
    original_task_path: TaskPath | None
    plan_settings: PlanSettings
    reserve_search: ReserveSearch | None = None
    reserve_run: tuple | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.scenario.name


# ------------------------------------------------------------------------------------- building
#: Largest share of a neighbouring segment a RAPID zone may cut (below half: two zones never meet).
RAPID_ZONE_CUT = 0.49


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


def _segments(specs) -> list:
    segs = []
    prev_end = None
    for k, s in enumerate(specs):
        where = f"path.segments[{k}]"
        start = s.start if getattr(s, "start", None) is not None else prev_end
        try:
            if s.type == "line":
                if start is None:
                    raise ScenarioError(f"{where}: the first line needs a start point")
                seg = Line(start, s.end)
            elif s.type == "arc":
                if start is None:
                    raise ScenarioError(f"{where}: the first arc needs a start point")
                seg = Arc(np.asarray(s.center, float), np.asarray(start, float), np.asarray(s.normal, float),
                          float(s.sweep))
            else:  # circle: through the given or previous end point, else at start_angle
                if start is not None:
                    seg = Circle(np.asarray(s.center, float), np.asarray(start, float), np.asarray(s.normal, float))
                else:
                    seg = Circle.from_centre(s.center, s.radius, s.normal, s.start_angle)
                if abs(seg.radius - s.radius) > RADIUS_MATCH:
                    raise ScenarioError(f"{where}: the start point is {seg.radius:.6g} m from the centre, not the "
                                        f"radius {s.radius:.6g} m; fix radius or centre")
        except PathmotionError as exc:
            if isinstance(exc, ScenarioError):
                raise
            raise type(exc)(f"{where}: {exc}") from None
        segs.append(seg)
        prev_end = seg.end_point
    return segs


def _waypoint_task_path(spec, base_dir: Path) -> tuple[TaskPath, TaskPath | None, str]:
    """(task path, the path before blends or None, where) of a ``type = "waypoints"`` path."""
    if spec.file is not None:
        where = f"path.file {spec.file}"
        points, orientations = load_waypoints_csv(base_dir / spec.file)
    else:
        where, points, orientations = "path.points", np.asarray(spec.points, float), None
    fixed = None
    if spec.orientation is not None:
        if orientations is not None:
            raise ScenarioError(f"{where}: the points carry orientations, so path.orientation must not be given too; "
                                "remove one of them")
        fixed = None if spec.orientation == "down" else np.asarray(spec.orientation, float)
    tol = 0.0 if spec.blend == "optimal" else spec.blend_tolerance  # optimal: searched on the sharp path (build_path)
    try:
        task = waypoint_path(points, orientations, tol, fixed, where=where)
        sharp = task if tol == 0.0 else waypoint_path(points, orientations, 0.0, fixed, where=where)
        original = sharp if spec.blend_tolerance > 0 else None
    except PathmotionError as exc:
        raise ScenarioError(str(exc)) from None
    return task, original, where


def build_path(scenario: Scenario, robot: Robot,
               base_dir: str | Path = ".") -> tuple[JointPath, TaskPath | None, TaskPath | None]:
    """(joint path, task path or None, original task path before blends or None); ``base_dir``: the folder
    relative file names (a waypoint file) refer to."""
    spec = scenario.path
    if spec.type == "waypoints":
        task, original, where = _waypoint_task_path(spec, Path(base_dir))
        corners = blended_corners(task, where) if spec.blend == "optimal" else []
        if corners:
            names = {c: f"{where} (blend_tolerance {spec.blend_tolerance:g} m at waypoint {c + 1})" for c in corners}
            shapes = _optimal_shapes(robot, task, dict.fromkeys(corners, spec.blend_tolerance), scenario, names,
                                     searches=dict.fromkeys(corners, spec.search))
            task = with_blends(task, {c: ("g2_shape", shape) for c, shape in shapes.items()}, names)
        q_start = None if spec.start_configuration is None else np.asarray(spec.start_configuration, float)
        try:
            return lift(robot, task, q_start, original=original), task, original
        except UnreachableError as exc:
            raise UnreachableError(f"{where}: {_near_waypoint(task, original, exc)}{exc}", index=exc.index,
                                   reason=exc.reason) from None
    if spec.type == "joint":
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
                                f"its range [{robot.limits.lower[j]:.4f}, {robot.limits.upper[j]:.4f}]")
        return SplineJointPath.from_waypoints(wp, robot.joint_names), None, None
    orientation = FixedOrientation() if spec.orientation == "down" else FixedOrientation(
        np.asarray(spec.orientation, float))
    task = TaskPath(tuple(_segments(spec.segments)), orientation)
    original = task if spec.blends else None
    chosen: dict[int, int] = {}  # connection index (0-based) -> k of path.blends[k]
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
    blends = {c: (spec.blends[k].type, spec.blends[k].radius if spec.blends[k].type == "circle"
                  else spec.blends[k].tolerance) for c, k in chosen.items()}
    if task.closure is not None and len(task.connections) in blends:
        task = _split_first_segment(task, len(task.connections))
    names = {c: f"path.blends[{k}] (corner {c + 1})" for c, k in chosen.items()}
    optimal = {c: v for c, (kind, v) in blends.items() if kind == "optimal"}
    if optimal:  # shapes searched with the other corners left sharp, then everything applied in one pass
        shapes = _optimal_shapes(robot, task, optimal, scenario, names,
                                 planar=[c for c in optimal if spec.blends[chosen[c]].planar],
                                 joined=[c for c in optimal if spec.blends[chosen[c]].join_ends],
                                 searches={c: spec.blends[chosen[c]].search for c in optimal})
        blends.update({c: ("g2_shape", shape) for c, shape in shapes.items()})
    task = with_blends(task, blends, names)
    q_start = None if spec.start_configuration is None else np.asarray(spec.start_configuration, float)
    log.info("lift: IK along the task path (%d segments, %.4g m, %d blended corners)", len(task.segments),
             task.length, len(blends))
    path = lift(robot, task, q_start, original=original)
    log.debug("lifted joint path: theta in [%.6g, %.6g], %d kinks", *path.domain, len(path.kinks))
    return path, task, original


def _optimal_shapes(robot: Robot, task: TaskPath, optimal: dict[int, float], scenario: Scenario,
                    names: dict[int, str], planar=(), joined=(), searches: dict[int, str] | None = None) -> dict:
    """{connection index: G2Shape} of the optimal blends (planning/blend_search.py) within ``optimal``
    {connection index: tolerance [m]} of ``task`` under the scenario's plan settings, each corner searched as
    ``searches`` names it ("fast" by default; the corners are independent, so each kind is one search, on
    plan.workers processes); errors prefixed with ``names`` (the scenario keys)."""
    from .planning.blend_search import SEARCHES, optimal_blends

    spec = scenario.path
    q0 = None if spec.start_configuration is None else np.asarray(spec.start_configuration, float)
    searches = searches or dict.fromkeys(optimal, "fast")
    shapes: dict = {}
    for kind in sorted(set(searches.values())):
        mine = {c: t for c, t in optimal.items() if searches[c] == kind}
        try:
            found = optimal_blends(robot, task, mine, list(mine), plan_settings(scenario), q0, search=SEARCHES[kind],
                                   planar=[c for c in planar if c in mine], joined_ends=[c for c in joined if c in mine],
                                   names=names, workers=scenario.plan.workers)
        except PathmotionError as exc:
            if str(exc).startswith(tuple(names.values())):
                raise
            where = "; ".join(names[c] for c in sorted(mine))  # e.g. a blended path out of reach: all of them
            raise type(exc)(f"{where}: {exc}") from None
        shapes.update(found.shapes)
    return shapes


def _split_first_segment(task: TaskPath, closing: int) -> TaskPath:
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


def _near_waypoint(task: TaskPath, original: TaskPath | None, exc: UnreachableError) -> str:
    """Where a lift failure lies among the waypoints: 'at waypoint k: ' (within 1 mm of it) or 'between
    waypoints k and k + 1: ' (0-based, the rows of the list), from the position the lift's message names."""
    import re

    found = re.search(r"position \(([-\d.e+]+), ([-\d.e+]+), ([-\d.e+]+)\) m", str(exc))
    if not found:
        return ""
    pos = np.array([float(v) for v in found.groups()])
    ref = original if original is not None else task
    points = np.array([ref.segments[0].start_point] + [s.end_point for s in ref.segments])
    near = np.linalg.norm(points - pos, axis=1)
    if near.min() < 1e-3:
        return f"at waypoint {int(np.argmin(near))}: "
    a, b = points[:-1], points[1:]
    t = np.clip(np.einsum("ij,ij->i", pos - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + t[:, None] * (b - a) - pos, axis=1)))
    return f"between waypoints {k} and {k + 1}: "


def plan_settings(scenario: Scenario, torque_reserve: float | None = None) -> PlanSettings:
    """The planner's settings from the scenario; ``torque_reserve`` [-] replaces the scenario's (a
    ``"auto"`` reserve is planned at 0, the search's first run, until :func:`resolve_torque_reserve`)."""
    lim, p = scenario.limits, scenario.plan
    if torque_reserve is not None or lim.torque_reserve == AUTO:
        lim = lim.model_copy(update={"torque_reserve": 0.0 if torque_reserve is None else float(torque_reserve)})
    periodic = p.periodic
    return PlanSettings(
        grid_points=p.grid_points, tolerance=p.tolerance, limits=limit_choices(lim),
        start=None if periodic else p.start, end=None if periodic else p.end,
        periodic=periodic, connections=p.connections, verify=p.verify, baselines=True,
    )


def reach_bound(robot: Robot) -> float:
    """An upper bound [m] of the TCP's distance from the base origin: the lengths of the kinematic chain
    (every joint placement, the flange frame and the tool) added up."""
    model = robot.model
    links = sum(float(np.linalg.norm(model.jointPlacements[i].translation)) for i in range(1, model.njoints))
    flange = model.frames[model.getFrameId(robot.flange_frame)].placement.translation
    return links + float(np.linalg.norm(flange)) + float(np.linalg.norm(robot.tool.translation))


def build(scenario: Scenario, base_dir: str | Path = ".", text: str = "") -> Setup:
    """Turn a validated scenario into a :class:`Setup` (loads the robot, lifts the path)."""
    base_dir = Path(base_dir)
    robot = build_robot(scenario, base_dir)
    unit_slips(scenario, reach_bound(robot), defaults.RATED_PAYLOAD.get(scenario.robot.name.lower()), robot.name)
    path, task, original = build_path(scenario, robot, base_dir)
    if path.closed and not scenario.plan.periodic:
        # a closed path run once from rest to rest (or with given end speeds) is an open motion
        path = dataclasses.replace(path, closed=False)
    setup = Setup(scenario, text, base_dir, robot, path, task, original, plan_settings(scenario))
    return resolve_torque_reserve(setup) if scenario.limits.torque_reserve == AUTO else setup


def load(scenario_path: str | Path, overrides: dict[str, Any] | None = None) -> Setup:
    """Read, validate and build a scenario file (``overrides``: key path -> value)."""
    text = read_input(scenario_path, "scenario")
    return build(parse_scenario(text, str(scenario_path), overrides), Path(scenario_path).parent, text)


def load_text(text: str, base_dir: str | Path = ".", overrides: dict[str, Any] | None = None,
              where: str = "scenario") -> Setup:
    return build(parse_scenario(text, where, overrides), base_dir, text)


# ------------------------------------------------------------------------------------- planning
def plan_scenario(setup: Setup) -> PlanResult:
    """The time-optimal plan of the scenario (with baselines and verification); with
    ``plan.blend_speed_scale`` < 1 the blends are then slowed to that fraction (verified). A setup whose
    reserve search ran returns the plan of the chosen reserve, planned then."""
    if setup.reserve_run is not None:
        return setup.reserve_run[0]
    result = plan(setup.path, setup.robot, setup.plan_settings)
    scale = setup.scenario.plan.blend_speed_scale
    if scale != 1.0:
        from .planning.blend_speed import cap_blend_speed

        log.info("slowing the blends to %g of their optimal speed", scale)
        result = cap_blend_speed(setup, result, scale)
    return result


# ---------------------------------------------------------------------- torque_reserve = "auto"
def resolve_torque_reserve(setup: Setup) -> Setup:
    """``torque_reserve = "auto"``: ``setup`` with the smallest reserve whose plan tracks in the scenario's
    own closed loop (its controller, realism and tolerances), found by :func:`search_reserve` over plan +
    simulate runs. When none tracks: the largest reserve that could be planned, and the search's failure,
    which :func:`plan_failures` reports (a failed result)."""
    runs: dict[float, tuple] = {}
    log.info("torque_reserve = auto: searching [0, %g] in steps of %g with the scenario's closed loop (%s)",
             defaults.AUTO_RESERVE_MAX, defaults.AUTO_RESERVE_STEP, setup.scenario.simulate.controller)
    search = search_reserve(lambda reserve: _reserve_trial(setup, reserve, runs))
    reserve = search.applied
    return dataclasses.replace(setup, plan_settings=plan_settings(setup.scenario, reserve), reserve_search=search,
                               reserve_run=runs[reserve])


def _reserve_trial(setup: Setup, reserve: float, runs: dict) -> ReserveTrial:
    """Plan and simulate ``setup`` with the torque reserve ``reserve`` [-]; (plan, simulation or None) go
    into ``runs[reserve]``. An infeasible plan is a verdict above reserve 0 (less reserve is needed); at 0
    it is the scenario's own error and propagates, as do errors of the simulation's set-up."""
    trial = dataclasses.replace(setup, plan_settings=plan_settings(setup.scenario, reserve))
    try:
        result = plan_scenario(trial)
    except InfeasibleError as exc:
        if reserve == 0:
            raise
        return ReserveTrial(reserve, Verdict.INFEASIBLE, reason=str(exc))
    failures = plan_failures(result)
    if failures:
        runs[reserve] = (result, None)
        return ReserveTrial(reserve, Verdict.FAILS, "the plan failed: " + "; ".join(failures), result.duration)
    sim = simulate_scenario(trial, result)
    runs[reserve] = (result, sim)
    summary = sim.summary()
    reason = tracking_failure(summary)
    return ReserveTrial(reserve, Verdict.FAILS if reason else Verdict.TRACKS, reason, result.duration,
                        summary[schema.CYCLE_TIME.key], summary[schema.PATH_ACCURACY.key])


def tracking_failure(sim_summary: dict) -> str:
    """Why a simulation summary's closed loop failed, "tracking failed: <its failure message>" ("" when it
    tracked): the line that joins a simulate run's failures and the reserve search's reasons."""
    if sim_summary.get(schema.TRACKING_OK.key, True):
        return ""
    failure = sim_summary.get(schema.FAILURE.key)
    return "tracking failed" + (f": {failure['message']}" if failure else "")


def reserve_summary(setup: Setup) -> dict:
    """summary.json's record of a reserve search ({} without one): the reserve applied and every run."""
    search = setup.reserve_search
    if search is None:
        return {}
    return {"torque_reserve": search.applied, schema.TORQUE_RESERVE_SEARCH.key: search.records()}


def plan_summary(setup: Setup, result: PlanResult) -> dict:
    """The contract keys of ``summary.json`` (issue 4) plus context."""
    r = result.ratios
    b = result.baselines
    out = {
        schema.SCENARIO.key: setup.name,
        schema.ROBOT.key: setup.robot.name,
        schema.PATH_LENGTH.key: float(setup.path.length),
        schema.PATH_KIND.key: "task" if setup.task_path is not None else "joint",
        schema.DURATION.key: result.profile.duration,
        schema.SOLVE_TIME.key: result.solve_time_s,
        schema.GRID_POINTS.key: result.grid_points,
        schema.DURATION_ERROR_ESTIMATE.key: result.duration_error_estimate,
        **({cls.summary_key(): None for cls in LIMIT_REGISTRY} if r is None else r.summary()),
        **limit_settings_summary(setup.robot, result.settings),
        schema.WORST_LIMIT.key: None if r is None else r.worst,
        schema.VERIFY_METHOD.key: None if r is None else r.method,
        schema.BASELINE_DURATION.key: (None if b is None or b.constant_speed is None
                                       else b.constant_speed.profile.duration),
        schema.FITTED_DURATION.key: None if b is None or b.fitted is None else b.fitted.profile.duration,
        schema.BASELINE_ERROR.key: None if b is None else b.constant_speed_error,
        "connections": setup.plan_settings.connections,
        schema.VELOCITY_JUMPS.key: [list(j) for j in result.jump_intervals],
        schema.KINKS.key: list(setup.path.kinks),
    }
    if setup.original_task_path is not None and setup.task_path is not None:
        out[schema.BLEND_MAX_DEVIATION.key] = max_deviation(setup.task_path, setup.original_task_path).distance
    if setup.scenario.rapid is not None and setup.task_path is not None:
        out[schema.RAPID_ESTIMATE.key] = _rapid_estimate(setup)
    check = getattr(setup.path, "check", None)
    if check is not None:
        out[schema.MIN_SINGULAR_VALUE.key] = check.min_singular_value
        out[schema.JOINT_RANGE_MARGIN.key] = check.range_margin
        prof = result.profile
        out[schema.WRIST_CROSSINGS.key] = [
            {**ps.summary(), "planned_speed_m_s": float(np.sqrt(np.interp(ps.theta, prof.grid, prof.x)))}
            for ps in check.wrist_passages]
    out.update(reserve_summary(setup))
    return out


def limit_settings_summary(robot: Robot, settings: PlanSettings) -> dict:
    """The limits' settings keys of summary.json (e.g. torque_reserve), from the limits the plan enforced,
    verified or not; null where the limit is off."""
    from .planning import effective_limits

    out = {key: None for cls in LIMIT_REGISTRY for key in cls.extra_summary_keys}
    for lim in effective_limits(robot, settings):
        out.update(lim.summary_values())
    return out


def rapid_zone_tolerances(program) -> list:
    """G2 blend tolerance [m] per corner of an imported RAPID program (io.rapid.RapidProgram): the deviation of
    the blend that starts at the zone radius from the target (ABB's corner path starts where the TCP enters the
    zone), the cut kept below RAPID_ZONE_CUT of each neighbour so a segment between two zones keeps a straight
    middle; None at fine points and where the moves join without a corner."""
    from .geometry.blends import g2_deviation
    from .io.rapid import effective_zones, segments

    segs = [Line(start, mv.point) if arc is None else Arc(arc.center, start, arc.normal, arc.sweep)
            for mv, start, arc, _ in segments(program)]
    path = TaskPath(tuple(segs), FixedOrientation())
    out = []
    for k, zone in enumerate(effective_zones(program)):
        A, B = path.segments[k], path.segments[k + 1]
        cut = min(zone, RAPID_ZONE_CUT * A.length, RAPID_ZONE_CUT * B.length)
        usable = path.connections[k].kind in ("corner", "tangent") and cut > 0
        out.append(g2_deviation(A, B, cut).upper if usable else None)
    return out


def _rapid_estimate(setup: Setup) -> float:
    """The RAPID program's constant-speed duration on the path before blends (io.rapid.rapid_estimate_s)."""
    from .io.rapid import rapid_estimate_s

    path = setup.original_task_path if setup.original_task_path is not None else setup.task_path
    spec = setup.scenario.rapid
    return rapid_estimate_s([s.length for s in path.segments], spec.speeds, spec.zones,
                            [c.angle for c in path.connections])


def write_plan(setup: Setup, result: PlanResult, out: str | Path, failures: list[str] | None = None,
               force_exports: bool = False) -> dict:
    """Write trajectory.csv/.parquet, summary.json, phase_plane.csv, the exports and the data the
    report and the figures read (limits.json, arm.csv, tcp_path.csv, original_path.csv); figures are
    drawn from these files by :mod:`pathmotion.report.figures`. ``failures`` (default
    :func:`plan_failures`) go into summary.json; the exports of a failed plan are written only with
    ``force_exports``, then with a warning header."""
    out = Path(out)
    log.info("writing the plan to %s", out)
    out.mkdir(parents=True, exist_ok=True)
    samples = result.trajectory.sample(setup.scenario.plan.sample_time)
    exports.write_trajectory_csv(out / "trajectory.csv", samples)
    exports.write_trajectory_parquet(out / "trajectory.parquet", samples)
    failures = plan_failures(result, setup) if failures is None else list(failures)
    notes = _write_exports(setup, samples, out, failures, force_exports)
    second = second_order_plan(setup, result)
    exports.write_table_csv(out / schema.PHASE_PLANE_FILE, phase_plane_columns(result, setup, second))
    write_report_data(setup, out, samples.t, samples.q)
    idx = exports.decimate(len(samples.t))
    tcp = fk(setup.robot, samples.q[idx])[0]
    exports.write_table_csv(out / "tcp_path.csv", {"t": samples.t[idx], **{f"tcp_{a}": tcp[:, k]
                                                                          for k, a in enumerate("xyz")}})
    if setup.scenario_text:
        write_text(out / "scenario.toml", setup.scenario_text)
    summary = plan_summary(setup, result)
    summary[schema.SECOND_ORDER_DURATION.key] = None if second is None else second.duration
    summary[schema.FAILURES.key] = failures
    summary[schema.EXPORT_NOTES.key] = notes
    write_json(out / "summary.json", summary)
    return summary


def plan_failures(result: PlanResult, setup: Setup | None = None) -> list[str]:
    """Why the planned motion must not be run as it is (empty when it may): a jump in the path speed
    (theta_dot) at a connection, a limit exceeded by more than LIMIT_TOLERANCE on the verification
    resample (a kink crossed at speed makes the acceleration and torque unbounded), and with ``setup``:
    a ``torque_reserve = "auto"`` search that found no reserve with which the closed loop tracks."""
    out = [f"the path speed jumps at theta = {a:.6g} .. {b:.6g} (a 'max' connection)"
           for a, b in result.jump_intervals]
    r = result.ratios
    if r is not None and not r.within():
        out.append(f"a limit is exceeded: {r.worst}")
    if setup is not None and setup.reserve_search is not None and not setup.reserve_search.ok:
        out.append(setup.reserve_search.failure())
    return out


def _write_exports(setup: Setup, samples, out: Path, failures: list[str], force: bool) -> list[str]:
    """The ROS 2, EGM and RAPID exports, each headed by :func:`exports.export_notes`; for a failed plan
    none (stale ones removed) unless ``force``. Returns the notes ([] when refused)."""
    if failures and not force:
        for name in exports.EXPORT_FILES:
            (out / name).unlink(missing_ok=True)
        return []
    notes, abb = exports.export_notes(samples, failures), exports.export_notes(samples, failures, degrees=True)
    ros, egm, rapid = (out / name for name in exports.EXPORT_FILES)
    exports.write_ros2_yaml(ros, samples, setup.robot.joint_names, setup.scenario.plan.sample_time, notes=notes)
    exports.write_egm_csv(egm, samples, notes=abb)
    exports.write_rapid(rapid, samples, notes=abb)
    return notes


def write_report_data(setup: Setup, out: Path, t: np.ndarray, q: np.ndarray) -> None:
    """limits.json (joint names, limits, the plan's scales), arm.csv (the arm's stick figure at
    REPORT_ARM_FRAMES of the times t (N,) [s] with joint positions q (N, n) [rad]) and, when blends
    replaced corners, original_path.csv (the sharp path, x, y, z [m])."""
    ps = setup.plan_settings
    scales = {"velocity": ps.velocity_scale if ps.velocity else None,
              "acceleration": ps.acceleration_scale if ps.acceleration else None,
              "torque": ps.torque_scale if ps.torque else None}
    record = exports.limits_record(setup.robot.joint_names, setup.robot.limits, scales)
    record["enforced"] = enforced_limits(setup.robot, ps)
    write_json(out / "limits.json", record)
    idx = exports.decimate(len(t), defaults.REPORT_ARM_FRAMES)
    exports.write_table_csv(out / "arm.csv", exports.arm_columns(t[idx], arm_points(setup.robot, q[idx])))
    task = setup.original_task_path
    if task is not None:
        points = np.asarray(task.evaluate(np.linspace(*task.domain, defaults.REPORT_MAX_POINTS))[0])[:, :3]
        exports.write_table_csv(out / "original_path.csv", {a: points[:, k] for k, a in enumerate("xyz")})


def enforced_limits(robot: Robot, settings: PlanSettings) -> dict:
    """limits.json's "enforced": {limit name: ``Limit.enforced()``} for every active limit, SI units:
    per-joint lists (velocity, acceleration, torque with its reserve and scale, jerk, torque rate), one
    number (TCP speed), {"knee", "at_max_speed"} per joint (the torque-speed envelope)."""
    from .planning import effective_limits

    return {lim.name: lim.enforced() for lim in effective_limits(robot, settings)}


def phase_plane_columns(result: PlanResult, setup: Setup | None = None,
                        second: PlanResult | None = None) -> dict[str, np.ndarray]:
    """phase_plane.csv (column names in io/schema.py): theta (the planner's grid), the planner's limit
    curves, the profiles (optimal, fitted, constant speed) as theta_dot; with ``setup``, each active
    limit's own maximum-velocity curve and each third-order limit's steady-speed curve
    (planning/limit_curves.py); with ``second`` (the plan without the third-order limits,
    :func:`second_order_plan`), its profile."""
    from .planning.limit_curves import X_UNBOUNDED, limit_curves, steady_curves

    grid = result.profile.grid
    cols = {schema.PHASE_THETA: grid, schema.PHASE_OPTIMAL: np.sqrt(result.profile.x)}
    c = result.curves
    for key, x in ((schema.PHASE_POINTWISE, c.x_max), (schema.PHASE_CONTROLLABLE, c.x_controllable)):
        cols[key] = np.sqrt(np.maximum(np.interp(grid, c.grid, np.minimum(x, X_UNBOUNDED)), 0))
    b = result.baselines
    if b is not None:
        for key, base in ((schema.PHASE_FITTED, b.fitted), (schema.PHASE_CONSTANT_SPEED, b.constant_speed)):
            if base is not None:
                cols[key] = base.profile.theta_dot_at(grid)
    if second is not None:
        cols[schema.PHASE_SECOND_ORDER] = second.profile.theta_dot_at(grid)
    if setup is not None:
        for name, curve in limit_curves(setup.path, setup.robot, result.settings, grid).items():
            cols[schema.limit_curve_column(name)] = curve
        for name, curve in steady_curves(setup.path, setup.robot, result.settings, grid).items():
            cols[schema.steady_curve_column(name)] = curve
    return cols


def second_order_plan(setup: Setup, result: PlanResult) -> PlanResult | None:
    """With jerk or torque-rate limits on: the verified plan under the same limits and grid without them
    (what those limits cost, for the phase plane and the summary); None when none is on."""
    from .planning import effective_limits

    settings = result.settings
    if not effective_limits(setup.robot, settings).third_order:
        return None
    limits = {cls.name: dataclasses.replace(settings.choice(cls), on=False) if cls.order == 3 else settings.choice(cls)
              for cls in LIMIT_REGISTRY}
    log.info("the plan without the jerk and torque-rate limits, for comparison")
    return plan(setup.path, setup.robot, dataclasses.replace(settings, limits=limits, baselines=False))


# ----------------------------------------------------------------------------------- simulation
def simulation_settings(setup: Setup):
    from .control import OrbitalGains, TrackingGains
    from .simulation import Realism, SimulationSettings

    sim = setup.scenario.simulate
    rs = sim.realism
    realism_kwargs = dict(inertia_error=rs.inertia_error, payload_mass=rs.payload_mass,
                          viscous_friction=rs.viscous_friction, coulomb_friction=rs.coulomb_friction,
                          encoder_resolution=rs.encoder_resolution, position_noise=rs.position_noise,
                          velocity_noise=rs.velocity_noise, delay=rs.delay, seed=rs.seed)
    if rs.payload_com is not None:
        realism_kwargs["payload_com"] = rs.payload_com
    kwargs = dict(sample_time=sim.sample_time, substeps=sim.substeps, realism=Realism(**realism_kwargs),
                  path_tolerance=sim.path_tolerance, joint_tolerance=sim.joint_tolerance,
                  saturation_limit=sim.saturation_limit, laps=sim.laps, plant=sim.plant,
                  sampled_design=sim.sampled_design, identify_payload=sim.identify_payload)
    if sim.gains:
        cls, field = (OrbitalGains, "orbital_gains") if sim.controller == "orbital" else (
            TrackingGains, "computed_torque_gains" if sim.controller == "computed_torque" else "pd_gains")
        allowed = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(sim.gains) - set(allowed))
        if unknown:
            raise ScenarioError(f"simulate.gains: unknown gain(s) {unknown} for controller {sim.controller!r}; "
                                f"allowed: {allowed}")
        base = getattr(SimulationSettings(), field)
        kwargs[field] = dataclasses.replace(base, **sim.gains)
    return SimulationSettings(**kwargs)


def simulate_scenario(setup: Setup, result: PlanResult):
    """Closed-loop simulation of the planned motion with the scenario's controller and plant (the reserve
    search's run when ``result`` is the plan it chose)."""
    from .simulation import simulate

    run = setup.reserve_run
    if run is not None and result is run[0] and run[1] is not None:
        return run[1]
    settings = simulation_settings(setup)
    return simulate(setup.robot, setup.path, result.profile, setup.scenario.simulate.controller, settings)


def simulation_summary(setup: Setup, result: PlanResult, sim) -> dict:
    summary = dict(sim.summary())
    summary["controller"] = setup.scenario.simulate.controller
    summary[schema.PLANT.key] = setup.scenario.simulate.plant
    summary[schema.PLANNED_DURATION.key] = result.profile.duration
    summary.update(reserve_summary(setup))
    return summary


def write_simulation(setup: Setup, result: PlanResult, sim, out: str | Path) -> dict:
    """Write simulation.csv/.parquet, summary.json (plan and simulation keys) and the report's data
    (limits.json, arm.csv, original_path.csv; see :func:`write_report_data`)."""
    out = Path(out)
    log.info("writing the simulation to %s", out)
    out.mkdir(parents=True, exist_ok=True)
    cols = simulation_columns(sim)
    exports.write_table_csv(out / "simulation.csv", cols)
    exports.write_table_parquet(out / "simulation.parquet", cols)
    write_report_data(setup, out, sim.t, sim.q)
    summary = {"plan": plan_summary(setup, result)}
    summary.update(simulation_summary(setup, result, sim))
    if setup.scenario_text:
        write_text(out / "scenario.toml", setup.scenario_text)
    write_json(out / "summary.json", summary)
    return summary


def simulation_columns(sim) -> dict[str, np.ndarray]:
    """simulation.csv columns: t, theta, q1..n, qd1..n, tau1..n, q_desired1..n, tcp xyz, desired tcp xyz,
    deviations (path_deviation; sharp_deviation: from the original sharp path, blended paths only)."""
    cols = {"t": sim.t, "theta": sim.theta}
    n = sim.q.shape[1]
    for name, arr in (("q", sim.q), ("qd", sim.qd), ("tau", sim.tau), ("q_desired", sim.q_desired)):
        cols.update({f"{name}{j + 1}": arr[:, j] for j in range(n)})
    for name, arr in (("tcp", sim.tcp), ("tcp_desired", sim.tcp_desired)):
        cols.update({f"{name}_{a}": arr[:, k] for k, a in enumerate("xyz")})
    cols["joint_deviation"] = sim.joint_deviation
    cols["path_deviation"] = sim.path_deviation
    if sim.corner_deviation is not None:
        cols["sharp_deviation"] = sim.corner_deviation
    return cols


# ------------------------------------------------------------------------------------ check
def path_is_closed(setup: Setup) -> bool:
    """Whether the path ends where it starts (a full circle does), whether or not it is planned as a
    periodic cycle (``plan.periodic``; a closed path run once is planned as an open motion)."""
    if setup.task_path is not None:
        return bool(setup.task_path.closed)
    q = setup.path.evaluate(np.array(setup.path.domain, float))[0]
    return bool(np.allclose(q[0], q[-1], rtol=0, atol=defaults.PATH_GAP_TOLERANCE))


def check_scenario(setup: Setup) -> dict:
    """What ``pathmotion check`` reports: the path lifted (reachable, in range, away from
    singularities: errors otherwise), its corners, pointwise feasibility (gravity torque below the
    limits, the largest admissible speed > 0 everywhere), and every test plan and simulate run before
    they write (the plan is solved, nothing is written): an OK means plan and simulate start."""
    from .planning.reduced import reduced_dynamics

    path, robot = setup.path, setup.robot
    out: dict[str, Any] = {schema.SCENARIO.key: setup.name, schema.ROBOT.key: robot.name, "joints": robot.n,
                           schema.PATH_KIND.key: "task" if setup.task_path is not None else "joint",
                           schema.PATH_LENGTH.key: float(path.length), "closed": path_is_closed(setup),
                           "periodic": bool(setup.scenario.plan.periodic)}
    if setup.task_path is not None:
        out["segments"] = len(setup.task_path.segments)
        out["connections"] = [c.describe() for c in setup.task_path.connections]
    out["sharp_corners_theta"] = list(path.kinks)
    check = getattr(path, "check", None)
    if check is not None:
        out[schema.MIN_SINGULAR_VALUE.key] = check.min_singular_value
        out["min_singular_value_theta"] = check.min_singular_theta
        out[schema.JOINT_RANGE_MARGIN.key] = check.range_margin
        out["joint_range_margin_joint"] = check.range_margin_joint
        out[schema.WRIST_CROSSINGS.key] = [ps.summary() for ps in check.wrist_passages]
    theta = np.linspace(*path.domain, 400)
    q, dq, ddq = path.evaluate(theta)
    if setup.plan_settings.torque:
        red = reduced_dynamics(robot, q, dq, ddq)
        ratio = np.abs(red.gamma) / robot.limits.torque / setup.plan_settings.torque_scale
        k, j = np.unravel_index(np.argmax(ratio), ratio.shape)
        out["max_gravity_torque_ratio"] = float(ratio[k, j])
        if ratio[k, j] >= 1:
            from .errors import InfeasibleError

            raise InfeasibleError(f"gravity torque of {robot.joint_names[j]} at theta = {theta[k]:.4f} is "
                                  f"{abs(red.gamma[k, j]):.1f} N m, above its limit "
                                  f"{robot.limits.torque[j] * setup.plan_settings.torque_scale:.1f} N m; "
                                  "raise the torque limit or move the path")
    if setup.plan_settings.velocity:
        speed = np.abs(dq) / robot.limits.velocity / setup.plan_settings.velocity_scale
        peak = np.max(speed, axis=1)
        vmax = 1.0 / np.maximum(peak, STILL_PATH_SPEED)
        out["min_velocity_limited_theta_dot"] = float(np.min(vmax))
    out.update(_check_like_plan_and_simulate(setup))
    return out


def _check_like_plan_and_simulate(setup: Setup) -> dict:
    """Every test ``plan`` and ``simulate`` run before they write, so that check's OK means OK: the plan
    itself (its boundary, limit and tightening checks), the trajectory's sample count at
    plan.sample_time, the simulation settings (gains, realism), the closed loop's sample budget and
    the loop's set-up (the controller's design, e.g. the orbital Riccati sweep, through the design
    cache, which simulate then reads; the plant)."""
    from .planning.trajectory import sample_times
    from .simulation import prepare_loop

    result = plan_scenario(setup)
    sample_times(result.profile.duration, setup.scenario.plan.sample_time)
    settings = simulation_settings(setup)
    prepare_loop(setup.robot, setup.path, result.profile, setup.scenario.simulate.controller, settings)
    return {schema.DURATION.key: float(result.profile.duration),
            schema.WORST_LIMIT.key: None if result.ratios is None else result.ratios.worst, **reserve_summary(setup)}


# ------------------------------------------------------------------------------------- demo
DEMO_SCENARIOS = ("circle_max", "corner_stop", "corner_max", "corner_transition", "corner_g2")
DEMO_COLUMNS = schema.keys(schema.DEMO)


def run_shipped(name: str, out: str | Path) -> dict:
    """Plan and simulate a shipped scenario into ``out`` (plan in out/plan); its summary row."""
    from .scenarios import scenario_path

    setup = load(scenario_path(name))
    result = plan_scenario(setup)
    write_plan(setup, result, Path(out) / "plan")
    sim = simulate_scenario(setup, result)
    summary = write_simulation(setup, result, sim, out)
    row = {"scenario": name}
    row.update({k: v for k, v in summary.items() if k != "plan"})
    row[schema.BASELINE_DURATION.key] = summary["plan"][schema.BASELINE_DURATION.key]
    return row


def write_demo_table(rows: list[dict], out: str | Path) -> Path:
    """demo.csv with DEMO_COLUMNS, one row per scenario."""
    out = Path(out)
    lines = [",".join(DEMO_COLUMNS)]
    for r in rows:
        lines.append(",".join("" if r.get(c) is None else str(r.get(c)) for c in DEMO_COLUMNS))
    return write_text(out / "demo.csv", "\n".join(lines) + "\n")
