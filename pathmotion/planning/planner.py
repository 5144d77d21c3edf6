"""The time-optimal planner: settings, result and :func:`plan`.

Flow: grid (uniform in theta, plus every segment connection) -> path derivatives on both sides of
each connection -> reduced dynamics (RNEA) -> canonical constraints -> reachability analysis
(topp.py) with the boundary conditions (boundary.py) and connection mode (segments.py) ->
verify on a dense time resample and tighten the limits locally where the continuous trajectory
exceeds them between grid points, re-solve (bounded) -> baselines.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Union

import numpy as np

from .. import defaults
from ..errors import InfeasibleError, ScenarioError
from ..joint_path import JointPath
from ..robot import Robot, jacobian
from .baselines import Baselines, compute_baselines
from .boundary import Boundary
from .constraints import EffectiveLimits, LimitScale, PointConstraints, point_constraints
from .profile import Profile
from .reduced import ReducedDynamics, reduced_dynamics
from .segments import CONNECTIONS, solve_chain
from .topp import IntervalProblem, interval_problem, maximum_velocity_curve
from .trajectory import Trajectory
from .verify import LimitRatios, sample_ratios, summarize, worst_outside


@dataclass(frozen=True)
class PlanSettings:
    """What to plan and under which limits.

    grid_points: points of the uniform theta grid (segment connections are added).
    velocity / acceleration / torque: limit on or off; *_scale multiplies the robot's limit
    (acceleration is off anyway when the robot has no acceleration limits).
    tcp_speed_limit: TCP speed limit [m/s] or None.
    start, end: "zero", "max" (boundary-level velocity) or theta_dot [unit theta / s]; None = "zero".
    periodic: steady-state cycle on a closed path (start/end must then be None).
    connections: "chain" | "zero" | "max" (see segments.py).
    limit_tolerance: allowed relative excess on the verification resample.
    verify: run the verify-and-tighten loop (and report the ratios); baselines: compute them.
    """

    grid_points: int = defaults.GRID_POINTS
    velocity: bool = True
    velocity_scale: float = 1.0
    acceleration: bool = True
    acceleration_scale: float = 1.0
    torque: bool = True
    torque_scale: float = 1.0
    tcp_speed_limit: float | None = None
    start: Union[str, float, None] = None
    end: Union[str, float, None] = None
    periodic: bool = False
    connections: str = "chain"
    limit_tolerance: float = defaults.LIMIT_TOLERANCE
    verify: bool = True
    verify_sample_time: float = defaults.VERIFY_SAMPLE_TIME
    max_tighten_iterations: int = defaults.PLAN_MAX_TIGHTEN_ITERATIONS
    baselines: bool = True
    fitted_margin: float = defaults.FITTED_PROFILE_MARGIN

    def __post_init__(self):
        if int(self.grid_points) != self.grid_points or self.grid_points < 3:
            raise ScenarioError(f"planner grid_points must be an integer >= 3, got {self.grid_points}")
        for name in ("velocity_scale", "acceleration_scale", "torque_scale"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ScenarioError(f"planner {name} must be > 0, got {v}")
        if self.tcp_speed_limit is not None and not (np.isfinite(self.tcp_speed_limit) and self.tcp_speed_limit > 0):
            raise ScenarioError(f"tcp_speed_limit must be > 0 m/s or None, got {self.tcp_speed_limit}")
        for name in ("start", "end"):
            v = getattr(self, name)
            if v is None or v in ("zero", "max"):
                continue
            if isinstance(v, str) or isinstance(v, bool) or not np.isfinite(v) or v < 0:
                raise ScenarioError(f"planner {name} must be 'zero', 'max' or a theta_dot >= 0, got {v!r}")
        if self.periodic and (self.start is not None or self.end is not None):
            raise ScenarioError("periodic planning fixes both ends (equal theta_dot); leave start and end unset")
        if self.connections not in CONNECTIONS:
            raise ScenarioError(f"connections must be one of {CONNECTIONS}, got {self.connections!r}")
        if not self.limit_tolerance >= 0:
            raise ScenarioError(f"limit_tolerance must be >= 0, got {self.limit_tolerance}")
        if not (0 <= self.fitted_margin < 1):
            raise ScenarioError(f"fitted_margin must be in [0, 1), got {self.fitted_margin}")

    @property
    def start_condition(self) -> Boundary:
        return "zero" if self.start is None else self.start

    @property
    def end_condition(self) -> Boundary:
        return "zero" if self.end is None else self.end


@dataclass(frozen=True, eq=False)
class LimitCurves:
    """Phase-plane curves on the grid (K,): x_max = maximum-velocity curve from the point-wise
    limits (inf where unbounded); x_controllable = upper bound of the controllable sets."""

    grid: np.ndarray
    x_max: np.ndarray
    x_controllable: np.ndarray


@dataclass(frozen=True, eq=False)
class PlanResult:
    """A plan: the optimal profile and trajectory, the per-segment profiles ("max" connections),
    the limit curves, verification ratios (None if verify was off), baselines (None if off),
    solve time [s] (everything but the baselines), grid size and tighten iterations used."""

    profile: Profile
    trajectory: Trajectory
    segment_profiles: tuple[Profile, ...]
    curves: LimitCurves
    ratios: LimitRatios | None
    baselines: Baselines | None
    solve_time_s: float
    grid_points: int
    tighten_iterations: int
    jump_intervals: tuple[tuple[float, float], ...]
    settings: PlanSettings = field(repr=False)

    @property
    def duration(self) -> float:
        return self.profile.duration


def effective_limits(robot: Robot, settings: PlanSettings) -> EffectiveLimits:
    lim = robot.limits
    return EffectiveLimits(
        velocity=lim.velocity * settings.velocity_scale if settings.velocity else None,
        acceleration=(lim.acceleration * settings.acceleration_scale
                      if settings.acceleration and lim.acceleration is not None else None),
        torque=lim.torque * settings.torque_scale if settings.torque else None,
        tcp_speed=settings.tcp_speed_limit,
    )


def make_grid(path: JointPath, points: int) -> tuple[np.ndarray, tuple[int, ...], tuple[int, ...]]:
    """Uniform grid on the path's domain plus its breaks; returns grid, break and kink indices."""
    lo, hi = path.domain
    grid = np.linspace(lo, hi, int(points))
    special = np.array(sorted({float(b) for b in (*path.breaks, *path.kinks) if lo < b < hi}))
    if special.size:
        step = (hi - lo) / (points - 1)
        near = np.min(np.abs(grid[:, None] - special[None, :]), axis=1) < 0.3 * step
        grid = np.union1d(grid[~near | (grid == lo) | (grid == hi)], special)
    step = grid[1] - grid[0]
    ends = np.array([lo, hi, *special])
    grade = step * 0.5 ** np.arange(1, defaults.GRID_GRADING_LEVELS + 1)
    extra = np.concatenate([ends[:, None] + grade[None, :], ends[:, None] - grade[None, :]]).ravel()
    grid = np.union1d(grid, extra[(extra > lo) & (extra < hi)])
    index = {float(t): i for i, t in enumerate(grid)}
    breaks = tuple(index[float(b)] for b in special)
    kinks = tuple(index[float(k)] for k in special if float(k) in {float(x) for x in path.kinks})
    return grid, breaks, kinks


