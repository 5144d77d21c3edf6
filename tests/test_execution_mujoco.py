"""The virtual IRC5 with MuJoCo moving the links (simulation's MujocoPlant): in lockstep over real UDP it runs the
motion to its end, and it agrees with the built-in plant: exactly (to round-off) with rigid gears, where both
integrate the same rigid arm by RK4 with the motor torque held; within the splitting error with elastic gears,
which shrinks with the square of the coupling step."""

from __future__ import annotations

import threading

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")
pytest.importorskip("mujoco")

from egm_support import irb140_task, line, planned as planned_scenario  # noqa: E402
from pathmotion.errors import ExecutionError  # noqa: E402
from pathmotion.execution import drives as drives_module  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.loops import open_listener, run_virtual_robot, serve  # noqa: E402
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess  # noqa: E402
from pathmotion.robot import fk  # noqa: E402

LINE = irb140_task("egm_mujoco", line([0.45, -0.05, 0.5], [0.45, 0.05, 0.45]))


@pytest.fixture(scope="module")
def planned():
    return planned_scenario(LINE)


def _run(robot, result, drives, plant):
    st = make_streamer(robot, result, "shaping", drives)
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0], plant=plant), result.duration + 0.5)
    return run, arm_figures(robot, run)


def _tcp_gap(robot, a, b) -> float:
    k = min(len(a.q), len(b.q))
    return float(np.linalg.norm(fk(robot, a.q[:k])[0] - fk(robot, b.q[:k])[0], axis=1).max())


def test_rigid_gears_mujoco_equals_builtin(planned):
    """Rigid gears: both plants integrate M(q) qdd + h = tau (rotors on the diagonal) by classical RK4 with tau
    held over the servo period, MuJoCo from its own reading of the URDF: the TCPs agree to 1e-9 m."""
    robot, result, drives = planned
    (a, fa), (b, fb) = (_run(robot, result, drives.rigid(), p) for p in ("builtin", "mujoco"))
    assert _tcp_gap(robot, a, b) < 1e-9
    assert abs(fa["path_accuracy_m"] - fb["path_accuracy_m"]) < 1e-9


def test_elastic_gears_mujoco_agrees_within_the_splitting_error(planned, monkeypatch):
    """Elastic gears (on a plan whose motors reach their torque limit): MuJoCo's links against the built-in
    two-mass RK4 within 0.01 mm at the TCP and in path accuracy; at a five times shorter coupling step the gap
    is at most a tenth (second-order splitting: 1/25), so the gap is the splitting's, not a model difference."""
    robot, result, drives = planned
    base, fig_base = _run(robot, result, drives, "builtin")
    coarse, fig = _run(robot, result, drives, "mujoco")
    gap = _tcp_gap(robot, base, coarse)
    assert 0.0 < gap < 1e-5 and abs(fig["path_accuracy_m"] - fig_base["path_accuracy_m"]) < 1e-5
    monkeypatch.setattr(drives_module, "COUPLING_PHASE", drives_module.COUPLING_PHASE / 5)
    fine, _ = _run(robot, result, drives, "mujoco")
    assert _tcp_gap(robot, base, fine) < gap / 10


def test_udp_lockstep_with_the_mujoco_plant(planned):
    """execute's serve against the virtual robot on MuJoCo over real datagrams in lockstep: the motion completes,
    no packet lost, and the arm's path is the in-process built-in run's within 0.01 mm."""
    robot, result, drives = planned
    streamer = make_streamer(robot, result, "shaping", drives)
    arm = VirtualArm(robot, drives, streamer.table.plan[0], plant="mujoco")
    sock = open_listener(0, "127.0.0.1")
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault("run", run_virtual_robot(
        arm, ("127.0.0.1", sock.getsockname()[1]), lockstep=True, max_time=result.duration + 2.0)))
    thread.start()
    try:
        ended = serve(sock, streamer, first_timeout=10.0, silence=2.0)
    finally:
        thread.join(30.0)
        sock.close()
    run = box["run"]
    assert ended == "done" and run.ended == "done" and streamer.counts.lost == 0
    base, _ = _run(robot, result, drives, "builtin")
    q = np.asarray(run.q)
    k = min(len(q), len(base.q))
    assert np.linalg.norm(fk(robot, q[:k])[0] - fk(robot, base.q[:k])[0], axis=1).max() < 1e-5


def test_an_unknown_plant_is_refused(planned):
    robot, result, drives = planned
    with pytest.raises(ExecutionError, match="plant 'bullet': choose one of builtin, mujoco"):
        VirtualArm(robot, drives, result.trajectory.at_time([0.0]).q[0], plant="bullet")
