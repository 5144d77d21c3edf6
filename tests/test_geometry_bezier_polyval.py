"""The compiled Horner evaluation of a quintic (geometry/bezier_polyval.py) against numpy's, operation for
operation (the same floats: every blend the search found stays the same), and against the Bernstein form and its
hodographs (an independent evaluation)."""

from math import comb

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.geometry.segments import _DERIVATIVE_FACTORS, BezierSegment


def _numpy_horner(coef, u, order):
    """The numpy Horner loop BezierSegment._polyval ran before it was compiled."""
    u = np.atleast_1d(np.asarray(u, float))[:, None]
    fac = _DERIVATIVE_FACTORS[order]
    out = np.empty((u.shape[0], 3))
    out[:] = fac[-1] * coef[5]
    for k in range(4, order - 1, -1):
        out *= u
        out += fac[k - order] * coef[k]
    return out


def _bernstein(b, u, order):
    """d^order/du^order of the Bezier curve with control points b (6, 3): its order-th hodograph's Bernstein sum."""
    d = np.array(b, float)
    for _ in range(order):
        d = (len(d) - 1) * np.diff(d, axis=0)
    n = len(d) - 1
    basis = np.array([comb(n, i) * u ** i * (1 - u) ** (n - i) for i in range(n + 1)])  # (n + 1, N)
    return basis.T @ d


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-4, 1e-2, 1.0]), n=st.integers(1, 300),
       order=st.integers(0, 3))
def test_compiled_horner_is_numpy_bit_for_bit_and_matches_the_bernstein_form(seed, scale, n, order):
    rng = np.random.default_rng(seed)
    b = scale * rng.normal(size=(6, 3))
    coef = BezierSegment._power_basis(b)
    u = np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, n)])
    got = BezierSegment._polyval(coef, u, order)
    assert np.array_equal(got, _numpy_horner(coef, u, order))
    np.testing.assert_allclose(got, _bernstein(b, u, order), rtol=0, atol=1e-12 * scale * 60 ** order)
