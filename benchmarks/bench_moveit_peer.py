"""Peer benchmark: MoveIt's pipeline, reproduced (toppra, then Ruckig smoothing through the
same samples), against pathmotion's jerk-limited plan on the same paths and limits.

What is reproduced of MoveIt (moveit2, moveit_core/trajectory_processing/src/ruckig_traj_smoothing.cpp,
``RuckigSmoothing::runRuckig`` as of 2024-2025, with ``mitigate_overshoot`` off, its default):
  * the input: the time-parameterized trajectory sampled every ``--dt`` seconds (positions, velocities,
    accelerations of toppra's acceleration-limited optimum, ParametrizeConstAccel on 1000 grid points);
  * segment by segment, Ruckig's time-optimal jerk-limited motion (``Ruckig.calculate``, no minimum
    duration) from waypoint i's state to waypoint i + 1's state, current and target velocities and
    accelerations clamped to the limits first, as MoveIt does;
  * where Ruckig fails, MoveIt's duration extension: a factor growing by 1.1 per failure (never reset,
    so later failures stretch more), waypoint i + 1's duration = factor x its original duration, its
    velocity divided by the factor (compounding over repeated failures of that waypoint), its
    acceleration = (v_{i+1} - v_i) / duration; the loop resumes at the failed segment and gives up when
    the factor reaches 10;
  * the result MoveIt returns: the waypoints with their (possibly stretched) durations, the last
    segment's duration set to Ruckig's.
MoveIt hands that waypoint list to the controller; two ways of playing it are measured:
  * ``MoveIt, played``: quintic interpolation through the waypoints' positions, velocities and
    accelerations at their times (what ros2_control's joint trajectory controller does with full
    waypoints);
  * ``MoveIt, Ruckig segments``: Ruckig's own segments joined end to end (the jerk-limited motion Ruckig
    computed between the same waypoints; its duration is the sum of theirs).
``toppra`` alone (no jerk limit) is listed for reference.

pathmotion: ``plan`` under the same limits, jerk from the robot's limits file (IRB140: 10x the
acceleration estimates), on a fixed grid of ``--grid`` points (as circle_smooth.toml does).

Cases: the IRB140 circle of circle_zero.toml with velocity + acceleration + jerk limits; the same circle
with circle_smooth.toml's limits (torque with a 0.2 reserve, the torque-speed envelope and jerk, the
acceleration estimates off: toppra gets velocity + torque with the reserve (it has no envelope) and
Ruckig the velocity, acceleration estimates and jerk, as MoveIt's joint_limits.yaml would give it);
seeded random clamped cubic joint splines through 4 waypoints (numpy default_rng(seed).uniform(-1.2, 1.2))
and seeded random straight TCP lines (tool pointing down), with velocity + acceleration + jerk limits.

Measured per row, on a 0.1 ms resample of the motion: the duration; the largest TCP distance from the
intended path (forward kinematics of the executed joints against the path's TCP curve, sampled at
20001 points, distance to the polyline); the largest jerk, acceleration, velocity (and torque, in the
torque case) ratio to the limit, jerk and acceleration by finite differences of the sampled velocity
and acceleration for every row alike (a step in acceleration shows as step / 0.1 ms); the wall time,
median of ``--repeats`` interleaved runs in a random order after one warm-up (MoveIt: toppra's solve,
the sampling and the Ruckig loop; pathmotion: ``plan``, verification included). The load average is
printed at start and end.

    .venv/bin/python benchmarks/bench_moveit_peer.py            # all cases (several minutes)
    .venv/bin/python benchmarks/bench_moveit_peer.py --quick    # the circle only, 1 repetition
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pathmotion import api  # noqa: E402
from pathmotion.lift.joint_path import SplineJointPath  # noqa: E402
from pathmotion.planning import PlanSettings, plan  # noqa: E402
from pathmotion.robot import fk, rnea  # noqa: E402
from pathmotion.scenarios import scenario_path  # noqa: E402

#: The resample of every measurement [s].
RESAMPLE = 1e-4
#: toppra's grid (as benchmarks/bench_third_order.py).
TOPPRA_GRID = 1000
#: Points of the intended TCP curve the deviation is measured against.
PATH_POINTS = 20001
#: MoveIt's constants (ruckig_traj_smoothing.cpp).
MAX_DURATION_EXTENSION_FACTOR = 10.0
DURATION_EXTENSION_FRACTION = 1.1
#: The torque reserve of circle_smooth.toml.
RESERVE = 0.2


# ----------------------------------------------------------------------------------- the cases
@dataclass
class Case:
    """A path (pathmotion JointPath) and the limits of both pipelines."""

    name: str
    path: object
    robot: object
    settings: PlanSettings
    torque: bool = False  # toppra gets velocity + torque (with RESERVE) instead of velocity + acceleration


def _kinematic(name, path, robot, grid) -> Case:
    return Case(name, path, robot, PlanSettings(grid_points=grid, limits={"use_torque": False, "use_jerk": True}))


def _line_text(seed: int) -> str:
    rng = np.random.default_rng(seed)
    box = (np.array([0.35, -0.25, 0.35]), np.array([0.65, 0.25, 0.65]))
    while True:
        a, b = rng.uniform(*box), rng.uniform(*box)
        if np.linalg.norm(b - a) > 0.2:
            break
    return (f'name = "line_{seed}"\n[robot]\nname = "irb140"\n[path]\ntype = "task"\norientation = "down"\n'
            f'[[path.segments]]\ntype = "line"\nstart = {a.tolist()}\nend = {b.tolist()}\n'
            '[plan]\nstart = "zero"\nend = "zero"\n')


def cases(grid: int, quick: bool) -> list[Case]:
    circle = api.load(scenario_path("circle_zero"))
    out = [_kinematic("circle, vel+acc+jerk", circle.path, circle.robot, grid)]
    if quick:
        return out
    smooth = api.load(scenario_path("circle_smooth"))
    out.append(Case("circle_smooth limits", smooth.path, smooth.robot,
                    api.dataclasses.replace(smooth.plan_settings, grid_points=grid, baselines=False), torque=True))
    for seed in (1, 2, 3):
        wp = np.random.default_rng(seed).uniform(-1.2, 1.2, (4, 6))
        out.append(_kinematic(f"spline seed {seed}", SplineJointPath.from_waypoints(wp), circle.robot, grid))
    for seed in (1, 2):
        line = api.load_text(_line_text(seed))
        out.append(_kinematic(f"line seed {seed}", line.path, line.robot, grid))
    return out


# ------------------------------------------------------------------------------------- toppra
def toppra_trajectory(case: Case):
    """toppra's optimum (ParametrizeConstAccel) under velocity + acceleration, or velocity + torque."""
    import toppra.algorithm as algo
    import toppra.constraint as constraint
    from reference_topp import toppra_instance

    lim = case.robot.limits
    inst = toppra_instance(case.path, lim.velocity, lim.acceleration, TOPPRA_GRID)
    if case.torque:
        model, data = case.robot.model, case.robot.model.createData()
        tau = (1.0 - RESERVE) * lim.torque
        cons = [inst.constraints[0], constraint.JointTorqueConstraint(
            lambda q, v, a: pin.rnea(model, data, q, v, a), np.vstack([-tau, tau]).T, np.zeros(case.robot.n),
            discretization_scheme=constraint.DiscretizationType.Interpolation)]
        inst = algo.TOPPRA(cons, inst.path, gridpoints=np.linspace(*case.path.domain, TOPPRA_GRID),
                           parametrizer="ParametrizeConstAccel")
    return inst.compute_trajectory()


