"""The sweep score and the Pareto front against brute force on handmade and generated tables."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.study import choose_best, pareto_front

T, E, D = "cycle_time_s", "mean_sharp_deviation_m", "max_sharp_deviation_m"


def _row(t, e, d, ok=True, error=None, **params):
    return {**params, T: t, E: e, D: d, "tracking_ok": ok, "error": error, "planned_duration_s": t,
            "path_accuracy_m": 0.0}


TABLE = [
    _row(1.43, 0.0, 0.0001, r=0.0),          # stop at the corner
    _row(1.36, 0.0005, 0.0115, r=0.03),
    _row(1.33, 0.0011, 0.0185, r=0.04),
    _row(None, None, 0.03, ok=False, r=0.05),   # tracking failed: never competes
    _row(1.30, 0.01, 0.2, r=0.06, error="PathError: does not fit"),  # an error row never competes
    _row(1.40, 0.0012, 0.0190, r=0.045),     # dominated by r = 0.04
    _row(1.33, 0.0011, 0.0185, r=0.041),     # equal to r = 0.04: kept on the front, loses the tie
]


def test_handmade_best_and_front():
    # scores with 100 s/m: 1.43, 1.41, 1.44, -, -, 1.52, 1.44
    best = choose_best(TABLE, ["r"])
    assert best["index"] == 1 and best["r"] == 0.03
    assert best["score"] == pytest.approx(1.36 + 100 * 0.0005)
    # no weight on the error: the fastest competing point; the tie goes to the earlier one
    assert choose_best(TABLE, ["r"], error_weight=0.0)["index"] == 2
    # a heavy weight: the stop
    assert choose_best(TABLE, ["r"], error_weight=1e4)["index"] == 0
    assert pareto_front(TABLE) == [0, 1, 2, 6]
    assert choose_best([_row(None, None, 0.1, ok=False)]) is None
    with pytest.raises(ValueError):
        choose_best(TABLE, error_weight=-1.0)


def _brute_front(rows):
    ok = [i for i, r in enumerate(rows) if not r["error"] and r["tracking_ok"]]
    out = []
    for i in ok:
        dominated = any(rows[j][D] <= rows[i][D] and rows[j][T] <= rows[i][T]
                        and (rows[j][D] < rows[i][D] or rows[j][T] < rows[i][T]) for j in ok)
        if not dominated:
            out.append(i)
    return sorted(out, key=lambda i: (rows[i][D], rows[i][T], i))


rows_strategy = st.lists(
    st.tuples(st.integers(1, 6), st.integers(0, 6), st.integers(0, 6), st.booleans(), st.booleans()).map(
        lambda v: _row(1.0 + v[0] / 10, v[1] / 1000, v[2] / 1000, ok=v[3] or v[4], error=None if v[3] else
                       (None if v[4] else "x"))),
    max_size=12)


@settings(max_examples=200, deadline=None)
@given(rows_strategy, st.floats(0.0, 1000.0))
def test_against_brute_force(rows, weight):
    assert pareto_front(rows) == _brute_front(rows)
    best = choose_best(rows, error_weight=weight)
    ok = [i for i, r in enumerate(rows) if not r["error"] and r["tracking_ok"]]
    if not ok:
        assert best is None
        return
    scores = {i: rows[i][T] + weight * rows[i][E] for i in ok}
    low = min(scores.values())
    assert best["index"] == min(i for i in ok if scores[i] == low)
    assert math.isclose(best["score"], low)


def test_outcome_text_counts_an_error_once_and_a_failed_tracking_as_a_result():
    from pathmotion.study.score import outcome_text

    rows = [{"tracking_ok": True}, {"tracking_ok": False}, {"error": "PathError: x", "tracking_ok": False},
            {"tracking_ok": True, "error": ""}]
    assert outcome_text(rows) == "4 points: 2 tracked, 1 tracking failed, 1 error"
    assert outcome_text(rows[:1], "run") == "1 run: 1 tracked, 0 tracking failed, 0 errors"
