"""What joint torque limits cost at a corner: the free-shape minimum-time reference with and
without them (``free_shape_optimum(..., torque=True)``), next to pathmotion's time-optimal stop with
and without them, on the 90 degree turn (0.1 m + 0.2 m, rest to rest).

The arm: the IRB140 with a payload (default its rated 6 kg, 0.1 m below the flange, 0.01 kg m^2 about
each axis) and drives at a fraction of the shipped torque limits (``--drives``, default 0.35: with the
shipped limits torque does not bind on this turn, the acceleration limits do). Prints per tolerance:
durations [s] (Richardson extrapolation over the meshes, its convergence error), the dense torque
ratio of the finest mesh (Pinocchio RNEA, 17 points per interval), IPOPT status and CPU time. One NLP
at a time.

Run: .venv/bin/python benchmarks/bench_free_shape_torque.py [--deltas 0,0.002] [--meshes 25,50,100]
     [--drives 0.35] [--payload 6]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from pathmotion.robot import load_robot
from pathmotion.robot.model import Payload
from pathmotion.study import free_shape as fs

TURN = np.array([(0.4, -0.1, 0.45), (0.5, -0.1, 0.45), (0.5, 0.1, 0.45)])


def arm(drives: float, payload: float):
    robot = load_robot("irb140").with_payload(Payload(payload, (0.0, 0.0, 0.1), np.eye(3) * 0.01))
    return robot.with_limits(dataclasses.replace(robot.limits, torque=robot.limits.torque * drives))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deltas", default="0,0.002", help="tube radii [m], comma-separated")
    ap.add_argument("--meshes", default="25,50,100", help="intervals per mesh, each twice the previous")
    ap.add_argument("--drives", type=float, default=0.35, help="fraction of the shipped torque limits")
    ap.add_argument("--payload", type=float, default=6.0, help="payload mass [kg]")
    args = ap.parse_args()
    robot = arm(args.drives, args.payload)
    meshes = tuple(int(m) for m in args.meshes.split(","))
    line = fs.Polyline(TURN)
    print(f"IRB140, payload {args.payload:g} kg, drives x {args.drives:g}, meshes {meshes}")
    for torque in (False, True):
        print(f"stop at the corner, torque {'on ' if torque else 'off'}: "
              f"{fs.stop_plan(robot, line, torque=torque)[1].profile.duration:.4f} s")
    print("delta [mm] | torque | duration [s] | conv. error [ms] | meshes [s] | max torque ratio | status | CPU [s]")
    for delta in (float(d) for d in args.deltas.split(",")):
        for torque in (False, True):
            t0 = time.process_time()
            opt = fs.free_shape_optimum(robot, TURN, delta, meshes=meshes, torque=torque)
            cpu = time.process_time() - t0
            ratio = opt.solutions[-1].verification["max_torque_ratio"]
            print(f"{delta * 1e3:g} | {'on' if torque else 'off'} | {opt.duration:.4f} | {opt.convergence_error * 1e3:.2f} | "
                  f"{', '.join(f'{d:.4f}' for d in opt.durations)} | {ratio:.4f} | {opt.status} | {cpu:.0f}", flush=True)


if __name__ == "__main__":
    main()
