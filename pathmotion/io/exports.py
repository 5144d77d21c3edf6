"""Exports of a sampled trajectory: CSV, Parquet, ROS 2 JointTrajectory YAML, ABB EGM stream, RAPID.

All take :class:`pathmotion.planning.trajectory.Samples` (t (N,), q/qd/qdd/tau (N, n)) and write
atomically. Units in files: SI and radians, except the ABB formats, which use degrees as the
controller does (jointtarget and EGM joint values are in degrees).
"""

from __future__ import annotations

import io as _io
from pathlib import Path

import numpy as np

from .. import defaults
from ..errors import PathmotionError
from .atomic import atomic_path, write_text
from .files import read_input


def trajectory_columns(samples, n: int | None = None) -> dict[str, np.ndarray]:
    """Column name -> values, in the contract order t, theta, theta_dot, theta_ddot, q1..qn,
    qd1..qdn, qdd1..qddn, tau1..taun (tau only when computed)."""
    n = samples.q.shape[1] if n is None else n
    cols = {"t": samples.t, "theta": samples.theta, "theta_dot": samples.theta_dot,
            "theta_ddot": samples.theta_ddot}
    for name, arr in (("q", samples.q), ("qd", samples.qd), ("qdd", samples.qdd), ("tau", samples.tau)):
        if arr is None:
            continue
        for j in range(n):
            cols[f"{name}{j + 1}"] = arr[:, j]
    return cols


def decimate(n: int, max_points: int = defaults.REPORT_MAX_POINTS) -> np.ndarray:
    """Indices of at most ``max_points`` samples out of ``n``, uniformly spread, first and last kept."""
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_points).round().astype(int))


def arm_columns(t: np.ndarray, points: np.ndarray) -> dict[str, np.ndarray]:
    """arm.csv columns: t (F,) [s], then p{k}_x, p{k}_y, p{k}_z [m] of the stick-figure vertices
    points (F, V, 3) (the base, the joint origins, the flange, the TCP last)."""
    cols = {"t": np.asarray(t, float)}
    for k in range(points.shape[1]):
        cols.update({f"p{k}_{a}": points[:, k, i] for i, a in enumerate("xyz")})
    return cols


def arm_points_from(cols: dict[str, np.ndarray]) -> np.ndarray:
    """The (F, V, 3) vertices of :func:`arm_columns` back from its columns."""
    count = 0
    while f"p{count}_x" in cols:
        count += 1
    return np.stack([np.column_stack([cols[f"p{k}_{a}"] for a in "xyz"]) for k in range(count)], axis=1)


def limits_record(joint_names, limits, scales: dict[str, float | None]) -> dict:
    """limits.json: the robot's joint names and limits (duck-typed: lower, upper, velocity,
    acceleration or None, torque; SI units) and the scale the plan applied to each limit kind
    (None when the plan did not enforce it)."""
    def values(v):
        return None if v is None else [float(x) for x in np.asarray(v, float)]

    return {"joint_names": list(joint_names),
            **{k: values(getattr(limits, k)) for k in ("lower", "upper", "velocity", "acceleration", "torque")},
            "plan_scale": dict(scales)}


#: write_table_csv formats this many rows per string operation [-] (bounds the temporary tuple of floats).
CSV_BLOCK_ROWS = 10_000


