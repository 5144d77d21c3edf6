"""Static figures (PNG, matplotlib) drawn from the files of a plan or simulation folder
(trajectory.csv, phase_plane.csv, simulation.csv, summary.json, limits.json, original_path.csv),
written next to them. The CLI calls these after :mod:`pathmotion.api` wrote the folder."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io import schema  # noqa: E402
from ..io.atomic import atomic_path  # noqa: E402
from .style import TITLE_WIDTH, legend_outside, wrapped  # noqa: E402,F401 (TITLE_WIDTH: the figures' width)
from .tables import (FALLBACK_LIMIT_COLOR, LIMIT_COLORS, PLOT_FLOOR, PLOT_HEADROOM, SPARE_LIMIT_COLORS,  # noqa: E402
                     THIRD_ORDER_NOTE, in_range, joint_columns, limit_curve_label, read_columns, read_json,
                     steady_curve_label)


def _save(fig, path: Path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
    return path


def _title(fig, text: str, **kw) -> None:
    """The figure's title above its axes, wrapped; however many lines it takes, it grows upwards (bottom-anchored
    just above the top axes), never into them."""
    top = max(ax.get_position().y1 for ax in fig.axes)
    fig.suptitle(wrapped(text), y=top + 0.02, va="bottom", **kw)


def _joint_names(folder: Path, n: int) -> list[str]:
    names = (read_json(folder / "limits.json", {}) or {}).get("joint_names")
    return list(names) if names and len(names) == n else [f"joint {j + 1}" for j in range(n)]


def phase_plane_labels(path_kind: str) -> tuple[str, str]:
    """Axis labels of the phase plane: on a task path theta is the arc length [m] and theta_dot the TCP
    speed [m/s]; on a joint path theta is a parameter on [0, 1] without a unit, theta_dot in [1/s]."""
    if path_kind == "joint":
        return "theta, path parameter [-]", "theta_dot [1/s]"
    return "theta, arc length along the path [m]", "theta_dot, TCP speed [m/s]"


def phase_plane(cols: dict[str, np.ndarray], summary: dict, ax=None):
    """theta_dot against theta (columns of phase_plane.csv, names in io/schema.py): the planner's
    curve of all limits together (wide grey), each active limit's own curve, the controllable bound,
    the optimum, the optimum without the third-order limits (when they are on) and the baselines,
    with the durations of a plan's ``summary``."""
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(8, 4.5))
    th = cols[schema.PHASE_THETA]
    profiles = [k for k in (schema.PHASE_OPTIMAL, schema.PHASE_SECOND_ORDER) if k in cols]
    top = PLOT_HEADROOM * max(float(np.max(cols[k])) for k in profiles) + PLOT_FLOOR
    def bound(values, label, **style):  # a limit curve clipped at the plot's top; one wholly above it is only named
        values = np.asarray(values, float)
        if np.all(~np.isfinite(values) | (values >= top)):
            ax.plot([], [], label=f"{label} (above the plot everywhere)", **style)
        else:
            ax.plot(th, np.minimum(values, top), label=label, **style)

    bound(cols[schema.PHASE_POINTWISE], "all limits (planner's curve)", color="0.6", lw=4, alpha=0.45,
          solid_capstyle="butt")
    spare = iter(SPARE_LIMIT_COLORS)
    for name in schema.limit_curve_names(cols):
        color = LIMIT_COLORS.get(name) or next(spare, FALLBACK_LIMIT_COLOR)
        bound(cols[schema.limit_curve_column(name)], limit_curve_label(name, summary), color=color, lw=1.1)
    for name in schema.steady_curve_names(cols):
        bound(cols[schema.steady_curve_column(name)], steady_curve_label(name),
              color=LIMIT_COLORS.get(name, FALLBACK_LIMIT_COLOR), lw=1.2, ls=":")
    bound(cols[schema.PHASE_CONTROLLABLE], "controllable bound", color="0.3", lw=1, ls="--")
    if schema.PHASE_SECOND_ORDER in cols:
        second = summary.get(schema.SECOND_ORDER_DURATION.key)
        ax.plot(th, cols[schema.PHASE_SECOND_ORDER], color="C0", lw=1.3, ls=(0, (4, 2)),
                label="without jerk / torque-rate limits" + ("" if second is None else f" ({second:.4f} s)"))
    third = schema.PHASE_SECOND_ORDER in cols
    ax.plot(th, cols[schema.PHASE_OPTIMAL], color="C0", lw=2,
            label=("time-optimal, jerk-limited" if third else "time-optimal")
            + f" ({summary.get(schema.DURATION.key, float('nan')):.4f} s)")
    fitted, constant = summary.get(schema.FITTED_DURATION.key), summary.get(schema.BASELINE_DURATION.key)
    if schema.PHASE_FITTED in cols and fitted is not None:
        ax.plot(th, cols[schema.PHASE_FITTED], color="C2", lw=1.3, label=f"fitted ({fitted:.4f} s)")
    if schema.PHASE_CONSTANT_SPEED in cols and constant is not None:
        ax.plot(th, cols[schema.PHASE_CONSTANT_SPEED], color="C3", lw=1.3,
                label=f"constant TCP speed ({constant:.4f} s)")
    ax.set_ylim(0, top)
    xlabel, ylabel = phase_plane_labels(summary.get(schema.PATH_KIND.key, "task"))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    name = summary.get(schema.SCENARIO.key)
    ax.set_title(wrapped(f"{name}: phase plane" if name else "Phase plane"))
    legend_outside(ax)
    if third:
        import textwrap

        ax.annotate("\n".join(textwrap.wrap(THIRD_ORDER_NOTE, 100)), xy=(0, 0), xycoords="axes fraction",
                    xytext=(0, -48), textcoords="offset points", va="top", fontsize=8, color="0.25")
    ax.grid(alpha=0.3)
    return ax


