"""Plan a built scenario and write the plan: trajectory, summary.json, phase plane, exports, report data."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np

from .. import defaults
from ..geometry import max_deviation
from ..io import exports, schema
from ..io.atomic import write_json, write_text
from ..planning import PlanResult, PlanSettings, effective_limits, plan
from ..planning.blend_speed import cap_blend_speed
from ..planning.limit_curves import X_UNBOUNDED, limit_curves, steady_curves
from ..planning.limits import REGISTRY as LIMIT_REGISTRY
from ..robot import Robot, fk
from ..robot.arm import arm_points
from .failures import FailureKind, ResultFailure
from ..planning.program_moves import move_table
from .program import axis_times, program_targets, program_thetas
from .rapid import rapid_estimate
from .setup import Setup

log = logging.getLogger(__name__)


def plan_scenario(setup: Setup) -> PlanResult:
    """The time-optimal plan of the scenario (with baselines and verification); with
    ``plan.blend_speed_scale`` < 1 the blends are then slowed to that fraction (verified). A setup whose
    reserve search ran returns the plan of the chosen reserve, planned then. ScenarioError when the setup
    still needs :func:`pathmotion.api.search`."""
    setup.require_searched("plan_scenario")
    if setup.reserve_run is not None:
        return setup.reserve_run[0]
    result = plan(setup.path, setup.robot, setup.plan_settings)
    scale = setup.scenario.plan.blend_speed_scale
    if scale != 1.0:
        log.info("slowing the blends to %g of their optimal speed", scale)
        result = cap_blend_speed(setup, result, scale)
    return result


def plan_failures(result: PlanResult, setup: Setup | None = None) -> list[ResultFailure]:
    """Why the planned motion must not be run as it is (empty when it may): a jump in the path speed
    (theta_dot) at a connection, a limit exceeded by more than LIMIT_TOLERANCE on the verification
    resample (a kink crossed at speed makes the acceleration and torque unbounded), and with ``setup``:
    a ``torque_reserve = "auto"`` search that found no reserve with which the closed loop tracks."""
    out = [ResultFailure(FailureKind.SPEED_JUMP, f"the path speed jumps at theta = {a:.6g} .. {b:.6g} (a 'max' "
                         "connection)", f"theta = {a:.6g} .. {b:.6g}") for a, b in result.jump_intervals]
    r = result.ratios
    if r is not None and not r.within():
        out.append(ResultFailure(FailureKind.LIMIT_EXCEEDED, f"a limit is exceeded: {r.worst}", r.worst))
    if setup is not None and setup.reserve_search is not None and not setup.reserve_search.ok:
        out.append(ResultFailure(FailureKind.NO_RESERVE, setup.reserve_search.failure(), "limits.torque_reserve"))
    return out


# ------------------------------------------------------------------------------------- summary
def reserve_summary(setup: Setup) -> dict:
    """summary.json's record of a reserve search ({} without one): the reserve applied and every run."""
    search = setup.reserve_search
    if search is None:
        return {}
    return {"torque_reserve": search.applied, schema.TORQUE_RESERVE_SEARCH.key: search.records()}


def limit_settings_summary(robot: Robot, settings: PlanSettings) -> dict:
    """The limits' settings keys of summary.json (e.g. torque_reserve), from the limits the plan enforced,
    verified or not; null where the limit is off."""
    out = {key: None for cls in LIMIT_REGISTRY for key in cls.extra_summary_keys}
    for lim in effective_limits(robot, settings):
        out.update(lim.summary_values())
    return out


def plan_summary(setup: Setup, result: PlanResult) -> dict:
    """The contract keys of ``summary.json`` (io/schema.py) plus context."""
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
        out[schema.RAPID_ESTIMATE.key] = rapid_estimate(setup)
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


def write_moves(setup: Setup, result: PlanResult, samples, out: Path) -> None:
    """moves.csv (planning/program_moves.py): one row per program move of a task path whose segments carry
    program moves; an earlier moves.csv is removed when they carry none."""
    table, spec = None, setup.scenario.path
    if setup.task_path is not None and program_targets(spec):
        bounds, lengths = program_thetas(spec, setup.robot, setup.path)
        table = move_table(spec, bounds, lengths, result.profile, samples,
                           enforced_limits(setup.robot, result.settings), setup.robot.joint_names,
                           axis_times(spec, setup.robot, setup.path))
    if table is None:
        (out / schema.MOVES_FILE).unlink(missing_ok=True)
    else:
        exports.write_rows_csv(out / schema.MOVES_FILE, table)


def enforced_limits(robot: Robot, settings: PlanSettings) -> dict:
    """limits.json's "enforced": {limit name: ``Limit.enforced()``} for every active limit, SI units:
    per-joint lists (velocity, acceleration, torque with its reserve and scale, jerk, torque rate), one
    number (TCP speed), {"knee", "at_max_speed"} per joint (the torque-speed envelope)."""
    return {lim.name: lim.enforced() for lim in effective_limits(robot, settings)}


