"""Optimal blends on programs with joint moves and dwells: searched at the corners between task segments, the
joint-space zones kept, a stop at each dwell. Checked against the same chain with symmetric G2 blends (built
without any search), the TCP against the sharp polyline by a distance computed here, and the fine points of the
RAPID fixtures against their robtargets with the reader of tests/test_rapid_programs.py."""

import dataclasses
import math
import socket
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pathmotion import api
from pathmotion.api import searches
from pathmotion.io.scheduler import run_on_cluster
from pathmotion.errors import PathmotionError, ScenarioError
from pathmotion.io.rapid import read_rapid, scenario_toml
from pathmotion.planning.blend_search import FAST
from pathmotion.report.tables import read_rows
from pathmotion.robot import fk, load_robot
from tests.test_rapid_programs import fine_targets, tool_of

HERE = Path(__file__).parent
MIXED = HERE / "data" / "chains" / "mixed_optimal.toml"
RAPID = HERE / "data" / "rapid"
QUICK = {"plan.verify": "off", "plan.duration_tolerance": 0.01}
#: The fast search cut to the quintic's scalar searches: the chain's machinery, not the search's reach, is tested.
QUINTIC = dataclasses.replace(FAST, steps=1, racing=False, polish_plans=0)


def _segment_distance(points, a, b):
    ab = b - a
    t = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


@pytest.fixture(scope="module")
def mixed():
    setup = api.search(api.load(MIXED, {"plan.duration_tolerance": 0.01}))  # the final plan certified
    symmetric = api.load(MIXED, {"plan.duration_tolerance": 0.01, "path.blends[0].type": "g2"})
    return setup, api.plan_scenario(setup), symmetric, api.plan_scenario(symmetric)


def test_mixed_chain_is_searched_where_task_segments_meet(mixed):
    setup, result, symmetric, symmetric_result = mixed
    kinds = [p.kind for p in setup.path.pieces]
    assert kinds == [p.kind for p in symmetric.path.pieces] == ["joint", "blend", "task", "task", "blend", "joint"]
    assert setup.blend_request is None
    assert [w for _, w in setup.path.dwells] == [w for _, w in symmetric.path.dwells] == [0.2]
    assert result.duration <= symmetric_result.duration * (1 + 1e-9)
    # the corner before the dwell got a searched blend that is not the symmetric one
    searched = [s.length for s in setup.path.pieces[2].path.task_path.segments]
    plain = [s.length for s in symmetric.path.pieces[2].path.task_path.segments]
    assert len(plain) == 3 and (len(searched) != 3 or not np.allclose(searched, plain, rtol=1e-6))


def test_mixed_chain_stays_within_the_tolerance_and_stops_at_the_dwell(mixed):
    setup, *_ = mixed
    robot, path = setup.robot, setup.path
    corners = {2: ([0.4, 0.25, 0.45], [0.48, 0.25, 0.45], [0.48, 0.25, 0.38]),
               3: ([0.48, 0.25, 0.38], [0.48, 0.25, 0.45], [0.48, 0.12, 0.45])}
    for index, polyline in corners.items():
        piece = path.pieces[index]
        theta = np.linspace(piece.lo, piece.hi, 600)
        tcp = fk(robot, path(theta))[0]
        pts = np.asarray(polyline)
        distance = np.minimum(_segment_distance(tcp, pts[0], pts[1]), _segment_distance(tcp, pts[1], pts[2]))
        assert distance.max() <= 0.005 + 1e-6
    (theta_dwell, wait), = path.dwells
    assert wait == 0.2
    np.testing.assert_allclose(fk(robot, path(np.array([theta_dwell])))[0][0], [0.48, 0.25, 0.38], atol=1e-5)


def test_mixed_chain_plans_certified(mixed):
    _, result, *_ = mixed
    assert not api.plan_failures(result)
    assert result.ratios.method == "certified"
    assert max(v for v in result.ratios.values.values() if v is not None) <= 1 + result.settings.limit_tolerance


def _imported(name, monkeypatch, overrides=None):
    monkeypatch.setitem(searches.SEARCHES, "fast", QUINTIC)
    prog = read_rapid(RAPID / f"{name}.mod", api.rapid_flange("irb140"))
    text = scenario_toml(prog, api.rapid_zone_tolerances(prog), blend="optimal")
    return text, api.search(api.load_text(text, RAPID, {**QUICK, **(overrides or {})}))


