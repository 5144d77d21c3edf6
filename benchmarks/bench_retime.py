"""Benchmark: the re-timer (planning/retime.py), timing and optimality.

Case: a random 6-joint clamped cubic spline through WAYPOINTS waypoints (numpy.random.default_rng(SEED)
.uniform(-1.5, 1.5)) on the IRB140 with its velocity and torque limits and accelerations ACC:
  second order  planned on a fixed grid of GRID_2 points (certified); the states lie in the first
                STATE_SPAN of the path, so every remaining grid has >= 1,000 points;
  jerk          the same limits plus joint jerk JERK_FACTOR x ACC, planned on GRID_3 points.

States: theta uniform; theta_dot a uniform fraction in [0, 1) of the largest savable speed there
(Retimer.max_speed: above and below the plan's profile); theta_ddot uniform in [-3, 3].

Timing: WARMUP calls, then every timed call from every state, interleaved in a random order: second order
``remaining``, ``stop`` and, as the peer, toppra from the same speed on the same remaining grid (every
PEER_EVERY-th state); jerk ``remaining`` (the compiled pass, the sequential LP where it gives no answer), the
compiled pass alone, the sequential-LP reference; ``stop``, the compiled stop alone and the LP reference
stop. Wall time (perf_counter), the process's and the calling thread's CPU time per call; p50, p99 and the
worst. Machine load (os.getloadavg) before and after.
The machine is shared: the CPU times are what a call costs, the wall time's tail is waiting for a core.

Optimality:
  remaining vs an offline plan of the same limits on the path from the state's theta (the planner with
  start = theta_dot on the tail of the path, GRID_2 points on it), and vs toppra (ParametrizeConstAccel,
  sd_start = theta_dot, the same limits, on the remaining grid itself); relative duration differences. The
  re-timer keeps the state's theta_ddot on its first interval, the references choose their start
  acceleration: it is given the offline plan's (and, as a separate row, the cost of a random theta_ddot).
  Jerk: vs the offline jerk plan from the same speed, re-timed from that plan's own start acceleration, and
  the compiled pass vs the sequential-LP reference from that same state; the compiled stop's distance vs the
  LP reference stop's from that state.
  stop vs the shortest stop distance from an independent computation: a forward integration in theta
  (STOP_STEPS steps) at the largest deceleration allowed by the joint velocity, acceleration and torque
  limits, the torque from Pinocchio's RNEA at each step.

    python benchmarks/bench_retime.py                   # full run: timing and optimality
    python benchmarks/bench_retime.py --quick           # fewer states
    python benchmarks/bench_retime.py --part timing --json benchmarks/results/retime_timing.json
    python benchmarks/bench_retime.py --part optimality --json benchmarks/results/retime_optimality.json
(--json writes the part's table for benchmarks/results.py; --states N2 N3 sets the second-order and jerk state
counts of the part.)
"""

from __future__ import annotations

import argparse
import os
import random
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from pathmotion.control.threads import single_blas_thread
from pathmotion.errors import PathmotionError, StateInfeasibleError
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, Retimer, plan
from pathmotion.robot import load_robot
from result_json import Table

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
SEED, WAYPOINTS = 1, 5
GRID_2, GRID_3 = 1100, 120
STATE_SPAN = 0.08
JERK_FACTOR = 10.0
WARMUP = 50
STOP_STEPS = 4000


def case(jerk: bool):
    irb = load_robot("irb140")
    robot = irb.with_limits(replace(irb.limits, acceleration=ACC))
    wp = np.random.default_rng(SEED).uniform(-1.5, 1.5, size=(WAYPOINTS, 6))
    path = SplineJointPath.from_waypoints(wp)
    limits = {"use_torque": True, **({"use_jerk": True, "jerk": tuple(JERK_FACTOR * ACC)} if jerk else {})}
    settings = PlanSettings(grid_points=GRID_3 if jerk else GRID_2, limits=limits)
    return robot, wp, path, plan(path, robot, settings)


