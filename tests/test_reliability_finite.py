"""Finite or refused: every intermediate array that reaches a limit check or an output is
finite, or the run stops with a one-line error naming the quantity and what to change."""

import numpy as np
import pytest
from typer.testing import CliRunner

from pathmotion import load_robot
from pathmotion.cli import PROGRESS_LINE, app
from pathmotion.control.gains import OrbitalGains, TrackingGains
from pathmotion.errors import InfeasibleError, PathError, RobotModelError, SimulationError, UnreachableError
from pathmotion.planning.reduced import reduced_dynamics
from pathmotion.robot import Payload, Tool
from pathmotion.robot.ik import ik_dls
from pathmotion.simulation.realism import Realism

from reliability_cases import JOINT, LINE

runner = CliRunner()


def _one_line_exit_1(tmp_path, text, *extra):
    scenario = tmp_path / "s.toml"
    scenario.write_text(text)
    res = runner.invoke(app, ["plan", str(scenario), "--out", str(tmp_path / "out"), "--no-figures", *extra])
    lines = [ln for ln in res.output.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert res.exit_code == 1 and len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert not (tmp_path / "out").exists()
    return lines[0]


def test_a_payload_far_away_is_refused_not_planned_with_nan_torques(tmp_path):
    # was: exit 0 with max_torque_ratio null (the torque limit silently unenforced)
    msg = _one_line_exit_1(tmp_path, JOINT + "[robot.payload]\nmass = 1.0\ncom = [1e308, 0, 0]\n")
    assert "mass x |com|^2" in msg and "robot.payload" in msg
    # finite products, far beyond reach: refused by the scenario's unit check
    msg = _one_line_exit_1(tmp_path, JOINT + "[robot.payload]\nmass = 1.0\ncom = [1e150, 0, 0]\n")
    assert "robot.payload.com" in msg


def test_a_tool_a_million_km_away_is_unreachable_not_a_linalg_error(tmp_path):
    msg = _one_line_exit_1(tmp_path, LINE + "[robot.tool]\ntranslation = [1e9, 0, 0]\n")
    assert "did not converge" in msg and "position error 1e+09 m" in msg
    robot = load_robot("irb140", tool=Tool(translation=(1e9, 0.0, 0.0)))
    with pytest.raises(UnreachableError):
        ik_dls(robot, (0.5, 0.0, 0.5), np.diag([1.0, -1.0, -1.0]), np.zeros(6))


def test_an_inertia_asymmetric_by_rounding_is_symmetrised_beyond_it_refused():
    rounding = Payload(1.0, (0.0, 0.0, 0.1), ((1.0, 1e-9, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
    i = np.asarray(rounding.inertia)
    assert np.array_equal(i, i.T) and i[0, 1] == pytest.approx(5e-10)
    robot = load_robot("irb140", payload=rounding)
    assert robot.model.nq == 6  # Pinocchio (which refuses any asymmetry) accepts it
    with pytest.raises(RobotModelError, match=r"asymmetric by 0\.001 kg m\^2.*I\[i\]\[j\] = I\[j\]\[i\]"):
        Payload(1.0, (0.0, 0.0, 0.1), ((1.0, 1e-3, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))


def test_reduced_dynamics_refuses_non_finite_inputs_and_coefficients():
    robot = load_robot("irb140")
    q = np.zeros((3, 6))
    q[:, 4] = 0.5
    dq = np.ones((3, 6))
    ddq = np.zeros((3, 6))
    red = reduced_dynamics(robot, q, dq, ddq)  # finite: no error, and gamma is gravity
    assert np.all(np.isfinite(red.alpha)) and np.any(red.gamma != 0)
    bad = dq.copy()
    bad[1, 3] = np.nan
    with pytest.raises(PathError, match=r"Phi'\(theta\) is not finite at point 1 \(joint_4\)"):
        reduced_dynamics(robot, q, bad, ddq)
    huge = ddq.copy()
    huge[2, 0] = 1e308  # finite input, overflowing M Phi'' + C Phi'
    with pytest.raises(InfeasibleError, match=r"beta .* is not finite at point 2 .*robot\.payload"):
        reduced_dynamics(robot, q, dq, huge)


@pytest.mark.parametrize("make", [lambda: OrbitalGains(bandwidth=1e300), lambda: OrbitalGains(integral_rate=1e200),
                                  lambda: TrackingGains(bandwidth=1e200)])
def test_gains_whose_products_overflow_are_refused(make):
    with pytest.raises(SimulationError, match="overflow.*bandwidth of at most"):
        make()


def test_the_simulated_unmodelled_payload_gets_the_same_checks():
    with pytest.raises(SimulationError, match=r"simulate\.realism\.payload.*\|com\|\^2 overflows"):
        Realism(payload_mass=1.0, payload_com=(1e308, 0.0, 0.0))
    assert Realism(payload_mass=1.0, payload_com=(0.1, 0.0, 0.0)).payload_com == (0.1, 0.0, 0.0)