def second_order_plan(setup: Setup, result: PlanResult) -> PlanResult | None:
    """With jerk or torque-rate limits on: the verified plan under the same limits and grid without them
    (what those limits cost, for the phase plane and the summary); None when none is on."""
    settings = result.settings
    if not effective_limits(setup.robot, settings).third_order:
        return None
    limits = {cls.name: dataclasses.replace(settings.choice(cls), on=False) if cls.order == 3 else settings.choice(cls)
              for cls in LIMIT_REGISTRY}
    log.info("the plan without the jerk and torque-rate limits, for comparison")
    return plan(setup.path, setup.robot, dataclasses.replace(settings, limits=limits, baselines=False))


def phase_plane_columns(result: PlanResult, setup: Setup | None = None,
                        second: PlanResult | None = None) -> dict[str, np.ndarray]:
    """phase_plane.csv (column names in io/schema.py): theta (the planner's grid), the planner's limit
    curves, the profiles (optimal, fitted, constant speed) as theta_dot; with ``setup``, each active
    limit's own maximum-velocity curve and each third-order limit's steady-speed curve
    (planning/limit_curves.py); with ``second`` (the plan without the third-order limits,
    :func:`second_order_plan`), its profile."""
    grid = result.profile.grid
    cols = {schema.PHASE_THETA: grid, schema.PHASE_OPTIMAL: np.sqrt(result.profile.x)}
    if result.profile.u_nodes is not None:
        cols[schema.PHASE_OPTIMAL_DDOT] = result.profile.u_nodes
    if result.profile.holds is not None:
        cols[schema.PHASE_HOLDS] = result.profile.holds
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
        for name, curve in limit_curves(setup.path, setup.robot, result.settings, grid, result.path_points).items():
            cols[schema.limit_curve_column(name)] = curve
        for name, curve in steady_curves(setup.path, setup.robot, result.settings, grid).items():
            cols[schema.steady_curve_column(name)] = curve
    return cols


# ------------------------------------------------------------------------------------- files
def write_report_data(setup: Setup, out: Path, t: np.ndarray, q: np.ndarray) -> None:
    """limits.json (joint names, limits, the plan's scales), arm.csv (the arm's stick figure at
    REPORT_ARM_FRAMES of the times t (N,) [s] with joint positions q (N, n) [rad]) and, when blends
    replaced corners, original_path.csv (the sharp path, x, y, z [m])."""
    ps = setup.plan_settings
    scales = {name: ps.limits[name].scale if ps.limits[name].on else None
              for name in ("velocity", "acceleration", "torque")}
    record = exports.limits_record(setup.robot.joint_names, setup.robot.limits, scales)
    record["enforced"] = enforced_limits(setup.robot, ps)
    write_json(out / "limits.json", record)
    idx = exports.decimate(len(t), defaults.REPORT_ARM_FRAMES)
    exports.write_table_csv(out / "arm.csv", exports.arm_columns(t[idx], arm_points(setup.robot, q[idx])))
    task = setup.original_task_path
    if task is not None:
        points = np.asarray(task.evaluate(np.linspace(*task.domain, defaults.REPORT_MAX_POINTS))[0])[:, :3]
        exports.write_table_csv(out / "original_path.csv", {a: points[:, k] for k, a in enumerate("xyz")})


def _write_exports(setup: Setup, samples, out: Path, failures: list[ResultFailure], force: bool) -> list[str]:
    """The ROS 2, EGM and RAPID exports, each headed by :func:`exports.export_notes`; for a failed plan
    none (stale ones removed) unless ``force``. Returns the notes ([] when refused)."""
    if failures and not force:
        for name in exports.EXPORT_FILES:
            (out / name).unlink(missing_ok=True)
        return []
    messages = [f.message for f in failures]
    notes, abb = exports.export_notes(samples, messages), exports.export_notes(samples, messages, degrees=True)
    skipped = exports.unsupported_exports(setup.robot.n)
    writers = {"trajectory_ros2.yaml": lambda path: exports.write_ros2_yaml(
                   path, samples, setup.robot.joint_names, setup.scenario.plan.sample_time, notes=notes),
               "trajectory_egm.csv": lambda path: exports.write_egm_csv(path, samples, notes=abb),
               "trajectory_rapid.mod": lambda path: exports.write_rapid(path, samples, notes=abb)}
    for name in exports.EXPORT_FILES:
        if name in skipped:
            (out / name).unlink(missing_ok=True)
            log.info("%s", skipped[name])
        else:
            writers[name](out / name)
    return notes + list(skipped.values())


def write_plan(setup: Setup, result: PlanResult, out: str | Path, failures: list[ResultFailure] | None = None,
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
    write_moves(setup, result, samples, out)
    if setup.scenario_text:
        write_text(out / "scenario.toml", setup.scenario_text)
    summary = plan_summary(setup, result)
    summary[schema.SECOND_ORDER_DURATION.key] = None if second is None else second.duration
    summary[schema.FAILURES.key] = [f.record() for f in failures]
    summary[schema.EXPORT_NOTES.key] = notes
    write_json(out / "summary.json", summary)
    return summary
