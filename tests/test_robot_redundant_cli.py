"""A 7-joint arm (the Panda of example-robot-data) through the command line: ``plan`` writes every file the arm can
take and names the export it cannot (a RAPID jointtarget holds 6 axes); ``check`` reports the same note; without
``start_configuration`` the start is found from several IK starts."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from pathmotion.cli import app
from pathmotion.io import exports
from robot_support import DATA, PANDA_URDF, ROBOTS

pytestmark = pytest.mark.skipif(ROBOTS is None, reason="example-robot-data (dev extra) is not installed")
runner = CliRunner()

PANDA = (f'name = "panda_circle"\n[robot]\nname = "{PANDA_URDF}"\nlimits = "{DATA / "panda_limits.toml"}"\n'
         "locked_joints = {panda_finger_joint1 = 0.02, panda_finger_joint2 = 0.02}\n"
         '[path]\ntype = "task"\nsegments = [{type = "circle", center = [0.4, 0.0, 0.4], radius = 0.1}]\n'
         "start_configuration = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\n[plan]\ngrid_points = 150\n")


def test_plan_skips_the_export_a_7_joint_arm_cannot_take_and_check_says_so(tmp_path):
    scenario = tmp_path / "panda.toml"
    scenario.write_text(PANDA)
    res = runner.invoke(app, ["check", str(scenario)])
    assert res.exit_code == 0, res.output
    assert "trajectory_rapid.mod not written" in res.output and "this arm has 7" in res.output
    out = tmp_path / "out"
    res = runner.invoke(app, ["plan", str(scenario), "--out", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "note: exports: trajectory_rapid.mod not written" in res.output
    written = {p.name for p in out.iterdir()}
    assert {"summary.json", "trajectory.csv", "trajectory_ros2.yaml", "trajectory_egm.csv"} <= written
    assert "trajectory_rapid.mod" not in written
    notes = json.loads((out / "summary.json").read_text())["export_notes"]
    assert any("RAPID jointtarget holds at most 6" in n for n in notes)
    egm_header = [ln for ln in (out / "trajectory_egm.csv").read_text().splitlines() if not ln.startswith("#")][0]
    assert egm_header.split(",")[:8] == ["t", *(f"j{k}" for k in range(1, 8))]


def test_unsupported_exports_is_the_rapid_writers_own_limit():
    import numpy as np

    from pathmotion.errors import PathmotionError
    from pathmotion.planning.trajectory import Samples

    for n in (6, 7):
        t = np.linspace(0, 0.2, 5)
        samples = Samples(t=t, theta=t, theta_dot=np.ones(5), theta_ddot=np.zeros(5), q=np.zeros((5, n)),
                          qd=np.zeros((5, n)), qdd=np.zeros((5, n)), tau=None)
        if exports.unsupported_exports(n):
            with pytest.raises(PathmotionError, match="at most 6"):
                exports.rapid_module(samples)
        else:
            assert "MODULE" in exports.rapid_module(samples)


def test_a_redundant_arm_without_a_start_configuration_is_lifted_from_several_starts(tmp_path):
    """The Panda circle at (0.5, 0, 0.4), r = 0.1, tool down: DLS from the zero configuration stalls at a joint
    limit; the lift tries the middle of the ranges and seeded random starts and plans from the first that works."""
    import numpy as np

    import pathmotion as pm
    from pathmotion.errors import UnreachableError
    from pathmotion.geometry import horizontal_circle
    from pathmotion.lift.constraint import start_candidates
    from pathmotion.robot import fk

    scenario = tmp_path / "panda.toml"
    scenario.write_text(PANDA.replace("[0.4, 0.0, 0.4]", "[0.5, 0.0, 0.4]").replace(
        "start_configuration = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\n", ""))
    setup = pm.load(scenario)
    robot = setup.robot
    path = horizontal_circle((0.5, 0.0, 0.4), 0.1)
    with pytest.raises(UnreachableError, match="did not converge"):
        pm.lift(robot, path, start_candidates(robot)[0])  # the zero configuration alone: refused
    assert np.array_equal(start_candidates(robot), start_candidates(robot))  # deterministic
    q = setup.path.evaluate(np.linspace(*setup.path.domain, 50))[0]
    assert np.max(np.linalg.norm(fk(robot, q)[0] - path.evaluate(np.linspace(*path.domain, 50))[0], axis=1)) < 1e-6
    assert np.all(q >= robot.limits.lower - 1e-9) and np.all(q <= robot.limits.upper + 1e-9)
    res = runner.invoke(app, ["plan", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"])
    assert res.exit_code == 0, res.output
