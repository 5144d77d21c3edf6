"""The time-optimal planner: settings, result and :func:`plan`.

Flow: grid (adaptive, refined until the duration's estimated error is within ``duration_tolerance``, grid.py;
or fixed with ``grid_points``) -> path derivatives on both sides of each connection and limit rows from every
active limit object (grid_data.py; limits/, limit_rows.py) -> reachability analysis
(topp.py) with the boundary conditions (boundary.py) and connection mode (segments.py) ->
verify (certified interval bounds or a dense time resample); where the continuous trajectory exceeds a
limit between grid points, halve those intervals (adaptive grid) or tighten the limits locally there,
re-solve (bounded) -> baselines.
"""

from __future__ import annotations


import logging
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Union

import numpy as np

from .. import defaults
from ..errors import InfeasibleError, ScenarioError
from ..lift.joint_path import JointPath
from ..modes import BoundaryMode, Connections, VerifyMode, parse_mode
from ..robot import Robot
from .baselines import Baselines, compute_baselines, dense_check
from .certify import CertifyContext, certify
from .grid import Grid, make_grid, refine
from .grid_data import ReusingPoints, Sampled, grid_breaks, grid_rows, sample_grid, with_knots
from .boundary import X_CAP_FRACTION, Boundary, at_rest
from .limit_rows import LimitRows
from .limits import EffectiveLimits, LimitChoice, LimitChoices, PathPoints, effective_limits_for, tcp_gain
from .profile import Profile
from .segments import solve_chain
from .third_order import solve_third_order
from .topp import IntervalProblem, maximum_velocity_curve
from .trajectory import Trajectory
from .verify import LimitRatios, interval_maxima, outside, sample_ratios, summarize, summarize_intervals

log = logging.getLogger(__name__)

#: A closed path's closure is a kink when Phi' differs across it by more than this, relative [-].
CLOSURE_KINK_TOLERANCE = 1e-6
#: Tightening: an interval is tightened when its ratio exceeds 1 + defaults.TIGHTEN_TRIGGER x tolerance
#: (shared with the certification's refinement), and its limits are scaled so that the ratio becomes
#: 1 - TIGHTEN_TARGET x tolerance [-].
TIGHTEN_TARGET = 0.25


