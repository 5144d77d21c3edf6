"""Sweep throughput on 2 cores: local processes vs a Dask cluster (a LocalCluster of 2 single-thread
worker processes started here), the same sweep, printed as simulated seconds per wall second and
their ratio. The tables are checked equal. The local pool is created per sweep (its process start-up,
imports and JIT compilation count); the Dask workers live on (their start-up is printed apart).

    .venv/bin/python benchmarks/bench_sweep.py [--points 6] [--grid-points 300]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pathmotion.scenarios import scenario_path
from pathmotion.study import run_study_sweep


def _throughput(rows, wall: float) -> float:
    simulated = sum(r["cycle_time_s"] or 0.0 for r in rows if r["error"] is None)
    return simulated / wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=6, help="sweep points (r_t values)")
    ap.add_argument("--grid-points", type=int, default=300)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    radii = [round(0.02 + 0.025 * k / max(1, args.points - 1), 6) for k in range(args.points)]
    grid = {"path.blends[0].radius": radii, "plan.grid_points": [args.grid_points]}
    scen = scenario_path("corner_transition")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        local = run_study_sweep(scen, grid, Path(tmp) / "local", workers=args.workers, figures=False)
        wall_local = time.perf_counter() - t0

        from distributed import LocalCluster

        t0 = time.perf_counter()
        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None) as cl:
            startup = time.perf_counter() - t0
            t0 = time.perf_counter()
            dask = run_study_sweep(scen, grid, Path(tmp) / "dask", scheduler=cl.scheduler_address, figures=False)
            wall_dask = time.perf_counter() - t0
    same = dask.rows == local.rows
    tl, td = _throughput(local.rows, wall_local), _throughput(dask.rows, wall_dask)
    print(f"sweep: {len(radii)} points of corner_transition (grid_points {args.grid_points}), {args.workers} workers")
    print(f"local processes: {wall_local:7.2f} s wall, {tl:6.3f} simulated s / wall s")
    print(f"dask cluster:    {wall_dask:7.2f} s wall, {td:6.3f} simulated s / wall s "
          f"(+ {startup:.2f} s to start the cluster, not counted)")
    print(f"ratio dask / local throughput: {td / tl:.3f}   tables identical: {same}")


if __name__ == "__main__":
    main()
