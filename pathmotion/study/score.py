"""Choosing among sweep points: the score and the Pareto front.

The thesis (section 7.2.2) chooses the transition radius "giving the least possible average error
combined with the lowest possible time period". Here that is one number, lower is better:

    score = cycle_time_s + error_weight * mean_sharp_deviation_m

cycle_time_s: the closed-loop time to do the motion [s]; mean_sharp_deviation_m: the TCP's mean
distance from the original sharp path over the run [m] (the thesis' average task-space error,
intended blend deviation included); error_weight [s/m], default defaults.STUDY_ERROR_WEIGHT = 100
(1 mm of mean deviation costs as much as 0.1 s of cycle time). Only points without an error and
with tracking_ok compete; ties go to the earlier point.

The Pareto front (deviation against cycle time, both minimized) is the set of competing points
that no other competing point beats in both, i.e. every point for which no other has
deviation <= its deviation and time <= its time with one of the two strictly smaller. It does not
depend on any weight. (The score uses the MEAN deviation, the front the LARGEST, so the best-scored
point need not lie on the front: a short deviation spike costs little on average.)
"""

from __future__ import annotations

import math
from typing import Sequence

from ..io import schema
from .. import defaults

TIME_KEY = schema.CYCLE_TIME.key
ERROR_KEY = schema.MEAN_SHARP_DEVIATION.key
DEVIATION_KEY = schema.MAX_SHARP_DEVIATION.key
#: Metrics copied into a best-point record.
BEST_METRICS = schema.keys((schema.CYCLE_TIME, schema.PLANNED_DURATION, schema.MEAN_SHARP_DEVIATION,
                            schema.MAX_SHARP_DEVIATION, schema.PATH_ACCURACY, schema.TRACKING_OK))


def _number(v) -> float | None:
    if v is None or isinstance(v, bool):
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def competes(row: dict, keys: Sequence[str] = (TIME_KEY, ERROR_KEY)) -> bool:
    """True for a row without error, with tracking_ok, and finite values under ``keys``."""
    return (not row.get("error") and row.get(schema.TRACKING_OK.key) is True
            and all(_number(row.get(k)) is not None for k in keys))


def score(row: dict, *, error_weight: float = defaults.STUDY_ERROR_WEIGHT, time_key: str = TIME_KEY,
          error_key: str = ERROR_KEY) -> float:
    """time + error_weight * error of a competing row (see the module docstring)."""
    return float(row[time_key]) + error_weight * float(row[error_key])


def choose_best(rows: Sequence[dict], parameters: Sequence[str] = (), *,
                error_weight: float = defaults.STUDY_ERROR_WEIGHT, time_key: str = TIME_KEY,
                error_key: str = ERROR_KEY) -> dict | None:
    """The competing row with the lowest score, as {"index", the parameters, "score", "error_weight",
    BEST_METRICS}; None when no row competes."""
    if not (math.isfinite(error_weight) and error_weight >= 0):
        raise ValueError(f"error_weight must be a finite number >= 0 s/m, got {error_weight!r}")
    best_i, best_s = None, math.inf
    for i, row in enumerate(rows):
        if competes(row, (time_key, error_key)):
            s = score(row, error_weight=error_weight, time_key=time_key, error_key=error_key)
            if s < best_s:
                best_i, best_s = i, s
    if best_i is None:
        return None
    row = rows[best_i]
    out = {"index": best_i}
    out.update({p: row.get(p) for p in parameters})
    out["score"] = best_s
    out["error_weight"] = error_weight
    out.update({k: row.get(k) for k in (*BEST_METRICS, time_key, error_key)})
    return out


def pareto_front(rows: Sequence[dict], *, x_key: str = DEVIATION_KEY, y_key: str = TIME_KEY) -> list[int]:
    """Indices of the competing rows on the Pareto front of (x, y), both minimized, sorted by x then y.
    Rows with equal (x, y) are all kept."""
    pts = sorted((float(rows[i][x_key]), float(rows[i][y_key]), i) for i in range(len(rows))
                 if competes(rows[i], (x_key, y_key)))
    front, best_y = [], math.inf
    k = 0
    while k < len(pts):  # groups of equal x: only the smallest y of a group can be on the front
        j = k
        while j < len(pts) and pts[j][0] == pts[k][0]:
            j += 1
        y_min = pts[k][1]
        if y_min < best_y:
            front += [i for x, y, i in pts[k:j] if y == y_min]
            best_y = y_min
        k = j
    return front


def outcome_text(rows: Sequence[dict], noun: str = "point") -> str:
    """'12 points: 9 tracked, 2 tracking failed, 1 error' for sweep rows: an error (row "error" set) is a
    point that did not run to a result; a failed tracking (tracking_ok false) is a result."""
    errors = sum(1 for r in rows if r.get("error"))
    failed = sum(1 for r in rows if not r.get("error") and r.get(schema.TRACKING_OK.key) is False)
    return (f"{len(rows)} {noun}{'s' if len(rows) != 1 else ''}: {len(rows) - failed - errors} tracked, "
            f"{failed} tracking failed, {errors} error{'s' if errors != 1 else ''}")