def waypoints(traj, dt: float):
    """(times (N,), q, qd, qdd (N, n)): ``traj`` sampled every dt, the last sample at its end."""
    T = float(traj.duration)
    t = np.append(np.arange(0.0, T - 0.5 * dt, dt), T)
    return t, traj(t), traj(t, 1), traj(t, 2)


# ------------------------------------------------------------------------------ MoveIt's Ruckig
@dataclass
class Smoothed:
    """MoveIt's output: waypoint times (N,) and q, qd, qdd (N, n); Ruckig's segments; the extension
    factor reached and whether it succeeded."""

    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    segments: list
    factor: float
    ok: bool


def _ruckig_segment(otg, inp, traj, cur, nxt, vmax, amax):
    from ruckig import Result, RuckigError

    inp.current_position, inp.target_position = cur[0].tolist(), nxt[0].tolist()
    inp.current_velocity = np.clip(cur[1], -vmax, vmax).tolist()
    inp.current_acceleration = np.clip(cur[2], -amax, amax).tolist()
    inp.target_velocity = np.clip(nxt[1], -vmax, vmax).tolist()
    inp.target_acceleration = np.clip(nxt[2], -amax, amax).tolist()
    try:
        result = otg.calculate(inp, traj)
    except RuckigError:  # input validation (a target it cannot hold, ...): MoveIt's C++ Ruckig (throw_error
        return False  # off) returns ErrorInvalidInput instead, a failure alike
    return result in (Result.Working, Result.Finished)


