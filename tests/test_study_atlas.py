"""The corner atlas (pathmotion/study/atlas.py): bad input, the parabolic zone's deviation against
its closed form, the optimum cache, one real row through the sweep machinery and the CLI, and the torque reserve
and robot files (corners --torque-reserve, --robot) down to a real weak-drive row."""

import csv
import json
import os
from pathlib import Path

import numpy as np
import pytest

from pathmotion import defaults
from pathmotion.errors import PathError
from pathmotion.geometry import max_deviation
from pathmotion.study import atlas


@pytest.mark.parametrize("angle", [0.0, 180.0, -10.0, 200.0])
def test_angles_of_0_or_180_degrees_are_errors(angle):
    with pytest.raises(PathError, match="not a corner"):
        atlas.check_inputs([angle], [0.001])


def test_tolerance_beyond_half_a_segment_is_an_error():
    with pytest.raises(PathError, match="below half a segment"):
        atlas.check_inputs([90.0], [0.15])


@pytest.mark.parametrize("meshes, fault", [((0,), "at least 2"), ((0, 0), "positive"), ((25, 40, 100), "twice the previous"),
                                           ((25.5, 51), "whole interval counts"), ((25,), "at least 2")])
def test_meshes_that_give_no_converged_reference_are_errors(meshes, fault):
    """`--meshes 0` ran the NLP on 3 intervals per phase and reported a 'local optimum below the feasible motion' (its
    one mesh had a NaN error); meshes that do not double break the extrapolation silently."""
    with pytest.raises(PathError, match=fault):
        atlas.check_inputs([90.0], [0.001], meshes)


def test_the_cli_and_the_api_default_to_the_same_meshes():
    """The CLI said 25,50,100 itself while corner_atlas and atlas_row fell back to free_shape.MESHES (with 200
    intervals): one command, two atlases. Both are defaults.ATLAS_MESHES now."""
    import typer

    from pathmotion.cli import app

    option = next(p for p in typer.main.get_command(app).commands["corners"].params if p.name == "meshes")
    cli_default = tuple(int(m) for m in option.default.split(","))
    assert cli_default == defaults.ATLAS_MESHES == atlas.check_inputs([90.0], [0.001])


def test_bad_meshes_through_the_cli_exit_1_before_any_work(tmp_path):
    from typer.testing import CliRunner

    from pathmotion.cli import app

    res = CliRunner().invoke(app, ["corners", "--angles", "90", "--tolerances", "0.001", "--meshes", "0",
                                   "--out", str(tmp_path / "atlas")])
    assert res.exit_code == 1 and "meshes" in res.output and "e.g. 25,50,100" in res.output
    assert not (tmp_path / "atlas").exists()
    res = CliRunner().invoke(app, ["corners", "--angles", "90", "--tolerances", "0.001", "--meshes", "25.5,51",
                                   "--out", str(tmp_path / "atlas")])
    assert res.exit_code == 1 and "whole interval counts" in res.output  # named, not truncated to 25


def test_a_reference_without_an_error_estimate_is_judged_by_the_margin_alone():
    from pathmotion.study.atlas import local_optimum_note

    assert local_optimum_note(0.8169, float("nan"), 0.8181) is None  # below the feasible motion: a reference
    assert local_optimum_note(0.8300, float("nan"), 0.8181) is not None


def test_too_large_tolerance_for_a_g2_blend_is_the_rows_error_with_the_largest_that_fits():
    result = atlas.atlas_point('robot = "irb140"\ncache = "/nonexistent"\n', ".",
                               (("angle_deg", 30.0), ("tolerance_m", 0.05)))
    assert result["summary"]["status"] == "error"
    assert "give a tolerance below" in result["error"]


@pytest.mark.parametrize("angle", [30.0, 90.0, 150.0])
def test_parabolic_zone_deviation_is_z_sin_angle_over_4(angle):
    task = atlas._task(atlas.corner_points(angle))
    tol = 0.004
    zoned = atlas.parabolic_zone(task, tol)
    z = 4 * tol / np.sin(np.radians(angle))
    expected = tol if z <= 0.1 else 0.1 * np.sin(np.radians(angle)) / 4
    assert max_deviation(zoned, task, rel_tol=1e-7).distance == pytest.approx(expected, rel=1e-5)
    assert [c.kind for c in zoned.connections] == ["tangent", "tangent"]  # G1: the curvature jumps


def test_optimum_cache_is_keyed_by_its_inputs(tmp_path):
    pytest.importorskip("casadi", reason='needs CasADi: pip install "pathmotion[optimal]"')
    from pathmotion.robot import load_robot

    robot = load_robot("irb140")
    pts = atlas.corner_points(90.0)
    first = atlas.cached_optimum(tmp_path, robot, pts, 0.0, meshes=(10, 20))
    assert len(list(tmp_path.glob("*.json"))) == 1
    assert atlas.cached_optimum(tmp_path, robot, pts, 0.0, meshes=(10, 20)) == first  # read back
    atlas.cached_optimum(tmp_path, robot, pts, 0.0, meshes=(10, 20, 40))
    assert len(list(tmp_path.glob("*.json"))) == 2  # other inputs, another entry


