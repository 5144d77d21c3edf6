"""Benchmark: pathmotion's time-optimal planner against toppra at equal accuracy.

Input (identical for both): a 6-joint clamped cubic spline through 5 waypoints drawn with
numpy.random.default_rng(42).uniform(-1.5, 1.5, size=(5, 6)), knots evenly spaced on [0, 1];
IRB140 velocity limits; accelerations (10, 10, 12, 20, 20, 25) rad/s^2; a second run adds the
IRB140 torque limits (toppra: JointTorqueConstraint with Pinocchio's RNEA as inv_dyn).

Method: the converged optimum T* is estimated by refinement (our planner on very fine grids, with
first-order Richardson extrapolation; toppra's value on its finest grid is printed next to it).
Each side then gets the smallest grid of a fixed sequence whose duration is within 0.1 % of T*,
and is timed there (median of several runs, after a warm-up run so numba compilation and caches
are excluded). toppra uses its own default discretization per constraint (interpolation for
acceleration, collocation for torque) and the "ParametrizeConstAccel" output, whose duration is
that of its discretized optimum; the acceleration excess of its default "ParametrizeSpline" output
is printed too. Our timing is given for the bare solve (verify=False, like toppra) and for the full
plan with the verify-and-tighten loop. Run: python benchmarks/bench_planner_vs_toppra.py
"""

from __future__ import annotations

import logging
import statistics
import time
from dataclasses import replace

import numpy as np
import pinocchio as pin

from pathmotion import defaults
from pathmotion.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, plan
from pathmotion.robot import load_robot

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
OUR_GRIDS = [50, 75, 100, 150, 200, 300, 400, 600, 800, 1000, 1500, 2000, 3000, 4000, 6000, 8000]
TOPPRA_GRIDS = [100, 200, 400, 800, 1600, 3200, 6400, 12800, 25600, 51200]
REPEATS = 5
ACCURACY = 1e-3


def median_time(fn, repeats=REPEATS):
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def toppra_setup(robot, wp, torque):
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    lim = robot.limits
    path = ta.SplineInterpolator(np.linspace(0, 1, len(wp)), wp, bc_type="clamped")

    def make(n, parametrizer="ParametrizeConstAccel"):
        cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T),
                constraint.JointAccelerationConstraint(np.vstack([-ACC, ACC]).T)]
        if torque:
            model, data = robot.model, robot.model.createData()
            cons.append(constraint.JointTorqueConstraint(
                lambda q, v, a: pin.rnea(model, data, q, v, a), np.vstack([-lim.torque, lim.torque]).T, np.zeros(6)))
        inst = algo.TOPPRA(cons, path, gridpoints=np.linspace(0, 1, n), parametrizer=parametrizer)
        return inst.compute_trajectory()

    return make


def toppra_acc_excess(jt, dt=defaults.VERIFY_SAMPLE_TIME):
    t = np.arange(0.0, jt.duration, dt)
    return float(np.max(np.abs(jt(t, 2)) / ACC))


