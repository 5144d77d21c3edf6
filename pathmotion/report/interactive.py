"""Interactive Plotly figures of the HTML report: arrays in, ``plotly.graph_objects.Figure`` out.

Units on the axes: time [s], joint errors [mrad], TCP positions [m], deviations [mm]; limit plots
show value / limit [-] with the +-1 lines. Long signals are decimated uniformly to at most
``defaults.REPORT_MAX_POINTS`` samples per trace (the key-figure tables hold the exact extremes).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import plotly.graph_objects as go
from plotly.colors import qualitative
from plotly.subplots import make_subplots

from ..io import schema
from ..io.exports import decimate  # noqa: F401  (the report's figures decimate with it)
from .tables import (FALLBACK_LIMIT_COLOR, LIMIT_COLORS, PLOT_FLOOR, PLOT_HEADROOM, SPARE_LIMIT_COLORS,
                     THIRD_ORDER_NOTE, limit_curve_label, steady_curve_label)

#: Smallest scene span of a 3-D view [m], so that a single point still gets axes.
SCENE_MIN_SPAN = 1e-6

JOINT_COLORS = qualitative.D3
COLORS = {"optimal": "#1f77b4", "fitted": "#2ca02c", "constant_speed": "#d62728", "limit": "#8c8c8c",
          "controllable": "#333333", "desired": "#222222", "original": "#9e9e9e", "actual": "#1f77b4",
          "corner": "#ff7f0e", "failed": "#d62728", "front": "#2ca02c", "best": "#e6a700"}
FONT = dict(family="system-ui, -apple-system, 'Segoe UI', Roboto, Helvetica, Arial, sans-serif", size=12)


def for_3d(points: np.ndarray) -> np.ndarray:
    """Coordinates [m] rounded to 1 um for WebGL traces: plotly.js scales each axis by the inverse of the
    data's span, so rounding noise (a flat path at z = 0.5 +- 1e-16 m) would blow the scene up."""
    return np.round(np.asarray(points, dtype=float), 6)


LEGENDS = {"top": dict(orientation="h", yanchor="bottom", y=1.02, x=0, xanchor="left"),
           "right": dict(orientation="v", yanchor="top", y=1, x=1.01, xanchor="left"),
           "bottom": dict(orientation="h", yanchor="top", y=-0.14, x=0, xanchor="left")}
#: Axis titles of sweep columns.
AXIS_TITLES = {k.key: f"{k.label} [{k.unit}]" for k in (schema.MAX_SHARP_DEVIATION, schema.PATH_ACCURACY,
                                                          schema.CYCLE_TIME, schema.LEGACY_SIMULATED_DURATION)}


def _layout(fig: go.Figure, title: str, height: int, legend: str = "top", **kwargs) -> go.Figure:
    """Common look: title top left, legend at ``legend`` ("top", "right", "bottom"), white template."""
    margin = dict(l=70, r=150 if legend == "right" else 20, t=110 if legend == "top" else 70,
                  b=110 if legend == "bottom" else 50)
    fig.update_layout(title=dict(text=title, x=0.01, xanchor="left", y=1 - 14 / height, yanchor="top",
                                 yref="container"),
                      height=height, template="plotly_white", font=FONT, margin=margin, hovermode="closest",
                      legend=LEGENDS[legend], **kwargs)
    return fig