def test_the_cache_key_has_the_spans_and_crowd_the_nlp_lays_out():
    """Spans (corner-confined) and crowd (whole tube) enter the key as free_shape.effective_spans lays the phases
    out: spans that fold to the same layout share a key, and a layout that changed is never read back under the
    raw spans of a cache written before the folding."""
    from pathmotion.robot import load_robot
    from pathmotion.study.free_shape import Polyline, effective_spans

    robot = load_robot("irb140")
    pts = atlas.corner_points(60.0)
    raw = [(0.19805, 0.1999998)]  # 60 deg / 10 mm: the stretches left on the lines are inside the capsules
    folded = effective_spans(Polyline(pts).lengths, 0.01, raw)
    assert folded != raw
    for spans, crowd in ((raw, None), (None, raw)):
        key = atlas._optimum_key(robot, pts, 0.01, spans, (25, 50), crowd=crowd)
        same = atlas._optimum_key(robot, pts, 0.01, folded if spans else None, (25, 50), crowd=folded if crowd else None)
        other = atlas._optimum_key(robot, pts, 0.01, [(0.1, 0.1)] if spans else None, (25, 50),
                                   crowd=[(0.1, 0.1)] if crowd else None)
        assert key == same != other


def test_reference_value_is_never_a_silent_number():
    ok = {"success": True, "duration": 0.7, "convergence_error": 0.002, "status": "Solve_Succeeded",
          "statuses": ["Solve_Succeeded"] * 3, "durations": [0.69, 0.695, 0.698]}
    assert atlas.reference_value(ok) == (0.7, 0.002, None)
    coarse_failed = {**ok, "success": False, "statuses": ["Maximum_Iterations_Exceeded", "Solve_Succeeded",
                                                          "Solved_To_Acceptable_Level"]}
    value, error, note = atlas.reference_value(coarse_failed)
    assert (value, error) == (0.698, pytest.approx(0.003))  # the finest, its change from the 50-interval mesh
    assert "coarsest mesh not converged (Maximum_Iterations_Exceeded)" in note
    fine_failed = {**ok, "success": False, "statuses": ["Solve_Succeeded", "Solve_Succeeded", "Restoration_Failed"]}
    assert atlas.reference_value(fine_failed) == (None, None, "NLP not converged (Solve_Succeeded, Solve_Succeeded, "
                                                              "Restoration_Failed)")
    # four meshes, the finest failed: the three coarser still fit an order. By hand: changes 5 and 3 ms, so
    # 2^p = 5/3 and Richardson adds 3 ms / (2^p - 1) = 4.5 ms to the finest of them
    four = {**ok, "success": False, "statuses": ["Solve_Succeeded"] * 3 + ["Maximum_Iterations_Exceeded"],
            "durations": [0.69, 0.695, 0.698, 0.75]}
    value, error, note = atlas.reference_value(four)
    assert (value, error) == pytest.approx((0.7025, 0.0045), rel=1e-9)
    assert value > 0.698 and "finest mesh not converged (Maximum_Iterations_Exceeded)" in note
    assert "3 coarser meshes" in note
    two_failed = {**four, "statuses": ["Solve_Succeeded"] * 2 + ["Restoration_Failed"] * 2}
    assert atlas.reference_value(two_failed)[0] is None


