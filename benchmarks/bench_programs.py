"""Program scale: what `pathmotion check` and `pathmotion plan` cost on generated contour programs of 10, 100,
1,000 and 10,000 moves (benchmarks/program_contour.py: 12 mm moves, 90 deg corners, a G2 blend within 0.5 mm at
every corner), and what the optimal blends cost per corner and gain over the G2 blends.

Each command runs as its own process (the CLI, as a user runs it), niced, with an empty controller cache (check
designs the closed loop afresh); its wall time, its CPU time (user + system,
the honest measure on a shared machine) and its peak resident memory come from the kernel (wait4). The per-segment
columns and the ratio of each size's CPU per segment to the smallest size's say whether the cost grows linearly.
The optimal rows plan the same contour with `type = "optimal"` (search = fast, then thorough on the smallest) and
report (their CPU - the G2 plan's CPU) / corners and the cycle time gained over G2.

The table is written with --json in the format of benchmarks/result_json.py (docs/results.md, `make results`):

    nice python benchmarks/bench_programs.py --sizes 10,100,1000,10000 --optimal-sizes 0 \
        --json benchmarks/results/programs.json
    python benchmarks/bench_programs.py --sizes 10,100 --optimal-sizes 10 --workers 2
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from program_contour import scenario  # noqa: E402
from result_json import Table, load_average  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def _measured(args: list[str], timeout: float) -> dict:
    """One CLI run, niced: wall [s], cpu [s] (user + system) and peak resident memory [MiB] of that process (wait4),
    its exit code and last stderr line."""
    import threading

    # an empty controller cache (control/design_cache.py) per command: check designs the closed loop as on a first
    # run, not read from an earlier run's entry
    cache = tempfile.TemporaryDirectory(prefix="pathmotion-cache-")
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", PATHMOTION_CACHE_DIR=cache.name)
    with cache, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        # nice -n 10 python ...: nice execs python, so the waited process is the run itself
        proc = subprocess.Popen(["nice", "-n", "10", sys.executable, "-m", "pathmotion.cli", *args], cwd=ROOT,
                                env=env, stdout=subprocess.DEVNULL, stderr=err)
        timer = threading.Timer(timeout, proc.kill)
        timer.start()
        _, status, usage = os.wait4(proc.pid, 0)
        timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        err.seek(0)
        last = err.read().strip().splitlines()[-1:]
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "peak_mib": usage.ru_maxrss / 1024.0,
            "exit": proc.returncode, "stderr": last}


def _summary(folder: Path) -> dict:
    f = folder / "summary.json"
    return json.loads(f.read_text()) if f.is_file() else {}


def _duration(folder: Path) -> float | None:
    return _summary(folder).get("duration_s")


def program_row(n: int, tmp: Path, timeout: float) -> dict:
    """check and plan of the N-move G2 contour, with the load average before each, the plan's grid points, duration
    and estimated duration error."""
    toml = tmp / f"contour{n}.toml"
    toml.write_text(scenario(n, "g2", 0.0005))
    load = load_average()
    check = _measured(["check", str(toml)], timeout)
    plan = _measured(["plan", str(toml), "--out", str(tmp / f"plan{n}"), "--no-figures"], timeout)
    s = _summary(tmp / f"plan{n}")
    return {"segments": n, "load": load, "check": check, "plan": plan, "duration_s": s.get("duration_s"),
            "grid_points": s.get("grid_points"), "error_estimate_s": s.get("duration_error_estimate")}


def optimal_row(n: int, tmp: Path, timeout: float, search: str, workers: int, g2: dict) -> dict:
    """plan of the N-move contour with optimal blends (``search``), against its G2 plan ``g2`` (a program_row)."""
    toml = tmp / f"contour{n}_{search}.toml"
    toml.write_text(scenario(n, "optimal", 0.0005, search))
    run = _measured(["plan", str(toml), "--out", str(tmp / f"opt{n}{search}"), "--no-figures",
                     "--workers", str(workers)], timeout)
    T, T_g2, corners = _duration(tmp / f"opt{n}{search}"), g2["duration_s"], n - 1
    extra = None if run["cpu_s"] is None or g2["plan"]["cpu_s"] is None else run["cpu_s"] - g2["plan"]["cpu_s"]
    return {"segments": n, "search": search, "workers": workers, "plan": run, "duration_s": T, "g2_duration_s": T_g2,
            "cpu_per_corner_s": None if extra is None else extra / corners,
            "gain_over_g2_pct": None if T is None or T_g2 is None else 100.0 * (T_g2 - T) / T_g2}


def _f(v, fmt="{:.1f}"):
    return "-" if v is None else fmt.format(v)


def print_table(rows: list[dict], optimal: list[dict]) -> None:
    print(f"{'segments':>8} | {'check wall':>10} {'cpu':>7} {'MiB':>6} | {'plan wall':>9} {'cpu':>7} {'MiB':>6} | "
          f"{'plan cpu/seg [ms]':>17} {'ratio':>6} | exit")
    pbase = next((r["plan"]["cpu_s"] / r["segments"] for r in rows if r["plan"]["cpu_s"]), None)
    for r in rows:
        c, p, n = r["check"], r["plan"], r["segments"]
        per = None if p["cpu_s"] is None else 1e3 * p["cpu_s"] / n
        ratio = None if per is None or not pbase else per / (1e3 * pbase)
        print(f"{n:>8} | {_f(c['wall_s']):>10} {_f(c['cpu_s']):>7} {_f(c['peak_mib'], '{:.0f}'):>6} | "
              f"{_f(p['wall_s']):>9} {_f(p['cpu_s']):>7} {_f(p['peak_mib'], '{:.0f}'):>6} | {_f(per, '{:.2f}'):>17} "
              f"{_f(ratio, '{:.2f}'):>6} | {c['exit']}/{p['exit']}")
    if optimal:
        print(f"\n{'segments':>8} {'search':>9} {'workers':>7} | {'plan wall':>9} {'cpu':>7} | {'cpu/corner [s]':>14} | "
              f"{'T [s]':>9} {'T G2 [s]':>9} {'gain %':>7}")
        for o in optimal:
            print(f"{o['segments']:>8} {o['search']:>9} {o['workers']:>7} | {_f(o['plan']['wall_s']):>9} "
                  f"{_f(o['plan']['cpu_s']):>7} | {_f(o['cpu_per_corner_s'], '{:.2f}'):>14} | "
                  f"{_f(o['duration_s'], '{:.4f}'):>9} {_f(o['g2_duration_s'], '{:.4f}'):>9} "
                  f"{_f(o['gain_over_g2_pct'], '{:.2f}'):>7}")


COLUMNS = [("segments", "segments"), ("load", "load avg"), ("check_wall_s", "check wall [s]"),
           ("check_cpu_s", "check CPU [s]"), ("check_peak_mib", "check peak [MiB]"), ("plan_wall_s", "plan wall [s]"),
           ("plan_cpu_s", "plan CPU [s]"), ("plan_peak_mib", "plan peak [MiB]"),
           ("plan_cpu_per_segment_ms", "plan CPU / segment [ms]"), ("grid_points", "grid points"),
           ("duration_s", "cycle [s]"), ("error_estimate_pct", "duration error estimate [%]"),
           ("exit", "exit check/plan")]


def _r(v, digits=2):
    return None if v is None else round(float(v), digits)


def table_row(r: dict) -> dict:
    """One program row in the result_json columns (COLUMNS)."""
    c, p, n, T, e = r["check"], r["plan"], r["segments"], r["duration_s"], r["error_estimate_s"]
    return {"segments": n, "load": _r(r["load"]), "check_wall_s": _r(c["wall_s"], 1), "check_cpu_s": _r(c["cpu_s"], 1),
            "check_peak_mib": _r(c["peak_mib"], 0), "plan_wall_s": _r(p["wall_s"], 1), "plan_cpu_s": _r(p["cpu_s"], 1),
            "plan_peak_mib": _r(p["peak_mib"], 0), "plan_cpu_per_segment_ms": _r(1e3 * p["cpu_s"] / n, 1),
            "grid_points": r["grid_points"], "duration_s": _r(T, 4),
            "error_estimate_pct": None if T is None or e is None else _r(100 * e / T, 3),
            "exit": f"{c['exit']}/{p['exit']}"}


TITLE = "Program scale: check and plan of the generated contour (G2 blends within 0.5 mm)"


def write_json(table: Table, path: Path, rows: list[dict], optimal: list[dict]) -> None:
    """The program rows into ``table`` (started before the runs), the optimal rows, if any, as its notes."""
    for r in rows:
        table.add(**table_row(r))
    table.notes.append("Each command is a niced CLI process with an empty controller cache; CPU is user + system, "
                       "peak is its maximum resident "
                       "memory (wait4). The contour: benchmarks/program_contour.py (12 mm moves, 90 deg corners).")
    for o in optimal:
        table.notes.append(f"optimal blends, {o['segments']} segments, search {o['search']}, {o['workers']} workers: "
                           f"{_f(o['cpu_per_corner_s'], '{:.2f}')} s CPU per corner, cycle "
                           f"{_f(o['duration_s'], '{:.4f}')} s against G2 {_f(o['g2_duration_s'], '{:.4f}')} s "
                           f"({_f(o['gain_over_g2_pct'], '{:.2f}')} % gain)")
    print(f"wrote {table.write(path)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="10,100,1000,10000", help="moves per program, comma-separated")
    ap.add_argument("--optimal-sizes", default="10", help="sizes also planned with optimal blends")
    ap.add_argument("--thorough", action="store_true", help="the optimal rows with search = thorough as well")
    ap.add_argument("--workers", type=int, default=1, help="plan --workers of the optimal rows")
    ap.add_argument("--timeout", type=float, default=3600.0, help="per command [s]")
    ap.add_argument("--json", type=Path, default=None, help="write the rows to this JSON file")
    a = ap.parse_args()
    sizes = sorted(int(v) for v in a.sizes.split(","))
    opt_sizes = {int(v) for v in a.optimal_sizes.split(",") if v}
    table = Table(TITLE, COLUMNS)
    load0 = os.getloadavg()[0]
    print(f"load average at start: {load0:.2f} ({os.cpu_count()} cores); commands niced")
    rows, optimal = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            rows.append(program_row(n, Path(tmp), a.timeout))
            for search in ("fast", "thorough") if a.thorough else ("fast",):
                if n in opt_sizes:
                    optimal.append(optimal_row(n, Path(tmp), a.timeout, search, a.workers, rows[-1]))
    load1 = os.getloadavg()[0]
    print_table(rows, optimal)
    print(f"load average at end: {load1:.2f}")
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        write_json(table, a.json, rows, optimal)


if __name__ == "__main__":
    main()
