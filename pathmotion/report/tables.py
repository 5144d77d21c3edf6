"""Reading the result files back for the report: numeric CSV tables, mixed-type row tables (sweeps)
and JSON. Every read error is a PathmotionError that names the file."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import PathmotionError
from ..io.exports import read_table_csv
from ..io.files import read_input
from ..io.schema import LIMITS

#: Both phase-plane plots (PNG and interactive) cut the limit curves at PLOT_HEADROOM times the fastest
#: profile, plus PLOT_FLOOR so that a profile at rest still gets an axis [-], [unit of theta_dot].
PLOT_HEADROOM = 1.6
PLOT_FLOOR = 1e-9

#: Colour of each limit's own curve in both phase-plane plots (PNG and interactive), by limit name (io/schema.py's
#: LIMITS); a limit not listed there takes the SPARE_LIMIT_COLORS in turn, then FALLBACK_LIMIT_COLOR.
LIMIT_COLORS = {name: row.color for name, row in LIMITS.items()}
SPARE_LIMIT_COLORS = ("#7f7f7f", "#aec7e8")
FALLBACK_LIMIT_COLOR = "#333333"

#: Legend text of each limit's own maximum-velocity curve in the phase plane (by limit name).
LIMIT_CURVE_LABELS = {name: row.curve for name, row in LIMITS.items() if row.curve}
#: What the phase plane says about third-order limits, which have no maximum-velocity curve.
THIRD_ORDER_NOTE = ("jerk and torque-rate limits bound how fast the speed may change, not the speed itself, so they "
                    "have no limit curve; dotted: the fastest constant speed within them (the motion may pass above "
                    "it while it speeds up or slows down); blue dashed: the optimum without them")
#: Legend text of each third-order limit's steady-speed curve (by limit name).
STEADY_CURVE_LABELS = {name: row.steady for name, row in LIMITS.items() if row.steady}


def steady_curve_label(name: str) -> str:
    """Legend text of third-order limit ``name``'s steady-speed curve."""
    return STEADY_CURVE_LABELS.get(name, name.replace("_", " ") + " limit at constant speed")


def limit_curve_label(name: str, summary: dict) -> str:
    """Legend text of limit ``name``'s curve; the torque limits name the reserve of a plan's ``summary``."""
    text = LIMIT_CURVE_LABELS.get(name, name.replace("_", " ") + " limit")
    reserve = summary.get(LIMITS["torque"].settings[0].key)
    if name in ("torque", "torque_speed") and reserve:
        text += f" ({100 * reserve:.3g} % kept free)"
    return text


def read_columns(path: str | Path, required: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """A numeric CSV with a header line (trajectory.csv, simulation.csv, phase_plane.csv) as
    {column: (N,) float array} (:func:`pathmotion.io.exports.read_table_csv`, errors headed "report")."""
    return read_table_csv(path, required, "report")


def _cell(text: str):
    """A CSV cell: '' -> None, true/false -> bool, numbers -> int/float, else the string."""
    if text == "":
        return None
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        return text
    return value if math.isfinite(value) else None


def read_rows(path: str | Path) -> tuple[list[str], list[dict]]:
    """A CSV with mixed cell types (sweep.csv, corner_study.csv): (column names, one dict per row)."""
    path = Path(path)
    text = read_input(path, "result")
    try:
        reader = csv.reader(io.StringIO(text, newline=""))
        names = next(reader, [])
        rows = [dict(zip(names, map(_cell, line))) for line in reader if line]
    except csv.Error as exc:
        raise PathmotionError(f"report: cannot read the table {path}: {exc}; "
                              "re-run the command that wrote it") from None
    return names, rows


def read_json(path: str | Path, default=None):
    """A JSON file; ``default`` when it does not exist (PathmotionError when it is unreadable)."""
    path = Path(path)
    if not path.is_file():
        return default
    try:
        from ..io.files import read_input

        return json.loads(read_input(path, "result"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PathmotionError(f"report: cannot read {path}: {exc}; re-run the command that wrote it") from None


#: The joint-position panel's title, in the PNG and in the report: each joint's position scaled to its range.
RANGE_LABEL = "joint position in its range: (q − centre) / half range"


def in_range(q: np.ndarray, lower, upper) -> np.ndarray:
    """q (N, n) [rad] scaled to each joint's range [-]: -1 at its lower, +1 at its upper limit, 0 at its centre
    (so the position panel shares the +-1 limit lines of the velocity, acceleration and torque panels)."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    return (np.asarray(q, float) - 0.5 * (upper + lower)) / (0.5 * (upper - lower))


def joint_columns(cols: dict[str, np.ndarray], prefix: str) -> np.ndarray | None:
    """The columns prefix1..prefixn stacked as (N, n), or None when prefix1 is absent."""
    names = []
    while f"{prefix}{len(names) + 1}" in cols:
        names.append(f"{prefix}{len(names) + 1}")
    if not names:
        return None
    return np.column_stack([cols[k] for k in names])
