"""EGM real time on localhost: N consecutive 4 ms cycles of a robot sender (its own process, sending an
EgmRobot on an absolute 4 ms clock and reading the answer), answered by pathmotion execute's loop
(execution.loops.serve, shaping references of circle_smooth, held at rest after its end, its path supervision
on) and, as the peer in the same run, by abb-robot-client's own EGM class (receive_from_robot + send_to_robot
with the same reference). The sender reports the joints of the latest answer it has (a robot that follows its
references: execute's path supervision sees an arm on the path, as in a run). Each answer is matched to its
robot message (execute echoes the robot's time, the peer the robot's seqno); it is late when it arrives more
than one 4 ms cycle after its message left, missing when it never arrives; cycles where the sender itself woke
more than half a cycle late are counted apart (sender slips). Per-cycle compute: receive to send on the
answering side.

With --requests, execute's side alone: during the real-time run stdin-like requests come in a fixed cycle
(override 0.1 moving, stop, resume at rest, override 0.2, stop, resume, ...) while the arm moves, every second
one switched on its own cycle (lead 0: the re-timing before that cycle's answer) and the others with
execute's default lead (the re-timing in the worker thread, the loop answering from the current segment), so
both share the run and its load. Per lead: the answers late (sender side: arrived more than 4 ms after their
message left) behind a request until the next one, the reaction (robot time from the request to its switch),
the re-timing's compute time.

With --realtime-priority N, as on real hardware: the robot sender (it stands for the IRC5, a real-time
controller), execute's loop (serve's own option, as execute --realtime-priority) and the peer's answering loop all
run at SCHED_FIFO priority N with their process's memory locked (execution.realtime; where the system refuses, a
warning and normal priority); the table records each answering side's scheduling.

    PYTHONPATH=. python benchmarks/bench_egm.py [--cycles 10000] [--realtime-priority N] [--json FILE]
    PYTHONPATH=. python benchmarks/bench_egm.py --requests [--cycles 10000] [--realtime-priority N] [--json FILE]
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


def _request_of(answer, echo: str) -> int:
    """The index of the robot message an answer belongs to: execute echoes the robot's time (header.tm, 4 ms per
    message); the peer echoes the robot's seqno in its first speed reference."""
    if echo == "tm":
        return int(round(answer.tm / (CYCLE * 1000)))
    return int(round(np.degrees(answer.speed[0]))) - 1  # sent in deg/s, decoded in rad/s


def robot_sender(port: int, cycles: int, q0: list, echo: str, result, priority: int = 0) -> None:
    """Send EgmRobot on an absolute CYCLE schedule, reporting the joints of the latest answer; take every answer as it
    arrives and match it to its message (``priority`` > 0: at SCHED_FIFO ``priority``, as a real-time controller;
    the sender blocks in select between its ticks, never spins).
    An answer is late when it arrives more than one cycle after its message actually left (the sender's own
    slips are counted apart, so a late sender does not count against the answering side); missing when none
    arrives before the run ends (0.2 s after the last message)."""
    from pathmotion.execution.messages import decode_sensor, encode_robot
    from pathmotion.execution.realtime import realtime

    with realtime(priority) as got:
        figures = _send(port, cycles, q0, echo, decode_sensor, encode_robot)
    result.put(figures | {"sender_scheduling": _named(got)})


def _named(got: dict) -> str:
    """A scheduling record of execution.realtime as a table's text: 'SCHED_FIFO 50' or 'SCHED_OTHER'."""
    return got["policy"] + (f" {got['priority']}" if got["priority"] else "")


