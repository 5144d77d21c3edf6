"""The IRB140 results the README quotes, measured with the code as it is.

Parts (each writes one JSON table with --json PATH, read by benchmarks/results.py):
- demo: the shipped scenarios `make demo` runs (api.DEMO_SCENARIOS), planned and simulated exactly as
  `pathmotion demo` does (api.run_shipped): planned duration, cycle time, path accuracy, largest joint
  deviation, distance from the sharp path, verdict.
- cycle: ABB's standard cycle as RAPID programs (tests/data/abb_cycle*.mod: fine points, z1, z10, z50)
  imported with the symmetric G2 blend at each zone and planned: time-optimal duration against the
  program's constant-speed estimate (rapid_estimate_s).
- study: the corner study `make demo` runs after the scenarios (study.corner_study with its defaults): the stop,
  the corner at full speed, transition circles, slowed blends, G2 blends and circles of the same deviation.
- optimal: the z10 program imported with `--blend optimal` and planned; its duration against the
  symmetric blend, and the CPU and wall time of the whole plan (search included).
Run: python benchmarks/bench_irb140.py demo --json benchmarks/results/irb140_demo.json
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from result_json import Table

from pathmotion import api
from pathmotion.io import schema
from pathmotion.io.rapid import read_rapid, scenario_toml

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = (("fine points", "abb_cycle_fine.mod"), ("z1", "abb_cycle_z1.mod"), ("z10", "abb_cycle.mod"),
            ("z50", "abb_cycle_z50.mod"))


def _mm(v):
    return None if v is None else round(v * 1e3, 4)


def demo(table: Table) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for name in api.DEMO_SCENARIOS:
            r = api.run_shipped(name, Path(tmp) / name)
            fail = r.get(schema.FAILURE.key) or {}
            table.add(scenario=name, planned_s=round(r[schema.PLANNED_DURATION.key], 4),
                      cycle_s=None if r.get(schema.CYCLE_TIME.key) is None else round(r[schema.CYCLE_TIME.key], 4),
                      accuracy_mm=_mm(r.get(schema.PATH_ACCURACY.key)),
                      joint_dev_rad=float(f"{r[schema.MAX_JOINT_DEVIATION.key]:.2g}"),
                      sharp_mm=_mm(r.get(schema.MAX_SHARP_DEVIATION.key)),
                      result="tracks" if r[schema.TRACKING_OK.key] else
                      f"fails: leaves the path tolerance, {_mm(fail.get('value'))} mm off"
                      if fail.get("reason") == "path_tolerance" else f"fails: {fail.get('reason')}")


def study(table: Table) -> None:
    from pathmotion.study import corner_study

    with tempfile.TemporaryDirectory() as tmp:
        result = corner_study(Path(tmp) / "corner_study", workers=2)
    for r in result.rows:
        cyc, planned = r.get(schema.CYCLE_TIME.key), r.get(schema.PLANNED_DURATION.key)
        value = r.get("value")
        table.add(case=r["case"], parameter=r["parameter"] + ("" if value is None else f" = {value:.4g}"),
                  cycle_s=None if cyc is None else round(cyc, 4),
                  planned_s=None if planned is None else round(planned, 4),
                  gain=None if r.get("gain_vs_stop") is None else f"{100 * r['gain_vs_stop']:.1f} %",
                  sharp_mm=_mm(r.get(schema.MAX_SHARP_DEVIATION.key)), accuracy_mm=_mm(r.get(schema.PATH_ACCURACY.key)),
                  tracks="yes" if r.get(schema.TRACKING_OK.key) else "no")


def _plan_program(mod: str, blend: str, tmp: Path, search: str | None = None) -> tuple[dict, float, float]:
    """Import ``mod`` with ``blend`` at each zone (optimal blends searched by ``search``: None = the scenario's
    default) and plan it: (summary, wall [s], CPU [s] of load, search and plan)."""
    prog = read_rapid(ROOT / "tests" / "data" / mod)
    scenario = tmp / f"{Path(mod).stem}_{blend}_{search}.toml"
    text = scenario_toml(prog, api.rapid_zone_tolerances(prog), blend=blend)
    if search is not None:
        text = text.replace('type = "optimal"', f'type = "optimal"\nsearch = "{search}"')
    scenario.write_text(text)
    wall, cpu = time.perf_counter(), time.process_time()
    setup = api.search(api.load(scenario))  # the optimal blends are searched here (none for g2 blends)
    summary = api.write_plan(setup, api.plan_scenario(setup), tmp / scenario.stem)
    return summary, time.perf_counter() - wall, time.process_time() - cpu


def cycle(table: Table) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for label, mod in PROGRAMS:
            s, _, _ = _plan_program(mod, "g2", Path(tmp))
            table.add(program=label, optimal_s=round(s["duration_s"], 4),
                      rapid_estimate_s=round(s[schema.RAPID_ESTIMATE.key], 4),
                      command=f"pathmotion import-rapid tests/data/{mod} --out c.toml && pathmotion plan c.toml "
                              "--out out/c")


def optimal(table: Table) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for blend, search in (("g2", None), ("optimal", "fast"), ("optimal", "thorough")):
            s, wall, cpu = _plan_program("abb_cycle.mod", blend, Path(tmp), search)
            table.add(blend=blend if search is None else f'{blend}, search = "{search}"',
                      duration_s=round(s["duration_s"], 4), wall_s=round(wall, 1), cpu_s=round(cpu, 1))


PARTS = {"demo": (demo, "The shipped scenarios of `make demo` (orbital controller at 4 ms, nominal plant)",
                  [("scenario", "scenario"), ("planned_s", "planned [s]"), ("cycle_s", "cycle time [s]"),
                   ("accuracy_mm", "path accuracy [mm]"), ("joint_dev_rad", "max joint deviation [rad]"),
                   ("sharp_mm", "from the sharp path [mm]"), ("result", "result")]),
         "cycle": (cycle, "ABB's standard cycle: time-optimal against the program's constant-speed estimate",
                   [("program", "program"), ("optimal_s", "time-optimal [s]"),
                    ("rapid_estimate_s", "constant speed v1000, ideal [s]"), ("command", "command")]),
         "study": (study, "The corner study of `make demo` (IRB140, the shipped corner, orbital controller at 4 ms)",
                   [("case", "case"), ("parameter", "parameter"), ("cycle_s", "cycle time [s]"),
                    ("planned_s", "planned [s]"), ("gain", "gain vs stop"), ("sharp_mm", "from the sharp path [mm]"),
                    ("accuracy_mm", "path accuracy [mm]"), ("tracks", "tracks")]),
         "optimal": (optimal, "The z10 cycle with symmetric G2 blends and with optimal blends (`--blend optimal`)",
                     [("blend", "blend"), ("duration_s", "duration [s]"), ("wall_s", "plan wall time [s]"),
                      ("cpu_s", "plan CPU time [s]")])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", choices=list(PARTS))
    ap.add_argument("--json", type=Path, help="write the table as JSON here (for benchmarks/results.py)")
    args = ap.parse_args()
    run, title, columns = PARTS[args.part]
    table = Table(title, columns)
    run(table)
    for row in table.rows:
        print(row)
    if args.json:
        print(f"wrote {table.write(args.json)}")


if __name__ == "__main__":
    main()
