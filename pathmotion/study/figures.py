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
from ..report.style import legend_outside, wrapped

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
        fig.savefig(tmp, dpi=120, format="png", bbox_inches="tight")
    _plt().close(fig)
    return path


def tradeoff_figure(rows: Sequence[dict], front: Sequence[int], best: dict | None, path: str | Path, *,
                    labels: dict[int, str] | None = None, x_key: str = schema.MAX_SHARP_DEVIATION.key,
                    y_key: str = schema.CYCLE_TIME.key, point_label=None, title: str = "") -> Path:
    """Deviation [mm] vs cycle time [s]; ``labels``: row index -> text for named points;
    ``point_label(row)`` gives every point's small label (default none). Rows with an error (no result) and rows
    that lost tracking are counted apart in the legend only (they have no cycle time)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    ok = [i for i, r in enumerate(rows) if _finite(r.get(x_key)) and _finite(r.get(y_key))
          and not r.get("error") and r.get("tracking_ok") is True]
    errors = sum(1 for r in rows if r.get("error"))  # no result: bad geometry, an infeasible plan, a crash
    lost = sum(1 for i, r in enumerate(rows) if i not in ok and not r.get("error"))  # ran, but did not track
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
    named = [(text, rows[i][x_key] * MM, rows[i][y_key]) for i, text in (labels or {}).items() if i in ok]
    small = [] if point_label is None else [(point_label(rows[i]), rows[i][x_key] * MM, rows[i][y_key]) for i in ok
                                            if i not in (labels or {})]
    _place_labels(ax, named + small, fontsize=8, color="0.25")  # named points first: they get a place
    if errors:
        ax.plot([], [], " ", label=f"{errors} point(s) with an error, no result (not shown)")
    if lost:
        ax.plot([], [], " ", label=f"{lost} point(s) lost tracking (not shown)")
    ax.set_xlabel("largest TCP distance from the sharp path [mm]")
    ax.set_ylabel("cycle time (closed loop) [s]")
    ax.set_title(wrapped(title or "Deviation vs cycle time", 70))
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _place_labels(ax, points: Sequence[tuple[str, float, float]], **style) -> list:
    """Annotate ``points`` (text, x, y in data units), each at the first of eight offsets around its
    point where its box overlaps no label placed before and no point marker; a label with no free
    place is left out. Returns the placed annotations."""
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    marks = [ax.transData.transform((x, y)) for _, x, y in points]
    placed, boxes = [], []
    offsets = [(5, 4), (5, -11), (-5, 4), (-5, -11), (0, 10), (0, -16), (10, -4), (-10, -4)]
    for text, x, y in points:
        for dx, dy in offsets:
            ann = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points",
                              ha="left" if dx >= 0 else "right", **style)
            box = ann.get_window_extent(renderer).expanded(1.05, 1.1)
            hits_mark = any(box.contains(mx, my) for mx, my in marks)
            if not hits_mark and not any(box.overlaps(b) for b in boxes):
                placed.append(ann)
                boxes.append(box)
                break
            ann.remove()
    return placed


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _panels(n: int):
    plt = _plt()
    cols = 2 if n > 1 else 1
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(6.0 * cols, 3.4 * rows), squeeze=False, sharex=True)
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
    legend_outside(axes[min(1, len(axes) - 1)] if len(runs) > 1 else axes[0], fontsize=7)
    fig.suptitle(wrapped(title))
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
    legend_outside(axes[min(1, len(axes) - 1)] if len(runs) > 1 else axes[0], fontsize=7)
    fig.suptitle(wrapped(title))
    fig.tight_layout()
    return _save(fig, path)


def _frame(runs, sharp, corner: np.ndarray, half_width: float, margin: float = 0.08):
    """x and y limits [m]: the box of every curve's points within ``half_width`` of the corner, plus
    ``margin`` of its size (the curves fill the frame; empty window: the whole window)."""
    curves = [tr[k] for _, tr in runs for k in ("tcp", "planned_path") if k in tr]
    if sharp is not None:
        curves.append(sharp)
    pts = np.concatenate([np.asarray(cv, float)[:, :2] for cv in curves]) if curves else np.empty((0, 2))
    near = pts[np.all(np.abs(pts - corner[:2]) <= half_width, axis=1)]
    if len(near) < 2:
        return (corner[0] - half_width, corner[0] + half_width), (corner[1] - half_width, corner[1] + half_width)
    lo, hi = near.min(axis=0), near.max(axis=0)
    pad = margin * max(float(np.max(hi - lo)), 1e-6)
    return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


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
    (x0, x1), (y0, y1) = _frame(runs, sharp, c, half_width)
    ax.set_xlim(x0 * MM, x1 * MM)
    ax.set_ylim(y0 * MM, y1 * MM)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    ax.set_title(wrapped(title, 60))
    fig.tight_layout()
    return _save(fig, path)