def states(rt: Retimer, n: int, span: float, rng, below_plan: bool) -> list:
    """``n`` states in the first ``span`` of the path: theta_dot up to the largest savable speed (or, with
    ``below_plan``, up to the plan's own speed there: jerk limits leave far fewer fast states savable)."""
    out = []
    for _ in range(n):
        theta = rng.uniform(0.0, span) * rt.grid[-1]
        top = float(rt.plan.profile.theta_dot_at(theta)) if below_plan else rt.max_speed(theta)
        out.append((theta, rng.uniform(0.0, 1.0) * top, rng.uniform(-3.0, 3.0)))
    return out


def percentiles(v) -> dict:
    v = 1e3 * np.asarray(v)
    return dict(p50_ms=float(np.percentile(v, 50)), p99_ms=float(np.percentile(v, 99)), worst_ms=float(v.max()))


def _calls(rt: Retimer, robot, wp, jerk: bool) -> dict:
    """The timed calls of a case by name: fn(theta, theta_dot, theta_ddot). Second order: the re-timer and toppra
    from the same speed on the re-timer's remaining grid (the peer: what an offline TOPP costs from that state);
    jerk: the re-timer's answer (the compiled pass, the LP where it gives none), the compiled pass alone and the
    sequential LP reference from the same state; the same three for the stop."""
    if jerk:
        return {"remaining": rt.remaining, "remaining: compiled pass": rt.compiled_remaining,
                "remaining: LP reference": lambda t, v, a: rt.remaining(t, v, a, reference=True), "stop": rt.stop,
                "stop: compiled": rt.compiled_stop,
                "stop: LP reference": lambda t, v, a: rt.stop(t, v, a, reference=True)}
    return {"remaining": rt.remaining, "stop": rt.stop,
            "toppra from the same speed": lambda t, v, a: toppra_duration(robot, wp, _remaining_grid(rt, t), v)}


def _remaining_grid(rt: Retimer, theta: float) -> np.ndarray:
    """The re-timer's remaining grid from theta (theta, then the plan's points after it)."""
    return np.concatenate([[theta], rt.grid[np.searchsorted(rt.grid, theta, side="right"):]])


#: Second order: toppra is timed from every this-many-th state (it takes ~100 times longer per call).
PEER_EVERY = 20


def timing(rt: Retimer, sts: list, calls: dict) -> dict:
    """Interleaved calls of every function in ``calls`` from every state (the second-order toppra peer from every
    PEER_EVERY-th) after WARMUP calls, in a random order: wall time, the process's CPU time and the calling
    thread's CPU time per call."""
    for theta, v, a in sts[:WARMUP]:
        for fn in calls.values():
            try:
                fn(theta, v, a)
            except PathmotionError:
                pass
    order = [(name, s) for name in calls for k, s in enumerate(sts)
             if (not name.startswith("stop") or s[1] > 0) and (not name.startswith("toppra") or k % PEER_EVERY == 0)]
    random.Random(0).shuffle(order)
    out = {name: {"wall": [], "cpu": [], "thread": [], "refused": 0, "none": 0} for name in calls}
    for name, (theta, v, a) in order:
        rec = out[name]
        t, c, th = time.perf_counter(), time.process_time(), time.thread_time()
        try:
            got = calls[name](theta, v, a)
            rec["none"] += got is None
        except StateInfeasibleError:  # timed too: the error is the answer for that state
            rec["refused"] += 1
        rec["wall"].append(time.perf_counter() - t)
        rec["cpu"].append(time.process_time() - c)
        rec["thread"].append(time.thread_time() - th)
    return {name: dict(wall=percentiles(r["wall"]), cpu=percentiles(r["cpu"]), thread=percentiles(r["thread"]),
                       calls=len(r["wall"]), unsaveable=r["refused"], no_answer=r["none"]) for name, r in out.items()}