@pytest.mark.slow
def test_one_atlas_row_through_the_cli(tmp_path):
    pytest.importorskip("casadi", reason='needs CasADi: pip install "pathmotion[optimal]"')
    from typer.testing import CliRunner

    from pathmotion.cli import app

    res = CliRunner().invoke(app, ["corners", "--angles", "90", "--tolerances", "0.005", "--meshes", "10,20,40",
                                   "--workers", "1", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((tmp_path / "corners.csv").open()))
    assert len(rows) == 1 and list(rows[0]) == list(atlas.ATLAS_COLUMNS)
    assert (rows[0]["torque"], rows[0]["torque_reserve"]) == ("false", "")  # planned without torque limits: no reserve
    words = ("status", "error", "closed_loop_ok", "torque", "torque_reserve")
    r = {k: float(v) for k, v in rows[0].items() if k not in words and v != ""}
    assert r["optimal_s"] <= r["g2_s"] < r["stop_s"]
    assert r["circle_s"] < r["stop_s"]
    assert r["gain_vs_stop"] == pytest.approx(1 - r["optimal_s"] / r["stop_s"])
    if rows[0]["status"] == "ok":  # a converged reference is below every blend (within its error)
        assert r["free_shape_optimum_s"] <= r["optimal_s"] + r["free_shape_error_s"]
    else:
        assert any(w in rows[0]["status"] for w in ("not converged", "closed loop", "corner_bound"))
    if "corner_bound_s" in r:  # a motion that holds the tube: slower than the finest mesh's, faster than the stop
        assert r["corner_optimum_s"] - r["corner_error_s"] < r["corner_bound_s"] < r["stop_s"]
        assert r["gap_to_corner_bound"] == pytest.approx(r["optimal_s"] / r["corner_bound_s"] - 1)
    else:
        assert "corner_bound" in rows[0]["status"]
    assert rows[0]["closed_loop_ok"] in ("true", "false")
    if rows[0]["closed_loop_ok"] == "true":  # within delta plus the tracking error of the planned path
        assert r["closed_loop_path_accuracy_m"] <= atlas.CLOSED_LOOP_PATH_ACCURACY
        assert r["closed_loop_cornering_deviation_m"] <= 0.005 + r["closed_loop_path_accuracy_m"]
    assert (tmp_path / "tdelta.png").is_file() and (tmp_path / "gain_vs_angle.png").is_file()
    spec = json.loads((tmp_path / "points_sweep" / "sweep_spec.json").read_text())
    assert spec["grid"] == {"angle_deg": [90.0], "tolerance_m": [0.005]}


def test_a_reference_above_a_feasible_motion_is_no_reference():
    """The stop and the optimal blend lie in both tubes, so a converged reference above the shorter of them by more
    than its convergence error (+ 0.2 %) is a local optimum (150 deg / 1 mm corner-confined: 0.9278 s against the
    optimal blend's 0.9065 s, error 0.57 ms): flagged, never a number."""
    from pathmotion.study.atlas import local_optimum_note

    assert local_optimum_note(0.9278, 0.00057, 0.9065) is not None
    assert "local optimum 0.9278 s" in local_optimum_note(0.9278, 0.00057, 0.9065)
    assert local_optimum_note(0.9065 * 1.0019, 0.0, 0.9065) is None  # within the 0.2 % margin
    assert local_optimum_note(0.9100, 0.004, 0.9065) is None  # within its own convergence error
    assert local_optimum_note(0.8600, 0.0, 0.9065) is None  # below: the normal case


def _stub_optimum(durations, success=True):
    """A FreeShapeOptimum as free_shape_optimum returns it, from its meshes' durations (no NLP)."""
    from pathmotion.study import free_shape as fs

    sols = tuple(fs.FreeShapeSolution(d, "Solve_Succeeded" if success else "Maximum_Iterations_Exceeded", success,
                                      None, {"max_excess_m": 0.0}, 10) for d in durations)
    value, error = fs.extrapolate(durations)
    return fs.FreeShapeOptimum(value, error, success, sols[-1].status, sols, 0.001, ((0.016, 0.018),))


def test_a_corner_reference_above_a_feasible_start_is_solved_again_from_the_other_start(tmp_path, monkeypatch):
    """150 deg / 1 mm: the cached first attempt (from the optimal blend, 0.9065 s) converged to 0.9278 s, a local
    optimum; the stop (0.9163 s) is tried, cached under its own key, and its 0.9055 s is the reference. The first
    attempt's cache entry is read, not solved again, and the whole tube starts from the start that won."""
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs

    robot = load_robot("irb140")
    pts, spans, meshes, blend = atlas.corner_points(150.0), [(0.016, 0.018)], (25, 50, 100), object()
    results = {"blend": _stub_optimum([0.9369, 0.9300, 0.9283]), "stop": _stub_optimum([0.9083, 0.9061, 0.9056])}
    solved = []

    def stub(robot_, points, delta, spans_, meshes_, warm=None, torque=False):
        solved.append("blend" if warm is blend else "stop")
        return results[solved[-1]]

    monkeypatch.setattr(fs, "free_shape_optimum", stub)
    atlas.cached_optimum(tmp_path, robot, pts, 0.001, spans, meshes, warm=blend)  # the atlas' first attempt
    solved.clear()
    ref = atlas.corner_reference(tmp_path, robot, pts, 0.001, spans, meshes, blend, False, 0.9065)
    assert solved == ["stop"]  # the first attempt came from the cache
    assert (ref.start, ref.note) == ("stop", None)
    assert ref.value == pytest.approx(results["stop"].duration) and ref.value < 0.9065
    assert ref.durations == pytest.approx((0.9083, 0.9061, 0.9056))  # the winning start's meshes, not the first's
    assert ref.solutions() is results["stop"]
    retry = [json.loads(f.read_text()) for f in tmp_path.glob("*.json") if "start" in json.loads(f.read_text())]
    assert [r["start"] for r in retry] == ["stop"] and len(list(tmp_path.glob("*.json"))) == 2
    # read back: nothing is solved again
    solved.clear()
    again = atlas.corner_reference(tmp_path, robot, pts, 0.001, spans, meshes, blend, False, 0.9065)
    assert solved == [] and again.value == ref.value and again.durations == ref.durations
    # its solutions, asked for by the whole tube's starts and the feasible bound, are solved again once, not per ask
    assert again.solutions() is again.solutions() is results["stop"] and solved == ["stop"]


def test_a_corner_reference_that_fails_from_every_start_says_so_per_start(tmp_path, monkeypatch):
    """A racing line starts from the stop; when neither start converges the row names both, and a first attempt that
    converged below the feasible motions is kept without a retry."""
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs

    robot = load_robot("irb140")
    pts, spans, meshes, blend = atlas.corner_points(60.0), [(0.198, 0.199)], (25, 50, 100), object()
    failed = _stub_optimum([0.6017, 0.6035, 0.6047], success=False)
    solved = []

    def stub(robot_, points, delta, spans_, meshes_, warm=None, torque=False):
        solved.append("blend" if warm is blend else "stop")
        return failed

    monkeypatch.setattr(fs, "free_shape_optimum", stub)
    ref = atlas.corner_reference(tmp_path, robot, pts, 0.01, spans, meshes, blend, True, 0.636)
    assert solved == ["stop", "blend"] and ref.value is None and ref.start == "stop"
    assert ref.note.startswith("from the stop: NLP not converged") and "; from the blend: NLP not converged" in ref.note
    good = _stub_optimum([0.6016, 0.6041, 0.6053])
    monkeypatch.setattr(fs, "free_shape_optimum", lambda *a, warm=None, **kw: solved.append("x") or good)
    solved.clear()
    ref = atlas.corner_reference(tmp_path / "other", robot, pts, 0.01, spans, meshes, blend, True, 0.636)
    assert solved == ["x"] and ref.start == "stop" and ref.note is None and ref.value == pytest.approx(good.duration)


def test_a_whole_tube_without_a_reference_from_the_corner_confined_start_is_solved_from_the_others(tmp_path,
                                                                                                  monkeypatch):
    """30 deg / 0.1 mm: the whole tube from the corner-confined solutions hit IPOPT's cap; here from them with their
    multipliers too (the same FreeShapeOptimum, crowded at the same spans); from the stop it converges below the
    feasible motions but above the corner-confined reference (whose tube is inside its own) by more than both errors, a
    local optimum; from the optimal blend it converges below it: that is the reference. The first attempt keeps the
    key it had before the retries (crowded at the spans, no start), each retry has its own. When the start with
    multipliers converges below the corner-confined reference, it is the reference and no other start is solved."""
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs

    robot = load_robot("irb140")
    pts, spans, meshes, blend = atlas.corner_points(30.0), [(0.004, 0.005)], (25, 50, 100), object()
    inner = _stub_optimum([0.8760, 0.8745, 0.8741])
    failed = _stub_optimum([0.8712, 0.8725, 0.8740], success=False)
    results = {"corner": failed, "corner_multipliers": failed,
               "stop": _stub_optimum([0.8790, 0.8782, 0.8780]), "blend": _stub_optimum([0.8731, 0.8726, 0.8725])}
    solved = []

    def stub(robot_, points, delta, spans_, meshes_, warm=None, torque=False):
        if spans_ is not None:
            solved.append("corner-confined")
            return inner
        if isinstance(warm, fs.WithMultipliers):
            assert warm.optimum is inner
            solved.append("corner_multipliers")
        else:
            solved.append({id(inner): "corner", id(None): "stop", id(blend): "blend"}[id(warm)])
        return results[solved[-1]]

    monkeypatch.setattr(fs, "free_shape_optimum", stub)
    corner = atlas.corner_reference(tmp_path, robot, pts, 0.0001, spans, meshes, blend, False, 0.8812)
    assert corner.note is None and corner.value == pytest.approx(inner.duration)
    whole = atlas.whole_reference(tmp_path, robot, pts, 0.0001, meshes, corner, spans, blend, 0.8812)
    assert solved == ["corner-confined", "corner", "corner_multipliers", "stop", "blend"]
    assert (whole.start, whole.note) == ("blend", None)
    assert whole.value == pytest.approx(results["blend"].duration) and whole.value <= corner.value
    first = atlas._optimum_key(robot, pts, 0.0001, None, meshes, crowd=spans)  # the key of the atlas before retries
    records = {f.stem: json.loads(f.read_text()) for f in tmp_path.glob("*.json")}
    assert "start" not in records[first] and records[first]["status"] == "Maximum_Iterations_Exceeded"
    assert sorted(r.get("start", "-") for r in records.values()) == ["-", "-", "blend", "corner_multipliers", "stop"]
    retry = atlas._optimum_key(robot, pts, 0.0001, None, meshes, crowd=spans, start="corner_multipliers")
    assert records[retry]["start"] == "corner_multipliers"  # crowded at the corner-confined spans, like the first
    solved.clear()  # read back: nothing is solved again, the same reference
    again = atlas.whole_reference(tmp_path, robot, pts, 0.0001, meshes, corner, spans, blend, 0.8812)
    assert solved == [] and (again.value, again.start) == (whole.value, "blend")
    # every start without a reference: none, and the row's status names each start's failure
    results["blend"] = results["stop"]
    whole = atlas.whole_reference(tmp_path / "other", robot, pts, 0.0001, meshes, corner, spans, blend, 0.8812)
    assert whole.value is None and whole.start == "corner"
    assert whole.note.startswith("from the corner: NLP not converged")
    assert (f"; from the stop: local optimum {results['stop'].duration:.4f} s, above the {inner.duration:.4f} s of the "
            "tube inside its own") in whole.note
    assert "; from the blend: local optimum" in whole.note
    assert "; from the corner_multipliers: NLP not converged" in whole.note
    # the start with multipliers converges below the corner-confined reference: the reference, nothing else solved
    results["corner_multipliers"] = _stub_optimum([0.8726, 0.8707, 0.8729])
    solved.clear()
    whole = atlas.whole_reference(tmp_path / "third", robot, pts, 0.0001, meshes, corner, spans, blend, 0.8812)
    assert solved == ["corner", "corner_multipliers"] and (whole.start, whole.note) == ("corner_multipliers", None)
    assert whole.value == pytest.approx(results["corner_multipliers"].duration)


def test_a_whole_tube_within_the_errors_of_the_corner_confined_reference_is_kept_without_a_retry(tmp_path,
                                                                                                monkeypatch):
    """The whole tube may end a little above the corner-confined reference on other meshes (90 / 10 mm: 0.6897 +-
    2.42 ms against 0.6884 +- 1.40 ms): within both errors it is the reference, and no other start is solved."""
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs

    robot = load_robot("irb140")
    pts, spans, meshes = atlas.corner_points(90.0), [(0.05, 0.05)], (25, 50, 100)
    whole_opt = _stub_optimum([0.6970, 0.6930, 0.6910])
    solved = []
    monkeypatch.setattr(fs, "free_shape_optimum", lambda *a, warm=None, **kw: solved.append(1) or whole_opt)
    corner = atlas.Reference(0.6884, 0.0014, None, "stop", lambda: None)
    assert whole_opt.duration - corner.value < whole_opt.convergence_error + corner.error
    whole = atlas.whole_reference(tmp_path, robot, pts, 0.01, meshes, corner, spans, object(), 0.6970)
    assert solved == [1] and (whole.start, whole.note) == ("corner", None)
    assert whole.value == pytest.approx(whole_opt.duration)


def _weak_drives():
    """the torque case (bench_free_shape_torque.py): the IRB140 with its rated 6 kg 0.1 m below the flange
    and drives at 35 % of the shipped torque limits, where the torque limit binds."""
    import dataclasses

    from pathmotion.robot import load_robot
    from pathmotion.robot.model import Payload

    arm = load_robot("irb140").with_payload(Payload(6.0, (0.0, 0.0, 0.1), ((0.01, 0, 0), (0, 0.01, 0), (0, 0, 0.01))))
    return arm.with_limits(dataclasses.replace(arm.limits, torque=arm.limits.torque * 0.35))


def test_torque_enters_the_optimum_key_with_what_the_torque_depends_on():
    """Without torque the key is the one of before the option (existing caches stay valid); with it, the key changes,
    and so it does for another payload or other drives (the limits alone do not say what the torque is)."""
    import dataclasses

    from pathmotion.robot import load_robot
    from pathmotion.robot.model import Payload

    weak, pts, spans = _weak_drives(), atlas.corner_points(90.0), [(0.01, 0.01)]
    arms = (weak, weak.with_payload(Payload(3.0, (0.0, 0.0, 0.1))),
            weak.with_limits(dataclasses.replace(weak.limits, torque=weak.limits.torque * 2)))
    keys = {atlas._optimum_key(r, pts, 0.005, spans, (25, 50), torque=True) for r in arms}
    assert len(keys) == 3
    off = atlas._optimum_key(weak, pts, 0.005, spans, (25, 50))
    assert off not in keys
    assert off == atlas._optimum_key(load_robot("irb140"), pts, 0.005, spans, (25, 50), torque=False)


# ------------------------------------------------------------------ torque reserve and robot files (corners options)
#: The weak-drive arm as a robot file (shipped with the benchmarks, used in the README).
WEAK_ROBOT_FILE = Path(__file__).resolve().parents[1] / "benchmarks" / "irb140_weak_drives.toml"


def _corners(tmp_path, *args):
    from typer.testing import CliRunner

    from pathmotion.cli import app

    return CliRunner().invoke(app, ["corners", "--angles", "90", "--tolerances", "0.005", "--meshes", "10,20",
                                    "--workers", "1", "--out", str(tmp_path / "atlas"), *args])


@pytest.mark.parametrize("reserve", [-0.1, 0.5, 1.0, float("nan"), float("inf"), True, "0.2"])
def test_a_reserve_out_of_range_is_refused_naming_the_option(reserve):
    from pathmotion.errors import ScenarioError

    with pytest.raises(ScenarioError, match=r"--torque-reserve .*\[0, 0.5\)"):
        atlas.check_torque_reserve(reserve, True, name="--torque-reserve")


def test_the_reserve_defaults_as_the_scenario_key_and_needs_torque():
    from pathmotion import defaults
    from pathmotion.errors import ScenarioError
    from pathmotion.io.scenario import LimitsSpec

    assert atlas.check_torque_reserve(None, True) == defaults.TORQUE_RESERVE == LimitsSpec().torque_reserve
    assert atlas.check_torque_reserve(None, False) == 0.0
    assert atlas.check_torque_reserve(0, True) == 0.0 and atlas.check_torque_reserve(0.2, True) == 0.2
    with pytest.raises(ScenarioError, match="without torque.*add torque"):
        atlas.check_torque_reserve(0.2, False)


@pytest.mark.parametrize("args, words", [
    (["--torque", "--torque-reserve", "0.5"], ["--torque-reserve 0.5", "[0, 0.5)"]),
    (["--torque", "--torque-reserve", "-0.1"], ["--torque-reserve -0.1", "e.g. 0.2"]),
    (["--torque", "--torque-reserve", "nan"], ["--torque-reserve nan"]),
    (["--torque-reserve", "0.1"], ["without --torque", "add --torque"]),
])
def test_bad_reserves_through_the_cli_exit_1_before_any_work(tmp_path, args, words):
    res = _corners(tmp_path, *args)
    assert res.exit_code == 1, res.output
    assert all(w in res.output for w in words), res.output
    assert "Traceback" not in res.output and not (tmp_path / "atlas").exists()


@pytest.mark.parametrize("text, words", [
    (None, ["robot file", "does not exist"]),
    ("[robot\nname = 1", ["not valid TOML"]),
    ('[robot]\nname = "irb140"\n[path]\ntype = "task"\n', ["'path' is not part of a robot file", "[robot]"]),
    ("[limits]\ntorque_scale = 0.35\n", ["limits.torque_scale is not the arm's joint limit", "limits.torque = [...]",
                                        "--torque-reserve"]),
    ("[robot]\npaylod = { mass = 6.0 }\n", ["robot.paylod", "did you mean 'payload'"]),
    ("[robot]\npayload = { mass = -6.0 }\n", ["robot.payload.mass", "greater than or equal to 0"]),
    ("[limits]\ntorque = [1.0, 2.0]\n", ["limits.torque has 2 values", "6 joints"]),
    ('[robot]\nname = "no_such_arm.urdf"\n', ["robot file", "neither a built-in robot"]),
])
def test_a_bad_robot_file_through_the_cli_exits_1_naming_it(tmp_path, text, words):
    robot = tmp_path / "arm.toml"
    if text is not None:
        robot.write_text(text)
    res = _corners(tmp_path, "--robot", str(robot))
    assert res.exit_code == 1, res.output
    assert all(w in res.output for w in words), res.output
    assert "Traceback" not in res.output and not (tmp_path / "atlas").exists()


def test_a_robot_file_builds_the_arm_the_api_builds(tmp_path):
    """The shipped weak-drive file gives the robot of _weak_drives (the same payload, limits, dynamics and so the same optimum
    keys and digest); relative URDF / limits paths are read from the file's folder."""
    import pathmotion.robot
    from pathmotion.robot import load_robot
    from pathmotion.study.robot_file import load_robot_file, robot_digest

    weak, loaded = _weak_drives(), load_robot_file(WEAK_ROBOT_FILE)
    assert robot_digest(loaded) == robot_digest(weak) != robot_digest(load_robot("irb140"))
    pts = atlas.corner_points(90.0)
    for torque in (False, True):
        assert (atlas._optimum_key(loaded, pts, 0.005, None, (25, 50), torque=torque)
                == atlas._optimum_key(weak, pts, 0.005, None, (25, 50), torque=torque))
    shipped = load_robot("irb140")
    (tmp_path / "irb140_limits.toml").write_text(
        (Path(pathmotion.robot.__file__).parent / "data" / "irb140_limits.toml").read_text().replace(
            "velocity = 3.49065850399  # 200 deg/s, official (spec p. 38)", "velocity = 3.0", 1))
    (tmp_path / "slow.toml").write_text('[robot]\nname = "irb140"\nlimits = "irb140_limits.toml"\n')
    slow = load_robot_file(tmp_path / "slow.toml")
    assert slow.limits.velocity[0] == 3.0 and np.array_equal(slow.limits.velocity[1:], shipped.limits.velocity[1:])


def test_a_robot_file_changed_since_the_atlas_started_is_each_rows_error():
    """A resumed atlas whose robot file now describes another arm gives no row of the new arm under the old spec."""
    from pathmotion.study.robot_file import load_robot_file, robot_digest

    digest = robot_digest(load_robot_file(WEAK_ROBOT_FILE))
    spec = (f'robot_file = {json.dumps(str(WEAK_ROBOT_FILE))}\nrobot_digest = "{digest}"\n'
            'cache = "/nonexistent"\ntorque = true\ntorque_reserve = 0.0\n')
    result = atlas.atlas_point(spec.replace('robot_digest = "', 'robot_digest = "0'), ".",
                               (("angle_deg", 30.0), ("tolerance_m", 0.05)))
    assert result["summary"]["status"] == "error" and "changed since this atlas started" in result["error"]
    result = atlas.atlas_point(spec, ".", (("angle_deg", 30.0), ("tolerance_m", 0.05)))  # the same file: it runs
    assert "give a tolerance below" in result["error"] and result["summary"]["torque_reserve"] == 0.0


def test_the_spec_names_its_robot_file_and_cache_relative_to_its_folder(tmp_path):
    """atlas_spec.toml holds no path of the machine: the robot file and the cache are relative to the spec's folder,
    so a moved folder still finds them."""
    from pathmotion.study.robot_file import load_robot_file, robot_digest

    digest = robot_digest(load_robot_file(WEAK_ROBOT_FILE))
    where = os.path.relpath(WEAK_ROBOT_FILE, tmp_path)
    spec = (f'robot_file = {json.dumps(where)}\nrobot_digest = "{digest}"\ncache = "optimum_cache"\ntorque = true\n'
            'torque_reserve = 0.0\n')
    result = atlas.atlas_point(spec, str(tmp_path), (("angle_deg", 30.0), ("tolerance_m", 0.05)))
    assert "give a tolerance below" in result["error"]  # the robot file was found from the spec's folder
    elsewhere = tmp_path / "a" / "b"  # another folder: the same relative path names no file there
    result = atlas.atlas_point(spec, str(elsewhere), (("angle_deg", 30.0), ("tolerance_m", 0.05)))
    assert result["summary"]["status"] == "error" and "give a tolerance below" not in result["error"]


#: Optimum keys written by fdb4d31 (before the reserve and robot files), 90 deg / 5 mm, corner span 10 mm, meshes
#: 25/50/100: the IRB140 without torque, the weak drives with torque.
KEY_IRB140_BEFORE = "bbfb5bc1a6f381c7d679"
KEY_WEAK_TORQUE_BEFORE = "cd001fdf085cd0a57be5"


def test_the_optimum_keys_of_before_stay_and_every_robot_or_reserve_has_its_own():
    """Keys written before the reserve and robot files (fdb4d31: the IRB140 without torque, the weak drives with
    torque) are unchanged, also with reserve 0; a reserve above 0, another reserve, a tool, other velocity limits
    each give another key; a payload without torque does not (the motion does not depend on it then)."""
    import dataclasses

    from pathmotion.robot import load_robot
    from pathmotion.robot.model import Tool

    pts, spans, meshes = atlas.corner_points(90.0), [(0.01, 0.01)], (25, 50, 100)

    def of_before(robot):  # the arm the keys were written for: the limits file's accelerations (and jerk) of then
        box = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])
        return robot.with_limits(dataclasses.replace(robot.limits, acceleration=box, jerk=10.0 * box))

    now = load_robot("irb140")
    irb, weak = of_before(now), of_before(_weak_drives())
    before = {"irb": atlas._optimum_key(irb, pts, 0.005, spans, meshes),
              "weak": atlas._optimum_key(weak, pts, 0.005, spans, meshes, torque=True)}
    assert before == {"irb": KEY_IRB140_BEFORE, "weak": KEY_WEAK_TORQUE_BEFORE}
    assert atlas._optimum_key(weak, pts, 0.005, spans, meshes, torque=True, torque_reserve=0.0) == before["weak"]
    keys = {atlas._optimum_key(weak, pts, 0.005, spans, meshes, torque=True, torque_reserve=r) for r in (0.1, 0.2)}
    keys |= {atlas._optimum_key(irb.with_tool(Tool((0.0, 0.0, 0.1))), pts, 0.005, spans, meshes),
             atlas._optimum_key(irb.with_limits(dataclasses.replace(irb.limits, velocity=irb.limits.velocity * 0.5)),
                                pts, 0.005, spans, meshes),
             atlas._optimum_key(now, pts, 0.005, spans, meshes)}  # today's limits file: another arm, another key
    assert len(keys) == 5 and not keys & set(before.values())
    assert atlas._optimum_key(weak, pts, 0.005, spans, meshes) == before["irb"]  # payload and drives: torque only


