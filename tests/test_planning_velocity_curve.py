"""The maximum-velocity curve (the largest x at each point for which some u meets every limit row) against a
linear program per point (scipy's HiGHS: maximize x subject to lo <= a u + b x + c <= hi, x >= 0)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from pathmotion.planning.limit_rows import LimitRows
from pathmotion.planning.topp import maximum_velocity_curve


def _lp_max(a, b, c, lo, hi) -> float:
    rows = np.column_stack([a, b])
    res = linprog([0.0, -1.0], A_ub=np.vstack([rows, -rows]), b_ub=np.concatenate([hi - c, c - lo]),
                  bounds=[(None, None), (0.0, None)], method="highs")
    if res.status == 3:  # unbounded
        return np.inf
    assert res.status == 0
    return -res.fun


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), m=st.integers(1, 6), zero_a=st.booleans())
def test_maximum_velocity_curve_is_the_largest_feasible_x(seed, m, zero_a):
    """Rows of the planner's kind (velocity rows a = 0, b > 0; acceleration rows with a of either sign around a
    feasible x = 0, u = 0): the curve is the LP's maximum to rounding, inf where no row bounds x."""
    rng = np.random.default_rng(seed)
    k = 25
    a = rng.normal(size=(k, m))
    if zero_a:
        a[:, 0] = 0.0  # a velocity-like row
    b = rng.normal(size=(k, m))
    if zero_a:
        b[:, 0] = np.abs(b[:, 0])
    c = rng.normal(scale=0.1, size=(k, m))
    lo, hi = c - rng.uniform(0.5, 2.0, (k, m)), c + rng.uniform(0.5, 2.0, (k, m))
    rows = LimitRows(a, b, c, lo, hi, np.full(k, np.inf), ("r",) * m, (0,) * m)
    got = maximum_velocity_curve(rows)
    want = np.array([_lp_max(a[i], b[i], c[i], lo[i], hi[i]) for i in range(k)])
    assert np.array_equal(np.isinf(got), np.isinf(want))
    finite = np.isfinite(want)
    np.testing.assert_allclose(got[finite], want[finite], rtol=1e-7, atol=1e-9)