@dataclass(frozen=True)
class PlanSettings:
    """What to plan and under which limits; a frozen value (change it with ``dataclasses.replace``).

    grid_points: None (default): an adaptive grid, refined until the duration's estimated error is
    within ``duration_tolerance`` (relative; planning/grid.py); a number: a fixed grid of that many uniform
    points (segment connections, spline knots and grading towards the ends are added).
    limits: the limits' choices (planning/limits/), as LimitChoices, {limit name: LimitChoice} or the keys of
    a scenario's ``[limits]`` table, e.g. ``{"use_torque": False, "velocity_scale": 0.5, "jerk": [...],
    "use_jerk": True}``; stored as LimitChoices (every limit, defaults filled in): ``settings.limits["torque"]
    .scale``.
    start, end: "zero", "max" (boundary-level velocity) or theta_dot [unit theta / s]; None = "zero".
    periodic: steady-state cycle on a closed path (start/end must then be None).
    connections: "chain" | "zero" | "max" (see segments.py).
    limit_tolerance: allowed relative excess on the verification resample.
    verify: "certified" (default: a certified bound of every limit on every grid interval,
    planning/certify.py), "dense" (the 0.1 ms time resample) or "off"; True/False mean
    "certified"/"off". The verify-and-tighten loop lowers the limits locally where the bound exceeds
    1 + limit_tolerance and re-solves. baselines: compute the baselines (off by default).
    Strings are turned into their enums and everything is checked on construction (ScenarioError).
    """

    grid_points: int | None = None
    duration_tolerance: float = defaults.PLAN_TOLERANCE
    limits: LimitChoices = field(default_factory=LimitChoices)
    start: Union[BoundaryMode, float, None] = None
    end: Union[BoundaryMode, float, None] = None
    periodic: bool = False
    connections: Connections = Connections.CHAIN
    limit_tolerance: float = defaults.LIMIT_TOLERANCE
    verify: VerifyMode = VerifyMode.CERTIFIED
    verify_sample_time: float = defaults.VERIFY_SAMPLE_TIME
    max_tighten_iterations: int = defaults.PLAN_MAX_TIGHTEN_ITERATIONS
    baselines: bool = False
    fitted_margin: float = defaults.FITTED_PROFILE_MARGIN

    def __post_init__(self):
        """Normalize the given forms (limits, mode strings) to their types, then check every field."""
        set_ = partial(object.__setattr__, self)  # a frozen dataclass normalizes its own fields here only
        set_("limits", LimitChoices.of(self.limits))
        for name in ("start", "end"):
            v = getattr(self, name)
            if isinstance(v, str):
                set_(name, parse_mode(BoundaryMode, v, f"planner {name} ('zero', 'max' or a theta_dot >= 0)"))
            elif v is not None and (isinstance(v, bool) or not np.isfinite(v) or v < 0):
                raise ScenarioError(f"planner {name} must be 'zero', 'max' or a theta_dot >= 0, got {v!r}")
        set_("connections", parse_mode(Connections, self.connections, "connections"))
        verify = self.verify
        if isinstance(verify, (bool, np.bool_)):
            verify = VerifyMode.CERTIFIED if verify else VerifyMode.OFF
        set_("verify", parse_mode(VerifyMode, verify, "plan.verify"))
        self._check()

    def _check(self):
        if self.grid_points is not None and (isinstance(self.grid_points, bool) or
                                             int(self.grid_points) != self.grid_points or self.grid_points < 3):
            raise ScenarioError(f"planner grid_points must be an integer >= 3 (or None: adaptive grid), "
                                f"got {self.grid_points}")
        tol = self.duration_tolerance
        if isinstance(tol, bool) or not (0 < tol < defaults.MAX_PLAN_TOLERANCE):
            raise ScenarioError(f"plan.duration_tolerance (relative error of the duration on the adaptive grid) must "
                                f"be in (0, {defaults.MAX_PLAN_TOLERANCE}), got {tol!r}")
        if self.periodic and (self.start is not None or self.end is not None):
            raise ScenarioError("periodic planning fixes both ends (equal theta_dot); leave start and end unset")
        if not self.limit_tolerance >= 0:
            raise ScenarioError(f"limit_tolerance must be >= 0, got {self.limit_tolerance}")
        if not (0 <= self.fitted_margin < 1):
            raise ScenarioError(f"fitted_margin must be in [0, 1), got {self.fitted_margin}")

    def choice(self, cls) -> LimitChoice:
        """The choice for the limit class ``cls``."""
        return self.limits[cls.name]

    @property
    def start_condition(self) -> Boundary:
        return BoundaryMode.ZERO if self.start is None else self.start

    @property
    def end_condition(self) -> Boundary:
        return BoundaryMode.ZERO if self.end is None else self.end


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
    solve time [s] (everything but the baselines), grid size and tighten iterations used;
    duration_error_estimate [s]: the estimate of the duration's discretization error, from the adaptive
    grid, or with third-order limits from the nested coarse grid (planning/third_order.py) plus the
    tightening's change; None on a fixed grid without third-order limits. ``path_points``: the final solve's path
    data (right side, left side) on ``curves.grid``, for the limit curves of the phase plane (None when not kept).
    ``scale_along``: the caller's local tightening it was planned with (see :func:`plan`; the Retimer keeps it)."""

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
    duration_error_estimate: float | None = None
    path_points: tuple[PathPoints, PathPoints] | None = field(default=None, repr=False)
    scale_along: object = field(default=None, repr=False)

    @property
    def duration(self) -> float:
        return self.profile.duration


def effective_limits(robot: Robot, settings: PlanSettings) -> EffectiveLimits:
    """The limits ``plan`` enforces for ``robot`` under ``settings`` (robot limits times the scales)."""
    return effective_limits_for(robot, settings.limits)


def _closure_is_kink(s: Sampled) -> bool:
    a, b = s.right.dq[0], s.left.dq[-1]
    return bool(np.linalg.norm(a - b) > CLOSURE_KINK_TOLERANCE * (1.0 + np.linalg.norm(a)))


@dataclass(frozen=True, eq=False)
class _Solved:
    """One solve: the grid, its path data, the chain arguments, rows (problem, right, left) and solution;
    error_estimate [s]: a third-order solve's estimate of the duration's discretization error (or None)."""

    grid: Grid
    samp: Sampled
    chain_args: dict
    problem: IntervalProblem
    right: LimitRows
    left: LimitRows
    sol: object
    error_estimate: float | None = None


