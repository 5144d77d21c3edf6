"""Boundary conditions of one planning run: "zero", "max" or a given theta_dot at each end, and the
periodic steady-state cycle (theta_dot equal at both ends of a closed path, the largest such).

"max" is the boundary-level velocity of the thesis: the largest x in the controllable set at the
start, the largest x in the reachable set at the end. Every failure is an InfeasibleError that
gives theta and, for an impossible boundary velocity, the feasible range.
"""

from __future__ import annotations

from typing import Union

import numpy as np

from .. import defaults
from ..errors import InfeasibleError
from ..modes import BoundaryMode
from .topp import IntervalProblem, SetSequence, controllable_sets, greedy_profile, reachable_sets

#: BoundaryMode.ZERO, BoundaryMode.MAX or a path velocity theta_dot >= 0 [unit theta / s].
Boundary = Union[BoundaryMode, float]

def at_rest(condition: Boundary) -> bool:
    """Whether a boundary ``condition`` holds the motion at rest there: "zero", or a given theta_dot of 0."""
    return condition == BoundaryMode.ZERO or (not isinstance(condition, str) and float(condition) == 0.0)


#: x at or above this fraction of defaults.PLANNER_X_CAP counts as unbounded [-].
X_CAP_FRACTION = 0.999
#: Relative slack (times 1 + x) when checking that a start x lies in a controllable set [-].
SET_MEMBERSHIP_TOLERANCE = 1e-9
#: At most this many passes each way when bounding the fastest cycle by its laps (solve_periodic); each
#: usually settles after two or three [-].
PERIODIC_LAPS = 6
#: Floor of the bisection's scale for the periodic search's relative tolerance [(unit theta / s)^2].
SEARCH_FLOOR = 1e-12


def _range_text(lo: float, hi: float) -> str:
    return f"[{np.sqrt(max(lo, 0.0)):.6g}, {np.sqrt(max(hi, 0.0)):.6g}]"


def _given(problem: IntervalProblem, value: float, index: int, which: str) -> tuple[float, float]:
    """x = value^2 for a given boundary theta_dot. A value whose square reaches the planner's cap on x
    (or overflows) is refused here with the pointwise feasible range; smaller infeasible values are
    reported by the set computations with the range reachable from the other end."""
    v = abs(float(value))
    if not v * v < defaults.PLANNER_X_CAP:
        cap = float(problem.x_max[index])
        raise InfeasibleError(f"{which} velocity theta_dot = {float(value):.6g} at theta = {problem.grid[index]:.6g} "
                              f"is infeasible: the feasible range is {_range_text(0.0, cap)} or narrower "
                              "(unit theta / s); give a smaller value, 'zero' or 'max'")
    return v * v, v * v


def _start_set(problem: IntervalProblem, start: Boundary) -> tuple[float, float]:
    if start == BoundaryMode.ZERO:
        return 0.0, 0.0
    if start == BoundaryMode.MAX:
        return 0.0, float(problem.x_max[0])
    return _given(problem, start, 0, "start")


def _end_set(problem: IntervalProblem, end: Boundary) -> tuple[float, float]:
    if end == BoundaryMode.ZERO:
        return 0.0, 0.0
    if end == BoundaryMode.MAX:
        return 0.0, float(problem.x_max[-1])
    return _given(problem, end, -1, "end")


def _not_traversable(problem: IntervalProblem, index: int, where: str) -> InfeasibleError:
    theta = problem.grid[index]
    return InfeasibleError(
        f"{where}the path cannot be traversed: no admissible path velocity at theta = {theta:.6g} "
        f"(maximum-velocity bound there x_max = {problem.x_max[index]:.6g}); relax the limits, "
        "lower the payload or change the path there"
    )


def _check_unbounded(x: float, which: str, theta: float, where: str) -> None:
    if x >= X_CAP_FRACTION * defaults.PLANNER_X_CAP:
        raise InfeasibleError(
            f"{where}the 'max' {which} velocity at theta = {theta:.6g} is unbounded: no active limit "
            "bounds theta_dot there (Phi' = 0 and no acceleration/torque limit); give a value instead"
        )