@dataclass(frozen=True, eq=False)
class _Sampled:
    """Path data on the grid, as seen from the interval after (right) and before (left) each point."""

    q: np.ndarray
    dq_r: np.ndarray
    ddq_r: np.ndarray
    dq_l: np.ndarray
    ddq_l: np.ndarray
    red_r: ReducedDynamics | None
    red_l: ReducedDynamics | None
    gain_r: np.ndarray | None
    gain_l: np.ndarray | None


def _sample(path, robot, grid, breaks, need_torque, need_gain) -> _Sampled:
    q, dq, ddq = path.evaluate(grid, "right")
    dq_l, ddq_l = dq.copy(), ddq.copy()
    idx = np.array(list(breaks) + [len(grid) - 1], dtype=int)
    _, dql, ddql = path.evaluate(grid[idx], "left")
    dq_l[idx], ddq_l[idx] = dql, ddql
    red_r = red_l = gain_r = gain_l = None
    if need_torque:
        red_r = reduced_dynamics(robot, q, dq, ddq)
        extra = reduced_dynamics(robot, q[idx], dql, ddql)
        al, be = red_r.alpha.copy(), red_r.beta.copy()
        al[idx], be[idx] = extra.alpha, extra.beta
        red_l = ReducedDynamics(al, be, red_r.gamma)
    if need_gain:
        jv = jacobian(robot, q)[:, :3, :]
        gain_r = np.linalg.norm(np.einsum("kij,kj->ki", jv, dq), axis=1)
        gain_l = np.linalg.norm(np.einsum("kij,kj->ki", jv, dq_l), axis=1)
    return _Sampled(q, dq, ddq, dq_l, ddq_l, red_r, red_l, gain_r, gain_l)


