"""The HTML report: discovery of result folders, the page's content, and the page itself rendered in
headless Chromium (offline, no console errors, every figure drawn, the arm animation playing)."""

from __future__ import annotations

import json
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion import api
from pathmotion.errors import PathmotionError
from pathmotion.report import interactive
from pathmotion.robot.arm import arm_points
from pathmotion.report.discovery import discover
from pathmotion.report.html import _matching_row, build_report, sweep_parameters
from pathmotion.report.tables import read_rows
from pathmotion.scenarios import scenario_path

CHROMIUM = Path("/usr/bin/chromium")
# The 7 MB report loads in 12 s on an idle 2-core CI machine and 17 s beside two busy cores; beside the rest of the
# suite on the other xdist worker it once took over playwright's default 30 s. A hang still fails, in 2 minutes.
PAGE_LOAD_TIMEOUT_MS = 120_000
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: Figures per section: simulation (phase plane, limits, task space, tracking, arm), plan (phase plane,
#: limits, planned TCP path, arm), sweep (trade-off).
SIMULATION_FIGURES, PLAN_FIGURES, SWEEP_FIGURES = 5, 4, 1

SWEEP_HEADER = ("path.blends[0].radius,cycle_time_s,planned_duration_s,settle_time_s,tracking_ok,failure_reason,"
                "max_sharp_deviation_m,mean_sharp_deviation_m,path_accuracy_m,some_future_column,error")
#: A handmade sweep: two competing points (both on the Pareto front), one dominated, one whose
#: tracking failed (no cycle time), one error row.
SWEEP_ROWS = (
    "0.03,1.40,1.39,1.40,true,,0.010,0.0005,6e-5,7,",
    "0.04,1.35,1.34,1.35,true,,0.019,0.0012,8e-5,7,",
    "0.045,1.45,1.44,1.45,true,,0.021,0.0012,9e-5,7,",
    "0.049,,1.30,,false,deviation,0.030,0.0020,0.004,7,",
    '0.2,,,,,,,,,,"PathError: a transition circle of radius 0.2 m does not fit, the largest is 0.05 m"',
)


def _write_sweep(folder: Path, best_index: int | None = 0) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "sweep.csv").write_text("\n".join((SWEEP_HEADER, *SWEEP_ROWS)) + "\n")
    if best_index is not None:
        (folder / "best.json").write_text(json.dumps({"index": best_index, "path.blends[0].radius": 0.03,
                                                      "rule": "score = cycle time + weight * mean deviation"}))
    return folder


