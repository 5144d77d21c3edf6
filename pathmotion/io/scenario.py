"""Scenario files (TOML), validated with Pydantic.

A scenario says which robot, which path, which limits, how to plan, how to simulate and what
to write. Every error names the file, the key path and what is allowed, in one or two lines.
``scenario_json_schema()`` gives the JSON Schema for editors.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from .. import defaults
from ..errors import ScenarioError, clipped
from ..modes import BlendType, BoundaryMode, Connections, Controller, VerifyMode
from .files import parse_toml, read_input
from .scheduler import check_scheduler_address

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


# ----------------------------------------------------------------------------------------- robot
class PayloadSpec(_Model):
    mass: float = Field(0.0, ge=0, description="payload mass [kg]")
    com: Vec3 = Field((0.0, 0.0, 0.0), description="centre of mass in the flange frame [m]")
    inertia: Mat3 = Field(((0.0,) * 3,) * 3, description="inertia about the COM, flange axes [kg m^2]")


class ToolSpec(_Model):
    translation: Vec3 = Field((0.0, 0.0, 0.0), description="TCP offset from the flange [m]")
    rotation_rpy: Vec3 = Field((0.0, 0.0, 0.0), description="TCP rotation from the flange, roll-pitch-yaw [rad]")


class RobotSpec(_Model):
    name: str = Field("irb140", description="built-in robot name, or a URDF file path (relative to the scenario)")
    limits: str | None = Field(None, description="limits TOML file (default: the built-in one, or the URDF's)")
    payload: PayloadSpec = PayloadSpec()
    tool: ToolSpec = ToolSpec()
    locked_joints: dict[str, float] = Field({}, description="joints fixed at a value [rad or m], e.g. gripper "
                                            "fingers: {panda_finger_joint1 = 0.02}")
    flange_frame: str | None = Field(None, description="URDF frame the tool and payload attach to "
                                     "(default: the URDF's last frame)")


# ------------------------------------------------------------------------------------------ path
Quat = tuple[float, float, float, float]
RobConf = tuple[int, int, int, int]


class ProgramMoveSpec(_Model):
    """The robot-program move a segment came from (``pathmotion import-rapid`` writes it; ``plan`` reads it
    for moves.csv, and robconf with conf for the IK branch)."""

    line: int = Field(ge=1, description="line of the move in the program")
    target: str = Field("", description="the target as written in the program")
    move: Literal["MoveL", "MoveC", "MoveJ", "MoveAbsJ", "WaitTime"] = Field(description="the instruction")
    speed: float | None = Field(None, gt=0, description="programmed TCP speed [m/s] (absent with a time)")
    time: float | None = Field(None, gt=0, description="programmed move time (\\T) [s]")
    zone: str = Field("fine", description="the zone as written (fine, z10, a zonedata name)")
    robconf: RobConf | None = Field(None, description="ABB robconf [cf1, cf4, cf6, cfx] of the target")
    conf: bool = Field(True, description="ConfL / ConfJ \\On: the planned configuration at the target must have "
                                         "the robconf (\\Off: the branch continuous with the previous one)")


class _Keyed(_Model):
    """Keys every task segment takes: the tool orientation at its end and the program move behind it."""

    quaternion: Quat | None = Field(None, description="tool orientation at the segment's end, unit quaternion "
                                    "[w, x, y, z] in the base frame; given on every segment or on none")
    orientation_zone: float = Field(0.0, ge=0, description="path distance [m] either side of the segment's end over "
                                    "which the orientation turns straight on to the next one (a zone's pzone_ori; "
                                    "0: the end orientation is met exactly)")
    program: ProgramMoveSpec | None = None


class LineSpec(_Keyed):
    type: Literal["line"]
    start: Vec3 | None = Field(None, description="start point [m] (default: the previous segment's end)")
    end: Vec3 = Field(description="end point [m]")


class ArcSpec(_Keyed):
    type: Literal["arc"]
    start: Vec3 | None = Field(None, description="start point [m] (default: previous end)")
    center: Vec3 = Field(description="circle centre [m]")
    normal: Vec3 = Field((0.0, 0.0, 1.0), description="plane normal; the sweep is right-handed about it")
    sweep: float = Field(description="signed sweep angle [rad]")


class CircleSpec(_Keyed):
    type: Literal["circle"]
    center: Vec3 = Field(description="centre [m]")
    radius: float = Field(gt=0, description="radius [m]")
    normal: Vec3 = Field((0.0, 0.0, 1.0), description="plane normal (0,0,1): horizontal circle")
    start_angle: float = Field(0.0, description="angle of the start point in the plane [rad]")
    start: Vec3 | None = Field(None, description="start point instead of start_angle (default: previous end, if any)")


class PoseTargetSpec(_Model):
    """A TCP pose solved by IK on the branch its robconf names (ABB's confdata)."""

    position: Vec3 = Field(description="TCP position [m]")
    quaternion: tuple[float, float, float, float] = Field(description="tool orientation, unit quaternion "
                                                          "[w, x, y, z] (normalised when off by rounding)")
    robconf: tuple[int, int, int, int] | None = Field(
        None, description="[cf1, cf4, cf6, cfx]: quadrants of axes 1, 4 and 6 and the arm/wrist configuration "
                          "number 0..7 (ABB's convention); default: the branch nearest the move's start")


class JointSegmentSpec(_Model):
    """A joint move (MoveJ / MoveAbsJ): linear in the joints from the previous segment's end configuration."""

    type: Literal["joint"]
    program: ProgramMoveSpec | None = None
    end: tuple[float, ...] | None = Field(None, description="joint values at the end [rad]")
    end_pose: PoseTargetSpec | None = Field(None, description="the end as a TCP pose solved by IK")

    @model_validator(mode="after")
    def _target(self):
        if (self.end is None) == (self.end_pose is None):
            raise ValueError("a joint segment needs exactly one of end = [joint values, rad] or "
                             "end_pose = {position, quaternion, robconf}")
        return self


class DwellSpec(_Model):
    """A wait at rest (WaitTime): the motion stops where the previous segment ends and waits."""

    type: Literal["dwell"]
    program: ProgramMoveSpec | None = None
    time: float = Field(ge=0, description="time at rest [s]")


SegmentSpec = Annotated[Union[LineSpec, ArcSpec, CircleSpec, JointSegmentSpec, DwellSpec],
                        Field(discriminator="type")]


class BlendSpec(_Model):
    corner: int | Literal["all"] = Field("all", description="connection index (1 = between segments 1 and 2) or 'all'")
    type: BlendType = Field(description="'circle': the thesis' transition circle; 'g2': curvature-continuous blend; "
                            "'optimal': the G2 blend shape with the shortest time-optimal duration")
    radius: float | None = Field(None, gt=0, description="transition circle radius r_t [m] (type circle)")
    tolerance: float | None = Field(None, gt=0, description="largest deviation from the corner [m] (type g2, optimal)")
    planar: bool = Field(False, description="type optimal: keep the blend in the corner's plane (default: anywhere "
                                            "within the tolerance, which may lift or lower the tool by up to it)")
    join_ends: bool = Field(False, description="type optimal: join the lines at the path's start and end even where "
                                               "the motion rests there (default: the blend may leave the start and reach "
                                               "the end at an angle, within the tolerance)")
    search: Literal["fast", "thorough"] = Field("fast", description="type optimal: 'fast' the quintic, the racing "
                                                "line and short free-end stages (1-3 s of CPU per corner), 'thorough' "
                                                "every stage of the search (15-60 s per corner; the corner atlas' "
                                                "search)")

    @model_validator(mode="after")
    def _size(self):
        if self.type == BlendType.CIRCLE and self.radius is None:
            raise ValueError("a 'circle' blend needs radius = r_t in metres")
        if self.type in (BlendType.G2, BlendType.OPTIMAL) and self.tolerance is None:
            raise ValueError(f"a '{self.type.value}' blend needs tolerance = largest allowed deviation in metres")
        if self.planar and self.type != BlendType.OPTIMAL:
            raise ValueError(f"planar = true is for 'optimal' blends (a '{self.type.value}' blend is always in the "
                             "corner's plane); remove it")
        if "search" in self.model_fields_set and self.type != BlendType.OPTIMAL:
            raise ValueError(f"search is for 'optimal' blends (a '{self.type.value}' blend is not searched); remove it")
        if self.join_ends and self.type != BlendType.OPTIMAL:
            raise ValueError(f"join_ends = true is for 'optimal' blends (a '{self.type.value}' blend always joins the "
                             "lines); remove it")
        return self


class TaskPathSpec(_Model):
    type: Literal["task"]
    segments: list[SegmentSpec] = Field(min_length=1, description="line, arc, circle, joint (a joint move: linear "
                                        "in the joints) or dwell (a wait at rest), each from where the previous ends")
    blends: list[BlendSpec] = []
    orientation: Literal["down"] | Mat3 = Field("down", description="fixed tool orientation: 'down' or a rotation "
                                                "matrix; with segment quaternions, the orientation at the start")
    start_configuration: tuple[float, ...] | None = Field(
        None, description="joint configuration [rad] the IK branch stays continuous with")
    start_pose: PoseTargetSpec | None = Field(None, description="the pose the path starts at, solved by IK on its "
                                              "robconf: the start configuration (when start_configuration is absent)")
    start_program: ProgramMoveSpec | None = Field(None, description="the program move whose target is the start")

    @model_validator(mode="after")
    def _keys(self):
        keyed = [s for s in self.segments if s.type in ("line", "arc", "circle")]
        given = [s.quaternion is not None for s in keyed]
        if any(given) and not all(given):
            k = self.segments.index(keyed[given.index(False)])
            raise ValueError(f"segments[{k}] has no quaternion but others do; give every line, arc and circle its "
                             "end orientation, or none")
        if not any(given) and any(s.orientation_zone for s in keyed):
            raise ValueError("orientation_zone needs segment quaternions (a fixed orientation does not turn)")
        return self


class JointPathSpec(_Model):
    type: Literal["joint"]
    waypoints: list[tuple[float, ...]] = Field(min_length=2, description="joint waypoints [rad], one row per waypoint")


class WaypointPathSpec(_Model):
    """Straight lines through waypoints from a CSV file (pathmotion.io.waypoints) or given inline."""

    type: Literal["waypoints"]
    file: str | None = Field(None, description="CSV file (relative to the scenario): columns x, y, z [m], "
                             "optionally qw, qx, qy, qz or roll, pitch, yaw [rad]")
    points: list[Vec3] | None = Field(None, min_length=2, description="waypoints [m] instead of a file")
    blend_tolerance: float = Field(0.0, ge=0, description="largest deviation of the G2 blend at each corner [m]; "
                                   "0 = stop at each corner")
    blend: Literal["g2", "optimal"] = Field("g2", description="the blend at each corner: 'g2' the symmetric G2 "
                                            "blend, 'optimal' the G2 blend shape with the shortest time-optimal "
                                            "duration within blend_tolerance (as [[path.blends]] type = 'optimal')")
    search: Literal["fast", "thorough"] = Field("fast", description="blend = 'optimal': how hard each corner is "
                                                "searched (as [[path.blends]] search)")
    orientation: Literal["down"] | Mat3 | None = Field(None, description="fixed tool orientation when the points "
                                                       "carry none: 'down' (default) or a rotation matrix")
    start_configuration: tuple[float, ...] | None = Field(
        None, description="joint configuration [rad] the IK branch stays continuous with (and, for arms with "
                          "more than 6 joints, the null-space motion stays near)")

    @model_validator(mode="after")
    def _source(self):
        if (self.file is None) == (self.points is None):
            raise ValueError("give either file = \"points.csv\" or points = [[x, y, z], ...], exactly one")
        if self.blend == "optimal" and self.blend_tolerance == 0.0:
            raise ValueError("blend = \"optimal\" needs blend_tolerance > 0 (the largest deviation [m] at each "
                             "corner); give one, or remove blend to stop at each corner")
        return self


PathSpec = Annotated[Union[TaskPathSpec, JointPathSpec, WaypointPathSpec], Field(discriminator="type")]


# ---------------------------------------------------------------------------------------- limits
class LimitsSpec(_Model):
    """The [limits] table: overrides of the robot's joint limits, and the keys of each registered
    limit class (``keys`` in pathmotion/planning/limits/; a test checks they match)."""

    velocity: tuple[float, ...] | None = Field(None, description="joint speed limits [rad/s], override")
    acceleration: tuple[float, ...] | None = Field(None, description="joint acceleration limits [rad/s^2], override")
    torque: tuple[float, ...] | None = Field(None, description="joint torque limits [N m], override")
    use_velocity: bool = True
    use_acceleration: bool = True
    use_torque: bool = True
    velocity_scale: float = Field(1.0, gt=0)
    acceleration_scale: float = Field(1.0, gt=0)
    torque_scale: float = Field(1.0, gt=0)
    tcp_speed: float | None = Field(None, gt=0, description="TCP speed limit [m/s] (off when absent)")
    torque_reserve: float | Literal["auto"] = Field(defaults.TORQUE_RESERVE, description="fraction of each torque limit kept free for "
                                                    "feedback, in [0, 0.5) (the planner enforces (1 - r) tau_max); "
                                                    "\"auto\": the smallest with which the scenario's closed loop "
                                                    "tracks (a search over plan + simulate runs)")
    torque_speed: dict[str, float | tuple[float, ...]] | None = Field(
        None, description="torque-speed envelope {knee, at_max_speed}, fractions in (0, 1] (scalar or per joint); "
                          "off when absent")
    jerk: tuple[float, ...] | None = Field(None, description="joint jerk limits [rad/s^3] (default: the robot's)")
    use_jerk: bool | None = Field(None, description="enforce the jerk limits (default: when [limits] jerk is given)")
    jerk_scale: float = Field(1.0, gt=0)
    torque_rate: tuple[float, ...] | None = Field(None, description="joint torque-rate limits [N m/s] (default: "
                                                  "the robot's)")
    use_torque_rate: bool | None = Field(None, description="enforce the torque-rate limits (default: when "
                                                           "[limits] torque_rate is given)")
    torque_rate_scale: float = Field(1.0, gt=0)

    @field_validator("torque_reserve", mode="before")
    @classmethod
    def _reserve(cls, value):
        """One message for every bad reserve (a union's per-member errors say less)."""
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if value == "auto" or (number and math.isfinite(value) and 0 <= value < defaults.MAX_TORQUE_RESERVE):
            return value
        raise ValueError(f"give a fraction of each torque limit kept free for feedback, in [0, "
                         f"{defaults.MAX_TORQUE_RESERVE:g}) (e.g. 0.2), or \"auto\" (the smallest reserve with which "
                         "the scenario's closed loop tracks)")


Boundary = Union[BoundaryMode, Annotated[float, Field(ge=0)]]


class PlanSpec(_Model):
    grid_points: int | None = Field(None, ge=10, le=1_000_000, description="a fixed planner grid of this many "
                                    "points; absent: adaptive, refined until the duration is within duration_tolerance")
    start: Boundary = Field(BoundaryMode.ZERO, description="theta_dot at the start: 'zero', 'max' or a value [1/s]")
    end: Boundary = Field(BoundaryMode.ZERO, description="theta_dot at the end: 'zero', 'max' or a value")
    periodic: bool = Field(False, description="closed path: the steady-state cycle")
    connections: Connections = Field(
        Connections.CHAIN, description="'chain': plan the whole path at once; 'zero'/'max': segment by segment")
    sample_time: float = Field(defaults.SAMPLE_TIME, gt=0, le=1.0, description="output sample time [s]")
    verify: VerifyMode = Field(VerifyMode.CERTIFIED, description="'certified': a certified bound of every limit "
                               "on every grid interval; 'dense': the 0.1 ms time resample; 'off'")
    workers: int = Field(1, ge=1, le=256, description="local processes that search the optimal blends' corners "
                         "in parallel (the same result as 1)")
    scheduler: str | None = Field(None, description="a Dask scheduler, tcp://HOST:PORT: the task runs of a path with "
                                  "joint moves or dwells search their optimal blends as tasks on its workers (the "
                                  "same result as without)")
    blend_speed_scale: float = Field(1.0, gt=0, le=1, description="path speed on the blend segments as a fraction "
                                     "of the optimal profile's there (1 = optimal; see pathmotion.planning.blend_speed)")
    duration_tolerance: float = Field(defaults.PLAN_TOLERANCE, gt=0, lt=defaults.MAX_PLAN_TOLERANCE,
                                      description="adaptive grid: requested relative error of the duration "
                                                  "(0.0005 = 0.05 %)")
    #: Former keys of this table -> their names now (an old key gets an error naming the new one).
    RENAMED: ClassVar[dict[str, str]] = {"tolerance": "duration_tolerance"}

    @field_validator("scheduler")
    @classmethod
    def _address(cls, value):
        if value is not None:
            try:
                check_scheduler_address(value, "the address")
            except ScenarioError as exc:
                raise ValueError(str(exc)) from None
        return value


# ------------------------------------------------------------------------------------ simulation
_NonNegative = Annotated[float, Field(ge=0)]


class RealismSpec(_Model):
    """Plant vs controller-model differences (all off by default); see pathmotion.simulation.Realism."""

    seed: int = Field(0, ge=0, le=2**64 - 1, description="seed of every random part (0 .. 2^64 - 1)")
    inertia_error: float = Field(0.0, ge=0, lt=1, description="plant link mass/inertia error, e.g. 0.1 = 10 %")
    payload_mass: float = Field(0.0, ge=0, description="unmodelled payload at the flange [kg]")
    payload_com: Vec3 | None = Field(None, description="its centre of mass in the flange frame [m]")
    viscous_friction: _NonNegative | tuple[_NonNegative, ...] = Field(0.0, description="[N m s/rad], one value for "
                                                                     "every joint or one per joint")
    coulomb_friction: _NonNegative | tuple[_NonNegative, ...] = Field(0.0, description="[N m], one value for every "
                                                                     "joint or one per joint")
    encoder_resolution: float = Field(0.0, ge=0, description="quantization step [rad] (0 = off)")
    position_noise: float = Field(0.0, ge=0, description="measurement noise std [rad]")
    velocity_noise: float = Field(0.0, ge=0, description="measurement noise std [rad/s]")
    delay: bool = Field(False, description="one-sample delay of the applied torque")


class EventSpec(_Model):
    """A re-timing event of the closed loop (pathmotion.simulation.events): exactly one of override, stop, resume."""

    t: float = Field(ge=0, description="time of the event [s]")
    override: float | None = Field(None, gt=0, le=1, description="speed override from then on (1 = the plan's "
                                   "speed; velocity x override, acceleration x override^2)")
    stop: bool = Field(False, description="stop on the path, as fast as the limits allow")
    resume: bool = Field(False, description="resume from a stop to the path's end")

    @model_validator(mode="after")
    def _one_action(self):
        if (self.override is not None) + self.stop + self.resume != 1:
            raise ValueError("give exactly one of override = <0..1>, stop = true, resume = true")
        return self


class SimulateSpec(_Model):
    controller: Controller = Controller.ORBITAL
    sample_time: float = Field(defaults.SAMPLE_TIME, gt=0, le=0.1, description="controller sample time [s]")
    substeps: int = Field(defaults.PLANT_SUBSTEPS, ge=1, le=defaults.MAX_PLANT_SUBSTEPS,
                          description="RK4 plant steps per sample (raised to the count the friction needs)")
    plant: Literal["builtin", "mujoco"] = Field(defaults.PLANT, description="the simulated arm: builtin (Pinocchio + "
                                                "RK4) or mujoco (pip install \"pathmotion[mujoco]\")")
    laps: int = Field(1, ge=1, le=100, description="laps of a closed path")
    realism: RealismSpec = RealismSpec()
    gains: dict[str, Annotated[float, Field(gt=0, le=defaults.MAX_GAIN)]] = Field({}, description="gains of the chosen controller overriding the defaults "
                                                    "(orbital: bandwidth, damping, speed_rate, min_speed, "
                                                    "terminal_time_to_go, integral_rate, observer_range, "
                                                    "payload_memory, payload_noise, payload_speed_noise; others: "
                                                    "bandwidth, damping)")
    path_tolerance: float = Field(defaults.PATH_TOLERANCE, gt=0,
                                  description="largest TCP distance from the planned path [m]")
    path_tolerance_deg: float = Field(defaults.PATH_TOLERANCE_DEG, gt=0, le=180,
                                      description="largest angle of the tool's orientation from the planned one [deg]")
    joint_tolerance: float = Field(defaults.JOINT_TOLERANCE, gt=0,
                                   description="largest joint deviation from the path [rad]")
    sampled_design: bool = Field(defaults.ORBITAL_SAMPLED_DESIGN, description="orbital gains designed at the "
                                 "sample time with the delay in the model")
    identify_payload: bool = Field(defaults.PAYLOAD_IDENTIFICATION, description="orbital controller: identify online "
                                   "the flange payload and the joint friction the model lacks (gains payload_memory "
                                   "[s], payload_noise [rad/s^2], payload_speed_noise [rad/s])")
    saturation_limit: float = Field(defaults.SATURATION_LIMIT, ge=0,
                                    description="longest stretch a torque may stay saturated [s]")
    events: list[EventSpec] = Field([], description="re-timing events (orbital controller): e.g. [{t = 0.3, "
                                    "override = 0.5}, {t = 0.6, stop = true}, {t = 1.0, resume = true}]")


# ----------------------------------------------------------------------------------------- rapid
class RapidSpec(_Model):
    """The speeds and zones of an imported RAPID program (``pathmotion import-rapid``)."""

    source: str = Field("", description="the RAPID module it came from")
    speeds: list[Annotated[float, Field(gt=0)]] = Field(min_length=1, description="programmed TCP speed per "
                                                                                 "segment [m/s]")
    zones: list[Annotated[float, Field(ge=0)]] = Field([], description="zone radius per corner [m], 0 = fine point")

    @model_validator(mode="after")
    def _counts(self):
        if len(self.zones) != len(self.speeds) - 1:
            raise ValueError(f"{len(self.speeds)} speeds need {len(self.speeds) - 1} zones (one per corner), "
                             f"got {len(self.zones)}")
        return self


class Scenario(_Model):
    name: str = "scenario"
    description: str = ""
    robot: RobotSpec = RobotSpec()
    path: PathSpec
    limits: LimitsSpec = LimitsSpec()
    plan: PlanSpec = PlanSpec()
    simulate: SimulateSpec = SimulateSpec()
    rapid: RapidSpec | None = Field(None, description="speeds and zones of an imported RAPID program")


# ----------------------------------------------------------------------------------------- load
def _loc(loc: tuple) -> str:
    out = ""
    for k, part in enumerate(loc):
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("line", "arc", "circle", "dwell", "task", "joint", "float", "int", "str", "bool") or not str(
                part).isidentifier():
            continue  # discriminator and union-member tags that pydantic inserts (e.g. "literal['zero','max']")
        elif part == "waypoints" and k > 0 and loc[k - 1] == "path":
            continue  # the tag of [path] type = "waypoints" (a joint path's key of that name follows its tag)
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _models_in(annotation) -> list[type[BaseModel]]:
    """The pydantic models an annotation may hold (through Annotated, Optional, Union, list, tuple, dict)."""
    import typing

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _model_at(loc: tuple, doc) -> type[BaseModel] | None:
    """The model whose keys apply at ``loc`` (a pydantic error location, its last part the key) in ``doc``;
    a union of models (segment types, path types) is resolved by the document's ``type`` there."""
    models, node = [Scenario], doc
    for part in loc[:-1]:
        if isinstance(part, int):
            node = node[part] if isinstance(node, (list, tuple)) and part < len(node) else None
            continue
        cls = _pick(models, node)
        if cls is None or part not in cls.model_fields:
            continue  # a union member tag pydantic inserts
        node = node.get(part) if isinstance(node, dict) else None
        models = _models_in(cls.model_fields[part].annotation)
    return _pick(models, node)


def _pick(models: list, node) -> type[BaseModel] | None:
    """The one of ``models`` whose Literal ``type`` is the node's ``type`` (else the first)."""
    kind = node.get("type") if isinstance(node, dict) else None
    typed = [m for m in models if "type" in m.model_fields
             and kind in typing_literal_values(m.model_fields["type"].annotation)]
    return (typed or models or [None])[0]


def typing_literal_values(annotation) -> tuple:
    """The values of a Literal annotation (() for anything else)."""
    import typing

    return typing.get_args(annotation) if typing.get_origin(annotation) is Literal else ()


def _did_you_mean(loc: tuple, doc) -> str:
    """'; did you mean 'radius'?' for an unknown key whose closest allowed key (difflib) is close enough,
    else the allowed keys."""
    import difflib

    cls = _model_at(loc, doc)
    if cls is None:
        return ""
    renamed = getattr(cls, "RENAMED", {}).get(str(loc[-1]))
    if renamed is not None:
        return f"; it is now called {renamed!r}: rename the key"
    allowed = list(cls.model_fields)
    close = difflib.get_close_matches(str(loc[-1]), allowed, n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else f"; allowed here: {', '.join(allowed)}"


def _error_line(err: dict, doc, where: str, overrides: dict) -> str:
    loc = _loc(err["loc"])
    given = next((k for k in overrides if loc == _loc(tuple(_parse_key(k))) or loc.startswith(
        _loc(tuple(_parse_key(k))) + ".")), None)
    place = f"--set {clipped(given)}" if given is not None else where
    loc = "" if given == loc else f" {clipped(loc)}:"
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        msg = f"unknown key {clipped(repr(err['loc'][-1]))}{_did_you_mean(err['loc'], doc)}"
    elif err["type"] == "missing":
        msg = "missing required key"
    elif err["type"] == "value_error":  # our validators' own sentences, without pydantic's label
        msg = msg.removeprefix("Value error, ")
    value = err.get("input")
    shown = "" if err["type"] in ("missing", "extra_forbidden") or isinstance(value, dict) else f" (got {_quoted(value)})"
    return f"{place}:{loc} {msg}{shown}"


def _quoted(value) -> str:
    """The start of ``value``'s repr (60 characters); an integer too long to print is described by its size."""
    if isinstance(value, int) and value.bit_length() > 4000:  # repr would exceed Python's int-to-str digit limit
        return f"an integer of about {int(value.bit_length() * 0.30103):,} digits"
    return f"{value!r:.60}"


def _merge_union_errors(errors: list[dict]) -> list[dict]:
    """One error per key path: the errors pydantic reports per member of a union (``plan.start``:
    'zero' or 'max', or a number >= 0) joined into one message ("...; or ...")."""
    merged: dict[str, dict] = {}
    for err in errors:
        key = _loc(err["loc"])
        if key in merged and err["type"] != "extra_forbidden":
            first = merged[key]
            first["msg"] = f"{first['msg']}; or {err['msg'][:1].lower()}{err['msg'][1:]}"
        else:
            merged.setdefault(key if err["type"] != "extra_forbidden" else f"{key}\0extra", dict(err))
    return list(merged.values())


#: Most validation errors one message lists (one a line), the rest counted.
MAX_ERRORS_SHOWN = 4


def scenario_from_dict(doc: dict, where: str = "scenario", overrides: dict | None = None) -> Scenario:
    """Validate a parsed scenario; ScenarioError names ``where`` (or ``--set KEY`` for a key the
    ``overrides`` set), the key path and what is allowed, one error a line: an unknown key first,
    with the closest allowed key ("did you mean 'radius'?").

    Strict types: a string, a boolean or a fractional number where an integer belongs (``grid_points =
    "60"``, ``laps = true``) is an error, not a silent conversion; an integer is a valid float. (Validated
    in JSON form, where arrays are tuples; TOML dates and times become strings.)"""
    import json

    try:
        return Scenario.model_validate_json(json.dumps(doc, default=str), strict=True)
    except ValidationError as exc:
        raise validation_error(exc.errors(), doc, where, overrides) from None


def validation_error(errors: list[dict], doc, where: str, overrides: dict | None = None) -> ScenarioError:
    """The ScenarioError of pydantic's ``errors`` (their ``loc`` from the root of ``doc``): one line per key path
    (a union's members joined), an unknown key first with the closest allowed one, at most MAX_ERRORS_SHOWN and
    the rest counted; each names ``where`` (or ``--set KEY`` for a key the ``overrides`` set)."""
    errors = sorted(_merge_union_errors(errors), key=lambda e: e["type"] != "extra_forbidden")
    lines = [_error_line(e, doc, where, overrides or {}) for e in errors[:MAX_ERRORS_SHOWN]]
    if len(errors) > MAX_ERRORS_SHOWN:
        lines.append(f"... and {len(errors) - MAX_ERRORS_SHOWN} more")
    return ScenarioError("\n".join(lines))


#: A point this many times farther from the base than the arm reaches is taken for millimetres [-].
MM_SLIP_FACTOR = 10.0
#: An angle up to this above a full turn is 2 pi typed with rounding, not degrees [rad].
FULL_TURN_SLACK = 1e-9


def unit_slips(scenario: Scenario, reach: float | None = None, rated_payload: float | None = None,
               robot: str = "the robot") -> None:
    """ScenarioError naming the key of the first value most likely given in the wrong unit: an angle
    [rad] above 2 pi (degrees?), a length [m] beyond the arm's ``reach`` [m] or a point more than
    MM_SLIP_FACTOR times beyond it (mm?; a point just out of reach gets the reachability error, which says
    where), a payload [kg] above ``rated_payload`` [kg] (grams, or outside the rating). None skips that check."""
    for key, value in _angles(scenario):
        if abs(value) > 2 * math.pi + FULL_TURN_SLACK:
            raise ScenarioError(f"{key} = {value:g} rad is more than a full turn (2 pi = 6.283 rad): degrees? the "
                                f"unit is rad (e.g. {math.radians(value):.6g} rad = {value:g} deg)")
    if reach is not None:
        for key, value in _lengths(scenario):
            point = isinstance(value, tuple)
            size = math.hypot(*value) if point else abs(value)
            if size > (MM_SLIP_FACTOR * reach if point else reach):
                raise ScenarioError(f"{key} = {_show(value)} is {size:g} m, beyond {robot}'s reach ({reach:.3g} m): "
                                    f"mm? the unit is m (e.g. {_show(value, 1e-3)})")
    if rated_payload is not None:
        for key, mass in (("robot.payload.mass", scenario.robot.payload.mass),
                          ("simulate.realism.payload_mass", scenario.simulate.realism.payload_mass)):
            if mass > rated_payload:
                raise ScenarioError(f"{key} = {mass:g} kg is above {robot}'s rated payload {rated_payload:g} kg: "
                                    "grams? the unit is kg (a heavier payload is outside the arm's rating)")


def degrees_hint(values, lower=None, upper=None) -> str:
    """'; degrees? ...' when angles ``values`` [rad] look like degrees: one of them beyond a full turn, or one
    beyond half a turn and all of them inside [``lower``, ``upper``] once read as degrees; else ''."""
    import numpy as np

    v = np.asarray(values, dtype=float)
    if not v.size:
        return ""
    beyond = np.abs(v) > 2 * math.pi + FULL_TURN_SLACK
    fits = (lower is not None and np.max(np.abs(v)) > math.pi
            and np.all((np.radians(v) >= lower) & (np.radians(v) <= upper)))
    if not (beyond.any() or fits):
        return ""
    x = float(v.flat[int(np.argmax(np.abs(v)))])
    return f"; degrees? the unit is rad (e.g. {x:g} deg = {math.radians(x):.6g} rad)"


def velocity_slip(velocity, names, where: str) -> str | None:
    """A warning when a joint speed limit [rad/s] is above defaults.PLAUSIBLE_JOINT_SPEED (deg/s typed as
    rad/s?), naming the joint, ``where`` the limits come from and the value read as degrees; else None."""
    fast = [j for j, v in enumerate(velocity) if v > defaults.PLAUSIBLE_JOINT_SPEED]
    if not fast:
        return None
    j = fast[0]
    return (f"{where}: velocity limit of {names[j]} is {velocity[j]:g} rad/s ({math.degrees(velocity[j]):,.0f} deg/s), "
            f"faster than any arm joint (> {defaults.PLAUSIBLE_JOINT_SPEED:g} rad/s) on {len(fast)} joint(s): degrees? "
            f"the unit is rad/s (e.g. {velocity[j]:g} deg/s = {math.radians(velocity[j]):.4g} rad/s)")


def _show(value, scale: float = 1.0) -> str:
    if isinstance(value, tuple):
        return "[" + ", ".join(f"{v * scale:g}" for v in value) + "]"
    return f"{value * scale:g}"


def _angles(scenario: Scenario):
    """(key, value [rad]) of the scenario's angles that are never more than a turn."""
    path = scenario.path
    for k, seg in enumerate(getattr(path, "segments", ())):
        if seg.type == "arc":
            yield f"path.segments[{k}].sweep", seg.sweep
        if seg.type == "circle":
            yield f"path.segments[{k}].start_angle", seg.start_angle
    for i, v in enumerate(scenario.robot.tool.rotation_rpy):
        yield f"robot.tool.rotation_rpy[{i}]", v


def _lengths(scenario: Scenario):
    """(key, value) of the scenario's points (tuples [m], measured from the base) and lengths [m]."""
    path = scenario.path
    for k, seg in enumerate(getattr(path, "segments", ())):
        if seg.type == "joint":  # joint values [rad]; its end_pose position is a point [m]
            if seg.end_pose is not None:
                yield f"path.segments[{k}].end_pose.position", tuple(seg.end_pose.position)
            continue
        for name in ("start", "end", "center", "radius"):
            value = getattr(seg, name, None)
            if value is not None:
                yield f"path.segments[{k}].{name}", tuple(value) if isinstance(value, tuple) else value
    for k, blend in enumerate(getattr(path, "blends", ())):
        for name in ("radius", "tolerance"):
            if getattr(blend, name) is not None:
                yield f"path.blends[{k}].{name}", getattr(blend, name)
    yield "robot.tool.translation", tuple(scenario.robot.tool.translation)
    yield "robot.payload.com", tuple(scenario.robot.payload.com)


def load_scenario(path: str | Path, overrides: dict[str, Any] | None = None) -> tuple[Scenario, Path]:
    """Read and validate a scenario file; ``overrides`` maps dotted key paths to values
    (e.g. ``{"path.blends[0].radius": 0.03}``) applied before validation. Returns the
    scenario and the folder relative paths in it refer to."""
    path = Path(path)
    text = read_input(path, "scenario")
    return parse_scenario(text, str(path), overrides), path.parent


def parse_scenario(text: str, where: str = "scenario", overrides: dict[str, Any] | None = None) -> Scenario:
    """Validate scenario TOML text (``where`` names it in errors), with key-path overrides."""
    doc = parse_toml(text, where)
    for key, value in (overrides or {}).items():
        set_key(doc, key, value, where=where)
    return scenario_from_dict(doc, where=where, overrides=overrides)


def _parse_key(key: str) -> list:
    parts: list = []
    for token in key.replace("]", "").split("."):
        name, *idx = token.split("[")
        if name:
            parts.append(name)
        parts.extend(int(i) for i in idx)
    return parts


def set_key(doc: dict, key: str, value, where: str = "scenario") -> None:
    """Set a dotted key path (``plan.grid_points``, ``path.blends[0].radius``) in a parsed document."""
    try:
        parts = _parse_key(key)
    except ValueError:
        raise ScenarioError(f"{where}: bad key path '{key}' (use e.g. path.blends[0].radius)") from None
    if not parts:
        raise ScenarioError(f"{where}: empty key path")
    node = doc
    for k, nxt in zip(parts[:-1], parts[1:]):
        try:
            child = node[k]
        except (KeyError, IndexError, TypeError):
            if isinstance(node, dict):
                child = node.setdefault(k, [] if isinstance(nxt, int) else {})
            else:
                raise ScenarioError(f"{where}: key path '{key}': no element {k!r}") from None
        node = child
    last = parts[-1]
    try:
        if isinstance(node, list) and isinstance(last, int) and last == len(node):
            node.append(value)
        else:
            node[last] = value
    except (IndexError, TypeError):
        raise ScenarioError(f"{where}: key path '{key}': cannot set element {last!r}") from None


def parse_value(text: str):
    """A command-line value (``--set KEY=VALUE``), read as a TOML value: ``true``, ``2000``, ``0.04``,
    ``"text"`` (without its quotes), ``[0.5, 0.0, 0.5]``, an inline table; a bare word (``orbital``)
    or anything else TOML does not read is the string itself. TRUE/False are booleans too, and
    non-finite numbers are an error."""
    import tomllib

    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    if t[:1] in ("[", "{"):  # through the guarded reader (nesting depth, size)
        value = parse_toml(f"v = {t}", f"value {text[:60]!r}")["v"]
    else:
        try:
            value = tomllib.loads(f"v = {t}")["v"]
        except ValueError as exc:  # (a TOMLDecodeError is a ValueError)
            if not isinstance(exc, tomllib.TOMLDecodeError):  # an integer beyond Python's int-to-str digit limit
                raise ScenarioError(f"value {clipped(text, 60)}: an integer of {len(t):,} characters, far beyond "
                                    "any limit; give a number of sensible size") from None
            if t[:1] in ('"', "'"):
                raise ScenarioError(f"value {text[:60]!r} is not a valid TOML string (an unclosed quote?)") from None
            try:
                value = float(t)  # Python spellings TOML does not take: 1., .5
            except ValueError:
                return t
    if isinstance(value, float) and not math.isfinite(value):
        raise ScenarioError(f"value {clipped(repr(text))} is not a finite number")
    return value


def scenario_json_schema() -> dict:
    """JSON Schema of the scenario format (for editors: e.g. taplo or Even Better TOML)."""
    schema = Scenario.model_json_schema()
    schema["title"] = "pathmotion scenario"
    return schema