def _check_gravity(grid, s: _Sampled, limits: EffectiveLimits, names) -> None:
    over = np.abs(s.red_r.gamma) > limits.torque
    if np.any(over):
        k, j = np.argwhere(over)[0]
        raise InfeasibleError(
            f"gravity torque of {names[j]} at theta = {grid[k]:.6g} is {s.red_r.gamma[k, j]:.6g} N m, beyond its "
            f"limit +-{limits.torque[j]:.6g} N m: the arm cannot hold the path there (nor stop on it); lower the "
            "payload, raise the torque limit or move the path"
        )


def _rows(pc: PointConstraints, sl) -> PointConstraints:
    return PointConstraints(pc.a[sl], pc.b[sl], pc.c[sl], pc.lo[sl], pc.hi[sl], pc.x_max[sl], pc.row_kind, pc.row_joint)


def _build(grid, s: _Sampled, limits, scale) -> tuple[IntervalProblem, PointConstraints, PointConstraints]:
    right = point_constraints(s.dq_r, s.ddq_r, limits, scale, s.red_r, s.gain_r, defaults.PLANNER_X_CAP)
    left = point_constraints(s.dq_l, s.ddq_l, limits, scale, s.red_l, s.gain_l, defaults.PLANNER_X_CAP)
    problem = interval_problem(grid, _rows(right, slice(0, -1)), _rows(left, slice(1, None)), right.x_max, left.x_max)
    return problem, right, left


def _closure_is_kink(s: _Sampled) -> bool:
    a, b = s.dq_r[0], s.dq_l[-1]
    return bool(np.linalg.norm(a - b) > 1e-6 * (1.0 + np.linalg.norm(a)))


