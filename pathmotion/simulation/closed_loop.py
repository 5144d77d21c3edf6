"""The closed loop: a discrete controller at a fixed sample time driving the plant.

Per sample k (t_k = k Ts): measure (sensor model) -> controller -> torque (one sample later with the
delay switch) -> saturate -> plant integrates the sample with the torque held. A monitor projects the
true state onto the path every sample and ends the run with a :class:`~.metrics.Failure` on
divergence, leaving the path's theta range, a deviation past the threshold, or the time budget
(``time_budget_factor`` x planned duration + ``time_budget_margin``). Failures are results, not
exceptions; a run always ends (the sample count is bounded by the budget).

Open paths planned to end at rest end ``settle_time`` after arrival: max_j |q - Phi(theta_end)| <=
``arrival_tolerance`` with the projected theta in the end's own stretch of the path (so a path whose
start is its end does not arrive at t = 0), the crossing interpolated between samples. Open paths
planned to end moving stop when the robot crosses the end (the projection extended past it reaches
theta_end, interpolated). Closed paths end after ``laps`` turns of theta (crossing interpolated), their
simulated duration is the mean period.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import defaults
from ..control import (CONTROLLER_NAMES, ComputedTorqueController, OrbitalController, OrbitalDesign, OrbitalGains,
                       PathTable, PDGravityController, TimeReference, TrackingGains, default_pd_gains)
from ..errors import SimulationError
from ..joint_path import JointPath
from ..planning.profile import Profile
from ..robot import Robot
from .metrics import (Failure, SimulationResult, original_path_deviation, polish_projection,
                      tcp_path_deviation)
from .monitor import monitor_state
from .plant import Plant, saturate
from .realism import Realism, Sensor


@dataclass(frozen=True)
class SimulationSettings:
    """sample_time [s]; substeps: RK4 steps per sample; realism; gains of the three controllers;
    failure_threshold [rad]; time budget = time_budget_factor * planned + time_budget_margin [s];
    laps (closed paths); table_points of the controller's path table; arrival_tolerance [rad] and
    settle_time [s] (open paths)."""

    sample_time: float = defaults.SAMPLE_TIME
    substeps: int = defaults.PLANT_SUBSTEPS
    realism: Realism = field(default_factory=Realism)
    orbital_gains: OrbitalGains = field(default_factory=OrbitalGains)
    computed_torque_gains: TrackingGains = field(default_factory=TrackingGains)
    pd_gains: TrackingGains = field(default_factory=default_pd_gains)
    failure_threshold: float = defaults.TRACKING_FAILURE_THRESHOLD
    time_budget_factor: float = defaults.TIME_BUDGET_FACTOR
    time_budget_margin: float = defaults.TIME_BUDGET_MARGIN
    laps: int = 1
    table_points: int = defaults.PATH_TABLE_POINTS
    arrival_tolerance: float = defaults.ARRIVAL_TOLERANCE
    settle_time: float = defaults.SETTLE_TIME

    def __post_init__(self):
        for name in ("sample_time", "failure_threshold", "time_budget_factor", "arrival_tolerance"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise SimulationError(f"SimulationSettings.{name} = {v!r}; it must be a number > 0")
        for name in ("time_budget_margin", "settle_time"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v >= 0):
                raise SimulationError(f"SimulationSettings.{name} = {v!r}; it must be a number >= 0")
        if not (isinstance(self.substeps, int) and self.substeps >= 1):
            raise SimulationError(f"SimulationSettings.substeps = {self.substeps!r}; give an integer >= 1")
        if not (isinstance(self.laps, int) and self.laps >= 1):
            raise SimulationError(f"SimulationSettings.laps = {self.laps!r}; give an integer >= 1")


def _check_inputs(robot: Robot, path: JointPath, profile: Profile) -> None:
    if path.n != robot.n:
        raise SimulationError(f"the joint path has {path.n} joints, robot {robot.name} has {robot.n}")
    lo, hi = path.domain
    tol = 1e-9 * max(1.0, hi - lo)
    if abs(profile.grid[0] - lo) > tol or abs(profile.grid[-1] - hi) > tol:
        raise SimulationError(
            f"the profile covers theta in [{profile.grid[0]:.6g}, {profile.grid[-1]:.6g}] but the path's domain is "
            f"[{lo:.6g}, {hi:.6g}]; plan the profile on this path"
        )


def make_controller(name: str, robot: Robot, path: JointPath, profile: Profile, table: PathTable,
                    settings: SimulationSettings, horizon: float, design: OrbitalDesign | None = None):
    """A fresh running controller ``name`` (one of CONTROLLER_NAMES) on the nominal robot."""
    if name == "orbital":
        design = design if design is not None else OrbitalDesign.build(table, profile, settings.orbital_gains)
        return OrbitalController(design, robot, settings.sample_time)
    if name in ("computed_torque", "pd_gravity"):
        ref = TimeReference.sample(path, profile, settings.sample_time, horizon)
        if name == "computed_torque":
            return ComputedTorqueController(ref, robot, settings.computed_torque_gains)
        return PDGravityController(ref, robot, settings.pd_gains)
    raise SimulationError(f"unknown controller '{name}'; choose one of {', '.join(CONTROLLER_NAMES)}")


def simulate(robot: Robot, path: JointPath, profile: Profile, controller: str = "orbital",
             settings: SimulationSettings = SimulationSettings(), design: OrbitalDesign | None = None
             ) -> SimulationResult:
    """Run ``controller`` on ``robot`` along q = Phi(theta) with the planned ``profile``.

    The run starts on the plan: q = Phi(theta_start), qd = Phi'(theta_start) sqrt(x*(theta_start)).
    ``design``: a prebuilt OrbitalDesign on this path and profile (reused across runs), optional.
    Raises SimulationError only for unusable inputs; tracking failures are in the result.
    """
    _check_inputs(robot, path, profile)
    ts, substeps = settings.sample_time, settings.substeps
    table = design.table if design is not None else PathTable.from_path(path, settings.table_points)
    lo, hi = path.domain
    length = hi - lo
    planned = profile.duration
    laps = settings.laps if path.closed else 1
    budget = settings.time_budget_factor * planned * laps + settings.time_budget_margin
    ctrl = make_controller(controller, robot, path, profile, table, settings, budget + ts, design)
    plant = Plant.from_robot(robot, settings.realism)
    sensor = Sensor(settings.realism)
    delay = settings.realism.delay

    phi0, dphi0, _ = path.evaluate(lo)
    q = np.array(phi0, dtype=float)
    qd = np.array(dphi0, dtype=float) * np.sqrt(profile.x[0])
    plant.check_step(q, ts, substeps)
    q_end = path.evaluate(hi, side="left")[0]
    # the plan itself spends (planned - plan_arrival) inside the arrival ball: credited to the run. Arrival
    # also needs theta past the point where the plan enters the ball (less the ball's own theta extent), so a
    # path that starts where it ends (a full circle run from rest to rest) does not arrive at t = 0
    if path.closed:
        plan_arrival, arrival_theta = None, lo
    else:
        plan_arrival, theta_in = _plan_arrival(table, profile, q_end, settings.arrival_tolerance)
        arrival_theta = theta_in - (hi - theta_in)
    # an open path planned to end moving (x*(end) > 0) arrives when the robot crosses the end, and the run
    # stops there: what follows is not part of the plan
    moving_end = not path.closed and profile.x[-1] > 0
    speed_limit = defaults.DIVERGENCE_SPEED_FACTOR * np.asarray(robot.limits.velocity, float)

    count = int(np.ceil(budget / ts)) + 1
    n = robot.n
    rec_q, rec_qd = np.empty((count, n)), np.empty((count, n))
    rec_tau, rec_cmd = np.zeros((count, n)), np.zeros((count, n))
    rec_theta = np.empty(count)
    saturated = 0
    failure = None
    done_at = None  # simulated duration (arrival or laps crossing)
    stop_at = None
    theta, theta_dot = lo, 0.0
    prev_end_dist = None
    pending = None
    crossed = False
    thr = settings.failure_threshold
    tol_arrival = settings.arrival_tolerance
    grid, coeffs, closed, kinks = table.grid, table.coeffs, table.closed, table.kinks
    projection = (defaults.PROJECTION_ITERATIONS, defaults.PROJECTION_TOLERANCE * length,
                  defaults.PROJECTION_MAX_STEP * length)
    speed_eps = 1e-12 * table.speed2_scale
    torque_limit = plant.torque_limit
    k = 0
    for k in range(count):
        t = k * ts
        # --- monitor the true state ---------------------------------------------------------------
        rec_q[k], rec_qd[k] = q, qd
        theta, theta_dot, dev, along, speed2, ok = monitor_state(
            grid, coeffs, closed, kinks, q, qd, table.next_guess(theta, theta_dot, ts), *projection, speed_limit,
            speed_eps)
        rec_theta[k] = theta
        if not ok:
            failure = Failure("diverged", t, theta, f"the state diverged (|qd| above {defaults.DIVERGENCE_SPEED_FACTOR:g}"
                              f" x the velocity limit or NaN) at t = {t:.4g} s, theta = {theta:.6g}")
            break
        if moving_end and theta >= hi:
            # arrival at a moving end: the robot crosses the normal plane of the end, theta_ext = hi, with
            # theta_ext = theta + Phi'^T y / |Phi'|^2 extending the projection past the end
            ext = theta + along
            prev = rec_theta[k - 1] if k else lo
            done_at = float(t - ts + ts * (hi - prev) / (ext - prev)) if ext > prev else t
            crossed = True  # this sample lies past the end: not part of the recorded motion
            break
        if not closed and (theta <= lo or theta >= hi) and speed2 > speed_eps:
            excess = along * np.sqrt(speed2)
            if (theta >= hi and excess > thr) or (theta <= lo and excess < -thr):
                side = "end" if theta >= hi else "start"
                failure = Failure("left_path_range", t, theta,
                                  f"the robot left the path past its {side} (theta = {theta:.6g}) by "
                                  f"{abs(excess):.3g} rad at t = {t:.4g} s")
                break
        if dev > thr:
            failure = Failure("deviation", t, theta, f"joint deviation {dev:.3g} rad > {thr:g} rad at t = {t:.4g} s, "
                              f"theta = {theta:.6g}; slow the profile down or raise the gains")
            break
        if stop_at is not None and t >= stop_at - 1e-12:
            break
        if done_at is None:
            if closed:
                turns = (theta - lo) / length
                if turns >= laps:
                    prev = (rec_theta[k - 1] - lo) / length
                    done_at = float((t - ts + ts * (laps - prev) / (turns - prev)) / laps)
                    stop_at = t
                    break
            elif theta >= arrival_theta:
                end_dist = float(np.abs(q - q_end).max())
                if end_dist <= tol_arrival:
                    if prev_end_dist is None or prev_end_dist <= tol_arrival:
                        done_at = t
                    else:
                        done_at = t - ts + ts * (prev_end_dist - tol_arrival) / (prev_end_dist - end_dist)
                    done_at = float(done_at + planned - plan_arrival)
                    stop_at = t + settings.settle_time
                prev_end_dist = end_dist
        if done_at is None and t >= budget:
            failure = Failure("timeout", t, theta, f"the robot did not reach the end of the path within the time budget "
                              f"{budget:.4g} s (theta = {theta:.6g} of [{lo:.6g}, {hi:.6g}])")
            break
        # --- control and plant ---------------------------------------------------------------------
        q_m, qd_m = sensor.measure(q, qd)
        cmd = ctrl(t, q_m, qd_m)
        if delay:
            cmd, pending = (cmd if pending is None else pending), cmd
        rec_cmd[k] = cmd
        finite, sat = saturate(cmd, torque_limit, rec_tau[k])
        if not finite:
            rec_cmd[k], rec_tau[k] = 0.0, 0.0
            failure = Failure("diverged", t, theta, f"the controller returned a non-finite torque at t = {t:.4g} s, "
                              f"theta = {theta:.6g}")
            break
        saturated += sat
        q, qd = plant.step(q, qd, rec_tau[k], ts, substeps)
    last = k if crossed else k + 1
    if last > 1 and not np.any(rec_cmd[last - 1]):  # no torque was computed at the final sample
        rec_cmd[last - 1], rec_tau[last - 1] = rec_cmd[last - 2], rec_tau[last - 2]
    return _result(robot, path, profile, controller, settings, table, rec_q[:last], rec_qd[:last],
                   rec_tau[:last], rec_cmd[:last], rec_theta[:last], done_at if failure is None else None,
                   saturated * ts, failure)


def _plan_arrival(table: PathTable, profile: Profile, q_end: np.ndarray, tolerance: float) -> tuple[float, float]:
    """Planned time [s] and theta at which the plan enters max_j |Phi(theta*(t)) - q_end| <= tolerance for the
    last time (found on a 1 ms grid, interpolated linearly)."""
    t = np.linspace(0.0, profile.duration, max(2, int(np.ceil(profile.duration / 1e-3)) + 1))
    theta = profile.state_at_time(t)[0]
    dist = np.max(np.abs(table.evaluate(theta)[0] - q_end), axis=1)
    outside = np.nonzero(dist > tolerance)[0]
    if len(outside) == 0:
        return 0.0, float(theta[0])
    i = int(outside[-1])
    if i + 1 >= len(t):
        return float(profile.duration), float(theta[-1])
    w = (dist[i] - tolerance) / (dist[i] - dist[i + 1])
    return float(t[i] + (t[i + 1] - t[i]) * w), float(theta[i] + (theta[i + 1] - theta[i]) * w)


def _result(robot, path, profile, controller, settings, table, q, qd, tau, cmd, theta, duration, saturation,
            failure) -> SimulationResult:
    t = np.arange(len(q)) * settings.sample_time
    finite = np.all(np.isfinite(q), axis=1)
    q_ok, th_ok = q[finite], theta[finite]
    theta_p, q_des = polish_projection(path, q_ok, th_ok) if len(q_ok) else (th_ok, q_ok.copy())
    points = len(table.grid)
    tcp, tcp_des, path_dev = tcp_path_deviation(robot, path, q_ok, theta_p, points)
    corner = original_path_deviation(path, tcp, points)
    return SimulationResult(
        controller=controller, sample_time=settings.sample_time, closed=path.closed, t=t[finite], theta=theta_p,
        q=q_ok, qd=qd[finite], tau=tau[finite], tau_command=cmd[finite], q_desired=q_des, tcp=tcp,
        tcp_desired=tcp_des, joint_deviation=np.max(np.abs(q_ok - q_des), axis=1) if len(q_ok) else np.zeros(0),
        path_deviation=path_dev, corner_deviation=corner, torque_limit=np.asarray(robot.limits.torque, float),
        planned_duration=profile.duration, simulated_duration=duration, saturation_time=float(saturation),
        failure=failure,
    )