def _touch(folder: Path, *names: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for n in names:
        (folder / n).write_text("")
    return folder


# ------------------------------------------------------------------------------------ discovery
def test_discover_plan_only(tmp_path):
    _touch(tmp_path / "p", "trajectory.csv", "phase_plane.csv", "summary.json")
    found = discover(tmp_path)
    assert [(r.kind, r.path) for r in found] == [("plan", tmp_path / "p")]


def test_discover_simulation_claims_its_plan(tmp_path):
    sim = _touch(tmp_path / "sim", "simulation.csv", "summary.json")
    _touch(sim / "plan", "trajectory.csv", "phase_plane.csv", "summary.json")
    found = discover(tmp_path)
    assert len(found) == 1
    assert (found[0].kind, found[0].path, found[0].plan_path) == ("simulation", sim, sim / "plan")


def test_discover_simulation_without_plan_and_nested_results(tmp_path):
    _touch(tmp_path, "simulation.csv", "summary.json")  # the root itself is a result
    _write_sweep(tmp_path / "b_sweep")
    _touch(tmp_path / "b_sweep" / "points", "simulation.csv", "summary.json")  # per-point files are not results
    _touch(tmp_path / "a" / "deep", "trajectory.csv", "phase_plane.csv", "summary.json")
    found = discover(tmp_path)
    assert [(r.kind, r.label(tmp_path)) for r in found] == [("simulation", "."), ("plan", "a/deep"),
                                                            ("sweep", "b_sweep")]
    assert found[0].plan_path is None


def test_discover_incomplete_plan_is_not_a_result(tmp_path):
    _touch(tmp_path / "p", "trajectory.csv", "summary.json")  # no phase_plane.csv
    with pytest.raises(PathmotionError):
        discover(tmp_path)


@pytest.mark.parametrize("make", [lambda p: p, lambda p: _touch(p / "x", "notes.txt").parent])
def test_empty_folder_is_a_one_line_error(tmp_path, make):
    root = make(tmp_path)
    with pytest.raises(PathmotionError) as info:
        build_report(root)
    msg = str(info.value)
    assert "\n" not in msg
    assert f"no plan, simulation or sweep results under {root}" in msg
    assert "run pathmotion plan/simulate/sweep first" in msg
    assert not (root / "report.html").exists()


def test_a_table_without_needed_columns_is_a_one_line_error(tmp_path):
    sim = _touch(tmp_path / "sim", "summary.json")
    (sim / "summary.json").write_text("{}")
    (sim / "simulation.csv").write_text("t,q1\n0,0\n")
    with pytest.raises(PathmotionError) as info:
        build_report(tmp_path)
    assert "simulation.csv has no column(s) ['q_desired1', 'tcp_x'" in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_folder_is_an_error(tmp_path):
    with pytest.raises(PathmotionError, match="is not a folder"):
        build_report(tmp_path / "nope")


def test_cli_report_on_empty_folder_exits_1_with_one_line(tmp_path):
    from typer.testing import CliRunner

    from pathmotion.cli import app

    res = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 1
    assert "no plan, simulation or sweep results" in res.output
    assert "Traceback" not in res.output


# -------------------------------------------------------------------------------- sweep helpers
def test_sweep_parameters_from_spec_and_from_column_order(tmp_path):
    names, rows = read_rows(_write_sweep(tmp_path) / "sweep.csv")
    assert sweep_parameters(names, None) == ["path.blends[0].radius"]
    assert sweep_parameters(names, {"grid": {"path.blends[0].radius": [0.03], "not.a.column": [1]}}) == \
        ["path.blends[0].radius"]
    assert rows[3]["tracking_ok"] is False and rows[3]["cycle_time_s"] is None
    assert rows[4]["error"].startswith("PathError: a transition circle") and rows[4]["cycle_time_s"] is None
    assert rows[0]["some_future_column"] == 7


def test_best_row_matching(tmp_path):
    _, rows = read_rows(_write_sweep(tmp_path) / "sweep.csv")
    params = ["path.blends[0].radius"]
    assert _matching_row(rows, {"index": 1, "path.blends[0].radius": 0.04}, params) == 1
    # a stale index (rows reordered) falls back to the parameters
    assert _matching_row(rows, {"index": 0, "path.blends[0].radius": 0.045}, params) == 2
    assert _matching_row(rows, {"index": None, "path.blends[0].radius": 0.5}, params) is None
    assert _matching_row(rows, None, params) is None


def test_tradeoff_figure_marks_front_best_and_failures(tmp_path):
    from pathmotion.study.score import pareto_front

    _, rows = read_rows(_write_sweep(tmp_path) / "sweep.csv")
    x, y = "max_sharp_deviation_m", "cycle_time_s"
    front = pareto_front(rows, x_key=x, y_key=y)
    assert sorted(front) == [0, 1]  # row 2 is dominated by row 1 (more deviation, more time)
    figure = interactive.tradeoff_figure(rows, x, y, front, 0, lambda r: str(r["path.blends[0].radius"]), "t",
                                         fallback_y_key="planned_duration_s")
    traces = {t.name.split(" (")[0]: t for t in figure.data}
    assert list(traces["Pareto front"].x) == pytest.approx([10.0, 19.0])  # mm, sorted by deviation
    assert list(traces["tracking ok"].text) == ["0.03", "0.04", "0.045"]
    failed = traces["tracking failed"]
    assert list(failed.x) == pytest.approx([30.0]) and list(failed.y) == pytest.approx([1.30])  # planned duration
    assert list(traces["best score"].text) == ["0.03"]
    drawn = [v for t in figure.data if not t.name.startswith(("Pareto", "best")) for v in t.text]
    assert sorted(drawn) == ["0.03", "0.04", "0.045", "0.049"]  # the error row has no values: not drawn


def test_report_of_sweeps_alone_tolerates_other_tables(tmp_path):
    _write_sweep(tmp_path / "a_new", best_index=None)  # no best.json: the study's score chooses
    old = _touch(tmp_path / "b_old")  # an older table: simulated duration and path deviation, wall time
    (old / "sweep.csv").write_text(
        "k.x,controller,simulated_duration_s,path_accuracy_m,tracking_ok,wall_time_s,error\n"
        "1,orbital,2.0,0.004,true,3.1,\n2,orbital,1.5,0.009,true,3.0,\n")
    (_touch(tmp_path / "c_empty") / "sweep.csv").write_text(SWEEP_HEADER + "\n")
    text = build_report(tmp_path).read_text()
    sections = re.findall(r'<section id="s\d+" data-figures="(\d+)"><h2>([^<]+)</h2>', text)
    assert sections == [("1", "Sweep: a_new"), ("1", "Sweep: b_old"), ("1", "Sweep: c_empty")]
    assert "best score (the study's score, no best.json)" in text  # the legend (JSON in the script)
    # score = time + 100 s/m * mean deviation: 1.45 s (#0) < 1.47 s (#1) < 1.57 s (#2)
    assert "Best score (the study&#x27;s score, no best.json): point #0, path.blends[0].radius = 0.03" in text
    assert "over k.x: 2 points: 2 tracked, 0 tracking failed, 0 errors" in text
    assert "largest TCP distance from the original sharp path [mm]" in text


# ------------------------------------------------------------------------------------ decimation
@settings(max_examples=200, deadline=None)
@given(st.integers(1, 20000), st.integers(2, 3000))
def test_decimate_keeps_ends_and_bounds_the_count(n, m):
    idx = interactive.decimate(n, m)
    assert idx[0] == 0 and idx[-1] == n - 1
    assert len(idx) <= max(m, 1) and np.all(np.diff(idx) > 0)
    if n <= m:
        assert np.array_equal(idx, np.arange(n))
    else:  # uniform: no gap more than one step longer than the mean gap
        assert np.max(np.diff(idx)) <= np.ceil((n - 1) / (m - 1))


def test_3d_coordinates_lose_rounding_noise_but_keep_micrometres():
    # plotly.js scales each 3-D axis by 1 / (data span): a flat path with 1e-16 m of noise must be exactly flat
    p = interactive.for_3d([[0.6, 0.0, 0.5], [0.5, 0.1, 0.49999999999999994], [0.4, 0.0, 0.5 + 2e-6]])
    assert p[0, 2] == p[1, 2] == 0.5
    assert p[2, 2] - p[0, 2] == pytest.approx(2e-6)
    scene = interactive.scene_box(p[:2])
    assert scene["zaxis"]["range"][1] - scene["zaxis"]["range"][0] > 0.2 * 0.1  # a flat path keeps some depth
    assert scene["aspectratio"]["x"] == pytest.approx(1.0)


# ------------------------------------------------------------------------------------ arm points
def test_arm_points_at_zero_match_the_irb140_reference(irb140):
    # ABB's IRB140 product specification (docs/robot.md): OPW a1 = 0.070, c1 = 0.352, c2 = 0.360, c3 = 0.380, c4 = 0.065 m.
    p = arm_points(irb140, np.zeros(6))
    assert p.shape == (6 + 3, 3)
    np.testing.assert_allclose(p[0], [0, 0, 0], atol=1e-12)  # base
    np.testing.assert_allclose(p[2], [0.070, 0, 0.352], atol=1e-9)  # joint 2 axis
    np.testing.assert_allclose(p[5], [0.070 + 0.380, 0, 0.352 + 0.360], atol=1e-9)  # wrist centre (joint 5)
    np.testing.assert_allclose(p[-1], [0.070 + 0.380 + 0.065, 0, 0.352 + 0.360], atol=1e-9)  # flange = TCP


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6))
def test_arm_points_are_rigid_and_end_at_the_tcp(irb140, q):
    from pathmotion.robot import fk

    robot = irb140
    q = np.asarray(q)
    p, p0 = arm_points(robot, q), arm_points(robot, np.zeros(6))
    links = np.linalg.norm(np.diff(p, axis=0), axis=1)
    np.testing.assert_allclose(links, np.linalg.norm(np.diff(p0, axis=0), axis=1), atol=1e-9)
    np.testing.assert_allclose(p[-1], fk(robot, q)[0], atol=1e-12)


