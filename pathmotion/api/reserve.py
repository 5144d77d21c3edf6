"""``[limits] torque_reserve = "auto"``: the smallest feedback reserve with which the closed loop tracks.

A reserve r keeps r tau_max of every joint free for the controller (the planner enforces (1 - r) tau_max,
planning/limits/torque.py). More reserve means a slower plan and more authority for feedback; "auto"
searches the reserves 0, s, 2 s, ..., ``top`` (s = ``step``) for the smallest one whose plan, run in the
scenario's own closed loop (its controller, ``[simulate.realism]`` and ``path_tolerance``), tracks.

The search assumes that tracking is monotone in r (a reserve that tracks leaves every larger one tracking)
and bisects on the grid of multiples of s: reserve 0 first (one run when no reserve is needed), then a
lower-bound bisection over s .. top, at most ceil(log2(top / s + 1)) further runs (5 for 0.45 in steps of
0.025). A reserve so large that the reduced torque cannot hold the path (the plan is infeasible) bounds
the search from above like a tracking one, but is never chosen.

This module holds the search and its record only; each run (plan + closed loop at one reserve) is passed in
as a function (:func:`pathmotion.api.searches.resolve_torque_reserve`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Callable

from .. import defaults

log = logging.getLogger(__name__)

#: The value of ``[limits] torque_reserve`` that asks for the search.
AUTO = "auto"


class Verdict(StrEnum):
    """The outcome of one run of the search."""

    TRACKS = "tracks"  # planned and tracked within the scenario's tolerances
    FAILS = "fails"  # planned, but the closed loop failed (or the plan itself failed): more reserve needed
    INFEASIBLE = "infeasible"  # no plan: the reduced torque cannot hold the path (less reserve needed)


@dataclass(frozen=True)
class ReserveTrial:
    """One run: the reserve [-], its verdict, why it did not track ("" when it did), and the run's figures
    (None where the run did not get that far): planned duration [s], closed-loop cycle time [s], path
    accuracy (largest TCP distance from the planned path) [m]."""

    reserve: float
    verdict: Verdict
    reason: str = ""
    planned_duration_s: float | None = None
    cycle_time_s: float | None = None
    path_accuracy_m: float | None = None

    def record(self) -> dict:
        """JSON-serializable, for summary.json's ``torque_reserve_search``."""
        out = {"torque_reserve": self.reserve, "verdict": self.verdict.value,
               "planned_duration_s": self.planned_duration_s, "cycle_time_s": self.cycle_time_s,
               "path_accuracy_m": self.path_accuracy_m}
        if self.reason:
            out["reason"] = self.reason
        return out

    def describe(self) -> str:
        """One line for the log: 'reserve 0.225: tracks (planned 0.52 s, cycle 0.55 s, path 0.41 mm)'."""
        figures = [f"{name} {v * scale:.4g} {unit}" for name, v, scale, unit in (
            ("planned", self.planned_duration_s, 1.0, "s"), ("cycle", self.cycle_time_s, 1.0, "s"),
            ("path accuracy", self.path_accuracy_m, 1e3, "mm")) if v is not None]
        shown = f" ({', '.join(figures)})" if figures else ""
        why = f": {self.reason}" if self.reason else ""
        return f"reserve {self.reserve:g}: {self.verdict.value}{shown}{why}"


@dataclass(frozen=True)
class ReserveSearch:
    """The runs of a search in the order they ran, the searched range [0, ``top``] in steps of ``step``,
    and the chosen reserve: the smallest that tracked (None when none did)."""

    trials: tuple[ReserveTrial, ...]
    top: float
    step: float

    @property
    def chosen(self) -> float | None:
        tracked = [t.reserve for t in self.trials if t.verdict == Verdict.TRACKS]
        return min(tracked) if tracked else None

    @property
    def ok(self) -> bool:
        return self.chosen is not None

    @property
    def applied(self) -> float:
        """The reserve the scenario then runs with: the chosen one, else the largest that could be planned."""
        return self.chosen if self.ok else self.largest_planned.reserve

    @property
    def largest_planned(self) -> ReserveTrial:
        """The run with the largest reserve that could be planned (reserve 0 always can: its errors propagate)."""
        return max((t for t in self.trials if t.verdict != Verdict.INFEASIBLE), key=lambda t: t.reserve)

    def records(self) -> list[dict]:
        return [t.record() for t in self.trials]

    def failure(self) -> str | None:
        """Why the search found no reserve, what was tried and what to change (None when it found one)."""
        if self.ok:
            return None
        last = self.largest_planned
        infeasible = [t.reserve for t in self.trials if t.verdict == Verdict.INFEASIBLE]
        above = (f"; from reserve {min(infeasible):g} up the plan is infeasible (the reduced torque cannot hold "
                 "the path)" if infeasible else "")
        return (f"limits.torque_reserve = \"{AUTO}\": no reserve in [0, {self.top:g}] (steps of {self.step:g}) "
                f"tracks in the scenario's closed loop; the largest tried, {last.reserve:g}, failed: "
                f"{last.reason or 'tracking failed'}{above}. Reserve alone does not make this motion executable: "
                "slow it down (limits.torque_scale, limits.velocity_scale, jerk limits), raise the controller's "
                "gains (simulate.gains), or loosen simulate.path_tolerance")


def search_reserve(run: Callable[[float], ReserveTrial], top: float = defaults.AUTO_RESERVE_MAX,
                   step: float = defaults.AUTO_RESERVE_STEP) -> ReserveSearch:
    """The smallest reserve in {0, step, 2 step, ..., top} for which ``run(reserve)`` tracks, by reserve 0
    first, then a lower-bound bisection over the rest (see the module docstring). ``run`` plans and
    simulates at one reserve and returns its :class:`ReserveTrial`; each reserve runs at most once."""
    if not (0 < step <= top < defaults.MAX_TORQUE_RESERVE):
        raise ValueError(f"the reserve search needs 0 < step <= top < {defaults.MAX_TORQUE_RESERVE}, got step "
                         f"{step!r}, top {top!r}")
    count = int(math.floor(top / step + 1e-9))  # grid indices 0 .. count
    trials: list[ReserveTrial] = []

    def trial(k: int) -> ReserveTrial:
        reserve = round(k * step, 12)  # 0.1 + 0.05 prints as 0.15
        t = run(reserve)
        trials.append(t)
        log.info("torque_reserve = auto, run %d: %s", len(trials), t.describe())
        return t

    if trial(0).verdict != Verdict.TRACKS:
        lo, hi = 1, count  # the smallest tracking index, if any, lies in [lo, hi]
        while lo <= hi:
            mid = (lo + hi) // 2
            if trial(mid).verdict == Verdict.FAILS:
                lo = mid + 1
            else:  # tracks, or so much reserve that nothing can be planned: look lower
                hi = mid - 1
    search = ReserveSearch(tuple(trials), top=round(count * step, 12), step=step)
    if search.ok:
        log.info("torque_reserve = auto: chose %g after %d runs", search.chosen, len(trials))
    else:
        log.warning("torque_reserve = auto: no reserve tracked after %d runs", len(trials))
    return search
