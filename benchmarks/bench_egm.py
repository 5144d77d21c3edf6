"""EGM real time on localhost: N consecutive 4 ms cycles of a robot sender (its own process, sending an
EgmRobot on an absolute 4 ms clock and reading the answer), answered by pathmotion execute's loop
(execution.loops.serve, shaping references of circle_smooth, held at rest after its end) and, as the peer in
the same run, by abb-robot-client's own EGM class (receive_from_robot + send_to_robot with the same
reference). An answer is late when it has not arrived when the sender's next cycle begins. Per-cycle compute:
receive to send on the answering side.

    PYTHONPATH=. python benchmarks/bench_egm.py [--cycles 10000] [--json FILE]
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import select
import socket
import time
from pathlib import Path

import numpy as np

from result_json import Table

CYCLE = 0.004


def robot_sender(port: int, cycles: int, q0: list, result) -> None:
    """Send EgmRobot every CYCLE seconds (absolute schedule); count answers that miss their cycle."""
    from pathmotion.execution.messages import decode_sensor, encode_robot

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.connect(("127.0.0.1", port))
    q = np.asarray(q0)
    late, missing, slip = 0, 0, 0.0
    start = time.perf_counter() + 0.2
    for k in range(cycles):
        tick = start + k * CYCLE
        now = time.perf_counter()
        if now < tick:
            time.sleep(tick - now)
        slip = max(slip, time.perf_counter() - tick)
        sock.send(encode_robot(k + 1, int(round(k * CYCLE * 1000)), q, q))
        got = False
        while True:
            left = tick + CYCLE - time.perf_counter()
            ready, _, _ = select.select([sock], [], [], max(left, 0.0))
            if not ready:
                break
            q = decode_sensor(sock.recv(65536), len(q)).joints
            got = True
            break
        if not got:
            late += 1
            ready, _, _ = select.select([sock], [], [], 0.05)  # a late answer still drains
            if ready:
                sock.recv(65536)
            else:
                missing += 1
    result.put({"late": late, "missing": missing, "max_send_slip_s": slip})


def serve_pathmotion(cycles: int):
    from pathmotion import api
    from pathmotion.execution.drive_file import drive_file_for, load_drives
    from pathmotion.execution.loops import open_listener, serve
    from pathmotion.execution.session import make_streamer

    from importlib import resources
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("circle_smooth.toml").read_text())
    result = api.plan_scenario(setup)
    streamer = make_streamer(setup.robot, result, "shaping", load_drives(drive_file_for("irb140"), setup.robot.n))
    streamer.settle = cycles * CYCLE + 10.0  # keep answering at rest after the motion's end
    sock = open_listener(0, "127.0.0.1")
    port = sock.getsockname()[1]
    q0 = streamer.table.q[0].tolist()

    def answer(done):
        serve(sock, streamer, first_timeout=30.0, silence=0.5)  # ends when the sender falls silent

    compute = lambda: np.array([r.t_send - r.t_recv for r in streamer.records])  # noqa: E731
    return port, q0, answer, compute, sock


def serve_peer(cycles: int, q0: list):
    from abb_robot_client.egm import EGM

    egm = EGM(port=0)
    port = egm.socket.getsockname()[1]
    times = []
    ref = np.degrees(np.asarray(q0))

    def answer(done):
        stop_at = time.perf_counter() + cycles * CYCLE + 3.0
        while not done() and time.perf_counter() < stop_at:
            ok, state = egm.receive_from_robot(0.05)
            if ok:
                t0 = time.perf_counter()
                egm.send_to_robot(ref, np.zeros(len(ref)))
                times.append(time.perf_counter() - t0)
    return port, answer, lambda: np.array(times), egm.socket


def measure(name, port, q0, answer, compute, sock, cycles):
    result = mp.Queue()
    sender = mp.Process(target=robot_sender, args=(port, cycles, q0, result))
    sender.start()
    answer(lambda: not sender.is_alive() and not result.empty() or False)
    got = result.get(timeout=30)
    sender.join(10)
    sock.close()
    c = compute()
    return {"side": name, "cycles": cycles, "answers": int(c.size), **got,
            "compute_median_s": float(np.median(c)), "compute_p99_s": float(np.percentile(c, 99)),
            "compute_p99_9_s": float(np.percentile(c, 99.9)), "compute_max_s": float(c.max()),
            "load_1min": os.getloadavg()[0]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=10_000)
    ap.add_argument("--json", type=Path, help="write the table as JSON here (for benchmarks/results.py)")
    args = ap.parse_args()
    table = Table("EGM real time on localhost: 4 ms cycles answered by pathmotion execute and by its peer",
                  [("side", "answering side"), ("cycles", "cycles"), ("late", "late"), ("missing", "missing"),
                   ("median_ms", "compute median [ms]"), ("p99_ms", "p99 [ms]"), ("p99_9_ms", "p99.9 [ms]"),
                   ("max_ms", "max [ms]"), ("load", "load (1 min)")])
    port, q0, answer, compute, sock = serve_pathmotion(args.cycles)
    rows = [measure("pathmotion execute (serve, shaping)", port, q0, answer, compute, sock, args.cycles)]
    port, answer, compute, sock = serve_peer(args.cycles, q0)
    rows.append(measure("abb-robot-client EGM (peer)", port, q0, answer, compute, sock, args.cycles))
    print(f"{'side':38s} {'cycles':>7s} {'late':>5s} {'median ms':>10s} {'p99 ms':>8s} {'p99.9 ms':>9s} "
          f"{'max ms':>8s} {'load':>5s}")
    for r in rows:
        print(f"{r['side']:38s} {r['cycles']:7d} {r['late']:5d} {1e3 * r['compute_median_s']:10.3f} "
              f"{1e3 * r['compute_p99_s']:8.3f} {1e3 * r['compute_p99_9_s']:9.3f} {1e3 * r['compute_max_s']:8.3f} "
              f"{r['load_1min']:5.2f}")
    ratio = rows[0]["compute_p99_9_s"] / rows[1]["compute_p99_9_s"]
    print(f"compute p99.9 ratio pathmotion / peer: {ratio:.2f}")
    if args.json:
        for r in rows:
            table.add(side=r["side"], cycles=r["cycles"], late=r["late"], missing=r["missing"],
                      **{k: round(1e3 * r[f"compute_{k[:-3]}_s"], 3) for k in ("median_ms", "p99_ms", "p99_9_ms",
                                                                                 "max_ms")},
                      load=round(r["load_1min"], 2))
        table.notes += [f"Compute p99.9 ratio pathmotion / peer: {ratio:.2f}.",
                        "Late: the answer had not arrived when the sender's next 4 ms cycle began; missing: not "
                        "within 50 ms either. Compute: receive to send on the answering side. The robot sender "
                        "runs in its own process on an absolute 4 ms clock."]
        print(f"wrote {table.write(args.json)}")


if __name__ == "__main__":
    main()