# --------------------------------------------------------------------------- the real flow's report
@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """A simulation (with its plan) of the shipped corner_g2 on a coarse grid, the same plan alone, a
    copy of the simulation whose tracking "failed" (summary edited), and a handmade sweep."""
    root = tmp_path_factory.mktemp("report")
    setup = api.load(scenario_path("corner_g2"), {"plan.grid_points": 300})
    result = api.plan_scenario(setup)
    api.write_plan(setup, result, root / "g2" / "plan")
    api.write_plan(setup, result, root / "plan_only")
    sim = api.simulate_scenario(setup, result)
    api.write_simulation(setup, result, sim, root / "g2")
    failed = root / "g2_failed"
    shutil.copytree(root / "g2", failed)
    summary = json.loads((failed / "summary.json").read_text())
    summary.update(tracking_ok=False, failure={"reason": "deviation", "t": 0.5, "theta": 0.2,
                                               "message": "joint deviation 0.31 rad above the threshold at t = 0.5 s"})
    (failed / "summary.json").write_text(json.dumps(summary))
    _write_sweep(root / "sweep")
    return root


@pytest.fixture(scope="module")
def report(results):
    return build_report(results)


EXPECTED_FIGURES = 2 * SIMULATION_FIGURES + PLAN_FIGURES + SWEEP_FIGURES