def _not_closed_message(path: JointPath) -> str:
    """Why a periodic plan of ``path`` is refused: its joint positions at the two ends (a closed task loop can
    still end on the other wrist branch, q4 + pi, -q5, q6 + pi: the same pose, another joint position)."""
    lo, hi = path.domain
    ends = np.asarray(path(np.array([lo, hi])))
    gap = np.abs(ends[1] - ends[0])
    j = int(np.argmax(gap))
    name = path.joint_names[j] if path.joint_names else f"joint {j + 1}"
    return (f"periodic planning needs a joint path that ends where it starts; {name} differs by "
            f"{gap[j]:.4g} rad between theta = {lo:.6g} and {hi:.6g} (an open path, or a loop whose wrist branch "
            "changes as it crosses q5 = 0); set plan.periodic = false, or change the path or tool orientation")


def plan(path: JointPath, robot: Robot, settings: PlanSettings = PlanSettings(),
         scale_along=None) -> PlanResult:
    """Time-optimal motion along ``path`` for ``robot`` under ``settings`` (see PlanSettings); ``scale_along``: a
    caller's local tightening, theta (K,) -> {limit name: factor (K,) in (0, 1]} multiplying that limit at
    each grid point (a limit not named: 1), or None."""
    t0 = time.perf_counter()
    if path.n != robot.n:
        raise ScenarioError(f"path has {path.n} joints, robot {robot.name} has {robot.n}")
    if settings.periodic and not path.closed:
        raise ScenarioError(_not_closed_message(path))
    _check_dwells(path, settings)
    limits = effective_limits(robot, settings)
    if limits.third_order and settings.connections == Connections.MAX:  # refused before any solve
        raise ScenarioError("jerk and torque-rate limits need a continuous profile: connections = 'max' makes "
                            "theta_dot jump at segment connections; use 'chain' or 'zero'")
    # third-order limits: one SLP on a fixed grid (its smooth interpolation needs no adaptive refinement)
    adaptive = settings.grid_points is None and not limits.third_order
    estimate = None
    if adaptive:
        last = []  # the latest solve: its path data seeds the next grid's

        def solve(g: Grid):
            donor = last.pop().samp.right if last else None  # the earlier solve's rows are freed before these
            out = _solve_on(path, robot, settings, limits, g, donor=donor, scale_along=scale_along)
            last[:] = [out[2]]
            return out

        refined = refine(solve, make_grid(path, defaults.GRID_INITIAL_POINTS), settings.duration_tolerance,
                         max_points=_largest_grid(robot.n))
        estimate, held = refined.error_estimate, [refined.solved]
        del refined
        last.clear()  # only ``held`` refers to the solve: _solve_verified frees it when it solves a finer grid
    else:
        points = settings.grid_points or defaults.THIRD_ORDER_GRID_POINTS
        solved = _solve_on(path, robot, settings, limits, make_grid(path, points), scale_along=scale_along)[2]
        first, estimate = solved.sol.profile.duration, solved.error_estimate
        held = [solved]
    solved, traj, ratios, iterations = _solve_verified(path, robot, settings, limits, held.pop(), adaptive,
                                                       scale_along)
    if not adaptive and estimate is not None:  # the tightening's change is part of the discretization error
        estimate += abs(solved.sol.profile.duration - first)
    sol, grid = solved.sol, solved.grid.theta
    log.info("grid: %d points (%d breaks, %d kinks%s); limits: %s", len(grid), len(solved.grid.breaks),
             len(solved.grid.kinks), "" if estimate is None else f", estimated duration error {estimate:.3g} s",
             ", ".join(lim.name for lim in limits) or "none")
    solve_time = time.perf_counter() - t0
    curves = LimitCurves(grid, np.minimum(maximum_velocity_curve(solved.right), maximum_velocity_curve(solved.left)),
                         sol.controllable_hi)
    log.info("planned: %.6g s in %.3g s (%d tightening iterations)", sol.profile.duration, solve_time, iterations)
    base = None
    if settings.baselines:
        log.info("baselines: fitted and constant TCP speed")
        base = compute_baselines(solved.problem, sol, solved.chain_args, tcp_gain(solved.samp.right),
                                 tcp_gain(solved.samp.left), _baseline_check(path, robot, settings, limits, solved),
                                 settings)
        log.debug("baselines: fitted %.6g s, constant speed %s", base.fitted.duration,
                  f"{base.constant_speed.duration:.6g} s" if base.constant_speed else base.constant_speed_error)
    profile = sol.profile
    if path.dwells:  # the waits at rest (dwells) join the motion's timing
        profile = profile.with_holds(path.dwells)
        traj = replace(traj, profile=profile)
        log.info("dwells: %s s at rest, cycle %.6g s", " + ".join(f"{w:g}" for _, w in path.dwells), profile.duration)
    return PlanResult(profile, traj, sol.segment_profiles, curves, ratios, base, solve_time, len(grid),
                      iterations, sol.jump_intervals, settings, estimate, (solved.samp.right, solved.samp.left),
                      scale_along)


