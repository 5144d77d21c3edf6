"""Optimal blends on paths with many corners: each corner searched on its window (the default) against every plan
on the whole path (``windows=False``), interleaved, on zigzags in the IRB140's workspace with 3-10 corners (random
leg lengths and turns, rest to rest, velocity, acceleration and torque limits). Prints per path: the durations
(symmetric G2, whole-path search, windowed search), the CPU time of each and the ratio, and a summary with medians,
ranges and the machine load. The whole-path search's cost grows with corners x path length, the windowed one's with
corners, so the ratio grows with the corners.

    python benchmarks/bench_blend_windows.py                          # 4 paths, 3-10 corners, with the polish
    python benchmarks/bench_blend_windows.py --corners 3,5 --polish-plans 0 --tolerance 0.003
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def zigzag(corners: int, seed: int) -> np.ndarray:
    """(corners + 2, 3) points [m]: a zigzag across y at z = 0.45 m, x alternating about 0.42 and 0.54 m (legs 10-16 cm)."""
    rng = np.random.default_rng(seed)
    y = np.linspace(-0.2, 0.2, corners + 2)
    x = np.where(np.arange(corners + 2) % 2 == 0, rng.uniform(0.40, 0.44, corners + 2), rng.uniform(0.52, 0.56, corners + 2))
    return np.c_[x, y + rng.uniform(-0.01, 0.01, corners + 2), np.full(corners + 2, 0.45)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corners", default="3,5,8,10", help="corners per path, comma-separated (one path each)")
    ap.add_argument("--tolerance", type=float, default=0.002, help="blend tolerance [m]")
    ap.add_argument("--polish-plans", type=int, default=None, help="plans of the full-grid polish (default POLISH_PLANS)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from pathmotion.geometry import FixedOrientation, Line, TaskPath
    from pathmotion.planning import PlanSettings
    from pathmotion.planning import blend_search as bs
    from pathmotion.robot import load_robot

    robot = load_robot("irb140")
    settings = PlanSettings(start="zero", end="zero", verify=False, baselines=False)
    polish = bs.POLISH_PLANS if a.polish_plans is None else a.polish_plans
    print(f"tolerance {a.tolerance * 1e3:g} mm, polish {polish} plans, load {os.getloadavg()[0]:.2f} "
          f"({os.cpu_count()} cores)")
    rows = []
    for i, n in enumerate(int(v) for v in a.corners.split(",")):
        pts = zigzag(n, a.seed + i)
        path = TaskPath(tuple(Line(p, q) for p, q in zip(pts[:-1], pts[1:])), FixedOrientation())
        out = {}
        for windows in ((True, False) if i % 2 == 0 else (False, True)):  # interleaved: each goes first in turn
            t0 = time.process_time()
            best = bs.optimal_blends(robot, path, a.tolerance, settings=settings, polish_plans=polish, windows=windows)
            out[windows] = (best.duration, time.process_time() - t0, best.symmetric_duration)
        (tw, cw, sym), (tf, cf, _) = out[True], out[False]
        rows.append((n, cf / cw, 100 * (tw / tf - 1)))
        print(f"{n:3d} corners, {path.length:.3f} m: symmetric G2 {sym:.5f} s, whole path {tf:.5f} s ({cf:.0f} s CPU), "
              f"windows {tw:.5f} s ({cw:.0f} s CPU): {cf / cw:.1f}x faster, duration {100 * (tw / tf - 1):+.3f} %",
              flush=True)
    r = np.array(rows)
    print(f"speed-up: median {np.median(r[:, 1]):.1f}x (range {r[:, 1].min():.1f}-{r[:, 1].max():.1f}); windows' duration "
          f"against the whole path's: median {np.median(r[:, 2]):+.3f} % (range {r[:, 2].min():+.3f} to "
          f"{r[:, 2].max():+.3f} %); load at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
