"""Benchmark: pathmotion's time-optimal planner against toppra at equal accuracy.

Cases: random 6-joint clamped cubic splines through 4, 7 and 12 waypoints drawn with
numpy.random.default_rng(seed).uniform(-1.5, 1.5), knots evenly spaced on [0, 1]; three limit sets:
  vel+acc   IRB140 velocity limits, accelerations ACC = (10, 10, 12, 20, 20, 25) rad/s^2;
  torque    the same plus the IRB140 torque limits;
  binding   torque limits with a 6 kg payload 0.2 m off the flange and doubled accelerations (the
            torque ratio is printed: it must be 1, i.e. torque binds).
toppra gets the same limits (JointTorqueConstraint with Pinocchio's RNEA on the same model,
interpolation discretization like ours) and the ParametrizeConstAccel output, whose duration is that
of its discretized optimum.

Method, per case:
  * T* by first-order Richardson extrapolation from BOTH tools on uniform grids of N and 2N points
    (both values and their agreement are printed; T* is their mean).
  * The same grid search for both tools: the smallest N of GRIDS (x sqrt 2 steps) whose duration is
    within ACCURACY (0.1 %) of T* (ours: N uniform points plus its grading towards the ends).
  * Timing after a warm-up, interleaved in a random order, REPEATS repetitions of each: toppra on its
    own grid, toppra on our grid, ours bare (verify off), ours verified (certified) on the searched
    grid, ours adaptive at tolerance 0.1 % (verified) and ours at default settings (adaptive 0.05 %,
    verified). Medians per case; over cases medians with min-max ranges.
  * Accuracy of the default settings against T*, and the largest limit ratio of the default plan on
    the 0.1 ms resample (every active limit).
  * The certification's cost: verified / bare on the same grid, in CPU time of the process (medians of
    the same interleaved runs; on a loaded machine the wall time of a millisecond call is mostly waiting).
Machine load (os.getloadavg) is printed at start and end.

Direct mode (``--direct``): the certification's cost alone, on the searched grid of each selected case:
plan() bare (verify off) and verified (certified) called alternately in a random order, ROUNDS rounds
after WARMUP calls of each; CPU time of the process and wall time; per case the ratio of the medians and
its range over BLOCKS consecutive blocks of rounds, the machine load before and after.

    python benchmarks/bench_planner_vs_toppra.py            # 4 seeds x (4, 7, 12) waypoints
    python benchmarks/bench_planner_vs_toppra.py --quick    # 1 seed x (4, 7, 12), fewer repetitions
    python benchmarks/bench_planner_vs_toppra.py --sets binding torque --waypoints 4   # a subset
    python benchmarks/bench_planner_vs_toppra.py --direct --sets binding --waypoints 4  # certification cost
    python benchmarks/bench_planner_vs_toppra.py --quick --json benchmarks/results/planner_vs_toppra.json
(--json writes the speed-up summary as a table for benchmarks/results.py; --repeats sets the repetitions.)
"""

from __future__ import annotations

import argparse
import logging
import os
import random
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from pathmotion import defaults
from pathmotion.control.threads import single_blas_thread
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, effective_limits, plan
from pathmotion.planning.grid import make_grid
from pathmotion.planning.verify import sample_ratios
from pathmotion.robot import load_robot
from pathmotion.robot.model import Payload
from result_json import Table

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
GRIDS = [int(round(100 * 2 ** (k / 2))) for k in range(17)]  # 100 ... 25600, x sqrt(2)
ACCURACY = 1e-3
T_STAR_POINTS = (8000, 16000)
#: Direct mode: calls of each before timing, timed rounds (one bare and one verified call each, in a
#: random order) and the blocks of consecutive rounds whose ratios give the range.
WARMUP, ROUNDS, BLOCKS = 10, 150, 5
SEEDS, WAYPOINTS = (1, 2, 3, 4), (4, 7, 12)


def robots():
    irb = load_robot("irb140")
    base = irb.with_limits(replace(irb.limits, acceleration=ACC))
    heavy = irb.with_payload(Payload(mass=6.0, com=(0.0, 0.0, 0.2)))
    heavy = heavy.with_limits(replace(heavy.limits, acceleration=2 * ACC))
    return {"vel+acc": (base, False), "torque": (base, True), "binding": (heavy, True)}