# ------------------------------------------------------------------------------------ phase plane
def phase_plane_figure(cols: dict[str, np.ndarray], durations: dict[str, float | None], path_kind: str,
                       summary: dict | None = None) -> go.Figure:
    """theta_dot against theta (columns of phase_plane.csv, names in io/schema.py): the planner's curve
    of all limits together, each active limit's own curve, the controllable bound, the time-optimal
    profile, the optimum without the third-order limits (when they are on) and the fitted and
    constant-TCP-speed baselines. ``durations``: {"optimal"/"second_order"/"fitted"/"constant_speed":
    duration [s] or None} for the legend; ``path_kind``: "task" (theta is arc length [m], theta_dot
    [m/s]) or "joint" (theta [-], [1/s]); ``summary``: the plan's summary.json (the torque reserve for
    the legend)."""
    theta = cols[schema.PHASE_THETA]
    idx = decimate(len(theta))
    profiles = [k for k in (schema.PHASE_OPTIMAL, schema.PHASE_SECOND_ORDER, schema.PHASE_FITTED,
                            schema.PHASE_CONSTANT_SPEED) if k in cols]
    top = PLOT_HEADROOM * max(float(np.max(cols[k])) for k in profiles) + PLOT_FLOOR
    third = schema.PHASE_SECOND_ORDER in cols

    def label(name, text):
        d = durations.get(name)
        return text if d is None else f"{text}: {d:.4g} s"

    spare = iter(SPARE_LIMIT_COLORS)
    lines = [(schema.PHASE_POINTWISE, "all limits together (the planner's curve)",
              dict(color=COLORS["limit"], width=6), 0.4)]
    lines += [(schema.limit_curve_column(name), limit_curve_label(name, summary or {}),
               dict(color=LIMIT_COLORS.get(name) or next(spare, FALLBACK_LIMIT_COLOR), width=1.3), 1.0)
              for name in schema.limit_curve_names(cols)]
    lines += [(schema.steady_curve_column(name), steady_curve_label(name),
               dict(color=LIMIT_COLORS.get(name, FALLBACK_LIMIT_COLOR), width=1.5, dash="dot"), 1.0)
              for name in schema.steady_curve_names(cols)]
    lines += [
        (schema.PHASE_CONTROLLABLE, "controllable bound (can still slow down in time)",
         dict(color=COLORS["controllable"], width=1.2, dash="dash"), 1.0),
        (schema.PHASE_CONSTANT_SPEED, label("constant_speed", "baseline, constant TCP speed"),
         dict(color=COLORS["constant_speed"], width=1.8), 1.0),
        (schema.PHASE_FITTED, label("fitted", "baseline, fitted profile"), dict(color=COLORS["fitted"], width=1.8), 1.0),
        (schema.PHASE_SECOND_ORDER, label("second_order", "without jerk / torque-rate limits"),
         dict(color=COLORS["optimal"], width=1.8, dash="dash"), 1.0),
        (schema.PHASE_OPTIMAL, label("optimal", "time-optimal, jerk-limited (chosen)" if third
                                     else "time-optimal (chosen)"), dict(color=COLORS["optimal"], width=3), 1.0),
    ]
    fig = go.Figure()
    for key, name, line, opacity in lines:
        if key in cols:
            y = np.minimum(cols[key][idx], 2 * top)  # the limit curve is ~1e6 where no limit binds
            fig.add_trace(go.Scatter(x=theta[idx], y=y, mode="lines", name=name, line=line, opacity=opacity))
    task = path_kind == "task"
    fig.update_xaxes(title_text="θ, arc length along the path [m]" if task else "θ, path parameter [-]")
    fig.update_yaxes(title_text="θ̇, TCP speed [m/s]" if task else "θ̇ [1/s]", range=[0, top])
    title = "Phase plane: path speed θ̇ against path position θ"
    if third:
        import textwrap

        title += "".join(f"<br><sup>{line}</sup>" for line in textwrap.wrap(THIRD_ORDER_NOTE, 140))
    return _layout(fig, title, 490 if third else 430, legend="right")


# ---------------------------------------------------------------------------------- joint limits
def limit_ratio_figure(t: np.ndarray, panels: Sequence[tuple[str, np.ndarray, float | None]],
                       joint_names: Sequence[str], title: str) -> go.Figure:
    """One panel per quantity: value / limit of every joint against time t (N,) [s].

    panels: (panel title, ratio (N, n), planning scale or None); the +-1 lines are the robot's
    limits, a scale below 1 adds dotted +-scale lines (the limit the planner used)."""
    idx = decimate(len(t))
    fig = make_subplots(rows=len(panels), cols=1, shared_xaxes=True, vertical_spacing=0.06,
                        subplot_titles=[p[0] for p in panels])
    for r, (_, ratio, scale) in enumerate(panels, start=1):
        for j, name in enumerate(joint_names):
            fig.add_trace(go.Scatter(x=t[idx], y=ratio[idx, j], mode="lines", name=name, legendgroup=name,
                                     showlegend=r == 1, line=dict(color=JOINT_COLORS[j % len(JOINT_COLORS)], width=1.4),
                                     hovertemplate=f"{name}: %{{y:.3f}} at t = %{{x:.3f}} s<extra></extra>"),
                          row=r, col=1)
        for y in (-1.0, 1.0):
            fig.add_hline(y=y, line=dict(color="black", width=1, dash="dash"), row=r, col=1)
            if scale is not None and scale < 1:
                fig.add_hline(y=y * scale, line=dict(color="black", width=1, dash="dot"), row=r, col=1)
        fig.update_yaxes(title_text="value / limit [-]", range=[-1.15, 1.15], row=r, col=1)
    fig.update_xaxes(title_text="t [s]", row=len(panels), col=1)
    return _layout(fig, title, 170 * len(panels) + 110, legend="right")