def test_a_plan_with_the_reserve_is_the_plan_of_the_reduced_limits():
    """The planner's reserve and the reduced robot the references are solved on (atlas.reserved) are the same limit:
    the stop with reserve 0.2 takes as long as the stop on drives at 0.8 of the limits, and longer than without."""
    weak = _weak_drives()
    task = atlas._task(atlas.corner_points(90.0))
    reduced = atlas.reserved(weak, 0.2)
    assert np.allclose(reduced.limits.torque, 0.8 * weak.limits.torque) and atlas.reserved(weak, 0.0) is weak
    with_reserve = atlas._duration(weak, task, torque=True, torque_reserve=0.2, connections="zero")
    whole = {"torque": True, "torque_reserve": 0.0, "connections": "zero"}  # the whole torque of each robot
    assert with_reserve == pytest.approx(atlas._duration(reduced, task, **whole), rel=1e-9)
    assert with_reserve > 1.01 * atlas._duration(weak, task, **whole)


@pytest.mark.slow
def test_a_reserve_row_through_the_cli_plans_and_solves_within_the_reduced_limits(tmp_path, monkeypatch):
    """corners --robot (weak drives) --torque --torque-reserve 0.2, 90 deg / 5 mm on coarse meshes, the real plans,
    NLPs and closed loop (the torque row of before, now with a reserve): every plan's torque on a dense resample, by
    Pinocchio's RNEA on the sampled joint motion, is within 0.8 tau_max and reaches it (the reserve binds, so a plan
    ignoring it would fail), both references were solved within the reduced limits (their dense verification), and
    the closed loop ran the plant with the whole limits; corners.csv has the reserve."""
    pytest.importorskip("casadi", reason='needs CasADi: pip install "pathmotion[optimal]"')
    import pinocchio as pin

    import pathmotion.planning as planning

    plans, loops = [], []
    real_plan, real_loop = planning.plan, atlas.closed_loop_check
    monkeypatch.setattr(planning, "plan", lambda *a, **kw: plans.append(real_plan(*a, **kw)) or plans[-1])
    monkeypatch.setattr(atlas, "closed_loop_check", lambda robot, *a: loops.append(robot) or real_loop(robot, *a))
    res = _corners(tmp_path, "--robot", str(WEAK_ROBOT_FILE), "--torque", "--torque-reserve", "0.2",
                   "--no-figures")
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((tmp_path / "atlas" / "corners.csv").open()))
    assert len(rows) == 1 and list(rows[0]) == list(atlas.ATLAS_COLUMNS)
    assert (rows[0]["torque"], float(rows[0]["torque_reserve"])) == ("true", 0.2)
    robot = _weak_drives()
    assert len(plans) >= 5 and len(loops) == 1 and np.array_equal(loops[0].limits.torque, robot.limits.torque)
    peaks = []
    for result in plans:
        s = result.trajectory.at_time(np.linspace(0.0, result.profile.duration, 3000))
        tau = np.array([pin.rnea(robot.model, robot.data, q, qd, qdd) for q, qd, qdd in zip(s.q, s.qd, s.qdd)])
        peaks.append(np.max(np.abs(tau) / robot.limits.torque))
    assert max(peaks) <= 0.8 * (1 + 2e-3) and peaks[0] >= 0.8 * 0.99, peaks  # peaks[0]: the stop
    # then the zone (its constant speed within the reduced limits too), G2, circle, the optimal blend's plan
    assert plans[1].baselines.constant_speed.ratios.torque <= 1 + 2e-3
    assert float(rows[0]["optimal_s"]) == pytest.approx(plans[4].profile.duration)
    records = [json.loads(f.read_text()) for f in (tmp_path / "atlas" / "optimum_cache").glob("*.json")]
    assert len(records) >= 2 and all(r["torque"] and r["torque_reserve"] == 0.2 for r in records)
    # against 0.8 tau_max: without the reserve the references would reach 1 / 0.8 = 1.25 of it; between the coarse
    # meshes' nodes the collocated torque overshoots by about 0.1 % (1.0011 on the polished blend's spans)
    # (the optima, and the corner-confined feasible bound where a solve held the tube: its record says why if none did)
    assert all(r["verification"]["max_torque_ratio"] <= 1 + 5e-3 for r in records if "verification" in r)
    assert all("verification" in r or r.get("error") for r in records)
    r = {k: float(v) for k, v in rows[0].items() if k in ("optimal_s", "stop_s", "corner_optimum_s",
                                                           "corner_error_s") and v != ""}
    assert r["optimal_s"] < r["stop_s"]
    if "corner_optimum_s" in r:
        assert r["corner_optimum_s"] <= r["optimal_s"] + r["corner_error_s"]


