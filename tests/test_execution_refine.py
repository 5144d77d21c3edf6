"""The refinement of shaped references on the nominal virtual IRC5 (execution/refine.py): it beats the analytic
shaping through the arm, by the execution figures (not its own cost); its error falls every iteration; what it
sends stays inside the limits; a stop after it continues the sent references (in the refined table's form)
and fades its correction out; the forward low-pass it uses is EGM's own filter."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("abb_robot_client")

from egm_support import irb140_task, line, planned as planned_scenario  # noqa: E402
from pathmotion import defaults  # noqa: E402
from pathmotion.execution.drives import EgmFilter, VirtualArm  # noqa: E402
from pathmotion.execution.reference import _invert_lowpass, lowpass, lowpass_alpha  # noqa: E402
from pathmotion.execution.refine import refine_reference  # noqa: E402
from pathmotion.execution.session import arm_figures, make_streamer, run_inprocess  # noqa: E402

SHORT = irb140_task("egm_refine", line([0.45, -0.03, 0.5], [0.45, 0.03, 0.5]))


@pytest.fixture(scope="module")
def planned():
    return planned_scenario(SHORT)


def _through_the_arm(planned, refine, stop_at=None):
    robot, result, drives = planned
    st = make_streamer(robot, result, "shaping", drives, refine=refine)
    run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0, stop_at=stop_at)
    return st, arm_figures(robot, run)


def test_refined_reference_beats_the_analytic_shaping_through_the_arm(planned):
    """On a second-order plan through the elastic gears, the refined table's path accuracy (execution_figures of
    the link-side TCP in a lockstep run) is below the analytic shaping's, and within 0.35 mm (analytic: 0.51)."""
    _, analytic = _through_the_arm(planned, 0)
    st, refined = _through_the_arm(planned, defaults.EGM_REFINE_ITERATIONS)
    assert refined["path_accuracy_m"] < analytic["path_accuracy_m"]
    assert refined["path_accuracy_m"] <= 0.35e-3, refined
    assert st.counts.clipped == 0


def test_refinement_error_falls_and_the_arm_confirms_it(planned):
    """The refinement's own error falls at every accepted iteration; run independently through the streamer and
    the arm, each refinement depth is no worse than one fewer (execution_figures' path accuracy, 5 % slack)."""
    robot, result, drives = planned
    table = make_streamer(robot, result, "shaping", drives, refine=0).table
    _, costs = refine_reference(robot, drives, table, iterations=3)
    assert len(costs) >= 3 and np.all(np.diff(costs) < 0), costs
    accuracy = [_through_the_arm(planned, k)[1]["path_accuracy_m"] for k in (0, 1, 3)]
    assert accuracy[1] < accuracy[0] and accuracy[2] <= 1.05 * accuracy[1], accuracy


def test_refined_references_stay_inside_the_limits(planned):
    """Every refined reference, position and speed, lies inside the joint limits, before and after a stop."""
    robot, result, _ = planned
    st, _ = _through_the_arm(planned, defaults.EGM_REFINE_ITERATIONS, stop_at=0.5 * result.duration)
    lim = robot.limits
    sent = np.array([r.sent for r in st.records])
    assert np.all(sent >= lim.lower) and np.all(sent <= lim.upper)
    for table in (st.table, st.segment):
        assert np.all(np.abs(table.qd) <= lim.velocity) and np.all((table.q >= lim.lower) & (table.q <= lim.upper))


def test_a_stop_after_refinement_continues_the_references_and_fades_the_correction(planned):
    """A stop requested mid-motion: the sent references step across the switch no more than the motion's own
    steps before it, and the stop segment's correction (the refinement's, carried over) is gone after the fade."""
    robot, result, drives = planned
    stop_at = 0.4 * result.duration
    st, _ = _through_the_arm(planned, defaults.EGM_REFINE_ITERATIONS, stop_at=stop_at)
    assert st.table.correction is not None and np.abs(st.table.correction).max() > 1e-5
    sent = np.array([r.sent for r in st.records])
    steps = np.abs(np.diff(sent, axis=0)).max(axis=1)
    k = int(round(st.requests[0].at / drives.cycle))  # the switch, a lead after the request
    assert steps[k - 1:k + 2].max() <= 1.5 * steps[:k - 1].max()
    stop = st.segment
    assert stop.correction is not None
    assert np.abs(stop.correction[stop.t >= defaults.EGM_REFINE_FADE]).max() == 0.0
    assert np.abs(stop.correction[0]).max() > 0.0


@pytest.mark.parametrize("fraction", [0.5, 0.7])
def test_a_stop_after_a_plain_refinement_vibrates_no_more_than_none(planned, fraction):
    """Where the refinement starts from the plain form (the short line: the analytic low-pass inverse asks the
    motors for more than their torque), a stop requested mid-motion continues in that form: the arm's residual
    vibration after the stop (execution_figures, elastic gears) is no larger than with no correction."""
    robot, result, drives = planned
    vibration = {}
    for mode in ("none", "shaping"):
        st = make_streamer(robot, result, mode, drives)
        run = run_inprocess(st, VirtualArm(robot, drives, st.table.plan[0]), result.duration + 1.0,
                            stop_at=fraction * result.duration)
        vibration[mode] = arm_figures(robot, run)["residual_vibration_m"]
    assert vibration["shaping"] <= vibration["none"], vibration
    assert st.table.plain and st.segment is not st.table and st.segment.plain


def test_lowpass_is_egms_filter_and_its_inverse_undoes_it():
    """lowpass on the EGM cycle grid equals EgmFilter's filtered position (no transport delay), and
    _invert_lowpass undoes it exactly, also with several table rows per cycle."""
    from dataclasses import replace

    from pathmotion.execution.drive_file import drive_file_for, load_drives

    drives = load_drives(drive_file_for("irb140"), 6)
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=(40, 6)) * 1e-3, axis=0)
    alpha = lowpass_alpha(drives)
    filt = EgmFilter(replace(drives, transport_delay=0.0), x[0])
    peer = []
    for row in x:
        filt.step(row, np.zeros(6))
        peer.append(filt.p_f.copy())
    assert np.allclose(lowpass(x, alpha, 1), np.array(peer), atol=1e-15)
    fine = np.repeat(x, 4, axis=0)
    assert np.allclose(_invert_lowpass(lowpass(fine, alpha, 4), alpha, 4), fine, atol=1e-13)