# ----------------------------------------------------------------------------------- task space
def scene_box(points: np.ndarray, min_fraction: float = 0.25, pad: float = 0.08) -> dict:
    """Scene axes of a 3-D view of ``points`` (N, 3) [m] at true scale: ranges around the points, each
    at least ``min_fraction`` of the largest span (a flat path keeps some depth), and the matching
    aspect ratio."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = np.maximum(hi - lo, min_fraction * float(np.max(hi - lo)) + SCENE_MIN_SPAN) * (1 + 2 * pad)
    centre = 0.5 * (lo + hi)
    axes = {f"{a}axis": dict(range=[centre[k] - span[k] / 2, centre[k] + span[k] / 2], title=f"{a} [m]",
                             autorange=False, nticks=5) for k, a in enumerate("xyz")}
    ratio = span / np.max(span)
    return dict(aspectmode="manual", aspectratio=dict(x=ratio[0], y=ratio[1], z=ratio[2]), **axes)


def task_space_figure(desired: np.ndarray, actual: np.ndarray | None = None, original: np.ndarray | None = None,
                      t: np.ndarray | None = None, deviations: dict[str, np.ndarray] | None = None,
                      title: str = "Task space") -> go.Figure:
    """The TCP path in 3-D [m] (desired (N, 3), simulated ``actual`` (N, 3), the original sharp path
    (M, 3) before blends) and, when ``deviations`` ({label: (N,) [m]}) are given, the deviations
    against time t [s] in mm on a log scale (values below 1e-4 mm drawn at 1e-4 mm)."""
    with_dev = bool(deviations) and t is not None
    if with_dev:
        fig = make_subplots(rows=1, cols=2, specs=[[{"type": "scene"}, {"type": "xy"}]], column_widths=[0.5, 0.5],
                            horizontal_spacing=0.08,
                            subplot_titles=("TCP path in 3-D (drag to rotate)", "TCP deviation against time"))
    else:
        fig = go.Figure()
    where = dict(row=1, col=1) if with_dev else {}
    clouds = []

    def path3d(p, name, line):
        p = for_3d(p)
        k = decimate(len(p))
        clouds.append(p[k])
        fig.add_trace(go.Scatter3d(x=p[k, 0], y=p[k, 1], z=p[k, 2], mode="lines", name=name, line=line,
                                   hovertemplate="x %{x:.4f} m<br>y %{y:.4f} m<br>z %{z:.4f} m<extra>" + name
                                   + "</extra>"), **where)

    if original is not None:
        path3d(original, "original sharp path (before the blend)", dict(color=COLORS["original"], width=4, dash="dot"))
    path3d(desired, "planned path (desired TCP)", dict(color=COLORS["desired"], width=3, dash="dash")
           if actual is not None else dict(color=COLORS["actual"], width=4))
    if actual is not None:
        path3d(actual, "simulated TCP", dict(color=COLORS["actual"], width=5))
    fig.update_scenes(camera=dict(eye=dict(x=0.5, y=-1.1, z=1.3)), **scene_box(np.vstack(clouds)))
    if with_dev:
        idx = decimate(len(t))
        colors = iter((COLORS["actual"], COLORS["corner"], "#9467bd", "#8c564b"))
        floor = 1e-4
        for name, dev in deviations.items():
            fig.add_trace(go.Scatter(x=t[idx], y=np.maximum(1e3 * dev[idx], floor), mode="lines", name=name,
                                     line=dict(color=next(colors), width=1.6), customdata=1e3 * dev[idx],
                                     hovertemplate="%{customdata:.4g} mm at t = %{x:.3f} s<extra></extra>"),
                          row=1, col=2)
        fig.update_xaxes(title_text="t [s]", row=1, col=2)
        fig.update_yaxes(title_text="TCP deviation [mm], log scale", type="log", row=1, col=2)
    return _layout(fig, title, 560, legend="bottom")


# ------------------------------------------------------------------------------------- tracking
def tracking_figure(t: np.ndarray, error: np.ndarray, joint_names: Sequence[str],
                    failure: dict | None = None) -> go.Figure:
    """Joint tracking errors q_j - Phi_j(theta) [mrad] against t (N,) [s]; error (N, n) [rad].
    ``failure``: {"t", "message", ...} marks when tracking failed."""
    idx = decimate(len(t))
    fig = go.Figure()
    for j, name in enumerate(joint_names):
        fig.add_trace(go.Scatter(x=t[idx], y=1e3 * error[idx, j], mode="lines", name=name,
                                 line=dict(color=JOINT_COLORS[j % len(JOINT_COLORS)], width=1.4),
                                 hovertemplate=f"{name}: %{{y:.4g}} mrad at t = %{{x:.3f}} s<extra></extra>"))
    if failure and failure.get("t") is not None:
        fig.add_vline(x=float(failure["t"]), line=dict(color=COLORS["failed"], width=2, dash="dash"),
                      annotation_text=f"tracking failed ({failure.get('reason', '')})",
                      annotation_font_color=COLORS["failed"])
    fig.update_xaxes(title_text="t [s]")
    fig.update_yaxes(title_text="q<sub>j</sub> − Φ<sub>j</sub>(θ) [mrad]")
    return _layout(fig, "Joint tracking errors (distance from the path, per joint)", 400)


# -------------------------------------------------------------------------------------- trade-off
def tradeoff_figure(rows: Sequence[dict], x_key: str, y_key: str, front: Sequence[int], best: int | None,
                    label: Callable[[dict], str], title: str, fallback_y_key: str | None = None,
                    group_key: str | None = None, best_label: str = "best score") -> go.Figure:
    """Deviation ``x_key`` [m, drawn in mm] against time ``y_key`` [s], one marker per row.

    Rows that compete (no error, tracking_ok) are circles (coloured by ``group_key`` if given);
    ``front`` (row indices) is joined by the Pareto line; ``best`` (row index) is a star; rows whose
    tracking failed are red crosses at ``fallback_y_key`` (e.g. the planned duration) when ``y_key``
    is empty. Rows with an error have no values and are not drawn (the report lists them).
    ``best_label``: the legend entry of the best point (say where it comes from)."""
    from ..study.score import competes

    fig = go.Figure()

    def num(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)

    def add(ids, name, marker, mode="markers", **kw):
        if not ids:
            return
        xs = [1e3 * rows[i][x_key] for i in ids]
        ys = [rows[i][y_key] if num(rows[i].get(y_key)) else rows[i][fallback_y_key] for i in ids]
        text = [label(rows[i]) for i in ids]
        fig.add_trace(go.Scatter(x=xs, y=ys, mode=mode, name=name, marker=marker, text=text,
                                 hovertemplate="%{text}<br>deviation %{x:.4g} mm<br>time %{y:.4g} s<extra>" + name
                                 + "</extra>", **kw))

    ok = [i for i, r in enumerate(rows) if competes(r, (x_key, y_key))]
    failed = [i for i, r in enumerate(rows) if i not in ok and not r.get("error") and num(r.get(x_key))
              and (num(r.get(y_key)) or (fallback_y_key is not None and num(r.get(fallback_y_key))))]
    front_sorted = sorted(front, key=lambda i: (rows[i][x_key], rows[i][y_key]))
    add(front_sorted, "Pareto front", dict(size=16, color="rgba(0,0,0,0)", line=dict(color=COLORS["front"], width=2)),
        mode="lines+markers", line=dict(color=COLORS["front"], width=2, dash="dot"))
    if group_key is None:
        add(ok, "tracking ok", dict(size=10, color=COLORS["actual"]))
    else:
        groups = list(dict.fromkeys(str(rows[i].get(group_key)) for i in ok))
        for g, name in enumerate(groups):
            add([i for i in ok if str(rows[i].get(group_key)) == name], name,
                dict(size=10, color=JOINT_COLORS[g % len(JOINT_COLORS)]))
    add(failed, "tracking failed" + (f" (drawn at {fallback_y_key})" if fallback_y_key else ""),
        dict(size=12, symbol="x", color=COLORS["failed"]))
    if best is not None and 0 <= best < len(rows) and best in ok:
        add([best], best_label, dict(size=20, symbol="star", color=COLORS["best"], opacity=0.85,
                                     line=dict(color="black", width=1)))
    fig.update_xaxes(title_text=AXIS_TITLES.get(x_key, f"{x_key} [mm]"), rangemode="tozero")
    fig.update_yaxes(title_text=AXIS_TITLES.get(y_key, f"{y_key} [s]"))
    return _layout(fig, title, 460)


# ---------------------------------------------------------------------------------- arm animation
def arm_animation_figure(t: np.ndarray, points: np.ndarray, reference: np.ndarray | None, title: str,
                         frame_time: float) -> go.Figure:
    """The arm as a stick figure playing the motion: ``points`` (F, m, 3) [m] (see
    :func:`pathmotion.robot.arm.arm_points`, read from arm.csv; the last vertex is the TCP) at the frame times t (F,) [s],
    the TCP trace drawn up to the current frame, the ``reference`` TCP path (M, 3) dashed. Play/pause
    buttons and a time slider; each frame shows for ``frame_time`` [s]."""
    points = for_3d(points)
    reference = None if reference is None else for_3d(reference)
    ref_idx = decimate(len(reference)) if reference is not None else None

    def arm(k):
        p = points[k]
        return go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines+markers", name="arm (joint origins)",
                            line=dict(color="#ff7f0e", width=9), marker=dict(size=4, color="#333333"),
                            hovertemplate="x %{x:.3f} m<br>y %{y:.3f} m<br>z %{z:.3f} m<extra>arm</extra>")

    def trail(k):
        p = points[: k + 1, -1]
        return go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines", name="TCP trace",
                            line=dict(color=COLORS["actual"], width=5), hoverinfo="skip")

    data = [arm(0), trail(0)]
    if reference is not None:
        data.append(go.Scatter3d(x=reference[ref_idx, 0], y=reference[ref_idx, 1], z=reference[ref_idx, 2],
                                 mode="lines", name="path (desired TCP)",
                                 line=dict(color=COLORS["desired"], width=2, dash="dash"), hoverinfo="skip"))
    frames = [go.Frame(data=[arm(k), trail(k)], traces=[0, 1], name=str(k)) for k in range(len(t))]
    fig = go.Figure(data=data, frames=frames)
    cloud = points.reshape(-1, 3) if reference is None else np.vstack([points.reshape(-1, 3), reference[ref_idx]])
    ms = int(round(1e3 * frame_time))
    play = dict(label="▶ Play", method="animate",
                args=[None, {"frame": {"duration": ms, "redraw": True}, "fromcurrent": True,
                             "transition": {"duration": 0}, "mode": "immediate"}])
    pause = dict(label="❚❚ Pause", method="animate",
                 args=[[None], {"frame": {"duration": 0, "redraw": False}, "transition": {"duration": 0},
                                "mode": "immediate"}])
    steps = [dict(label=f"{t[k]:.2f}", method="animate",
                  args=[[str(k)], {"frame": {"duration": 0, "redraw": True}, "transition": {"duration": 0},
                                   "mode": "immediate"}]) for k in range(len(t))]
    fig.update_layout(
        scene=dict(camera=dict(eye=dict(x=1.1, y=-1.3, z=0.7)), **scene_box(cloud, min_fraction=0.6, pad=0.05)),
        updatemenus=[dict(type="buttons", direction="left", buttons=[play, pause], x=0, y=0, xanchor="left",
                          yanchor="top", pad=dict(t=10, r=10), showactive=False)],
        sliders=[dict(steps=steps, active=0, x=0.18, len=0.82, y=0, yanchor="top", pad=dict(t=10), font=dict(size=9),
                      currentvalue=dict(prefix="t = ", suffix=" s", visible=True))],
    )
    return _layout(fig, title, 700)


# ------------------------------------------------------------------------------------- program moves
def moves_figure(rows: Sequence[dict]) -> go.Figure:
    """The cycle by program move (moves.csv rows): one bar per move, its planned time and its dwell
    (WaitTime) stacked [s], labelled by RAPID line and target; the hover says the binding limit."""
    label = [f"{r.get('move')}: line {r.get('line')} {r.get('target') or ''}" for r in rows]

    def num(key):
        return [float(r[key]) if isinstance(r.get(key), (int, float)) else 0.0 for r in rows]

    hover = [f"{r.get('instruction')} {r.get('target')}<br>binding: {r.get('binding_limit') or '–'} "
             f"{r.get('binding_joint') or ''}" for r in rows]
    fig = go.Figure()
    fig.add_trace(go.Bar(x=label, y=num("planned_time_s"), name="planned motion", marker_color=COLORS["optimal"],
                         customdata=hover, hovertemplate="%{customdata}<br>%{y:.4g} s<extra></extra>"))
    if any(num("dwell_s")):
        fig.add_trace(go.Bar(x=label, y=num("dwell_s"), name="dwell (WaitTime)", marker_color=COLORS["limit"],
                             hovertemplate="dwell %{y:.4g} s<extra></extra>"))
    fig.update_layout(barmode="stack")
    fig.update_xaxes(title_text="move (RAPID line, target)", type="category")
    fig.update_yaxes(title_text="time [s]")
    return _layout(fig, f"Cycle by move: {sum(num('cycle_s')):.4g} s in {len(rows)} moves", 420)