def _send(port: int, cycles: int, q0: list, echo: str, decode_sensor, encode_robot) -> dict:
    """:func:`robot_sender`'s run: its figures."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.connect(("127.0.0.1", port))
    q = np.asarray(q0)
    sent, arrived = np.full(cycles, np.nan), np.full(cycles, np.nan)
    start = time.perf_counter() + 0.2

    def drain(until: float) -> None:
        nonlocal q
        while True:
            ready, _, _ = select.select([sock], [], [], max(until - time.perf_counter(), 0.0))
            if not ready:
                return
            answer = decode_sensor(sock.recv(65536), len(q))
            q = answer.joints
            k = _request_of(answer, echo)
            if 0 <= k < cycles and np.isnan(arrived[k]):
                arrived[k] = time.perf_counter()

    for k in range(cycles):
        tick = start + k * CYCLE
        drain(tick)
        sent[k] = time.perf_counter()
        sock.send(encode_robot(k + 1, int(round(k * CYCLE * 1000)), q, q))
    drain(time.perf_counter() + 0.2)
    slip = sent - (start + CYCLE * np.arange(cycles))
    rtt = arrived - sent
    answered = ~np.isnan(rtt)
    sock.close()
    return {"rtt": rtt.tolist(), "late": int(np.sum(rtt[answered] > CYCLE)), "missing": int(np.sum(~answered)),
            "sender_slips": int(np.sum(slip > 0.5 * CYCLE)), "max_send_slip_s": float(slip.max()),
            "rtt_p99_9_s": float(np.percentile(rtt[answered], 99.9)) if answered.any() else float("nan")}


def circle_smooth_streamer(cycles: int):
    """execute's Streamer for circle_smooth (shaping, path supervision on), answering at rest after the motion's
    end for at least ``cycles`` cycles."""
    from pathmotion import api
    from pathmotion.execution.drive_file import drive_file_for, load_drives
    from pathmotion.execution.session import make_streamer

    from importlib import resources
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("circle_smooth.toml").read_text())
    result = api.plan_scenario(setup)
    streamer = make_streamer(setup.robot, result, "shaping", load_drives(drive_file_for("irb140"), setup.robot.n))
    streamer.settle = cycles * CYCLE + 10.0  # keep answering at rest after the motion's end
    return streamer


def serve_pathmotion(cycles: int, priority: int = 0):
    from pathmotion.execution.loops import open_listener, serve

    streamer = circle_smooth_streamer(cycles)
    sock = open_listener(0, "127.0.0.1")
    port = sock.getsockname()[1]
    q0 = streamer.table.q[0].tolist()

    def answer(done):
        serve(sock, streamer, first_timeout=30.0, silence=0.5, priority=priority)  # ends when the sender falls silent
        return _named(streamer.scheduling)

    compute = lambda: np.array([r.t_send - r.t_recv for r in streamer.records])  # noqa: E731
    return port, q0, answer, compute, sock


def serve_peer(cycles: int, q0: list, priority: int = 0):
    from abb_robot_client.egm import EGM

    from pathmotion.execution.realtime import realtime

    egm = EGM(port=0)
    port = egm.socket.getsockname()[1]
    times = []
    ref = np.degrees(np.asarray(q0))

    def answer(done):
        stop_at = time.perf_counter() + cycles * CYCLE + 3.0
        with realtime(priority) as got:  # blocks in select between messages, never spins
            while not done() and time.perf_counter() < stop_at:
                ok, state = egm.receive_from_robot(0.05)
                if ok:
                    t0 = time.perf_counter()
                    echo = np.zeros(len(ref))
                    echo[0] = state.robot_message.header.seqno  # for the sender to match the answer to its message
                    egm.send_to_robot(ref, echo)
                    times.append(time.perf_counter() - t0)
        return _named(got)
    return port, answer, lambda: np.array(times), egm.socket


def measure(name, port, q0, answer, compute, sock, cycles, echo, priority=0):
    result = mp.Queue()
    sender = mp.Process(target=robot_sender, args=(port, cycles, q0, echo, result, priority))
    sender.start()
    scheduling = answer(lambda: not sender.is_alive() and not result.empty() or False)
    got = result.get(timeout=30)
    sender.join(10)
    sock.close()
    c = compute()
    got.pop("rtt")
    return {"side": name, "cycles": cycles, "answers": int(c.size), **got, "scheduling": scheduling,
            "compute_median_s": float(np.median(c)), "compute_p99_s": float(np.percentile(c, 99)),
            "compute_p99_9_s": float(np.percentile(c, 99.9)), "compute_max_s": float(c.max()),
            "load_1min": os.getloadavg()[0]}


#: The requests' cycle of --requests, and the robot time [s] between a request and the next.
REQUESTS = ("override 0.1", "stop", "resume", "override 0.2", "stop", "resume")
GAP = 0.25


def request_commands(streamer, leads: tuple):
    """serve's ``commands()``: the next of REQUESTS once GAP has passed since the last one's switch (a resume once
    the stop is at rest), while the motion goes on; each with the next of ``leads`` [s] as the streamer's lead.
    Returns (commands, issued): issued lists (lead, request line, index of its request in streamer.requests)."""
    issued, state = [], {"k": 0, "next": GAP}

    def commands():
        st = streamer
        if not st.started or st.pending is not None or st._now < state["next"]:
            return []
        line = REQUESTS[state["k"] % len(REQUESTS)]
        tau = st._now - st._segment_start
        if line == "resume" and tau < st.segment.duration:
            return []  # still stopping
        if line != "resume" and (st.stop_reason is not None or tau >= st.segment.duration):
            return []  # the motion is over
        st.lead = leads[len(issued) % len(leads)]
        issued.append((st.lead, line, len(st.requests)))  # its request, if it makes one, comes next
        state["k"] += 1
        state["next"] = st._now + GAP
        return [line]

    return commands, issued


def measure_requests(cycles: int, priority: int = 0) -> tuple[list, dict]:
    """A real-time run of execute's serve with requests (--requests): per lead, its row."""
    import logging

    from pathmotion import defaults
    from pathmotion.execution.loops import open_listener, serve

    logging.disable(logging.WARNING)  # the requests' own warnings (stopping, re-timed slower)
    streamer = circle_smooth_streamer(cycles)
    streamer.realtime = True  # as execute runs against a controller
    commands, issued = request_commands(streamer, (0.0, defaults.EGM_SWITCH_LEAD))
    sock = open_listener(0, "127.0.0.1")
    result = mp.Queue()
    q0 = streamer.table.q[0].tolist()
    sender = mp.Process(target=robot_sender, args=(sock.getsockname()[1], cycles, q0, "tm", result, priority))
    sender.start()
    serve(sock, streamer, commands=commands, first_timeout=30.0, silence=0.5, priority=priority)
    got = result.get(timeout=30)
    sender.join(10)
    sock.close()
    rtt = np.asarray(got["rtt"], float)
    late = ~(rtt <= CYCLE)  # late or missing
    made = [(lead, streamer.requests[i]) for lead, _, i in issued if i < len(streamer.requests)]
    made = [(lead, r) for lead, r in made if r.outcome != "at rest"]
    reqs = [r for _, r in made]
    starts = [int(round(r.requested / CYCLE)) + 1 for r in reqs]  # the first message behind the request
    # a request's window: from it to GAP after its switch (or its request), at most to the next request
    ends = [min(int(round(((r.at if r.outcome == "switched" else r.requested) + GAP) / CYCLE)) + 1, b)
            for r, b in zip(reqs, starts[1:] + [len(rtt)])]
    outside = np.ones(len(rtt), bool)
    rows = {}
    for (lead, r), a, b in zip(made, starts, ends):
        row = rows.setdefault(lead, {"lead_ms": round(1e3 * lead, 1), "requests": 0, "late": 0, "window": 0,
                                     "reaction": [], "compute": [], "rescheduled": 0, "waited": 0, "kept": 0})
        row["requests"] += 1
        row["late"] += int(late[a:b].sum())
        row["window"] += b - a
        outside[a:b] = False
        if r.outcome == "switched":
            row["reaction"].append(r.at - r.requested)
        else:
            row["kept"] += 1
        row["compute"].append(r.compute or 0.0)
        row["rescheduled"] += r.attempts > 1
        row["waited"] += r.waited > 0.0
    before = int(late[:starts[0]].sum()) if starts else int(late.sum())
    for row in rows.values():
        row["late_per_s"] = round(row["late"] / max(row.pop("window") * CYCLE, 1e-9), 2)
    return list(rows.values()), {"late_total": int(late.sum()), "late_before_requests": before,
                                 "late_outside_per_s": round(float(late[outside].sum()) / (outside.sum() * CYCLE), 2),
                                 "sender_slips": got["sender_slips"], "load": os.getloadavg()[0],
                                 "requests": len(reqs), "moving_until_s": float(reqs[-1].requested) if reqs else 0.0,
                                 "scheduling": _named(streamer.scheduling),
                                 "sender_scheduling": got["sender_scheduling"]}


