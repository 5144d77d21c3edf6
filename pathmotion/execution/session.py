"""Whole EGM runs: execute's (listen, stream, write execution.csv and summary.json), the virtual IRC5's (send,
move, write robot.csv and summary.json), and both in one process through the same messages (lockstep, no
socket) for studies and tests."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import defaults
from ..errors import ExecutionError, PathmotionError, StateInfeasibleError
from ..planning import effective_limits
from ..planning.planner import TIGHTEN_TARGET
from ..planning.profile import Profile
from ..planning.retime import Retimer
from ..io import exports
from ..io.atomic import write_json
from ..robot import Robot
from .drive_file import DriveParameters
from .drives import VirtualArm
from .figures import execution_figures
from .messages import decode_sensor, encode_robot
from .orbital import TransverseLoop, loop_gain
from .reference import MODES, RawMotion, build_reference, gear_period
from .refine import refine_reference
from .shaped_limits import motion_ratios, shaped_plan
from .streamer import Streamer
from .supervision import PathSupervision

log = logging.getLogger(__name__)


def _stop(retimer: Retimer, state: tuple) -> Profile:
    """The Retimer's shortest stop along the path; when its jerk-limited stop finds none, its stop within the
    second-order limits (acceleration, torque: the arm still stops on the path, with steps in acceleration)."""
    try:
        return retimer.stop(*state)
    except StateInfeasibleError as exc:
        if not retimer.third_order:
            raise
        log.warning("no jerk-limited stop from theta = %.6g (%s); stopping within the second-order limits", state[0], exc)
        return retimer.stop(*state, second_order=True)


def _retimed(retimer: Retimer, kind: str, state: tuple, override: float, s2: float) -> Profile:
    """The re-timed profile of a stop, an override or a resume from ``state`` with the acceleration and the
    torque's dynamic part scaled by ``s2`` in (0, 1] (velocity by its root; the Retimer's override scaling: the
    stop is ``s2`` times the unit-limit stop from theta_dot^2 / s2)."""
    if kind == "stop":
        if s2 >= 1.0:
            return _stop(retimer, state)
        unit = retimer.stop(state[0], state[1] / np.sqrt(s2), second_order=True)
        return Profile(unit.grid, s2 * unit.x)
    if kind == "resume":
        return retimer.remaining(state[0], 0.0, 0.0, override * np.sqrt(s2))
    return retimer.override_remaining(*state, override * np.sqrt(s2))


def _shaped_within(table, ratio, tolerance: float, kind: str):
    """``table(s2)``'s re-timed table whose shaped motion keeps the plan's limits (``ratio(table)``: its largest
    limit ratio): the shaper averages the motion before the switch into the re-timed one, which starts at the
    limits, so where the ratio exceeds 1 + ``tolerance`` the re-timed profile's acceleration is scaled by
    (1 - TIGHTEN_TARGET x tolerance) / ratio, at most ``defaults.EGM_RETIME_TIGHTEN`` times (a warning when it
    still exceeds them, or when no slower re-timing exists)."""
    s2, built = 1.0, table(1.0)
    for _ in range(defaults.EGM_RETIME_TIGHTEN):
        r = ratio(built)
        if r <= 1.0 + tolerance:
            return built
        s2 *= (1.0 - TIGHTEN_TARGET * tolerance) / r
        try:
            built = table(s2)
        except PathmotionError as exc:
            log.warning("the shaped %s exceeds the plan's limits %.4g times and none slower exists (%s)", kind, r, exc)
            return built
    r = ratio(built)
    if r > 1.0 + tolerance:
        log.warning("the shaped %s exceeds the plan's limits %.4g times", kind, r)
    return built


def make_streamer(robot: Robot, plan_result, mode: str, drives: DriveParameters,
                  tolerance: float = defaults.EGM_START_TOLERANCE,
                  path_tolerance: float | None = defaults.JOINT_TOLERANCE,
                  refine: int = defaults.EGM_REFINE_ITERATIONS, lead: float = defaults.EGM_SWITCH_LEAD,
                  realtime: bool = False) -> Streamer:
    """execute's Streamer for a plan (a planning.PlanResult) in correction ``mode``; with shaping (and orbital)
    a second-order plan planned again with its limits tightened locally until its shaped motion keeps the
    plan's limits (shaped_limits.py: the plan streamed and re-timed is that one), and the plan's table
    refined by at most ``refine`` iterations on the nominal arm (refine.py; 0: the analytic shaping alone); stops, overrides and resumes re-timed by the plan's Retimer (analytic, the refinement's
    correction faded out); ``path_tolerance`` [rad]: the path supervision's joint deviation (None: no
    supervision); ``lead`` [s], ``realtime``: when a request switches and whether the loop ever waits for its
    re-timing (:class:`.streamer.Streamer`)."""
    if mode not in MODES:
        raise ExecutionError(f"--correction {mode!r}: choose one of {', '.join(MODES)}")
    path = plan_result.trajectory.path
    start = plan_result.trajectory.at_time([0.0]).q[0]
    # the shaper makes a second-order plan's acceleration continuous (a jerk-limited plan's already is); one
    # shaper for every segment of the run, so that a re-timed segment continues the references sent. Without
    # elastic gears its period is the position loop's time constant 1 / Kp: the acceleration steps, fed
    # forward as torque steps at the plan's torque limits, would saturate the motors
    period = 0.0 if plan_result.profile.smooth else gear_period(robot, drives, start) or 1.0 / drives.position_gain
    limits = effective_limits(robot, plan_result.settings)  # the plan's, as the user planned it
    if mode != "none" and period > 0.0:  # the shaped motion within the plan's limits: the plan streamed is slower
        plan_result = shaped_plan(robot, plan_result, period)[0]
    try:
        retimer = Retimer(plan_result)
    except PathmotionError as exc:
        raise ExecutionError(f"execute needs a plan it can stop along the path: {exc}") from None

    def retime(kind: str, state: tuple, override: float, previous, offset: float):
        def table(s2: float):
            profile = _retimed(retimer, kind, state, override, s2)
            return build_reference(robot, path, RawMotion(profile, previous.raw, offset), mode, drives,
                                   period=period, carried=(previous, offset))

        if mode == "none" or period <= 0.0:
            return table(1.0)
        return _shaped_within(table, lambda t: max(motion_ratios(robot, path, t.motion, limits).values()),
                              plan_result.settings.limit_tolerance, kind)

    table = build_reference(robot, path, RawMotion(plan_result.profile), mode, drives, period=period)
    if mode != "none" and refine > 0:
        table = refine_reference(robot, drives, table, iterations=refine)[0]
    lim = robot.limits
    loop = TransverseLoop(path, loop_gain(drives)) if mode == "orbital" else None
    watch = None if path_tolerance is None else PathSupervision(robot, path, path_tolerance)
    return Streamer(table, retime, lim.lower, lim.upper, lim.velocity, mode=mode, tolerance=tolerance, loop=loop,
                    supervision=watch, plan=plan_result.trajectory, lead=lead, realtime=realtime)


def execution_summary(robot: Robot, streamer: Streamer, ended: str) -> dict:
    """summary.json of execute: ISO 9283 figures of the reported (motor-side) joints, packets, timing."""
    recs = streamer.records
    c = streamer.counts
    summary = {"ended": ended, "correction": streamer.mode, "messages_answered": c.answered,
               "packets_received": c.received, "packets_lost": c.lost, "packets_late": c.late,
               "packets_duplicated": c.duplicated, "packets_out_of_order": c.out_of_order,
               "packets_rejected": c.rejected, "references_clipped": c.clipped}
    if streamer.supervision is not None:
        summary.update(streamer.supervision.figures())
    if recs:
        t = np.array([r.tm for r in recs]) / 1000.0
        t -= t[0]
        q = np.array([r.reported for r in recs])
        compute = np.array([r.t_send - r.t_recv for r in recs])
        summary.update(execution_figures(robot, streamer.plan, t, q, np.array([r.theta for r in recs]),
                                         streamer.rest_time))
        summary["cycle_compute_p99_s"] = float(np.percentile(compute, 99))
        summary["cycle_compute_max_s"] = float(np.max(compute))
    summary["requests"] = [r.summary() for r in streamer.requests]
    if streamer.scheduling:
        summary["loop_scheduling"] = {k: streamer.scheduling[k] for k in ("requested_priority", "policy", "priority",
                                                                          "memory_locked", "refused")}
    return summary


def write_execution(out: Path, robot: Robot, streamer: Streamer, ended: str) -> dict:
    """execution.csv (per answered message: receive/send times, seqno, plan time, reported, sent and planned
    joints) and summary.json into ``out``; returns the summary."""
    recs = streamer.records
    cols = {"t_recv": np.array([r.t_recv for r in recs]), "t_send": np.array([r.t_send for r in recs]),
            "seqno": np.array([r.seqno for r in recs], float), "robot_tm_s": np.array([r.tm for r in recs]) / 1e3,
            "segment_time": np.array([r.tau for r in recs]), "theta": np.array([r.theta for r in recs])}
    for name, attr in (("reported", "reported"), ("sent", "sent"), ("planned", "plan")):
        arr = np.array([getattr(r, attr) for r in recs]).reshape(len(recs), -1)
        cols.update({f"{name}{j + 1}": arr[:, j] for j in range(arr.shape[1])})
    exports.write_table_csv(out / "execution.csv", cols)
    summary = execution_summary(robot, streamer, ended)
    write_json(out / "summary.json", summary)
    return summary


@dataclass
class InProcess:
    """A lockstep run without a socket: the streamer's messages carried to the arm and back."""

    streamer: Streamer
    arm: VirtualArm
    t: np.ndarray
    q: np.ndarray
    theta: np.ndarray


