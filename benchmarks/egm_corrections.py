"""The three corrections of ``pathmotion execute`` (none, shaping, orbital) through the virtual IRC5, rigid
and elastic gears, on shipped scenarios: path accuracy and cycle time of the arm's link side (the TCP that
moves), and the residual vibration after its stops (at the path's end, and after a stop along the path
switched at half the planned time); when execute's path supervision stopped the run, when, and how far from
the planned path the arm ends. Lockstep EGM in one process, through the encoded messages.

    PYTHONPATH=. python benchmarks/egm_corrections.py [--scenarios circle_smooth,corner_g2,abb_cycle] [--json F]
        [--unknown-payload KG]   (the arm carries KG 0.1 m beyond the flange; the plan and the drives' model not)
        [--plant builtin|mujoco] (what moves the links: the built-in two-mass RK4 or MuJoCo)
        [--jerk]                 (plan every scenario with the robot's jerk limits, limits.use_jerk = true)
        [--no-supervision]       (execute streams on whatever the arm does: no stop when it leaves the path)
"""

from __future__ import annotations

import argparse
import time
from importlib import resources
from pathlib import Path

import numpy as np

from pathmotion import api
from pathmotion.execution.drive_file import drive_file_for, load_drives
from pathmotion.execution.drives import VirtualArm
from pathmotion.execution.figures import LINE_POINTS, PROJECTION_STEPS
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess
from pathmotion.execution.shaped_limits import motion_ratios
from pathmotion.planning import effective_limits
from pathmotion.simulation.metrics import planned_tcp_line, polish_projection, tcp_path_deviation
from pathmotion.robot import Payload
from result_json import Table

MODES = ("none", "shaping", "orbital")
COLUMNS = [("scenario", "scenario"), ("gears", "gears"), ("correction", "correction"),
           ("planned_s", "planned [s]"), ("streamed_s", "plan streamed [s]"),
           ("path_accuracy_mm", "path accuracy [mm]"),
           ("cycle_s", "cycle [s]"), ("cycle_ratio", "cycle / planned"),
           ("vibration_end_mm", "vibration after end [mm]"), ("vibration_stop_mm", "vibration after a stop [mm]"),
           ("supervision_stop_s", "supervision stop [s]"), ("end_off_path_mm", "ends off the path [mm]"),
           ("shaped_ratio", "shaped motion's largest limit ratio"),
           ("sent_ratio", "sent motion's largest limit ratio"), ("stop_ratio", "stop's largest limit ratio")]


def run(setup, result, drives, mode, stop_at=None, payload=0.0, plant="builtin", supervision=True):
    tolerance = setup.scenario.simulate.joint_tolerance if supervision else None
    streamer = make_streamer(setup.robot, result, mode, drives, path_tolerance=tolerance)
    carried = setup.robot.with_payload(Payload(mass=payload, com=(0.0, 0.0, 0.1))) if payload > 0 else None
    arm = VirtualArm(setup.robot, drives, streamer.table.plan[0], plant_robot=carried, plant=plant)
    # the stop requested its lead before stop_at (defaults.EGM_SWITCH_LEAD), so that it switches at stop_at
    request = None if stop_at is None else stop_at - streamer.lead
    out = run_inprocess(streamer, arm, result.duration + 2.0, stop_at=request)
    figures = arm_figures(setup.robot, out)
    tripped = streamer.supervision.tripped if supervision else None
    figures["supervision_stop_s"] = None if tripped is None else round(tripped.t, 3)
    figures["end_off_path_m"] = end_off_path(setup.robot, result.trajectory.path, out.q[-1], out.theta[-1])
    limits = effective_limits(setup.robot, result.settings)  # the plan's, as the user planned it
    path = result.trajectory.path
    figures["shaped_ratio"] = max(motion_ratios(setup.robot, path, streamer.table.motion, limits).values())
    figures["sent_ratio"] = max(motion_ratios(setup.robot, path, streamer.table.sent, limits).values())
    stopped = streamer.segment is not streamer.table
    figures["stop_ratio"] = max(motion_ratios(setup.robot, path, streamer.segment.motion, limits).values()) \
        if stopped else None
    figures["streamed_s"] = streamer.plan.duration
    return figures


