"""Peak memory of planning on large grids and of simulating a long motion.

Each case runs in a fresh process (so peaks do not mix) and reports that process's peak resident set size
(``ru_maxrss``) and its baseline after the imports, next to the grid size or the simulated time. The bounds
stated below are checked: the script exits 1 if one is exceeded.

    python benchmarks/bench_memory.py            # grids 1,000 / 10,000 / 100,000 and 60 s of simulation
    python benchmarks/bench_memory.py --quick    # grids 1,000 / 10,000 and 10 s
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import resource
import sys
import time

#: Stated bounds on the peak resident memory [MiB] (imports included).
PLAN_BOUND_MIB = {1_000: 1024, 10_000: 1024, 100_000: 2048}
SIMULATE_BOUND_MIB = 2048


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kilobytes on Linux


def _plan_case(grid: int, queue) -> None:
    from pathmotion import api
    from pathmotion.scenarios import scenario_path

    setup = api.load(scenario_path("joint_waypoints"), {"plan.grid_points": grid})
    base = _peak_mib()
    t0 = time.perf_counter()
    result = api.plan_scenario(setup)
    queue.put({"grid": result.grid_points, "duration_s": result.profile.duration, "baseline_mib": base,
               "peak_mib": _peak_mib(), "wall_s": time.perf_counter() - t0})


def _simulate_case(seconds: float, queue) -> None:
    from pathmotion import api
    from pathmotion.scenarios import scenario_path

    setup = api.load(scenario_path("circle_periodic"))
    result = api.plan_scenario(setup)
    laps = max(1, math.ceil(seconds / result.profile.duration))
    setup = api.load(scenario_path("circle_periodic"), {"simulate.laps": laps})
    result = api.plan_scenario(setup)
    base = _peak_mib()
    t0 = time.perf_counter()
    sim = api.simulate_scenario(setup, result)
    queue.put({"laps": laps, "simulated_s": float(sim.t[-1]), "samples": len(sim.t), "baseline_mib": base,
               "peak_mib": _peak_mib(), "wall_s": time.perf_counter() - t0, "tracking_ok": sim.tracking_ok})


def _run(target, arg) -> dict:
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=target, args=(arg, queue))
    proc.start()
    out = queue.get()
    proc.join()
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="smaller grids and a 10 s simulation")
    args = parser.parse_args(argv)
    grids = (1_000, 10_000) if args.quick else (1_000, 10_000, 100_000)
    seconds = 10.0 if args.quick else 60.0
    ok = True
    print(f"{'case':<34}{'baseline [MiB]':>16}{'peak [MiB]':>12}{'bound [MiB]':>13}{'wall [s]':>10}")
    for grid in grids:
        r = _run(_plan_case, grid)
        bound = PLAN_BOUND_MIB[grid]
        ok &= r["peak_mib"] <= bound
        label = f"plan, grid_points = {grid:,} ({r['grid']:,} used)"
        print(f"{label:<34}"
              f"{r['baseline_mib']:>16.0f}{r['peak_mib']:>12.0f}{bound:>13}{r['wall_s']:>10.2f}")
    r = _run(_simulate_case, seconds)
    ok &= r["peak_mib"] <= SIMULATE_BOUND_MIB
    label = f"simulate {r['simulated_s']:.1f} s ({r['laps']} laps)"
    print(f"{label:<34}"
          f"{r['baseline_mib']:>16.0f}{r['peak_mib']:>12.0f}{SIMULATE_BOUND_MIB:>13}{r['wall_s']:>10.2f}")
    print("within the stated bounds" if ok else "A BOUND WAS EXCEEDED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
