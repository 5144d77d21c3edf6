"""A sweep with its choice: run the points, score them, find the Pareto front, write best.json
and the trade-off figure (what ``pathmotion sweep`` does)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..io import schema
from .. import defaults
from ..io.atomic import write_json
from .score import choose_best, pareto_front
from .sweep import OnResult, SweepPoint, run_sweep

SCORE_RULE = "score = cycle_time_s + error_weight * mean_sharp_deviation_m (lower is better; tracking_ok points only)"


@dataclass(frozen=True, eq=False)
class SweepOutcome:
    """rows: one dict per point in point order (parameters, SUMMARY_KEYS, error); best: the chosen
    point (index, parameters, score, key metrics) or None; front: row indices on the Pareto front of
    max_sharp_deviation_m vs cycle_time_s; points: the SweepPoints; out: the output folder;
    figures: the PNG files written."""

    rows: list[dict]
    best: dict | None
    front: list[int]
    points: list[SweepPoint] = field(repr=False)
    out: Path
    figures: tuple[Path, ...] = ()


def run_study_sweep(scenario_path, grid: dict[str, list], out, *, workers: int = 2, scheduler: str | None = None,
                    on_result: OnResult | None = None, figures: bool = True, traces: bool = False,
                    error_weight: float = defaults.STUDY_ERROR_WEIGHT) -> SweepOutcome:
    """Sweep ``grid`` (key path -> values) over the scenario file, write ``out/sweep.csv``,
    ``sweep.parquet``, ``best.json`` (the best-scored point, the rule, the Pareto front) and, with
    ``figures``, ``tradeoff.png``. Resumes in an existing ``out``. See :mod:`.sweep` and :mod:`.score`."""
    out = Path(out)
    points, rows = run_sweep(scenario_path, grid, out, workers=workers, scheduler=scheduler, on_result=on_result,
                             traces=traces)
    params = list(grid)
    best = choose_best(rows, params, error_weight=error_weight)
    front = pareto_front(rows)
    record = dict(best) if best is not None else {"index": None, "score": None,
                                                  "reason": "no point finished without error and with tracking_ok"}
    record["rule"] = SCORE_RULE
    record["error_weight_s_per_m"] = error_weight
    record["pareto_front"] = [{**{p: rows[i].get(p) for p in params}, "index": i,
                               schema.MAX_SHARP_DEVIATION.key: rows[i][schema.MAX_SHARP_DEVIATION.key],
                               schema.CYCLE_TIME.key: rows[i][schema.CYCLE_TIME.key]} for i in front]
    write_json(out / "best.json", record)
    written: tuple[Path, ...] = ()
    if figures and rows:
        from .figures import tradeoff_figure

        varying = [p for p in params if len(grid[p]) > 1] or params

        def label(row):
            return ", ".join(f"{p.rsplit('.', 1)[-1]}={row[p]:g}" if isinstance(row[p], float) else
                             f"{p.rsplit('.', 1)[-1]}={row[p]}" for p in varying)

        written = (tradeoff_figure(rows, front, best, out / "tradeoff.png", point_label=label,
                                   title=f"{Path(scenario_path).stem}: deviation vs cycle time"),)
    return SweepOutcome(rows, best, front, points, out, written)