def same_limits(torque: bool) -> dict:
    """Our planner's limit choices for the problem toppra solves: the whole torque limits (no feedback reserve)."""
    return {"use_torque": torque, "torque_reserve": 0.0}


def toppra_solver(robot, wp, torque):
    """f(grid) -> toppra's ConstAccel trajectory on that grid (theta in [0, 1])."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    lim = robot.limits
    cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T),
            constraint.JointAccelerationConstraint(np.vstack([-lim.acceleration, lim.acceleration]).T)]
    if torque:
        model, data = robot.model, robot.model.createData()
        cons.append(constraint.JointTorqueConstraint(
            lambda q, v, a: pin.rnea(model, data, q, v, a), np.vstack([-lim.torque, lim.torque]).T,
            np.zeros(robot.n), discretization_scheme=constraint.DiscretizationType.Interpolation))
    path = ta.SplineInterpolator(np.linspace(0, 1, len(wp)), wp, bc_type="clamped")
    return lambda grid: algo.TOPPRA(cons, path, gridpoints=grid, parametrizer="ParametrizeConstAccel") \
        .compute_trajectory()


def interleaved(fns: dict, repeats: int) -> tuple[dict, dict]:
    """({name: median wall time [s]}, {name: median CPU time of this process [s]}): one warm-up each,
    then ``repeats`` rounds in a random order. The CPU time leaves out the time the process waits for
    a core, which on a shared machine is most of the wall time of a millisecond call."""
    for fn in fns.values():
        fn()
    wall, cpu = {k: [] for k in fns}, {k: [] for k in fns}
    rng = random.Random(0)
    for _ in range(repeats):
        order = list(fns)
        rng.shuffle(order)
        for k in order:
            t, c = time.perf_counter(), time.process_time()
            fns[k]()
            wall[k].append(time.perf_counter() - t)
            cpu[k].append(time.process_time() - c)
    return ({k: statistics.median(v) for k, v in wall.items()}, {k: statistics.median(v) for k, v in cpu.items()})


def dense_worst(result, path, robot) -> float:
    limits = effective_limits(robot, result.settings)
    _, r = sample_ratios(result.trajectory, limits, defaults.VERIFY_SAMPLE_TIME, result.jump_intervals)
    return max(float(np.max(v)) for v in r.values())


def search_case(robot, torque, seed, n_wp) -> dict:
    """One case's path, toppra solver, T* (Richardson from both tools) and both tools' searched grids
    (the smallest of GRIDS within ACCURACY of T*; None when none is)."""
    wp = np.random.default_rng(seed).uniform(-1.5, 1.5, size=(n_wp, 6))
    path = SplineJointPath.from_waypoints(wp)
    bare = PlanSettings(limits=same_limits(torque), verify="off")
    ours = lambda n, **kw: plan(path, robot, replace(bare, grid_points=n, **kw))  # noqa: E731
    tp = toppra_solver(robot, wp, torque)
    uniform = lambda n: np.linspace(0.0, 1.0, n)  # noqa: E731
    a, b = (ours(n).duration for n in T_STAR_POINTS)
    c, d = (tp(uniform(n)).duration for n in T_STAR_POINTS)
    t_ours, t_toppra = 2 * b - a, 2 * d - c
    t_star = 0.5 * (t_ours + t_toppra)
    within = lambda t: abs(t - t_star) <= ACCURACY * t_star  # noqa: E731
    return dict(path=path, ours=ours, tp=tp, uniform=uniform, t_ours=t_ours, t_toppra=t_toppra, t_star=t_star,
                n_ours=next((n for n in GRIDS if within(ours(n).duration)), None),
                n_tp=next((n for n in GRIDS if within(tp(uniform(n)).duration)), None))


def run_case(label, robot, torque, seed, n_wp, repeats):
    c = search_case(robot, torque, seed, n_wp)
    path, ours, tp, uniform, t_star, n_ours, n_tp = (c[k] for k in ("path", "ours", "tp", "uniform", "t_star",
                                                                   "n_ours", "n_tp"))
    default = plan(path, robot, PlanSettings(limits=same_limits(torque)))
    coarse = plan(path, robot, PlanSettings(limits=same_limits(torque), duration_tolerance=ACCURACY))
    verified = ours(n_ours, verify="certified")
    our_grid = make_grid(path, n_ours).theta
    fns = {"toppra own grid": lambda: tp(uniform(n_tp)), "toppra our grid": lambda: tp(our_grid),
           "ours bare": lambda: ours(n_ours), "ours verified": lambda: ours(n_ours, verify="certified"),
           "ours adaptive 0.1%": lambda: plan(path, robot, PlanSettings(limits=same_limits(torque),
                                                                        duration_tolerance=ACCURACY)),
           "ours default": lambda: plan(path, robot, PlanSettings(limits=same_limits(torque)))}
    if n_tp is None:
        del fns["toppra own grid"]
    times, cpu = interleaved(fns, repeats)
    row = dict(label=label, seed=seed, wp=n_wp, t_star=t_star, t_ours=c["t_ours"], t_toppra=c["t_toppra"],
               n_ours=n_ours, n_tp=n_tp, default_err=(default.duration - t_star) / t_star,
               default_est=default.duration_error_estimate / t_star, default_pts=default.grid_points,
               coarse_err=(coarse.duration - t_star) / t_star, dense=dense_worst(default, path, robot),
               torque_ratio=default.ratios.torque, verified_err=(verified.duration - t_star) / t_star,
               tighten=verified.tighten_iterations, toppra_same=tp(our_grid).duration - ours(n_ours).duration,
               certify_cost_cpu=cpu["ours verified"] / cpu["ours bare"],
               certify_cost_wall=times["ours verified"] / times["ours bare"], **times)
    return row


def direct_case(label, robot, torque, seed, n_wp, rounds=ROUNDS) -> dict:
    """Certification cost on the case's searched grid: bare and verified plan() alternately in a random
    order after WARMUP calls each; {"cpu": ratio of medians, "cpu_blocks": ratio per block, "wall": ...}."""
    c = search_case(robot, torque, seed, n_wp)
    n, path = c["n_ours"], c["path"]
    settings = {"bare": PlanSettings(limits=same_limits(torque), verify="off", grid_points=n),
                "verified": PlanSettings(limits=same_limits(torque), verify="certified", grid_points=n)}
    res = plan(path, robot, settings["verified"])
    for _ in range(WARMUP):
        for s in settings.values():
            plan(path, robot, s)
    load0 = os.getloadavg()[0]
    cpu, wall = {k: [] for k in settings}, {k: [] for k in settings}
    rng = random.Random(seed)
    for _ in range(rounds):
        order = list(settings)
        rng.shuffle(order)
        for k in order:
            t, p = time.perf_counter(), time.process_time()
            plan(path, robot, settings[k])
            cpu[k].append(time.process_time() - p)
            wall[k].append(time.perf_counter() - t)
    ratio = lambda v, a=0, b=None: (statistics.median(v["verified"][a:b])  # noqa: E731
                                    / statistics.median(v["bare"][a:b]))
    size = rounds // BLOCKS
    return dict(label=label, seed=seed, wp=n_wp, points=res.grid_points, n=n, tighten=res.tighten_iterations,
                bare_ms=1e3 * statistics.median(cpu["bare"]), verified_ms=1e3 * statistics.median(cpu["verified"]),
                cpu=ratio(cpu), wall=ratio(wall), cpu_blocks=[ratio(cpu, i * size, (i + 1) * size) for i in range(BLOCKS)],
                load=(load0, os.getloadavg()[0]), torque_ratio=res.ratios.torque)


def print_direct(r):
    b = r["cpu_blocks"]
    tr = "" if r["torque_ratio"] is None else f", certified torque ratio {r['torque_ratio']:.5f}"
    print(f"{r['label']:8s} seed {r['seed']:2d} wp {r['wp']:2d}: grid {r['n']} ({r['points']} points), CPU bare "
          f"{r['bare_ms']:.3f} ms, verified {r['verified_ms']:.3f} ms: verified / bare {r['cpu']:.3f}x (blocks of "
          f"{ROUNDS // BLOCKS} rounds {min(b):.3f}-{max(b):.3f}), wall {r['wall']:.3f}x; tighten {r['tighten']}{tr}; "
          f"load {r['load'][0]:.1f} -> {r['load'][1]:.1f}")


def summarize_direct(rows):
    cpu = [r["cpu"] for r in rows]
    blocks = [b for r in rows for b in r["cpu_blocks"]]
    print(f"\nverified / bare (CPU time, ratio of medians of {ROUNDS} interleaved rounds) over {len(rows)} cases: "
          f"median {statistics.median(cpu):.3f}x, cases {min(cpu):.3f}-{max(cpu):.3f}x, blocks of "
          f"{ROUNDS // BLOCKS} rounds {min(blocks):.3f}-{max(blocks):.3f}x (target 1.5x); wall "
          f"{statistics.median([r['wall'] for r in rows]):.3f}x")


def print_row(r):
    ms = lambda k: f"{1e3 * r[k]:8.2f}" if k in r else "     n/a"  # noqa: E731
    print(f"{r['label']:8s} seed {r['seed']:2d} wp {r['wp']:2d}: T* {r['t_star']:.6f} s (ours {r['t_ours']:.6f}, toppra "
          f"{r['t_toppra']:.6f}, agree {100 * (r['t_ours'] - r['t_toppra']) / r['t_star']:+.4f} %); grids ours "
          f"{r['n_ours']} toppra {r['n_tp']}; toppra on our grid {r['toppra_same']:+.1e} s from ours")
    print(f"    ms: toppra own {ms('toppra own grid')} | toppra our grid {ms('toppra our grid')} | ours bare "
          f"{ms('ours bare')} | verified {ms('ours verified')} (+{100 * r['verified_err']:.3f} %, tighten "
          f"{r['tighten']}) | adaptive 0.1% {ms('ours adaptive 0.1%')} ({100 * r['coarse_err']:+.3f} %) | default "
          f"{ms('ours default')}")
    tr = "" if r["torque_ratio"] is None else f", torque ratio {r['torque_ratio']:.5f}"
    print(f"    default: {r['default_pts']} points, {100 * r['default_err']:+.4f} % from T* (estimate "
          f"{100 * r['default_est']:.4f} %), dense 0.1 ms worst ratio {r['dense']:.5f}{tr}; certified / bare "
          f"(CPU time) {r['certify_cost_cpu']:.2f}")


#: The summary's speed-ups: (key, text, the timing of ours it divides toppra on its own grid by).
SPEEDUPS = (("verified", "verified", "ours verified"), ("bare", "bare", "ours bare"),
            ("adaptive", "adaptive 0.1%", "ours adaptive 0.1%"), ("default", "default", "ours default"))


def speedups(rows) -> dict:
    """{limit set or "all": {key: [speed-up per case]}}: toppra on its own grid / ours (SPEEDUPS), toppra on our
    grid / ours bare ("same") and toppra own grid / toppra our grid ("grid"), over the cases toppra solved."""
    out = {}
    for label in sorted({r["label"] for r in rows}) + ["all"]:
        sel = [r for r in rows if (label == "all" or r["label"] == label) and "toppra own grid" in r]
        if sel:
            out[label] = {key: [r["toppra own grid"] / r[name] for r in sel] for key, _, name in SPEEDUPS}
            out[label]["same"] = [r["toppra our grid"] / r["ours bare"] for r in sel]
            out[label]["grid"] = [r["toppra own grid"] / r["toppra our grid"] for r in sel]
    return out


def spread(vals, digits=1) -> str:
    return f"{statistics.median(vals):.{digits}f}x ({min(vals):.{digits}f}-{max(vals):.{digits}f})"


def summarize(rows):
    rng = lambda vals, digits=1: f"{spread(vals, digits):>7s}"  # noqa: E731
    print("\nspeed-up = toppra on its own grid / ours; median (min-max) over cases")
    for label, sp in speedups(rows).items():
        print(f"{label:8s} " + " | ".join(f"{text} {rng(sp[key])}" for key, text, _ in SPEEDUPS)
              + f" | same grid, solver only {rng(sp['same'])} | grid (toppra own / toppra ours) {rng(sp['grid'])}")
    for line in findings(rows):
        print(line)


def findings(rows) -> list[str]:
    """The certification's cost, the cases below the speed target, the default settings' accuracy."""
    out = []
    for key, what in (("certify_cost_cpu", "CPU time"), ("certify_cost_wall", "wall clock")):
        torque = [r[key] for r in rows if r["label"] != "vel+acc"]
        if torque:
            out.append(f"certification cost with torque (verified / bare on the same grid, {what}, ratio of medians): "
                       f"{spread(torque, 2)} (target 1.5x); vel+acc: "
                       f"{spread([r[key] for r in rows if r['label'] == 'vel+acc'] or [0], 2)}")
    for key, target in (("ours adaptive 0.1%", 3.0), ("ours verified", 3.0)):
        slow = [f"{r['label']} seed {r['seed']} wp {r['wp']} ({r['toppra own grid'] / r[key]:.1f}x)" for r in rows
                if "toppra own grid" in r and r["toppra own grid"] / r[key] < target]
        out.append(f"{key}: cases below {target:g}x: {', '.join(slow) or 'none'}")
    worst_err = max(abs(r["default_err"]) for r in rows)
    out.append(f"default settings: largest |error| {100 * worst_err:.4f} % of T* (target 0.05 %); every estimate "
               f"bounds its error: {all(abs(r['default_err']) <= r['default_est'] for r in rows)}; largest dense "
               f"ratio {max(r['dense'] for r in rows):.5f} (target 1.001)")
    binding = [r["torque_ratio"] for r in rows if r["label"] == "binding"]
    if binding:
        out.append(f"binding set: torque ratio {min(binding):.5f}-{max(binding):.5f}")
    return out


def speedup_table() -> Table:
    """The summary's result table, started before the measurement (its date and load at the start)."""
    return Table("Planner against toppra at equal accuracy (0.1 % of T*): speed-up = toppra's time / ours",
                  [("set", "limit set"), ("cases", "cases"), *((k, t) for k, t, _ in SPEEDUPS),
                   ("same", "same grid, solver only"), ("grid", "toppra own grid / our grid")])


