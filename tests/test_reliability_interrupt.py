"""Interruption, determinism and sweeps with failing points.

* ``pathmotion plan`` killed by SIGINT or SIGTERM at points marked by the output folder's state leaves, for every file, the
  previous complete version or a complete new one (CSV/JSON/Parquet/PNG parsed), never a ``*.tmp``;
* an interrupted ``pathmotion sweep`` keeps every finished row and a re-run resumes without redoing them;
* a 40-point sweep on 2 worker processes with failing points records each failure as a row, the rest intact;
* the same scenario gives byte-identical files on repeated runs (every file; in ``summary.json`` every key
  but the wall-clock ``solve_time_s``) and the same sweep tables with 1 and 2 worker processes.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from pathmotion import api
from pathmotion.scenarios import scenario_path
from pathmotion.study import run_study_sweep

#: wall-clock keys, the only ones allowed to differ between identical runs
TIMING_KEYS = {"solve_time_s", "wall_time_s"}


def fast_joint_scenario(folder: Path) -> Path:
    """The shipped joint-waypoint scenario without the torque limit (inactive on it, and the slowest part
    of verification), so that sweep points take well under a second."""
    text = scenario_path("joint_waypoints").read_text().replace("[plan]", "[plan]\ngrid_points = 40", 1)
    text = text.replace("[limits]", "[limits]\nuse_torque = false", 1)
    path = folder / "joint.toml"
    path.write_text(text)
    return path


def cli(*args) -> list[str]:
    return [sys.executable, "-c", "from pathmotion.cli import main; main()", *map(str, args)]


def tmp_files(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.endswith(".tmp")]


def complete(path: Path) -> bool:
    """Whether ``path`` parses as a whole file of its kind."""
    data = path.read_bytes()
    if path.suffix == ".json":
        json.loads(data)
    elif path.suffix == ".csv":
        lines = data.decode().splitlines()
        assert data.endswith(b"\n") and len(lines) >= 2
        width = len(lines[0].split(","))
        assert all(len(ln.split(",")) == width for ln in lines[1:])
    elif path.suffix == ".parquet":
        pq.read_table(path)
    elif path.suffix == ".png":
        assert data.startswith(b"\x89PNG") and data.endswith(b"IEND\xaeB`\x82")
    else:
        assert data.endswith(b"\n")
    return True


def finished_points(out: Path) -> int:
    """Sweep points recorded so far (one JSON file each, written atomically)."""
    return len(list((out / "points").glob("*.json"))) if (out / "points").is_dir() else 0


def table_rows(out: Path) -> int:
    """Data rows in the sweep table (0 before it is first written)."""
    table = out / "sweep.csv"
    return len(table.read_text().splitlines()) - 1 if table.is_file() else 0


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ------------------------------------------------------------------------------------ interruption
def file_ids(folder: Path) -> dict[str, int]:
    """Inode of every file in ``folder``: an atomic write (temporary file renamed over the old one)
    gives the file a new inode, so a changed id means 'a new complete version is in place'."""
    return {p.name: p.stat().st_ino for p in folder.iterdir() if p.is_file()} if folder.is_dir() else {}


def kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL the process group of ``proc`` (started with start_new_session) and reap it: nothing of a
    failed test keeps running."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def signal_when(proc: subprocess.Popen, sig: int, marker, limit_s: float = 300.0) -> bool:
    """Send ``sig`` to ``proc`` as soon as ``marker()`` is true (polled on the file system); True
    when it was sent before the process ended on its own. ``limit_s`` only guards against a hang."""
    deadline = time.monotonic() + limit_s
    while proc.poll() is None and time.monotonic() < deadline:
        if marker():
            proc.send_signal(sig)
            return True
        time.sleep(0.002)
    return False


#: Points of a ``plan`` run at which it is interrupted, each defined by what the output folder shows
#: (no timing): an atomic write has begun (the first temporary file); the new trajectory.csv is in place
#: while the rest is still the previous run's; a figure is being rendered into its temporary file.
KILL_POINTS = {
    "first write": lambda out, before: bool(tmp_files(out.parent)),  # (the run writes into a sibling folder)
    "new trajectory in place": lambda out, before: file_ids(out).get("trajectory.csv") != before["trajectory.csv"],
    "rendering a figure": lambda out, before: any(p.name.startswith((".joints.png", ".phase_plane.png"))
                                                  for p in tmp_files(out.parent)),
}


def check_old_or_new(out: Path, before: dict[str, bytes]) -> None:
    """Every file is the previous complete version or a complete new one; no temporary file is left;
    a new summary.json describes a trajectory that is already complete (it is written after it)."""
    assert not tmp_files(out.parent), tmp_files(out.parent)  # nor a temporary sibling folder
    for name, data in snapshot(out).items():
        if data != before.get(name):
            assert complete(out / name), name
    summary = json.loads((out / "summary.json").read_text())
    if summary["grid_points"] != json.loads(before["summary.json"])["grid_points"]:
        rows = len((out / "trajectory.csv").read_text().splitlines()) - 1
        assert rows >= int(summary["duration_s"] / 0.004)


@pytest.mark.slow
@pytest.mark.parametrize("point, sig", [("first write", signal.SIGINT), ("new trajectory in place", signal.SIGTERM),
                                        ("rendering a figure", signal.SIGINT)])
def test_plan_interrupted_while_writing_leaves_old_or_new_complete_files(tmp_path, point, sig):
    scenario = scenario_path("joint_waypoints")
    out = tmp_path / "out"
    first = subprocess.run(cli("plan", scenario, "--out", out, "--set", "plan.grid_points=300"), capture_output=True)
    assert first.returncode == 0, first.stderr.decode()
    marker = KILL_POINTS[point]
    interrupted = False
    for attempt in range(4):  # the run may finish between the marker and the signal: then try again
        before, ids = snapshot(out), file_ids(out)
        proc = subprocess.Popen(cli("plan", scenario, "--out", out, "--set", f"plan.grid_points={302 + attempt}"),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        sent = signal_when(proc, sig, lambda: marker(out, ids))
        _, err = proc.communicate(timeout=300)
        assert sent or proc.returncode == 0, err.decode()
        # the marker shows the CLI has started and installed its handlers: 130 = its clean exit; 0 = it
        # finished before the signal arrived; -sig = the signal arrived during interpreter shutdown
        assert proc.returncode in (0, 130, -sig), (sig, proc.returncode, err.decode())
        assert "Traceback" not in err.decode()
        check_old_or_new(out, before)
        if proc.returncode == 130:
            interrupted = True
            break
    assert interrupted, f"no run was interrupted at '{point}' in 4 attempts"


@pytest.mark.slow
def test_interrupted_sweep_keeps_finished_rows_and_resumes(tmp_path):
    scenario = fast_joint_scenario(tmp_path)
    out = tmp_path / "sweep"
    count = 12  # 9 points still to run when the signal is sent after 3: the run cannot finish first
    values = ",".join(f"{v:.3f}" for v in np.linspace(0.0, 0.4, count))
    args = cli("sweep", scenario, "--set", f"plan.end={values}", "--out", out, "--workers", "1", "--no-figures")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    # signalled once the table shows 3 rows (it is rewritten, atomically, after each recorded point)
    assert signal_when(proc, signal.SIGTERM, lambda: table_rows(out) >= 3)
    at_signal = finished_points(out)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err.decode()
    assert not tmp_files(out)
    finished = {p.name: p.read_bytes() for p in (out / "points").glob("*.json")}
    # the point being recorded when the signal arrived may still land, no later one
    assert 3 <= at_signal <= len(finished) <= at_signal + 1 < count
    assert complete(out / "sweep.csv") and 3 <= table_rows(out) <= len(finished)
    done = subprocess.run(args, capture_output=True)
    assert done.returncode == 0, done.stderr.decode()
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert len(rows) == count
    for name, data in finished.items():  # finished points were kept, not recomputed
        assert (out / "points" / name).read_bytes() == data


# ------------------------------------------------------------------------------------ sweeps
@pytest.mark.slow
def test_forty_point_sweep_on_two_workers_records_failures_and_keeps_the_rest(tmp_path):
    scenario = fast_joint_scenario(tmp_path)
    ends = [round(v, 2) for v in np.linspace(0.0, 0.95, 20)]  # feasible end speeds are about [0, 0.48]
    grid = {"plan.end": ends, "plan.grid_points": [30, 40]}
    outcome = run_study_sweep(scenario, grid, tmp_path / "sweep", workers=2, figures=False)
    rows = outcome.rows
    assert len(rows) == 40
    failed = [r for r in rows if r["error"]]
    ok = [r for r in rows if not r["error"]]
    assert failed and ok
    assert all(r["error"].startswith("InfeasibleError: end velocity") for r in failed)
    assert all(r["planned_duration_s"] is None for r in failed)
    assert all(r["planned_duration_s"] > 0 and r["tracking_ok"] is not None for r in ok)
    # the feasible end speeds form an interval from 0: every failure is above every success
    assert max(r["plan.end"] for r in ok) < min(r["plan.end"] for r in failed)
    table = (tmp_path / "sweep" / "sweep.csv").read_text().splitlines()
    assert len(table) == 41 and pq.read_table(tmp_path / "sweep" / "sweep.parquet").num_rows == 40


def test_sweep_tables_are_identical_with_one_and_two_workers(tmp_path):
    scenario = fast_joint_scenario(tmp_path)
    grid = {"plan.end": [0.0, 0.3, 2.0], "plan.grid_points": [30, 40]}
    files = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        run_study_sweep(scenario, grid, out, workers=workers, figures=False)
        files[workers] = {name: (out / name).read_bytes() for name in ("sweep.csv", "sweep.parquet", "best.json")}
        recs = [json.loads(p.read_text()) for p in sorted((out / "points").glob("*.json"))]
        files[workers]["points"] = json.dumps([{k: v for k, v in r.items() if k not in TIMING_KEYS} for r in recs])
    assert files[1] == files[2]


# ------------------------------------------------------------------------------------ determinism
def test_repeated_plans_write_byte_identical_files(tmp_path):
    from pathmotion.report.figures import plan_figures

    setup = api.load(scenario_path("corner_transition"), {"plan.grid_points": 150})
    for name in ("a", "b"):
        api.write_plan(setup, api.plan_scenario(setup), tmp_path / name)
        plan_figures(tmp_path / name)  # the CLI's figures, drawn from the written folder
    a, b = snapshot(tmp_path / "a"), snapshot(tmp_path / "b")
    assert a.keys() == b.keys() and {"phase_plane.png", "trajectory.parquet", "trajectory.csv"} <= a.keys()
    for name in a:
        if name == "summary.json":
            sa, sb = (json.loads(x) for x in (a[name], b[name]))
            assert {k: v for k, v in sa.items() if k not in TIMING_KEYS} == \
                   {k: v for k, v in sb.items() if k not in TIMING_KEYS}
        else:
            assert a[name] == b[name], name


def test_atomic_writes_leave_the_previous_file_when_interrupted(tmp_path):
    from pathmotion.io.atomic import atomic_path, write_text

    target = write_text(tmp_path / "f.txt", "old\n")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise KeyboardInterrupt
    assert target.read_text() == "old\n" and not tmp_files(tmp_path)
    assert os.listdir(tmp_path) == ["f.txt"]


@pytest.mark.slow
def test_interrupted_parallel_sweep_stops_without_running_the_queued_points(tmp_path):
    scenario = fast_joint_scenario(tmp_path)
    out = tmp_path / "sweep"
    values = ",".join(f"{v:.3f}" for v in np.linspace(0.0, 0.45, 100))
    proc = subprocess.Popen(cli("sweep", scenario, "--set", f"plan.end={values}", "--set", "plan.grid_points=30,40",
                                "--out", out, "--workers", "2", "--no-figures"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        assert signal_when(proc, signal.SIGTERM, lambda: finished_points(out) >= 3)
        at_signal = finished_points(out)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 130, err.decode()
        # queued points were dropped and running ones stopped: at most the point being recorded when
        # the signal arrived is added (points are recorded by the main process only)
        assert finished_points(out) <= at_signal + 1 < 200
        assert not tmp_files(out)
    finally:
        kill_group(proc)


def spin_point(text, base_dir, overrides, traces):
    """A sweep point that never returns (pure Python, so it never blocks signals); it first leaves
    started-PID in the folder named by the scenario text, so the test knows the worker runs it."""
    Path(text.strip(), f"started-{os.getpid()}").touch()
    while True:
        pass


def test_sigterm_stops_workers_in_the_middle_of_a_point(tmp_path):
    """The parent's terminate() ends a worker wherever it is: a worker that kept the CLI's SIGTERM ->
    KeyboardInterrupt handler returned the exception as the point's result and went on with the next
    queued point, so the interrupted sweep waited for them (here: forever)."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(str(tmp_path) + "\n")
    script = ("import signal, sys; sys.path.insert(0, sys.argv[1])\n"
              "from pathmotion.cli import _interrupt\n"
              "from pathmotion.study.sweep import run_sweep\n"
              "from test_reliability_interrupt import spin_point\n"
              "signal.signal(signal.SIGTERM, _interrupt)\n"
              "try:\n"
              "    run_sweep(sys.argv[2], {'a': [1, 2, 3, 4, 5, 6]}, sys.argv[3], workers=2, point_fn=spin_point)\n"
              "except KeyboardInterrupt:\n"
              "    sys.exit(130)\n")
    proc = subprocess.Popen([sys.executable, "-c", script, str(Path(__file__).parent), str(scenario), str(tmp_path / "out")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    started = lambda: sorted(tmp_path.glob("started-*"))  # noqa: E731
    try:
        assert signal_when(proc, signal.SIGTERM, lambda: len(started()) >= 2)
        _, err = proc.communicate(timeout=300)  # only a hang guard: without the fix this never returns
        assert proc.returncode == 130, err.decode()
        assert len(started()) == 2  # no queued point was started after the signal
        assert finished_points(tmp_path / "out") == 0
        _assert_workers_gone(tmp_path)
    finally:
        kill_group(proc)


def test_a_sigterm_delivered_to_another_thread_still_stops_a_parallel_sweep(tmp_path):
    """The kernel delivers a process-directed SIGTERM to any thread; one that lands on a thread other than the
    main one (here: sent to a thread of the script's own) must still end the sweep. A main thread blocked on the
    workers' results without a timeout was never woken to run the handler: the sweep waited for its points
    (here: forever)."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(str(tmp_path) + "\n")
    script = ("import signal, sys, threading, time; from pathlib import Path; sys.path.insert(0, sys.argv[1])\n"
              "from pathmotion.cli import _interrupt\n"
              "from pathmotion.study.sweep import run_sweep\n"
              "from test_reliability_interrupt import spin_point\n"
              "signal.signal(signal.SIGTERM, _interrupt)\n"
              "def kill_from_here():\n"
              "    while len(list(Path(sys.argv[4]).glob('started-*'))) < 2:\n"
              "        time.sleep(0.01)\n"
              "    signal.pthread_kill(threading.get_ident(), signal.SIGTERM)\n"
              "threading.Thread(target=kill_from_here, daemon=True).start()\n"
              "try:\n"
              "    run_sweep(sys.argv[2], {'a': [1, 2, 3]}, sys.argv[3], workers=2, point_fn=spin_point)\n"
              "except KeyboardInterrupt:\n"
              "    sys.exit(130)\n")
    proc = subprocess.Popen([sys.executable, "-c", script, str(Path(__file__).parent), str(scenario),
                             str(tmp_path / "out"), str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        _, err = proc.communicate(timeout=300)  # only a hang guard: without the fix this never returns
        assert proc.returncode == 130, err.decode()
        assert len(sorted(tmp_path.glob("started-*"))) == 2 and finished_points(tmp_path / "out") == 0
    finally:
        kill_group(proc)


def sleep_call(folder):
    """A call that leaves started-PID in ``folder`` and sleeps (blocking in C, as a numerical call does)."""
    Path(folder, f"started-{os.getpid()}").touch()
    time.sleep(600.0)


def test_an_interrupted_worker_pool_map_ends_its_workers(tmp_path):
    """WorkerPool (the blend search's and the sweep's workers): a Ctrl-C while the main thread waits for a map's
    results raises there and leaves no worker running its call. Run in a subprocess: a hang guard."""
    script = ("import _thread, sys, threading, time; from pathlib import Path; sys.path.insert(0, sys.argv[1])\n"
              "from pathmotion.io.processes import WorkerPool\n"
              "from test_reliability_interrupt import sleep_call\n"
              "def interrupt():\n"
              "    while len(list(Path(sys.argv[2]).glob('started-*'))) < 2:\n"
              "        time.sleep(0.01)\n"
              "    _thread.interrupt_main()\n"
              "threading.Thread(target=interrupt, daemon=True).start()\n"
              "try:\n"
              "    with WorkerPool(2) as pool:\n"
              "        pool.map(sleep_call, [(sys.argv[2],), (sys.argv[2],)])\n"
              "except KeyboardInterrupt:\n"
              "    sys.exit(130)\n")
    proc = subprocess.Popen([sys.executable, "-c", script, str(Path(__file__).parent), str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        _, err = proc.communicate(timeout=300)  # the workers hold the pipes: this returns once they are gone
        assert proc.returncode == 130, err.decode()
        assert len(list(tmp_path.glob("started-*"))) == 2
        _assert_workers_gone(tmp_path)
    finally:
        kill_group(proc)


def _assert_workers_gone(folder: Path) -> None:
    """Every worker that left started-PID in ``folder`` has exited (within 60 s: reaped by init once its parent has
    exited)."""
    for marker in folder.glob("started-*"):
        pid = int(marker.name.split("-")[1])
        deadline = time.monotonic() + 60
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(pid), marker.name


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie has exited: only its process-table entry is left
        return Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
def test_ctrl_c_to_a_parallel_sweeps_process_group_prints_one_line(tmp_path):
    """Ctrl-C at a terminal sends SIGINT to the whole process group, workers included: the workers ignore
    it, the parent prints one line and exits 130 (it printed ~147 lines of worker tracebacks before)."""
    scenario = fast_joint_scenario(tmp_path)
    out = tmp_path / "sweep"
    values = ",".join(f"{v:.3f}" for v in np.linspace(0.0, 0.45, 100))
    proc = subprocess.Popen(cli("sweep", scenario, "--set", f"plan.end={values}", "--out", out, "--workers", "2",
                                "--no-figures"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while proc.poll() is None and finished_points(out) < 2 and time.monotonic() < deadline:
            time.sleep(0.005)
        assert proc.poll() is None, "the sweep ended before it could be interrupted"
        os.killpg(proc.pid, signal.SIGINT)  # the parent and both workers, as a terminal's Ctrl-C
        _, err = proc.communicate(timeout=300)
        # (off a terminal a sweep prints a progress line per finished point; the interrupt is one more line)
        lines = [ln for ln in err.decode().splitlines() if ln.strip() and not ln.startswith("sweep: ")]
        assert proc.returncode == 130 and len(lines) == 1 and lines[0].startswith("interrupted"), err.decode()
        assert "Traceback" not in err.decode() and not tmp_files(out)
    finally:
        kill_group(proc)


@pytest.mark.parametrize("address", ["garbage", "tcp://", "xyz://host:1", "tcp://host:99999", 8786])
def test_a_bad_dask_address_is_a_scenario_error_for_api_callers(tmp_path, address):
    from pathmotion.errors import ScenarioError
    from pathmotion.study.sweep import _run_dask

    with pytest.raises(ScenarioError, match="tcp://HOST:PORT"):
        _run_dask(address, ("", "."), [], lambda *a: None, None, False)


def test_an_exception_after_a_signal_is_the_interrupt_not_an_internal_error(monkeypatch):
    """A C extension may swallow the KeyboardInterrupt a signal raised and raise another exception (pybind11's
    argument conversion: "TypeError: incompatible function arguments" from matplotlib's affine_transform, seen in
    CI while a figure rendered): after a signal the command exits 130; without one the same exception is a bug,
    exit 3."""
    import typer

    from pathmotion import cli

    @cli.guarded
    def swallowed():
        raise TypeError("affine_transform(): incompatible function arguments")

    monkeypatch.setattr(cli, "_SIGNALLED", [])
    with pytest.raises(typer.Exit) as bug:
        swallowed()
    assert bug.value.exit_code == 3
    with pytest.raises(KeyboardInterrupt):
        cli._interrupt(signal.SIGINT, None)
    assert cli._SIGNALLED == [signal.SIGINT]
    with pytest.raises(typer.Exit) as interrupted:
        swallowed()
    assert interrupted.value.exit_code == 130