def run_inprocess(streamer: Streamer, arm: VirtualArm, max_time: float, stop_at: float | None = None) -> InProcess:
    """Lockstep EGM between ``streamer`` and ``arm`` through encoded messages, for at most ``max_time`` [s] of
    arm time; ``stop_at`` [s]: request a stop along the path then."""
    dt = arm.params.cycle
    ref, t, q, theta = arm.feedback, [], [], []
    k = 0
    while k * dt <= max_time:
        if stop_at is not None and k * dt >= stop_at:
            streamer.stop("stop requested")
        reply = streamer.handle(encode_robot(k + 1, int(round(k * dt * 1000)), arm.feedback, ref), 0.0,
                                lambda: 0.0)
        answer = decode_sensor(reply, arm.n)
        ref = answer.joints
        arm.cycle(answer.joints, answer.speed if answer.speed is not None else np.zeros(arm.n))
        t.append(k * dt)
        q.append(arm.state.q.copy())
        theta.append(streamer.records[-1].theta)
        k += 1
        if answer.done:
            break
    return InProcess(streamer, arm, np.array(t), np.array(q), np.array(theta))


def arm_figures(robot: Robot, run: InProcess) -> dict:
    """ISO figures of the arm's link side (the TCP that really moves) in an in-process run."""
    return execution_figures(robot, run.streamer.plan, run.t, run.q, run.theta, run.streamer.rest_time)
