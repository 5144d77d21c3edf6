"""The constant-speed baseline's compiled row bounds against their numpy array form."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.planning.baselines import _cruise_bounds


def _numpy_cruise(P, Q, R, inv):
    D = P * inv[:-1, None] + Q * inv[1:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(D > 0, R / np.where(D > 0, D, 1.0), np.inf)
    return u.min(axis=1, initial=np.inf)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), k=st.integers(2, 40), m=st.integers(0, 6), still=st.floats(0.0, 0.5),
       nan_row=st.booleans())
def test_cruise_bounds_are_the_array_forms(seed, k, m, still, nan_row):
    """Per interval the least R / (P inv_i + Q inv_i+1) over rows with a positive denominator: the same floats as
    the (K-1, M) array form, with still points (inv nan), rows of either sign, no rows, and a nan in R."""
    rng = np.random.default_rng(seed)
    P, Q = rng.normal(size=(k - 1, m)), rng.normal(size=(k - 1, m))
    R = rng.uniform(0.1, 2.0, size=(k - 1, m))
    if nan_row and m:
        R[rng.integers(k - 1), rng.integers(m)] = np.nan
    inv = 1.0 / rng.uniform(0.1, 3.0, k) ** 2
    inv[rng.uniform(size=k) < still] = np.nan
    np.testing.assert_array_equal(_cruise_bounds(P, Q, R, inv), _numpy_cruise(P, Q, R, inv))
