"""Study figures (PNG, matplotlib Agg): the trade-off plot and the chapter-7 style time series.

* :func:`tradeoff_figure`: deviation from the sharp path against cycle time, one marker per point,
  the Pareto front as a line, the best-scored point and named points labelled;
* :func:`y_figure`: one panel per run: the TCP's y(t) [mm] (solid), the planned trajectory's y(t)
  (dashed) and the y of the nearest point of the sharp path (dotted), as in the thesis' Fig. 7.8/7.10;
* :func:`error_figure`: one panel per run: the error vector TCP - nearest sharp-path point, its x, y,
  z components and norm [mm] over time (the thesis' Fig. 7.9/7.11);
* :func:`corner_view_figure`: top view (x, y) of the corner region: sharp path, each run's TCP.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from ..io import schema

MM = 1000.0


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    from ..io.atomic import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    _plt().close(fig)
    return path


def tradeoff_figure(rows: Sequence[dict], front: Sequence[int], best: dict | None, path: str | Path, *,
                    labels: dict[int, str] | None = None, x_key: str = schema.MAX_SHARP_DEVIATION.key,
                    y_key: str = schema.CYCLE_TIME.key, point_label=None, title: str = "") -> Path:
    """Deviation [mm] vs cycle time [s]; ``labels``: row index -> text for named points;
    ``point_label(row)`` gives every point's small label (default none). Failed rows are listed
    in the legend only (they have no cycle time)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    ok = [i for i, r in enumerate(rows) if _finite(r.get(x_key)) and _finite(r.get(y_key))
          and not r.get("error") and r.get("tracking_ok") is True]
    failed = len(rows) - len(ok)
    ax.scatter([rows[i][x_key] * MM for i in ok], [rows[i][y_key] for i in ok], s=28, color="tab:blue",
               label=f"points ({len(ok)})", zorder=2)
    if front:
        fx = [rows[i][x_key] * MM for i in front]
        fy = [rows[i][y_key] for i in front]
        ax.step(fx, fy, where="post", color="tab:orange", lw=1.5, zorder=1)
        ax.scatter(fx, fy, s=60, facecolor="none", edgecolor="tab:orange", lw=1.5, label="Pareto front", zorder=3)
    if best is not None and best.get("index") in ok:
        r = rows[best["index"]]
        ax.scatter([r[x_key] * MM], [r[y_key]], marker="*", s=220, color="tab:red", zorder=4,
                   label=f"best score {best['score']:.4g}")
    if point_label is not None:
        for i in ok:
            ax.annotate(point_label(rows[i]), (rows[i][x_key] * MM, rows[i][y_key]), fontsize=7,
                        xytext=(4, -9), textcoords="offset points", color="0.35")
    for i, text in (labels or {}).items():
        if i in ok:
            ax.annotate(text, (rows[i][x_key] * MM, rows[i][y_key]), fontsize=9, weight="bold",
                        xytext=(6, 6), textcoords="offset points")
    if failed:
        ax.plot([], [], " ", label=f"{failed} point(s) failed or lost tracking (not shown)")
    ax.set_xlabel("largest TCP distance from the sharp path [mm]")
    ax.set_ylabel("cycle time (closed loop) [s]")
    ax.set_title(title or "Deviation vs cycle time")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return _save(fig, path)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _panels(n: int):
    plt = _plt()
    cols = 2 if n > 1 else 1
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(6.0 * cols, 3.4 * rows), squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    return fig, axes.ravel()


def y_figure(runs: Sequence[tuple[str, dict]], path: str | Path, title: str) -> Path:
    """One panel per (label, trace): y(t) of the TCP, the planned trajectory and the sharp path [mm]."""
    fig, axes = _panels(len(runs))
    for ax, (label, tr) in zip(axes, runs):
        t = tr["t"]
        ax.plot(t, tr["tcp"][:, 1] * MM, color="tab:blue", lw=1.4, label="TCP y(t)")
        ax.plot(t, tr["tcp_planned"][:, 1] * MM, "--", color="tab:blue", lw=1.0, alpha=0.7, label="planned y(t)")
        ax.plot(t, tr["sharp_nearest"][:, 1] * MM, ":", color="k", lw=1.0, label="sharp path (nearest point)")
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("y [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def error_figure(runs: Sequence[tuple[str, dict]], path: str | Path, title: str) -> Path:
    """One panel per (label, trace): components and norm of TCP - nearest sharp-path point [mm]."""
    fig, axes = _panels(len(runs))
    for ax, (label, tr) in zip(axes, runs):
        e = (tr["tcp"] - tr["sharp_nearest"]) * MM
        for k, (name, color) in enumerate((("x", "tab:red"), ("y", "tab:green"), ("z", "tab:blue"))):
            ax.plot(tr["t"], e[:, k], color=color, lw=1.0, label=f"e_{name}")
        ax.plot(tr["t"], np.linalg.norm(e, axis=1), color="k", lw=1.4, label="|e|")
        ax.set_title(f"{label}: max |e| = {np.max(np.linalg.norm(e, axis=1)):.3g} mm", fontsize=10)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("error [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="best", ncol=2)
    fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def corner_view_figure(runs: Sequence[tuple[str, dict]], corner: Sequence[float], half_width: float,
                       path: str | Path, title: str) -> Path:
    """Top view (x, y) [mm] within ``half_width`` [m] of ``corner`` (3,) [m]: the sharp path (black), each
    run's planned path (thin dashed) and TCP (solid)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 6.0))
    c = np.asarray(corner, float)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    sharp = runs[0][1].get("sharp_path") if runs else None
    if sharp is not None:
        ax.plot(sharp[:, 0] * MM, sharp[:, 1] * MM, color="k", lw=2.0, label="sharp path")
    for k, (label, tr) in enumerate(runs):
        col = colors[k % len(colors)]
        if "planned_path" in tr:
            ax.plot(tr["planned_path"][:, 0] * MM, tr["planned_path"][:, 1] * MM, "--", color=col, lw=0.9)
        ax.plot(tr["tcp"][:, 0] * MM, tr["tcp"][:, 1] * MM, color=col, lw=1.5, label=label)
    ax.set_xlim((c[0] - half_width) * MM, (c[0] + half_width) * MM)
    ax.set_ylim((c[1] - half_width) * MM, (c[1] + half_width) * MM)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title)
    fig.tight_layout()
    return _save(fig, path)
