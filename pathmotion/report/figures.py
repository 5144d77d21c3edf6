"""Static figures (PNG, matplotlib) written next to plan and simulation results."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io.atomic import atomic_path  # noqa: E402


def _save(fig, path: Path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
    return path


def phase_plane(result, ax=None):
    """theta_dot against theta: pointwise limit curve, controllable bound, optimum and baselines."""
    from ..api import phase_plane_columns

    cols = phase_plane_columns(result)
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(8, 4.5))
    th = cols["theta"]
    top = 1.6 * np.max(cols["theta_dot_optimal"]) + 1e-9
    ax.plot(th, np.minimum(cols["theta_dot_max_pointwise"], top), color="0.6", lw=1, label="pointwise limit")
    ax.plot(th, np.minimum(cols["theta_dot_controllable"], top), color="0.3", lw=1, ls="--", label="controllable bound")
    ax.plot(th, cols["theta_dot_optimal"], color="C0", lw=2, label=f"time-optimal ({result.profile.duration:.4f} s)")
    b = result.baselines
    if b is not None and b.fitted is not None:
        ax.plot(th, cols["theta_dot_fitted"], color="C2", lw=1.3, label=f"fitted ({b.fitted.profile.duration:.4f} s)")
    if b is not None and b.constant_speed is not None:
        ax.plot(th, cols["theta_dot_constant_speed"], color="C3", lw=1.3,
                label=f"constant TCP speed ({b.constant_speed.profile.duration:.4f} s)")
    ax.set_ylim(0, top)
    ax.set_xlabel("path coordinate theta")
    ax.set_ylabel("theta_dot [1/s]")
    ax.set_title("Phase plane")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return ax


def plan_figures(setup, result, samples, out: Path) -> list[Path]:
    """phase_plane.png and joints.png (q, qd/limit, qdd/limit, tau/limit against time)."""
    out = Path(out)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    phase_plane(result, ax)
    paths = [_save(fig, out / "phase_plane.png")]
    lim = setup.robot.limits
    names = setup.robot.joint_names
    rows = [("q [rad]", samples.q, None), ("qd / limit", samples.qd, lim.velocity)]
    if lim.acceleration is not None:
        rows.append(("qdd / limit", samples.qdd, lim.acceleration))
    if samples.tau is not None:
        rows.append(("tau / limit", samples.tau, lim.torque))
    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.2 * len(rows)), sharex=True)
    for ax, (label, arr, limit) in zip(axes, rows):
        for j in range(arr.shape[1]):
            ax.plot(samples.t, arr[:, j] if limit is None else arr[:, j] / limit[j], lw=1, label=names[j])
        if limit is not None:
            ax.axhline(1, color="k", lw=0.8, ls="--")
            ax.axhline(-1, color="k", lw=0.8, ls="--")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=min(6, len(names)), fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"{setup.name}: planned joint motion against the limits")
    paths.append(_save(fig, out / "joints.png"))
    return paths


def simulation_figures(setup, result, sim, out: Path) -> list[Path]:
    """tracking_joints.png (q - Phi(theta) per joint) and tracking_task.png (TCP path, deviation)."""
    out = Path(out)
    names = setup.robot.joint_names
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    err = sim.q - sim.q_desired
    for j in range(err.shape[1]):
        axes[0].plot(sim.t, err[:, j], lw=1, label=names[j])
    axes[0].set_ylabel("q - Phi(theta) [rad]")
    axes[0].legend(ncol=6, fontsize=7)
    axes[0].grid(alpha=0.3)
    axes[1].plot(sim.t, sim.theta, lw=1.2)
    axes[1].set_ylabel("theta")
    axes[1].set_xlabel("t [s]")
    axes[1].grid(alpha=0.3)
    status = "tracking ok" if sim.tracking_ok else f"tracking FAILED: {sim.failure.message}"
    fig.suptitle(f"{setup.name}: joint tracking ({sim.controller}) - {status}", fontsize=10)
    paths = [_save(fig, out / "tracking_joints.png")]

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    ax = axes[0]
    if setup.original_task_path is not None:
        p0 = setup.original_task_path.evaluate(np.linspace(*setup.original_task_path.domain, 800))[0]
        ax.plot(p0[:, 0], p0[:, 1], color="0.6", lw=1, ls=":", label="original (sharp) path")
    ax.plot(sim.tcp_desired[:, 0], sim.tcp_desired[:, 1], "k--", lw=1, label="desired")
    ax.plot(sim.tcp[:, 0], sim.tcp[:, 1], color="C0", lw=1.2, label="simulated TCP")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("TCP path, top view")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[1]
    ax.plot(sim.t, 1e3 * sim.path_deviation, lw=1.2, label="distance to the desired path")
    if sim.corner_deviation is not None:
        ax.plot(sim.t, 1e3 * sim.corner_deviation, lw=1.2, label="distance to the original sharp path")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("TCP deviation [mm]")
    ax.set_title("Task-space error")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.suptitle(f"{setup.name}: task-space tracking ({sim.controller})", fontsize=10)
    paths.append(_save(fig, out / "tracking_task.png"))
    return paths
