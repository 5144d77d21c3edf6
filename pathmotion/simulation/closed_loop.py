"""The closed loop: a discrete controller at a fixed sample time driving the plant.

Per sample k (t_k = k Ts) the loop does four things:

1. measure: a monitor projects the true state onto the path (:mod:`.monitor`);
2. control: the end rules (:mod:`.end_rules`) judge the sample, and the controller computes the torque from
   the sensor's view (one sample later with the delay switch), saturated at the limits;
3. step: the plant integrates the sample with the torque held (:class:`PlantModel`);
4. record.

A run ends with a :class:`~.metrics.Failure` (divergence, leaving the path's theta range, the TCP outside the
path tolerance, a joint deviation past the joint tolerance, a torque saturated too long, the time budget
``time_budget_factor`` x planned duration + ``time_budget_margin``) or an arrival (the TCP at the end of an
open path within the path tolerance, or crossing it, or ``laps`` turns of a closed path). Of several failures
the one that started first is reported. Failures are results, not exceptions; a run always ends (the sample
count is bounded by the budget).
"""

from __future__ import annotations

import logging
import dataclasses
import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pinocchio as pin

from .. import defaults
from ..control import (CONTROLLER_NAMES, ComputedTorqueController, OrbitalController, OrbitalDesign, OrbitalGains,
                       PathTable, PDGravityController, TimeReference, TrackingGains, default_pd_gains)
from ..control.design_cache import cached_design, cached_table
from ..control.threads import blas_single_threaded
from ..errors import ScenarioError, SimulationError
from ..lift.joint_path import JointPath
from ..planning.profile import Profile
from ..robot import Robot
from .end_rules import FLAT_SPEED2, Sample, end_rules
from .events import EventPlayer
from .metrics import (Failure, SimulationResult, polyline_distance_local, cornering_deviation, line_window,
                      orientation_deviation, original_path_deviation, planned_tcp_line, polish_projection,
                      tcp_path_deviation)
from .monitor import monitor_state
from .plant import PLANT_NAMES, make_plant
from .saturation import saturate
from .realism import Realism, Sensor

log = logging.getLogger(__name__)

#: Relative mismatch allowed between the profile's theta range and the path's domain [-].
DOMAIN_MATCH = 1e-9


