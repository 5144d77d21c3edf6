"""HermiteSegment (the TCP trace of a joint move) against a curve known in closed form: a helix sampled with its
exact derivatives, parameterized by a non-arc-length parameter."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pathmotion.errors import PathError
from pathmotion.geometry import HermiteSegment, Line, TaskPath


def _helix(s):
    """p, p', p'', p''' of a helix in a parameter s that is not its arc length (|p'| = 0.3 sqrt(1 + 4 s^2) ...)."""
    s = np.asarray(s, float)
    a = 2.0 * s + s**2
    da, dda = 2.0 + 2.0 * s, 2.0 * np.ones_like(s)
    c, sn = np.cos(a), np.sin(a)
    p = np.stack([0.2 * c, 0.2 * sn, 0.1 * s], axis=1)
    dp = np.stack([-0.2 * sn * da, 0.2 * c * da, 0.1 * np.ones_like(s)], axis=1)
    ddp = np.stack([-0.2 * c * da**2 - 0.2 * sn * dda, -0.2 * sn * da**2 + 0.2 * c * dda, 0 * s], axis=1)
    dddp = np.stack([0.2 * sn * da**3 - 0.6 * c * da * dda, -0.2 * c * da**3 - 0.6 * sn * da * dda, 0 * s], axis=1)
    return p, dp, ddp, dddp


@pytest.fixture(scope="module")
def helix():
    s = np.linspace(0.0, 1.0, 101)
    return HermiteSegment(s, *_helix(s)[:3], label="helix")


def test_interpolates_the_curve_and_its_derivatives(helix):
    s = np.linspace(0.0, 1.0, 2001)
    got = helix.evaluate3(s)
    exact = _helix(s)
    # quintic Hermite on h = 0.01: error O(h^6) in p, one order less per derivative
    for k, tol in enumerate((1e-12, 1e-9, 1e-7, 1e-4)):
        assert np.max(np.abs(got[k] - exact[k])) < tol, k
    assert helix.length == 1.0


def test_exact_at_the_samples_and_continuous(helix):
    s = helix.s[1:-1]
    right = helix.evaluate3(s)
    left = helix.evaluate3(s - 1e-13)
    exact = _helix(s)
    for k in range(3):
        np.testing.assert_allclose(right[k], exact[k], atol=1e-12)
        np.testing.assert_allclose(left[k], exact[k], atol=1e-9)


@settings(max_examples=25)
@given(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-0.1, 0.2))
def test_closest_point_against_brute_force(x, y, z):
    s = np.linspace(0.0, 1.0, 51)
    seg = HermiteSegment(s, *_helix(s)[:3])
    dense = np.linspace(0.0, 1.0, 200001)
    d_brute = np.min(np.linalg.norm(seg.evaluate(dense)[0] - [x, y, z], axis=1))
    _, d = seg.closest(np.array([[x, y, z]]))
    assert d[0] <= d_brute + 1e-9
    assert d[0] >= d_brute - 1e-6  # the dense grid's spacing bounds its own error


def test_chains_with_lines_in_a_task_path(helix):
    start = helix.p[0]
    path = TaskPath((Line(start + [0.0, 0.0, -0.1], start), helix))
    assert path.length == pytest.approx(0.1 + 1.0)
    np.testing.assert_allclose(path.evaluate(0.6)[0], helix.evaluate(0.5)[0][0], atol=1e-15)


@pytest.mark.parametrize("bad", ["unsorted", "shape", "nan"])
def test_bad_samples_are_errors(bad):
    s = np.linspace(0.0, 1.0, 5)
    p, dp, ddp = (a.copy() for a in _helix(s)[:3])
    if bad == "unsorted":
        s = s[::-1].copy()
    elif bad == "shape":
        p = p[:, :2]
    else:
        dp[2, 0] = np.nan
    with pytest.raises(PathError, match="segment|samples|finite"):
        HermiteSegment(s, p, dp, ddp, label="segment x")