def plan(path: JointPath, robot: Robot, settings: PlanSettings = PlanSettings()) -> PlanResult:
    """Time-optimal motion along ``path`` for ``robot`` under ``settings`` (see PlanSettings)."""
    t0 = time.perf_counter()
    if path.n != robot.n:
        raise ScenarioError(f"path has {path.n} joints, robot {robot.name} has {robot.n}")
    if settings.periodic and not path.closed:
        raise ScenarioError("periodic planning needs a closed path (start pose == end pose); set periodic = false")
    limits = effective_limits(robot, settings)
    grid, breaks, kinks = make_grid(path, settings.grid_points)
    samp = _sample(path, robot, grid, breaks, limits.torque is not None,
                   limits.tcp_speed is not None or settings.baselines)
    if limits.torque is not None:
        _check_gravity(grid, samp, limits, robot.joint_names)
    stops = set(kinks)
    if settings.periodic and _closure_is_kink(samp):
        stops |= {0, len(grid) - 1}
    chain_args = dict(start=settings.start_condition, end=settings.end_condition, periodic=settings.periodic,
                      connections=settings.connections, breaks=breaks, stops=tuple(sorted(stops)))
    scale = LimitScale.ones(len(grid), robot.n)
    tol = settings.limit_tolerance
    ratios = None
    iterations = 0
    while True:
        problem, right, left = _build(grid, samp, limits, scale)
        sol = solve_chain(problem, **chain_args)
        _check_bounded(grid, sol.x)
        traj = Trajectory(path, sol.profile, robot)
        if not settings.verify:
            break
        samples, r = sample_ratios(traj, limits, settings.verify_sample_time, sol.jump_intervals)
        jumps = tuple(grid[k] for k in kinks if sol.x[k] > 0)
        ratios = summarize(samples, r, limits, settings.verify_sample_time, jumps, robot.joint_names)
        interval = np.clip(np.searchsorted(grid, samples.theta, side="right") - 1, 0, len(grid) - 2)
        worst = worst_outside(samples, r, sol.jump_intervals)
        free = _outside(samples.theta, sol.jump_intervals)
        if worst <= 1.0 + tol:
            break
        if iterations >= settings.max_tighten_iterations:
            raise InfeasibleError(
                f"the planned motion still exceeds a limit by {100 * (worst - 1):.3g} % between grid points after "
                f"{iterations} tightening iterations ({ratios.worst}); raise grid_points or limit_tolerance"
            )
        scale = _tightened(scale, r, interval, free, tol, len(grid))
        iterations += 1
    solve_time = time.perf_counter() - t0
    curves = LimitCurves(grid, np.minimum(maximum_velocity_curve(right), maximum_velocity_curve(left)),
                         sol.controllable_hi)
    base = None
    if settings.baselines:
        base = compute_baselines(problem, sol, chain_args, samp.gain_r, samp.gain_l, path, robot, limits, settings)
    return PlanResult(sol.profile, traj, sol.segment_profiles, curves, ratios, base, solve_time, len(grid),
                      iterations, sol.jump_intervals, settings)


def _check_bounded(grid: np.ndarray, x: np.ndarray) -> None:
    """InfeasibleError where the profile reaches the cap on x: no active limit bounds the speed there."""
    capped = np.nonzero(x >= 0.999 * defaults.PLANNER_X_CAP)[0]
    if capped.size:
        raise InfeasibleError(
            f"no active limit bounds the path speed at theta = {grid[capped[0]]:.6g} (theta_dot would reach the "
            f"cap {np.sqrt(defaults.PLANNER_X_CAP):.3g}): the time-optimal motion is unbounded; switch on a "
            "velocity, acceleration or torque limit (limits.use_*) or give a tcp_speed limit")


def _outside(theta: np.ndarray, intervals) -> np.ndarray:
    free = np.ones(len(theta), dtype=bool)
    for a, b in intervals:
        free &= ~((theta >= a) & (theta <= b))
    return free


def _tightened(scale: LimitScale, ratios: dict, interval: np.ndarray, free: np.ndarray, tol: float,
               k: int) -> LimitScale:
    """Scale the limits down at both ends of every interval whose samples exceed 1 + tol/2."""
    new = {}
    for kind, field_name in (("velocity", "velocity"), ("acceleration", "acceleration"), ("torque", "torque"),
                             ("tcp_speed", "tcp")):
        cur = getattr(scale, field_name)
        if kind not in ratios:
            new[field_name] = cur
            continue
        r = ratios[kind][free]
        worst = np.ones((k - 1, r.shape[1]))
        np.maximum.at(worst, interval[free], r)
        factor = np.where(worst > 1.0 + 0.5 * tol, (1.0 - 0.25 * tol) / worst, 1.0)
        point = np.ones((k, r.shape[1]))
        point[:-1] = np.minimum(point[:-1], factor)
        point[1:] = np.minimum(point[1:], factor)
        if cur.ndim == 1:
            point = point.min(axis=1)
        new[field_name] = cur * point
    return LimitScale(**new)
