"""The corner atlas' section of the HTML report (``pathmotion corners --out DIR``): its
table (corners.csv), T(delta) per turn angle and the gain over the stop against the angle, as
interactive figures. Read from the folder's files only."""

from __future__ import annotations

from html import escape
from pathlib import Path

import plotly.graph_objects as go

from .blocks import Section, cell, figure_html, section_title
from .discovery import ResultFolder
from .tables import read_rows

#: The durations drawn in T(delta): column -> (label, dash).
CURVES = (("stop_s", "stop at the corner", "dash"), ("industrial_zone_s", "constant speed, parabolic zone", "dot"),
          ("circle_s", "transition circle", "solid"), ("g2_s", "G2 blend", "solid"),
          ("optimal_s", "optimal blend", "solid"), ("corner_optimum_s", "corner-confined optimum", "dashdot"),
          ("free_shape_optimum_s", "whole-tube optimum", "dashdot"))
#: Table columns: column -> (label, scale).
TABLE = (("angle_deg", "angle [deg]", 1.0), ("tolerance_m", "tolerance [mm]", 1e3), ("torque", "torque limits", 1.0),
         ("torque_reserve", "torque reserve [%]", 100.0), ("stop_s", "stop [s]", 1.0),
         ("industrial_zone_s", "zone, const. speed [s]", 1.0), ("circle_s", "circle [s]", 1.0),
         ("g2_s", "G2 [s]", 1.0), ("quintic_s", "fastest quintic [s]", 1.0), ("optimal_s", "optimal [s]", 1.0),
         ("corner_optimum_s", "corner opt. [s]", 1.0), ("corner_bound_s", "corner feasible bound [s]", 1.0),
         ("free_shape_optimum_s", "whole-tube opt. [s]", 1.0), ("gain_vs_stop", "gain vs stop [%]", 100.0),
         ("gain_vs_zone", "gain vs zone [%]", 100.0), ("gap_to_corner_optimum", "gap to corner opt. [%]", 100.0),
         ("gap_to_corner_bound", "gap at least [%]", 100.0),
         ("gap_to_optimum", "gap to whole-tube opt. [%]", 100.0), ("capture", "capture [%]", 100.0),
         ("closed_loop_ok", "closed loop ok", 1.0), ("status", "status", 1.0), ("error", "error", 1.0))


def tdelta_figure(rows: list[dict]) -> go.Figure:
    """Duration against tolerance (log axis, mm), one colour per method, one dash group per angle
    (legend groups by angle)."""
    fig = go.Figure()
    for i, angle in enumerate(sorted({r["angle_deg"] for r in rows if r.get("angle_deg") is not None})):
        mine = sorted((r for r in rows if r["angle_deg"] == angle), key=lambda r: r["tolerance_m"])
        for j, (key, label, dash) in enumerate(CURVES):
            pts = [(r["tolerance_m"] * 1e3, r[key]) for r in mine if isinstance(r.get(key), (int, float))]
            if pts:
                x, y = zip(*pts)
                fig.add_trace(go.Scatter(x=x, y=y, mode="lines+markers", name=f"{angle:g} deg: {label}",
                                         legendgroup=f"{angle:g}", line={"dash": dash, "color": f"hsl({j * 50},65%,"
                                                                         f"{30 + 10 * (i % 4)}%)"}))
    fig.update_layout(title="T(delta): rest-to-rest duration against the corner tolerance", height=520,
                      xaxis={"type": "log", "title": "tolerance delta [mm]"}, yaxis={"title": "duration [s]"},
                      margin={"l": 60, "r": 20, "t": 50, "b": 50})
    return fig


def gain_figure(rows: list[dict]) -> go.Figure:
    """Time saved against the stop [%] per turn angle: optimal blend (solid) and whole-tube optimum
    (dashed), one colour per tolerance."""
    fig = go.Figure()
    for i, tol in enumerate(sorted({r["tolerance_m"] for r in rows if r.get("tolerance_m") is not None})):
        mine = sorted((r for r in rows if r["tolerance_m"] == tol and isinstance(r.get("stop_s"), (int, float))),
                      key=lambda r: r["angle_deg"])
        for key, dash, what in (("optimal_s", "solid", "optimal blend"), ("free_shape_optimum_s", "dash",
                                                                         "whole-tube optimum")):
            pts = [(r["angle_deg"], 100 * (1 - r[key] / r["stop_s"])) for r in mine
                   if isinstance(r.get(key), (int, float))]
            if pts:
                x, y = zip(*pts)
                fig.add_trace(go.Scatter(x=x, y=y, mode="lines+markers", name=f"{tol * 1e3:g} mm: {what}",
                                         line={"dash": dash, "color": f"hsl({i * 70},65%,40%)"}))
    fig.update_layout(title="Gain over the time-optimal stop against the turn angle", height=480,
                      xaxis={"title": "turn angle [deg]"}, yaxis={"title": "time saved [%]"},
                      margin={"l": 60, "r": 20, "t": 50, "b": 50})
    return fig


def _table(rows: list[dict]) -> str:
    head = "".join(f"<th>{escape(label)}</th>" for _, label, _ in TABLE)
    body = []
    for r in rows:
        cells = []
        for key, _, scale in TABLE:
            v = r.get(key)
            if key in ("status", "error") and v and v != "ok":
                cells.append(f'<td class="bad error">{escape(str(v))}</td>')
            else:
                cells.append(cell(v, scale))
        body.append(f"<tr>{''.join(cells)}</tr>")
    return (f'<div class="scroll"><table class="rows"><caption>corners.csv</caption><tr>{head}</tr>'
            f"{''.join(body)}</table></div>")


def atlas_section(result: ResultFolder, root: Path, anchor: str) -> Section:
    """The atlas' Section: an explanation, the T(delta) and gain-vs-angle figures, the table."""
    _, rows = read_rows(result.path / "corners.csv")
    done = [r for r in rows if not r.get("error")]
    bad = len(rows) - sum(1 for r in rows if r.get("status") == "ok")
    parts = [f"<p>The corner atlas: two 0.2 m lines turning by each angle, rest to rest, every way "
             f"to take the corner within the tolerance against the free-shape optimum. {len(rows)} rows, "
             f"{bad} with an error, an unconverged optimum or a failed closed-loop check (status column).</p>"]
    figures = 0
    if done:
        parts += [figure_html(tdelta_figure(done), f"{anchor}-tdelta"), figure_html(gain_figure(done), f"{anchor}-gain")]
        figures = 2
    parts.append(_table(rows))
    best = max(done, key=lambda r: r.get("gain_vs_stop") or 0.0, default=None)
    summary = {"points": f"{len(rows)} rows, {bad} not ok"}
    if best is not None:
        summary["planned"] = best.get("optimal_s")
    return Section(anchor, section_title("Corner atlas", result, root, None), "".join(parts), figures, summary)


__all__ = ["atlas_section", "gain_figure", "tdelta_figure"]
