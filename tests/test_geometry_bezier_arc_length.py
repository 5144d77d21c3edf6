"""The compiled arc length of a quintic Bezier (geometry/bezier_arc_length.py) against an independent
adaptive quadrature (scipy's QUADPACK) of the curve's speed, and its inverse against the same."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from pathmotion.geometry import BezierSegment


def _curve(seed: int, scale: float) -> BezierSegment:
    """A quintic whose control points wander from the origin along +x (no cusp), ``scale`` [m] across."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(5, 3)) * 0.4 + np.array([1.0, 0.0, 0.0])
    return BezierSegment(scale * np.vstack([np.zeros(3), np.cumsum(steps, axis=0)]))


def _quad_length(seg: BezierSegment, u: float) -> float:
    """int_0^u |X'(v)| dv by adaptive Gauss-Kronrod, from the control points' power basis."""
    coef = BezierSegment._power_basis(seg.control_points)
    speed = lambda v: float(np.linalg.norm(BezierSegment._polyval(coef, np.array([v]), 1)[0]))  # noqa: E731
    return quad(speed, 0.0, u, epsabs=1e-15, epsrel=1e-13, limit=200)[0]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-3, 0.05, 1.0]))
def test_length_and_inverse_match_adaptive_quadrature(seed, scale):
    seg = _curve(seed, scale)
    assert abs(seg.length - _quad_length(seg, 1.0)) <= 1e-12 * max(1.0, seg.length)
    s = np.linspace(0.0, seg.length, 9)
    u = seg.parameter(s)
    assert u[0] == 0.0 and u[-1] == 1.0
    assert np.all(np.diff(u) > 0)
    for si, ui in zip(s[1:-1], u[1:-1]):
        assert abs(_quad_length(seg, ui) - si) <= 1e-12 * max(1.0, seg.length)
