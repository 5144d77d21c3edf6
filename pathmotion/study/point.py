"""One sweep point: plan + simulate a scenario (given as TOML text) with key-path overrides.

The point's summary holds the simulation summary of :func:`pathmotion.api.simulation_summary`
(flattened: ``failure`` becomes ``failure_reason``) and the study's own figures, in the fixed order
of :data:`SUMMARY_KEYS`:

* ``cycle_time_s``: the closed-loop cycle time (the TCP at the end of the path within the path tolerance), None
  if tracking failed;
* ``max_sharp_deviation_m`` / ``mean_sharp_deviation_m``: largest / mean distance [m] of the TCP from
  the ORIGINAL sharp path (before blends; for a path without blends, the path itself): what the
  thesis calls the error in task space, intended blend deviation included;
* ``mean_path_deviation_m``: mean distance of the TCP from the planned (blended) path, the tracking
  error (its max is ``path_accuracy_m``);
* ``blend_max_deviation_m``: the planned blend's own largest distance from the sharp path (geometry).

With ``traces=True`` the point also returns time series for figures (see :func:`trace_arrays`).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..io import schema
from .. import defaults
from ..errors import PathmotionError

#: Columns a sweep row holds after the parameters, in this order (then ``error``).
SUMMARY_KEYS = schema.keys(schema.SWEEP_ROW)


def _sharp_path(setup):
    task = setup.original_task_path if setup.original_task_path is not None else setup.task_path
    return None if task is None else task


def point_summary(setup, result, sim) -> tuple[dict, dict]:
    """(summary with SUMMARY_KEYS, {"sharp_nearest": (K, 3) array}) of one run."""
    from ..api import plan_summary, simulation_summary
    from ..simulation.metrics import sharp_path_deviation  # here: keeps the sweep parent process light

    summary = dict(simulation_summary(setup, result, sim))
    failure = summary.pop("failure", None)
    summary[schema.FAILURE_REASON.key] = None if not failure else failure.get("reason")
    plan = plan_summary(setup, result)
    summary[schema.BASELINE_DURATION.key] = plan[schema.BASELINE_DURATION.key]
    summary[schema.BLEND_MAX_DEVIATION.key] = plan.get(schema.BLEND_MAX_DEVIATION.key)
    summary[schema.MEAN_PATH_DEVIATION.key] = float(np.mean(sim.path_deviation[sim.on_path()])) if sim.path_deviation.size else 0.0
    sharp = _sharp_path(setup)
    if sharp is not None and len(sim.tcp):
        dist, near = sharp_path_deviation(sharp, sim.tcp)
    else:  # a joint path: its own TCP path is the reference
        near, dist = sim.tcp_desired, sim.path_deviation
    summary[schema.MAX_SHARP_DEVIATION.key] = float(np.max(dist)) if dist.size else 0.0
    summary[schema.MEAN_SHARP_DEVIATION.key] = float(np.mean(dist)) if dist.size else 0.0
    return summary, {"sharp_nearest": near}


def trace_arrays(setup, result, sim, sharp_nearest: np.ndarray) -> dict[str, np.ndarray]:
    """Time series of a run for figures: t (K,) [s]; tcp (K, 3) measured TCP; tcp_planned (K, 3) TCP of
    the planned trajectory at the same times (the clock-indexed desired motion); sharp_nearest (K, 3)
    nearest point of the sharp path; planned_path / sharp_path (P, 3) polylines of the planned
    (blended) and the sharp task path [m]."""
    from ..robot import fk

    t = np.asarray(sim.t, float)
    planned_q = result.trajectory.at_time(t).q
    out = {"t": t, "tcp": np.asarray(sim.tcp, float), "tcp_planned": fk(setup.robot, planned_q)[0],
           "sharp_nearest": np.asarray(sharp_nearest, float)}
    for name, task in (("planned_path", setup.task_path), ("sharp_path", _sharp_path(setup))):
        if task is not None:
            lo, hi = task.domain
            grid = np.union1d(np.linspace(lo, hi, defaults.STUDY_TRACE_PATH_POINTS), task.breaks)
            out[name] = task.evaluate(grid)[0]
    return out


def run_point(scenario_text: str, base_dir: str, overrides: tuple[tuple[str, Any], ...],
              traces: bool = False) -> dict:
    """Plan and simulate one point of a scenario given as TOML text (so that cluster workers need
    no shared file system; ``base_dir`` resolves relative files in it).

    Returns {"summary": {key: value for SUMMARY_KEYS}, "error": None or one line, "trace": None or
    arrays, "wall_time_s": seconds spent}. A
    PathmotionError becomes the ``error`` (with what it was: "PathError: ..."); so does any other
    exception ("internal error ..."), so one bad point never stops a sweep."""
    from ..api import load_text, plan_scenario, search, simulate_scenario

    started = time.perf_counter()
    trace = None
    try:
        setup = search(load_text(scenario_text, base_dir, dict(overrides)))
        result = plan_scenario(setup)
        sim = simulate_scenario(setup, result)
        summary, extra = point_summary(setup, result, sim)
        if traces:
            trace = trace_arrays(setup, result, sim, extra["sharp_nearest"])
        error = None
    except PathmotionError as exc:
        summary, error = {}, f"{type(exc).__name__}: {str(exc).splitlines()[0]}"
    except Exception as exc:  # a bug must not stop a sweep: record it, loudly
        summary, error = {}, f"internal error {type(exc).__name__}: {exc}"
    summary = {k: summary.get(k) for k in SUMMARY_KEYS}
    return {"summary": summary, "error": error, "trace": trace, schema.WALL_TIME.key: time.perf_counter() - started}
