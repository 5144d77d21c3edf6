"""ISO 9283 figures of an executed motion, by the simulation's own measures (simulation/metrics.py):
path accuracy (largest TCP distance to the planned TCP path), cycle time (the TCP first within the path
tolerance of the path's end, plus the plan's own time from entering that ball to its end, as simulate
credits it), settle time (within it for good), the residual vibration after the reference came to rest
(largest TCP distance from where the arm finally rests, after that moment), and the start latency (from the
first message to the TCP's first motion: EGM's transport delay and low-pass, which the cycle time includes)."""

from __future__ import annotations

import numpy as np

from .. import defaults
from ..robot import Robot, fk
from ..simulation.metrics import planned_tcp_line, polish_projection, tcp_path_deviation

#: Newton steps of the projection from the plan's theta at the same plan time (a close start).
PROJECTION_STEPS = 4
#: Planned-path polyline points per metre of TCP path (chord sag below a micrometre on these paths).
LINE_POINTS = 4000
#: The TCP has started moving once it is this far from where it was at the first message [m].
START_MOTION = 5e-5


def _plan_in_ball(robot: Robot, trajectory, end: np.ndarray, tolerance: float) -> float:
    """The plan's own time [s] from entering the ball of ``tolerance`` about ``end`` (for good) to its end."""
    duration = trajectory.duration
    t = np.linspace(0.0, duration, max(2, int(duration / defaults.EGM_TABLE_STEP) + 1))
    tcp = fk(robot, trajectory.at_time(t).q)[0]
    outside = np.flatnonzero(np.linalg.norm(tcp - end, axis=1) > tolerance)
    return float(duration - t[outside[-1] + 1]) if outside.size and outside[-1] + 1 < len(t) else 0.0


def execution_figures(robot: Robot, trajectory, t: np.ndarray, q: np.ndarray, theta_guess: np.ndarray,
                      rest_time: float, tolerance: float = defaults.PATH_TOLERANCE) -> dict:
    """Figures (SI units, JSON-ready) of joint states q (K, n) at times t (K,) [s] executing ``trajectory`` (the
    plan, a planning.Trajectory); theta_guess (K,): the reference's theta at each sample; rest_time [s]: when
    the reference came to rest (the plan's end or a stop)."""
    path, planned_duration = trajectory.path, trajectory.duration
    lo, hi = path.domain
    grid = np.linspace(lo, hi, LINE_POINTS + 1)
    line = planned_tcp_line(robot, path, grid)
    theta, _ = polish_projection(path, q, np.asarray(theta_guess, float), PROJECTION_STEPS)
    tcp, _, dist = tcp_path_deviation(robot, path, q, theta, grid, line)
    end = line[-1] if not path.closed else line[0]
    near_end = np.linalg.norm(tcp - end, axis=1) <= tolerance
    reached = np.flatnonzero(near_end & (t >= 0.5 * planned_duration))
    outside = np.flatnonzero(~near_end)
    after = t >= rest_time
    vibration = float(np.max(np.linalg.norm(tcp[after] - tcp[-1], axis=1))) if after.any() else None
    moved = np.flatnonzero(np.linalg.norm(tcp - tcp[0], axis=1) > START_MOTION) if len(tcp) else np.array([], int)
    return {
        "planned_duration_s": float(planned_duration),
        "path_accuracy_m": float(np.max(dist)) if dist.size else 0.0,
        "cycle_time_s": (float(t[reached[0]]) + _plan_in_ball(robot, trajectory, end, tolerance)
                         if reached.size else None),
        "start_latency_s": float(t[moved[0]] - t[0]) if moved.size else None,
        "settle_time_s": (float(t[outside[-1] + 1]) if outside.size and outside[-1] + 1 < len(t) else
                          (None if outside.size else float(t[0]))),
        "residual_vibration_m": vibration,
        "path_tolerance_m": float(tolerance),
        "final_tcp_m": [float(v) for v in fk(robot, q[-1:])[0][0]] if len(q) else None,
    }
