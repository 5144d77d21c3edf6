"""One self-contained interactive HTML page from result folders (``pathmotion report DIR``).

:func:`build_report` finds every plan, simulation, sweep and corner-study folder under ``DIR``
(:mod:`.discovery`), makes one section per folder with its key figures and interactive Plotly
figures (:mod:`.interactive`), a table of contents and a summary table on top, and writes
``DIR/report.html`` atomically. plotly.js is embedded once: the page works offline (no CDN, no
web fonts). The report reads files only: the robot's limits, the original (sharp) path and the arm's
stick figure come from the data files the writer (:mod:`pathmotion.api`) left in each folder
(:class:`FolderData`); it never rebuilds a scenario.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Sequence

import numpy as np

from .. import defaults
from ..errors import PathmotionError
from ..io import schema
from ..io.atomic import write_text
from ..io.exports import arm_points_from
from . import interactive as fig
from .atlas import atlas_section
from .blocks import Section, cell, figure_html, fmt, section_title
from .discovery import ResultFolder, discover
from .tables import RANGE_LABEL, in_range, joint_columns, read_columns, read_json, read_rows

#: Key figures of summary.json: key -> (label, unit, scale applied to the value).
PLAN_KEYS = schema.display(schema.PLAN)
SIMULATION_KEYS = schema.display(schema.SIMULATION)
#: Sweep columns: the time (first present) and the deviation (first present) of the trade-off plot.
TIME_KEYS = schema.keys((schema.CYCLE_TIME, schema.LEGACY_SIMULATED_DURATION))
DEVIATION_KEYS = schema.keys((schema.MAX_SHARP_DEVIATION, schema.PATH_ACCURACY))
#: Sweep columns shown in the table of points (when present), with (label, unit, scale).
SWEEP_COLUMNS = schema.display(schema.SWEEP_TABLE, short=True)


# ---------------------------------------------------------------------------------- formatting
def _key_table(summary: dict, keys: dict, caption: str) -> str:
    rows = []
    for key, (label, unit, scale) in keys.items():
        if key in summary:
            unit_text = f" [{unit}]" if unit else ""
            rows.append(f'<tr><th title="{escape(key)}">{escape(label)}{unit_text}</th>'
                        f"{cell(summary[key], scale)}</tr>")
    return f'<table class="keys"><caption>{escape(caption)}</caption>{"".join(rows)}</table>'


def _other_values(summary: dict, shown: Sequence[str]) -> str:
    rest = {k: v for k, v in summary.items() if k not in shown and not isinstance(v, dict)}
    if not rest:
        return ""
    rows = "".join(f"<tr><th>{escape(k)}</th>{cell(v)}</tr>" for k, v in sorted(rest.items()))
    return f'<details><summary>all other values of summary.json</summary><table class="keys">{rows}</table></details>'


def _note(text: str) -> str:
    return f'<p class="note">{escape(text)}</p>'


# ---------------------------------------------------------------------------- the writer's data
#: Written by pathmotion.api next to the results, for the report and the figures.
LIMITS_FILE, ARM_FILE, ORIGINAL_FILE, TCP_FILE = "limits.json", "arm.csv", "original_path.csv", "tcp_path.csv"


@dataclass(frozen=True)
class FolderData:
    """Plain data a result folder holds for the report: limits (limits.json: joint names, limits,
    the plan's scales), arm (t (F,) [s], stick-figure vertices (F, V, 3) [m]), original (P, 3) sharp
    path [m] or None, and a note when limits or arm are missing (older folders)."""

    limits: dict | None
    arm: tuple[np.ndarray, np.ndarray] | None
    original: np.ndarray | None

    @classmethod
    def read(cls, folder: Path) -> "FolderData":
        limits = read_json(folder / LIMITS_FILE, None)
        arm = None
        if (folder / ARM_FILE).is_file():
            cols = read_columns(folder / ARM_FILE, ("t", "p0_x"))
            arm = (cols["t"], arm_points_from(cols))
        original = None
        if (folder / ORIGINAL_FILE).is_file():
            cols = read_columns(folder / ORIGINAL_FILE, ("x", "y", "z"))
            original = np.column_stack([cols[a] for a in "xyz"])
        return cls(limits, arm, original)

    @property
    def complete(self) -> bool:
        return self.limits is not None and self.arm is not None

    @property
    def note(self) -> str | None:
        if self.complete:
            return None
        return (f"no {LIMITS_FILE} or {ARM_FILE} in this folder (pathmotion plan and simulate write them): the limit "
                "plots and the arm view are omitted")

    def joint_names(self, n: int) -> list[str]:
        names = (self.limits or {}).get("joint_names")
        return list(names) if names and len(names) == n else [f"joint {j + 1}" for j in range(n)]


# ------------------------------------------------------------------------------------ figures
#: Columns the report needs in each table.
PHASE_PLANE_COLUMNS = (schema.PHASE_THETA, schema.PHASE_OPTIMAL)
TRAJECTORY_COLUMNS = ("t", "q1", "qd1")
SIMULATION_COLUMNS = ("t", "q1", "q_desired1", *(f"tcp_{a}" for a in "xyz"), *(f"tcp_desired_{a}" for a in "xyz"),
                      "path_deviation")


def _plan_keys(summary: dict) -> dict:
    """PLAN_KEYS with the unit of the path length: m on a task path, none on a joint path."""
    if summary.get("path_kind") != "joint":
        return PLAN_KEYS
    return {**PLAN_KEYS, "path_length": ("path length (θ range)", "", 1.0)}


def _phase_plane(plan_dir: Path, plan_summary: dict, anchor: str) -> str:
    cols = read_columns(plan_dir / schema.PHASE_PLANE_FILE, PHASE_PLANE_COLUMNS)
    durations = {"optimal": plan_summary.get(schema.DURATION.key),
                 "second_order": plan_summary.get(schema.SECOND_ORDER_DURATION.key),
                 "fitted": plan_summary.get(schema.FITTED_DURATION.key),
                 "constant_speed": plan_summary.get(schema.BASELINE_DURATION.key)}
    return figure_html(fig.phase_plane_figure(cols, durations, plan_summary.get("path_kind", "task"), plan_summary),
                        f"{anchor}-phase")


def _limit_panels(traj: dict[str, np.ndarray], limits: dict) -> list[tuple[str, np.ndarray, float | None]]:
    lim = {k: None if limits.get(k) is None else np.asarray(limits[k], float)
           for k in ("lower", "upper", "velocity", "acceleration", "torque")}
    scale = limits.get("plan_scale", {})
    q, qd, qdd, tau = (joint_columns(traj, p) for p in ("q", "qd", "qdd", "tau"))
    n = len(limits.get("joint_names", ()))
    if q.shape[1] != n:
        raise PathmotionError(f"report: trajectory.csv has {q.shape[1]} joints but {LIMITS_FILE} next to it has {n}; "
                              "re-run the plan")
    panels = [(RANGE_LABEL, in_range(q, lim["lower"], lim["upper"]), None),
              ("joint velocity / limit", qd / lim["velocity"], scale.get("velocity"))]
    if qdd is not None and lim["acceleration"] is not None:
        panels.append(("joint acceleration / limit", qdd / lim["acceleration"], scale.get("acceleration")))
    if tau is not None:
        panels.append(("joint torque / limit", tau / lim["torque"], scale.get("torque")))
    return panels


def _joint_limits(traj: dict[str, np.ndarray], limits: dict, anchor: str) -> str:
    title = "Planned joint motion against the limits (dashed: robot limits; dotted: scaled limits used by the plan)"
    return figure_html(fig.limit_ratio_figure(traj["t"], _limit_panels(traj, limits), limits["joint_names"], title),
                        f"{anchor}-limits")


def _arm(data: FolderData, reference: np.ndarray | None, anchor: str, what: str) -> str:
    t, points = data.arm
    duration = float(t[-1] - t[0])
    frame_time = max(duration / max(len(t) - 1, 1), defaults.REPORT_MIN_FRAME_TIME)
    speed = duration / max(len(t) - 1, 1) / frame_time
    title = (f"The arm playing the {what} (stick figure through the joint origins; "
             f"playback at {speed:.2g}× real time)")
    return figure_html(fig.arm_animation_figure(t, points, reference, title, frame_time), f"{anchor}-arm")


#: Unit of each enforced limit in limits.json (SI) and its row label, by limit name (io/schema.py's LIMITS).
LIMIT_UNITS = {name: row.unit for name, row in schema.LIMITS.items()}
LIMIT_ROW_LABELS = {name: row.label for name, row in schema.LIMITS.items()}


def _enforced_table(limits: dict | None, summary: dict) -> str:
    """The limits the plan enforced (limits.json's "enforced"), one row per limit, one column per joint,
    with the largest ratio of each (summary.json's max_<limit>_ratio)."""
    enforced = (limits or {}).get("enforced")
    if not enforced:
        return ""
    names = list((limits or {}).get("joint_names") or [])
    width = max([len(names)] + [len(v) for v in enforced.values() if isinstance(v, list)])
    names += [f"joint {j + 1}" for j in range(len(names), width)]
    head = "".join(f"<th>{escape(n)}</th>" for n in names[:width])
    rows = []
    order = list(LIMIT_UNITS)
    for name, value in sorted(enforced.items(), key=lambda kv: order.index(kv[0]) if kv[0] in order else len(order)):
        if isinstance(value, dict):  # the envelope: knee / at_max_speed per joint (or one for all)
            knee, low = (list(value.get(k) or []) for k in ("knee", "at_max_speed"))
            knee, low = ((v * width if len(v) == 1 else v) for v in (knee, low))
            cells = "".join(f"<td>{fmt(a)} / {fmt(b)}</td>" for a, b in zip(knee, low))
        elif isinstance(value, list):
            cells = "".join(cell(v) for v in value)
        else:
            cells = f'<td colspan="{width}">{fmt(value)}</td>'
        label = LIMIT_ROW_LABELS.get(name, name.replace("_", " "))
        if name == "torque" and summary.get(schema.TORQUE_RESERVE.key):
            label += f" (with {100 * summary[schema.TORQUE_RESERVE.key]:.3g} % reserve)"
        ratio = summary.get(schema.LIMITS[name].ratio.key if name in schema.LIMITS else f"max_{name}_ratio")
        rows.append(f'<tr><th title="{escape(name)}">{escape(label)} [{escape(LIMIT_UNITS.get(name, "-"))}]</th>'
                    f"{cells}{cell(ratio)}</tr>")
    return ('<table class="limits"><caption>Limits the plan enforced (limits.json) and the largest ratio of each '
            f'(summary.json)</caption><tr><th>limit</th>{head}<th>largest ratio</th></tr>{"".join(rows)}</table>')


# ----------------------------------------------------------------------------------- sections
def _failure_html(summary: dict) -> str:
    failure = summary.get("failure")
    if summary.get(schema.TRACKING_OK.key) is False:
        message = failure.get("message", "") if isinstance(failure, dict) else str(failure or "")
        return f'<p class="failure">Tracking FAILED: {escape(message)}</p>'
    return ""


def _plan_summary_row(summary: dict) -> dict:
    return {"scenario": summary.get("scenario"), "planned": summary.get(schema.DURATION.key),
            "baseline": summary.get(schema.BASELINE_DURATION.key)}


def plan_section(result: ResultFolder, root: Path, anchor: str) -> Section:
    """Key figures, phase plane, joint limits, the planned TCP path and the arm of a plan folder."""
    folder = result.path
    summary = read_json(folder / "summary.json", {})
    data = FolderData.read(folder)
    parts = [_key_table(summary, _plan_keys(summary), "Plan (summary.json)"), _enforced_table(data.limits, summary),
             _other_values(summary, PLAN_KEYS), _phase_plane(folder, summary, anchor)]
    count = 1
    if not data.complete or not (folder / TCP_FILE).is_file():
        parts.append(_note(data.note or f"no {TCP_FILE} in this folder: the planned TCP path and the arm view are "
                                        "omitted"))
    else:
        traj = read_columns(folder / "trajectory.csv", TRAJECTORY_COLUMNS)
        tcp_cols = read_columns(folder / TCP_FILE, ("tcp_x", "tcp_y", "tcp_z"))
        tcp = np.column_stack([tcp_cols[f"tcp_{a}"] for a in "xyz"])
        parts += [_joint_limits(traj, data.limits, anchor),
                  figure_html(fig.task_space_figure(tcp, original=data.original,
                                                     title="Planned TCP path (forward kinematics of the plan)"),
                               f"{anchor}-task"),
                  _arm(data, tcp, anchor, "planned motion")]
        count += 3
    moves, figures = _moves(folder, anchor)
    parts.append(moves)
    count += figures
    row = _plan_summary_row(summary)
    return Section(anchor, section_title("Plan", result, root, summary.get("scenario")), "".join(parts), count, row)


#: moves.csv columns shown, with (label, scale to the shown unit).
MOVE_COLUMNS = {"move": ("#", 1.0), "line": ("RAPID line", 1.0), "target": ("target", 1.0),
                "instruction": ("move", 1.0), "planned_time_s": ("planned [s]", 1.0), "dwell_s": ("dwell [s]", 1.0),
                "programmed_time_s": ("programmed-speed estimate [s]", 1.0),
                "mean_tcp_speed_m_s": ("mean TCP speed [m/s]", 1.0), "peak_tcp_speed_m_s": ("peak TCP speed [m/s]", 1.0),
                "binding_limit": ("binding limit", 1.0), "binding_joint": ("joint", 1.0),
                "binding_ratio": ("use of the limit [-]", 1.0), "blend_tolerance_m": ("blend tolerance [mm]", 1e3)}
#: Sorts a table.sortable by the clicked column (numbers as numbers, empty cells last).
SORT_JS = """document.addEventListener('click',function(e){var th=e.target.closest('table.sortable th');if(!th)return;
var tr=th.parentNode,table=tr.closest('table'),i=Array.prototype.indexOf.call(tr.children,th),
rows=Array.prototype.slice.call(table.querySelectorAll('tr')).slice(1),up=th.dataset.dir!=='up';
th.dataset.dir=up?'up':'down';function v(r){var t=r.children[i].textContent.trim(),n=parseFloat(t);
return t===''||t==='–'?null:(isNaN(n)?t:n);}rows.sort(function(a,b){var x=v(a),y=v(b);if(x===null)return 1;
if(y===null)return -1;return (x<y?-1:x>y?1:0)*(up?1:-1);});rows.forEach(function(r){r.parentNode.appendChild(r);});});"""


def _moves(folder: Path, anchor: str) -> tuple[str, int]:
    """(HTML, figure count) of moves.csv: the table of program moves (sortable by any column) and the bar
    chart of the cycle by move; ("", 0) without moves.csv."""
    if not (folder / schema.MOVES_FILE).is_file():
        return "", 0
    names, rows = read_rows(folder / schema.MOVES_FILE)
    cols = [c for c in MOVE_COLUMNS if c in names]
    head = "".join(f"<th>{escape(MOVE_COLUMNS[c][0])}</th>" for c in cols)
    body = "".join("<tr>" + "".join(cell(r.get(c), MOVE_COLUMNS[c][1]) for c in cols) + "</tr>" for r in rows)
    table = (f'<div class="scroll"><table class="rows sortable"><caption>Program moves ({schema.MOVES_FILE}; click '
             f"a column to sort)</caption><tr>{head}</tr>{body}</table></div>")
    return table + figure_html(fig.moves_figure(rows), f"{anchor}-moves"), 1


def simulation_section(result: ResultFolder, root: Path, anchor: str) -> Section:
    """Key figures (simulation and its plan), phase plane and joint limits of the plan, task-space
    path and deviation, joint tracking errors and the arm playing the simulated motion."""
    folder = result.path
    summary = read_json(folder / "summary.json", {})
    plan_summary = summary.get("plan") if isinstance(summary.get("plan"), dict) else {}
    data = FolderData.read(folder)
    note = data.note
    sim = read_columns(folder / "simulation.csv", SIMULATION_COLUMNS)
    t = sim["t"]
    tables = _key_table(summary, SIMULATION_KEYS, "Closed-loop simulation (summary.json)")
    if plan_summary:
        tables += _key_table(plan_summary, _plan_keys(plan_summary), "Its plan (summary.json: plan)")
    parts = [_failure_html(summary), f'<div class="tables">{tables}</div>',
             _other_values(summary, [*SIMULATION_KEYS, "failure"])]
    count = 0
    if note:
        parts.append(_note(note))
    if result.plan_path is not None:
        parts.append(_phase_plane(result.plan_path, plan_summary or read_json(result.plan_path / "summary.json", {}),
                                  anchor))
        count += 1
        plan_limits = read_json(result.plan_path / LIMITS_FILE, None)
        if plan_limits is not None:
            parts.append(_joint_limits(read_columns(result.plan_path / "trajectory.csv", TRAJECTORY_COLUMNS),
                                       plan_limits, anchor))
            count += 1
    else:
        parts.append(_note("no plan folder (./plan) next to this simulation: phase plane and limit plots omitted"))
    tcp = np.column_stack([sim[f"tcp_{a}"] for a in "xyz"])
    desired = np.column_stack([sim[f"tcp_desired_{a}"] for a in "xyz"])
    deviations = {"distance from the planned (blended) path": sim["path_deviation"]}
    if "sharp_deviation" in sim:
        deviations["distance from the original sharp path"] = sim["sharp_deviation"]
    parts.append(figure_html(fig.task_space_figure(desired, tcp, data.original, t, deviations,
                                                    title="Task space: TCP path and its deviation"), f"{anchor}-task"))
    q = joint_columns(sim, "q")
    failure = summary.get("failure") if isinstance(summary.get("failure"), dict) else None
    names = data.joint_names(q.shape[1])
    parts.append(figure_html(fig.tracking_figure(t, q - joint_columns(sim, "q_desired"), names, failure),
                              f"{anchor}-tracking"))
    count += 2
    if data.arm is not None:
        parts.append(_arm(data, desired, anchor, "simulated motion"))
        count += 1
    row = _plan_summary_row(plan_summary)
    row.update(simulated=summary.get(schema.CYCLE_TIME.key), path_dev=summary.get(schema.PATH_ACCURACY.key),
               sharp_dev=summary.get(schema.MAX_SHARP_DEVIATION.key), tracking=summary.get(schema.TRACKING_OK.key))
    return Section(anchor, section_title("Simulation", result, root, plan_summary.get("scenario")), "".join(parts), count,
                   row)


def sweep_parameters(names: Sequence[str], spec: dict | None) -> list[str]:
    """The swept parameters among a sweep table's columns: sweep_spec.json's grid keys, else the
    columns before the first known summary column."""

    if spec and isinstance(spec.get("grid"), dict):
        return [k for k in spec["grid"] if k in names]
    known = {*schema.keys(schema.SWEEP_ROW), schema.ERROR.key, schema.WALL_TIME.key}
    params = []
    for n in names:
        if n in known:
            break
        params.append(n)
    return params


def _first(names: Sequence[str], keys: Sequence[str]) -> str | None:
    return next((k for k in keys if k in names), None)


def _matching_row(rows: list[dict], best: dict | None, params: Sequence[str]) -> int | None:
    """The row best.json names: its index if the parameters agree, else the row with its parameters."""
    if not best:
        return None

    def same(row):
        return all(p in best and _equal(row.get(p), best[p]) for p in params)

    index = best.get("index")
    if isinstance(index, int) and 0 <= index < len(rows) and same(rows[index]):
        return index
    return next((i for i, r in enumerate(rows) if params and same(r)), None)


#: Sweep parameter values read back from JSON/CSV that count as the same value (round trip of a float
#: through text): relative and absolute tolerance [-], [unit of the value].
SAME_VALUE_REL = 1e-12
SAME_VALUE_ABS = 1e-15


def _equal(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(float(a), float(b), rel_tol=SAME_VALUE_REL, abs_tol=SAME_VALUE_ABS)
    return a == b


def _rows_table(rows: list[dict], first: Sequence[str], highlight: set[int], caption: str) -> str:
    cols = [*first, *(k for k in SWEEP_COLUMNS if rows and k in rows[0] and k not in first)]
    head = "".join(f"<th>{escape(_column_label(c))}</th>" for c in cols)
    body = []
    for i, r in enumerate(rows):
        cells = []
        for c in cols:
            if c == "error" and r.get(c):
                cells.append(f'<td class="bad error">{escape(str(r[c]))}</td>')
            else:
                cells.append(cell(r.get(c), SWEEP_COLUMNS.get(c, ("", "", 1.0))[2]))
        cls = ' class="best"' if i in highlight else ""
        body.append(f"<tr{cls}><td>{i}</td>{''.join(cells)}</tr>")
    return (f'<div class="scroll"><table class="rows"><caption>{escape(caption)}</caption>'
            f"<tr><th>#</th>{head}</tr>{''.join(body)}</table></div>")


def _column_label(c: str) -> str:
    label, unit, _ = SWEEP_COLUMNS.get(c, (c, "", 1.0))
    return f"{label} [{unit}]" if unit else label


def _tradeoff_section(rows, names, params, best_index, anchor, title, best_label, group_key=None, label=None):
    from ..study.score import pareto_front

    x_key, y_key = _first(names, DEVIATION_KEYS), _first(names, TIME_KEYS)
    errors = [i for i, r in enumerate(rows) if r.get("error")]
    parts = []
    count = 0
    if x_key and y_key:
        front = pareto_front(rows, x_key=x_key, y_key=y_key)

        def default_label(row):
            return ", ".join(f"{p} = {fmt(row.get(p))}" for p in params) or "point"

        figure = fig.tradeoff_figure(rows, x_key, y_key, front, best_index, label or default_label, title,
                                     fallback_y_key=_first(names, (schema.PLANNED_DURATION.key,)), group_key=group_key,
                                     best_label=best_label)
        parts.append(figure_html(figure, f"{anchor}-tradeoff"))
        count = 1
    else:
        parts.append(_note(f"the table has no deviation column ({', '.join(DEVIATION_KEYS)}) or no time column "
                           f"({', '.join(TIME_KEYS)}): no trade-off plot"))
    if errors:
        parts.append(_note(f"{len(errors)} point(s) failed with an error and have no values (red in the table)."))
    return parts, count, errors


def _varying(rows: list[dict], params: Sequence[str]) -> list[str]:
    """The parameters that take more than one value over the rows (all of them if none does)."""
    varying = [p for p in params if len({repr(r.get(p)) for r in rows}) > 1]
    return varying or list(params)


def _summary_from_row(row: dict | None) -> dict:
    """The summary-table cells a sweep or study row can fill (its best or only point)."""
    if row is None:
        return {}
    return {"planned": row.get(schema.PLANNED_DURATION.key),
            "simulated": row.get(schema.CYCLE_TIME.key, row.get(schema.LEGACY_SIMULATED_DURATION.key)),
            "baseline": row.get(schema.BASELINE_DURATION.key), "path_dev": row.get(schema.PATH_ACCURACY.key),
            "sharp_dev": row.get(schema.MAX_SHARP_DEVIATION.key),
            "tracking": row.get(schema.TRACKING_OK.key)}


def sweep_section(result: ResultFolder, root: Path, anchor: str) -> Section:
    """The trade-off plot (deviation against time, Pareto front, failed points, best point) and the
    table of points of a sweep folder."""
    from ..study.score import choose_best, outcome_text

    folder = result.path
    names, rows = read_rows(folder / "sweep.csv")
    spec = read_json(folder / "sweep_spec.json")
    params = sweep_parameters(names, spec)
    varying = _varying(rows, params)
    best = read_json(folder / "best.json")
    source = "best.json"
    if best is None and schema.CYCLE_TIME.key in names and schema.MEAN_SHARP_DEVIATION.key in names:
        best, source = choose_best(rows, params), "the study's score, no best.json"
    best_index = _matching_row(rows, best, params)
    scenario = spec.get("scenario") if spec else None
    title = f"Trade-off: deviation against time ({len(rows)} point{'s' if len(rows) != 1 else ''})"
    parts, count, _ = _tradeoff_section(
        rows, names, varying, best_index, anchor, title, f"best score ({source})")
    fixed = [p for p in params if p not in varying]
    fixed_text = ", ".join(f"{p} = {fmt(rows[0].get(p))}" for p in fixed) if rows else ""
    intro = (f"<p>Sweep of {escape(Path(str(scenario)).name if scenario else 'a scenario')} over "
             f"{escape(', '.join(varying) or 'no named parameter')}"
             + (f" (fixed: {escape(fixed_text)})" if fixed_text else "")
             + f": {outcome_text(rows)}.")
    if best_index is not None:
        rule = best.get("rule", "") if isinstance(best, dict) else ""
        values = ", ".join(f"{p} = {fmt(best.get(p))}" for p in varying)
        intro += (f" Best score ({escape(source)}): point #{best_index}"
                  + (f", {escape(values)}" if values else " (no parameter varies)")
                  + (f" <span class=\"muted\">({escape(rule)})</span>" if rule else "") + ".")
    intro += "</p>"
    parts = [intro, *parts, _rows_table(rows, params, {best_index} if best_index is not None else set(),
                                        "Points (sweep.csv); the best point is highlighted")]
    row = _summary_from_row(rows[best_index] if best_index is not None else rows[0] if len(rows) == 1 else None)
    row.update(scenario=scenario and Path(str(scenario)).stem, points=outcome_text(rows))
    return Section(anchor, section_title("Sweep", result, root, scenario and Path(str(scenario)).stem), "".join(parts),
                   count, row)


def study_section(result: ResultFolder, root: Path, anchor: str) -> Section:
    """The corner study's combined trade-off (every case, coloured by case) and its table."""
    from ..study.score import outcome_text

    folder = result.path
    names, rows = read_rows(folder / "corner_study.csv")
    record = read_json(folder / "corner_study.json", {}) or {}
    best = record.get("best") if isinstance(record.get("best"), dict) else None
    best_index = _matching_row(rows, best, [p for p in ("case", "parameter", "value") if p in names])

    def label(row):
        value = f" = {fmt(row.get('value'))}" if row.get("value") is not None else ""
        return f"{row.get('case')}: {row.get('parameter') or ''}{value}"

    title = f"Corner study: deviation from the sharp path against cycle time ({len(rows)} runs)"
    parts, count, _ = _tradeoff_section(rows, names, [], best_index, anchor, title,
                                             "best score (corner_study.json)", group_key="case", label=label)
    first = [c for c in ("case", "parameter", "value", "gain_vs_stop") if c in names]
    parts = [f"<p>The chapter-7 corner study: {len(rows)} runs in {len(set(r.get('case') for r in rows))} cases; "
             "each case is a sweep folder below (sections that follow).</p>", *parts,
             _rows_table(rows, first, {best_index} if best_index is not None else set(),
                         "Runs (corner_study.csv); the best-scored run is highlighted")]
    row = _summary_from_row(rows[best_index] if best_index is not None else None)
    row["points"] = outcome_text(rows, "run")
    return Section(anchor, section_title("Corner study", result, root, None), "".join(parts), count, row)


RENDERERS = {"plan": plan_section, "simulation": simulation_section, "sweep": sweep_section, "study": study_section,
             "atlas": atlas_section}


# ---------------------------------------------------------------------------------------- page
CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,Helvetica,Arial,sans-serif;margin:0;color:#222;
background:#fafafa;line-height:1.4}
main{max-width:1280px;margin:0 auto;padding:1em 2em 4em}
h1{margin-bottom:.2em} h2{border-bottom:2px solid #1f77b4;padding-bottom:.2em;margin-top:2.5em}
nav ol{columns:2;font-size:.95em} a{color:#1f5fa0}
table{border-collapse:collapse;margin:.6em 1.5em .6em 0;font-size:.9em;background:#fff}
caption{text-align:left;font-weight:600;padding:.3em 0}
th,td{border:1px solid #ddd;padding:.25em .6em;text-align:left;vertical-align:top}
table.rows th{background:#f0f4f8} table.keys th,table.limits th{font-weight:500;background:#f6f8fa}
td.ok{color:#1a7f37;font-weight:600} td.bad{color:#c62828;font-weight:600}
td.error{min-width:26em;font-weight:400}
tr.best td{background:#fff6d5}
.tables{display:grid;grid-template-columns:repeat(auto-fit,minmax(420px,1fr));gap:0 1.5em;align-items:start}
.tables table{width:100%}
.figure{background:#fff;border:1px solid #e3e3e3;margin:1em 0;padding:.3em}
.failure{color:#c62828;font-weight:600;border-left:4px solid #c62828;padding:.3em .8em;background:#fdecea}
.note{color:#8a6d00;background:#fff8e1;border-left:4px solid #e6a700;padding:.3em .8em}
table.sortable th{cursor:pointer} .muted{color:#666} .scroll{overflow-x:auto} details{margin:.5em 0}
"""

SUMMARY_COLUMNS = (("kind", "kind"), ("scenario", "scenario"), ("planned", "planned duration [s]"),
                   ("simulated", "simulated / cycle time [s]"), ("baseline", "constant-TCP-speed baseline [s]"),
                   ("speedup", "baseline / planned [×]"), ("path_dev", "max dev. from planned path [mm]"),
                   ("sharp_dev", "max dev. from sharp path [mm]"), ("tracking", "tracking ok"),
                   ("points", "sweep points"))


def _summary_table(sections: Sequence[Section]) -> str:
    head = "".join(f"<th>{escape(label)}</th>" for _, label in SUMMARY_COLUMNS)
    body = []
    for s in sections:
        row = dict(s.summary)
        row["kind"] = s.title.split(":")[0]
        if isinstance(row.get("planned"), (int, float)) and isinstance(row.get("baseline"), (int, float)) \
                and row["planned"] > 0:
            row["speedup"] = row["baseline"] / row["planned"]
        cells = "".join(cell(row.get(k), 1e3 if k.endswith("_dev") else 1.0) for k, _ in SUMMARY_COLUMNS)
        body.append(f'<tr><td><a href="#{s.anchor}">{escape(s.title.split(": ", 1)[-1])}</a></td>{cells}</tr>')
    return (f'<div class="scroll"><table class="rows"><tr><th>folder</th>{head}</tr>{"".join(body)}</table></div>')


def render_page(root: Path, sections: Sequence[Section]) -> str:
    """The whole HTML page (plotly.js embedded once)."""
    from plotly.offline import get_plotlyjs

    from .. import __version__

    toc = "".join(f'<li><a href="#{s.anchor}">{escape(s.title)}</a></li>' for s in sections)
    body = "".join(f'<section id="{s.anchor}" data-figures="{s.figures}"><h2>{escape(s.title)}</h2>{s.body}</section>'
                   for s in sections)
    total = sum(s.figures for s in sections)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="pathmotion-figures" content="{total}">
<title>pathmotion report: {escape(root.resolve().name)}</title>
<style>{CSS}</style>
<script type="text/javascript">{get_plotlyjs()}</script>
<script type="text/javascript">{SORT_JS}</script>
</head><body><main>
<h1>pathmotion report: {escape(root.resolve().name)}</h1>
<p class="muted">{len(sections)} result folder(s) under {escape(str(root))}, {total} interactive figures
(drag to zoom or rotate, double-click to reset, click a legend entry to hide it). Written by pathmotion
{escape(__version__)}; self-contained, works offline.</p>
<nav><h2>Contents</h2><ol><li><a href="#summary">Summary</a></li>{toc}</ol></nav>
<section id="summary"><h2>Summary</h2>{_summary_table(sections)}</section>
{body}
</main></body></html>
"""


def _in_study_order(results, root: Path):
    """The results of a demo folder in the order of its table (demo.csv: the thesis' experiments in
    study order), the others (the corner study) after them; any other folder in name order."""
    if not (root / "demo.csv").is_file():
        return results
    order = [str(r.get(schema.SCENARIO.key)) for r in read_rows(root / "demo.csv")[1]]

    def rank(result):
        top = result.path.relative_to(root).parts[:1]
        return order.index(top[0]) if top and top[0] in order else len(order)

    return tuple(sorted(results, key=rank))  # stable: the name order within a rank


def build_report(folder: str | Path, out: str | Path | None = None) -> Path:
    """Write ``out`` (default ``folder/report.html``): one self-contained interactive page of every
    result under ``folder`` (see the module docstring); returns its path. PathmotionError when there
    is none."""
    root = Path(folder)
    results = _in_study_order(discover(root), root)
    sections = [RENDERERS[r.kind](r, root, f"s{k + 1}") for k, r in enumerate(results)]
    return write_text(root / "report.html" if out is None else Path(out), render_page(root, sections))