def run(robot, path, wp, torque):
    label = "with torque limits" if torque else "velocity + acceleration limits"
    print(f"\n=== {label} ===")
    base = PlanSettings(torque=torque, baselines=False, verify=False)
    ours = lambda n, **kw: plan(path, robot, replace(base, grid_points=n, **kw))  # noqa: E731
    t16, t32 = ours(16000).duration, ours(32000).duration
    t_star = 2.0 * t32 - t16
    make = toppra_setup(robot, wp, torque)
    t_toppra_fine = make(TOPPRA_GRIDS[-1]).duration
    print(f"converged optimum T* = {t_star:.6f} s (ours 16000 / 32000 points: {t16:.6f} / {t32:.6f} s, "
          f"Richardson); toppra at {TOPPRA_GRIDS[-1]} points: {t_toppra_fine:.6f} s")

    default = plan(path, robot, PlanSettings(torque=torque, baselines=False))
    print(f"ours at default settings ({defaults.GRID_POINTS} points + grading, verified): {default.duration:.6f} s, "
          f"{100 * (default.duration - t_star) / t_star:+.4f} % from T*; acceleration ratio on the "
          f"{defaults.VERIFY_SAMPLE_TIME * 1e3:g} ms resample {default.ratios.acceleration:.6f}"
          + (f", torque ratio {default.ratios.torque:.6f}" if torque else ""))

    n_ours = next(n for n in OUR_GRIDS if abs(ours(n).duration - t_star) / t_star < ACCURACY)
    n_toppra = next((n for n in TOPPRA_GRIDS if abs(make(n).duration - t_star) / t_star < ACCURACY), None)
    res = ours(n_ours)
    t_ours = median_time(lambda: ours(n_ours))
    t_ours_verified = median_time(lambda: ours(n_ours, verify=True))
    verified = ours(n_ours, verify=True)
    print(f"ours:   {n_ours:6d} points -> {res.duration:.6f} s ({100 * (res.duration - t_star) / t_star:+.4f} %), "
          f"solve {1e3 * t_ours:8.2f} ms (full plan with verify-and-tighten: {1e3 * t_ours_verified:.2f} ms, "
          f"acceleration ratio {verified.ratios.acceleration:.6f})")
    if n_toppra is None:
        print(f"toppra: not within {100 * ACCURACY:g} % of T* on any grid up to {TOPPRA_GRIDS[-1]} points")
        return
    jt = make(n_toppra)
    t_toppra = median_time(lambda: make(n_toppra), repeats=3 if n_toppra > 5000 else REPEATS)
    jt_spline = make(n_toppra, "ParametrizeSpline")
    print(f"toppra: {n_toppra:6d} points -> {jt.duration:.6f} s ({100 * (jt.duration - t_star) / t_star:+.4f} %), "
          f"solve {1e3 * t_toppra:8.2f} ms; acceleration ratio on the 0.1 ms resample: "
          f"{toppra_acc_excess(jt):.6f} (ConstAccel output), {toppra_acc_excess(jt_spline):.6f} (default spline output)")
    print(f"speed-up at equal accuracy ({100 * ACCURACY:g} %): {t_toppra / t_ours:.1f}x (bare solve), "
          f"{t_toppra / t_ours_verified:.1f}x (ours with verification)")
    grid = res.curves.grid  # same grid for both: isolates the solver speed from the grid choice
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    lim = robot.limits
    cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T),
            constraint.JointAccelerationConstraint(np.vstack([-ACC, ACC]).T)]
    if torque:
        model, data = robot.model, robot.model.createData()
        cons.append(constraint.JointTorqueConstraint(
            lambda q, v, a: pin.rnea(model, data, q, v, a), np.vstack([-lim.torque, lim.torque]).T, np.zeros(6),
            discretization_scheme=constraint.DiscretizationType.Interpolation))
    tpath = ta.SplineInterpolator(np.linspace(0, 1, len(wp)), wp, bc_type="clamped")
    same = lambda: algo.TOPPRA(cons, tpath, gridpoints=grid,  # noqa: E731
                               parametrizer="ParametrizeConstAccel").compute_trajectory()
    t_same = median_time(same)
    print(f"on our graded grid ({len(grid)} points, interpolation everywhere): toppra {same().duration:.6f} s in "
          f"{1e3 * t_same:.2f} ms vs ours {res.duration:.6f} s in {1e3 * t_ours:.2f} ms ({t_same / t_ours:.1f}x)")


def main():
    logging.disable(logging.WARNING)
    irb = load_robot("irb140")
    robot = irb.with_limits(replace(irb.limits, acceleration=ACC))
    wp = np.random.default_rng(42).uniform(-1.5, 1.5, size=(5, 6))
    path = SplineJointPath.from_waypoints(wp)
    print("pathmotion planner vs toppra: clamped spline, 5 random waypoints (seed 42), IRB140 limits")
    for torque in (False, True):
        run(robot, path, wp, torque)


if __name__ == "__main__":
    main()
