"""execute PLAN_DIR: a plan read back from the folder pathmotion plan wrote reproduces the plan (profile, joints,
the references execute streams, a stop along the path); folders that are not a plan are refused naming what is
missing, and a folder whose files disagree with its trajectory export is refused."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from egm_support import irb140_task, line, run_commands  # noqa: E402
from pathmotion import api  # noqa: E402
from pathmotion.api.plan_folder import is_plan_folder, read_plan  # noqa: E402
from pathmotion.errors import ScenarioError  # noqa: E402
from pathmotion.execution.drive_file import drive_file_for, load_drives  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess  # noqa: E402
from pathmotion.io.files import RESULT_MARK  # noqa: E402

LINE = irb140_task("egm_folder", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5])
                   + '[[path.segments]]\ntype = "dwell"\ntime = 0.05\n' + line(None, [0.45, 0.03, 0.45]))
JERK = LINE + "[limits]\nuse_jerk = true\n"


def _written(tmp_path, text, name="plan"):
    setup = api.load_text(text)
    result = api.plan_scenario(setup)
    api.write_plan(setup, result, tmp_path / name)
    (tmp_path / name / RESULT_MARK).write_text("mark\n")
    return setup, result, tmp_path / name


@pytest.mark.parametrize("text", [LINE, JERK], ids=["second-order with a dwell", "jerk-limited"])
def test_a_plan_folder_is_the_plan(tmp_path, text):
    """The profile (grid, theta_dot, theta_ddot nodes, dwells) and the joints at any time are the planner's own;
    the references execute streams from the folder are those it streams from the plan."""
    setup, result, folder = _written(tmp_path, text)
    assert is_plan_folder(folder)
    _, read = read_plan(folder)
    a, b = result.profile, read.profile
    assert np.array_equal(a.grid, b.grid) and np.allclose(a.x, b.x, rtol=1e-15, atol=0)
    assert (a.u_nodes is None) == (b.u_nodes is None) and (a.holds is None) == (b.holds is None)
    t = np.linspace(0.0, result.duration, 97)
    assert np.abs(result.trajectory.at_time(t).q - read.trajectory.at_time(t).q).max() < 1e-12
    drives = load_drives(drive_file_for("irb140"), setup.robot.n)
    planned, from_folder = (make_streamer(setup.robot, r, "shaping", drives).table for r in (result, read))
    assert np.abs(planned.q - from_folder.q).max() < 1e-12


def test_a_plan_folder_executes_and_stops_along_the_path(tmp_path):
    """Through the virtual IRC5 (lockstep, elastic gears): the folder's plan runs to the end within 0.25 mm, and
    a stop requested before half way comes to rest on the path (the Retimer built from the folder's plan). The accuracy is
    that of the jerk-limited plan: elastic gears ring after a second-order plan's acceleration steps."""
    _, _, smooth_folder = _written(tmp_path, JERK, "jerk")
    robot, read = read_plan(smooth_folder)[0].robot, read_plan(smooth_folder)[1]
    drives = load_drives(drive_file_for("irb140"), robot.n)
    st = make_streamer(robot, read, "shaping", drives)
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), read.duration + 1.0)
    assert st.finished and arm_figures(robot, run)["path_accuracy_m"] < 0.25e-3
    read = read_plan(_written(tmp_path, LINE)[2])[1]
    st = make_streamer(robot, read, "shaping", drives)
    # switched before half way: a line's time-optimal plan brakes from half way as a stop does, and ends at the end
    run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), read.duration + 1.0,
                  stop_at=0.4 * read.duration - st.lead)
    theta = np.array([r.theta for r in st.records])
    assert st.stop_reason and theta[-1] < read.profile.grid[-1] and np.all(np.diff(theta) >= -1e-12)


def test_folders_that_are_not_a_plan_are_refused(tmp_path):
    """An empty folder, a folder without the mark, a plan without its phase plane: each refused naming what is
    missing; an edited trajectory export: refused with the joint and the difference."""
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ScenarioError, match=r"not a pathmotion result folder: \.pathmotion-result, trajectory\.csv"):
        read_plan(empty)
    _, _, folder = _written(tmp_path, LINE)
    (folder / "phase_plane.csv").unlink()
    with pytest.raises(ScenarioError, match="not a complete plan: phase_plane.csv missing"):
        read_plan(folder)
    _, _, folder = _written(tmp_path, LINE, "edited")
    lines = (folder / "trajectory.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = lines[len(lines) // 2].split(",")
    row[header.index("q2")] = repr(float(row[header.index("q2")]) + 1e-3)
    lines[len(lines) // 2] = ",".join(row)
    (folder / "trajectory.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ScenarioError, match="do not reproduce trajectory.csv .joint 2 differs by 0.001 rad"):
        read_plan(folder)


def test_cli_execute_refuses_a_folder_that_is_not_a_plan(tmp_path):
    """Exit 1 and one line saying what is missing; nothing written, no port opened. A plan folder with --set, or
    as its own output folder, is refused too."""
    from typer.testing import CliRunner

    from pathmotion.cli import app

    folder = tmp_path / "notaplan"
    folder.mkdir()
    (folder / "notes.txt").write_text("x")
    res = CliRunner().invoke(app, ["execute", str(folder), "--egm", "0", "--out", str(tmp_path / "run")])
    assert res.exit_code == 1, res.output
    assert "not a pathmotion result folder" in res.output and ".pathmotion-result" in res.output
    assert not (tmp_path / "run").exists()
    _, _, plan = _written(tmp_path, LINE)
    res = CliRunner().invoke(app, ["execute", str(plan), "--egm", "0", "--set", "plan.grid_points=50"])
    assert res.exit_code == 1 and "is a plan folder" in res.output, res.output
    res = CliRunner().invoke(app, ["execute", str(plan), "--egm", "0", "--out", str(plan)])
    assert res.exit_code == 1 and "holds the input" in res.output, res.output


@pytest.mark.slow
def test_cli_execute_a_plan_folder_against_the_virtual_robot_on_mujoco(tmp_path):
    """The commands as processes on a plan folder: execute PLAN_DIR and virtual-robot PLAN_DIR --lockstep
    --plant mujoco exit 0; the arm (MuJoCo links, elastic gears) follows the folder's plan within 0.25 mm."""
    import json

    pytest.importorskip("mujoco")
    _, _, folder = _written(tmp_path, JERK)  # jerk-limited, as elastic gears need
    ex, robot, out = run_commands(folder, ["--plant", "mujoco"])
    assert ex.returncode == 0, ex.stdout + ex.stderr
    assert robot.returncode == 0, out
    summary = json.loads((tmp_path / "plan_execute" / "summary.json").read_text())
    assert summary["ended"] == "done" and summary["packets_lost"] == 0
    arm = json.loads((tmp_path / "plan_robot" / "summary.json").read_text())
    assert arm["plant"] == "mujoco" and arm["ended"] == "done" and arm["path_accuracy_m"] < 0.25e-3
    assert (folder / "trajectory.csv").is_file()  # the plan folder is kept
