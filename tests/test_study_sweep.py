"""Sweeps: --set parsing and the point grid, resuming, failing points, tables and figures."""

from __future__ import annotations

import csv
import itertools
import json

import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.errors import ScenarioError
from pathmotion.scenarios import scenario_path
from pathmotion.study import SUMMARY_KEYS, parse_sets, run_point, run_study_sweep, sweep_points
from pathmotion.io.scenario import parse_value
from pathmotion.study.sweep import run_sweep

RADIUS = "path.blends[0].radius"
GRID = "plan.grid_points"


# ------------------------------------------------------------------------------------ parsing
def test_parse_values():
    assert parse_value("3") == 3 and isinstance(parse_value("3"), int)
    assert parse_value(" 0.04 ") == 0.04
    assert parse_value("TRUE") is True and parse_value("false") is False
    assert parse_value("orbital") == "orbital"
    with pytest.raises(ScenarioError, match="finite"):
        parse_value("nan")


def test_parse_sets():
    grid = parse_sets(["path.blends[0].radius=0.03,0.04", "simulate.controller=orbital,pd_gravity", "plan.grid_points=300"])
    assert grid == {RADIUS: [0.03, 0.04], "simulate.controller": ["orbital", "pd_gravity"], GRID: [300]}
    assert parse_sets(["path.segments[0].center=[0.5, 0, 0.5],[0.6, 0, 0.5]"]) == {
        "path.segments[0].center": [[0.5, 0, 0.5], [0.6, 0, 0.5]]}
    for bad, match in ((["radius"], "expected NAME=V1"), (["a=1", "a=2"], "given twice"), (["a="], "at least one"),
                       ([], "at least one --set"), (["a=1,1"], "repeated")):
        with pytest.raises(ScenarioError, match=match):
            parse_sets(bad)


@settings(max_examples=50, deadline=None)
@given(st.dictionaries(st.sampled_from(["a", "b.c", "d[0].e", "f"]),
                       st.lists(st.integers(-5, 5), min_size=1, max_size=4, unique=True), max_size=4))
def test_points_are_the_cartesian_product(grid):
    points = sweep_points(grid, "digest")
    expected = list(itertools.product(*grid.values()))
    assert len(points) == len(expected)
    # same order as itertools.product (last name fastest), every combination once, indices 0..n-1
    assert [tuple(v for _, v in p.overrides) for p in points] == expected
    assert [p.index for p in points] == list(range(len(expected)))
    assert all([k for k, _ in p.overrides] == list(grid) for p in points)
    assert len({p.key for p in points}) == len(points)


def test_point_key_depends_on_scenario_and_overrides():
    a = sweep_points({"x": [1, 2]}, "s1")
    b = sweep_points({"x": [1, 2]}, "s2")
    assert a[0].key == sweep_points({"x": [1]}, "s1")[0].key
    assert a[0].key != a[1].key and a[0].key != b[0].key


# ------------------------------------------------------------------------------- running
def _read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_resume_failure_and_tables(tmp_path):
    """Run 3 points (one with an r_t too large for the corner), delete one finished point, re-run:
    only that point is recomputed, the table is identical, the failing point is a row with its
    error and the others are intact."""
    calls = []

    def counting(text, base_dir, overrides, traces=False):
        calls.append(dict(overrides))
        return run_point(text, base_dir, overrides, traces)

    grid = {RADIUS: [0.03, 0.2, 0.04], GRID: [300]}
    out = tmp_path / "sweep"
    progress = []
    outcome = run_study_sweep(scenario_path("corner_transition"), grid, out, workers=1, figures=True,
                              on_result=lambda d, n: progress.append((d, n)))
    assert progress[0] == (0, 3) and progress[-1] == (3, 3)
    rows = outcome.rows
    assert [r[RADIUS] for r in rows] == [0.03, 0.2, 0.04]
    assert rows[1]["error"].startswith("PathError") and "0.2 m does not fit" in rows[1]["error"]
    assert all(rows[1][k] is None for k in SUMMARY_KEYS)
    for r in (rows[0], rows[2]):
        assert r["error"] is None and r["tracking_ok"] is True and r["cycle_time_s"] > 0
        # the TCP leaves the sharp path by about the blend's own deviation, and tracks the blend closely
        assert r["max_sharp_deviation_m"] == pytest.approx(r["blend_max_deviation_m"], abs=1e-3)
        assert r["path_accuracy_m"] < 1e-3
    # larger r_t: larger deviation, shorter cycle (the thesis' trade-off)
    assert rows[2]["max_sharp_deviation_m"] > rows[0]["max_sharp_deviation_m"]
    assert rows[2]["cycle_time_s"] < rows[0]["cycle_time_s"]

    header, *body = _read_csv(out / "sweep.csv")
    assert header == [RADIUS, GRID, *SUMMARY_KEYS, "error"]
    assert len(body) == 3 and body[1][-1].startswith("PathError")
    table = pq.read_table(out / "sweep.parquet").to_pylist()
    assert [t["cycle_time_s"] for t in table] == [r["cycle_time_s"] for r in rows]
    best = json.loads((out / "best.json").read_text())
    assert best["index"] == outcome.best["index"] and best["score"] == outcome.best["score"]
    assert (out / "tradeoff.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    first_csv = (out / "sweep.csv").read_text()

    # delete the last point's file: a re-run recomputes only that point, the table is the same
    victim = outcome.points[2]
    (out / "points" / f"{victim.key}.json").unlink()
    _, again = run_sweep(scenario_path("corner_transition"), grid, out, workers=1, point_fn=counting)
    assert calls == [{RADIUS: 0.04, GRID: 300}]
    assert again == rows
    assert (out / "sweep.csv").read_text() == first_csv
    # a full re-run computes nothing
    run_sweep(scenario_path("corner_transition"), grid, out, workers=1, point_fn=counting)
    assert len(calls) == 1


def crashing_point(text, base_dir, overrides, traces=False):
    """A point function for the process executor: crashes on one point, a fixed row otherwise."""
    if dict(overrides)[GRID] == 11:
        raise RuntimeError("boom")
    return {"summary": {k: None for k in SUMMARY_KEYS} | {"tracking_ok": True, "cycle_time_s": 1.0},
            "error": None, "trace": None}


def test_crashed_point_is_a_row(tmp_path):
    """A point whose worker raises is recorded with the error; the other points finish."""
    _, rows = run_sweep(scenario_path("corner_stop"), {GRID: [10, 11, 12]}, tmp_path, workers=2,
                        point_fn=crashing_point)
    assert [r["error"] is None for r in rows] == [True, False, True]
    assert "RuntimeError: boom" in rows[1]["error"]
    assert rows[0]["cycle_time_s"] == 1.0 and rows[1]["cycle_time_s"] is None


def test_run_point_records_errors():
    """run_point turns a pathmotion error into the row's error, naming the error class."""
    text = scenario_path("corner_transition").read_text()
    res = run_point(text, str(scenario_path("corner_transition").parent), ((RADIUS, 0.2),))
    assert res["error"].startswith("PathError:") and res["trace"] is None
    assert set(res["summary"]) == set(SUMMARY_KEYS)
    res = run_point(text, ".", (("plan.grid_points", "many"),))
    assert res["error"].startswith("ScenarioError:") and "plan.grid_points" in res["error"]


def test_unreadable_scenario(tmp_path):
    with pytest.raises(ScenarioError, match=r"missing.toml does not exist"):
        run_study_sweep(tmp_path / "missing.toml", {GRID: [300]}, tmp_path / "o")