@pytest.mark.parametrize("name", ["palletizing", "tending"])
def test_fixture_programs_plan_with_optimal_blends_and_meet_their_fine_points(name, monkeypatch, tmp_path):
    text, setup = _imported(name, monkeypatch)
    result = api.plan_scenario(setup)
    api.write_plan(setup, result, tmp_path)
    _, rows = read_rows(tmp_path / "moves.csv")  # one row per program move, the cycle split among them
    assert len(rows) == len(setup.scenario.path.segments)
    assert sum(r["cycle_s"] for r in rows) == pytest.approx(result.duration, rel=1e-6)
    g2 = api.load_text(text.replace('type = "optimal"', 'type = "g2"'), RAPID, QUICK)
    assert result.duration <= api.plan_scenario(g2).duration * (1 + 1e-9)
    assert ('type = "optimal"' in text) == (name == "tending")  # palletizing's zones all join MoveJ
    targets, decl = fine_targets(RAPID / f"{name}.mod")
    tool_p, tool_r = tool_of(decl, RAPID / f"{name}.mod")
    path = setup.path
    stops = np.array(sorted({*path.kinks, *path.domain, *(t for t, _ in path.dwells)}))
    flange_p, flange_r = fk(load_robot("irb140"), path(stops))
    tcp_p = flange_p + np.einsum("nij,j->ni", flange_r, tool_p)
    tcp_r = flange_r @ tool_r
    for target, p, r in targets:
        k = int(np.argmin(np.linalg.norm(tcp_p - p, axis=1)))
        assert np.linalg.norm(tcp_p[k] - p) < 1e-5, target
        assert math.degrees(Rotation.from_matrix(tcp_r[k].T @ r).magnitude()) < 0.01, target


def test_an_optimal_blend_at_a_dwell_is_refused():
    with pytest.raises(ScenarioError, match=r"path.blends\[0\]: corner 3 is at a dwell"):
        api.load(MIXED, {**QUICK, "path.blends[0].corner": 3})


# ------------------------------------------------------------------------------------------- on a Dask cluster
def test_runs_searched_on_a_dask_cluster_equal_the_serial_search(monkeypatch):
    distributed = pytest.importorskip("distributed")
    monkeypatch.setitem(searches.SEARCHES, "fast", QUINTIC)
    serial = api.search(api.load(MIXED, QUICK))
    calls = []
    monkeypatch.setattr(searches, "run_on_cluster", lambda *a, **k: calls.append(a) or run_on_cluster(*a, **k))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                   dashboard_address=None) as cluster:
        clustered = api.search(api.load(MIXED, {**QUICK, "plan.scheduler": cluster.scheduler_address}))
    assert len(calls) == 1 and len(calls[0][2]) == 2  # both task runs went to the cluster
    for a, b in zip(serial.path.pieces, clustered.path.pieces):
        assert (a.kind, a.lo, a.hi) == (b.kind, b.lo, b.hi)
        theta = np.linspace(a.lo, a.hi, 50)
        np.testing.assert_array_equal(serial.path(theta), clustered.path(theta))
    assert api.plan_scenario(serial).duration == api.plan_scenario(clustered).duration


def test_a_bad_or_unreachable_scheduler_is_one_clear_error():
    with pytest.raises(ScenarioError, match=r"plan.scheduler.*not a Dask scheduler address"):
        api.load(MIXED, {**QUICK, "plan.scheduler": "localhost"})
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(PathmotionError, match="cannot reach the Dask scheduler"):
        api.search(api.load(MIXED, {**QUICK, "plan.scheduler": f"tcp://127.0.0.1:{port}"}))


def test_plan_refuses_a_bad_scheduler_option_before_any_work(tmp_path):
    from typer.testing import CliRunner

    from pathmotion.cli import app

    res = CliRunner().invoke(app, ["plan", str(MIXED), "--out", str(tmp_path / "o"), "--scheduler", "no-port"])
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 1 and len(lines) == 1 and lines[0].startswith("error: --scheduler"), res.output
    assert "tcp://HOST:PORT" in lines[0] and not (tmp_path / "o").exists()