def moveit_ruckig(times, q, qd, qdd, vmax, amax, jmax) -> Smoothed:
    """MoveIt's runRuckig on the waypoints (see the module docstring), mitigate_overshoot off."""
    from ruckig import InputParameter, Ruckig, Trajectory

    n_wp, dof = q.shape
    dur = np.diff(times, prepend=times[0])  # duration from the previous waypoint
    original = dur.copy()
    q, qd, qdd = q.copy(), qd.copy(), qdd.copy()
    otg, inp = Ruckig(dof), InputParameter(dof)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax.tolist(), amax.tolist(), jmax.tolist()
    segments = [None] * (n_wp - 1)
    factor, idx, complete, ok = 1.0, 0, False, True
    while factor < MAX_DURATION_EXTENSION_FACTOR and not complete:
        while idx < n_wp - 1:
            traj = Trajectory(dof)
            ok = _ruckig_segment(otg, inp, traj, (q[idx], qd[idx], qdd[idx]), (q[idx + 1], qd[idx + 1], qdd[idx + 1]),
                                 vmax, amax)
            if ok:
                segments[idx] = traj
            if ok and idx == n_wp - 2:
                dur[idx + 1] = traj.duration
                complete = True
                break
            if not ok:  # extendTrajectoryDuration
                factor *= DURATION_EXTENSION_FRACTION
                dur[idx + 1] = factor * original[idx + 1]
                qd[idx + 1] = qd[idx + 1] / factor
                qdd[idx + 1] = (qd[idx + 1] - qd[idx]) / dur[idx + 1]
                break
            idx += 1
    return Smoothed(np.cumsum(dur), q, qd, qdd, segments, factor, ok and complete)


def _average_segment(dur: np.ndarray) -> float:
    """RobotTrajectory::getAverageSegmentDuration: the total duration over the number of waypoints."""
    return float(np.sum(dur) / len(dur))


def moveit_ruckig_humble(times, q, qd, qdd, vmax, amax, jmax) -> Smoothed:
    """The Humble-era runRuckig (see the module docstring): Ruckig.update with the average segment duration
    as its cycle must reach every next waypoint within one cycle (Result.Finished); otherwise every duration
    is stretched from the original by the growing factor, the velocities divided by it, the accelerations
    recomputed as differences, and the loop starts again from the first waypoint."""
    from ruckig import InputParameter, OutputParameter, Result, Ruckig, RuckigError

    n_wp, dof = q.shape
    original = np.diff(times, prepend=times[0])
    dur, qd0 = original.copy(), qd.copy()
    qd, qdd = qd.copy(), qdd.copy()
    timestep = _average_segment(dur)
    factor, complete, result = 1.0, False, None
    inp, out = InputParameter(dof), OutputParameter(dof)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax.tolist(), amax.tolist(), jmax.tolist()
    while factor < MAX_DURATION_EXTENSION_FACTOR and not complete:
        otg = Ruckig(dof, timestep)
        for idx in range(n_wp - 1):
            inp.current_position, inp.target_position = q[idx].tolist(), q[idx + 1].tolist()
            inp.current_velocity = np.clip(qd[idx], -vmax, vmax).tolist()
            inp.current_acceleration = np.clip(qdd[idx], -amax, amax).tolist()
            inp.target_velocity = np.clip(qd[idx + 1], -vmax, vmax).tolist()
            inp.target_acceleration = np.clip(qdd[idx + 1], -amax, amax).tolist()
            try:
                result = otg.update(inp, out)
            except RuckigError:  # ErrorInvalidInput in MoveIt's C++ Ruckig
                result = None
            if idx == n_wp - 2 and result == Result.Finished:
                complete = True
                break
            if result != Result.Finished:
                factor *= DURATION_EXTENSION_FRACTION
                dur = original.copy()
                for i in range(1, n_wp):  # the average is taken while the durations are being stretched
                    dur[i] = factor * original[i]
                    timestep = _average_segment(dur)
                    qd[i] = qd0[i] / factor
                    qdd[i] = (qd[i] - qd[i - 1]) / timestep
                break
    return Smoothed(np.cumsum(dur), q, qd, qdd, [], factor, complete)


