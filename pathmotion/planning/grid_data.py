"""Path data and limit rows on a planner grid: Phi, Phi', Phi'' (and Phi''') at every grid point, from the
interval after it (right) and, at the path's breaks, from the interval before it (left); the grid's breaks and
spline knots; the rows of every limit on both sides and the interval problem they make (planning/topp.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..lift.joint_path import JointPath
from ..robot import Robot
from .limit_rows import LimitRows, limit_rows
from .limits import EffectiveLimits, PathPoints
from .topp import IntervalProblem, interval_problem


@dataclass(frozen=True, eq=False)
class Sampled:
    """Path data on the grid, as seen from the interval after (right) and before (left) each point."""

    right: PathPoints
    left: PathPoints


class ReusingPoints(PathPoints):
    """PathPoints whose derived quantities (reduced dynamics, TCP gain...) are copied from ``donor``
    (right-side points of an earlier grid) where a grid point is also one of the donor's, and
    computed only at the new points: the adaptive grid's refinements keep their parents' points."""

    def __init__(self, robot, path, theta, q, dq, ddq, donor: PathPoints):
        super().__init__(robot, path, theta, q, dq, ddq)
        pos = np.clip(np.searchsorted(donor.theta, theta), 0, len(donor.theta) - 1)
        self._shared = donor.theta[pos] == theta
        self._donor, self._donor_index = donor, pos[self._shared]

    def detach(self) -> None:
        """Forget the donor (its data are copied where used): an earlier grid's path data are freed with it;
        a quantity asked for later is computed at every point."""
        self._donor = None

    def cached(self, key, compute, third=False):
        if key not in self._cache and self._donor is not None and key in self._donor._cache:
            new = np.nonzero(~self._shared)[0]
            data = (self.q, self.dq, self.ddq) + ((self.dddq,) if third else ())
            fresh = compute(self.robot, *(d[new] for d in data)) if new.size else None
            value = []
            for j, old in enumerate(self._donor._cache[key]):
                v = np.empty((len(self.theta),) + old.shape[1:], old.dtype)
                v[self._shared] = old[self._donor_index]
                if fresh is not None:
                    v[new] = fresh[j]
                value.append(v)
            self._cache[key] = tuple(value)
        return super().cached(key, compute, third)


def sample_grid(path: JointPath, robot: Robot, grid: np.ndarray, breaks: tuple[int, ...],
            donor: PathPoints | None = None, third: bool = False) -> Sampled:
    """Path data on ``grid``, from both sides of ``breaks``; ``third``: Phi''' too, from the same
    evaluation (third-order limits need it; path.evaluate3 repeats path.evaluate's work). Where a point of
    ``grid`` is one of ``donor``'s (an earlier grid's right-side data), its Phi, Phi', Phi'' are copied."""
    idx = np.array(list(breaks) + [len(grid) - 1], dtype=int)
    if third:
        data = path.evaluate3(grid, "right")
    elif donor is None:  # both sides in one pass
        data, (_, dql, ddql) = path.evaluate_sides(grid, idx)
    else:
        data = _evaluate_reusing(path, grid, donor)
    if third or donor is not None:
        _, dql, ddql = path.evaluate(grid[idx], "left")
    q, dq, ddq = data[:3]
    dq_l, ddq_l = dq.copy(), ddq.copy()
    dq_l[idx], ddq_l[idx] = dql, ddql
    right = PathPoints(robot, path, grid, q, dq, ddq) if donor is None else \
        ReusingPoints(robot, path, grid, q, dq, ddq, donor)
    if third:
        right._cache["dddq"] = np.atleast_2d(data[3])
    return Sampled(right, PathPoints(robot, path, grid, q, dq_l, ddq_l, base=right, changed=idx, side="left"))


def _evaluate_reusing(path: JointPath, grid: np.ndarray, donor: PathPoints) -> tuple[np.ndarray, ...]:
    """path.evaluate(grid, "right") (Phi, Phi', Phi'' (K, n)), copied from ``donor`` at its points and evaluated at
    the new ones only: the lift is point by point, and the refinements' grids contain their parents'."""
    pos = np.clip(np.searchsorted(donor.theta, grid), 0, len(donor.theta) - 1)
    shared = donor.theta[pos] == grid
    out = tuple(np.empty((len(grid),) + d.shape[1:]) for d in (donor.q, donor.dq, donor.ddq))
    for o, d in zip(out, (donor.q, donor.dq, donor.ddq)):
        o[shared] = d[pos[shared]]
    if not shared.all():
        for o, fresh in zip(out, path.evaluate(grid[~shared], "right")):
            o[~shared] = fresh
    return out


def grid_rows(grid, s: Sampled, limits: EffectiveLimits, scale: dict,
              x_ref: np.ndarray | None) -> tuple[IntervalProblem, LimitRows, LimitRows]:
    """The rows of every limit on ``grid`` (K,) from the path data ``s`` at the limit scales ``scale`` {name: (K, m)}
    (linearized around x_ref (K,) where a limit needs it): (the interval problem, right rows, left rows)."""
    right = limit_rows(s.right, limits, scale, defaults.PLANNER_X_CAP, x_ref)
    left = _left_rows(right, s.right, s.left, limits, scale, x_ref)
    problem = interval_problem(grid, right.slice(slice(0, -1)), left.slice(slice(1, None)), right.x_max, left.x_max)
    return problem, right, left


def _left_rows(right: LimitRows, right_points: PathPoints, left: PathPoints, limits: EffectiveLimits, scale: dict,
               x_ref: np.ndarray | None) -> LimitRows:
    """limit_rows of the left side: the rows are point by point, and the left side's path data equal the right
    side's (``right_points``, whose rows are ``right``) except at the breaks, so only those are assembled afresh."""
    idx = left.changed_from(right_points)
    if idx is None:
        return limit_rows(left, limits, scale, defaults.PLANNER_X_CAP, x_ref)
    points = PathPoints(left.robot, left.path, left.theta[idx], left.q[idx], left.dq[idx], left.ddq[idx],
                        side="left")
    part = limit_rows(points, limits, {name: v[idx] for name, v in scale.items()}, defaults.PLANNER_X_CAP,
                      None if x_ref is None else x_ref[idx])
    arrays = []
    for whole, changed in zip((right.a, right.b, right.c, right.lo, right.hi, right.x_max),
                              (part.a, part.b, part.c, part.lo, part.hi, part.x_max)):
        whole = whole.copy()
        whole[idx] = changed
        arrays.append(whole)
    return LimitRows(*arrays, right.row_kind, right.row_column)


def with_knots(path: JointPath, theta: np.ndarray, breaks: tuple[int, ...]) -> tuple[int, ...]:
    """``breaks`` and the indices of the path's spline knots on ``theta``: Phi''' jumps there, so
    third-order rows and a smooth profile's certification need the path data from both sides."""
    knots = np.searchsorted(theta, [k for k in getattr(path, "knots", ()) if theta[0] < k < theta[-1]])
    return tuple(sorted(set(breaks) | {int(i) for i in knots}))


def grid_breaks(path: JointPath, pgrid: np.ndarray) -> tuple[int, ...]:
    """Indices in ``pgrid`` of the path's interior breaks (segment joins, spline knots)."""
    special = [float(b) for b in path.breaks if pgrid[0] < b < pgrid[-1]]
    return tuple(int(i) for i in np.searchsorted(pgrid, special))