def _check_dwells(path: JointPath, settings: PlanSettings) -> None:
    """A dwell at the path's start or end needs the motion at rest there (plan.start / plan.end)."""
    for theta, _ in path.dwells:
        for end, key, condition in ((path.domain[0], "start", settings.start_condition),
                                    (path.domain[1], "end", settings.end_condition)):
            if theta == end and not at_rest(condition):
                raise ScenarioError(f"a dwell at the path's {key} (theta = {theta:.6g} m) waits at rest, but "
                                    f"plan.{key} = {condition!r} moves through it; set plan.{key} = 'zero' or "
                                    "remove the dwell")


def _solve_on(path, robot, settings, limits, grid: Grid, samp: Sampled | None = None, scale: dict | None = None,
              x_ref: np.ndarray | None = None, donor: PathPoints | None = None,
              scale_along=None) -> tuple[float, np.ndarray, "_Solved"]:
    """Solve on ``grid`` (path data sampled unless ``samp`` is given, reusing ``donor``'s at shared points;
    limit scales ``scale``, else ``scale_along``'s (see :func:`plan`), else 1): (duration [s], x on the grid
    (K,), the solve)."""
    theta = grid.theta
    _check_grid_memory(len(theta), robot.n, settings, len(grid.breaks) + 1)
    if samp is None:
        sides = with_knots(path, theta, grid.breaks) if limits.third_order else grid.breaks
        samp = sample_grid(path, robot, theta, sides, donor, third=limits.third_order)
        for lim in limits:
            lim.check(samp.right, robot.joint_names)
    stops = set(grid.kinks)
    if settings.periodic and _closure_is_kink(samp):
        stops |= {0, len(theta) - 1}
    chain_args = dict(start=settings.start_condition, end=settings.end_condition, periodic=settings.periodic,
                      connections=settings.connections, breaks=grid.breaks, stops=tuple(sorted(stops)))
    if scale is None:
        scale = start_scale(limits, theta, robot.n, scale_along)
    problem, right, left, sol, estimate = _solve_rows(theta, samp, limits, scale, x_ref, chain_args)
    if isinstance(samp.right, ReusingPoints):  # the rows are built: the earlier grid's path data may go
        samp.right.detach()
    _check_bounded(theta, sol.x)
    log.debug("solve on %d grid points: duration %.9g s", len(theta), sol.profile.duration)
    return sol.profile.duration, sol.x, _Solved(grid, samp, chain_args, problem, right, left, sol, estimate)


def _largest_grid(joints: int) -> int:
    """The most points the adaptive grid may reach: defaults.GRID_MAX_POINTS, or fewer where the memory this
    run may use (io/memory.py) holds fewer at PLAN_BYTES_PER_POINT_JOINT."""
    from ..io.memory import largest_count

    fits = largest_count(defaults.PLAN_BYTES_PER_POINT_JOINT * joints, defaults.PLAN_MEMORY_BASE)
    return defaults.GRID_MAX_POINTS if fits is None else min(defaults.GRID_MAX_POINTS, fits)