# ------------------------------------------------------------------------------- playing motions
@dataclass
class Motion:
    """A motion on the resample: t (N,), q, qd, qdd (N, n)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def _resample_times(duration: float) -> np.ndarray:
    return np.append(np.arange(0.0, duration, RESAMPLE), duration)


def quintic(s: Smoothed) -> Motion:
    """The waypoints played by quintic interpolation of (q, qd, qdd) between consecutive times."""
    t = _resample_times(float(s.times[-1]))
    k = np.clip(np.searchsorted(s.times, t, side="right") - 1, 0, len(s.times) - 2)
    h = (s.times[k + 1] - s.times[k])[:, None]
    tau = (t - s.times[k])[:, None]
    p0, v0, a0, p1, v1, a1 = s.q[k], s.qd[k], s.qdd[k], s.q[k + 1], s.qd[k + 1], s.qdd[k + 1]
    c3 = (20 * (p1 - p0) - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h**2) / (2 * h**3)
    c4 = (30 * (p0 - p1) + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h**2) / (2 * h**4)
    c5 = (12 * (p1 - p0) - 6 * (v1 + v0) * h + (a1 - a0) * h**2) / (2 * h**5)
    q = p0 + v0 * tau + 0.5 * a0 * tau**2 + c3 * tau**3 + c4 * tau**4 + c5 * tau**5
    qd = v0 + a0 * tau + 3 * c3 * tau**2 + 4 * c4 * tau**3 + 5 * c5 * tau**4
    qdd = a0 + 6 * c3 * tau + 12 * c4 * tau**2 + 20 * c5 * tau**3
    return Motion(t, q, qd, qdd)


def ruckig_segments(s: Smoothed) -> Motion:
    """Ruckig's segments joined end to end."""
    starts = np.concatenate([[0.0], np.cumsum([seg.duration for seg in s.segments])])
    t = _resample_times(float(starts[-1]))
    k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(s.segments) - 1)
    out = np.empty((3, len(t), s.q.shape[1]))
    for i, (ti, ki) in enumerate(zip(t, k)):
        p, v, a = s.segments[ki].at_time(min(ti - starts[ki], s.segments[ki].duration))[:3]
        out[0, i], out[1, i], out[2, i] = p, v, a
    return Motion(t, out[0], out[1], out[2])


def toppra_motion(traj) -> Motion:
    t = _resample_times(float(traj.duration))
    return Motion(t, traj(t), traj(t, 1), traj(t, 2))


def pathmotion_motion(result) -> Motion:
    s = result.trajectory.at_time(_resample_times(result.duration))
    return Motion(s.t, s.q, s.qd, s.qdd)


# ---------------------------------------------------------------------------------- measures
class IntendedPath:
    """The path's TCP curve at PATH_POINTS points, and distances from it."""

    def __init__(self, case: Case):
        from scipy.spatial import cKDTree

        theta = np.linspace(*case.path.domain, PATH_POINTS)
        self.points = fk(case.robot, case.path.evaluate(theta)[0])[0]
        self.tree = cKDTree(self.points)

    def deviation(self, robot, q: np.ndarray) -> float:
        """Largest distance [m] of the TCP at joint positions q (N, n) from the polyline."""
        p = fk(robot, q)[0]
        _, i = self.tree.query(p)
        best = np.full(len(p), np.inf)
        for a_idx in (i - 1, i):
            a_idx = np.clip(a_idx, 0, len(self.points) - 2)
            a, b = self.points[a_idx], self.points[a_idx + 1]
            ab = b - a
            s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
            best = np.minimum(best, np.linalg.norm(a + s[:, None] * ab - p, axis=1))
        return float(best.max())


def ratios(m: Motion, case: Case) -> dict[str, float]:
    """Largest jerk, acceleration, velocity (and torque) ratio on the resample."""
    lim = case.robot.limits
    jerk = np.diff(m.qdd, axis=0) / np.diff(m.t)[:, None]
    acc = np.diff(m.qd, axis=0) / np.diff(m.t)[:, None]
    out = {"jerk": float(np.max(np.abs(jerk) / lim.jerk)), "acc": float(np.max(np.abs(acc) / lim.acceleration)),
           "vel": float(np.max(np.abs(m.qd) / lim.velocity))}
    if case.torque:
        tau = rnea(case.robot, m.q, m.qd, m.qdd)
        out["torque"] = float(np.max(np.abs(tau) / ((1.0 - RESERVE) * lim.torque)))
    return out


