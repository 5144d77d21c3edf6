"""The searches a scenario can ask for, each made of many plans: the optimal blends (``blend = "optimal"``,
planning/blend_search.py) and the torque reserve (``torque_reserve = "auto"``, :mod:`.reserve`, plan and
closed loop per run). :func:`search` runs what a :class:`~.setup.Setup` still needs and returns the
setup they complete; the CLI's ``plan``, ``simulate`` and ``check`` call it after loading."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from .. import defaults
from ..errors import InfeasibleError, PathmotionError
from ..geometry import with_blends
from ..io import schema
from ..io.scheduler import run_on_cluster
from ..planning import PlanSettings
from ..planning.blend_search import SEARCHES, optimal_blends
from .blend_request import BlendRequest, ChainBlendRequest
from .chain_blends import search_chain_blends
from .plan import plan_failures, plan_scenario
from .program import check_program
from .reserve import AUTO, ReserveTrial, Verdict, search_reserve
from .setup import Setup, lift_task_path, plan_settings
from .simulate import simulate_scenario, tracking_failure

log = logging.getLogger(__name__)


def search(setup: Setup) -> Setup:
    """``setup`` completed by the searches it still needs (:attr:`Setup.pending`): first the optimal
    blends (then the path is lifted), then the torque reserve; ``setup`` itself when it needs none."""
    if setup.blend_request is not None:
        setup = search_blends(setup)
    if setup.scenario.limits.torque_reserve == AUTO and setup.reserve_search is None:
        setup = resolve_torque_reserve(setup)
    return setup


# ------------------------------------------------------------------------------------- optimal blends
def search_blends(setup: Setup) -> Setup:
    """``setup`` with its optimal blends found (planning/blend_search.py, under the scenario's plan
    settings), applied with the scenario's other blends in one pass, and the blended path lifted; on a chain
    (joint moves or dwells among the segments) in each task run (:mod:`.chain_blends`)."""
    request, scenario = setup.blend_request, setup.scenario
    if isinstance(request, ChainBlendRequest):
        path = search_chain_blends(setup.robot, request, plan_settings(scenario),
                                   lambda jobs: _runs_shapes(setup, jobs))
        check_program(scenario.path, setup.robot, path)
        return dataclasses.replace(setup, path=path, task_path=path.task_path,
                                   original_task_path=path.original_task_path, blend_request=None)
    q0 = None if scenario.path.start_configuration is None else np.asarray(scenario.path.start_configuration, float)
    shapes = _optimal_shapes(setup.robot, request, plan_settings(scenario), q0, scenario.plan.workers,
                             scenario.plan.scheduler)
    task = with_blends(request.sharp, {**request.blends, **{c: ("g2_shape", s) for c, s in shapes.items()}},
                       request.names)
    path = lift_task_path(scenario, setup.robot, task, setup.original_task_path)
    return dataclasses.replace(setup, path=path, task_path=task, blend_request=None)


def _runs_shapes(setup: Setup, jobs: list) -> list[dict]:
    """The optimal blends of the task runs ``jobs`` [(BlendRequest, PlanSettings, start configuration)], in order:
    each a task on the Dask cluster at plan.scheduler (its corners in one process), else one after the other
    (each run's corners on plan.workers processes, or on the cluster when there is one run)."""
    plan_spec = setup.scenario.plan
    if plan_spec.scheduler is None or len(jobs) <= 1:
        return [_optimal_shapes(setup.robot, *job, plan_spec.workers, plan_spec.scheduler) for job in jobs]
    return run_on_cluster(plan_spec.scheduler, _optimal_shapes, [(setup.robot, *job, 1) for job in jobs],
                          "optimal-blends")


def _optimal_shapes(robot, request: BlendRequest, settings: PlanSettings, q0, workers: int,
                    scheduler: str | None = None) -> dict:
    """{connection index: G2Shape} of the optimal blends of ``request`` planned under ``settings`` from ``q0``
    (n,) [rad] or None, each corner searched as ``request.searches`` names it (the corners are independent, so
    each kind is one search, on ``workers`` processes or the Dask cluster at ``scheduler``); errors start with the scenario key of their corner, or
    of every searched corner when they concern them all (a blended path out of reach)."""
    kinds = {c: request.searches.get(c, "fast") for c in request.tolerances}
    shapes: dict = {}
    for kind in sorted(set(kinds.values())):
        optimal = {c: t for c, t in request.tolerances.items() if kinds[c] == kind}
        log.info("optimal blends: searching %d corner(s), %s search", len(optimal), kind)
        try:
            found = optimal_blends(robot, request.sharp, optimal, list(optimal), settings, q0,
                                   search=SEARCHES[kind], planar=[c for c in request.planar if c in optimal],
                                   joined_ends=[c for c in request.joined if c in optimal], names=request.names,
                                   workers=workers, scheduler=scheduler)
        except PathmotionError as exc:
            if exc.where in request.names.values():
                raise
            raise exc.in_context("; ".join(request.names[c] for c in sorted(optimal))) from exc
        shapes.update(found.shapes)
    return shapes


# ------------------------------------------------------------------------- torque_reserve = "auto"
def resolve_torque_reserve(setup: Setup) -> Setup:
    """``torque_reserve = "auto"``: ``setup`` with the smallest reserve whose plan tracks in the scenario's
    own closed loop (its controller, realism and tolerances), found by :func:`search_reserve` over plan +
    simulate runs. When none tracks: the largest reserve that could be planned, and the search's failure,
    which :func:`~.plan.plan_failures` reports (a failed result)."""
    runs: dict[float, tuple] = {}
    log.info("torque_reserve = auto: searching [0, %g] in steps of %g with the scenario's closed loop (%s)",
             defaults.AUTO_RESERVE_MAX, defaults.AUTO_RESERVE_STEP, setup.scenario.simulate.controller)
    search_record = search_reserve(lambda reserve: _reserve_trial(setup, reserve, runs))
    reserve = search_record.applied
    return dataclasses.replace(setup, plan_settings=plan_settings(setup.scenario, reserve),
                               reserve_search=search_record, reserve_run=runs[reserve])


def _reserve_trial(setup: Setup, reserve: float, runs: dict) -> ReserveTrial:
    """Plan and simulate ``setup`` with the torque reserve ``reserve`` [-]; (plan, simulation or None) go
    into ``runs[reserve]``. An infeasible plan is a verdict above reserve 0 (less reserve is needed); at 0
    it is the scenario's own error and propagates, as do errors of the simulation's set-up."""
    scenario = setup.scenario
    scenario = scenario.model_copy(update={"limits": scenario.limits.model_copy(update={"torque_reserve": reserve})})
    trial = dataclasses.replace(setup, scenario=scenario, plan_settings=plan_settings(scenario))
    try:
        result = plan_scenario(trial)
    except InfeasibleError as exc:
        if reserve == 0:
            raise
        return ReserveTrial(reserve, Verdict.INFEASIBLE, reason=str(exc))
    failures = plan_failures(result)
    if failures:
        runs[reserve] = (result, None)
        return ReserveTrial(reserve, Verdict.FAILS, "the plan failed: " + "; ".join(f.message for f in failures),
                            result.duration)
    sim = simulate_scenario(trial, result)
    runs[reserve] = (result, sim)
    summary = sim.summary()
    failure = tracking_failure(summary)
    return ReserveTrial(reserve, Verdict.TRACKS if failure is None else Verdict.FAILS,
                        "" if failure is None else failure.message, result.duration,
                        summary[schema.CYCLE_TIME.key], summary[schema.PATH_ACCURACY.key])