def test_report_page_content(results, report):
    assert report == results / "report.html"
    text = report.read_text()
    from plotly.offline import get_plotlyjs

    js = get_plotlyjs()
    assert text.count(js[:200]) == 1  # plotly.js embedded exactly once
    assert not re.search(r"<script[^>]+src=|<link[^>]+href=|@import|url\(http", text)  # nothing fetched
    assert len(re.findall(r'class="plotly-graph-div"', text)) == EXPECTED_FIGURES
    assert f'content="{EXPECTED_FIGURES}"' in text
    for anchor in re.findall(r'href="#(s\d+)"', text):  # the table of contents points at sections
        assert f'id="{anchor}"' in text
    sections = re.findall(r'<section id="s\d+" data-figures="\d+"><h2>([^<]+)</h2>', text)
    assert sections == ["Simulation: corner_g2 (g2)", "Simulation: corner_g2 (g2_failed)",
                        "Plan: corner_g2 (plan_only)", "Sweep: sweep"]
    assert "5 points: 3 tracked, 1 tracking failed, 1 error" in text  # a failed tracking is not an error
    assert '<p class="failure">Tracking FAILED: joint deviation 0.31 rad above the threshold' in text
    assert text.count('class="failure"') == 1
    summary = json.loads((results / "g2" / "summary.json").read_text())
    assert f"{summary['cycle_time_s']:.4g}" in text
    assert f"{1e3 * summary['max_sharp_deviation_m']:.4g}" in text  # in mm
    assert "PathError: a transition circle of radius 0.2 m does not fit" in text


def test_report_titles_name_the_scenario_and_a_demo_folder_keeps_its_study_order(results, tmp_path):
    import shutil as sh

    own = build_report(results / "plan_only", tmp_path / "own.html").read_text()
    assert "<h2>Plan: corner_g2 (plan_only)</h2>" in own and ": .</" not in own
    demo = tmp_path / "demo"
    for name in ("zz_first", "aa_second"):
        sh.copytree(results / "plan_only", demo / name / "plan")
    (demo / "demo.csv").write_text("scenario,planned_duration_s\nzz_first,1.0\naa_second,1.1\n")
    text = build_report(demo).read_text()
    sections = re.findall(r'<section id="s\d+" data-figures="\d+"><h2>([^<]+)</h2>', text)
    assert sections == ["Plan: corner_g2 (zz_first/plan)", "Plan: corner_g2 (aa_second/plan)"]


def test_best_point_without_varying_parameters_reads_as_a_sentence(tmp_path):
    folder = tmp_path / "one"
    folder.mkdir()
    header, row = SWEEP_HEADER.split(",", 1)[1], SWEEP_ROWS[0].split(",", 1)[1]  # no parameter column
    (folder / "sweep.csv").write_text(f"{header}\n{row}\n")
    (folder / "best.json").write_text(json.dumps({"index": 0}))
    text = build_report(folder).read_text()
    assert "Best score (best.json): point #0 (no parameter varies)." in text


def test_report_is_rewritten_atomically(results, report):
    before = set(results.iterdir())
    build_report(results)
    assert set(results.iterdir()) == before  # no temporary file left behind


