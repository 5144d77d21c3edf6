"""``pathmotion demo``: plan and simulate shipped scenarios, one summary row each."""

from __future__ import annotations

from pathlib import Path

from ..io import schema
from ..io.atomic import write_text
from ..scenarios import scenario_path
from .plan import plan_scenario, write_plan
from .searches import search
from .setup import load
from .simulate import simulate_scenario, write_simulation

DEMO_SCENARIOS = ("circle_max", "corner_stop", "corner_max", "corner_transition", "corner_g2")
DEMO_COLUMNS = schema.keys(schema.DEMO)


def run_shipped(name: str, out: str | Path) -> dict:
    """Plan and simulate a shipped scenario into ``out`` (plan in out/plan); its summary row."""
    setup = search(load(scenario_path(name)))
    result = plan_scenario(setup)
    write_plan(setup, result, Path(out) / "plan")
    sim = simulate_scenario(setup, result)
    summary = write_simulation(setup, result, sim, out)
    row = {"scenario": name}
    row.update({k: v for k, v in summary.items() if k != "plan"})
    row[schema.BASELINE_DURATION.key] = summary["plan"][schema.BASELINE_DURATION.key]
    return row


def write_demo_table(rows: list[dict], out: str | Path) -> Path:
    """demo.csv with DEMO_COLUMNS, one row per scenario."""
    out = Path(out)
    lines = [",".join(DEMO_COLUMNS)]
    for r in rows:
        lines.append(",".join("" if r.get(c) is None else str(r.get(c)) for c in DEMO_COLUMNS))
    return write_text(out / "demo.csv", "\n".join(lines) + "\n")