def test_a_row_without_references_solves_and_reads_no_optimum(tmp_path, monkeypatch):
    """references = false in the atlas spec (what benchmarks/atlas_rows.py times): the row plans every motion, and
    neither reference is looked up, solved or cached; its columns are empty and the status says why. The search is
    cut to its quintic stage here (the row's logic is what is tested, not the search)."""
    import functools

    from pathmotion.planning import blend_search

    def no_reference(*a, **kw):
        raise AssertionError("a reference was asked for")

    quick = functools.partial(blend_search.optimal_blends, racing=False, steps=1, free_plans=0, end_plans=0,
                              joint_plans=0, polish_plans=0, retry_capped=False)
    monkeypatch.setattr(blend_search, "optimal_blends", quick)  # atlas.optimal_motion imports it when called
    monkeypatch.setattr(atlas, "corner_reference", no_reference)
    monkeypatch.setattr(atlas, "whole_reference", no_reference)
    spec = f'robot = "irb140"\nmeshes = [25, 50]\nclosed_loop = false\nreferences = false\ncache = "{tmp_path}"\n'
    rec = atlas.atlas_point(spec, str(tmp_path), [("angle_deg", 90.0), ("tolerance_m", 0.005)])
    row = rec["summary"]
    assert rec["error"] is None, rec["error"]
    assert row["optimal_s"] <= row["g2_s"] < row["stop_s"] and row["circle_s"] < row["stop_s"]
    for key in ("free_shape_optimum_s", "corner_optimum_s", "free_shape_error_s", "corner_error_s", "gap_to_optimum",
                "gap_to_corner_optimum", "capture"):
        assert row[key] is None, key
    assert row["status"].count("not solved (references off)") == 2
    assert list(tmp_path.iterdir()) == []  # nothing cached