def test_report_of_a_folder_without_the_writers_data(results, tmp_path):
    """A plan folder without limits.json/arm.csv (an older writer): the phase plane only, and a note.
    The report never rebuilds the scenario: a scenario.toml naming a missing robot changes nothing."""
    folder = tmp_path / "plan"
    shutil.copytree(results / "plan_only", folder)
    (folder / "scenario.toml").write_text((folder / "scenario.toml").read_text().replace('"irb140"', '"missing.urdf"'))
    assert len(re.findall(r'class="plotly-graph-div"', build_report(tmp_path).read_text())) == PLAN_FIGURES
    (folder / "limits.json").unlink()
    (folder / "arm.csv").unlink()
    text = build_report(tmp_path).read_text()
    assert "no limits.json or arm.csv in this folder" in text
    assert len(re.findall(r'class="plotly-graph-div"', text)) == 1  # the phase plane only


# ---------------------------------------------------------------------------------- the browser
def _browser_check(html: Path, shot: Path, expected_figures: int) -> dict:
    from playwright.sync_api import sync_playwright

    seen = {"errors": [], "external": []}
    with sync_playwright() as p, tempfile.TemporaryDirectory() as user_dir:
        ctx = p.chromium.launch_persistent_context(user_dir, executable_path=str(CHROMIUM), args=CHROMIUM_ARGS,
                                                   headless=True, viewport={"width": 1400, "height": 900})
        try:
            page = ctx.new_page()
            page.on("console", lambda m: m.type == "error" and seen["errors"].append(m.text))
            page.on("pageerror", lambda e: seen["errors"].append(str(e)))

            def route(r):
                if r.request.url.startswith("file://"):
                    r.continue_()
                else:  # offline: anything else is blocked, and recorded
                    seen["external"].append(r.request.url)
                    r.abort()

            page.route("**/*", route)
            page.goto(html.as_uri(), timeout=PAGE_LOAD_TIMEOUT_MS)
            page.wait_for_function(
                "n => { const d = [...document.querySelectorAll('.plotly-graph-div')];"
                " return d.length === n && d.every(x => x.querySelector('.main-svg')); }",
                arg=expected_figures, timeout=PAGE_LOAD_TIMEOUT_MS)
            seen["divs"] = page.evaluate("document.querySelectorAll('.plotly-graph-div').length")
            seen["svgs"] = page.evaluate("document.querySelectorAll('.js-plotly-plot .main-svg').length")
            seen["webgl_missing"] = page.evaluate(
                "[...document.querySelectorAll('.plotly-graph-div')]"
                ".some(d => /WebGL is not supported/.test(d.innerText))")
            seen["play_buttons"] = page.evaluate(
                "[...document.querySelectorAll('.updatemenu-button')].filter(b => /Play/.test(b.textContent)).length")
            seen["scatter_points"] = page.evaluate("document.querySelectorAll('.scatterlayer .point').length")
            arm = page.locator("div[id$='-arm']").first
            arm.scroll_into_view_if_needed()
            x0 = page.evaluate("id => JSON.stringify(document.getElementById(id).data[0].x)", arm.get_attribute("id"))
            arm.locator(".updatemenu-button", has_text="Play").click()
            page.wait_for_function(
                "([id, x0]) => JSON.stringify(document.getElementById(id).data[0].x) !== x0",
                arg=[arm.get_attribute("id"), x0], timeout=20000)
            seen["animated"] = True
            page.evaluate("window.scrollTo(0, 0)")
            page.screenshot(path=str(shot), full_page=True)
        finally:
            ctx.close()
    return seen


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium "
                                                   "(apt-get install chromium; CI installs it)")
def test_report_renders_offline_in_chromium(results, report, tmp_path):
    pytest.importorskip("playwright", reason="needs the playwright package (pip install playwright; dev extra)")
    shot = tmp_path / "report.png"
    seen = _browser_check(report, shot, EXPECTED_FIGURES)
    assert seen["errors"] == []
    assert seen["external"] == []
    assert seen["divs"] == EXPECTED_FIGURES and seen["svgs"] >= EXPECTED_FIGURES
    assert not seen["webgl_missing"]
    assert seen["play_buttons"] == 2 + 1  # the arm of both simulations and of the plan
    assert seen["scatter_points"] > 0  # the trade-off markers are drawn
    assert seen["animated"]
    assert shot.stat().st_size > 50_000
