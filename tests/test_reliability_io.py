"""The I/O edges through the command line: special input files, byte caps, TOML depth, output
folders checked before any work, write errors named, a result folder replaced as one unit under a lock,
umask-respecting modes, warnings and parser lines kept off the terminal. Each refusal: exit 1, one
``error:`` line, no traceback, no temporary file left."""

import errno
import json
import logging
import os
import signal
import subprocess
import sys
import time
import tomllib
import warnings
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pathmotion import defaults
from pathmotion.cli import PROGRESS_LINE, app
from pathmotion.errors import OutputError, ScenarioError
from pathmotion.io import atomic, files

from reliability_cases import ARM, JOINT, urdf

runner = CliRunner()


def one_error_line(res, *words) -> str:
    """The one ``error:`` line of a failed run (the progress line of each stage it started aside)."""
    lines = [ln for ln in res.output.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert res.exit_code == 1, (res.exit_code, res.output)
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def leftovers(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.endswith(".tmp") or p.name.endswith(".lock")]


@pytest.fixture
def joint(tmp_path) -> Path:
    path = tmp_path / "joint.toml"
    path.write_text(JOINT)
    return path


# ------------------------------------------------------------------------------------------ inputs
def test_special_files_as_scenario_are_refused_by_name(tmp_path):
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)  # opening it blocking would hang forever: it has no writer
    loop = tmp_path / "loop.toml"
    os.symlink(tmp_path / "loop2.toml", loop)
    os.symlink(loop, tmp_path / "loop2.toml")
    cases = {fifo: "not a regular file", loop: "symbolic links", tmp_path: "is a folder",
             Path("/dev/zero"): "not a regular file", Path("/dev/urandom"): "not a regular file",
             Path("/proc/self/status"): "not a regular file", tmp_path / ("n" * 300): "too long"}
    if os.path.exists("/dev/tty"):
        cases[Path("/dev/tty")] = "not a regular file"
    for path, words in cases.items():
        res = runner.invoke(app, ["check", str(path)])
        one_error_line(res, "scenario file", words)


def test_byte_cap_reads_exactly_the_cap_and_refuses_one_more(tmp_path, monkeypatch):
    monkeypatch.setattr(defaults, "MAX_TOML_BYTES", len(JOINT))
    path = tmp_path / "s.toml"
    path.write_text(JOINT)
    assert files.read_input(path, "scenario") == JOINT
    path.write_text(JOINT + "\n")
    with pytest.raises(ScenarioError, match=rf"larger than {len(JOINT):,} bytes \(defaults.MAX_TOML_BYTES\)"):
        files.read_input(path, "scenario")
    res = runner.invoke(app, ["check", str(path)])
    one_error_line(res, "s.toml", "defaults.MAX_TOML_BYTES")


def _depth(node) -> int:
    """Nesting of arrays and tables in a parsed document (an independent count)."""
    if isinstance(node, dict):
        return 1 + max((_depth(v) for v in node.values()), default=0)
    if isinstance(node, list):
        return 1 + max((_depth(v) for v in node), default=0)
    return 0


@pytest.mark.parametrize("depth", [1, 2, 5, 17, 32])
def test_toml_depth_scan_agrees_with_the_parsed_document(depth):
    text = ('name = "[[[{ not. a. key. ]]"  # [[[ {{ a.b.c.d\n'
            f"x = {'[' * depth}1{']' * depth}\n"
            f"y = {'{a = ' * depth}2{'}' * depth}\n"
            f"{'.'.join(['k'] * depth)} = '''\n[[[ ...\n'''\n")
    doc = tomllib.loads(text)
    nesting, keys = files.toml_depth(text)
    assert nesting == _depth(doc["x"]) == _depth(doc["y"]) == depth
    parts, node = 1, doc["k"]
    while isinstance(node, dict):
        parts, node = parts + 1, node["k"]
    assert keys == parts == depth