def end_off_path(robot, path, q, theta_guess) -> float:
    """The TCP's distance [m] at joints q (n,) from the planned TCP path (simulate's measure, near theta_guess)."""
    grid = np.linspace(*path.domain, LINE_POINTS + 1)
    theta, _ = polish_projection(path, q[None], np.array([theta_guess]), PROJECTION_STEPS)
    return float(tcp_path_deviation(robot, path, q[None], theta, grid, planned_tcp_line(robot, path, grid))[2][0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="circle_smooth,corner_g2,abb_cycle")
    ap.add_argument("--json", type=Path, help="write the table as JSON here (for benchmarks/results.py)")
    ap.add_argument("--unknown-payload", type=float, default=0.0, help="kg the arm carries unknown to the plan")
    ap.add_argument("--plant", default="builtin", choices=("builtin", "mujoco"), help="what moves the links")
    ap.add_argument("--jerk", action="store_true", help="plan every scenario with the robot's jerk limits")
    ap.add_argument("--no-supervision", action="store_true", help="no path supervision: stream on off the path")
    args = ap.parse_args()
    payload = f", the arm carrying {args.unknown_payload:g} kg unknown to the plan" if args.unknown_payload else ""
    on = ", MuJoCo moving the links" if args.plant == "mujoco" else ""
    jerk = ", every plan jerk-limited" if args.jerk else ""
    free = ", no path supervision" if args.no_supervision else ""
    table = Table(f"EGM corrections through the virtual IRC5{payload}{on}{jerk}{free}", COLUMNS)
    print("| " + " | ".join(h for _, h in COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    for name in args.scenarios.split(","):
        text = resources.files("pathmotion.scenarios").joinpath(f"{name}.toml").read_text()
        setup = api.load_text(text, overrides={"limits.use_jerk": True} if args.jerk else None)
        result = api.plan_scenario(setup)
        elastic = load_drives(drive_file_for("irb140"), setup.robot.n)
        for gears, drives in (("rigid", elastic.rigid()), ("elastic", elastic)):
            for mode in MODES:
                t0 = time.perf_counter()
                kw = dict(payload=args.unknown_payload, plant=args.plant, supervision=not args.no_supervision)
                f = run(setup, result, drives, mode, **kw)
                s = run(setup, result, drives, mode, stop_at=0.5 * result.duration, **kw)
                cyc = f["cycle_time_s"]
                table.add(scenario=name, gears=gears, correction=mode, planned_s=round(result.duration, 4),
                          streamed_s=round(f["streamed_s"], 4),
                          path_accuracy_mm=round(1e3 * f["path_accuracy_m"], 3),
                          cycle_s=None if cyc is None else round(cyc, 3),
                          cycle_ratio=None if cyc is None else round(cyc / result.duration, 4),
                          vibration_end_mm=round(1e3 * f["residual_vibration_m"], 3),
                          vibration_stop_mm=round(1e3 * s["residual_vibration_m"], 3),
                          supervision_stop_s=f["supervision_stop_s"],
                          end_off_path_mm=round(1e3 * f["end_off_path_m"], 3),
                          shaped_ratio=round(f["shaped_ratio"], 4), sent_ratio=round(f["sent_ratio"], 4),
                          stop_ratio=None if s["stop_ratio"] is None else round(s["stop_ratio"], 4))
                row = table.rows[-1]
                print("| " + " | ".join("-" if row[k] is None else str(row[k]) for k, _ in COLUMNS) + " |"
                      f"  ({time.perf_counter() - t0:.1f} s)", flush=True)
    table.notes.append("Lockstep EGM through the virtual IRC5, the link side's TCP. Cycle as `simulate` counts it: "
                       "the TCP first within 1 mm of the path's end plus the plan's own time inside that ball. "
                       "Vibration: the TCP's largest distance from where it finally rests, after the reference came "
                       "to rest, at the path's end and after a stop switched at half the planned time (requested "
                       "its lead, defaults.EGM_SWITCH_LEAD, before). Supervision "
                       "stop: when execute's path supervision (simulate.joint_tolerance) stopped the run along the "
                       "path; ends off the path: the TCP's final distance from the planned path. Plan streamed: the "
                       "plan execute streams (with shaping of a second-order plan, planned again with its limits "
                       "tightened where its shaped motion exceeded them); cycle / planned against the plan as "
                       "planned. Largest limit ratio: of the motion the references follow (theta, theta_dot, "
                       "theta_ddot; shaped with shaping and orbital) against the plan's velocity, acceleration and "
                       "torque limits, on the run to the end and on the stop segment of the stopped run; the sent "
                       "motion's: of the motion the sent references follow in time on the run's first segment, "
                       "from rest (the references show the motion at its own plan time: no lead by the "
                       "transport delay).")
    if args.json:
        print(f"wrote {table.write(args.json)}")


if __name__ == "__main__":
    main()