def plan_figures(folder: str | Path) -> list[Path]:
    """phase_plane.png and joints.png (q, qd/limit, qdd/limit, tau/limit against time) of a plan folder."""
    out = Path(folder)
    summary = read_json(out / "summary.json", {})
    fig, ax = plt.subplots(figsize=(8, 4.5))
    phase_plane(read_columns(out / schema.PHASE_PLANE_FILE, (schema.PHASE_THETA, schema.PHASE_OPTIMAL)), summary, ax)
    paths = [_save(fig, out / "phase_plane.png")]
    traj = read_columns(out / "trajectory.csv", ("t", "q1"))
    lim = read_json(out / "limits.json", {}) or {}
    q = joint_columns(traj, "q")
    names = _joint_names(out, q.shape[1])
    rows = [("q in range [-]", in_range(q, lim["lower"], lim["upper"]), "range") if lim.get("lower") is not None
            else ("q [rad]", q, None),
            ("qd / limit", joint_columns(traj, "qd"), lim.get("velocity"))]
    qdd, tau = joint_columns(traj, "qdd"), joint_columns(traj, "tau")
    if qdd is not None and lim.get("acceleration") is not None:
        rows.append(("qdd / limit", qdd, lim["acceleration"]))
    if tau is not None:
        rows.append(("tau / limit", tau, lim.get("torque")))
    rows = [r for r in rows if r[1] is not None]
    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.2 * len(rows)), sharex=True)
    for ax, (label, arr, limit) in zip(np.atleast_1d(axes), rows):
        for j in range(arr.shape[1]):
            ratio = arr[:, j] if limit is None or isinstance(limit, str) else arr[:, j] / limit[j]
            ax.plot(traj["t"], ratio, lw=1, label=names[j])
        if limit is not None:  # the limits, and the joint range's ends: -1 = lower, +1 = upper
            ax.axhline(1, color="k", lw=0.8, ls="--")
            ax.axhline(-1, color="k", lw=0.8, ls="--")
        ax.set_ylabel(label if limit is not None else label.replace(" / limit", ""))  # no limits.json: raw values
        ax.grid(alpha=0.3)
    axes = np.atleast_1d(axes)
    legend_outside(axes[0])
    axes[-1].set_xlabel("t [s]")
    _title(fig, f"{summary.get(schema.SCENARIO.key, out.name)}: planned joint motion against the limits "
                "(dashed: the limits; q: -1 = lower, +1 = upper end of its range)")
    paths.append(_save(fig, out / "joints.png"))
    return paths


