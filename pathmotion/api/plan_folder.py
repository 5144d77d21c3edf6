"""A plan read back from the folder ``pathmotion plan`` wrote, instead of planning again.

The folder is recognised by its result mark (.pathmotion-result) and its trajectory export (trajectory.csv);
the plan itself is the folder's scenario.toml (robot, limits, path: built, not planned) and its phase plane
(phase_plane.csv: the profile's grid, theta_dot and, when the plan has them, theta_ddot at the grid points
and the dwells). The rebuilt trajectory must reproduce trajectory.csv, so what is streamed is the plan the
folder shows.
"""

from __future__ import annotations

import dataclasses
import json
import logging
from pathlib import Path

import numpy as np

from .. import defaults
from ..errors import PathmotionError, ScenarioError
from ..io import schema
from ..io.exports import read_table_csv
from ..io.files import RESULT_MARK, read_input
from ..planning import PlanResult
from ..planning.profile import Profile
from ..planning.trajectory import Trajectory
from .searches import search_blends
from .setup import Setup, load, plan_settings

log = logging.getLogger(__name__)

#: The files of a plan folder that a plan is read from.
PLAN_FILES = (RESULT_MARK, "trajectory.csv", schema.PHASE_PLANE_FILE, "scenario.toml", "summary.json")


def is_plan_folder(folder: str | Path) -> bool:
    """True when ``folder`` is a folder holding the result mark and the trajectory export."""
    folder = Path(folder)
    return folder.is_dir() and (folder / RESULT_MARK).is_file() and (folder / "trajectory.csv").is_file()


def _check_files(folder: Path) -> dict:
    """The folder's summary.json; ScenarioError naming every plan file that is missing or a failed plan."""
    if not folder.is_dir():
        raise ScenarioError(f"{folder}: not a folder; give a scenario file or the output folder of pathmotion plan")
    missing = [name for name in PLAN_FILES if not (folder / name).is_file()]
    if missing:
        what = "it is not a pathmotion result folder" if RESULT_MARK in missing else "it is not a complete plan"
        raise ScenarioError(f"{folder}: {what}: {', '.join(missing)} missing; give the output folder of "
                            "`pathmotion plan SCENARIO --out DIR` (or the scenario file)")
    try:
        summary = json.loads(read_input(folder / "summary.json", "result"))
    except ValueError as exc:
        raise ScenarioError(f"{folder / 'summary.json'}: not JSON ({exc}); plan again") from None
    failures = summary.get(schema.FAILURES.key) or []
    if failures:
        first = failures[0].get("message", failures[0]) if isinstance(failures[0], dict) else failures[0]
        raise ScenarioError(f"{folder}: the plan failed ({first}); it must not be run; fix the scenario and plan again")
    return summary


def _setup(folder: Path, summary: dict) -> Setup:
    """The folder's scenario built (robot, path), with the torque reserve the plan applied; the optimal
    blends searched again when the scenario asks for them (the folder keeps the scenario, not the shapes)."""
    setup = load(folder / "scenario.toml")
    if setup.blend_request is not None:
        log.info("the plan's scenario asks for optimal blends: searching them again to rebuild its path")
        setup = search_blends(setup)
    reserve = summary.get("torque_reserve")
    if isinstance(reserve, (int, float)):
        setup = dataclasses.replace(setup, plan_settings=plan_settings(setup.scenario, float(reserve)))
    return setup


def _profile(folder: Path) -> Profile:
    cols = read_table_csv(folder / schema.PHASE_PLANE_FILE, (schema.PHASE_THETA, schema.PHASE_OPTIMAL), "execute")
    return Profile(cols[schema.PHASE_THETA], cols[schema.PHASE_OPTIMAL] ** 2, cols.get(schema.PHASE_OPTIMAL_DDOT),
                   cols.get(schema.PHASE_HOLDS))


def read_plan(folder: str | Path, tolerance: float = defaults.PLAN_FOLDER_TOLERANCE) -> tuple[Setup, PlanResult]:
    """(setup, plan) of a plan folder, without planning. ScenarioError when a plan file is missing, the plan
    failed, or the rebuilt trajectory leaves trajectory.csv's joints by more than ``tolerance`` [rad] (the
    folder was edited, or written from other files or by another version)."""
    folder = Path(folder)
    summary = _check_files(folder)
    setup = _setup(folder, summary)
    try:
        profile = _profile(folder)
    except PathmotionError as exc:
        raise ScenarioError(f"{folder / schema.PHASE_PLANE_FILE}: {exc}") from None
    traj = Trajectory(setup.path, profile, setup.robot)
    export = read_table_csv(folder / "trajectory.csv", ("t", "q1"), "execute")
    n = setup.robot.n
    names = [f"q{j + 1}" for j in range(n)]
    if any(name not in export for name in names) or f"q{n + 1}" in export:
        raise ScenarioError(f"{folder / 'trajectory.csv'}: its joints are not the {n} of the scenario's robot; "
                            "plan again")
    t = export["t"]
    gap = np.abs(traj.at_time(t).q - np.column_stack([export[name] for name in names]))
    k, j = np.unravel_index(int(np.argmax(gap)), gap.shape)
    if gap[k, j] > tolerance or abs(traj.duration - float(t[-1])) > 1e-9 + 1e-9 * traj.duration:
        raise ScenarioError(f"{folder}: phase_plane.csv and scenario.toml do not reproduce trajectory.csv (joint "
                            f"{j + 1} differs by {gap[k, j]:.3g} rad at t = {t[k]:.4g} s, duration "
                            f"{traj.duration:.6g} against {t[-1]:.6g} s): the folder was edited or written by "
                            "another version; plan again")
    result = PlanResult(profile, traj, (profile,), None, None, None, 0.0, len(profile.grid), 0, (),
                        setup.plan_settings)
    log.info("read the plan of %s from %s (%.6g s, %d grid points)", setup.name, folder, traj.duration,
             len(profile.grid))
    return setup, result
