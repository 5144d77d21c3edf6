"""The chapter-7 corner study on the shipped scenarios (horizontal circle + radial line, 90 deg corner).

:func:`corner_study` runs, each as a resumable sweep in its own sub-folder of ``out``:

* ``stop``: stop at the corner (corner_stop), the reference cycle;
* ``boundary``: boundary-level velocity at the corner, no transition (corner_max: tracking fails);
* ``transition``: the transition circle for each r_t (corner_transition, thesis Fig. 7.8/7.9);
* ``speed``: r_t = ``speed_radius`` with the blend speed scaled (plan.blend_speed_scale, Fig. 7.10/7.11);
* ``g2``: the G2 blend with the time-optimal profile for each tolerance (corner_g2);
* ``matched``: the transition circle whose deviation from the sharp path equals each G2 tolerance
  (the circle against the G2 blend at the same deviation).

``overrides`` (key path -> value) apply to every run, e.g. ``{"limits.use_acceleration": False}``.
It writes ``corner_study.csv`` / ``.json`` (one row per run: case, parameter, cycle time, deviation
from the sharp path, tracking error, tracking_ok, gain over the stop) and the figures
``rt_y.png``, ``rt_error.png``, ``rt_corner.png``, ``speed_y.png``, ``speed_error.png``,
``tradeoff.png`` and ``g2_vs_transition.png``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from ..io import schema
from .. import defaults
from ..io.atomic import write_json
from .score import choose_best, pareto_front
from .sweep import OnResult, load_trace, run_sweep, write_tables

RADIUS_KEY = "path.blends[0].radius"
TOLERANCE_KEY = "path.blends[0].tolerance"
SPEED_KEY = "plan.blend_speed_scale"
#: The transition-circle radius r_t of the thesis' corner experiment [m] (labelled in the figures).
THESIS_RADIUS = 0.04
#: Columns of corner_study.csv.
CORNER_COLUMNS = ("case", "parameter", "value", schema.CYCLE_TIME.key, schema.PLANNED_DURATION.key, "gain_vs_stop",
                  schema.MAX_SHARP_DEVIATION.key, schema.MEAN_SHARP_DEVIATION.key, schema.PATH_ACCURACY.key, schema.TRACKING_OK.key, "error")


@dataclass(frozen=True, eq=False)
class CornerStudy:
    """rows: one dict per run (CORNER_COLUMNS); best: the best-scored run; front: indices of rows on
    the Pareto front; out: folder; figures: PNG files written."""

    rows: list[dict]
    best: dict | None
    front: list[int]
    out: Path
    figures: tuple[Path, ...]


def transition_radius_for_deviation(original, corner: int, deviation: float, iterations: int = 40) -> float:
    """The transition circle radius r_t [m] whose largest distance from ``original`` (the sharp task
    path) is ``deviation`` [m] at connection ``corner`` (bisection; the deviation grows with r_t).
    PathError if even the largest radius that fits deviates less."""
    from ..errors import PathError
    from ..geometry import max_deviation, with_transition
    from ..geometry.blends import largest_transition_radius

    def dev(r: float) -> float:
        return max_deviation(with_transition(original, corner, r), original).distance

    hi = largest_transition_radius(original, corner)
    if dev(hi) < deviation:
        raise PathError(f"a transition circle at connection {corner} deviates at most {dev(hi):.4g} m (r_t = {hi:.4g} m)"
                        f", less than {deviation:.4g} m")
    lo = 0.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if dev(mid) < deviation else (lo, mid)
    return 0.5 * (lo + hi)


def _part(name: str, scenario: str, grid: dict[str, list], overrides: dict, out: Path, traces: bool, **kw):
    from ..scenarios import scenario_path

    full = {k: [v] for k, v in overrides.items() if k not in grid}
    full.update(grid)
    points, rows = run_sweep(scenario_path(scenario), full, out / name, traces=traces, **kw)
    return points, rows


def corner_study(out, *, r_t_values: Sequence[float] = (0.03, 0.035, 0.04, 0.049),
                 speed_scales: Sequence[float] = (0.25, 0.5, 0.75, 1.0),
                 speed_radius: float = defaults.THESIS_TRANSITION_RADIUS,
                 g2_tolerances: Sequence[float] = (0.002, 0.005, 0.01),
                 overrides: dict[str, Any] | None = None, workers: int = 2, scheduler: str | None = None,
                 on_result: OnResult | None = None, figures: bool = True,
                 error_weight: float = defaults.STUDY_ERROR_WEIGHT) -> CornerStudy:
    """Run the corner study into ``out`` (see the module docstring); returns its table and choice.
    ``on_result(done, total)`` reports progress per part (total = that part's points)."""
    from ..api import load
    from ..scenarios import scenario_path

    out = Path(out)
    overrides = dict(overrides or {})
    kw = dict(workers=workers, scheduler=scheduler, on_result=on_result)
    original = load(scenario_path("corner_g2"), {k: v for k, v in overrides.items()
                                                 if k.startswith("robot.")}).original_task_path
    matched = [transition_radius_for_deviation(original, 0, tol) for tol in g2_tolerances]
    parts = {
        "stop": ("corner_stop", {}, False),
        "boundary": ("corner_max", {}, False),
        "transition": ("corner_transition", {RADIUS_KEY: list(r_t_values)}, True),
        "speed": ("corner_transition", {RADIUS_KEY: [speed_radius], SPEED_KEY: list(speed_scales)}, True),
        "g2": ("corner_g2", {TOLERANCE_KEY: list(g2_tolerances)}, True),
        "matched": ("corner_transition", {RADIUS_KEY: matched}, False),
    }
    results = {name: _part(name, scen, grid, overrides, out, traces, **kw)
               for name, (scen, grid, traces) in parts.items()}
    rows = _table(results)
    best = choose_best(rows, ("case", "parameter", "value"), error_weight=error_weight)
    front = pareto_front(rows)
    write_tables(out, rows, list(CORNER_COLUMNS), stem="corner_study")
    write_json(out / "corner_study.json", {"overrides": overrides, "rows": rows, "best": best, "pareto_front": front,
                                           "matched_radii_m": dict(zip(map(str, g2_tolerances), matched))})
    written: tuple[Path, ...] = ()
    if figures:
        written = _figures(out, results, rows, speed_radius)
    return CornerStudy(rows, best, front, out, written)


def _table(results: dict) -> list[dict]:
    stop_rows = results["stop"][1]
    stop = stop_rows[0].get(schema.CYCLE_TIME.key) if stop_rows else None
    keys = {"transition": RADIUS_KEY, "speed": SPEED_KEY, "g2": TOLERANCE_KEY, "matched": RADIUS_KEY}
    names = {"transition": "r_t [m]", "speed": "blend_speed_scale", "g2": "tolerance [m]",
             "matched": "r_t [m] (deviation = G2 tolerance)"}
    rows = []
    for case, (_, part_rows) in results.items():
        for r in part_rows:
            row = {"case": case, "parameter": names.get(case, ""), "value": r.get(keys[case]) if case in keys else None}
            row.update({k: r.get(k) for k in CORNER_COLUMNS if k not in row})
            cyc = row[schema.CYCLE_TIME.key]
            row["gain_vs_stop"] = None if cyc is None or not stop else 1.0 - cyc / stop
            rows.append(row)
    return rows


def _runs(out: Path, results: dict, part: str, label) -> list[tuple[str, dict]]:
    points, rows = results[part]
    runs = []
    for p, r in zip(points, rows):
        trace = load_trace(out / part, p)
        if trace is not None:
            runs.append((label(dict(p.overrides), r), trace))
    return runs


def _figures(out: Path, results: dict, rows: list[dict], speed_radius: float) -> tuple[Path, ...]:
    from . import figures as fig

    def tag(r):
        return "" if r.get(schema.TRACKING_OK.key) else " (tracking failed)"

    written = []
    rt = _runs(out, results, "transition", lambda o, r: f"r_t = {o[RADIUS_KEY]:g} m{tag(r)}")
    if rt:
        written.append(fig.y_figure(rt, out / "rt_y.png", "Transition radius r_t: TCP y(t) against the desired path"))
        written.append(fig.error_figure(rt, out / "rt_error.png",
                                        "Transition radius r_t: error vector TCP - nearest point of the sharp path"))
        corner = rt[0][1]["sharp_path"][0]
        written.append(fig.corner_view_figure(rt, corner, THESIS_RADIUS, out / "rt_corner.png", "Corner region, top view"))
    sp = _runs(out, results, "speed", lambda o, r: f"blend speed x{o[SPEED_KEY]:g} (r_t = {speed_radius:g} m){tag(r)}")
    if sp:
        written.append(fig.y_figure(sp, out / "speed_y.png", "Transition segment speed: TCP y(t) against the desired path"))
        written.append(fig.error_figure(sp, out / "speed_error.png",
                                        "Transition segment speed: error vector TCP - nearest point of the sharp path"))
    # the slowed-blend runs are in speed_*.png; here the geometric trade-off (stop, r_t, G2, matched)
    shown = [r for r in rows if r["case"] != "speed"]
    labels = {}
    for i, r in enumerate(shown):
        if r["case"] == "stop":
            labels[i] = "stop at corner"
        elif r["case"] == "transition" and r["value"] is not None and math.isclose(r["value"], THESIS_RADIUS):
            labels[i] = "thesis r_t = 0.04 m"

    def small(r):
        if r["case"] in ("transition", "matched"):
            return f"r_t {r['value'] * 1000:.3g} mm"
        if r["case"] == "g2":
            return f"G2 {r['value'] * 1000:.3g} mm"
        return ""

    written.append(fig.tradeoff_figure(shown, pareto_front(shown), choose_best(shown), out / "tradeoff.png",
                                       labels=labels, point_label=small,
                                       title="90 deg corner: deviation from the sharp path vs cycle time"))
    written.append(_families(rows, out / "g2_vs_transition.png"))
    return tuple(written)


def _families(rows: list[dict], path: Path) -> Path:
    """Cycle time against deviation for the G2 blends and the transition circles (all radii)."""
    from .figures import MM, _plt, _save

    plt = _plt()
    f, ax = plt.subplots(figsize=(7, 4.8))
    for cases, label, style in ((("transition", "matched"), "transition circle (time-optimal)", "o-"),
                                (("g2",), "G2 blend (time-optimal)", "s-")):
        pts = sorted((r[schema.MAX_SHARP_DEVIATION.key], r[schema.CYCLE_TIME.key]) for r in rows
                     if r["case"] in cases and r.get(schema.TRACKING_OK.key) and r.get(schema.CYCLE_TIME.key) is not None)
        if pts:
            ax.plot([p[0] * MM for p in pts], [p[1] for p in pts], style, label=label)
    stop = [r for r in rows if r["case"] == "stop" and r.get(schema.CYCLE_TIME.key) is not None]
    if stop:
        ax.axhline(stop[0][schema.CYCLE_TIME.key], color="k", ls="--", lw=1, label="stop at the corner")
        ax.axhline(stop[0][schema.CYCLE_TIME.key] * (1 - 0.16), color="tab:red", ls=":", lw=1, label="16 % shorter than the stop")
    ax.axvline(10.0, color="0.5", ls=":", lw=1, label="10 mm")
    ax.set_xlabel("largest TCP distance from the sharp path [mm]")
    ax.set_ylabel("cycle time (closed loop) [s]")
    ax.set_title("G2 blend vs transition circle at the same deviation")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    f.tight_layout()
    return _save(f, path)
