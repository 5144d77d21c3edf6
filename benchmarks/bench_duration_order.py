"""Order of convergence of the planned DURATION in the grid step: pathmotion's planner (fixed uniform grids) and its
peer toppra on the same joint paths and limits, toppra with both of its discretization schemes.

For each grid of N intervals the duration T(N) is computed, N doubling; the order is log2 of the ratio of successive
changes, |T(N) - T(N/2)| / |T(2N) - T(N)| (1: first order, 2: second order). Both planners discretize with a constant
path acceleration u per interval; the "interpolation" scheme (Pham & Pham 2018) imposes every limit at both ends of
the interval with that u: feasible everywhere up to O(step^2), but wherever the optimal u(theta) varies along a limit
its constant u must meet the tighter end, O(step) below the optimum, so the duration converges at first order. The
"collocation" scheme imposes the limits at the start only (not feasible at the end; its duration is not monotone).

    python benchmarks/bench_duration_order.py
"""

from __future__ import annotations

import logging
import os

import numpy as np

from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning import PlanSettings, plan
from pathmotion.robot import load_robot

ACC = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])  # rad/s^2, as tests/test_planning_grid.py
CASES = [(1, 7), (2, 12), (3, 4)]  # (seed, waypoints) of random clamped splines
INTERVALS = (200, 400, 800, 1600, 3200, 6400)


def _orders(durations: list[float]) -> np.ndarray:
    d = np.abs(np.diff(durations))
    return np.log2(d[:-1] / d[1:])


def _toppra(path, robot, n: int, scheme: int) -> float:
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    spline = toppra.SplineInterpolator(np.linspace(*path.domain, len(path.waypoints)), path.waypoints,
                                       bc_type="clamped")
    lim = robot.limits
    cons = [constraint.JointVelocityConstraint(np.vstack([-lim.velocity, lim.velocity]).T),
            constraint.JointAccelerationConstraint(np.vstack([-ACC, ACC]).T, discretization_scheme=scheme)]
    grid = np.linspace(*path.domain, n + 1)
    sd = algo.TOPPRA(cons, spline, gridpoints=grid, parametrizer="ParametrizeConstAccel").compute_parameterization(0, 0)[1]
    root = np.sqrt(np.maximum(sd, 0.0) ** 2)
    return float(np.sum(2.0 * np.diff(grid) / (root[:-1] + root[1:])))


def main() -> None:
    logging.disable(logging.WARNING)
    robot = load_robot("irb140")
    robot = robot.with_limits(__import__("dataclasses").replace(robot.limits, acceleration=ACC))
    print(f"load average {os.getloadavg()[0]:.2f}; intervals {INTERVALS}")
    print(f"{'case':>8} {'planner':>26}  orders of successive halvings")
    for seed, n in CASES:
        path = SplineJointPath.from_waypoints(np.random.default_rng(seed).uniform(-1.5, 1.5, (n, 6)))
        rows = {"pathmotion": [plan(path, robot, PlanSettings(grid_points=k + 1, verify="off")).duration
                               for k in INTERVALS],
                "toppra interpolation": [_toppra(path, robot, k, 1) for k in INTERVALS],
                "toppra collocation": [_toppra(path, robot, k, 0) for k in INTERVALS]}
        for name, durations in rows.items():
            print(f"{seed:>4}/{n:<3} {name:>26}  {np.array2string(_orders(durations), precision=2)}"
                  f"   T({INTERVALS[-1]}) = {durations[-1]:.7f} s")


if __name__ == "__main__":
    main()