def fill_speedups(table: Table, rows, seeds, repeats) -> Table:
    """One row per limit set (and all): speed-ups median (min-max) over cases; the findings as notes."""
    for label, sp in speedups(rows).items():
        table.add(set=label, cases=len(sp["bare"]), **{k: spread(v) for k, v in sp.items()})
    table.notes += [f"Random 6-joint clamped splines (seeds {', '.join(map(str, seeds))}; "
                    f"{', '.join(str(w) for w in sorted({r['wp'] for r in rows}))} waypoints) on the IRB140; "
                    f"wall-time medians of {repeats} interleaved repetitions per case, median (min-max) over cases. "
                    "toppra: ParametrizeConstAccel on the smallest grid within 0.1 % of T* (Richardson from both "
                    "tools); ours verified/bare: the same search; adaptive: duration_tolerance 0.1 %; default: the "
                    "default settings (adaptive 0.05 %, certified).", *findings(rows)]
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one seed per waypoint count, 3 repetitions")
    ap.add_argument("--sets", nargs="+", choices=list(robots()), help="limit sets (default: all three)")
    ap.add_argument("--waypoints", nargs="+", type=int, help=f"waypoint counts (default: {WAYPOINTS})")
    ap.add_argument("--seeds", nargs="+", type=int, help=f"seeds (default: {SEEDS}; --quick: 1)")
    ap.add_argument("--repeats", type=int, help="timed repetitions per case (default: 7; --quick: 3)")
    ap.add_argument("--json", type=Path, help="write the speed-up summary as JSON here (for benchmarks/results.py)")
    ap.add_argument("--direct", action="store_true", help="time only bare vs verified plan() on the searched "
                    f"grid, {ROUNDS} interleaved rounds per case (the certification's cost)")
    args = ap.parse_args()
    if args.json and args.direct:
        ap.error("--json writes the speed-up summary, which --direct does not measure")
    logging.disable(logging.WARNING)
    seeds, repeats = ((1,), 3) if args.quick else (SEEDS, 7)
    seeds, repeats = tuple(args.seeds or seeds), args.repeats or repeats
    table = speedup_table()
    print(f"load average at start: {os.getloadavg()} on {os.cpu_count()} cores")
    # both tools run with BLAS on one thread: OpenBLAS's second thread otherwise spins after a call and its CPU
    # time lands in whichever sub-millisecond call comes next (process CPU time counts every thread)
    with single_blas_thread():
        rows = []
        for label, (robot, torque) in robots().items():
            if args.sets and label not in args.sets:
                continue
            for n_wp in args.waypoints or WAYPOINTS:
                for seed in seeds:
                    if args.direct:
                        rows.append(direct_case(label, robot, torque, seed, n_wp))
                        print_direct(rows[-1])
                    else:
                        rows.append(run_case(label, robot, torque, seed, n_wp, repeats))
                        print_row(rows[-1])
    (summarize_direct if args.direct else summarize)(rows)
    print(f"load average at end: {os.getloadavg()}")
    if args.json:
        print(f"wrote {fill_speedups(table, rows, seeds, repeats).write(args.json)}")


if __name__ == "__main__":
    main()