def write_table_csv(path: str | Path, columns: dict[str, np.ndarray]) -> Path:
    """CSV with a header line and full double precision (repr round-trips)."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    buf = _io.StringIO()
    buf.write(",".join(names) + "\n")
    # np.savetxt's text (fmt %.17g, one line per row), formatted a block of rows per % operation instead of one
    # per row: a plan's 200,000-row tables spent most of their writing in savetxt's per-row Python loop
    line = ",".join(["%.17g"] * data.shape[1]) + "\n"
    for a in range(0, len(data), CSV_BLOCK_ROWS):
        block = data[a:a + CSV_BLOCK_ROWS]
        buf.write((line * len(block)) % tuple(block.ravel().tolist()))
    return write_text(path, buf.getvalue())


def write_rows_csv(path: str | Path, columns: dict[str, list]) -> Path:
    """CSV of mixed columns (numbers, text, None as an empty cell) with a header line; numbers in full
    precision (repr round-trips)."""
    import csv

    names = list(columns)
    buf = _io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(names)
    for row in zip(*(columns[k] for k in names)):
        writer.writerow(["" if v is None else repr(float(v)) if isinstance(v, (float, np.floating)) else v
                         for v in row])
    return write_text(path, buf.getvalue())


def write_table_parquet(path: str | Path, columns: dict[str, np.ndarray]) -> Path:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({k: np.asarray(v) for k, v in columns.items()})
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return Path(path)


def read_table_csv(path: str | Path, required=(), who: str = "read") -> dict[str, np.ndarray]:
    """A numeric CSV with a header line (as :func:`write_table_csv` writes it) as {column: (N,) float array};
    PathmotionError (headed ``who``) when it cannot be read, a ``required`` column is missing or the table has
    no rows while columns are required."""
    path = Path(path)
    text = read_input(path, "result")  # a regular file under the result cap (a FIFO would hang)
    try:
        fh = _io.StringIO(text, newline="")
        header = fh.readline().strip().split(",")
        data = np.loadtxt(fh, delimiter=",", ndmin=2) if header != [""] else np.empty((0, 0))
    except ValueError as exc:
        raise PathmotionError(f"{who}: cannot read the table {path}: {exc}; re-run the command that wrote it") from None
    if header == [""] or (data.size and data.shape[1] != len(header)):
        raise PathmotionError(f"{who}: {path} has {data.shape[1] if data.size else 0} values per row but "
                              f"{len(header)} column names; re-run the command that wrote it")
    missing = [name for name in required if name not in header]
    if missing:
        raise PathmotionError(f"{who}: {path} has no column(s) {missing}; it was written by another version of "
                              "pathmotion or edited: re-run the command that wrote it")
    if not data.size:
        if required:
            raise PathmotionError(f"{who}: {path} has no rows; re-run the command that wrote it")
        return {name: np.empty(0) for name in header}
    return {name: data[:, k] for k, name in enumerate(header)}


def write_trajectory_csv(path, samples) -> Path:
    return write_table_csv(path, trajectory_columns(samples))


def write_trajectory_parquet(path, samples) -> Path:
    return write_table_parquet(path, trajectory_columns(samples))


#: Largest joint speed [rad/s] at the first sample that still counts as "at rest" for the exports' notes.
REST_SPEED = 1e-9


def export_notes(samples, failures=(), degrees: bool = False) -> list[str]:
    """Lines every export of ``samples`` carries at its top: a warning per failure of the plan (exports
    of a failed plan are written only on request) and, when the first sample is not at rest, the
    joint speeds the arm must already have when the motion starts ([rad/s], or [deg/s] with
    ``degrees``, the unit of the ABB files)."""
    notes = [f"WARNING: exported with --force although the plan failed: {f}" for f in failures]
    qd0 = np.asarray(samples.qd[0], float)
    if np.max(np.abs(qd0), initial=0.0) > REST_SPEED:
        speeds = ", ".join(f"{v:.4g}" for v in tidy(np.degrees(qd0) if degrees else qd0, EXPORT_DECIMALS))
        unit = "deg/s" if degrees else "rad/s"
        notes.append(f"the first sample is not at rest: the arm must already move at joint speeds [{speeds}] {unit} "
                     f"(theta_dot {float(samples.theta_dot[0]):.4g}) when this motion starts")
    return notes


#: A duration within this many cycles of a whole number of cycles is that number (round-off of t / dt) [-].
CYCLE_ROUNDING = 1e-9


def cycle_grid(duration: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The controller's cycle times for a motion of ``duration`` [s]: k (K+1,) integers and t = k dt [s]
    (rounded to the nanosecond), K = ceil(duration / dt), so every row is exactly one cycle after the
    previous one; the last row (at most one cycle after ``duration``) holds the end state."""
    count = int(np.ceil(duration / dt - CYCLE_ROUNDING)) if duration > 0 else 0
    k = np.arange(count + 1)
    return k, np.round(k * dt, 9)


def on_cycles(samples, dt: float) -> dict[str, np.ndarray]:
    """t (K+1,) on :func:`cycle_grid` and q, qd, qdd (K+1, n) linearly interpolated from ``samples``
    there (exact at the samples themselves); past the planned end the end state holds."""
    t = samples.t
    _, grid = cycle_grid(float(t[-1]), dt)
    at = np.minimum(grid, t[-1])
    out = {"t": grid}
    for name in ("q", "qd", "qdd"):
        arr = getattr(samples, name)
        out[name] = np.column_stack([np.interp(at, t, arr[:, j]) for j in range(arr.shape[1])])
    return out


