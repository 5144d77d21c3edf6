"""The jerk planner's speed against toppra, and its optimality against the CasADi + IPOPT reference.

Speed: the verified plan (``plan``, certified verification, baselines off; ``PlanResult.solve_time_s``
is the same span) on ``scenarios/circle_smooth.toml`` (jerk, torque with a 0.2 reserve, the
torque-speed envelope; acceleration estimates off) at its default grid and at fixed grids, timed
interleaved with toppra's acceleration-only solve (``reference_topp.toppra_instance``, 1000 points,
``compute_trajectory``) on the same path, in the same process: one warm-up of each, then
``--repeat`` rounds of (toppra, each grid). Medians with their ranges, the machine's load average
before and after, and the ratio of the medians are printed.

Optimality: the planner at its default grid (and ``--grids``) against the converged reference
(``benchmarks/reference_topp.py``) on the circle_zero table (recorded below from its run over
200..6400 intervals; ``--reference 200 400 800`` recomputes it), and on ``--splines`` random joint
splines (seeded, 4 waypoints uniform in [-1.2, 1.2] rad, velocity + acceleration + jerk 10x the
acceleration limits), whose references were converged over 200, 400, 800 intervals (Richardson;
recorded below, ``--spline-reference 200 400 800`` recomputes them). Target: within 1 %. Each default-grid
line also shows the plan's ``duration_error_estimate`` and the error / estimate ratio (at most 1 when the
estimate bounds the error).

Run: ``.venv/bin/python benchmarks/bench_third_order.py`` (about a minute on a loaded 2-core machine);
``--quick``: fewer repeats, no fixed grids, no splines, a check that it runs.
"""

from __future__ import annotations

import dataclasses

import argparse
import os
import time
import numpy as np

from pathmotion import defaults
from pathmotion.api import load
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, plan

#: Converged optima from benchmarks/reference_topp.py (its module docstring), in seconds.
RECORDED_REFERENCE = {
    "vel + acc": 1.087412,
    "+ jerk 10x acc": 1.213063,
    "+ jerk 4x acc": 1.554302,
    "vel + torque, acc off": 0.466664,
    "vel + torque, reserve 0.2": 0.497121,
}
#: Converged references of the random splines (seed: duration [s]): reference_topp.converged_duration over
#: 200, 400, 800 intervals (Richardson, orders 0.93-1.01), vel + acc + jerk 10x acc; ``--spline-reference``
#: recomputes them (about 3 minutes per spline on a loaded 2-core machine).
RECORDED_SPLINE_REFERENCE = {0: 2.249666, 1: 2.166832, 2: 2.106202, 3: 1.855757, 4: 1.930648}
#: toppra's grid for the timing baseline [points].
TOPPRA_POINTS = 1000


def cases(robot) -> dict[str, dict]:
    acc = robot.limits.acceleration
    return {
        "vel + acc": dict(limits={"use_torque": False}),
        "+ jerk 10x acc": dict(limits={"use_torque": False, "jerk": tuple(10.0 * acc)}),
        "+ jerk 4x acc": dict(limits={"use_torque": False, "jerk": tuple(4.0 * acc)}),
        "vel + torque, acc off": dict(limits={"use_acceleration": False}),
        "vel + torque, reserve 0.2": dict(limits={"use_acceleration": False, "torque_reserve": 0.2}),
    }


def _ms(value) -> str:
    """A duration [s] in ms, or "none"."""
    return "none" if value is None else f"{1e3 * value:.2f} ms"


def _stats(values) -> str:
    v = 1e3 * np.asarray(values)
    return f"{np.median(v):8.1f} ms [{v.min():.1f}, {v.max():.1f}]"


def speed(scenario: str, grids: list, repeat: int) -> None:
    """Interleaved timing of the verified jerk plan and toppra's acceleration-only solve."""
    from reference_topp import toppra_instance

    setup = load(scenario)
    path, robot = setup.path, setup.robot
    base = setup.plan_settings
    lim = robot.limits
    labels = ["default"] + [str(g) for g in grids]
    settings = {lab: _with_grid(base, None if lab == "default" else int(lab)) for lab in labels}

    def run_toppra():
        t0 = time.perf_counter()
        toppra_instance(path, lim.velocity, lim.acceleration, TOPPRA_POINTS).compute_trajectory()
        return time.perf_counter() - t0

    def run_plan(lab):
        t0 = time.perf_counter()
        res = plan(path, robot, settings[lab])
        return time.perf_counter() - t0, res

    load_before = os.getloadavg()
    run_toppra()
    results = {lab: run_plan(lab)[1] for lab in labels}  # warm-up (numba, caches)
    times = {"toppra": [], **{lab: [] for lab in labels}}
    for _ in range(repeat):
        times["toppra"].append(run_toppra())
        for lab in labels:
            dt, results[lab] = run_plan(lab)
            times[lab].append(dt)
    load_after = os.getloadavg()
    t_toppra = float(np.median(times["toppra"]))
    print(f"speed: {scenario} (jerk + torque, reserve, envelope), verified ({base.verify.value}), "
          f"{repeat} interleaved rounds after a warm-up; load average {load_before[0]:.1f} before, "
          f"{load_after[0]:.1f} after ({os.cpu_count()} cores)")
    print(f"  {'toppra acc-only, ' + str(TOPPRA_POINTS) + ' points':34s} {_stats(times['toppra'])}")
    for lab in labels:
        res = results[lab]
        print(f"  {'pathmotion, grid ' + lab + f' ({res.grid_points} points)':34s} {_stats(times[lab])}  "
              f"ratio {np.median(times[lab]) / t_toppra:5.2f}  T = {res.duration:.6f} s  "
              f"max ratio {res.ratios.max_ratio:.5f} ({res.ratios.method}), {res.tighten_iterations} tightening, "
              f"error estimate {_ms(res.duration_error_estimate)}")


