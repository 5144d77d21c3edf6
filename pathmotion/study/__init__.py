"""Studies over the plan + simulate flow: parameter sweeps (local processes or a Dask cluster),
the score and Pareto front that choose among their points, and the
chapter-7 corner study with its figures.

Entry points::

    outcome = run_study_sweep("scenarios/corner_transition.toml", {"path.blends[0].radius": [0.03, 0.04]}, "out/rt")
    outcome.rows, outcome.best, outcome.front
    corner_study("out/corner")
"""

from __future__ import annotations

from .corner import CornerStudy, corner_study, transition_radius_for_deviation
from .point import SUMMARY_KEYS, run_point
from .runner import SCORE_RULE, SweepOutcome, run_study_sweep
from .score import choose_best, competes, pareto_front, score
from .sweep import SweepPoint, load_trace, parse_sets, run_sweep, sweep_points

__all__ = [
    "CornerStudy", "SCORE_RULE", "SUMMARY_KEYS", "SweepOutcome", "SweepPoint",
    "choose_best", "competes", "corner_study", "load_trace", "pareto_front", "parse_sets", "run_point",
    "run_study_sweep", "run_sweep", "score", "sweep_points", "transition_radius_for_deviation",
]
