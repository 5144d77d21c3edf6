"""Finding result folders under a root folder (what ``pathmotion report DIR`` turns into sections).

Recognized folders (files written by :mod:`pathmotion.api` and :mod:`pathmotion.study`):

* ``simulation``: simulation.csv + summary.json (its plan, if any, in ``./plan``);
* ``plan``: trajectory.csv + phase_plane.csv + summary.json (not listed separately when it is the
  ``plan`` folder of a simulation folder: it belongs to that section);
* ``sweep``: sweep.csv (with sweep_spec.json and best.json when written by ``pathmotion sweep``);
* ``study``: corner_study.csv (the chapter-7 corner study, whose parts are sweep folders below it);
* ``atlas``: corners.csv (``pathmotion corners``; its per-point sweep folder is part of it).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import PathmotionError

KINDS = ("simulation", "plan", "sweep", "study", "atlas")
#: Folders never searched: a sweep's per-point files.
SKIPPED_FOLDERS = ("points",)


@dataclass(frozen=True)
class ResultFolder:
    """One result folder: ``kind`` (one of KINDS), its ``path``, and for a simulation the plan folder
    it came with (``plan_path``, None when absent)."""

    kind: str
    path: Path
    plan_path: Path | None = None

    def label(self, root: Path) -> str:
        """The folder relative to the report's root ("." for the root itself)."""
        rel = self.path.relative_to(root).as_posix()
        return rel or "."


def is_plan(folder: Path) -> bool:
    return all((folder / f).is_file() for f in ("trajectory.csv", "phase_plane.csv", "summary.json"))


def is_simulation(folder: Path) -> bool:
    return all((folder / f).is_file() for f in ("simulation.csv", "summary.json"))


def is_sweep(folder: Path) -> bool:
    return (folder / "sweep.csv").is_file()


def is_study(folder: Path) -> bool:
    return (folder / "corner_study.csv").is_file()


def is_atlas(folder: Path) -> bool:
    return (folder / "corners.csv").is_file()


def classify(folder: Path) -> ResultFolder | None:
    """The result in ``folder`` itself (not below it), or None."""
    if is_simulation(folder):
        plan = folder / "plan"
        return ResultFolder("simulation", folder, plan if is_plan(plan) else None)
    if is_plan(folder):
        return ResultFolder("plan", folder)
    if is_atlas(folder):
        return ResultFolder("atlas", folder)
    if is_sweep(folder):
        return ResultFolder("sweep", folder)
    if is_study(folder):
        return ResultFolder("study", folder)
    return None


def discover(root: str | Path) -> tuple[ResultFolder, ...]:
    """Every result folder under ``root`` (``root`` included), depth first in name order.

    PathmotionError when ``root`` is not a folder or holds no recognizable result."""
    root = Path(root)
    if not root.is_dir():
        raise PathmotionError(f"report: {root} is not a folder; give the folder written by pathmotion "
                              "plan/simulate/sweep/demo (--out DIR)")
    found: list[ResultFolder] = []
    claimed: set[Path] = set()  # plan folders that belong to a simulation section
    for dirpath, dirnames, _ in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d not in SKIPPED_FOLDERS and not d.startswith("."))
        folder = Path(dirpath)
        if folder in claimed:
            continue
        result = classify(folder)
        if result is None:
            continue
        found.append(result)
        if result.plan_path is not None:
            claimed.add(result.plan_path)
        if result.kind == "atlas":
            claimed.add(folder / "points_sweep")
    if not found:
        raise PathmotionError(f"report: no plan, simulation or sweep results under {root}; "
                              "run pathmotion plan/simulate/sweep first")
    return tuple(found)
