"""--correction shaping of a second-order plan keeps the plan's limits: the joints of the streamed table's shaped
motion, differentiated by finite differences over its time step, stay within the plan's velocity and
acceleration limits and (through rnea) its torque limits, on corner_g2 and on a random corner, where the plan
streamed as it is breaks them; the shaped motion stays on the path and never runs back; a jerk-limited plan is
streamed as it is (docs/execution.md)."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from egm_support import irb140_task, line, planned  # noqa: E402
from pathmotion import api, defaults  # noqa: E402
from pathmotion.execution.drive_file import drive_file_for, load_drives  # noqa: E402
from pathmotion.execution.drives import VirtualArm  # noqa: E402
from pathmotion.execution.messages import decode_sensor, encode_robot  # noqa: E402
from pathmotion.execution.reference import gear_period, lowpass, lowpass_alpha  # noqa: E402
from pathmotion.execution.session import make_streamer  # noqa: E402
from pathmotion.execution.shaped_limits import shaped_plan, shaped_ratios  # noqa: E402
from pathmotion.planning import effective_limits  # noqa: E402
from pathmotion.robot import rnea  # noqa: E402

#: What central differences over the table's 1 ms step may add to the true peaks (curvature of the motion) [-].
DIFFERENCE_ALLOWANCE = 5e-3


def _corner_g2():
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("corner_g2.toml").read_text())
    return setup.robot, api.plan_scenario(setup), load_drives(drive_file_for("irb140"), setup.robot.n)


def _random_corner():
    rng = np.random.default_rng(11)
    angle = rng.uniform(np.radians(45.0), np.radians(135.0))
    corner = np.array([0.50, 0.00, 0.45])
    end = corner + 0.1 * np.array([np.cos(angle), np.sin(angle), 0.0])
    segments = line([0.40, 0.00, 0.45], corner.round(4).tolist()) + line(None, end.round(4).tolist())
    blend = '[[path.blends]]\ncorner = 1\ntype = "g2"\ntolerance = 0.004\n'
    text = irb140_task("shaped_corner", segments + blend)
    return planned(text)


def _fd_ratios(robot, result, table, q=None) -> dict[str, float]:
    """The table's planned joints (its shaped motion; or the joints q (K, n) at its rows) differentiated by
    central differences, against the plan's effective velocity, acceleration and torque limits (torque by
    rnea)."""
    return _joint_ratios(robot, result, table.plan if q is None else q, table.t[1] - table.t[0])


def _joint_ratios(robot, result, q, h) -> dict[str, float]:
    """The joints q (K, n) every h [s] differentiated by central differences, against the plan's effective
    velocity, acceleration and torque limits (torque by rnea)."""
    limits = {lim.name: lim for lim in effective_limits(robot, result.settings).active}
    qd = (q[2:] - q[:-2]) / (2.0 * h)
    qdd = (q[2:] - 2.0 * q[1:-1] + q[:-2]) / h**2
    tau = rnea(robot, q[1:-1], qd, qdd)
    peaks = {"velocity": (np.abs(qd), "qd_max"), "acceleration": (np.abs(qdd), "qdd_max"),
             "torque": (np.abs(tau), "tau_max")}
    return {name: float(np.max(peak / getattr(limits[name], bound))) for name, (peak, bound) in peaks.items()
            if name in limits}


@pytest.mark.parametrize("case", [_corner_g2, _random_corner], ids=["corner_g2", "random_corner"])
def test_shaped_table_keeps_the_plans_limits_on_the_path(case):
    robot, result, drives = case()
    period = gear_period(robot, drives, result.trajectory.at_time([0.0]).q[0])
    before = max(shaped_ratios(robot, result, period).values())
    assert before > 1.0 + 10 * defaults.LIMIT_TOLERANCE  # the plan streamed as planned breaks its limits
    streamer = make_streamer(robot, result, "shaping", drives, refine=0)
    table = streamer.table
    ratios = _fd_ratios(robot, result, table)
    assert max(ratios.values()) <= 1.0 + defaults.LIMIT_TOLERANCE + DIFFERENCE_ALLOWANCE, ratios
    # on the path: the table's joints are the path's at theta, which never runs back and ends at the path's end
    assert np.allclose(table.plan, result.trajectory.path.evaluate(table.theta)[0], atol=1e-12)
    assert np.all(np.diff(table.theta) >= -1e-12)
    assert table.theta[-1] == pytest.approx(result.trajectory.path.domain[1], abs=1e-9)
    assert streamer.plan.duration >= result.duration  # what keeping the limits costs


def test_the_difference_check_sees_the_plan_streamed_as_planned():
    """The finite-difference check finds the excess a shaper makes without the re-planning (it can fail): the
    average over a whole period (four times execute's) takes corner_g2's acceleration to 1.30 times its limit."""
    robot, result, drives = _corner_g2()
    period = 4.0 * gear_period(robot, drives, result.trajectory.at_time([0.0]).q[0])
    from pathmotion.execution.reference import RawMotion, build_reference

    table = build_reference(robot, result.trajectory.path, RawMotion(result.profile), "shaping", drives,
                            period=period)
    assert _fd_ratios(robot, result, table)["acceleration"] > 1.2


def test_a_jerk_limited_plan_is_streamed_as_planned():
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("circle_smooth.toml").read_text())
    result = api.plan_scenario(setup)
    assert result.profile.smooth
    same, _ = shaped_plan(setup.robot, result, 0.05)
    assert same is result


def _run_with_retimings(streamer, arm, duration: float, end: float):
    """Lockstep EGM through encoded messages for at most 3 ``duration`` + 1 s (``duration``: the plan's): an
    override to 0.9 at 10 % of the duration, a stop at 55 %, a resume once the stop is at rest before the path's
    end ``end``; {kind: table} of the tables streamed ("plan", then each re-timed one)."""
    tables = {"plan": streamer.table}
    retime = streamer.retime
    streamer.retime = lambda kind, *a: tables.setdefault(kind, retime(kind, *a))
    dt, ref, k, done = arm.params.cycle, arm.feedback, 0, False
    while k * dt <= 3.0 * duration + 1.0 and not done:
        now = k * dt
        if k == round(0.1 * duration / dt):
            streamer.override(0.9)
        if k == round(0.55 * duration / dt):
            streamer.stop("stop requested")
        if streamer.stop_reason is not None and now > streamer.rest_time + 0.05 and streamer.segment.theta[-1] < end:
            streamer.resume()
        answer = decode_sensor(streamer.handle(encode_robot(k + 1, int(round(now * 1000)), arm.feedback, ref), 0.0,
                                               lambda: 0.0), arm.n)
        ref, done = answer.joints, answer.done
        arm.cycle(answer.joints, answer.speed)
        k += 1
    return tables


def _sent_joints(streamer, drives) -> np.ndarray:
    """The joints (K, n) the sent references show the servo: EGM's low-pass of them at its cycle (rigid gears and no
    refinement: the shaping adds no deflection and no correction to the motion's joints)."""
    sent = np.array([r.sent for r in streamer.records])
    return lowpass(sent, lowpass_alpha(drives), 1)


def _circle_smooth():
    setup = api.load_text(resources.files("pathmotion.scenarios").joinpath("circle_smooth.toml").read_text())
    return setup.robot, api.plan_scenario(setup), load_drives(drive_file_for("irb140"), setup.robot.n)


@pytest.mark.parametrize("case", [_corner_g2, _circle_smooth], ids=["corner_g2", "circle_smooth"])
def test_sent_motion_keeps_the_plans_limits_from_rest_and_when_re_timed(case):
    """What execute sends keeps the plan's velocity, acceleration and torque limits on the first segment (from
    rest, where a time-optimal plan runs at its limits) and on the re-timed ones (override, stop, resume): on
    rigid gears the joints the sent messages show the servo (EGM's low-pass of them), differentiated over the
    EGM cycle; on elastic gears the motion each streamed table's references follow (ReferenceTable.sent),
    differentiated over the table step."""
    robot, result, elastic = case()
    allowed = 1.0 + defaults.LIMIT_TOLERANCE + DIFFERENCE_ALLOWANCE
    for drives in (elastic.rigid(), elastic):
        streamer = make_streamer(robot, result, "shaping", drives, refine=0)
        arm = VirtualArm(robot, drives, streamer.table.plan[0])
        end = result.trajectory.path.domain[1] - 1e-9
        tables = _run_with_retimings(streamer, arm, result.duration, end)
        assert streamer.finished and {"override", "stop"} <= set(tables)
        # a jerk-limited stop may run on to the next point where the plan rests (circle_smooth: the path's end)
        assert ("resume" in tables) == (tables["stop"].theta[-1] < end)
        for table in tables.values():
            q = result.trajectory.path.evaluate(table.sent[:, 0])[0]
            ratios = _fd_ratios(robot, result, table, q)
            assert max(ratios.values()) <= allowed, ratios
        if not drives.elastic.any():
            ratios = _joint_ratios(robot, result, _sent_joints(streamer, drives), drives.cycle)
            assert max(ratios.values()) <= allowed, ratios




def test_the_references_show_the_shaped_motion_at_its_own_time():
    """The references are not led by the transport delay (a lead caught up from rest would run them faster than
    the plan, which leaves rest at its limits): EGM's low-pass of the sent references is the shaped motion's
    joints plus the gear deflection at the same rows, so the limits checked on table.plan are the sent motion's."""
    robot, result, drives = _corner_g2()
    table = make_streamer(robot, result, "shaping", drives, refine=0).table
    per = int(round(drives.cycle / (table.t[1] - table.t[0])))
    filtered = lowpass(table.q, lowpass_alpha(drives), per)
    motor = table.plan + table.deflection
    assert np.allclose(filtered[per:], motor[per:], atol=1e-9)
    assert table.delay == drives.transport_delay
