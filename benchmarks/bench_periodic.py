"""The periodic solve (planning/boundary.py): the laps' bound, checked, against the plain bisection it replaced.

Both run in the same process on the same closed paths and grids, interleaved round by round after one warm-up
of each: ``solve_periodic`` as shipped, and with ``_lap_bound`` switched off (it then returns no bound, so the
bisection runs from the point-wise bound, the earlier code path). Cases: a 0.15 m x 0.2 m square with 3 mm G2
blends at its four corners (the closing one too), the thesis' horizontal circle, the circle with the vertical
circle, and ``--polygons`` random closed polygons in the IRB140's workspace (seeded; 3-5 corners, 2 mm G2
blends; a polygon whose blend does not fit is skipped), each with and without torque limits, the planner's
default adaptive grid. Printed per case: the backward/forward sweeps per plan, the median plan time of each
with its range, the ratio of the medians, and the relative difference of the durations; then the median ratio
over the cases with its range, and the machine's load average before and after.

Run: ``.venv/bin/python benchmarks/bench_periodic.py`` (about a minute); ``--repeat`` rounds per case.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from pathmotion.api import split_first_segment
from pathmotion.lift.constraint import lift
from pathmotion.geometry import FixedOrientation, Line, TaskPath, circle_with_vertical_circle, horizontal_circle
from pathmotion.geometry import with_blends
from pathmotion.planning import PlanSettings, boundary, plan
from pathmotion.robot import load_robot


def _polygon(robot, points: np.ndarray, tolerance: float):
    """A closed polygon through ``points`` (N, 3) [m], every corner (the closing one too) G2-blended."""
    task = TaskPath(tuple(Line(points[i], points[(i + 1) % len(points)]) for i in range(len(points))),
                    FixedOrientation())
    task = split_first_segment(task, len(points) - 1)
    return lift(robot, with_blends(task, {k: ("g2", tolerance) for k in range(len(points))}), original=task)


def cases(robot, polygons: int, seed: int) -> dict:
    out = {"square 3 mm": _polygon(robot, np.array([[0.45, -0.1, 0.5], [0.6, -0.1, 0.5], [0.6, 0.1, 0.5],
                                                    [0.45, 0.1, 0.5]]), 0.003),
           "thesis circle": lift(robot, horizontal_circle()),
           "circle + vertical circle": lift(robot, circle_with_vertical_circle())}
    rng = np.random.default_rng(seed)
    for k in range(polygons):
        centre = np.array([0.5, 0.0, 0.5]) + rng.uniform(-0.05, 0.05, 3)
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, int(rng.integers(3, 6))))
        radius = rng.uniform(0.05, 0.12, len(angles))
        points = centre + np.stack([radius * np.cos(angles), radius * np.sin(angles),
                                    rng.uniform(-0.03, 0.03, len(angles))], axis=1)
        try:
            out[f"polygon {k} ({len(points)} corners)"] = _polygon(robot, points, 0.002)
        except Exception as exc:  # a blend that does not fit, a point out of reach: not this benchmark's subject
            print(f"polygon {k}: skipped ({type(exc).__name__})")
    return out


class _Counted:
    """controllable_sets / reachable_sets of planning.boundary, counted."""

    def __init__(self):
        self.calls = 0
        self.backward, self.forward = boundary.controllable_sets, boundary.reachable_sets

    def __enter__(self):
        def backward(*a, **k):
            self.calls += 1
            return self.backward(*a, **k)

        def forward(*a, **k):
            self.calls += 1
            return self.forward(*a, **k)

        boundary.controllable_sets, boundary.reachable_sets = backward, forward
        return self

    def __exit__(self, *exc):
        boundary.controllable_sets, boundary.reachable_sets = self.backward, self.forward


def _no_bound(problem, top):
    return np.inf, np.inf


def run(path, robot, settings, laps: bool):
    shipped = boundary._lap_bound
    boundary._lap_bound = shipped if laps else _no_bound
    try:
        with _Counted() as counted:
            t = time.perf_counter()
            result = plan(path, robot, settings)
            return time.perf_counter() - t, counted.calls, result.profile.duration
    finally:
        boundary._lap_bound = shipped


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="interleaved rounds per case")
    parser.add_argument("--polygons", type=int, default=6, help="random closed polygons")
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    robot = load_robot("irb140")
    load_before = os.getloadavg()
    ratios = []
    for name, path in cases(robot, args.polygons, args.seed).items():
        for torque in (False, True):
            settings = PlanSettings(periodic=True, limits={"use_torque": torque}, verify=False, baselines=False)
            times = {True: [], False: []}
            info = {laps: run(path, robot, settings, laps) for laps in (True, False)}  # warm-up
            for _ in range(args.repeat):
                for laps in (False, True):
                    times[laps].append(run(path, robot, settings, laps)[0])
            bis, lap = np.array(times[False]), np.array(times[True])
            ratio = float(np.median(bis) / np.median(lap))
            ratios.append(ratio)
            print(f"{name:26s} {'torque' if torque else 'vel+acc':7s}  sweeps {info[False][1]:4d} -> {info[True][1]:4d}  "
                  f"bisection {1e3 * np.median(bis):7.1f} ms [{1e3 * bis.min():.1f}, {1e3 * bis.max():.1f}]  "
                  f"laps {1e3 * np.median(lap):7.1f} ms [{1e3 * lap.min():.1f}, {1e3 * lap.max():.1f}]  "
                  f"ratio {ratio:5.2f}  duration {info[True][2]:.9f} s (rel. diff {info[True][2] / info[False][2] - 1:+.1e})")
    r = np.array(ratios)
    print(f"plan time, bisection / laps: median {np.median(r):.2f}x [{r.min():.2f}, {r.max():.2f}] over {len(r)} cases; "
          f"load average {load_before[0]:.2f} before, {os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()
