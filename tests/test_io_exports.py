"""Exports: CSV/Parquet round trips, the ROS 2 JointTrajectory message parsed back, EGM stream, RAPID."""

import io
import os

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from pathmotion.errors import PathmotionError
from pathmotion.io import exports
from pathmotion.io.atomic import atomic_path, write_json
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.planning.trajectory import Trajectory


@pytest.fixture(scope="module")
def samples(irb140):
    wp = np.array([[0, 0, 0, 0, 0.5, 0], [0.5, 0.2, -0.3, 0.4, 0.8, 1.0], [1.0, 0.4, -0.1, 0.0, 0.5, 2.0]])
    path = SplineJointPath.from_waypoints(wp)
    grid = np.linspace(0, 1, 201)
    x = 4.0 * np.sin(np.pi * grid) ** 2 + 1e-3  # a smooth, slow profile
    return Trajectory(path, Profile(grid, x), irb140).sample(0.004)


def test_csv_round_trip(tmp_path, samples):
    path = exports.write_trajectory_csv(tmp_path / "t.csv", samples)
    header = path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["t", "theta", "theta_dot", "theta_ddot"]
    assert header[4:10] == [f"q{j}" for j in range(1, 7)] and header[-1] == "tau6"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data[:, 0], samples.t)  # %.17g round-trips exactly
    np.testing.assert_array_equal(data[:, 4:10], samples.q)


def test_parquet_round_trip(tmp_path, samples):
    path = exports.write_trajectory_parquet(tmp_path / "t.parquet", samples)
    table = pq.read_table(path)
    np.testing.assert_array_equal(table.column("qd3").to_numpy(), samples.qd[:, 2])
    np.testing.assert_array_equal(table.column("tau2").to_numpy(), samples.tau[:, 1])