def _check_grid_memory(points: int, joints: int, settings, segments: int) -> None:
    """ScenarioError before a grid of ``points`` is sampled when its memory estimate (PLAN_MEMORY_BASE +
    PLAN_BYTES_PER_POINT_JOINT per point and joint) exceeds what the run may use; the message gives the largest
    grid (fixed) or path (adaptive) that fits."""
    from ..io.memory import check_memory

    each = defaults.PLAN_BYTES_PER_POINT_JOINT * joints
    if settings.grid_points is not None:
        check_memory(points, each, f"plan.grid_points = {settings.grid_points:,} (a grid of {points:,} points)",
                     lambda largest: f"give plan.grid_points <= {largest:,}", defaults.PLAN_MEMORY_BASE)
        return
    per_segment = points / max(segments, 1)
    check_memory(points, each, f"the adaptive planner grid of {points:,} points for {segments:,} segments",
                 lambda largest: f"the largest grid that fits has {largest:,} points: plan the path in parts of at "
                                 f"most {int(largest / per_segment):,} segments, or raise plan.duration_tolerance",
                 defaults.PLAN_MEMORY_BASE)


def start_scale(limits, theta: np.ndarray, n: int, scale_along) -> dict:
    """{name: (K, m)} limit scales at the grid ``theta`` (K,): 1, times ``scale_along``'s factors (see :func:`plan`)."""
    scale = limits.unit_scale(len(theta), n)
    if scale_along is not None:
        for name, factor in scale_along(theta).items():
            if name in scale:
                scale[name] = scale[name] * np.asarray(factor, float)[:, None]
    return scale


def _solve_verified(path, robot, settings, limits, s: _Solved, adaptive: bool, scale_along=None):
    """Bound every limit on every grid interval of the solve ``s`` (certified or dense, settings.verify);
    where a bound exceeds 1 + limit_tolerance, halve those intervals and their neighbours and re-solve (adaptive grid, at most
    PLAN_MAX_REFINE_ROUNDS: refinement keeps the duration at the optimum), then tighten the limits
    locally there and re-solve (bounded by settings.max_tighten_iterations).
    Returns the final solve, its trajectory, ratios and the tighten iterations."""
    tol = settings.limit_tolerance
    ratios, scale = None, None
    iterations = rounds = 0
    while True:
        log.info("solve pass %d: %d grid points, duration %.6g s", iterations + rounds + 1, len(s.grid.theta),
                 s.sol.profile.duration)
        traj = Trajectory(path, s.sol.profile, robot)
        if settings.verify == VerifyMode.OFF:
            break
        theta = s.grid.theta
        jumps = tuple(theta[k] for k in s.grid.kinks if s.sol.x[k] > 0)
        bounds, ratios = _interval_bounds(settings, traj, limits, s.samp, s.sol, jumps, robot, theta, s.grid.breaks)
        worst = max((float(b.max()) for b in bounds.values() if b.size), default=0.0)
        log.info("verify pass %d (%s): worst limit ratio %.4f (%s)", iterations + rounds + 1, settings.verify.value,
                 worst, ratios.worst)
        if worst <= 1.0 + tol:
            break
        if adaptive and scale is None and rounds < defaults.PLAN_MAX_REFINE_ROUNDS:
            over = np.zeros(len(theta) - 1, bool)
            for b in bounds.values():
                if b.size:
                    over |= (b > 1.0 + defaults.TIGHTEN_TRIGGER * tol).any(axis=1)
            log.info("refining the %d grid intervals where a limit is exceeded (and %d on each side), then solving "
                     "again", int(over.sum()), defaults.PLAN_REFINE_NEIGHBOURS)
            grid, donor = s.grid.halved(_widened(over, defaults.PLAN_REFINE_NEIGHBOURS)), s.samp.right
            s = None  # its rows are freed before the finer grid's are built
            s = _solve_on(path, robot, settings, limits, grid, donor=donor, scale_along=scale_along)[2]
            rounds += 1
            continue
        if iterations >= settings.max_tighten_iterations:
            raise InfeasibleError(
                f"the planned motion still exceeds a limit by {100 * (worst - 1):.3g} % between grid points after "
                f"{iterations} tightening iterations ({ratios.worst}); raise grid_points or limit_tolerance"
            )
        scale = tightened(start_scale(limits, theta, robot.n, scale_along) if scale is None else scale, bounds, tol)
        log.info("tightening the limits locally where they are exceeded, then solving again")
        s = _solve_on(path, robot, settings, limits, s.grid, s.samp, scale, s.sol.x)[2]
        iterations += 1
    return s, traj, ratios, iterations


