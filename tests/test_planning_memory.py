"""A plan's memory is estimated before its grid is built: a grid beyond what the run may use is refused with
the estimate and the largest size that fits (exit 1, never a MemoryError), and the estimate is an upper
bound of what the planner holds (measured with tracemalloc, fixed and adaptive grids)."""

import re
import tracemalloc

import pytest
from typer.testing import CliRunner

import pathmotion as pm
from pathmotion import defaults
from pathmotion.cli import app
from pathmotion.errors import ScenarioError
from pathmotion.io import memory

from reliability_cases import LINE

runner = CliRunner()


def _zigzag(segments: int) -> str:
    pts = [[0.5 + 0.01 * (i % 2), -0.1 + 0.2 * i / segments, 0.5] for i in range(segments + 1)]
    return f'name = "zigzag"\n[path]\ntype = "waypoints"\npoints = {pts}\nblend_tolerance = 0.0\n'


def test_a_grid_beyond_the_budget_is_refused_with_the_largest_that_fits(tmp_path, monkeypatch):
    monkeypatch.setattr(memory, "available_bytes", lambda: 2**30)
    scenario = tmp_path / "line.toml"
    scenario.write_text(LINE)
    res = runner.invoke(app, ["check", str(scenario), "--set", "plan.grid_points=1000000"])
    assert res.exit_code == 1, res.output
    largest = int((2**30 * defaults.MEMORY_FRACTION - defaults.PLAN_MEMORY_BASE)
                  // (defaults.PLAN_BYTES_PER_POINT_JOINT * 6))
    assert f"give plan.grid_points <= {largest:,}" in res.output and "GiB" in res.output
    need = (defaults.PLAN_MEMORY_BASE + 1_000_000 * 6 * defaults.PLAN_BYTES_PER_POINT_JOINT) / 2**30
    assert re.search(r"plan.grid_points = 1,000,000 \(a grid of 1,000,0\d\d points\) needs about "
                     + f"{need:.3g}"[:3], res.output), res.output
    monkeypatch.setattr(memory, "available_bytes", lambda: 2**20)  # the adaptive grid: names the segments
    with pytest.raises(ScenarioError, match="adaptive planner grid of .* points for 1 segments.*at most 0 segments"):
        pm.plan_scenario(pm.load_text(LINE.replace("grid_points = 60", ""), tmp_path))


def test_a_5000_digit_integer_is_an_input_error(tmp_path):
    scenario = tmp_path / "line.toml"
    scenario.write_text(LINE)
    res = runner.invoke(app, ["check", str(scenario), "--set", "plan.grid_points=" + "9" * 5000])
    assert res.exit_code == 1 and "--set plan.grid_points" in res.output and "5,000 characters" in res.output
    assert len(res.output) < 400
    scenario.write_text(LINE.replace("grid_points = 60", "grid_points = " + "9" * 5000))
    res = runner.invoke(app, ["check", str(scenario)])
    assert res.exit_code == 1 and "more than 4,300 digits" in res.output


@pytest.mark.parametrize("text", [LINE.replace("grid_points = 60", "grid_points = 3000"), _zigzag(30)])
def test_the_estimate_bounds_what_the_planner_holds(tmp_path, text):
    setup = pm.load_text(text, tmp_path)
    tracemalloc.start()
    try:
        result = pm.plan_scenario(setup)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < defaults.PLAN_MEMORY_BASE + result.grid_points * setup.robot.n * defaults.PLAN_BYTES_PER_POINT_JOINT