def _tracking_joints(out: Path, summary: dict, sim: dict[str, np.ndarray]) -> Path:
    err = joint_columns(sim, "q") - joint_columns(sim, "q_desired")
    names = _joint_names(out, err.shape[1])
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for j in range(err.shape[1]):
        axes[0].plot(sim["t"], err[:, j], lw=1, label=names[j])
    axes[0].set_ylabel("q - Phi(theta) [rad]")
    legend_outside(axes[0])
    axes[0].grid(alpha=0.3)
    axes[1].plot(sim["t"], sim["theta"], lw=1.2)
    axes[1].set_ylabel(phase_plane_labels((summary.get("plan") or {}).get(schema.PATH_KIND.key, "task"))[0])
    axes[1].set_xlabel("t [s]")
    axes[1].grid(alpha=0.3)
    failure = summary.get(schema.FAILURE.key) if isinstance(summary.get(schema.FAILURE.key), dict) else {}
    ok = summary.get(schema.TRACKING_OK.key, True)
    status = "tracking ok" if ok else f"tracking FAILED: {failure.get('message', '')}"
    name = (summary.get("plan") or {}).get(schema.SCENARIO.key, out.name)
    _title(fig, f"{name}: joint tracking ({summary.get(schema.CONTROLLER.key)}) - {status}", fontsize=10)
    return _save(fig, out / "tracking_joints.png")


def simulation_figures(folder: str | Path) -> list[Path]:
    """tracking_joints.png (q - Phi(theta) per joint) and tracking_task.png (TCP path, deviation) of a
    simulation folder."""
    out = Path(folder)
    summary = read_json(out / "summary.json", {})
    sim = read_columns(out / "simulation.csv", ("t", "theta", "q1", "q_desired1", "path_deviation"))
    paths = [_tracking_joints(out, summary, sim)]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    ax = axes[0]
    if (out / "original_path.csv").is_file():
        p0 = read_columns(out / "original_path.csv", ("x", "y"))
        ax.plot(p0["x"], p0["y"], color="0.6", lw=1, ls=":", label="original (sharp) path")
    planned = out / "plan" / "tcp_path.csv"
    if planned.is_file():  # the whole planned path, every segment, also where a failed run stopped early
        p1 = read_columns(planned, ("tcp_x", "tcp_y"))
        ax.plot(p1["tcp_x"], p1["tcp_y"], "k--", lw=1, label="desired (planned path)")
    else:
        ax.plot(sim["tcp_desired_x"], sim["tcp_desired_y"], "k--", lw=1, label="desired")
    ax.plot(sim["tcp_x"], sim["tcp_y"], color="C0", lw=1.2, label="simulated TCP")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("TCP path, top view")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2)
    ax.grid(alpha=0.3)
    ax = axes[1]
    ax.plot(sim["t"], 1e3 * sim["path_deviation"], lw=1.2, label="distance to the desired path")
    if "sharp_deviation" in sim:
        ax.plot(sim["t"], 1e3 * sim["sharp_deviation"], lw=1.2, label="distance to the original sharp path")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("TCP deviation [mm]")
    ax.set_title("Task-space error")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.15))
    ax.grid(alpha=0.3)
    name = (summary.get("plan") or {}).get(schema.SCENARIO.key, out.name)
    _title(fig, f"{name}: task-space tracking ({summary.get(schema.CONTROLLER.key)})", fontsize=10)
    paths.append(_save(fig, out / "tracking_task.png"))
    return paths