def _widened(mask: np.ndarray, n: int) -> np.ndarray:
    """``mask`` (K - 1,) with the ``n`` entries on each side of every true entry set too."""
    out = mask.copy()
    for k in range(1, n + 1):
        out[k:] |= mask[:-k]
        out[:-k] |= mask[k:]
    return out


def _interval_bounds(settings, traj, limits, samp, sol, jumps, robot, grid, breaks) -> tuple[dict, LimitRatios]:
    """{name: (K - 1, m) bound of the ratio on each interval of the planner's ``grid``, outside the
    profile's jump intervals} and the summary ratios (everywhere), by the certified interval bound or
    the dense resample."""
    if settings.verify == VerifyMode.DENSE:
        dt = settings.verify_sample_time
        samples, r = sample_ratios(traj, limits, dt, sol.jump_intervals)
        ratios = summarize(samples, r, limits, dt, jumps, robot.joint_names)
        theta = samples.theta
    else:
        ctx = _certify_context(traj.path, robot, sol.profile, limits, grid, samp, breaks)
        r = certify(ctx, limits, accept=1.0 + settings.limit_tolerance)
        ratios = summarize_intervals(sol.profile, r, limits, jumps, robot.joint_names)
        pgrid = sol.profile.grid
        if not sol.jump_intervals and len(pgrid) == len(grid) and np.array_equal(pgrid, grid):
            return r, ratios  # the bounds are already per interval of the planner's grid
        theta = 0.5 * (pgrid[:-1] + pgrid[1:])
    free = outside(theta, sol.jump_intervals)
    return interval_maxima(theta[free], {name: v[free] for name, v in r.items()}, grid), ratios


def _baseline_check(path, robot, settings, limits, s: _Solved):
    """How the baselines are verified (baselines.compute_baselines' ``check``): like the plan, by the certified bound
    on every interval with the solve's path data (``verify = "certified"``), else on the dense resample; also with
    jerk or torque-rate limits, which the certification bounds on smooth profiles only (a baseline's theta_ddot
    is constant per interval)."""
    if settings.verify != VerifyMode.CERTIFIED or limits.third_order:
        return dense_check(path, robot, limits, settings)

    def check(profile: Profile, jumps) -> tuple[float, LimitRatios]:
        ctx = _certify_context(path, robot, profile, limits, s.grid.theta, s.samp, s.grid.breaks)
        bounds = certify(ctx, limits)
        pgrid = profile.grid
        free = outside(0.5 * (pgrid[:-1] + pgrid[1:]), jumps)
        worst = max((float(b[free].max()) for b in bounds.values() if b.size and free.any()), default=0.0)
        return worst, summarize_intervals(profile, bounds, limits, (), robot.joint_names)
    return check


def _certify_context(path, robot, profile, limits, grid, samp, breaks) -> CertifyContext:
    """The certification's view of ``profile``: the planner's grid data, or, when the profile has its own
    grid ("max" connections insert the intervals that carry the jumps), fresh path data on it."""
    pgrid = profile.grid
    if len(pgrid) == len(grid) and np.array_equal(pgrid, grid):
        return CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque)
    pbreaks = grid_breaks(path, pgrid)
    right = PathPoints(robot, path, pgrid, *path.evaluate(pgrid, "right"))
    left = PathPoints(robot, path, pgrid, *path.evaluate(pgrid, "left"), side="left")
    return CertifyContext(path, robot, profile, right, left, pbreaks, limits.needs_torque)


def certified_bounds(path: JointPath, robot: Robot, profile: Profile, settings: PlanSettings) -> dict:
    """{name: (K - 1, m)} certified upper bound of every active limit's ratio on every interval of
    ``profile``'s grid (planning/certify.py), with the path data evaluated afresh on that grid."""
    limits = effective_limits(robot, settings)
    pgrid = profile.grid
    breaks = grid_breaks(path, pgrid)
    samp = sample_grid(path, robot, pgrid, with_knots(path, pgrid, breaks) if profile.smooth else breaks,
                   third=profile.smooth)
    return certify(CertifyContext(path, robot, profile, samp.right, samp.left, breaks, limits.needs_torque), limits)


