"""Where a robot program's cycle goes: one row per program move of a planned task path (moves.csv).

A move runs from where the path passes its start target to where it passes its end target (the
point nearest the target, :func:`pathmotion.geometry.targets.target_thetas`: a fine point's target
itself, mid-blend at a zone); a WaitTime is a row of its own. Per move:

* ``planned_time_s`` -- the plan's time over that stretch [s]; ``dwell_s`` -- its WaitTime [s];
  ``cycle_s`` -- their sum, so the column sums to the program's cycle.
* ``programmed_time_s`` -- the programmed-speed estimate (:func:`programmed_time`): the move's length on the
  sharp path over its programmed TCP speed (or its \\T time) [s], acceleration and zones ignored; a joint
  move (MoveJ, MoveAbsJ) takes at least the slowest axis's time at its max speed.
* ``mean_tcp_speed_m_s`` / ``peak_tcp_speed_m_s`` -- length over planned time, and the largest path
  speed theta_dot over the stretch (theta is the TCP's arc length on task and joint moves alike, so
  theta_dot is the TCP speed) [m/s].
* ``binding_limit`` / ``binding_joint`` / ``binding_ratio`` -- the limit and joint that come closest to
  their bound on the stretch: the largest |value| / enforced limit over the trajectory samples of
  joint velocity, acceleration, torque (and jerk, torque rate, TCP speed when enforced).
* ``blend_tolerance_m`` -- the blend's tolerance at the move's end (0: a stop, a fine point).
"""

from __future__ import annotations

import numpy as np


#: moves.csv's columns, in order.
COLUMNS = ("move", "line", "target", "instruction", "planned_time_s", "dwell_s", "cycle_s", "programmed_time_s",
           "mean_tcp_speed_m_s", "peak_tcp_speed_m_s", "binding_limit", "binding_joint", "binding_ratio",
           "blend_tolerance_m")
#: Trajectory sample fields compared with each per-joint enforced limit.
_JOINT_SIGNALS = {"velocity": "qd", "acceleration": "qdd", "torque": "tau", "jerk": "qddd", "torque_rate": "tau_dot"}


def _utilisation(samples, enforced: dict, joint_names, rows: np.ndarray) -> tuple[str, str, float]:
    """(limit, joint, ratio) of the largest |signal| / limit over the samples ``rows``."""
    best = ("", "", 0.0)
    for name, field in _JOINT_SIGNALS.items():
        values, limit = getattr(samples, field, None), enforced.get(name)
        if values is None or limit is None or not rows.any():
            continue
        ratio = np.max(np.abs(values[rows]), axis=0) / np.asarray(limit, float)
        j = int(np.argmax(ratio))
        if ratio[j] > best[2]:
            best = (name, joint_names[j], float(ratio[j]))
    tcp = enforced.get("tcp_speed")
    if tcp is not None and rows.any():
        ratio = float(np.max(np.abs(samples.theta_dot[rows])) / tcp)
        if ratio > best[2]:
            best = ("tcp_speed", "TCP", ratio)
    return best


def _tolerances(spec, count: int) -> list[float]:
    """Blend tolerance (or circle radius) [m] at each segment's end (0 where none), from ``path.blends``."""
    out = [0.0] * count
    for blend in spec.blends:
        size = blend.tolerance if blend.tolerance is not None else blend.radius
        corners = range(count - 1) if blend.corner == "all" else [blend.corner - 1]
        for c in corners:
            if 0 <= c < count:
                out[c] = float(size)
    return out


def programmed_time(seg, move, length: float, axis_time: float = 0.0) -> float | None:
    """The programmed-speed estimate [s] of one segment ``seg`` with its program ``move`` (ProgramMoveSpec or
    None): a dwell its time; a move with \\T its time; else ``length`` [m] over the programmed TCP speed. A joint
    move takes at least ``axis_time`` [s], the slowest axis's time at its max speed, max_i |dq_i| / qd_max_i: the
    controller moves the axes synchronized at the programmed TCP speed unless an axis would exceed its max speed
    (the more faithful of the two readings of MoveJ's speed). None without a program."""
    if seg.type == "dwell":
        return seg.time
    if move is None:
        return None
    if move.time is not None:
        return move.time
    return max(length / move.speed, axis_time) if move.speed else None


def move_table(spec, bounds, lengths, profile, samples, enforced: dict, joint_names,
               axis_times=None) -> dict[str, list] | None:
    """moves.csv's columns (:data:`COLUMNS`) of a planned ``type = "task"`` path whose segments carry program
    moves (``spec``: its TaskPathSpec); ``bounds`` (K + 1,) [m]: theta where the plan passes the start and each
    segment's end; ``lengths`` (K,) [m]: each segment's length before blending; ``axis_times`` (K,) [s]: a joint
    move's slowest-axis time at max speed (0 elsewhere; default all 0); ``profile``: the plan's Profile;
    ``samples``: its trajectory samples; ``enforced``: {limit name: enforced value} as limits.json has them.
    None when the segments carry no program. A dwell segment's row has its wait as ``dwell_s``."""
    moves = [getattr(s, "program", None) for s in spec.segments]
    if all(m is None for m in moves):
        return None
    motion = getattr(profile, "motion", profile)  # the times without the dwells' holds
    times = np.interp(bounds, motion.grid, motion.times)
    speed = np.sqrt(profile.x)
    tol = _tolerances(spec, len(moves))
    axis_times = [0.0] * len(moves) if axis_times is None else axis_times
    cols: dict[str, list] = {c: [] for c in COLUMNS}
    for k, (seg, mv) in enumerate(zip(spec.segments, moves)):
        lo, hi = bounds[k], bounds[k + 1]
        planned = float(times[k + 1] - times[k])
        on = (profile.grid >= lo) & (profile.grid <= hi)
        rows = (samples.theta >= lo) & (samples.theta <= hi) & (hi > lo)
        limit, joint, ratio = _utilisation(samples, enforced, joint_names, rows)
        dwell = seg.time if seg.type == "dwell" else 0.0
        programmed = programmed_time(seg, mv, lengths[k], axis_times[k])
        values = {"move": k + 1, "line": None if mv is None else mv.line, "target": "" if mv is None else mv.target,
                  "instruction": seg.type if mv is None else mv.move, "planned_time_s": planned, "dwell_s": dwell,
                  "cycle_s": planned + dwell, "programmed_time_s": programmed,
                  "mean_tcp_speed_m_s": (hi - lo) / planned if planned > 0 else None,
                  "peak_tcp_speed_m_s": float(speed[on].max()) if on.any() and hi > lo else None,
                  "binding_limit": limit, "binding_joint": joint, "binding_ratio": ratio if limit else None,
                  "blend_tolerance_m": tol[k]}
        for c in COLUMNS:
            cols[c].append(values[c])
    return cols


__all__ = ["COLUMNS", "move_table", "programmed_time"]
