"""The 90 degree turn, (0.4, -0.1, 0.45) -> (0.5, -0.1, 0.45) -> (0.5, 0.1, 0.45) m, tool down, rest to
rest, velocity and acceleration limits: the stop, the G2 blend, the optimal blend and BOTH free-shape references
(corner-confined on the optimal blend's own spans, and the whole tube), as the atlas solves them (study/atlas.py:
the same starts, retries and cache), with the share of the whole tube's gain over the stop that each takes.

    python benchmarks/right_turn.py                              # 1, 3 and 10 mm, meshes 25/50/100
    python benchmarks/right_turn.py --tolerances 0.01 --cache out/turn_cache

Reading: the moonshot asks the optimal blend for >= 90 % of the whole tube's gain. "corner-confined capture" is
what even the best motion that deviates only over the blend's own spans can take; where it is below 90 %, the
moonshot needs the path to leave the line outside the corner's spans, which no corner blend does.
Needs the optional extra: pip install "pathmotion[optimal]".
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

TURN = np.array([(0.4, -0.1, 0.45), (0.5, -0.1, 0.45), (0.5, 0.1, 0.45)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tolerances", default="0.001,0.003,0.01", help="tube radii [m], comma-separated")
    ap.add_argument("--meshes", default="25,50,100", help="NLP meshes (intervals), each twice the previous")
    ap.add_argument("--cache", default="out/right_turn_cache", help="free-shape optimum cache folder")
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    from pathmotion.geometry import with_g2_blend
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _duration, _task, corner_reference, optimal_motion, whole_reference

    robot = load_robot("irb140")
    task = _task(TURN)
    meshes = tuple(int(m) for m in a.meshes.split(","))
    cache = Path(a.cache)
    cache.mkdir(parents=True, exist_ok=True)
    stop = _duration(robot, task, connections="zero")
    rows = []
    for tol in (float(t) for t in a.tolerances.split(",")):
        t0 = time.process_time()
        g2 = _duration(robot, with_g2_blend(task, 0, tol), task)
        best, _, warm = optimal_motion(robot, task, tol)
        opt = float(warm.profile.duration)
        shape = best.shapes[0]
        spans = [(shape.entry, shape.exit)]
        feasible = min(stop, opt)
        corner = corner_reference(cache, robot, TURN, tol, spans, meshes, warm, shape.racing, feasible)
        whole = whole_reference(cache, robot, TURN, tol, meshes, corner, spans, warm, feasible)
        rows.append((tol, g2, best.quintic_duration, opt, shape, corner, whole, time.process_time() - t0))
        print(f"{tol * 1e3:g} mm: optimal {opt:.5f} s, corner-confined {corner.value} ({corner.note}), "
              f"whole {whole.value} ({whole.note}), {rows[-1][-1]:.0f} s CPU", flush=True)

    def share(t, whole):
        return "-" if t is None or whole is None else f"{100 * (stop - t) / (stop - whole):.1f} %"

    print(f"\nstop {stop:.5f} s, meshes {meshes}, load {os.getloadavg()[0]:.1f}")
    print("| tolerance | spans (entry / exit) | G2 | fastest single quintic | optimal blend | corner-confined optimum "
          "| whole-tube optimum | capture: G2 / quintic / optimal / corner-confined | gap to corner-confined |")
    print("|---|---|---|---|---|---|---|---|---|")
    for tol, g2, quintic, opt, shape, corner, whole, _ in rows:
        cv = "none" if corner.value is None else f"{corner.value:.5f} s ± {1e3 * (corner.error or 0):.2f} ms"
        wv = "none" if whole.value is None else f"{whole.value:.5f} s ± {1e3 * (whole.error or 0):.2f} ms"
        gap = "-" if corner.value is None else f"{100 * (opt / corner.value - 1):.2f} %"
        shares = " / ".join(share(t, whole.value) for t in (g2, quintic, opt, corner.value))
        print(f"| {tol * 1e3:g} mm | {shape.entry * 1e3:.1f} / {shape.exit * 1e3:.1f} mm | {g2:.5f} s "
              f"| {quintic:.5f} s "
              f"| {opt:.5f} s | {cv} | {wv} | {shares} | {gap} |")


if __name__ == "__main__":
    main()
