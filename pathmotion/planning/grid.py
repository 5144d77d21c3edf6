"""Planner grids: the graded initial grid and its adaptive refinement.

The discretized optimum converges to the continuous one at first order in the grid step (measured:
halving every interval divides the duration's change by 1.95-2.05, i.e. order 0.96-1.04, on random
splines, with and without torque limits; tests/test_planning_grid.py measures it again). The error is concentrated
where the profile switches between limit curves, at kinks of the limit curves and at the ends. First order is
inherent to the discretization, not to this code: theta_ddot is constant on an interval and meets every limit at both
of its ends (TOPP-RA's "interpolation" scheme; its O(step^2) is the limits' violation between the points, not the
duration's error), so wherever the optimal theta_ddot varies along a limit the interval's constant one meets the
tighter end, O(step) below the optimum. toppra's interpolation and collocation schemes measure order 0.8-1.1 on the
same paths (benchmarks/bench_duration_order.py).

Refinement (Richardson, interval by interval, on nested grids): solve on G0 and on G1 = G0 with every
interval halved. An interval split into n parts changes its time by e (1 - n^-p) (e its error before,
p = ``ORDER``), so the parts keep the error c / (n^p - 1), c = |time on the interval - time on its
parts|; an interval not split keeps its earlier estimate. The sum of these times ``ERROR_SAFETY`` is
the reported estimate. While it exceeds ``tolerance x T``, every interval of the latest grid is split
into n_i parts, n_i proportional to the square root of its error (the fewest parts that bring the
summed error to ``TARGET_FRACTION`` of the tolerance), and that grid is solved: one solve per
refinement (usually 3 in all), and each grid contains the previous one, so the path data and reduced
dynamics of the shared points are reused (planner.py).

A grid never exceeds ``max_points`` (after the first halving of the initial grid): when the parts the
tolerance asks for do not fit, the points that fit are given by the same rule (n_i proportional to the
square root of the error), that grid is solved and returned with its larger estimate and a warning.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .. import defaults
from ..lift.joint_path import JointPath

log = logging.getLogger(__name__)

#: Grid points nearer than this fraction of the grid step to a segment connection are dropped [-].
GRID_MERGE_FRACTION = 0.3
#: Grid points nearer than this fraction of the grid step to their predecessor are rounding twins
#: (grading points that land on a break) and are dropped [-].
GRID_MIN_GAP = 1e-9
#: Convergence order of the discretized duration in the grid step (measured, see the module docstring).
ORDER = 1
#: The summed per-interval estimate times this is reported: on the 36 cases of
#: benchmarks/bench_planner_vs_toppra.py the plain sum was 0.72-1.05 of the true error (the measured
#: halving ratio is 1.95-2.05, i.e. order 0.96-1.04, not exactly ORDER, and intervals left unsplit keep an older
#: estimate); the factor covers that [-].
ERROR_SAFETY = 1.5
#: The next grid aims at this fraction of the tolerance (its predicted estimate; the estimate measured on it
#: came out lower, 0.5-0.95 of the tolerance on the benchmark cases, so one redistribution usually suffices) [-].
TARGET_FRACTION = 1.0
#: At most this many parts per interval in one redistribution [-].
MAX_PIECES = 64
#: Bisection steps for the multiplier of the parts (pieces_for): 2^-24 of the continuous optimum [-].
PIECES_BISECTIONS = 24


@dataclass(frozen=True, eq=False)
class Grid:
    """Grid points theta (K,) and the indices of the segment connections (breaks) and kinks on it."""

    theta: np.ndarray
    breaks: tuple[int, ...]
    kinks: tuple[int, ...]

    def halved(self, mask: np.ndarray | None = None) -> "Grid":
        """This grid with the midpoint of every interval (where ``mask`` (K - 1,) is true) inserted."""
        n = np.full(len(self.theta) - 1, 2) if mask is None else np.where(np.asarray(mask, bool), 2, 1)
        return self.split(n)

    def split(self, pieces: np.ndarray) -> "Grid":
        """This grid with interval i split into ``pieces[i]`` (K - 1,) >= 1 equal parts."""
        t = self.theta
        pieces = np.asarray(pieces, int)
        start = np.repeat(t[:-1], pieces - 1)
        step = np.repeat(np.diff(t) / pieces, pieces - 1)
        # j = 1 .. pieces - 1 within each interval
        j = np.arange(start.size) - np.repeat(np.cumsum(pieces - 1) - (pieces - 1), pieces - 1) + 1
        theta = np.union1d(t, start + j * step)
        return Grid(theta, *_indices(theta, t[list(self.breaks)], t[list(self.kinks)]))


def _indices(theta: np.ndarray, breaks: np.ndarray, kinks: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
    return (tuple(int(i) for i in np.searchsorted(theta, breaks)),
            tuple(int(i) for i in np.searchsorted(theta, kinks)))


def make_grid(path: JointPath, points: int) -> Grid:
    """Uniform grid of ``points`` on the path's domain plus its breaks, spline knots and curvature peaks
    (``path.peaks``), and points graded by halving (GRID_GRADING_LEVELS) towards each end, connection and peak."""
    lo, hi = path.domain
    grid = np.linspace(lo, hi, int(points))
    # the uniform step, not grid[1] - grid[0] of the merged grid: a segment shorter than a step at the start
    # (a blend that uses all of its neighbour but a sliver) made that 1e-7 m and the grading collapsed onto the
    # breaks, leaving a 0.6 mm corner piece with no point inside (its curvature peak unseen: 0.55 s for 0.73 s)
    step = (hi - lo) / (points - 1)
    special = np.array(sorted({float(b) for b in (*path.breaks, *path.kinks) if lo < b < hi}))
    if special.size:
        near = np.min(np.abs(grid[:, None] - special[None, :]), axis=1) < GRID_MERGE_FRACTION * step
        grid = np.union1d(grid[~near | (grid == lo) | (grid == hi)], special)
    # spline knots (the third derivative jumps) are grid points too: no interval holds a kink of Phi''
    grid = np.union1d(grid, [float(k) for k in getattr(path, "knots", ()) if lo < k < hi])
    # curvature peaks inside segments (graded, not breaks): a near-cusp of a blend 0.07 mm wide at half height got no
    # point near it on 300 points, and the search's coarse plan took 0.75 s for a motion of 0.87 s
    peaks = np.array([float(p) for p in getattr(path, "peaks", ()) if lo < p < hi])
    grid = np.union1d(grid, peaks)
    grid = np.union1d(grid, _graded(np.array([lo, hi, *special, *peaks]), step))
    grid = _drop_near_duplicates(grid, np.array([lo, hi, *special, *peaks]), GRID_MIN_GAP * step)
    kinks = np.array([k for k in special if float(k) in {float(x) for x in path.kinks}])
    return Grid(grid, *_indices(grid, special, kinks))


def _graded(ends: np.ndarray, step: float) -> np.ndarray:
    """Points graded by halving (step / 2, step / 4, ..., GRID_GRADING_LEVELS) on both sides of each of
    ``ends`` (domain ends, breaks, peaks), each only as far as the next of ``ends`` on its side: beyond it
    the grid grades towards that one, so a path of many short segments gets GRID_GRADING_LEVELS points per
    side of a break at most, not one per level whatever the segment's length."""
    ends = np.unique(ends)
    grade = step * 0.5 ** np.arange(1, defaults.GRID_GRADING_LEVELS + 1)
    gap_after = np.append(np.diff(ends), 0.0)[:, None]  # 0 past the domain's end: nothing graded there
    gap_before = np.insert(np.diff(ends), 0, 0.0)[:, None]
    after = (ends[:, None] + grade[None, :])[grade[None, :] < gap_after]
    before = (ends[:, None] - grade[None, :])[grade[None, :] < gap_before]
    return np.concatenate([after, before])