def _solve_rows(grid, samp, limits, scale, x_ref, chain_args):
    """Build the rows and solve. With rows linearized around x_ref (``relinearize`` limits: inner
    bounds, exact at x_ref) re-solve with x_ref = the previous x until the duration changes by less
    than RELINEARIZE_TOLERANCE: the previous x stays feasible, so the duration never increases."""
    problem, right, left = grid_rows(grid, samp, limits, scale, None if limits.third_order else x_ref)
    sol = solve_chain(problem, **chain_args)
    # a third-order re-solve (x_ref given) starts from x_ref, not from this second-order solution
    relinearize = limits.relinearize and not limits.third_order
    for _ in range(defaults.RELINEARIZE_ITERATIONS if relinearize else 0):
        previous = sol.profile.duration
        problem, right, left = grid_rows(grid, samp, limits, scale, sol.x)
        sol = solve_chain(problem, **chain_args)
        log.debug("relinearized rows: duration %.9g s (was %.9g s)", sol.profile.duration, previous)
        if abs(previous - sol.profile.duration) <= defaults.RELINEARIZE_TOLERANCE * previous:
            break
    estimate = None
    if limits.third_order:
        sol, estimate = _smooth(grid, samp, limits, scale, sol, chain_args, x_ref)
    return problem, right, left, sol, estimate


def _smooth(grid, samp, limits, scale, sol, chain_args, x_ref):
    """The third-order (jerk, torque-rate) solution, linearized first around ``x_ref`` (the previous
    smooth solution, when re-solving after tightening) or the second-order optimum ``sol.x``, and the
    estimate of its duration's discretization error [s] (None when re-solving)."""
    k = len(grid)
    rest = np.zeros(k, dtype=bool)
    rest[list(chain_args["stops"])] = True
    if chain_args["connections"] == Connections.ZERO:
        rest[list(chain_args["breaks"])] = True
    fixed = {}
    if not chain_args["periodic"]:
        for idx, cond in ((0, chain_args["start"]), (k - 1, chain_args["end"])):
            if at_rest(cond):
                rest[idx] = True
            elif not isinstance(cond, str):
                fixed[idx] = float(cond) ** 2
    resolve = x_ref is not None and len(x_ref) == k
    profile, _, estimate = solve_third_order(grid, samp, limits, scale, x_ref if resolve else sol.x, rest, fixed,
                                             chain_args["periodic"], smooth_start=resolve)
    return replace(sol, profile=profile, segment_profiles=(profile,), x=profile.x), estimate


def _check_bounded(grid: np.ndarray, x: np.ndarray) -> None:
    """InfeasibleError where the profile reaches the cap on x: no active limit bounds the speed there."""
    capped = np.nonzero(x >= X_CAP_FRACTION * defaults.PLANNER_X_CAP)[0]
    if capped.size:
        raise InfeasibleError(
            f"no active limit bounds the path speed at theta = {grid[capped[0]]:.6g} (theta_dot would reach the "
            f"cap {np.sqrt(defaults.PLANNER_X_CAP):.3g}): the time-optimal motion is unbounded; switch on a "
            "velocity, acceleration or torque limit (limits.use_*) or give a tcp_speed limit")


def tightened(scale: dict, bounds: dict, tol: float) -> dict:
    """Scale each limit down at both ends of every interval whose bound exceeds 1 + defaults.TIGHTEN_TRIGGER tol:
    scale {name: (K, m)}, bounds {name: (K - 1, m)} per grid interval."""
    new = {}
    for name, cur in scale.items():
        worst = bounds[name]
        factor = np.where(worst > 1.0 + defaults.TIGHTEN_TRIGGER * tol,
                          (1.0 - TIGHTEN_TARGET * tol) / np.maximum(worst, 1.0), 1.0)
        new[name] = cur * at_points(factor)
    return new


def at_points(per_interval: np.ndarray) -> np.ndarray:
    """Factors (K, ...) at the grid points from factors (K - 1, ...) on the intervals: at each point the least of
    the intervals on either side of it (and 1 where it is larger)."""
    point = np.ones((per_interval.shape[0] + 1,) + per_interval.shape[1:])
    point[:-1] = np.minimum(point[:-1], per_interval)
    point[1:] = np.minimum(point[1:], per_interval)
    return point
