"""The planner against the CasADi + IPOPT reference on circle_zero (issue 12's table), and its speed.

For every case of issue 12's table the planner solves at the given grids (default: its default
1000 points and 2000); each duration is compared with the converged reference of
``benchmarks/reference_topp.py`` (recorded below from its run over 200..6400 intervals with
Richardson extrapolation; ``--reference 200 400 800`` recomputes it on those grids instead). The
solve time is the verified plan (``PlanResult.solve_time_s``, baselines off), next to toppra's
acceleration-only solve on the same machine in the same run.

Run: ``.venv/bin/python benchmarks/bench_third_order.py`` (several minutes on a loaded 2-core machine);
``--quick``: one coarse grid (150 points), a check that it runs, not a measurement.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from pathmotion.api import load
from pathmotion.planning import PlanSettings, plan

#: Converged optima from benchmarks/reference_topp.py (its module docstring), in seconds.
RECORDED_REFERENCE = {
    "vel + acc": 1.087412,
    "+ jerk 10x acc": 1.213063,
    "+ jerk 4x acc": 1.554302,
    "vel + torque, acc off": 0.466664,
    "vel + torque, reserve 0.2": 0.497121,
}


def cases(robot) -> dict[str, dict]:
    acc = robot.limits.acceleration
    return {
        "vel + acc": dict(torque=False),
        "+ jerk 10x acc": dict(torque=False, jerk_limit=tuple(10.0 * acc)),
        "+ jerk 4x acc": dict(torque=False, jerk_limit=tuple(4.0 * acc)),
        "vel + torque, acc off": dict(acceleration=False),
        "vel + torque, reserve 0.2": dict(acceleration=False, torque_reserve=0.2),
    }


def toppra_seconds(path, robot, gridpoints: int = 1000, repeat: int = 3) -> float:
    """Best of ``repeat`` wall times of toppra's acceleration-only solve (ParametrizeConstAccel)."""
    from reference_topp import toppra_instance

    lim = robot.limits
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        toppra_instance(path, lim.velocity, lim.acceleration, gridpoints).compute_trajectory()
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="pathmotion/scenarios/circle_zero.toml")
    parser.add_argument("--grids", type=int, nargs="+", default=[1000, 2000])
    parser.add_argument("--reference", type=int, nargs="*", default=None,
                        help="recompute the reference on these interval counts (default: the recorded values)")
    parser.add_argument("--quick", action="store_true", help="one coarse grid (150 points): checks that it runs")
    args = parser.parse_args(argv)
    if args.quick:
        args.grids = [150]
    setup = load(args.scenario)
    path, robot = setup.path, setup.robot
    reference = dict(RECORDED_REFERENCE)
    if args.reference:
        import reference_topp as ref

        for label, limits in ref.circle_cases(robot).items():
            reference[label] = ref.converged_duration(path, robot, limits, args.reference)[0]
    t_toppra = toppra_seconds(path, robot)
    header = f"{'limits':28s} {'reference [s]':>13s}" + "".join(
        f" {f'grid {g} [s]':>14s} {'diff':>8s} {'solve':>8s} {'max ratio':>9s}" for g in args.grids)
    print(header)
    for label, kwargs in cases(robot).items():
        line = f"{label:28s} {reference[label]:13.6f}"
        for g in args.grids:
            res = plan(path, robot, PlanSettings(grid_points=g, baselines=False, **kwargs))
            diff = 100 * (res.duration / reference[label] - 1)
            line += (f" {res.duration:14.6f} {diff:+7.3f}% {res.solve_time_s:7.2f}s "
                     f"{res.ratios.max_ratio:9.5f}")
        print(line, flush=True)
    print(f"\ntoppra acceleration-only solve at 1000 points: {1e3 * t_toppra:.1f} ms (same run)")


if __name__ == "__main__":
    main()
