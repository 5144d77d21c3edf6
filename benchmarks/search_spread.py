"""How much the optimal blend moves when its tolerance moves in its last bits: the blend search (planning/
blend_search.py) run on one corner at delta (1 + e) for several tiny e. Its stages are local searches that branch
on comparisons (which S-curve the racing stage ends at, whether a blend reaches a path end), so a change of 1e-9 of the
tolerance can end in another local optimum: the spread printed is how far one atlas number is from luck.

    python benchmarks/search_spread.py                       # the 90 deg turn at 10 mm
    python benchmarks/search_spread.py --angle 30 --tolerance 0.005
    python benchmarks/search_spread.py --relative 0,1e-9,-1e-9 --wide-plans 0 --wide-normal-plans 0
    python benchmarks/search_spread.py --angle 30 --tolerance 0.005 --restart-plans 0   # without the wide restart
    python benchmarks/search_spread.py --angle 30 --tolerance 0.005 --search-grid-points 2000 --reference 0.67146
    python benchmarks/search_spread.py --angle 60 --tolerance 0.01 --relative 0 --global-plans 0   # without it

Prints per run the full-grid duration, the spans and which ends are free; then the median and range.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from right_turn import TURN  # noqa: E402  (the 90 degree turn, defined once there)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angle", type=float, default=None,
                    help="an atlas corner's turn angle [deg] (default: the 90 degree turn)")
    ap.add_argument("--tolerance", type=float, default=0.01, help="tube radius [m]")
    ap.add_argument("--relative", default="0,1e-9,-1e-9,2e-9,-2e-9,1e-7,-1e-7",
                    help="relative changes e of the tolerance, comma-separated")
    ap.add_argument("--wide-plans", type=int, default=None, help="plans of the outward wide start (default WIDE_PLANS)")
    ap.add_argument("--wide-normal-plans", type=int, default=None,
                    help="plans of the wide start along the normal (default WIDE_NORMAL_PLANS)")
    ap.add_argument("--restart-plans", type=int, default=None, help="plans of the wide restart (default RESTART_PLANS)")
    ap.add_argument("--search-grid-points", type=int, default=None,
                    help="the search's fixed grid (default SEARCH_GRID_POINTS)")
    ap.add_argument("--global-plans", type=int, default=None, help="plans of the global stage (default GLOBAL_PLANS)")
    ap.add_argument("--polish-plans", type=int, default=None, help="plans of the full-grid polish (default POLISH_PLANS)")
    ap.add_argument("--polish-starts", type=int, default=None,
                    help="how many of the fastest distinct full-grid candidates the polish runs from (default POLISH_STARTS)")
    ap.add_argument("--reference", type=float, default=None,
                    help="a reference duration [s] (e.g. the whole-tube optimum): also prints each run's gap to it "
                         "and how many runs are within 1 %% of it")
    a = ap.parse_args()
    if a.reference is not None and not a.reference > 0:
        ap.error(f"--reference must be a positive duration [s], got {a.reference}")
    if a.search_grid_points is not None and a.search_grid_points < 3:
        ap.error(f"--search-grid-points must be at least 3, got {a.search_grid_points}")
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    from pathmotion.planning import blend_search as bs
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _settings, _task, corner_points

    robot = load_robot("irb140")
    points = TURN if a.angle is None else corner_points(a.angle)
    kw = {"wide_plans": bs.WIDE_PLANS if a.wide_plans is None else a.wide_plans,
          "wide_normal_plans": bs.WIDE_NORMAL_PLANS if a.wide_normal_plans is None else a.wide_normal_plans,
          "restart_plans": bs.RESTART_PLANS if a.restart_plans is None else a.restart_plans,
          "search_grid_points": bs.SEARCH_GRID_POINTS if a.search_grid_points is None else a.search_grid_points,
          "polish_plans": bs.POLISH_PLANS if a.polish_plans is None else a.polish_plans,
          "global_plans": bs.GLOBAL_PLANS if a.global_plans is None else a.global_plans,
          "polish_starts": bs.POLISH_STARTS if a.polish_starts is None else a.polish_starts}
    where = "the 90 deg turn" if a.angle is None else f"{a.angle:g} deg atlas corner"
    print(f"{where}, {a.tolerance * 1e3:g} mm, {kw}, load {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    durations = []
    for e in (float(v) for v in a.relative.split(",")):
        t0 = time.process_time()
        best = bs.optimal_blends(robot, _task(points), a.tolerance * (1 + e),
                                 settings=_settings(verify=False, baselines=False), **kw)
        s = best.shapes[0]
        durations.append(best.duration)
        gap = "" if a.reference is None else f" ({100 * (best.duration / a.reference - 1):.3f} % over the reference)"
        print(f"  e = {e:+.0e}: {best.duration:.6f} s{gap}, spans {s.entry * 1e3:.1f} / {s.exit * 1e3:.1f} mm, free start "
              f"{s.departure is not None}, free end {s.arrival is not None}, {best.plans} plans, "
              f"{time.process_time() - t0:.0f} s CPU", flush=True)
    d = np.array(durations)
    print(f"median {np.median(d):.6f} s, range {d.min():.6f}-{d.max():.6f} s ({100 * (d.max() / d.min() - 1):.2f} %)")
    if a.reference is not None:
        print(f"over the reference {a.reference:.6g} s: median {100 * (np.median(d) / a.reference - 1):.3f} %, "
              f"{int(np.sum(d <= 1.01 * a.reference))} of {len(d)} within 1 %")


if __name__ == "__main__":
    main()