def main_requests(args) -> None:
    columns = [("lead_ms", "lead [ms]"), ("requests", "requests"), ("late", "late answers behind them"),
               ("late_per_s", "late per s of their windows"),
               ("reaction_median_ms", "reaction median [ms]"), ("reaction_max_ms", "reaction max [ms]"),
               ("compute_median_ms", "re-timing median [ms]"), ("compute_max_ms", "re-timing max [ms]"),
               ("rescheduled", "scheduled again"), ("waited", "waited for"), ("kept", "no switch"),
               ("scheduling", "loop scheduling"), ("load", "load (1 min)")]
    table = Table("EGM requests in real time: late answers behind stop, override and resume requests, switched "
                  "on their cycle (lead 0) and a lead later", columns)
    rows, totals = measure_requests(args.cycles, args.realtime_priority)
    print(" | ".join(h for _, h in columns))
    for r in rows:
        reaction, compute = 1e3 * np.asarray(r.pop("reaction") or [np.nan]), 1e3 * np.asarray(r.pop("compute"))
        r.update(reaction_median_ms=round(float(np.median(reaction)), 1),
                 reaction_max_ms=round(float(np.max(reaction)), 1),
                 compute_median_ms=round(float(np.median(compute)), 1),
                 compute_max_ms=round(float(np.max(compute)), 1), scheduling=totals["scheduling"],
                 load=round(totals["load"], 2))
        table.add(**r)
        print(" | ".join(str(r[k]) for k, _ in columns))
    print(f"late answers in the run: {totals['late_total']} of {args.cycles} ({totals['late_before_requests']} before "
          f"the first request; {totals['late_outside_per_s']} per s outside the requests' windows); sender slips {totals['sender_slips']}; {totals['requests']} requests until "
          f"{totals['moving_until_s']:.1f} s; loop {totals['scheduling']}, sender {totals['sender_scheduling']}; "
          f"load (1 min) {totals['load']:.2f}")
    table.notes += [
        f"One real-time run of {args.cycles} cycles on localhost (execute's serve, circle_smooth, shaping, its "
        "path supervision on; the robot sender in its own process on an absolute 4 ms clock): "
        f"{totals['requests']} requests (override 0.1, stop, resume, override 0.2, stop, resume, ... 0.25 s of "
        "robot time apart while the arm moves), alternately switched on their own cycle (lead 0) and a lead "
        f"later. Late answers in the whole run: {totals['late_total']} ({totals['late_before_requests']} before the "
        f"first request; {totals['late_outside_per_s']} per s outside the requests' windows: the machine's load); "
        f"sender slips {totals['sender_slips']}. Scheduling: the loop {totals['scheduling']}, the robot sender "
        f"{totals['sender_scheduling']}.",
        "Late: an answer that arrived more than 4 ms after its message left (sender side) or never, counted "
        "in the request's window: from the request to 0.25 s after its switch, at most to the next request. Reaction: robot time from the request to the switch. Re-timing: "
        "wall time of the Retimer, shaped table and limit check (the last attempt); scheduled again: not ready at "
        "its switch, re-timed from a later state; waited for: the loop waited for it at its switch."]
    if args.json:
        print(f"wrote {table.write(args.json)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=10_000)
    ap.add_argument("--json", type=Path, help="write the table as JSON here (for benchmarks/results.py)")
    ap.add_argument("--requests", action="store_true", help="execute alone, with stop / override / resume requests")
    ap.add_argument("--realtime-priority", type=int, default=0, help="the robot sender and the answering loops at "
                    "this SCHED_FIFO priority, memory locked (0: normal scheduling)")
    args = ap.parse_args()
    if args.requests:
        main_requests(args)
        return
    table = Table("EGM real time on localhost: 4 ms cycles answered by pathmotion execute and by its peer",
                  [("side", "answering side"), ("cycles", "cycles"), ("late", "late"), ("missing", "missing"),
                   ("sender_slips", "sender slips"), ("rtt_p99_9_ms", "round trip p99.9 [ms]"),
                   ("median_ms", "compute median [ms]"), ("p99_ms", "p99 [ms]"), ("p99_9_ms", "p99.9 [ms]"),
                   ("max_ms", "max [ms]"), ("scheduling", "scheduling"), ("load", "load (1 min)")])
    prio = args.realtime_priority
    port, q0, answer, compute, sock = serve_pathmotion(args.cycles, prio)
    rows = [measure("pathmotion execute (serve, shaping)", port, q0, answer, compute, sock, args.cycles, "tm", prio)]
    port, answer, compute, sock = serve_peer(args.cycles, q0, prio)
    rows.append(measure("abb-robot-client EGM (peer)", port, q0, answer, compute, sock, args.cycles, "seqno", prio))
    print(f"{'side':38s} {'cycles':>7s} {'late':>5s} {'missing':>7s} {'slips':>5s} {'median ms':>10s} {'p99 ms':>8s} "
          f"{'p99.9 ms':>9s} {'max ms':>8s} {'scheduling':>14s} {'load':>5s}")
    for r in rows:
        print(f"{r['side']:38s} {r['cycles']:7d} {r['late']:5d} {r['missing']:7d} {r['sender_slips']:5d} "
              f"{1e3 * r['compute_median_s']:10.3f} "
              f"{1e3 * r['compute_p99_s']:8.3f} {1e3 * r['compute_p99_9_s']:9.3f} {1e3 * r['compute_max_s']:8.3f} "
              f"{r['scheduling']:>14s} {r['load_1min']:5.2f}")
    ratio = rows[0]["compute_p99_9_s"] / rows[1]["compute_p99_9_s"]
    print(f"compute p99.9 ratio pathmotion / peer: {ratio:.2f}")
    if args.json:
        for r in rows:
            table.add(side=r["side"], cycles=r["cycles"], late=r["late"], missing=r["missing"],
                      sender_slips=r["sender_slips"], rtt_p99_9_ms=round(1e3 * r["rtt_p99_9_s"], 3),
                      **{k: round(1e3 * r[f"compute_{k[:-3]}_s"], 3) for k in ("median_ms", "p99_ms", "p99_9_ms",
                                                                                 "max_ms")},
                      scheduling=r["scheduling"], load=round(r["load_1min"], 2))
        table.notes += [f"Compute p99.9 ratio pathmotion / peer: {ratio:.2f}.",
                        "Late: the answer, matched to its robot message, arrived more than 4 ms after that message "
                        "left; missing: it never arrived. Sender slips: cycles where the sender (its own process, "
                        "absolute 4 ms clock) sent more than 2 ms after its tick. Compute: receive to send on the "
                        "answering side. Scheduling: the answering loop's (the robot sender's: "
                        f"{rows[0]['sender_scheduling']}, {rows[1]['sender_scheduling']})."]
        print(f"wrote {table.write(args.json)}")


if __name__ == "__main__":
    main()
