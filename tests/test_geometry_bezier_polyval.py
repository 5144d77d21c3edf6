"""The compiled power basis and Horner evaluation of a quintic (geometry/bezier_polyval.py) against numpy's,
operation for operation (the same floats: every blend the search found stays the same), and against the Bernstein form and its
hodographs (an independent evaluation)."""

from math import comb

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.geometry.segments import _DERIVATIVE_FACTORS, _POWER_SCALE, _POWER_SIGNED, BezierSegment


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


def _numpy_power_basis(b):
    """The numpy loop BezierSegment._power_basis ran before it was compiled."""
    acc = np.zeros((6, 3))
    for i in range(6):
        acc = acc + _POWER_SIGNED[:, i, None] * b[i]
    return _POWER_SCALE[:, None] * acc


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


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-4, 1e-2, 1.0, 1e3]))
def test_compiled_power_basis_is_numpy_bit_for_bit(seed, scale):
    """The power basis every blend and its certified deviation bound start from: the same floats as numpy's loop
    (so the blends the search finds stay the same), on contiguous, read-only and strided control points."""
    rng = np.random.default_rng(seed)
    b = scale * rng.normal(size=(6, 3)) + scale * rng.normal(size=3)
    want = _numpy_power_basis(b)
    assert np.array_equal(BezierSegment._power_basis(b), want)
    frozen = b.copy()
    frozen.flags.writeable = False
    assert np.array_equal(BezierSegment._power_basis(frozen), want)
    wide = np.zeros((6, 6))
    wide[:, ::2] = b
    assert np.array_equal(BezierSegment._power_basis(wide[:, ::2]), want)


def _numpy_curvature_squared(coef, u):
    """The numpy form of BezierSegment._curvature_squared: X', X'' by Horner, then Lagrange's identity, the dot
    products summed (x0 y0 + x2 y2) + x1 y1 (as numpy's einsum("ij,ij->i") sums rows of 3 on x86-64)."""
    d1, d2 = _numpy_horner(coef, u, 1), _numpy_horner(coef, u, 2)

    def dot(a, b):
        return (a[:, 0] * b[:, 0] + a[:, 2] * b[:, 2]) + a[:, 1] * b[:, 1]

    g2 = dot(d1, d1)
    return (g2 * dot(d2, d2) - dot(d1, d2) ** 2) / g2 ** 3


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-4, 1e-2, 1.0]), n=st.integers(1, 300))
def test_compiled_curvature_is_numpy_bit_for_bit_and_the_cross_product_form(seed, scale, n):
    """The curvature the peaks of every blend piece are found on: numpy's floats (so grids and durations stay the
    same), and |X' x X''|^2 / |X'|^6 from the Bernstein hodographs (independent)."""
    rng = np.random.default_rng(seed)
    b = scale * rng.normal(size=(6, 3))
    seg_coef = BezierSegment._power_basis(b)
    u = np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, n)])
    got = BezierSegment(b)._curvature_squared(u) if _no_cusp(b) else None
    direct = BezierSegment.__dict__["_curvature_squared"](type("S", (), {"_coef": seg_coef})(), u)
    assert np.array_equal(direct, _numpy_curvature_squared(seg_coef, u))
    if got is not None:
        assert np.array_equal(got, direct)
    d1, d2 = _bernstein(b, u, 1), _bernstein(b, u, 2)
    want = np.sum(np.cross(d1, d2) ** 2, axis=1) / np.sum(d1 ** 2, axis=1) ** 3
    np.testing.assert_allclose(direct, want, rtol=1e-6, atol=1e-9 * np.max(np.abs(want)))


