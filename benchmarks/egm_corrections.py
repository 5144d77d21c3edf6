"""The three corrections of ``pathmotion execute`` (none, shaping, orbital) through the virtual IRC5, rigid
and elastic gears, on shipped scenarios: path accuracy and cycle time of the arm's link side (the TCP that
moves), and the residual vibration after its stops (at the path's end, and after a stop along the path
requested at half the planned time). Lockstep EGM in one process, through the encoded messages.

    PYTHONPATH=. python benchmarks/egm_corrections.py [--scenarios circle_smooth,corner_g2,abb_cycle] [--json F]
        [--unknown-payload KG]   (the arm carries KG 0.1 m beyond the flange; the plan and the drives' model not)
"""

from __future__ import annotations

import argparse
import json
import time
from importlib import resources

import numpy as np

from pathmotion import api
from pathmotion.execution.drive_file import drive_file_for, load_drives
from pathmotion.execution.drives import VirtualArm
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess
from pathmotion.robot import Payload

MODES = ("none", "shaping", "orbital")


def run(setup, result, drives, mode, stop_at=None, payload=0.0):
    streamer = make_streamer(setup.robot, result, mode, drives)
    plant = setup.robot.with_payload(Payload(mass=payload, com=(0.0, 0.0, 0.1))) if payload > 0 else None
    arm = VirtualArm(setup.robot, drives, streamer.table.plan[0], plant_robot=plant)
    out = run_inprocess(streamer, arm, result.duration + 2.0, stop_at=stop_at)
    return arm_figures(setup.robot, out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="circle_smooth,corner_g2,abb_cycle")
    ap.add_argument("--json", default=None, help="write the rows to this JSON file")
    ap.add_argument("--unknown-payload", type=float, default=0.0, help="kg the arm carries unknown to the plan")
    args = ap.parse_args()
    rows = []
    print("| scenario | gears | correction | path accuracy [mm] | cycle [s] | cycle / planned | vibration after end [mm] "
          "| vibration after a stop [mm] |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.scenarios.split(","):
        text = resources.files("pathmotion.scenarios").joinpath(f"{name}.toml").read_text()
        setup = api.load_text(text)
        result = api.plan_scenario(setup)
        elastic = load_drives(drive_file_for("irb140"), setup.robot.n)
        for gears, drives in (("rigid", elastic.rigid()), ("elastic", elastic)):
            for mode in MODES:
                t0 = time.perf_counter()
                f = run(setup, result, drives, mode, payload=args.unknown_payload)
                s = run(setup, result, drives, mode, stop_at=0.5 * result.duration, payload=args.unknown_payload)
                row = {"scenario": name, "gears": gears, "correction": mode, "planned_s": result.duration,
                       "path_accuracy_m": f["path_accuracy_m"], "cycle_time_s": f["cycle_time_s"],
                       "vibration_end_m": f["residual_vibration_m"], "vibration_stop_m": s["residual_vibration_m"],
                       "wall_s": time.perf_counter() - t0}
                rows.append(row)
                cyc = row["cycle_time_s"]
                print(f"| {name} | {gears} | {mode} | {1e3 * row['path_accuracy_m']:.3f} | "
                      f"{'-' if cyc is None else f'{cyc:.3f}'} | "
                      f"{'-' if cyc is None else f'{cyc / result.duration:.4f}'} | "
                      f"{1e3 * row['vibration_end_m']:.3f} | {1e3 * row['vibration_stop_m']:.3f} |", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