def toppra_duration(robot, wp, grid, v0) -> float:
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    lim = robot.limits
    model, data = robot.model, robot.model.createData()
    cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T),
            constraint.JointAccelerationConstraint(np.vstack([-lim.acceleration, lim.acceleration]).T),
            constraint.JointTorqueConstraint(lambda q, v, a: pin.rnea(model, data, q, v, a),
                                             np.vstack([-lim.torque, lim.torque]).T, np.zeros(robot.n),
                                             discretization_scheme=constraint.DiscretizationType.Interpolation)]
    class Tail(ta.SplineInterpolator):  # the same spline, on the remaining part [grid[0], grid[-1]]
        @property
        def path_interval(self):
            return np.array([grid[0], grid[-1]])

    path = Tail(np.linspace(0, 1, len(wp)), wp, bc_type="clamped")
    traj = algo.TOPPRA(cons, path, gridpoints=grid, parametrizer="ParametrizeConstAccel").compute_trajectory(
        sd_start=v0, sd_end=0.0)
    return float(traj.duration) if traj is not None else float("nan")


def shortest_stop(path, robot, theta0, v0, steps_hint) -> float:
    """Stop distance at the largest deceleration the limits allow, by forward Euler in theta (independent
    of the planner's rows: the torque from RNEA at each step)."""
    model, data = robot.model, robot.model.createData()
    lim = robot.limits
    x, theta, h = v0 * v0, theta0, steps_hint / STOP_STEPS
    end = path.domain[1]
    while x > 0.0 and theta < end:
        q, d1, d2 = path.evaluate(theta)
        g = pin.rnea(model, data, q, np.zeros(6), np.zeros(6))
        alpha = pin.rnea(model, data, q, np.zeros(6), d1) - g
        beta = pin.rnea(model, data, q, d1, d2) - g
        lo = -np.inf
        zero = np.zeros(6)
        for a, b, c, top in ((d1, d2 * x, zero, lim.acceleration), (alpha, beta * x, g, lim.torque)):
            for j in range(6):  # -top <= a u + b + c <= top: the least u allowed
                if a[j] > 0:
                    lo = max(lo, (-top[j] - c[j] - b[j]) / a[j])
                elif a[j] < 0:
                    lo = max(lo, (top[j] - c[j] - b[j]) / a[j])
        step = min(h, x / (-2.0 * lo)) if lo < 0 else h
        x, theta = x + 2.0 * lo * step, theta + step
    return theta - theta0


#: Jerk case: shares of the offline plan's start acceleration tried in turn (it lies on the boundary of the
#: jerk-limited set, within the plans' limit tolerance, where the re-timer's exact rows can refuse it).
ACCELERATION_SHARES = (1.0, 0.99, 0.95)


def _from_offline_acceleration(rt, theta, v, u0):
    for share in ACCELERATION_SHARES:
        try:
            return rt.remaining(theta, v, share * u0), share * u0, share
        except StateInfeasibleError:
            continue
    return None, None, None