def _reference(value, start="stop", solutions=None):
    return atlas.Reference(value, 0.0005, None, start, lambda: solutions, (value,))


def test_the_corner_bound_is_cached_by_its_start_and_a_failure_is_recorded(tmp_path, monkeypatch):
    """corner_bound: free_shape.feasible_bound from the corner-confined reference's own solutions, written to the
    cache and read back (not solved again), keyed apart per reference start; a bound that cannot be had (here: the
    solution leaves a stretch held on the line) is a record with its error, cached as well."""
    from pathmotion.errors import PathmotionError
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs

    robot = load_robot("irb140")
    pts, spans, meshes = atlas.corner_points(90.0), [(0.05, 0.06)], (25, 50, 100)
    solutions, calls = object(), []

    def stub(robot_, points, delta, spans_, meshes_, torque=False, optimum=None):
        calls.append(optimum)
        if len(calls) == 3:
            raise PathmotionError("free shape: the solution leaves a stretch held on the line by 0.2 mm")
        return fs.FeasibleBound(0.7451, 0.0048, optimum, {"held_excess_m": -1e-6}, 1)

    monkeypatch.setattr(fs, "feasible_bound", stub)
    first = atlas.corner_bound(tmp_path, robot, pts, 0.005, spans, meshes, _reference(0.744, "stop", solutions))
    assert calls == [solutions] and first["duration"] == 0.7451 and first["radius"] == 0.0048
    again = atlas.corner_bound(tmp_path, robot, pts, 0.005, spans, meshes, _reference(0.744, "stop", solutions))
    assert len(calls) == 1 and again == first  # read from the cache
    other = atlas.corner_bound(tmp_path, robot, pts, 0.005, spans, meshes, _reference(0.744, "blend", solutions))
    assert len(calls) == 2 and other["duration"] == 0.7451  # another start: its own key
    failed = atlas.corner_bound(tmp_path, robot, pts, 0.004, spans, meshes, _reference(0.75, "stop", solutions))
    assert failed["duration"] is None and "held on the line" in failed["error"]
    assert atlas.corner_bound(tmp_path, robot, pts, 0.004, spans, meshes, _reference(0.75))["error"] == failed["error"]
    assert len(calls) == 3 and len(list(tmp_path.glob("*.json"))) == 3