def test_toml_nested_beyond_the_limit_is_refused_without_recursion(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    one_error_line(runner.invoke(app, ["check", str(path)]), "deep.toml", "nested 100000 deep", "MAX_TOML_DEPTH")
    path.write_text(".".join(["k"] * 20_000) + " = 1\n")
    one_error_line(runner.invoke(app, ["check", str(path)]), "dotted key of 20000 parts")
    res = runner.invoke(app, ["check", str(path), "--set", "plan.start=" + "[" * 5000 + "]" * 5000])
    one_error_line(res, "nested 5000 deep")


def test_urdf_parser_lines_never_reach_the_terminal(tmp_path):
    (tmp_path / "arm.urdf").write_text(urdf(limit='<limit lower="-3" upper="abc" velocity="2" effort="50"/>'))
    (tmp_path / "arm.toml").write_text(ARM)
    proc = subprocess.run([sys.executable, "-c", "from pathmotion.cli import main; main()", "check",
                           str(tmp_path / "arm.toml")], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stderr
    lines = [ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: URDF of arm cannot be parsed"), lines
    assert "upper value (abc) is not a valid float" in lines[0]


def test_warnings_are_logged_not_printed(joint, monkeypatch, caplog):
    import numpy as np

    from pathmotion import api

    real = api.load

    def noisy(*args, **kwargs):
        with np.errstate(divide="warn"):
            np.log(np.zeros(1))  # RuntimeWarning: divide by zero
        warnings.warn("a numpy-style warning", RuntimeWarning)
        return real(*args, **kwargs)

    monkeypatch.setattr(api, "load", noisy)
    caplog.set_level(logging.DEBUG, logger="pathmotion.cli")
    res = runner.invoke(app, ["check", str(joint)])
    assert "divide by zero" in caplog.text and "a numpy-style warning" in caplog.text
    assert res.exit_code == 0, res.output
    assert "Warning" not in res.output and "divide" not in res.output


# ----------------------------------------------------------------------------------------- outputs
@pytest.mark.parametrize("kind", ["file", "under_file", "dev_null", "sys", "too_long", "read_only"])
def test_bad_out_is_refused_before_any_work(kind, tmp_path, monkeypatch):
    (tmp_path / "afile").write_text("x")
    out = {"file": tmp_path / "afile", "under_file": tmp_path / "afile" / "sub", "dev_null": Path("/dev/null"),
           "sys": Path("/sys/pathmotion"), "too_long": tmp_path / ("o" * 250), "read_only": tmp_path / "ro" / "out"}[kind]
    if kind == "read_only":  # (tests may run as root, who ignores permission bits: simulate the mount)
        def read_only(*args, **kwargs):
            raise OSError(errno.EROFS, "Read-only file system")
        monkeypatch.setattr(files.tempfile, "mkdtemp", read_only)
    # a scenario that does not exist: the --out check comes first, so it is the one reported
    res = runner.invoke(app, ["plan", str(tmp_path / "missing.toml"), "--out", str(out), "--no-figures"])
    line = one_error_line(res, "output folder")
    assert "missing.toml" not in line
    assert not (tmp_path / "ro").exists() and not leftovers(tmp_path)


def _plan(joint: Path, out: Path, *extra):
    return runner.invoke(app, ["plan", str(joint), "--out", str(out), "--no-figures", *extra])


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("code,words", [(errno.ENOSPC, "disk is full"), (errno.EROFS, "read-only"),
                                        (errno.EACCES, "permission denied")])
def test_write_errors_are_named_and_keep_the_previous_results(code, words, joint, tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert _plan(joint, out).exit_code == 0
    before = snapshot(out)
    real = os.fsync

    def failing(fd):
        if os.readlink(f"/proc/self/fd/{fd}").endswith(".tmp") and "summary.json" in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(code, os.strerror(code))
        return real(fd)

    monkeypatch.setattr(atomic.os, "fsync", failing)
    line = one_error_line(_plan(joint, out, "--set", "plan.grid_points=70"), "summary.json", words)
    assert line.startswith("error: cannot write ")
    assert snapshot(out) == before and not leftovers(tmp_path)


def test_a_folder_with_a_result_file_name_and_a_file_in_the_path_are_named(tmp_path):
    (tmp_path / "summary.json").mkdir()
    with pytest.raises(OutputError, match=r"summary.json: a folder has that name"):
        atomic.write_json(tmp_path / "summary.json", {})
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputError, match=r"f/x.csv: a part of the path is a file"):
        atomic.write_text(tmp_path / "f" / "x.csv", "a\n")
    assert not leftovers(tmp_path)


def test_result_folder_is_replaced_as_one_unit(joint, tmp_path):
    out = tmp_path / "out"
    assert _plan(joint, out).exit_code == 0
    before = snapshot(out)
    (out / "stale_extra.txt").write_text("from an older version")
    with pytest.raises(KeyboardInterrupt):  # interrupted after writing half of the files
        with atomic.result_folder(out) as new:
            (new / "summary.json").write_text("{}")
            raise KeyboardInterrupt
    assert snapshot(out) == {**before, "stale_extra.txt": b"from an older version"}
    assert not leftovers(tmp_path)
    assert _plan(joint, out, "--set", "plan.grid_points=70").exit_code == 0
    after = snapshot(out)
    assert "stale_extra.txt" not in after  # the new folder replaced the old one, not merged into it
    assert json.loads(after["summary.json"])["grid_points"] != json.loads(before["summary.json"])["grid_points"]
    assert set(after) == set(before)


def test_stale_temporary_siblings_are_cleaned_and_a_half_swap_is_undone(tmp_path):
    out = tmp_path / "out"
    (tmp_path / ".out.pm-new-abc.tmp").mkdir()
    (tmp_path / ".out.pm-new-abc.tmp" / "half.csv").write_text("t\n")
    old = tmp_path / ".out.pm-old-def.tmp"  # killed between the two renames: out missing, old complete
    old.mkdir()
    (old / "summary.json").write_text('{"old": true}')
    (tmp_path / ".other.pm-new-x.tmp").mkdir()  # another folder's: not ours to touch
    with atomic.output_lock(out):
        atomic._clean_stale(out.absolute())
    assert (out / "summary.json").read_text() == '{"old": true}'
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.pm-new-x.tmp", "out"]


def test_concurrent_run_is_refused_naming_the_pid_and_a_dead_runs_lock_is_taken_over(joint, tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\nfrom pathmotion.io.atomic import output_lock\n"
                               f"with output_lock({str(out)!r}):\n    print('held', flush=True)\n    time.sleep(600)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        one_error_line(_plan(joint, out), f"pid {holder.pid}", "another pathmotion run", "choose another --out")
    finally:
        holder.send_signal(signal.SIGKILL)  # dies holding the lock: the file stays, with its pid
        holder.wait(timeout=60)
    assert (tmp_path / ".out.lock").read_text().strip() == str(holder.pid)
    res = _plan(joint, out)
    assert res.exit_code == 0, res.output
    assert (out / "summary.json").exists() and not leftovers(tmp_path)


@pytest.mark.parametrize("mask", [0o022, 0o027])
def test_result_files_respect_the_umask(mask, joint, tmp_path):
    old = os.umask(mask)
    try:
        assert _plan(joint, tmp_path / "out").exit_code == 0
    finally:
        os.umask(old)
    assert (tmp_path / "out").stat().st_mode & 0o777 == 0o777 & ~mask
    for p in (tmp_path / "out").iterdir():
        assert p.stat().st_mode & 0o777 == 0o666 & ~mask, p


@pytest.mark.slow
def test_interrupted_plans_leave_the_old_folder_or_the_new_one(joint, tmp_path):
    out = tmp_path / "out"
    cmd = [sys.executable, "-c", "from pathmotion.cli import main; main()", "plan", str(joint), "--out", str(out),
           "--no-figures"]
    started = time.perf_counter()
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    span = time.perf_counter() - started
    before = snapshot(out)
    for k in range(6):
        proc = subprocess.Popen(cmd + ["--set", f"plan.grid_points={70 + 20 * k}"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE)
        time.sleep((0.3 + 0.1 * k) * span)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=300)
        assert "Traceback" not in err.decode()
        now = snapshot(out)
        if now != before:  # the new folder, whole: every file of the run is new (the summary's reported
            # grid_points may coincide between requested 70..75, so the files themselves are compared)
            assert set(now) == set(before)
            assert all(now[n] != before[n] for n in ("summary.json",))
            assert all(now[n] != before[n] for n in ("trajectory.csv", "phase_plane.csv", "trajectory.parquet"))
            before = now
        assert not leftovers(tmp_path)


# ---------------------------------------------------------------------------------- guarded values
def test_simulation_sample_count_is_guarded(joint, tmp_path):
    res = runner.invoke(app, ["simulate", str(joint), "--out", str(tmp_path / "out"), "--no-figures",
                              "--set", "simulate.sample_time=1e-7"])
    one_error_line(res, "simulate.sample_time = 1e-07 s", "defaults.MAX_TRAJECTORY_SAMPLES")
    assert not (tmp_path / "out").exists() and not leftovers(tmp_path)


@pytest.mark.parametrize("address", ["garbage", "tcp://1.2.3.4", "tcp://host:99999", "http://host:8786 x"])
def test_scheduler_address_is_checked_before_any_work(address, tmp_path):
    res = runner.invoke(app, ["sweep", str(tmp_path / "missing.toml"), "--set", "plan.grid_points=60,70",
                              "--out", str(tmp_path / "out"), "--scheduler", address])
    one_error_line(res, "--scheduler", "tcp://HOST:PORT")


def test_report_tables_and_rapid_files_are_read_through_the_one_input_rule(tmp_path):
    """A FIFO as a result table or RAPID module is refused by name at once (it hung before), and a table
    above the result cap is refused without being read."""
    import threading

    import numpy as np

    from pathmotion.errors import PathmotionError, ScenarioError
    from pathmotion.io.rapid import read_rapid
    from pathmotion.report.tables import read_columns, read_rows

    fifo = tmp_path / "trajectory.csv"
    os.mkfifo(fifo)
    done = []

    def attempt():
        for reader, error in ((read_columns, PathmotionError), (read_rows, PathmotionError), (read_rapid, ScenarioError)):
            try:
                reader(fifo)
            except error as exc:
                done.append(str(exc))

    worker = threading.Thread(target=attempt, daemon=True)
    worker.start()
    worker.join(60)
    assert len(done) == 3 and all("not a regular file" in m and str(fifo) in m for m in done), done
    table = tmp_path / "t.csv"
    table.write_text("a,b\n1,2\n3,4\n")
    np.testing.assert_array_equal(read_columns(table, ("a",))["b"], [2.0, 4.0])
    assert read_rows(table) == (["a", "b"], [{"a": 1, "b": 2}, {"a": 3, "b": 4}])
