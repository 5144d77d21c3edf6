"""The fast optimal-blend search against the thorough one on the corner atlas' rows (two 0.2 m lines, rest to rest,
velocity and acceleration limits; pathmotion.study.atlas): per row the symmetric G2 blend's duration, each search's
duration, CPU time and plans, and the share of the thorough search's gain over G2 that the fast search keeps.

Each search runs in its own process (so CPU times do not mix), ``--workers`` rows at a time, niced.

    python benchmarks/bench_fast_search.py --json out/fast_search.json
    python benchmarks/bench_fast_search.py --angles 90 --tolerances 0.001,0.01 --workers 1
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path


def _search(job: tuple[float, float, str]) -> dict:
    """One row searched: (angle [deg], tolerance [m], "fast" | "thorough") -> its record."""
    os.nice(10)
    from pathmotion.errors import PathmotionError
    from pathmotion.planning import blend_search as bs
    from pathmotion.robot.model import load_robot
    from pathmotion.study.atlas import _settings, _task, corner_points

    angle, tol, kind = job
    t0 = time.process_time()
    try:
        best = bs.optimal_blends(load_robot("irb140"), _task(corner_points(angle)), tol,
                                 settings=_settings(False, verify=False, baselines=False), search=bs.SEARCHES[kind])
    except PathmotionError as exc:
        return {"angle_deg": angle, "tolerance_m": tol, "search": kind, "error": str(exc)}
    return {"angle_deg": angle, "tolerance_m": tol, "search": kind, "duration_s": best.duration,
            "g2_s": best.symmetric_duration, "plans": best.plans, "cpu_s": time.process_time() - t0}


def _rows(records: list[dict]) -> list[dict]:
    by = {(r["angle_deg"], r["tolerance_m"], r["search"]): r for r in records}
    out = []
    for (a, t) in sorted({(r["angle_deg"], r["tolerance_m"]) for r in records}):
        fast, thorough = by.get((a, t, "fast"), {}), by.get((a, t, "thorough"), {})
        row = {"angle_deg": a, "tolerance_m": t, "fast": fast, "thorough": thorough}
        if "duration_s" in fast and "duration_s" in thorough:
            g2 = fast["g2_s"]
            gain_f, gain_t = g2 - fast["duration_s"], g2 - thorough["duration_s"]
            row.update(g2_s=g2, gain_fast_pct=100 * gain_f / g2, gain_thorough_pct=100 * gain_t / g2,
                       kept_pct=100 * gain_f / gain_t if gain_t > 0 else None)
        out.append(row)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angles", default="30,60,90,120,150", help="turn angles [deg], comma-separated")
    ap.add_argument("--tolerances", default="0.0001,0.001,0.005,0.01", help="tolerances [m], comma-separated")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    jobs = [(float(an), float(t), kind) for an in a.angles.split(",") for t in a.tolerances.split(",")
            for kind in ("thorough", "fast")]
    load0 = os.getloadavg()[0]
    print(f"load average at start: {load0:.2f} ({os.cpu_count()} cores), {a.workers} workers, niced")
    with ProcessPoolExecutor(a.workers) as pool:
        records = list(pool.map(_search, jobs))
    rows = _rows(records)
    print(f"{'angle':>6} {'tol [mm]':>8} | {'G2 [s]':>8} {'fast [s]':>9} {'thorough [s]':>12} | {'gain fast %':>11} "
          f"{'thorough %':>10} {'kept %':>7} | {'cpu fast':>8} {'thorough':>8} {'plans':>11}")
    for r in rows:
        f, t = r["fast"], r["thorough"]
        if "g2_s" not in r:
            print(f"{r['angle_deg']:6g} {r['tolerance_m'] * 1e3:8g} | {f.get('error') or t.get('error')}")
            continue
        kept = "-" if r["kept_pct"] is None else f"{r['kept_pct']:.1f}"
        print(f"{r['angle_deg']:6g} {r['tolerance_m'] * 1e3:8g} | {r['g2_s']:8.5f} {f['duration_s']:9.5f} "
              f"{t['duration_s']:12.5f} | {r['gain_fast_pct']:11.3f} {r['gain_thorough_pct']:10.3f} {kept:>7} | "
              f"{f['cpu_s']:8.2f} {t['cpu_s']:8.1f} {f['plans']:>5}/{t['plans']:<5}")
    done = [r for r in rows if "g2_s" in r]
    if done:
        gf = sum(r["g2_s"] - r["fast"]["duration_s"] for r in done)
        gt = sum(r["g2_s"] - r["thorough"]["duration_s"] for r in done)
        cpu = [r["fast"]["cpu_s"] for r in done]
        print(f"rows {len(done)}: the fast search keeps {100 * gf / gt:.1f} % of the thorough search's summed gain "
              f"over G2; fast CPU per corner median {statistics.median(cpu):.2f} s (range {min(cpu):.2f}-{max(cpu):.2f}),"
              f" mean {statistics.mean(cpu):.2f} s; thorough mean "
              f"{statistics.mean(r['thorough']['cpu_s'] for r in done):.1f} s")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({"load_start": load0, "load_end": os.getloadavg()[0], "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