def optimality(robot, wp, path, res, rt, sts, jerk: bool) -> dict:
    rows = []
    for theta, v, a in sts:
        tail = replace(path, domain=(theta, path.domain[1]))
        try:
            if jerk:  # from the offline plan's own start acceleration (the planner cannot be given one)
                off = plan(tail, robot, replace(res.settings, start=v, grid_points=GRID_3))
                ours, a, share = _from_offline_acceleration(rt, theta, v, float(off.profile.u_nodes[0]))
                if ours is None:
                    continue
                row = dict(theta=theta, theta_dot=v, ours=ours.duration, offline=off.duration, acceleration_share=share)
                fast = rt.compiled_remaining(theta, v, a)
                row.update(pass_duration=np.nan if fast is None else fast.duration,
                           lp_reference=rt.remaining(theta, v, a, reference=True).duration)
                if fast is not None:
                    row["pass_ratio"] = rt.certify(fast).max_ratio
            else:
                # from the offline plan's own start acceleration: the references choose theirs, the re-timer
                # keeps the state's on its first interval
                off = plan(tail, robot, replace(res.settings, start=v, grid_points=GRID_2))
                ours = rt.remaining(theta, v, float(off.profile.u[0]))
                row = dict(theta=theta, theta_dot=v, ours=ours.duration, offline=off.duration,
                           toppra=toppra_duration(robot, wp, ours.grid, v),
                           own_acceleration=rt.remaining(theta, v, a).duration)
            row["ratio"] = rt.certify(ours).max_ratio
            if v > 0 and jerk:  # no independent jerk-limited reference: the second-order stop bounds it below
                s = rt.stop(theta, v, a)
                row.update(stop=float(s.grid[-1] - theta), stop_ratio=rt.certify(s).max_ratio,
                           second_order_stop=float(rt.stop(theta, v, a, second_order=True).grid[-1] - theta))
                row.update(_compiled_stop_row(rt, theta, v, a))
            elif v > 0:
                s = rt.stop(theta, v, a)
                row.update(stop=float(s.grid[-1] - theta),
                           shortest=shortest_stop(path, robot, theta, v, s.grid[-1] - theta),
                           stop_ratio=rt.certify(s).max_ratio)
        except StateInfeasibleError:
            continue
        rows.append(row)
    rel = lambda k: [(r["ours"] - r[k]) / r[k] for r in rows if k in r and np.isfinite(r[k])]  # noqa: E731
    stop = [(r["stop"] - r["shortest"]) / r["shortest"] for r in rows if "shortest" in r]
    above = [(r["stop"] - r["second_order_stop"]) / r["second_order_stop"] for r in rows if "second_order_stop" in r]
    own = [(r["own_acceleration"] - r["ours"]) / r["ours"] for r in rows if "own_acceleration" in r]
    pass_lp = [(r["pass_duration"] - r["lp_reference"]) / r["lp_reference"] for r in rows
               if np.isfinite(r.get("pass_duration", np.nan))]
    compiled = [(r["compiled_stop"] - r["lp_stop"]) / r["lp_stop"] for r in rows if "compiled_stop" in r]
    summary = dict(vs_offline=_spread(rel("offline")), compiled_stop_vs_lp=_spread(compiled),
                   pass_vs_lp=_spread(pass_lp), stop_vs_shortest=_spread(stop),
                   state_acceleration=_spread(own),
                   stop_vs_second_order=_spread(above),
                   worst_certified_ratio=max((max(r["ratio"], r.get("stop_ratio", 0.0), r.get("pass_ratio", 0.0))
                                              for r in rows), default=None),
                   states=len(sts), saveable=len(rows))
    if not jerk:
        summary["vs_toppra"] = _spread(rel("toppra"))
    return dict(summary=summary, rows=rows)


def _compiled_stop_row(rt, theta, v, a) -> dict:
    """The compiled stop's distance and certified ratio and the LP reference stop's distance from the state (both
    where both answer)."""
    fast = rt.compiled_stop(theta, v, a)
    try:
        lp = rt.stop(theta, v, a, reference=True)
    except StateInfeasibleError:
        return {}
    if fast is None:
        return {}
    return dict(compiled_stop=float(fast.grid[-1] - theta), lp_stop=float(lp.grid[-1] - theta),
                stop_ratio=max(rt.certify(fast).max_ratio, rt.certify(lp).max_ratio))


def _spread(v) -> dict:
    v = np.asarray(v, float)
    return dict(median=float(np.median(v)), min=float(v.min()), max=float(v.max()), worst_abs=float(np.abs(v).max()),
                n=int(v.size)) if v.size else {}


