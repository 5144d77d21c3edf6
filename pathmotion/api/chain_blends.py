"""Optimal blends on a chain (a task path with joint moves or dwells; docs/program.md, "Optimal blends in a
program"): each task run's optimal corners are searched on that run (planning/blend_search.py), entered and left
at the path speeds a plan of the whole chain with symmetric G2 blends has at the run's ends (at rest after a
dwell, a fine point or a joint move without a zone); the joint-space zones and the stops stay as they are. The
runs' searches are independent (a Dask cluster may run them). A run's found blends replace its symmetric ones
only when the chain with them plans faster."""

from __future__ import annotations

import logging
from typing import Callable

import numpy as np

from ..geometry import with_blends
from ..lift.chain import TaskRun, lift_chain
from ..lift.joint_move import Piece, PiecewiseJointPath
from ..planning import PlanSettings, plan
from ..planning.blend_search import replace_settings
from .blend_request import BlendRequest, ChainBlendRequest

log = logging.getLogger(__name__)

#: find_all([(request, settings, q_start)]) -> [{connection: G2Shape}]: the optimal blends of task runs, in order.
FindAll = Callable[[list[tuple[BlendRequest, PlanSettings, np.ndarray]]], list[dict]]


def chain_with(robot, request: ChainBlendRequest, chosen: dict) -> PiecewiseJointPath:
    """The chain of ``request`` lifted with, in each searched run i, the blends ``chosen[i]`` {local connection:
    (kind, value)} at its optimal corners and its other blends."""
    items = list(request.items)
    for i, run in request.runs.items():
        items[i] = TaskRun(with_blends(run.sharp, {**run.blends, **chosen[i]}, run.names), run.sharp, items[i].where)
    return lift_chain(robot, items, request.q_start, request.zones)


def _run_piece(path: PiecewiseJointPath, where: str) -> Piece:
    """The task piece of ``path`` that the run ``where`` (TaskRun.where) became."""
    return next(p for p in path.pieces if p.kind == "task" and p.where == where)


def run_settings(path: PiecewiseJointPath, profile, settings: PlanSettings, where: str) -> tuple[PlanSettings,
                                                                                                  np.ndarray]:
    """(plan settings, start configuration (n,) [rad]) of the run ``where`` of ``path`` searched on its own: the
    chain's start (end) condition where the run starts (ends) the chain, else the path speed [m/s] the chain's
    ``profile`` has at the run's start (end), 0 at a stop."""
    piece = _run_piece(path, where)
    lo, hi = piece.shift, piece.shift + piece.path.length

    def speed(theta: float) -> float:
        return float(np.sqrt(max(np.interp(theta, profile.grid, profile.x), 0.0)))

    first, last = path.domain
    start = settings.start if lo <= first else speed(lo)
    end = settings.end if hi >= last else speed(hi)
    return (replace_settings(settings, periodic=False, start=start, end=end),
            piece.path.evaluate(0.0)[0])


def search_chain_blends(robot, request: ChainBlendRequest, settings: PlanSettings,
                        find_all: FindAll) -> PiecewiseJointPath:
    """The chain of ``request`` with each run's optimal blends found by ``find_all`` (module docstring) under the
    plan ``settings`` (verification and baselines off). The runs are searched independently, each between the
    speeds of the chain's plan with symmetric G2 blends. A run's found blends are then kept, run by run, where the
    chain with them plans faster than without them (the run searched on its own sees its ends at fixed speeds,
    not the joint zone or joint move beyond them); elsewhere that run keeps its symmetric G2 blends."""
    settings = replace_settings(settings, verify="off", baselines=False)
    chosen = {i: {c: ("g2", t) for c, t in run.tolerances.items()} for i, run in request.runs.items()}
    path = chain_with(robot, request, chosen)
    symmetric = best = plan(path, robot, settings)
    jobs = []
    for i, run in request.runs.items():
        where = request.items[i].where
        settings_i, q_i = run_settings(path, symmetric.profile, settings, where)
        log.info("optimal blends: task run %s, %d corner(s), entered at %s, left at %s", where, len(run.tolerances),
                 _condition(settings_i.start), _condition(settings_i.end))
        jobs.append((run, settings_i, q_i))
    for i, found in zip(request.runs, find_all(jobs)):
        trial = {**chosen, i: {c: ("g2_shape", shape) for c, shape in found.items()}}
        trial_path = chain_with(robot, request, trial)
        trial_plan = plan(trial_path, robot, settings)
        if trial_plan.duration <= best.duration:
            chosen, path, best = trial, trial_path, trial_plan
            continue
        log.info("optimal blends: task run %s: the chain plans in %.6g s with its searched blends, %.6g s without "
                 "(its ends join joint moves the run's search does not see); its symmetric G2 blends are kept",
                 request.items[i].where, trial_plan.duration, best.duration)
    log.info("optimal blends: the chain plans in %.6g s (%.6g s with the symmetric G2 blends)", best.duration,
             symmetric.duration)
    return path


def _condition(value) -> str:
    """A run end's boundary condition for the log."""
    if value is None:
        return "rest"
    return f"{value:.4g} m/s" if isinstance(value, float) else str(getattr(value, "value", value))