def _no_cusp(b) -> bool:
    try:
        BezierSegment(b)
    except Exception:
        return False
    return True


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-4, 1e-2, 1.0]), n=st.integers(1, 300))
def test_compiled_speed_range_is_numpy_bit_for_bit(seed, scale, n):
    """BezierSegment's cusp check: the slowest speed, its first index and the fastest of numpy's norm of X'
    (summed in the same order, so a curve on the check's edge is refused either way alike)."""
    from pathmotion.geometry import bezier_polyval

    rng = np.random.default_rng(seed)
    coef = BezierSegment._power_basis(scale * rng.normal(size=(6, 3)))
    u = np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, n)])
    speed = np.linalg.norm(BezierSegment._polyval(coef, u, 1), axis=1)
    assert bezier_polyval.speed_range(coef, u, _DERIVATIVE_FACTORS[1]) == (np.min(speed), int(np.argmin(speed)),
                                                                          np.max(speed))


def _numpy_peak_parameters(seg):
    """The numpy rounds BezierSegment.curvature_peaks ran before they were compiled: the parameters u of the peaks."""
    from pathmotion.geometry.segments import PEAK_MIN_CURVATURE, PEAK_REFINE_ROUNDS, PEAK_REFINE_SAMPLES, PEAK_SAMPLES

    u = np.linspace(0.0, 1.0, PEAK_SAMPLES)
    k = seg._curvature_squared(u)
    i = np.nonzero((k[1:-1] >= k[:-2]) & (k[1:-1] > k[2:]) & (k[1:-1] > PEAK_MIN_CURVATURE ** 2))[0] + 1
    at, half = u[i], np.full(i.size, u[1])
    offsets = np.linspace(-1.0, 1.0, PEAK_REFINE_SAMPLES)
    for _ in range(PEAK_REFINE_ROUNDS if i.size else 0):
        trial = np.clip(at[:, None] + half[:, None] * offsets[None, :], 0.0, 1.0)
        best = np.argmax(seg._curvature_squared(trial.ravel()).reshape(trial.shape), axis=1)
        at, half = trial[np.arange(i.size), best], half * 2.0 / (PEAK_REFINE_SAMPLES - 1)
    return at


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.sampled_from([1e-4, 1e-2, 1.0]),
       kind=st.sampled_from(["random", "blend", "nearly straight"]))
def test_compiled_curvature_peaks_are_numpy_bit_for_bit(seed, scale, kind):
    """The peaks every blend piece grades the plan's grid at (one compiled call): numpy's rounds' parameters, the
    same floats (so grids and durations stay the same), on random curves, blend-like corners and nearly straight
    pieces (many rounding-noise maxima, none above the floor)."""
    from pathmotion.geometry import bezier_polyval
    from pathmotion.geometry.segments import _PEAK_OFFSETS, _PEAK_U, PEAK_MIN_CURVATURE, PEAK_REFINE_ROUNDS

    rng = np.random.default_rng(seed)
    if kind == "random":
        b = scale * rng.normal(size=(6, 3))
    elif kind == "blend":
        a = np.radians(rng.uniform(5.0, 175.0))
        side = np.array([np.cos(a), np.sin(a), 0.0])
        b = scale * np.array([[-1.0, 0, 0], [-0.6, 0, 0], [-0.2, 0, 0], 0.2 * side, 0.6 * side, side])
        b += scale * rng.choice([0.0, 1e-3, 0.05]) * rng.normal(size=(6, 3))
    else:
        b = scale * (np.linspace(0.0, 1.0, 6)[:, None] * rng.normal(size=3) + 1e-7 * rng.normal(size=(6, 3)))
    if not _no_cusp(b):
        return
    seg = BezierSegment(b)
    got = bezier_polyval.curvature_peak_parameters(seg._coef, _PEAK_U, _DERIVATIVE_FACTORS[1], _DERIVATIVE_FACTORS[2],
                                                   PEAK_MIN_CURVATURE ** 2, _PEAK_OFFSETS, PEAK_REFINE_ROUNDS, 3.0)
    want = _numpy_peak_parameters(seg)
    assert np.array_equal(got, want)
    assert seg.curvature_peaks == (tuple(float(s) for s in seg._arc_length(want)) if want.size else ())
