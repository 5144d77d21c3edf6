"""A 1,000-point sweep on 2 worker processes, some points failing on purpose.

The scenario is cheap on purpose: the shipped joint-waypoint spline on a 30-point grid with the torque
limit off (inactive on this path; its dense verification is the slow part). The grid sweeps the end speed
``plan.end`` over 100 values, of which those above the feasible range (about 0.48 / s) fail with an
InfeasibleError, and ``plan.grid_points`` over 10 values: 1,000 points. Prints the wall time, the number of
failed rows and checks that every point has its row (finished points intact, failures recorded).

    python benchmarks/bench_sweep_scale.py [--points 1000] [--workers 2] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=1000, help="points (a multiple of 10)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args(argv)
    from pathmotion.scenarios import scenario_path
    from pathmotion.study import run_study_sweep

    ends = [round(float(v), 4) for v in np.linspace(0.0, 0.99, args.points // 10)]
    grids = list(range(30, 40))
    folder = Path(tempfile.mkdtemp(prefix="pathmotion-sweep-")) if args.out is None else args.out
    scenario = folder / "joint.toml"
    folder.mkdir(parents=True, exist_ok=True)
    scenario.write_text(scenario_path("joint_waypoints").read_text().replace("[limits]", "[limits]\nuse_torque = false", 1))
    t0 = time.perf_counter()
    outcome = run_study_sweep(scenario, {"plan.end": ends, "plan.grid_points": grids}, folder / "sweep",
                              workers=args.workers, figures=False)
    wall = time.perf_counter() - t0
    rows = outcome.rows
    failed = [r for r in rows if r["error"]]
    internal = [r for r in failed if not r["error"].startswith(("InfeasibleError", "PathError", "ScenarioError"))]
    lines = (folder / "sweep" / "sweep.csv").read_text().splitlines()
    print(f"{len(rows)} points on {args.workers} workers in {wall:.1f} s ({wall / len(rows) * 1e3:.0f} ms per point); "
          f"{len(failed)} failed on purpose, {len(rows) - len(failed)} finished; sweep.csv has {len(lines) - 1} rows")
    ok = len(rows) == len(ends) * len(grids) == len(lines) - 1 and not internal and failed
    print("every point has its row, failures recorded" if ok else f"PROBLEM: internal errors {internal[:3]}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
