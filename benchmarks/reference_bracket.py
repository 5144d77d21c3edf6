"""Bracket the corner-confined free-shape optimum of atlas rows from both sides and measure the optimal blend
against both.

A mesh imposes the tube only at its points, so between them the TCP may leave it, and each mesh's duration (and
their extrapolation, the atlas' ``corner_optimum_s``) may lie below the true minimum time. The feasible bound
(study/free_shape.feasible_bound) re-solves the finest mesh in a tube shrunk by that excess until a dense resample
holds the given tube: a motion that meets every constraint, so the true minimum time is at most its duration and the
blend's gap to it is a lower bound of the blend's true gap. Each row: the optimal blend (full grid, rest to rest,
velocity and acceleration limits: the atlas' settings), the reference on the blend's own spans (from the stop, on
--meshes), its dense excess, the feasible bound, and the blend's gap to each.

    python benchmarks/reference_bracket.py --rows 135/0.007,135/0.002 --workers 2
    python benchmarks/reference_bracket.py --rows 135/0.007 --meshes 25,50,100,200
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed


def row(angle: float, tolerance: float, meshes: tuple[int, ...]) -> dict:
    from pathmotion.planning.blend_search import optimal_blends
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs
    from pathmotion.study.atlas import _settings, _task, corner_points

    robot = load_robot("irb140")
    pts = corner_points(angle)
    t0 = time.process_time()
    blend = optimal_blends(robot, _task(pts), tolerance, settings=_settings(verify=False, baselines=False))
    shape = blend.shapes[0]
    spans = [(shape.entry, shape.exit)]
    t1 = time.process_time()
    opt = fs.free_shape_optimum(robot, pts, tolerance, spans, meshes)
    t2 = time.process_time()
    try:
        bound = fs.feasible_bound(robot, pts, tolerance, spans, meshes, optimum=opt)
        feasible, radius, solves, note = bound.duration, bound.radius, bound.solves, ""
    except Exception as exc:  # reported in the row, never a silent number
        feasible, radius, solves, note = float("nan"), float("nan"), 0, str(exc)
    t3 = time.process_time()
    return {"angle": angle, "tolerance": tolerance, "blend": blend.duration, "durations": opt.durations,
            "reference": opt.duration, "error": opt.convergence_error, "success": opt.success,
            "excess": opt.solutions[-1].verification["max_excess_m"], "feasible": feasible, "radius": radius,
            "solves": solves, "note": note, "cpu": (t1 - t0, t2 - t1, t3 - t2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", default="135/0.007,135/0.002", help="angle/tolerance pairs [deg/m], comma-separated")
    ap.add_argument("--meshes", default="25,50,100", help="NLP meshes (intervals), each twice the previous")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    rows = [tuple(float(v) for v in r.split("/")) for r in a.rows.split(",")]
    meshes = tuple(int(v) for v in a.meshes.split(","))
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores), {a.workers} workers, "
          f"meshes {meshes}")
    print(f"{'angle':>5} {'tol mm':>6} {'blend s':>8} {'meshes s':>26} {'extrap. s':>16} {'excess mm':>9} "
          f"{'feasible s':>10} {'tube mm':>7} {'gap extrap.':>11} {'gap >=':>7}  CPU s (blend, NLP, bound)", flush=True)
    with ProcessPoolExecutor(a.workers) as pool:  # rows in the order they finish
        for done in as_completed([pool.submit(row, angle, tol, meshes) for angle, tol in rows]):
            _print(done.result())
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


def _print(r: dict) -> None:
    gap = 100 * (r["blend"] / r["reference"] - 1)
    low = 100 * (r["blend"] / r["feasible"] - 1)
    print(f"{r['angle']:5g} {r['tolerance'] * 1e3:6g} {r['blend']:8.5f} "
          f"{', '.join(f'{d:.5f}' for d in r['durations']):>26} "
          f"{r['reference']:.5f}+-{r['error'] * 1e3:4.2f}ms {r['excess'] * 1e3:9.3f} {r['feasible']:10.5f} "
          f"{r['radius'] * 1e3:7.3f} {gap:10.2f}% {low:6.2f}%  {', '.join(f'{c:.0f}' for c in r['cpu'])}"
          + ("" if r["success"] else "  (reference did not converge)") + (f"  {r['note']}" if r["note"] else ""),
          flush=True)


if __name__ == "__main__":
    main()