def solve_open(problem: IntervalProblem, start: Boundary, end: Boundary, where: str = "") -> tuple[np.ndarray, SetSequence]:
    """Time-optimal x (K,) with the given boundary conditions, and the controllable sets."""
    end_lo, end_hi = _end_set(problem, end)
    sets = controllable_sets(problem, end_lo, end_hi)
    if sets.failed_at >= 0:
        if not isinstance(end, BoundaryMode):
            reach = reachable_sets(problem, *_start_set(problem, start))
            if reach.failed_at < 0:
                raise InfeasibleError(
                    f"{where}end velocity theta_dot = {float(end):.6g} at theta = {problem.grid[-1]:.6g} is "
                    f"infeasible: from the given start the feasible range there is "
                    f"{_range_text(reach.lo[-1], reach.hi[-1])} (unit theta / s)"
                )
        raise _not_traversable(problem, max(sets.failed_at, 0), where)
    k_lo, k_hi = sets.lo[0], sets.hi[0]
    tol = SET_MEMBERSHIP_TOLERANCE * (1.0 + k_hi)
    if start == BoundaryMode.MAX:
        x0 = k_hi
        _check_unbounded(x0, "start", problem.grid[0], where)
    else:
        x0 = _start_set(problem, start)[0]
        if not (k_lo - tol <= x0 <= k_hi + tol):
            what = "rest" if start == BoundaryMode.ZERO else f"theta_dot = {float(start):.6g}"
            raise InfeasibleError(
                f"{where}start from {what} at theta = {problem.grid[0]:.6g} is infeasible: the feasible start "
                f"velocity range is {_range_text(k_lo, k_hi)} (unit theta / s)"
            )
        x0 = min(max(x0, k_lo), k_hi)
    x = greedy_profile(problem, sets, x0)
    if end == BoundaryMode.MAX:
        _check_unbounded(x[-1], "end", problem.grid[-1], where)
    return x, sets


def _lap_bound(problem: IntervalProblem, top: float) -> tuple[float, float]:
    """Upper bounds (B, F) of the fastest cycle's v from the laps: B the largest x_0 from which a lap can end at
    or below B, F the largest x_{K-1} a lap can reach from a start at or below F, each iterated from ``top`` (a
    bound of v at both ends) while it falls by more than PLANNER_SEARCH_TOLERANCE, at most PERIODIC_LAPS times.
    A cycle's v starts and ends a lap, so v <= B_n and v <= F_n at every step n."""
    b = f = top
    for _ in range(PERIODIC_LAPS):
        back, ahead = controllable_sets(problem, 0.0, b), reachable_sets(problem, 0.0, f)
        if back.failed_at >= 0 or ahead.failed_at >= 0:  # no bound from a failed sweep: keep the last ones
            break
        nb, nf = float(back.hi[0]), float(ahead.hi[-1])
        settled = (nb >= b * (1 - defaults.PLANNER_SEARCH_TOLERANCE)
                   and nf >= f * (1 - defaults.PLANNER_SEARCH_TOLERANCE))
        b, f = min(b, nb), min(f, nf)
        if settled:
            break
    return b, f


def solve_periodic(problem: IntervalProblem, where: str = "") -> tuple[np.ndarray, SetSequence]:
    """The fastest steady-state cycle: the largest v = x_0 = x_{K-1} for which the end set {v} is
    controllable from x_0 = v. The feasible v form an interval containing 0 (the feasible x sequences
    form a convex polytope and the arm can stop anywhere). Its top is at most min(B, F) of
    :func:`_lap_bound`; usually it is that bound (checked: {v} controllable from v), else a bisection below it
    finds it."""

    def sets_for(v: float) -> SetSequence | None:
        s = controllable_sets(problem, v, v)
        if s.failed_at >= 0:
            return None
        slack = SET_MEMBERSHIP_TOLERANCE * (1 + v)
        return s if s.lo[0] - slack <= v <= s.hi[0] + slack else None

    free = controllable_sets(problem, 0.0, float(problem.x_max[-1]))
    if free.failed_at >= 0:
        raise _not_traversable(problem, free.failed_at, where)
    lo, hi = 0.0, float(min(problem.x_max[0], problem.x_max[-1], free.hi[0]))
    best = sets_for(lo)
    if best is None:
        raise InfeasibleError(f"{where}no periodic cycle exists: the arm cannot even pass the closure point "
                              f"theta = {problem.grid[0]:.6g} from rest; relax the limits")
    top = sets_for(hi)
    if top is None:  # the laps' bound, usually the answer (PERIODIC_LAPS)
        hi = min(hi, *_lap_bound(problem, hi))
        top = sets_for(hi) if hi > lo else None
    if top is not None:
        lo, best = hi, top
    else:
        while hi - lo > defaults.PLANNER_SEARCH_TOLERANCE * max(hi, SEARCH_FLOOR):
            mid = 0.5 * (lo + hi)
            s = sets_for(mid)
            if s is None:
                hi = mid
            else:
                lo, best = mid, s
    x = greedy_profile(problem, best, min(max(lo, best.lo[0]), best.hi[0]))
    x[-1] = x[0]
    return x, best
