"""Whole-chain versus segment-by-segment planning, and joining per-segment profiles.

connections:
  "chain"  one plan over the whole path; it stops only where it must (kinks: Phi' jumps).
  "zero"   stop at every segment connection (path.breaks): the segments decouple.
  "max"    each segment planned on its own with the boundary-level ("max") velocity at its
           connections, as in the thesis. Neighbouring segments then generally disagree at a
           connection, and at a kink Phi' jumps at non-zero speed: the joined profile represents
           the jump in theta_dot as an interval of CONNECTION_JUMP_FRACTION of the local grid step,
           whose huge acceleration shows in the limit ratios (and a kink crossed at speed is
           reported as an infinite acceleration there). The per-segment profiles are kept too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..errors import InfeasibleError
from ..modes import BoundaryMode, Connections
from .boundary import Boundary, solve_open, solve_periodic
from .profile import Profile
from .topp import IntervalProblem

#: Neighbouring pieces whose x differ by at most this, relative to (1 + x), join without a jump [-].
JOIN_TOLERANCE = 1e-12


@dataclass(frozen=True, eq=False)
class Solution:
    """A solved problem.

    profile: the joined profile; segment_profiles: one per planned segment (one for "chain"/"zero");
    x (K,): x on the problem grid (at a "max" connection: the value after it);
    controllable_hi (K,): upper bound of the controllable sets; jump_intervals: (theta_a, theta_b)
    of the short intervals that carry a jump in theta_dot.
    """

    profile: Profile
    segment_profiles: tuple[Profile, ...]
    x: np.ndarray
    controllable_hi: np.ndarray
    jump_intervals: tuple[tuple[float, float], ...]


def _check_moving(grid: np.ndarray, x: np.ndarray, where: str) -> None:
    both = (x[:-1] <= 0) & (x[1:] <= 0)
    if np.any(both):
        i = int(np.argmax(both))
        raise InfeasibleError(
            f"{where}the path cannot be traversed: the admissible path velocity is zero on theta in "
            f"[{grid[i]:.6g}, {grid[i + 1]:.6g}]; relax the limits there"
        )


def solve_chain(problem: IntervalProblem, *, start: Boundary, end: Boundary, periodic: bool,
                connections: Connections, breaks: tuple[int, ...], stops: tuple[int, ...]) -> Solution:
    """Solve ``problem`` for a connection mode.

    breaks: grid indices of the segment connections; stops: grid indices where the motion must
    stop in "chain" mode (kinks; a closed path's closure point when it is a kink: 0 and K-1).
    """
    if connections in (Connections.CHAIN, Connections.ZERO):
        forced = set(stops) if connections == Connections.CHAIN else set(stops) | set(breaks)
        bound = np.full(problem.size, np.inf)
        bound[sorted(forced)] = 0.0
        prob = problem.capped(bound)
        x, sets = solve_periodic(prob) if periodic else solve_open(prob, start, end)
        _check_moving(prob.grid, x, "")
        prof = Profile(prob.grid, x)
        return Solution(prof, (prof,), x, sets.hi, ())
    # "max": each segment on its own
    cuts = [0, *sorted(b for b in breaks if 0 < b < problem.size - 1), problem.size - 1]
    pieces, highs = [], []
    for j, (i0, i1) in enumerate(zip(cuts[:-1], cuts[1:])):
        sub = problem.slice(i0, i1)
        s = BoundaryMode.MAX if (j > 0 or periodic) else start
        e = BoundaryMode.MAX if (j < len(cuts) - 2 or periodic) else end
        where = f"segment {j} (theta {sub.grid[0]:.6g} .. {sub.grid[-1]:.6g}): "
        x, sets = solve_open(sub, s, e, where)
        _check_moving(sub.grid, x, where)
        pieces.append(x)
        highs.append(sets.hi)
    seg_profiles = tuple(Profile(problem.grid[i0:i1 + 1], x) for (i0, i1), x in zip(zip(cuts[:-1], cuts[1:]), pieces))
    joined, jumps = join_segments(problem.grid, cuts, pieces)
    x_grid = np.concatenate([pieces[0][:1], *[p[1:] for p in pieces]])
    hi_grid = np.concatenate([highs[0][:1], *[h[1:] for h in highs]])
    for j in range(1, len(pieces)):  # values after each connection
        x_grid[cuts[j]] = pieces[j][0]
        hi_grid[cuts[j]] = highs[j][0]
    return Solution(joined, seg_profiles, x_grid, hi_grid, jumps)


def join_segments(grid: np.ndarray, cuts: list[int], pieces: list[np.ndarray]) -> tuple[Profile, tuple]:
    """Join per-segment x arrays (segment j on grid[cuts[j]..cuts[j+1]]) into one Profile. Where
    neighbours disagree, the jump is carried by an interval of CONNECTION_JUMP_FRACTION of the local
    grid step on the slower side of the connection (so the joint velocities stay within their
    limits and only the acceleration shows the jump). Returns the profile and the jump intervals."""
    frac = defaults.CONNECTION_JUMP_FRACTION
    gs = [grid[i0:i1 + 1].copy() for i0, i1 in zip(cuts[:-1], cuts[1:])]
    xs = [p.copy() for p in pieces]
    jumps = []
    for j in range(len(xs) - 1):
        left, right = xs[j], xs[j + 1]
        if abs(left[-1] - right[0]) <= JOIN_TOLERANCE * (1.0 + right[0]):
            gs[j], xs[j] = gs[j][:-1], left[:-1]
            continue
        if left[-1] > right[0]:  # slow down at the end of the left segment
            delta = frac * (gs[j][-1] - gs[j][-2])
            jumps.append((gs[j][-1] - delta, gs[j][-1]))
            gs[j][-1] -= delta
            left[-1] = left[-2] + (left[-1] - left[-2]) * (1.0 - frac)
        else:  # speed up at the start of the right segment
            delta = frac * (gs[j + 1][1] - gs[j + 1][0])
            jumps.append((gs[j + 1][0], gs[j + 1][0] + delta))
            gs[j + 1][0] += delta
            right[0] = right[0] + (right[1] - right[0]) * frac
            # the left segment keeps its end value at the connection; the right one starts after it
            gs[j + 1] = np.concatenate([[gs[j][-1]], gs[j + 1]])
            xs[j + 1] = np.concatenate([[left[-1]], right])
            gs[j], xs[j] = gs[j][:-1], left[:-1]
    return Profile(np.concatenate(gs), np.concatenate(xs)), tuple(jumps)
