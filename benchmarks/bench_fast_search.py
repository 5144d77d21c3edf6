"""The fast optimal-blend search against the thorough one on the corner atlas' rows (two 0.2 m lines, rest to rest,
velocity and acceleration limits; pathmotion.study.atlas): per row the symmetric G2 blend's duration, each search's
duration, CPU time and plans, and the share of the thorough search's gain over G2 that the fast search keeps.

Each search runs in a worker process (so CPU times do not mix), ``--workers`` rows at a time, niced; each worker
first searches one corner untimed (warm-up). The thorough
search costs about a minute of CPU per row; ``--thorough-from FILE`` takes its durations from a JSON file instead
({"source": ..., "rows": [{angle_deg, tolerance_m, thorough_s}]}, e.g. benchmarks/atlas_thorough_durations.json) and
runs only the fast search.

    python benchmarks/bench_fast_search.py --workers 1 --json benchmarks/results/fast_search.json
    python benchmarks/bench_fast_search.py --workers 1 --thorough-from benchmarks/atlas_thorough_durations.json \\
        --json benchmarks/results/fast_search.json
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

#: The JSON table's columns (benchmarks/result_json.py).
COLUMNS = [("angle_deg", "angle [deg]"), ("tolerance_mm", "tolerance [mm]"), ("g2_s", "G2 [s]"),
           ("fast_s", "fast [s]"), ("thorough_s", "thorough [s]"), ("gain_fast_pct", "fast gain over G2 [%]"),
           ("gain_thorough_pct", "thorough gain over G2 [%]"), ("kept_pct", "gain kept [%]"),
           ("fast_cpu_s", "fast CPU [s]"), ("thorough_cpu_s", "thorough CPU [s]"), ("fast_plans", "fast plans")]


def _search(job: tuple[float, float, str]) -> dict:
    """One row searched: (angle [deg], tolerance [m], "fast" | "thorough") -> its record."""
    os.nice(10)
    from pathmotion.errors import PathmotionError
    from pathmotion.planning import blend_search as bs
    from pathmotion.robot.model import load_robot
    from pathmotion.study.atlas import _settings, _task, corner_points

    angle, tol, kind = job
    robot, task = load_robot("irb140"), _task(corner_points(angle))
    t0 = time.process_time()
    try:
        best = bs.optimal_blends(robot, task, tol, settings=_settings(False, verify=False, baselines=False),
                                 search=bs.SEARCHES[kind])
    except PathmotionError as exc:
        return {"angle_deg": angle, "tolerance_m": tol, "search": kind, "error": str(exc)}
    return {"angle_deg": angle, "tolerance_m": tol, "search": kind, "duration_s": best.duration,
            "g2_s": best.symmetric_duration, "plans": best.plans, "cpu_s": time.process_time() - t0}


def _warm_up() -> None:
    """Each worker searches one corner untimed first: imports, the compiled kernels' loading (their compilation
    where no cache exists yet) and first-call costs do not land on the first timed row."""
    _search((90.0, 0.001, "fast"))


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


def _given_thorough(path: Path, keys: set) -> tuple[list[dict], str]:
    """The thorough search's records of the rows ``keys`` {(angle, tolerance)} from ``path``, and its source."""
    doc = json.loads(path.read_text())
    found = {(float(r["angle_deg"]), float(r["tolerance_m"])): r["thorough_s"] for r in doc["rows"]}
    missing = sorted(k for k in keys if k not in found)
    if missing:
        raise SystemExit(f"{path}: no thorough duration for the rows {missing}; run without --thorough-from")
    return [{"angle_deg": a, "tolerance_m": t, "search": "thorough", "duration_s": found[(a, t)], "cpu_s": None,
             "plans": None} for a, t in sorted(keys)], doc.get("source", str(path))


