"""EGM cycle in process: the compute of execute's per-message step (Streamer.handle on circle_smooth, shaping,
path supervision on, an arm that reports the reference it got) without a socket or a second process, so that
it can be compared between versions on a loaded machine, where bench_egm's wall-clock numbers are noise.

* warm: the cycles back to back, the per-cycle minimum over --repeats runs (each on a copy of the streamer,
  as serve's rehearsal makes one): the work itself, preemption filtered out;
* cold: one cycle every 4 ms with a 24 MB sweep of memory before each, as the real loop finds its caches after
  waiting for the robot (bench_egm's idle median compute is several times the warm one).

    PYTHONPATH=. python benchmarks/bench_egm_cycle.py [--cycles 3000] [--repeats 5] [--cold 1000]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import gc
import os
import time

import numpy as np

from bench_egm import CYCLE, circle_smooth_streamer


def _copy(streamer):
    """A fresh streamer on the same table (its own counts, records, supervision state, requests)."""
    from pathmotion.execution.streamer import Counts

    return dataclasses.replace(streamer, counts=Counts(), records=[], supervision=copy.copy(streamer.supervision),
                               requests=[], _pending=None, _worker=None, _took={})


def run(streamer, cycles: int, cold: bool) -> np.ndarray:
    """Per-cycle compute [s] of ``cycles`` messages answered by ``streamer`` (collector paused, rehearsed, as
    serve runs it)."""
    from pathmotion.execution.messages import decode_sensor, encode_robot

    clock, n = time.perf_counter, streamer.n
    sweep = np.random.default_rng(0).random(3_000_000) if cold else None
    q = streamer.table.q[0]
    times = np.empty(cycles)
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        streamer.rehearse()
        tick = clock()
        for k in range(cycles):
            data = encode_robot(k + 1, 4 * k, q, q)
            if cold:
                tick += CYCLE
                time.sleep(max(tick - clock(), 0.0))
                sweep.sum()
            t0 = clock()
            reply = streamer.handle(data, t0, clock)
            times[k] = clock() - t0
            q = decode_sensor(reply, n).joints  # the arm reports the reference it got
    finally:
        gc.enable()
        gc.unfreeze()
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=3000, help="warm cycles per run")
    ap.add_argument("--repeats", type=int, default=5, help="warm runs (per-cycle minimum)")
    ap.add_argument("--cold", type=int, default=1000, help="cold cycles, one per 4 ms")
    args = ap.parse_args()
    streamer = circle_smooth_streamer(max(args.cycles, args.cold))
    warm = np.min([run(_copy(streamer), args.cycles, False) for _ in range(args.repeats)], axis=0)
    cold = run(_copy(streamer), args.cold, True)
    print(f"{'cycle compute [us]':28s} {'cycles':>7s} {'median':>8s} {'p99':>8s} {'p99.9':>8s} {'max':>8s}")
    for name, c in ((f"warm (min of {args.repeats} runs)", warm), ("cold (4 ms apart, swept)", cold)):
        us = 1e6 * c
        print(f"{name:28s} {len(us):7d} {np.median(us):8.1f} {np.percentile(us, 99):8.1f} "
              f"{np.percentile(us, 99.9):8.1f} {us.max():8.1f}")
    print(f"load (1 min): {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