@pytest.mark.parametrize("bounds, bound", [(True, 0.7452), (True, None), (False, 0.7452)])
def test_a_row_gives_the_corner_bound_and_the_gap_to_it(tmp_path, monkeypatch, bounds, bound):
    """The row's corner_bound_s and gap_to_corner_bound (optimal_s over it, less 1: a lower bound of the blend's true
    gap); a bound that cannot be had leaves both empty and says why in the status; ``bounds = false`` in the spec
    (pathmotion corners --no-bounds) asks for none. The search is cut to its quintic stage, the references stubbed."""
    import functools

    from pathmotion.planning import blend_search

    quick = functools.partial(blend_search.optimal_blends, racing=False, steps=1, free_plans=0, end_plans=0,
                              joint_plans=0, polish_plans=0, retry_capped=False)
    monkeypatch.setattr(blend_search, "optimal_blends", quick)
    monkeypatch.setattr(atlas, "corner_reference", lambda *a, **kw: _reference(0.7440))
    monkeypatch.setattr(atlas, "whole_reference", lambda *a, **kw: _reference(0.7400))
    asked = []

    def stub_bound(*a, **kw):
        asked.append(1)
        return {"duration": bound} if bound is not None else {"duration": None, "error": "no solve held the tube"}

    monkeypatch.setattr(atlas, "corner_bound", stub_bound)
    spec = (f'robot = "irb140"\nmeshes = [25, 50]\nclosed_loop = false\n{"" if bounds else "bounds = false"}\n'
            f'cache = "{tmp_path}"\n')
    row = atlas.atlas_point(spec, str(tmp_path), [("angle_deg", 90.0), ("tolerance_m", 0.005)])["summary"]
    assert len(asked) == int(bounds)
    if bounds and bound is not None:
        assert row["corner_bound_s"] == bound
        assert row["gap_to_corner_bound"] == pytest.approx(row["optimal_s"] / bound - 1)
        assert row["status"] == "ok"
    else:
        assert row["corner_bound_s"] is None and row["gap_to_corner_bound"] is None
        assert ("corner_bound: no solve held the tube" in row["status"]) == bounds
