"""A sweep on a real Dask cluster (a scheduler and two single-thread worker processes on localhost)
gives the same table, value for value, as the local process pool."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pathmotion.scenarios import scenario_path
from pathmotion.study import run_study_sweep

pytest.importorskip("distributed")

BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def cluster(tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        for k in range(2):
            procs.append(subprocess.Popen([str(BIN / "dask"), "worker", address, "--nthreads", "1", "--no-dashboard",
                                           "--name", f"w{k}", "--local-directory", str(tmp_path / f"w{k}")],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        from distributed import Client

        deadline = time.monotonic() + 40
        while True:
            try:
                with Client(address, timeout="2s") as client:
                    client.wait_for_workers(2, timeout=max(1.0, deadline - time.monotonic()))
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.3)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


@pytest.mark.slow
def test_dask_equals_local(cluster, tmp_path):
    grid = {"path.blends[0].radius": [0.03, 0.2, 0.04], "plan.grid_points": [300]}
    local = run_study_sweep(scenario_path("corner_transition"), grid, tmp_path / "local", workers=2, figures=False)
    dask = run_study_sweep(scenario_path("corner_transition"), grid, tmp_path / "dask", scheduler=cluster,
                           figures=False)
    assert dask.rows == local.rows  # identical values, including the failed point's error
    assert sum(r["error"] is None for r in dask.rows) == 2
    assert (tmp_path / "dask" / "sweep.csv").read_text() == (tmp_path / "local" / "sweep.csv").read_text()
    assert dask.best == local.best


def test_unreachable_scheduler(tmp_path):
    from pathmotion.errors import PathmotionError

    with pytest.raises(PathmotionError, match="cannot reach the Dask scheduler"):
        run_study_sweep(scenario_path("corner_stop"), {"plan.grid_points": [300]}, tmp_path,
                        scheduler=f"tcp://127.0.0.1:{_free_port()}")
