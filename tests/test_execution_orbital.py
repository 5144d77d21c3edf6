"""--correction orbital: its gain follows the drives' lag, which the drive model's own step response confirms; on
an arm carrying a payload unknown to the plan, shaping (refined on the nominal arm, which does not carry it)
still follows the path closer than the plan streamed as it is, and the loop, tuned for the drives' lag, does not
improve on it (docs/execution.md)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from egm_support import irb140_task, line  # noqa: E402
from pathmotion import api  # noqa: E402
from pathmotion.execution.drive_file import drive_file_for, load_drives  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.orbital import loop_gain, loop_lag  # noqa: E402
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess  # noqa: E402
from pathmotion.robot import Payload, load_robot  # noqa: E402

ARC = irb140_task("egm_orbital", line([0.40, -0.10, 0.45], [0.50, 0.00, 0.45]) + line(None, [0.40, 0.10, 0.45])
                  + '[[path.blends]]\ncorner = 1\ntype = "g2"\ntolerance = 0.005\n')


def test_loop_lag_is_the_drive_models_mean_step_delay():
    """The mean delay of the rigid drive model's response to a small reference step, sum over cycles of
    (1 - y) times the cycle, is within 20 % of loop_lag (mean delays of cascaded lags add)."""
    robot = load_robot("irb140")
    drives = load_drives(drive_file_for("irb140"), 6).rigid()
    q0 = np.radians([0, 20, -10, 0, 40, 0])
    arm = VirtualArm(robot, drives, q0)
    step, y = 1e-4, []
    for _ in range(200):
        arm.cycle(q0 + step, np.zeros(6))
        y.append((arm.feedback - q0) / step)
    mean_delay = np.sum(1.0 - np.array(y), axis=0) * drives.cycle
    assert np.all(np.abs(mean_delay - loop_lag(drives)) < 0.2 * loop_lag(drives)), mean_delay
    assert loop_gain(drives) == pytest.approx(0.25 * drives.cycle / loop_lag(drives))


@pytest.fixture(scope="module")
def planned():
    setup = api.load_text(ARC)
    carried = setup.robot.with_payload(Payload(mass=3.0, com=(0.0, 0.0, 0.1)))
    return setup.robot, carried, api.plan_scenario(setup), load_drives(drive_file_for("irb140"), setup.robot.n)


def _accuracy(planned, mode, rigid):
    robot, carried, result, drives = planned
    drives = drives.rigid() if rigid else drives
    st = make_streamer(robot, result, mode, drives)
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0], plant_robot=carried), result.duration + 0.5)
    return arm_figures(robot, run)["path_accuracy_m"]


@pytest.mark.parametrize("rigid", [True, False], ids=["rigid", "elastic"])
def test_shaping_with_an_unknown_payload_beats_the_plan_as_it_is(planned, rigid):
    shaping, none = _accuracy(planned, "shaping", rigid), _accuracy(planned, "none", rigid)
    assert shaping < none, (shaping, none)