def run(label: str, jerk: bool, n_time: int, n_opt: int) -> dict:
    """One case: the timing of ``n_time`` states and the optimality of ``n_opt`` states (0: that part skipped)."""
    robot, wp, path, res = case(jerk)
    t = time.perf_counter()
    rt = Retimer(res)
    build = time.perf_counter() - t
    rng = np.random.default_rng(7)
    out = dict(label=label, plan_points=len(res.profile.grid), plan_duration=res.duration, build_s=build)
    if n_time:
        sts = states(rt, n_time, STATE_SPAN, rng, jerk)
        remaining_points = [len(res.profile.grid) - int(np.searchsorted(res.profile.grid, s[0])) + 1 for s in sts]
        out.update(remaining_points_min=int(min(remaining_points)), load_before=os.getloadavg())
        out["timing"] = timing(rt, sts, _calls(rt, robot, wp, jerk))
        out["load_after"] = os.getloadavg()
    if n_opt:
        out["optimality"] = optimality(robot, wp, path, res, rt, states(rt, n_opt, 0.9, rng, jerk), jerk)
    return out


def report(r: dict) -> None:
    print(f"\n== {r['label']}: plan {r['plan_points']} points, {r['plan_duration']:.4f} s; Retimer built in "
          f"{1e3 * r['build_s']:.1f} ms")
    if "timing" in r:
        print(f"   remaining grids >= {r['remaining_points_min']} points; load before {r['load_before'][0]:.2f}, "
              f"after {r['load_after'][0]:.2f} (1-min average, {os.cpu_count()} cores)")
        print("   call                          calls   wall / process CPU / thread CPU p50, p99, worst [ms]")
        for name, t in r["timing"].items():
            ms = lambda v: f"{v['p50_ms']:.3f} {v['p99_ms']:.3f} {v['worst_ms']:.3f}"  # noqa: E731
            print(f"   {name:28s} {t['calls']:6d}   {ms(t['wall'])} | {ms(t['cpu'])} | {ms(t['thread'])}   "
                  f"({t['unsaveable']} unsaveable, {t['no_answer']} without an answer)")
    if "optimality" in r:
        s = r["optimality"]["summary"]
        for key, text in COMPARISONS:
            if s.get(key):
                v = s[key]
                print(f"   {text:28s} median {100 * v['median']:+.3f} %, range [{100 * v['min']:+.3f}, "
                      f"{100 * v['max']:+.3f}] %, n = {v['n']}")
        print(f"   worst certified limit ratio of the re-timed profiles: {s['worst_certified_ratio']} "
              f"({s['saveable']} of {s['states']} states saveable)")


COMPARISONS = (("vs_offline", "remaining vs offline plan"), ("vs_toppra", "remaining vs toppra"),
               ("pass_vs_lp", "compiled pass vs LP reference"),
               ("state_acceleration", "remaining keeping a random theta_ddot vs keeping the offline one"),
               ("stop_vs_shortest", "stop vs shortest distance"),
               ("compiled_stop_vs_lp", "compiled stop vs LP reference stop"),
               ("stop_vs_second_order", "stop vs second-order stop"))


def timing_table() -> Table:
    """The timing part's table, started before the measurement (its date and load at the start)."""
    return Table("The re-timer: time per call from a measured state", [
        ("case", "case"), ("plan", "plan points / duration [s]"), ("build_ms", "Retimer built [ms]"),
        ("remaining_points", "remaining grids >= points"), ("call", "call"), ("calls", "calls"),
        ("wall", "wall p50 / p99 / worst [ms]"), ("cpu", "process CPU p50 / p99 / worst [ms]"),
        ("thread", "thread CPU p50 / p99 / worst [ms]"), ("unsaveable", "refused / no answer"),
        ("load", "load before / after")])