def test_ros2_yaml_parses_back_one_point_per_cycle(tmp_path, samples, irb140):
    path = exports.write_ros2_yaml(tmp_path / "traj.yaml", samples, irb140.joint_names)
    msg = yaml.safe_load(path.read_text())
    assert set(msg) == {"header", "joint_names", "points"}
    assert msg["joint_names"] == list(irb140.joint_names)
    ns = np.array([p["time_from_start"]["sec"] * 10**9 + p["time_from_start"]["nanosec"] for p in msg["points"]])
    np.testing.assert_array_equal(np.diff(ns), 4_000_000)  # every point exactly one 4 ms cycle after the last
    assert ns[0] == 0 and samples.t[-1] <= ns[-1] * 1e-9 < samples.t[-1] + 0.004
    assert all(0 <= p["time_from_start"]["nanosec"] < 1_000_000_000 for p in msg["points"])
    for k in (0, len(ns) // 2, len(ns) - 1):  # the samples at the same times; the last: the end state
        i = min(k, len(samples.t) - 1)
        np.testing.assert_allclose(msg["points"][k]["positions"], samples.q[i], rtol=0, atol=1e-9)
        np.testing.assert_allclose(msg["points"][k]["velocities"], samples.qd[i], rtol=0, atol=1e-9)
        np.testing.assert_allclose(msg["points"][k]["accelerations"], samples.qdd[i], rtol=0, atol=1e-9)


def test_ros2_yaml_text_is_what_pyyaml_writes(tmp_path, samples, irb140):
    """The points are formatted directly; the text is the one yaml.dump writes for the same message."""
    from dataclasses import replace

    bent = replace(samples, q=samples.q * np.array([1.0, 1e-7, -3e5, 1e17, 1.0, 0.0]))  # exponents, 0, large
    for s in (samples, bent):
        path = exports.write_ros2_yaml(tmp_path / "traj.yaml", s, irb140.joint_names, notes=["a note"])
        msg = exports.ros2_joint_trajectory(s, irb140.joint_names)
        expected = "# a note\n" + yaml.dump(msg, Dumper=yaml.SafeDumper, sort_keys=False, default_flow_style=None,
                                             width=1000)
        assert path.read_text() == expected


def test_ros2_rejects_wrong_joint_names(samples):
    with pytest.raises(PathmotionError, match="joint names"):
        exports.ros2_joint_trajectory(samples, ["a", "b"])


def test_egm_stream_rows_are_exactly_one_cycle_apart_and_read_cleanly(tmp_path, samples):
    path = exports.write_egm_csv(tmp_path / "egm.csv", samples, sample_time=0.004)
    text = path.read_text()
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    k = np.arange(len(data))
    np.testing.assert_array_equal(data[:, 0], np.round(k * 0.004, 9))  # the last row too
    assert samples.t[-1] <= data[-1, 0] < samples.t[-1] + 0.004
    rows = text.splitlines()[1:]
    assert rows[1].startswith("0.004,") and rows[3].startswith("0.012,")  # not 0.0040000000000000001
    assert ",-0.0," not in text and not any(r.endswith(",-0.0") for r in rows)
    expected = np.degrees(np.array([np.interp(np.minimum(data[:, 0], samples.t[-1]), samples.t, samples.q[:, j])
                                    for j in range(6)]).T)
    np.testing.assert_allclose(data[:, 1:7], expected, atol=1e-9)
    np.testing.assert_allclose(data[-1, 1:7], np.degrees(samples.q[-1]), atol=1e-9)  # the end state


def test_tidy_rounds_and_removes_negative_zero():
    out = exports.tidy(np.array([-1e-12, 0.1 + 0.2, -0.0]), 9)
    assert [repr(v) for v in out.tolist()] == ["0.0", "0.3", "0.0"]


def test_rapid_module_structure(samples):
    text = exports.rapid_module(samples, step=0.05)
    assert text.startswith("MODULE PathmotionReplay") and text.rstrip().endswith("ENDMODULE")
    n = int(text.split("CONST num n_points := ")[1].split(";")[0])
    targets = text.split("CONST jointtarget path{")[1].split("];")[0]
    assert targets.count("[[") == n
    move_times = [float(v) for v in text.split("CONST num move_time{")[1].split(":= [")[1].split("]")[0].split(",")]
    assert len(move_times) == n
    assert sum(move_times) == pytest.approx(samples.t[-1], abs=1e-5)
    first = [float(v) for v in targets.split("[[")[1].split("]")[0].split(",")]
    np.testing.assert_allclose(first, np.degrees(samples.q[0]), atol=1e-5)
    with pytest.raises(PathmotionError):
        exports.rapid_module(samples, module="bad name")


def test_atomic_write_keeps_old_file_on_failure(tmp_path):
    target = tmp_path / "summary.json"
    write_json(target, {"a": 1})
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert yaml.safe_load(target.read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_json_is_strict_with_inf_as_a_string_and_nan_as_null(tmp_path):
    import json

    path = write_json(tmp_path / "x.json", {"v": float("nan"), "w": np.float64(2.0), "k": np.int64(3),
                                            "r": float("inf"), "s": -np.inf})
    data = json.loads(path.read_text(), parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert data == {"k": 3, "v": None, "w": 2.0, "r": "inf", "s": "-inf"}
    assert float(data["r"]) == np.inf


@pytest.mark.parametrize("umask, expected", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_written_files_respect_the_umask(tmp_path, samples, umask, expected):
    """Every writer (text, JSON, Parquet) creates files as open() would: 0666 minus the umask."""
    import stat


    old = os.umask(umask)
    try:
        paths = [write_json(tmp_path / "s.json", {"a": 1}), exports.write_trajectory_csv(tmp_path / "t.csv", samples),
                 exports.write_trajectory_parquet(tmp_path / "t.parquet", samples)]
        reference = tmp_path / "plain.txt"
        reference.write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(reference.stat().st_mode) == expected  # the independent reference: open()
    for p in paths:
        assert stat.S_IMODE(os.stat(p).st_mode) == expected, p


@pytest.mark.parametrize("rows", [0, 1, exports.CSV_BLOCK_ROWS + 7])
def test_table_csv_is_savetxt_text(tmp_path, rows):
    """write_table_csv formats blocks of rows at once: the text is np.savetxt's (%.17g, comma-separated), across
    block boundaries and with nan, inf and -0.0, and it reads back to the same floats."""
    data = np.random.default_rng(rows).normal(size=(rows, 3)) * 10.0 ** np.arange(-8, 7, 7)
    if rows:
        data.ravel()[:3] = [np.nan, -np.inf, -0.0]
    path = exports.write_table_csv(tmp_path / "t.csv", {"a": data[:, 0], "b": data[:, 1], "c": data[:, 2]})
    want = io.StringIO()
    want.write("a,b,c\n")
    np.savetxt(want, data, delimiter=",", fmt="%.17g")
    assert path.read_text() == want.getvalue()
    if rows:
        back = exports.read_table_csv(path)
        np.testing.assert_array_equal(np.column_stack([back[k] for k in "abc"]), data)