# -------------------------------------------------------------------------------------- timing
def interleaved(fns: dict, repeats: int) -> dict[str, float]:
    """{name: median wall time [s]}: one warm-up each, then ``repeats`` rounds in a random order."""
    for fn in fns.values():
        fn()
    times = {k: [] for k in fns}
    rng = random.Random(0)
    for _ in range(repeats):
        order = list(fns)
        rng.shuffle(order)
        for k in order:
            t0 = time.perf_counter()
            fns[k]()
            times[k].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


# ------------------------------------------------------------------------------------- the run
def run_case(case: Case, dts: list[float], repeats: int) -> list[tuple]:
    """The table's rows of one case: toppra alone, MoveIt's variants at each waypoint spacing, pathmotion."""
    lim = case.robot.limits
    kinematic = (lim.velocity, lim.acceleration, lim.jerk)
    smoothers = {"main": moveit_ruckig, "Humble": moveit_ruckig_humble}

    def moveit(smoother, dt):
        traj = toppra_trajectory(case)
        return traj, smoother(*waypoints(traj, dt), *kinematic)

    fns = {"toppra": lambda: toppra_trajectory(case), "ours": lambda: plan(case.path, case.robot, case.settings)}
    for dt in dts:
        for name, smoother in smoothers.items():
            fns[(name, dt)] = lambda smoother=smoother, dt=dt: moveit(smoother, dt)
    wall = interleaved(fns, repeats)
    intended = IntendedPath(case)
    traj = fns["toppra"]()
    motions = [("toppra alone (no jerk limit)", toppra_motion(traj), wall["toppra"], "")]
    for dt in dts:
        for name in smoothers:
            smoothed = fns[(name, dt)]()[1]
            note = "" if smoothed.factor == 1 else f"stretched, factor {smoothed.factor:.3g}"
            if not smoothed.ok:
                note = f"smoothing failed (factor {smoothed.factor:.3g} reached)"
            plays = [("played", quintic)] + ([("Ruckig's segments", ruckig_segments)] if name == "main" else [])
            for how, play in plays:
                motions.append((f"MoveIt {name}, {how} (dt {dt:g} s)", play(smoothed) if smoothed.ok else None,
                                wall[(name, dt)], note))
    motions.append(("pathmotion", pathmotion_motion(fns["ours"]()), wall["ours"], ""))
    rows = []
    for label, motion, wall_time, note in motions:
        if motion is None:
            rows.append((case.name, label, None, None, {}, wall_time, note))
        else:
            rows.append((case.name, label, motion.duration, intended.deviation(case.robot, motion.q),
                         ratios(motion, case), wall_time, note))
    return rows


def _fmt(v, spec):
    return "-" if v is None else format(v, spec)


def print_header(torque: bool) -> None:
    head = ("| case | pipeline | duration [s] | path dev. [mm] | jerk ratio | acc. ratio | vel. ratio |"
            + (" torque ratio |" if torque else "") + " wall [ms] | note |")
    print(head)
    print("|" + "---|" * (head.count("|") - 1), flush=True)


def print_rows(rows: list[tuple], torque: bool) -> None:
    for name, label, dur, dev, r, wall, note in rows:
        cells = [name, label, _fmt(dur, ".4f"), _fmt(None if dev is None else 1e3 * dev, ".3g"),
                 _fmt(r.get("jerk"), ".4g"), _fmt(r.get("acc"), ".4g"), _fmt(r.get("vel"), ".4g")]
        if torque:
            cells.append(_fmt(r.get("torque"), ".4g"))
        cells += [_fmt(None if wall is None else 1e3 * wall, ".0f"), note]
        print("| " + " | ".join(cells) + " |", flush=True)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, nargs="+", default=[0.1, 0.01],
                        help="MoveIt's waypoint spacings in time [s] (0.1: MoveIt's resample_dt default)")
    parser.add_argument("--grid", type=int, default=200, help="pathmotion's fixed grid (points)")
    parser.add_argument("--repeats", type=int, default=3, help="timed repetitions (medians)")
    parser.add_argument("--quick", action="store_true", help="the circle only, one repetition")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    print(f"load average at start: {os.getloadavg()}", flush=True)
    all_cases = cases(args.grid, args.quick)
    torque = any(c.torque for c in all_cases)
    print_header(torque)
    for case in all_cases:
        print_rows(run_case(case, args.dt, repeats), torque)
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
