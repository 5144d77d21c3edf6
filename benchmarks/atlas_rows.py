"""The corner atlas' own work, without the free-shape references: what `pathmotion corners` does once every
optimum is cached (the target: under 10 minutes on 2 cores), without the hours of NLPs a cache costs to
fill. Every row runs through the atlas' sweep machinery (`corner_atlas(..., references=False)`, the same
worker processes), in a fresh folder; prints each row's wall time and optimal blend, the total wall time, and the
machine load. A real cached run adds only the cache look-ups (JSON files) and the figures.

    python benchmarks/atlas_rows.py                                  # the whole atlas, 2 workers
    python benchmarks/atlas_rows.py --angles 90 --tolerances 0.001,0.01 --workers 1
    python benchmarks/atlas_rows.py --angles 90 --json benchmarks/results/atlas_rows_90.json    # for make results
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path


#: The JSON table's columns (corner_atlas row keys, and each row's wall time).
COLUMNS = [("angle_deg", "angle [deg]"), ("tolerance_m", "tolerance [m]"), ("stop_s", "stop [s]"),
           ("industrial_zone_s", "parabolic zone, constant speed [s]"), ("circle_s", "circle [s]"),
           ("g2_s", "G2 [s]"), ("optimal_s", "optimal blend [s]"), ("gain_vs_stop", "optimal vs stop"),
           ("closed_loop_ok", "closed loop tracks"), ("closed_loop_path_accuracy_m", "closed-loop accuracy [m]"),
           ("row_wall_s", "row wall time [s]"), ("error", "error")]


def _rounded(v):
    return round(v, 6) if isinstance(v, float) else v


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angles", default="30,60,90,120,150", help="turn angles [deg], comma-separated")
    ap.add_argument("--tolerances", default="0.0001,0.001,0.005,0.01,0.05", help="tolerances [m], comma-separated")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, help="write the rows as a JSON table here (benchmarks/results.py)")
    a = ap.parse_args()
    from result_json import Table

    table = Table("The corner atlas without the free-shape references (`corners --no-references`): the planned "
                  "motions per corner", COLUMNS)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from pathmotion.study.atlas import corner_atlas
    from pathmotion.study.sweep import load_finished

    angles = [float(v) for v in a.angles.split(",")]
    tolerances = [float(v) for v in a.tolerances.split(",")]
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores), {a.workers} workers")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        atlas = corner_atlas(tmp, angles, tolerances, workers=a.workers, figures=False, references=False)
        wall = time.perf_counter() - t0
        times = {(rec["summary"]["angle_deg"], rec["summary"]["tolerance_m"]): rec.get("wall_time_s")
                 for rec in load_finished(Path(tmp) / "points_sweep").values()}
    print(f"{'angle':>6} {'tolerance':>10} {'optimal [s]':>12} {'spans [mm]':>15} {'row wall [s]':>13}  status")
    for r in sorted(atlas.rows, key=lambda r: (r["angle_deg"], r["tolerance_m"])):
        opt = "-" if r.get("optimal_s") is None else f"{r['optimal_s']:.6f}"
        row_wall = times.get((r["angle_deg"], r["tolerance_m"]))
        spans = ("-" if r.get("optimal_entry_m") is None
                 else f"{r['optimal_entry_m'] * 1e3:.1f} / {r['optimal_exit_m'] * 1e3:.1f}")  # which reference applies
        print(f"{r['angle_deg']:6g} {r['tolerance_m'] * 1e3:8g} mm {opt:>12} {spans:>15} "
              f"{'-' if row_wall is None else f'{row_wall:.1f}':>13}  {r.get('error') or r.get('status')}")
        table.add(**{k: _rounded(r.get(k)) for k, _ in COLUMNS if k != "row_wall_s"},
                  row_wall_s=None if row_wall is None else round(row_wall, 1))
    table.notes.append(f"{len(atlas.rows)} rows, {a.workers} workers: {wall:.0f} s wall for the atlas, "
                       f"{sum(v or 0.0 for v in times.values()):.0f} s of row wall time.")
    if a.json:
        print(f"wrote {table.write(a.json)}")
    print(f"rows: {len(atlas.rows)}, sum of row wall times {sum(v or 0.0 for v in times.values()):.0f} s, "
          f"atlas wall {wall:.0f} s ({wall / 60:.1f} min)")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