def _drop_near_duplicates(grid: np.ndarray, keep: np.ndarray, gap: float) -> np.ndarray:
    """``grid`` without points closer than ``gap`` to their predecessor (rounding twins of a grading
    point), the ``keep`` points (ends, breaks) always kept."""
    close = np.concatenate([[False], np.diff(grid) < gap])
    if not close.any():
        return grid
    kept = np.isin(grid, keep)
    drop = close & ~kept
    twin = np.nonzero(close & kept)[0] - 1  # a kept point's too-close predecessor goes instead
    drop[twin[~kept[twin]]] = True
    return grid[~drop]


def interval_times(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Time on each interval (K - 1,) [s] of the profile x = theta_dot^2 (K,) with constant theta_ddot."""
    s = np.sqrt(np.maximum(x, 0.0))
    den = s[:-1] + s[1:]
    return np.where(den > 0, 2.0 * np.diff(theta) / np.where(den > 0, den, 1.0), 0.0)


def change_per_interval(coarse: Grid, x_coarse: np.ndarray, fine: Grid, x_fine: np.ndarray,
                        pieces: np.ndarray) -> np.ndarray:
    """|time on each interval of ``coarse`` - time on its parts in ``fine``| (K - 1,) [s]; ``fine`` is
    ``coarse.split(pieces)``."""
    t_fine = interval_times(fine.theta, x_fine)
    first = np.concatenate([[0], np.cumsum(pieces)[:-1]])
    return np.abs(interval_times(coarse.theta, x_coarse) - np.add.reduceat(t_fine, first))


def pieces_for(error: np.ndarray, target: float) -> np.ndarray:
    """Parts (K - 1,) to split each interval into so that the summed error becomes at most ``target``
    [s]: an interval's error is first order in its step over its length, so n parts divide its
    ``error`` by n. The fewest parts in total (Lagrange) take n_i = lambda sqrt(error_i); with n_i
    rounded up to integers, lambda is the smallest (bisection) whose rounded parts meet the target."""
    error = np.maximum(error, 0.0)
    if float(error.sum()) <= target:
        return np.ones(len(error), int)
    root = np.sqrt(error)

    def parts(lam):
        return np.clip(np.ceil(lam * root), 1, MAX_PIECES)

    lo, hi = 0.0, float(root.sum()) / max(target, 1e-300)  # the continuous optimum: met after rounding up
    for _ in range(PIECES_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if float(np.sum(error / parts(mid))) <= target else (mid, hi)
    return parts(hi).astype(int)


def pieces_within(error: np.ndarray, room: int) -> np.ndarray:
    """Parts (K - 1,) by the rule of :func:`pieces_for` (n_i = ceil(lambda sqrt(error_i))) that add at most
    ``room`` points in all: the largest lambda (bisection on its logarithm) whose parts fit."""
    root = np.sqrt(np.maximum(error, 0.0))
    ones = np.ones(len(error), int)
    positive = root[root > 0]
    if room <= 0 or positive.size == 0:
        return ones

    def parts(lam):
        return np.clip(np.ceil(lam * root), 1, MAX_PIECES)

    lo, hi = np.log(1.0 / positive.max()), np.log(MAX_PIECES / positive.min())  # all ones .. all MAX_PIECES
    if float(np.sum(parts(np.exp(hi)) - 1)) <= room:
        return parts(np.exp(hi)).astype(int)
    for _ in range(2 * PIECES_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if float(np.sum(parts(np.exp(mid)) - 1)) <= room else (lo, mid)
    return parts(np.exp(lo)).astype(int)


@dataclass(frozen=True, eq=False)
class Refined:
    """The adaptive result: the grid (the finer of the last pair), what ``solve`` returned on it, the
    duration's error estimate [s] and the refinement iterations."""

    grid: Grid
    solved: Any
    error_estimate: float
    iterations: int


def refine(solve: Callable[[Grid], tuple[float, np.ndarray, Any]], initial: Grid, tolerance: float,
           max_iterations: int = defaults.GRID_MAX_REFINEMENTS,
           max_points: int = defaults.GRID_MAX_POINTS) -> Refined:
    """Refine ``initial`` until the estimate of the duration's error is within ``tolerance`` (relative).
    ``solve(grid)`` returns (duration [s], x on the grid (K,), anything). Every grid contains the
    previous one (module docstring), so ``solve`` may reuse path data at the shared points."""
    if max_iterations < 1:
        raise ValueError(f"refine: max_iterations must be >= 1, got {max_iterations}")
    grid = initial
    _, x, _ = solve(grid)
    prior = np.full(len(grid.theta) - 1, np.inf)  # error estimate per interval [s]; unknown at first
    pieces = np.full(len(grid.theta) - 1, 2)
    full = False  # the latest grid used all the points max_points allows
    for iteration in range(1, max_iterations + 1):
        fine = grid.split(pieces)
        solved = None  # the coarser grid's solve is not kept while the finer one is built
        t_fine, x_fine, solved = solve(fine)
        change = change_per_interval(grid, x, fine, x_fine, pieces)
        # an interval split into n parts: its change is e (1 - 1/n), e its error before; unsplit ones keep theirs
        error = np.where(pieces > 1, change / np.maximum(pieces ** ORDER - 1.0, 1.0), prior)
        estimate = ERROR_SAFETY * float(error.sum())
        log.debug("adaptive grid: %d -> %d points, duration %.9g s, error estimate %.3g %%",
                  len(grid.theta), len(fine.theta), t_fine, 100 * estimate / t_fine)
        prior = np.repeat(error / pieces, pieces)  # the parts share their interval's error
        if estimate > tolerance * t_fine and not full and iteration < max_iterations:
            pieces = pieces_for(prior, TARGET_FRACTION * tolerance * t_fine / ERROR_SAFETY)
            room = max_points - len(fine.theta)
            full = int(np.sum(pieces - 1)) > room
            if full:
                pieces = pieces_within(prior, room)
            if pieces.max() > 1:
                grid, x = fine, x_fine
                continue
        if estimate > tolerance * t_fine:
            log.warning("adaptive grid stopped at %d points with an estimated duration error of %.3g %% "
                        "(requested %.3g %%)%s", len(fine.theta), 100 * estimate / t_fine, 100 * tolerance,
                        f": the grid is at its largest ({max_points:,} points)" if full else "")
        return Refined(fine, solved, estimate, iteration)
    raise AssertionError("the last iteration returns")  # the loop runs at least once and returns on its last