def _with_grid(settings: PlanSettings, grid_points):
    """``settings`` with ``grid_points`` and the baselines off."""
    return dataclasses.replace(settings, grid_points=grid_points, baselines=False)


def optimality_circle(scenario: str, grids: list, reference_grids) -> list:
    setup = load(scenario)
    path, robot = setup.path, setup.robot
    reference = dict(RECORDED_REFERENCE)
    if reference_grids:
        import reference_topp as ref

        for label, limits in ref.circle_cases(robot).items():
            reference[label] = ref.converged_duration(path, robot, limits, reference_grids)[0]
    labels = ["default"] + [str(g) for g in grids]
    print(f"\noptimality: {scenario} against the converged reference (recorded: reference_topp.py)")
    print(f"  {'limits':28s} {'reference [s]':>13s}" + "".join(f" {'grid ' + lab:>16s} {'diff':>8s}" for lab in labels)
          + "   (est.: the default grid's duration_error_estimate, and |diff| / est.)")
    diffs = []
    for label, kwargs in cases(robot).items():
        line = f"  {label:28s} {reference[label]:13.6f}"
        for lab in labels:
            res = plan(path, robot, PlanSettings(grid_points=None if lab == "default" else int(lab), baselines=False,
                                                 **kwargs))
            diff = 100 * (res.duration / reference[label] - 1)
            if lab == "default":
                diffs.append(diff)
                est, err = res.duration_error_estimate, abs(res.duration - reference[label])
            line += f" {res.duration:16.6f} {diff:+7.3f}%"
        if est is not None:
            line += f"   est. {_ms(est)} ({err / est:.2f})"
        print(line, flush=True)
    return diffs


def optimality_splines(count: int, reference_grids, robot) -> list:
    """The planner at its default grid against the splines' references (recorded unless ``reference_grids``)."""
    import reference_topp as ref

    lim = robot.limits
    limits = ref.ReferenceLimits(velocity=lim.velocity, acceleration=lim.acceleration, jerk=10.0 * lim.acceleration)
    print(f"\noptimality: {count} random splines (seeds 0..{count - 1}), vel + acc + jerk 10x acc, default grid "
          f"({defaults.THIRD_ORDER_GRID_POINTS} points); reference "
          + (f"converged over {list(reference_grids)} intervals" if reference_grids else "recorded (200, 400, 800)"))
    print(f"  {'seed':>4s} {'reference [s]':>13s} {'order':>6s} {'pathmotion [s]':>14s} {'diff':>8s} {'solve':>9s}"
          f"  error estimate (|diff| / estimate)")
    diffs = []
    for seed in range(count):
        path = SplineJointPath.from_waypoints(np.random.default_rng(seed).uniform(-1.2, 1.2, (4, 6)))
        if reference_grids or seed not in RECORDED_SPLINE_REFERENCE:
            t_ref, order, _ = ref.converged_duration(path, robot, limits, reference_grids or (200, 400, 800))
        else:
            t_ref, order = RECORDED_SPLINE_REFERENCE[seed], float("nan")
        res = plan(path, robot, PlanSettings(limits={"use_torque": False, "jerk": tuple(10.0 * lim.acceleration)},
                                             baselines=False))
        diff = 100 * (res.duration / t_ref - 1)
        diffs.append(diff)
        order_text = f"{order:6.2f}" if np.isfinite(order) else f"{'rec.':>6s}"
        est = res.duration_error_estimate
        print(f"  {seed:4d} {t_ref:13.6f} {order_text} {res.duration:14.6f} {diff:+7.3f}% "
              f"{1e3 * res.solve_time_s:7.0f} ms  {_ms(est)}"
              + ("" if est is None else f" ({abs(res.duration - t_ref) / est:.2f})"), flush=True)
    return diffs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speed-scenario", default="scenarios/circle_smooth.toml")
    parser.add_argument("--scenario", default="pathmotion/scenarios/circle_zero.toml")
    parser.add_argument("--grids", type=int, nargs="*", default=[200, 400])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--reference", type=int, nargs="*", default=None,
                        help="recompute the circle reference on these interval counts (default: the recorded values)")
    parser.add_argument("--splines", type=int, default=5)
    parser.add_argument("--spline-reference", type=int, nargs="*", default=None,
                        help="recompute the splines' reference on these interval counts (default: the recorded values)")
    parser.add_argument("--quick", action="store_true", help="3 rounds, no fixed grids, no splines: checks that it runs")
    args = parser.parse_args(argv)
    if args.quick:
        args.grids, args.repeat, args.splines = [], 3, 0
    speed(args.speed_scenario, args.grids, args.repeat)
    diffs = optimality_circle(args.scenario, args.grids, args.reference)
    if args.splines:
        diffs += optimality_splines(args.splines, args.spline_reference, load(args.scenario).robot)
    print(f"\nlargest difference from the reference at the default grid: {max(diffs, key=abs):+.3f} % (target: 1 %)")


if __name__ == "__main__":
    main()