def tidy(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` rounded to ``decimals`` places, with -0 turned into 0 (for human-read exports)."""
    return np.round(np.asarray(values, float), decimals) + 0.0


def _csv_text(columns: dict[str, np.ndarray], comments=()) -> str:
    """CSV with the shortest text that reads back each value (``repr``), after optional '# ' comment lines."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    lines = [f"# {c}" for c in comments] + [",".join(names)]
    lines += [",".join(map(repr, row)) for row in data.tolist()]
    return "\n".join(lines) + "\n"


#: Decimal places of the human-read exports: times to the nanosecond; joint values [rad or deg] and
#: their rates to 1e-9 (far below any encoder; the files stay readable).
EXPORT_DECIMALS = 9


def ros2_joint_trajectory(samples, joint_names, sample_time: float = defaults.SAMPLE_TIME) -> dict:
    """A ``trajectory_msgs/msg/JointTrajectory`` as a plain dict (YAML/JSON message form).

    One point every ``sample_time`` [s] exactly (:func:`cycle_grid`), the first the start state at
    time_from_start 0 (the arm must already be there); times strictly increase, as
    ros2_control's joint_trajectory_controller requires.
    """
    joint_names = list(joint_names)
    if samples.q.shape[1] != len(joint_names):
        raise PathmotionError(f"{len(joint_names)} joint names for {samples.q.shape[1]} joints")
    if np.any(np.diff(samples.t) <= 0):
        raise PathmotionError("trajectory times must strictly increase for ROS 2 export")
    k, _ = cycle_grid(float(samples.t[-1]), sample_time)
    cyc = on_cycles(samples, sample_time)
    step_ns = int(round(sample_time * 1e9))
    q, qd, qdd = (tidy(cyc[name], EXPORT_DECIMALS).tolist() for name in ("q", "qd", "qdd"))
    points = [{"positions": q[i], "velocities": qd[i], "accelerations": qdd[i], "effort": [],
               "time_from_start": {"sec": int(k[i]) * step_ns // 1_000_000_000,
                                   "nanosec": int(k[i]) * step_ns % 1_000_000_000}}
              for i in range(len(k))]
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
            "joint_names": joint_names, "points": points}


def write_ros2_yaml(path, samples, joint_names, sample_time: float = defaults.SAMPLE_TIME, notes=()) -> Path:
    """Write the JointTrajectory message as YAML, e.g. for
    ``ros2 topic pub --once /joint_trajectory_controller/joint_trajectory
    trajectory_msgs/msg/JointTrajectory "$(cat trajectory_ros2.yaml)"``; ``notes`` become '# ' lines
    at the top."""
    import yaml

    msg = ros2_joint_trajectory(samples, joint_names, sample_time)
    head = "".join(f"# {n}\n" for n in notes)
    points = msg.pop("points")
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml's emitter for the header and the names
    text = yaml.dump(msg, Dumper=dumper, sort_keys=False, default_flow_style=None, width=1000)
    return write_text(path, head + text + "points:\n" + "".join(_yaml_point(pt) for pt in points))


def _yaml_float(v: float) -> str:
    """A float as PyYAML's SafeRepresenter writes it (repr, lower case, '.0' before a bare exponent)."""
    if v != v:
        return ".nan"
    if v in (np.inf, -np.inf):
        return ".inf" if v > 0 else "-.inf"
    text = repr(float(v)).lower()
    return text.replace("e", ".0e", 1) if "." not in text and "e" in text else text


def _yaml_point(pt: dict) -> str:
    """One JointTrajectoryPoint of :func:`ros2_joint_trajectory` as the item of the block sequence ``points`` that
    yaml.dump(default_flow_style=None) writes (flow lists and mapping of scalars), formatted directly: the
    representer of PyYAML spends about 20 us per number, a motion of minutes has millions."""
    rows = [f"{key}: [{', '.join(_yaml_float(v) for v in pt[key])}]"
            for key in ("positions", "velocities", "accelerations", "effort")]
    t = pt["time_from_start"]
    rows.append(f"time_from_start: {{sec: {int(t['sec'])}, nanosec: {int(t['nanosec'])}}}")
    return "- " + "\n  ".join(rows) + "\n"


def write_egm_csv(path, samples, sample_time: float = defaults.SAMPLE_TIME, notes=()) -> Path:
    """ABB Externally Guided Motion joint stream: one row per controller cycle (default 4 ms), exactly
    one cycle apart (:func:`cycle_grid`), columns t [s], j1..jn [deg], j1_speed..jn_speed [deg/s]; ``notes``
    become '# ' lines before the header. A streaming client (e.g. over EgmSensor UDP messages) sends
    row k at cycle k."""
    cyc = on_cycles(samples, sample_time)
    n = cyc["q"].shape[1]
    cols = {"t": cyc["t"]}
    cols.update({f"j{j + 1}": tidy(np.degrees(cyc["q"][:, j]), EXPORT_DECIMALS) for j in range(n)})
    cols.update({f"j{j + 1}_speed": tidy(np.degrees(cyc["qd"][:, j]), EXPORT_DECIMALS) for j in range(n)})
    return write_text(path, _csv_text(cols, notes))


def rapid_module(samples, module: str = "PathmotionReplay", step: float = 0.05, zone: str = "z1",
                 notes=()) -> str:
    """A RAPID module replaying the motion with timed ``MoveAbsJ`` instructions.

    Points every ``step`` seconds (the IRC5 cannot take one instruction per 4 ms); each move gets
    ``\\T:=`` the time since the previous point, so the controller's own interpolation reproduces
    the timing between points, not the profile inside them. The first move (``fine``, 2 s) brings
    the arm to the start; the last uses ``fine``. ``notes`` become '!' comment lines at the top.
    """
    if not module.isidentifier() or len(module) > 32:
        raise PathmotionError(f"RAPID module name {module!r} must be an identifier of at most 32 characters")
    t = samples.t
    picks = np.unique(np.concatenate([np.searchsorted(t, np.arange(0.0, t[-1], step)), [len(t) - 1]]))
    q = np.degrees(samples.q[picks])
    times = t[picks]
    if q.shape[1] > RAPID_MAX_AXES:
        raise PathmotionError(rapid_refusal(q.shape[1]))
    lines = [f"MODULE {module}", *(f"  ! {n}" for n in notes), f"  ! Generated by pathmotion: {len(picks)} points, duration {t[-1]:.4f} s.",
             "  ! Joint values in degrees (jointtarget); \\T is the time of each move in seconds.",
             f"  CONST num n_points := {len(picks)};",
             f"  CONST jointtarget path{{{len(picks)}}} := ["]
    rows = []
    for row in q:
        axes = list(row) + [0.0] * (6 - len(row))
        rows.append("    [[" + ",".join(f"{v:.6f}" for v in axes) + "],[9E9,9E9,9E9,9E9,9E9,9E9]]")
    lines.append(",\n".join(rows) + "];")
    lines.append(f"  CONST num move_time{{{len(picks)}}} := [" + ",".join(
        f"{max(dt, 0.0):.6f}" for dt in np.diff(np.concatenate([[times[0]], times]))) + "];")
    lines += [
        "  PROC main()",
        "    MoveAbsJ path{1}, v100, fine, tool0;",
        "    FOR i FROM 2 TO n_points DO",
        "      IF i = n_points THEN",
        "        MoveAbsJ path{i}, v7000 \\T:=move_time{i}, fine, tool0;",
        "      ELSE",
        f"        MoveAbsJ path{{i}}, v7000 \\T:=move_time{{i}}, {zone}, tool0;",
        "      ENDIF",
        "    ENDFOR",
        "  ENDPROC",
        "ENDMODULE",
    ]
    return "\n".join(lines) + "\n"


def write_rapid(path, samples, module: str = "PathmotionReplay", step: float = 0.05, notes=()) -> Path:
    return write_text(path, rapid_module(samples, module=module, step=step, notes=notes))


#: The files of the exports for a robot stack, as :func:`pathmotion.api.write_plan` names them.
EXPORT_FILES = ("trajectory_ros2.yaml", "trajectory_egm.csv", "trajectory_rapid.mod")
#: Robot axes a RAPID ``jointtarget`` holds (robax rax_1..rax_6).
RAPID_MAX_AXES = 6


def rapid_refusal(n_axes: int) -> str:
    return (f"trajectory_rapid.mod not written: a RAPID jointtarget holds at most {RAPID_MAX_AXES} robot axes, "
            f"this arm has {n_axes}")


def unsupported_exports(n_axes: int) -> dict[str, str]:
    """The exports (file name -> why) an arm of ``n_axes`` joints cannot take; the others are written."""
    return {EXPORT_FILES[2]: rapid_refusal(n_axes)} if n_axes > RAPID_MAX_AXES else {}
