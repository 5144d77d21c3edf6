"""EGM switch cost: the compute of a stop or an override request's re-timing (execute runs it in a worker
thread within the switch's lead; timed here as Streamer.stop / Streamer.override with lead 0, which re-time on
the call) on a streamer at a moving state of the plan (the Retimer's profile, the
shaped reference table built from it and its check against the plan's limits, re-timed slower where it exceeds
them), against the peer in the same run: Ruckig (off the path: joint-space velocity control to rest from the
same sent joint state within the joint velocity, acceleration and jerk limits; Ruckig's `calculate` alone).
The calls are interleaved in a shuffled order after a warm-up; thread CPU time per call. `over 4 ms` counts
the calls longer than one 4 ms cycle (with execute --switch-lead 0 they would make that cycle's answer late).

    PYTHONPATH=. python benchmarks/bench_egm_switch.py [--scenarios circle_smooth,corner_g2,abb_cycle]
        [--states 18] [--jerk] [--json FILE]
"""

from __future__ import annotations

import argparse
import logging
import random
import time
from importlib import resources
from pathlib import Path

import numpy as np

from bench_egm_cycle import _copy
from result_json import Table

CYCLE = 0.004
COLUMNS = [("scenario", "scenario"), ("request", "request"), ("calls", "calls"),
           ("median_ms", "median [ms]"), ("p90_ms", "p90 [ms]"), ("max_ms", "max [ms]"),
           ("over_cycle", "over 4 ms"), ("refused", "kept its motion (no re-timed segment)"),
           ("ruckig_median_ms", "Ruckig stop median [ms]"), ("ratio", "median / Ruckig's")]


def _ruckig_stop(n: int, lim, jerk):
    """Ruckig's velocity-control stop to rest (one joint state -> its calculate call)."""
    from ruckig import ControlInterface, InputParameter, Ruckig, Trajectory

    otg, inp, traj = Ruckig(n), InputParameter(n), Trajectory(n)
    inp.control_interface = ControlInterface.Velocity
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = lim.velocity, lim.acceleration, jerk
    inp.target_velocity, inp.target_acceleration = np.zeros(n), np.zeros(n)

    def stop(q, qd, qdd):
        inp.current_position, inp.current_velocity = q, np.clip(qd, -lim.velocity, lim.velocity)
        inp.current_acceleration = np.clip(qdd, -lim.acceleration, lim.acceleration)
        otg.calculate(inp, traj)
    return stop


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="circle_smooth,corner_g2,abb_cycle")
    ap.add_argument("--states", type=int, default=18, help="moving plan states per scenario (5-90 %% of the plan)")
    ap.add_argument("--jerk", action="store_true", help="plan every scenario with the robot's jerk limits")
    ap.add_argument("--json", type=Path, help="write the table as JSON here (for benchmarks/results.py)")
    args = ap.parse_args()
    logging.disable(logging.WARNING)  # a switch that is re-timed slower warns; counted, not printed
    from pathmotion import api
    from pathmotion.execution.drive_file import drive_file_for, load_drives
    from pathmotion.execution.session import make_streamer

    jerk_note = ", every plan jerk-limited" if args.jerk else ""
    table = Table(f"EGM switch cost: execute's stop and override requests against Ruckig's stop{jerk_note}",
                  COLUMNS)
    print("| " + " | ".join(h for _, h in COLUMNS) + " |")
    for name in args.scenarios.split(","):
        text = resources.files("pathmotion.scenarios").joinpath(f"{name}.toml").read_text()
        setup = api.load_text(text, overrides={"limits.use_jerk": True} if args.jerk else None)
        robot = setup.robot
        streamer = make_streamer(robot, api.plan_scenario(setup), "shaping",
                                 load_drives(drive_file_for("irb140"), robot.n))
        tab = streamer.table
        lim = robot.limits
        jerk = lim.jerk if lim.jerk is not None else 10.0 * lim.acceleration
        peer = _ruckig_stop(robot.n, lim, jerk)
        step = tab.t[1] - tab.t[0]
        qdd = np.gradient(tab.qd, step, axis=0)
        times = np.linspace(0.05, 0.9, args.states) * tab.duration
        requests = {"stop": lambda st: st.stop("benchmark"), "override 0.5": lambda st: st.override(0.5)}

        def prepare(kind, t):
            """The call of ``kind`` at plan time t, and the streamer copy it acts on (None for Ruckig)."""
            if kind == "ruckig":
                k = min(int(round(t / step)), len(tab.t) - 1)
                return (lambda: peer(tab.q[k], tab.qd[k], qdd[k])), None
            st = _copy(streamer)
            st._now, st.lead = t, 0.0  # the re-timing on the request's call, as execute's worker runs it
            return (lambda: requests[kind](st)), st

        calls = [(kind, t) for kind in (*requests, "ruckig") for t in times]
        for kind, t in calls[:: max(1, len(calls) // 6)]:  # warm-up: compiled kernels, caches
            prepare(kind, t)[0]()
        random.Random(0).shuffle(calls)
        cost = {kind: [] for kind in (*requests, "ruckig")}
        kept = {kind: 0 for kind in requests}
        for kind, t in calls:
            fn, st = prepare(kind, t)
            t0 = time.thread_time()
            fn()
            cost[kind].append(time.thread_time() - t0)
            if kind != "ruckig":
                kept[kind] += st.segment is st.table
        peer_ms = 1e3 * float(np.median(cost["ruckig"]))
        for kind in requests:
            ms = 1e3 * np.asarray(cost[kind])
            table.add(scenario=name + (" (jerk)" if args.jerk else ""), request=kind, calls=len(ms),
                      median_ms=round(float(np.median(ms)), 2), p90_ms=round(float(np.percentile(ms, 90)), 2),
                      max_ms=round(float(ms.max()), 2), over_cycle=int(np.sum(ms > 1e3 * CYCLE)),
                      refused=kept[kind], ruckig_median_ms=round(peer_ms, 4),
                      ratio=round(float(np.median(ms)) / peer_ms, 1))
            row = table.rows[-1]
            print("| " + " | ".join(str(row[k]) for k, _ in COLUMNS) + " |", flush=True)
    table.notes.append("Thread CPU time of the request's call on a copy of execute's streamer ("
                       "shaping, the IRB140's drive file, elastic gears) at moving plan "
                       "states from 5 to 90 % of the plan; a request that leaves the segment as it was (an override "
                       "the re-timer refuses from that state, or a stop where the plan rests already) is counted in "
                       "'kept its motion'. Ruckig: the same sent joint state, stopped in joint space (it leaves the "
                       "path), its calculate call alone.")
    if args.json:
        print(f"wrote {table.write(args.json)}")


if __name__ == "__main__":
    main()
