"""The atlas' corner-confined references on a finer mesh sequence: does the 1 % verdict hold?

The atlas (``pathmotion corners``) solves each free-shape reference on defaults.ATLAS_MESHES (25, 50, 100 intervals) and
extrapolates (free_shape.extrapolate). Its stated error is |extrapolated - finest|, which assumes the three meshes
are in the asymptotic range. This script solves each row's corner-confined reference, the one the 1 % target is
measured against, on the atlas' meshes and on a longer sequence (default 25, 50, 100, 200), exactly as the atlas
does (the same blend, spans, starts and cache keys: study/atlas.corner_reference), and prints both with the gap of
the optimal blend to each, and the mesh durations. A cache folder makes a re-run read every solved reference.

    python benchmarks/refine_references.py 60:0.01 120:0.01 --cache out/refine_cache
    python benchmarks/refine_references.py --all --cache out/refine_cache     # the 20 atlas rows that fit

Reading: the longer sequence's value lies outside the atlas' value +- its error where the three meshes were not
yet asymptotic; the last column says whether the blend is within 1 % of the finer reference.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

#: The atlas' angles [deg] and tolerances [m] whose blends fit the 0.2 m lines (0.05 m does not).
ATLAS_ROWS = tuple(f"{a}:{t}" for a in (30, 60, 90, 120, 150) for t in (0.0001, 0.001, 0.005, 0.01))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rows", nargs="*", help="ANGLE_DEG:TOLERANCE_M")
    ap.add_argument("--all", action="store_true", help="every atlas row that fits (ATLAS_ROWS)")
    ap.add_argument("--meshes", default="25,50,100,200", help="the finer sequence (intervals, each twice the last)")
    ap.add_argument("--cache", type=Path, required=True, help="optimum cache folder (an atlas' optimum_cache works)")
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    from pathmotion import defaults
    from pathmotion.robot import load_robot
    from pathmotion.study import atlas
    from pathmotion.study.free_shape import check_meshes

    finer = check_meshes([int(m) for m in a.meshes.split(",")], least=3)
    rows = list(ATLAS_ROWS if a.all else a.rows)
    if not rows:
        ap.error("give rows ANGLE_DEG:TOLERANCE_M or --all")
    robot = load_robot("irb140")
    a.cache.mkdir(parents=True, exist_ok=True)
    print(f"| angle | tol mm | optimal [s] | corner ref. {list(defaults.ATLAS_MESHES)} | gap | corner ref. "
          f"{list(finer)} | gap | mesh durations [s] | CPU [s] | within 1 % |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        angle, tol = (float(v) for v in row.split(":"))
        t0 = time.process_time()
        pts = atlas.corner_points(angle)
        task = atlas._task(pts)
        stop = atlas._duration(robot, task, connections="zero")
        best, _, warm = atlas.optimal_motion(robot, task, tol)
        T, shape = float(warm.profile.duration), best.shapes[0]
        spans, cells = [(shape.entry, shape.exit)], []
        for meshes in (defaults.ATLAS_MESHES, finer):
            ref = atlas.corner_reference(a.cache, robot, pts, tol, spans, meshes, warm, shape.racing, min(stop, T))
            if ref.value is None:
                cells += [f"none ({ref.note})", "-"]
            else:
                note = "" if ref.note is None else f" ({ref.note})"
                cells += [f"{ref.value:.5f} ± {ref.error * 1e3:.2f} ms{note}", f"{100 * (T / ref.value - 1):.2f} %"]
        durations = ", ".join(f"{d:.5f}" for d in ref.durations)  # the finer reference's
        verdict = "-" if ref.value is None else ("yes" if T <= 1.01 * ref.value else "no")
        print(f"| {angle:g} | {tol * 1e3:g} | {T:.5f} | {' | '.join(cells)} | {durations} | "
              f"{time.process_time() - t0:.0f} | {verdict} |", flush=True)


if __name__ == "__main__":
    main()