def _print(rows: list[dict]) -> None:
    print(f"{'angle':>6} {'tol [mm]':>8} | {'G2 [s]':>8} {'fast [s]':>9} {'thorough [s]':>12} | {'gain fast %':>11} "
          f"{'thorough %':>10} {'kept %':>7} | {'cpu fast':>8} {'thorough':>8} {'plans':>5}")
    for r in rows:
        f, t = r["fast"], r["thorough"]
        if "g2_s" not in r:
            print(f"{r['angle_deg']:6g} {r['tolerance_m'] * 1e3:8g} | {f.get('error') or t.get('error')}")
            continue
        kept = "-" if r["kept_pct"] is None else f"{r['kept_pct']:.1f}"
        cpu_t = "-" if t.get("cpu_s") is None else f"{t['cpu_s']:.1f}"
        print(f"{r['angle_deg']:6g} {r['tolerance_m'] * 1e3:8g} | {r['g2_s']:8.5f} {f['duration_s']:9.5f} "
              f"{t['duration_s']:12.5f} | {r['gain_fast_pct']:11.3f} {r['gain_thorough_pct']:10.3f} {kept:>7} | "
              f"{f['cpu_s']:8.2f} {cpu_t:>8} {f['plans']:>5}")


def _summary(done: list[dict]) -> str:
    gf = sum(r["g2_s"] - r["fast"]["duration_s"] for r in done)
    gt = sum(r["g2_s"] - r["thorough"]["duration_s"] for r in done)
    cpu = [r["fast"]["cpu_s"] for r in done]
    kept = [r["kept_pct"] for r in done if r["kept_pct"] is not None]
    return (f"{len(done)} rows: the fast search keeps {100 * gf / gt:.1f} % of the thorough search's summed gain over "
            f"G2 (per row {min(kept):.1f}-{max(kept):.1f} %, {sum(k >= 95.0 for k in kept)} rows at 95 % or more); "
            f"fast CPU per corner mean {statistics.mean(cpu):.2f} s, median {statistics.median(cpu):.2f} s "
            f"(range {min(cpu):.2f}-{max(cpu):.2f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angles", default="30,60,90,120,150", help="turn angles [deg], comma-separated")
    ap.add_argument("--tolerances", default="0.0001,0.001,0.005,0.01", help="tolerances [m], comma-separated")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--thorough-from", type=Path, default=None,
                    help="JSON file of the thorough search's durations (then only the fast search runs)")
    ap.add_argument("--json", type=Path, default=None, help="write the table here (benchmarks/result_json.py)")
    a = ap.parse_args()
    from result_json import Table

    table = Table("The fast optimal-blend search against the thorough one on the corner atlas' rows", COLUMNS)
    keys = {(float(an), float(t)) for an in a.angles.split(",") for t in a.tolerances.split(",")}
    kinds = ("fast",) if a.thorough_from else ("thorough", "fast")
    jobs = [(an, t, kind) for an, t in sorted(keys) for kind in kinds]
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores), {a.workers} workers, niced")
    with ProcessPoolExecutor(a.workers, initializer=_warm_up) as pool:
        records = list(pool.map(_search, jobs))
    source = None
    if a.thorough_from:
        given, source = _given_thorough(a.thorough_from, keys)
        records += given
    rows = _rows(records)
    _print(rows)
    done = [r for r in rows if "g2_s" in r]
    for r in done:
        f, t = r["fast"], r["thorough"]
        table.add(angle_deg=r["angle_deg"], tolerance_mm=round(r["tolerance_m"] * 1e3, 6), g2_s=round(r["g2_s"], 5),
                  fast_s=round(f["duration_s"], 5), thorough_s=round(t["duration_s"], 5),
                  gain_fast_pct=round(r["gain_fast_pct"], 3), gain_thorough_pct=round(r["gain_thorough_pct"], 3),
                  kept_pct=None if r["kept_pct"] is None else round(r["kept_pct"], 1),
                  fast_cpu_s=round(f["cpu_s"], 2), thorough_cpu_s=None if t["cpu_s"] is None else round(t["cpu_s"], 1),
                  fast_plans=f["plans"])
    if done:
        table.notes.append(_summary(done))
        print(table.notes[-1])
    if source:
        table.notes.append(f"Thorough durations from {a.thorough_from}: {source}")
    table.notes.append("CPU time of each search in its own niced process (user + system); the machine is shared, "
                       "so the load average is given above.")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")
    if a.json is not None:
        print(f"wrote {table.write(a.json)}")


if __name__ == "__main__":
    main()