@dataclass(frozen=True)
class SimulationSettings:
    """sample_time [s]; substeps: RK4 steps per sample; realism; gains of the three controllers; the verdict:
    path_tolerance [m] (TCP from the planned path, and from the end point for the arrival), joint_tolerance
    [rad], saturation_limit [s] (longest saturated stretch); time budget = time_budget_factor * planned +
    time_budget_margin [s]; laps (closed paths); table_points of the controller's path table; settle_time [s]
    observed after the arrival (open paths ending at rest); sampled_design: the orbital gains designed on the
    sampled transverse linearization at sample_time with the realism's delay in the model; design_cache: read and
    write the path table and the orbital design in the on-disk cache (:mod:`pathmotion.control.design_cache`); plant: "builtin" or "mujoco" (see
    :func:`.plant.make_plant`); events: re-timing events (:class:`.events.Event`: override, stop, resume at a time),
    played by the orbital controller (simulate then needs the plan's Retimer); run_to_end: go on after the first
    failure (it stays the verdict) until the arrival or the time budget, instead of stopping there (the default, and
    the only way after a non-finite torque)."""

    sample_time: float = defaults.SAMPLE_TIME
    substeps: int = defaults.PLANT_SUBSTEPS
    realism: Realism = field(default_factory=Realism)
    orbital_gains: OrbitalGains = field(default_factory=OrbitalGains)
    computed_torque_gains: TrackingGains = field(default_factory=TrackingGains)
    pd_gains: TrackingGains = field(default_factory=default_pd_gains)
    path_tolerance: float = defaults.PATH_TOLERANCE
    path_tolerance_deg: float = defaults.PATH_TOLERANCE_DEG
    joint_tolerance: float = defaults.JOINT_TOLERANCE
    saturation_limit: float = defaults.SATURATION_LIMIT
    time_budget_factor: float = defaults.TIME_BUDGET_FACTOR
    time_budget_margin: float = defaults.TIME_BUDGET_MARGIN
    laps: int = 1
    table_points: int = defaults.PATH_TABLE_POINTS
    settle_time: float = defaults.SETTLE_TIME
    plant: str = defaults.PLANT
    sampled_design: bool = defaults.ORBITAL_SAMPLED_DESIGN
    design_cache: bool = defaults.DESIGN_CACHE
    identify_payload: bool = defaults.PAYLOAD_IDENTIFICATION
    events: tuple = ()
    run_to_end: bool = False

    def __post_init__(self):
        for name in ("sample_time", "path_tolerance", "path_tolerance_deg", "joint_tolerance", "time_budget_factor"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise SimulationError(f"SimulationSettings.{name} = {v!r}; it must be a number > 0")
        for name in ("time_budget_margin", "settle_time", "saturation_limit"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v >= 0):
                raise SimulationError(f"SimulationSettings.{name} = {v!r}; it must be a number >= 0")
        if not (isinstance(self.substeps, int) and self.substeps >= 1):
            raise SimulationError(f"SimulationSettings.substeps = {self.substeps!r}; give an integer >= 1")
        if self.plant not in PLANT_NAMES:
            raise SimulationError(f"SimulationSettings.plant = {self.plant!r}; choose one of {', '.join(PLANT_NAMES)}")
        if not (isinstance(self.laps, int) and self.laps >= 1):
            raise SimulationError(f"SimulationSettings.laps = {self.laps!r}; give an integer >= 1")


def _check_inputs(robot: Robot, path: JointPath, profile: Profile) -> None:
    if path.n != robot.n:
        raise SimulationError(f"the joint path has {path.n} joints, robot {robot.name} has {robot.n}")
    lo, hi = path.domain
    tol = DOMAIN_MATCH * max(1.0, hi - lo)
    if abs(profile.grid[0] - lo) > tol or abs(profile.grid[-1] - hi) > tol:
        raise SimulationError(
            f"the profile covers theta in [{profile.grid[0]:.6g}, {profile.grid[-1]:.6g}] but the path's domain is "
            f"[{lo:.6g}, {hi:.6g}]; plan the profile on this path"
        )


def make_controller(name: str, robot: Robot, path: JointPath, profile: Profile, table: PathTable,
                    settings: SimulationSettings, horizon: float, design: OrbitalDesign | None = None):
    """A fresh running controller ``name`` (one of CONTROLLER_NAMES) on the nominal robot."""
    if name == "orbital":
        if design is None:
            log.info("closed-loop design: orbital controller (transverse linearization, %s Riccati)",
                     "sampled" if settings.sampled_design else "continuous")
            design = OrbitalDesign.build(table, profile, settings.orbital_gains, *_sampling(settings))
        return OrbitalController(design, robot, settings.sample_time, int(settings.realism.delay), settings.sampled_design,
                                 settings.identify_payload)
    if name in ("computed_torque", "pd_gravity"):
        ref = TimeReference.sample(path, profile, settings.sample_time, horizon)
        if name == "computed_torque":
            return ComputedTorqueController(ref, robot, settings.computed_torque_gains)
        return PDGravityController(ref, robot, settings.pd_gains)
    raise SimulationError(f"unknown controller '{name}'; choose one of {', '.join(CONTROLLER_NAMES)}")


def _sampling(settings: SimulationSettings) -> tuple[float | None, int]:
    """(sample_time, delay) of the orbital design: (None, 0) for the continuous-time one."""
    return (settings.sample_time, int(settings.realism.delay)) if settings.sampled_design else (None, 0)


class PlantModel(Protocol):
    """What the loop needs of a plant: torque_limit (n,) [N m]; step: the state (q, qd) (n,) after ``dt`` [s]
    with the torque tau (n,) held; check_step: raise SimulationError when it cannot integrate that step."""

    torque_limit: np.ndarray

    def step(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, dt: float, substeps: int
             ) -> tuple[np.ndarray, np.ndarray]: ...

    def check_step(self, q: np.ndarray, dt: float, substeps: int) -> None: ...

    def substeps_needed(self, q: np.ndarray, dt: float) -> tuple[int, str]: ...


@blas_single_threaded
def prepare_loop(robot: Robot, path: JointPath, profile: Profile, controller: str = "orbital",
                 settings: SimulationSettings = SimulationSettings(), design: OrbitalDesign | None = None,
                 plant: PlantModel | None = None) -> tuple:
    """Everything :func:`simulate` sets up before its loop, raising the SimulationError it would raise (the
    inputs, the path table and the orbital design, through the on-disk cache when settings.design_cache,
    the controller, the plant and its first step, the end rules). ``pathmotion check`` runs it, so that
    its OK means that simulate starts. Returns (table, command, plant, planned TCP line, end rules,
    time budget [s])."""
    _check_inputs(robot, path, profile)
    if settings.events and controller != "orbital":
        raise SimulationError(f"simulate.events need the orbital controller (it follows a re-timed profile), "
                              f"not {controller!r}")
    budget = time_budget(settings, profile.duration, path.closed) + events_allowance(settings, profile.duration)
    ts, substeps = settings.sample_time, settings.substeps
    if design is None and settings.design_cache:
        if controller == "orbital":
            design = cached_design(path, profile, settings.orbital_gains, *_sampling(settings),
                                   points=settings.table_points)
            table = design.table
        else:
            table = cached_table(path, settings.table_points)[0]
    else:
        table = design.table if design is not None else PathTable.from_path(path, settings.table_points)
    control = _Command(make_controller(controller, robot, path, profile, table, settings, budget + ts, design),
                       Sensor(settings.realism), settings.realism.delay)
    plant = make_plant(settings.plant, robot, settings.realism) if plant is None else plant
    substeps = plant_substeps(plant, np.array(path.evaluate(path.domain[0])[0], dtype=float), ts, substeps)
    line = planned_tcp_line(robot, path, table.grid)
    return table, control, plant, line, end_rules(table, profile, line, budget, settings), budget, substeps


def plant_substeps(plant: PlantModel, q: np.ndarray, ts: float, asked: int) -> tuple[int, str]:
    """(sub-steps per sample, note): ``asked`` (simulate.substeps), raised to the count the plant needs at
    ``q`` to integrate its friction accurately (the note says so; empty when not raised); a SimulationError
    naming the scenario keys when that count exceeds defaults.MAX_PLANT_SUBSTEPS."""
    need, why = plant.substeps_needed(q, ts)
    if need <= asked:
        return asked, ""
    if need > defaults.MAX_PLANT_SUBSTEPS:
        plant.check_step(q, ts, asked)  # raises, naming the keys to change
    note = (f"simulate.substeps {asked} raised to {need}: {why}; a plant step of at most {ts / need:.3g} s "
            "integrates it accurately")
    log.info("%s", note)
    return need, note


def events_allowance(settings: SimulationSettings, duration: float) -> float:
    """Extra time budget [s] for the events: the last event's time, and the planned ``duration`` [s] stretched
    by the lowest override (time_budget_factor x duration x (1 / override - 1))."""
    if not settings.events:
        return 0.0
    lowest = min([e.override for e in settings.events if e.override is not None], default=1.0)
    return max(e.t for e in settings.events) + settings.time_budget_factor * duration * (1.0 / lowest - 1.0)


def time_budget(settings: SimulationSettings, duration: float, closed: bool) -> float:
    """The closed loop's time budget [s]: ``time_budget_factor`` x the planned duration [s] (x ``laps`` on a
    closed path) + ``time_budget_margin``. A ScenarioError, before any array is built, when the run at
    ``settings.sample_time`` would hold more than ``defaults.MAX_TRAJECTORY_SAMPLES`` samples."""
    budget = settings.time_budget_factor * duration * (settings.laps if closed else 1) + settings.time_budget_margin
    count = budget / settings.sample_time + 1
    if count > defaults.MAX_TRAJECTORY_SAMPLES:  # the closed loop holds arrays of this many samples
        raise ScenarioError(f"simulate.sample_time = {settings.sample_time:g} s: the {budget:.4g} s closed-loop run "
                            f"would need {count:.3g} samples, more than {defaults.MAX_TRAJECTORY_SAMPLES:,} "
                            "(defaults.MAX_TRAJECTORY_SAMPLES); raise the sample time (the default is "
                            f"{defaults.SAMPLE_TIME:g} s)")
    return budget


@blas_single_threaded
def simulate(robot: Robot, path: JointPath, profile: Profile, controller: str = "orbital",
             settings: SimulationSettings = SimulationSettings(), design: OrbitalDesign | None = None,
             plant: PlantModel | None = None, retimer=None) -> SimulationResult:
    """Run ``controller`` on ``robot`` along q = Phi(theta) with the planned ``profile``.

    The run starts on the plan: q = Phi(theta_start), qd = Phi'(theta_start) sqrt(x*(theta_start)).
    ``design``: a prebuilt OrbitalDesign on this path and profile (reused across runs), optional.
    ``plant``: a prebuilt plant (:class:`PlantModel`); default ``make_plant(settings.plant, robot, settings.realism)``.
    ``retimer``: the plan's :class:`~pathmotion.planning.retime.Retimer`, needed by ``settings.events``.
    Raises SimulationError only for unusable inputs; tracking failures are in the result.
    """
    if settings.events and retimer is None:
        raise SimulationError("simulate: settings.events need the plan's Retimer (retimer=Retimer(plan_result))")
    table, control, plant, line, rules, budget, (substeps, note) = prepare_loop(robot, path, profile, controller,
                                                                                settings, design, plant)
    player = EventPlayer(settings.events, retimer, robot, path, profile, settings) if settings.events else None
    ts = settings.sample_time
    phi0, dphi0, _ = path.evaluate(path.domain[0])
    q, qd = np.array(phi0, dtype=float), np.array(dphi0, dtype=float) * np.sqrt(profile.x[0])
    log.info("loop start: %s controller, %s plant, Ts = %g s (%d sub-steps), time budget %.4g s", controller,
             settings.plant, ts, substeps, budget)
    monitor = _Monitor(table, robot, line, ts)
    rec = _Record(int(np.ceil(budget / ts)) + 1, robot.n)
    failure, arrival, keep, sample = None, _Arrived(), True, None
    k = 0
    for k in range(rec.count):
        rec.q[k], rec.qd[k] = q, qd
        sample = monitor.measure(k, k * ts, q, qd, arrival.time is not None)  # measure (the true state)
        rec.theta[k] = sample.theta
        if settings.run_to_end:
            found, verdict = _all_checks(rules, sample)
            failure = failure or found
        else:
            verdict = _first_check(rules, sample)
            if isinstance(verdict, Failure):
                failure = verdict
                break
        if verdict is not None and arrival.update(verdict, k):
            keep = verdict.keep
            break
        if player is not None:
            player.step(sample.t, sample.theta, sample.theta_dot, control)
        cmd = control(sample.t, q, qd)  # control
        rec.cmd[k] = cmd
        tau = rec.tau[k]
        finite, clipped = saturate(cmd, plant.torque_limit, tau)
        torque_failure = _first_torque_check(rules, sample, cmd, tau, finite, clipped)
        if torque_failure is not None:
            failure = failure or torque_failure
            if not finite:
                rec.cmd[k], rec.tau[k] = 0.0, 0.0
            if not (settings.run_to_end and finite):
                break
        rec.saturated += clipped
        q, qd = plant.step(q, qd, tau, ts, substeps)  # step
    stopped = failure is not None and not settings.run_to_end
    failure = _earliest([failure, *(rule.finish(sample) for rule in rules)])
    log.info("loop end at t = %.4g s: %s", k * ts, f"failed ({failure.reason}): {failure.message}"
             if failure is not None else f"arrived, cycle time {arrival.time:.6g} s" if arrival.time is not None
             else "no arrival")
    events = tuple(r.as_dict() for r in player.reports) if player is not None else ()
    result = dataclasses.replace(
        _result(robot, path, profile, controller, settings, table, line, rec, k + keep, arrival, failure,
                control.identified(), events), substeps=substeps, substeps_note=note or None,
        stopped_at_failure=stopped, path_end_index=None if path.closed or failure is not None else arrival.index)
    return orientation_verdict(result, settings.path_tolerance_deg)


def _first_check(rules, sample: Sample):
    """The first rule's verdict on ``sample`` that is not None (None if all are); a plain loop, per sample."""
    for rule in rules:
        verdict = rule.check(sample)
        if verdict is not None:
            return verdict
    return None


def orientation_verdict(result: SimulationResult, tolerance_deg: float) -> SimulationResult:
    """``result`` judged on the tool's orientation too: when its orientation path accuracy (on the path) exceeds
    ``tolerance_deg`` [deg] and it has no earlier failure, it fails there ("orientation_tolerance"), with the
    angle's largest value; its cycle and settle times are then None."""
    angles = np.degrees(result.orientation_deviation[result.on_path()])
    over = np.flatnonzero(angles > tolerance_deg)
    if not over.size:
        return result
    i, peak = int(over[0]), int(np.argmax(angles))
    failure = Failure("orientation_tolerance", float(result.t[i]), float(result.theta[i]),
                      f"the tool's orientation left the {tolerance_deg:.4g} deg tolerance at t = {result.t[i]:.4g} s, "
                      f"theta = {result.theta[i]:.6g} and turned {angles[peak]:.4g} deg from the planned orientation "
                      f"(largest at t = {result.t[peak]:.4g} s); slow the motion down there or raise "
                      "simulate.path_tolerance_deg", value=float(angles[peak]), limit=tolerance_deg, unit="deg")
    if result.failure is not None and result.failure.t <= failure.t:
        return result
    return dataclasses.replace(result, failure=failure, cycle_time=None, settle_time=None)


def _all_checks(rules, sample: Sample):
    """(the first failure among every rule's verdict on ``sample``, the first verdict that is not a failure);
    either None. Every rule sees every sample (a run that goes on after a failure)."""
    verdicts = [rule.check(sample) for rule in rules]
    return (next((v for v in verdicts if isinstance(v, Failure)), None),
            next((v for v in verdicts if v is not None and not isinstance(v, Failure)), None))


def _first_torque_check(rules, sample: Sample, cmd: np.ndarray, tau: np.ndarray, finite: bool, clipped: bool):
    """The first rule's failure on this sample's commanded and applied torque (None if no rule fails)."""
    for rule in rules:
        failure = rule.check_torque(sample, cmd, tau, finite, clipped)
        if failure is not None:
            return failure
    return None


def _first(verdicts):
    """The first verdict that is not None (None if all are)."""
    return next((v for v in verdicts if v is not None), None)


def _earliest(failures: list[Failure | None]) -> Failure | None:
    """The failure that started first (the first listed on a tie); its message says how the run ended when
    another failure ended it."""
    found = [f for f in failures if f is not None]
    if not found:
        return None
    first = min(found, key=lambda f: f.t)
    if found[0] is not first and failures[0] is not None:
        end = failures[0]
        first = Failure(first.reason, first.t, first.theta, f"{first.message} (the run ended at t = {end.t:.4g} s: "
                        f"{end.reason})", first.value, first.limit, first.unit)
    return first


class _Arrived:
    """The cycle and settle times the arrival verdicts have set."""

    def __init__(self):
        self.time, self.settle, self.index = None, None, None

    def update(self, verdict, k: int) -> bool:
        """Take an Arrival's times (and ``k``, the sample of the first cycle time: the end of the path, after which
        an open path only settles); True when it ends the run."""
        if verdict.time is not None and self.index is None:
            self.index = k
        self.time = verdict.time if verdict.time is not None else self.time
        self.settle = verdict.settle if verdict.settle is not None else self.settle
        return verdict.stop


class _Command:
    """The torque the controller commands for the sensor's view of (q, qd), ``delay`` samples late (until
    then the first command is held)."""

    def __init__(self, controller, sensor: Sensor, delay: int):
        self.controller, self.sensor, self.delay, self.pending = controller, sensor, int(delay), []

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        cmd = self.controller(t, *self.sensor.measure(q, qd))
        if not self.delay:
            return cmd
        self.pending.append(cmd)
        return self.pending.pop(0) if len(self.pending) > self.delay else self.pending[0]

    def identified(self) -> dict | None:
        """What the controller's payload identification holds now (:meth:`.PayloadEstimator.identified`), None
        for a controller without it."""
        estimator = getattr(self.controller, "payload", None)
        return None if estimator is None else estimator.identified()


class _Monitor:
    """Projection of the true state onto the path, sample after sample (:func:`.monitor.monitor_state`), and
    the TCP's distance from the planned TCP path ``line`` (M, 3) on table.grid and from its end point."""

    def __init__(self, table: PathTable, robot: Robot, line: np.ndarray, sample_time: float):
        self.table, self.path, self.projection = table, table.arrays, table.projection()
        self.speed_limit = defaults.DIVERGENCE_SPEED_FACTOR * np.asarray(robot.limits.velocity, float)
        self.speed_eps = FLAT_SPEED2 * table.speed2_scale
        self.sample_time = sample_time
        self.theta, self.theta_dot = table.domain[0], 0.0
        self.line, self.window = line, line_window(len(table.grid))
        self.model, self.data, self.tcp_frame = robot.model, robot.model.createData(), robot.frame_id(None)
        self.centre = np.zeros(1, dtype=np.int64)  # the TCP's segment of the line, reused each sample
        self.end = None if table.closed else line[-1]

    def measure(self, k: int, t: float, q: np.ndarray, qd: np.ndarray, arrived: bool) -> Sample:
        previous = self.theta
        guess = self.table.next_guess(self.theta, self.theta_dot, self.sample_time)
        theta, theta_dot, dev, along, speed2, ok = monitor_state(self.path, q, qd, guess, self.projection,
                                                                 self.speed_limit, self.speed_eps)
        self.theta, self.theta_dot = theta, theta_dot
        distance, to_end = self.tcp(q, theta) if ok else (np.inf, np.inf)
        return Sample(k, t, theta, theta_dot, dev, along, speed2, ok, q, qd, previous, arrived, distance, to_end)

    def tcp(self, q: np.ndarray, theta: float) -> tuple[float, float]:
        """Distance [m] of the TCP at q from the planned TCP path near theta, and from the end point."""
        grid = self.table.grid
        pin.forwardKinematics(self.model, self.data, q)  # the TCP frame alone, without robot.fk's batch handling
        tcp = pin.updateFramePlacement(self.model, self.data, self.tcp_frame).translation
        lo, hi = self.table.domain
        th = lo + (theta - lo) % (hi - lo) if self.table.closed else min(max(theta, lo), hi)
        self.centre[0] = min(max(int(grid.searchsorted(th)) - 1, 0), len(grid) - 2)
        dist = polyline_distance_local(tcp[None, :], self.line, self.centre, self.window, self.table.closed)[0]
        gap = None if self.end is None else tcp - self.end
        to_end = np.inf if gap is None else math.sqrt(gap @ gap)  # np.linalg.norm's own formula
        return float(dist[0]), to_end


class _Record:
    """The signals of a run of at most ``count`` samples: q, qd, tau (applied), cmd (commanded) (count, n),
    theta (count,), and the number of samples with a clipped torque."""

    def __init__(self, count: int, n: int):
        self.count = count
        self.q, self.qd = np.empty((count, n)), np.empty((count, n))
        self.tau, self.cmd = np.zeros((count, n)), np.zeros((count, n))
        self.theta = np.empty(count)
        self.saturated = 0

    def trimmed(self, last: int) -> tuple[np.ndarray, ...]:
        """(q, qd, tau, cmd, theta) of the first ``last`` samples; the final sample, which computed no torque,
        repeats the torque before it."""
        if last > 1 and not np.any(self.cmd[last - 1]):
            self.cmd[last - 1], self.tau[last - 1] = self.cmd[last - 2], self.tau[last - 2]
        return self.q[:last], self.qd[:last], self.tau[:last], self.cmd[:last], self.theta[:last]


def _result(robot, path, profile, controller, settings, table, line, rec: _Record, last: int, arrival: _Arrived,
            failure, identified: dict | None = None, events: tuple = ()) -> SimulationResult:
    q, qd, tau, cmd, theta = rec.trimmed(last)
    saturation = rec.saturated * settings.sample_time
    t = np.arange(len(q)) * settings.sample_time
    finite = np.all(np.isfinite(q), axis=1)
    q_ok, th_ok = q[finite], theta[finite]
    theta_p, q_des = polish_projection(path, q_ok, th_ok) if len(q_ok) else (th_ok, q_ok.copy())
    tcp, tcp_des, path_dev = tcp_path_deviation(robot, path, q_ok, th_ok, table.grid, line)  # the verdict's theta
    corner = original_path_deviation(path, tcp)
    ok = failure is None
    return SimulationResult(
        controller=controller, sample_time=settings.sample_time, closed=path.closed, t=t[finite], theta=theta_p,
        q=q_ok, qd=qd[finite], tau=tau[finite], tau_command=cmd[finite], q_desired=q_des, tcp=tcp,
        tcp_desired=tcp_des, joint_deviation=np.max(np.abs(q_ok - q_des), axis=1) if len(q_ok) else np.zeros(0),
        path_deviation=path_dev, corner_deviation=corner, torque_limit=np.asarray(robot.limits.torque, float),
        planned_duration=profile.duration, cycle_time=arrival.time if ok else None, saturation_time=float(saturation),
        failure=failure, settle_time=arrival.settle if ok else None, path_tolerance=settings.path_tolerance,
        cornering_deviation=cornering_deviation(path, tcp, theta_p), identified=identified, events=events,
        orientation_deviation=orientation_deviation(robot, q_ok, q_des), path_tolerance_deg=settings.path_tolerance_deg,
    )