def fill_timing(table: Table, results: list) -> Table:
    """One row per case and call: p50, p99 and worst of wall, process CPU and thread CPU time [ms]."""
    ms = lambda v: f"{v['p50_ms']:.3f} / {v['p99_ms']:.3f} / {v['worst_ms']:.3f}"  # noqa: E731
    for r in results:
        for name, t in r["timing"].items():
            table.add(case=r["label"], plan=f"{r['plan_points']} / {r['plan_duration']:.4f}",
                      build_ms=round(1e3 * r["build_s"], 1), remaining_points=r["remaining_points_min"], call=name,
                      calls=t["calls"], wall=ms(t["wall"]), cpu=ms(t["cpu"]), thread=ms(t["thread"]),
                      unsaveable=f"{t['unsaveable']} / {t['no_answer']}",
                      load=f"{r['load_before'][0]:.2f} / {r['load_after'][0]:.2f}")
    table.notes.append("States in the first 8 % of a random 6-joint spline on the IRB140, every call of a case "
                       "interleaved in a random order after a warm-up (the second-order toppra peer from every "
                       f"{PEER_EVERY}th state). CPU: the process's and the calling thread's CPU time per call; the "
                       "wall time's tail on this shared machine is mostly waiting for a core (the load column). Jerk: "
                       "'remaining' is what the re-timer answers (the compiled pass; the sequential LP where the pass "
                       "gives none: 'no answer' of the pass row), the LP reference is the sequential LP from the same "
                       "state; 'refused': StateInfeasibleError (timed too).")
    return table


def optimality_table() -> Table:
    """The optimality part's table, started before the measurement (its date and load at the start)."""
    return Table("The re-timer: optimality against independent references", [
        ("case", "case"), ("comparison", "comparison"), ("median", "median [%]"), ("range", "range [%]"),
        ("n", "states"), ("ratio", "worst certified limit ratio"), ("saveable", "saveable / states")])


def fill_optimality(table: Table, results: list) -> Table:
    """One row per case and comparison: the relative difference's median and range [%]."""
    for r in results:
        s = r["optimality"]["summary"]
        for key, text in COMPARISONS:
            if s.get(key):
                v = s[key]
                table.add(case=r["label"], comparison=text, median=f"{100 * v['median']:+.4f}",
                          range=f"{100 * v['min']:+.4f} to {100 * v['max']:+.4f}", n=v["n"],
                          ratio=round(s["worst_certified_ratio"], 6), saveable=f"{s['saveable']} / {s['states']}")
    table.notes += ["Relative difference of the re-timer's duration (remaining) or stop distance (stop) from the "
                    "reference: the offline plan of the same limits from the same state, toppra "
                    "(ParametrizeConstAccel, same limits, same grid), the shortest stop by forward integration at "
                    "the largest deceleration the limits allow (torque from Pinocchio's RNEA); for the jerk case "
                    "the second-order stop bounds the stop below. The worst certified limit ratio covers every "
                    "re-timed profile of the case."]
    return table


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer states")
    ap.add_argument("--part", choices=("timing", "optimality"), help="measure only this part (default: both)")
    ap.add_argument("--states", nargs=2, type=int, metavar=("N2", "N3"),
                    help="states of the part for the second-order and the jerk case")
    ap.add_argument("--json", type=Path, help="write the part's table as JSON here (for benchmarks/results.py)")
    args = ap.parse_args(argv)
    if args.json and not args.part:
        ap.error("--json writes one table: name the part with --part timing or --part optimality")
    if args.states and not args.part:
        ap.error("--states sets the states of one part: name it with --part")
    n2, n3, o2, o3 = (300, 10, 6, 3) if args.quick else (3000, 40, 20, 30)
    if args.part == "timing":
        n2, n3, o2, o3 = (*(args.states or (n2, n3)), 0, 0)
    elif args.part == "optimality":
        n2, n3, o2, o3 = (0, 0, *(args.states or (o2, o3)))
    table = {"timing": timing_table, "optimality": optimality_table}[args.part]() if args.json else None
    with single_blas_thread():
        results = [run("second order (velocity, acceleration, torque)", False, n2, o2),
                   run(f"jerk {JERK_FACTOR:g} x acceleration (plus the second-order limits)", True, n3, o3)]
    for r in results:
        report(r)
    if args.json:
        fill = fill_timing if args.part == "timing" else fill_optimality
        print(f"\nwrote {fill(table, results).write(args.json)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
