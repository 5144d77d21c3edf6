"""Segments: exact derivatives (vs central differences), arc-length parameterization, closest
points (vs brute force), constructors and degenerate input."""

import numpy as np
import pytest
from geometry_support import central_difference, near_cusp
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.errors import PathError
from pathmotion.geometry import Arc, BezierSegment, Circle, Line

RNG = np.random.default_rng(1234)


def _random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _segments():
    rng = np.random.default_rng(7)
    n = _random_unit(rng)
    c = rng.uniform(-1, 1, 3)
    radial = np.cross(n, _random_unit(rng))
    start = c + 0.3 * radial / np.linalg.norm(radial)
    return [
        Line((0.1, -0.2, 0.3), (0.7, 0.4, -0.1)),
        Arc(c, start, n, 2.0),
        Arc(c, start, n, -4.0),
        Arc.through_points((1.0, 0.0, 0.2), (0.3, 0.8, 0.5), (-0.6, 0.2, 0.9)),
        Circle.horizontal((0.5, 0.0, 0.5), 0.1),
        Circle.from_centre((0.5, 0.0, 0.5), 0.2, (1.0, 1.0, 0.0), start_angle=0.7, direction=-1),
        BezierSegment(np.array([[0, 0, 0], [0.1, 0.02, 0], [0.2, 0.1, 0.05], [0.25, 0.3, 0.1],
                                [0.2, 0.45, 0.2], [0.1, 0.5, 0.3]], float)),
    ]


@pytest.mark.parametrize("seg", _segments(), ids=lambda s: s.kind)
def test_derivatives_match_finite_differences(seg):
    s = np.sort(RNG.uniform(1e-3, seg.length - 1e-3, 25))
    p, dp, ddp = seg.evaluate(s)
    assert p.shape == dp.shape == ddp.shape == (25, 3)
    np.testing.assert_allclose(central_difference(lambda x: seg.evaluate(x)[0], s), dp, atol=1e-9)
    np.testing.assert_allclose(central_difference(lambda x: seg.evaluate(x)[1], s), ddp, atol=1e-8 * max(1, np.abs(ddp).max()))


@pytest.mark.parametrize("seg", _segments(), ids=lambda s: s.kind)
def test_parameter_is_arc_length(seg):
    s = np.linspace(0.0, seg.length, 2001)
    p, dp, _ = seg.evaluate(s)
    np.testing.assert_allclose(np.linalg.norm(dp, axis=1), 1.0, atol=1e-12)
    # the chord sum converges to the length from below (independent of the segment's own length)
    chords = np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))
    assert chords <= seg.length + 1e-12
    assert chords == pytest.approx(seg.length, rel=1e-6)


@pytest.mark.parametrize("seg", _segments(), ids=lambda s: s.kind)
def test_closest_point_matches_brute_force(seg):
    rng = np.random.default_rng(3)
    pts = seg.evaluate(rng.uniform(0, seg.length, 40))[0] + rng.normal(scale=0.2, size=(40, 3))
    grid = seg.evaluate(np.linspace(0, seg.length, 50001))[0]
    brute = np.array([np.min(np.linalg.norm(grid - x, axis=1)) for x in pts])
    s, d = seg.closest(pts)
    assert np.all(d <= brute + 1e-12)
    np.testing.assert_allclose(d, brute, atol=seg.length / 50000)
    np.testing.assert_allclose(np.linalg.norm(seg.evaluate(s)[0] - pts, axis=1), d, atol=1e-12)


def test_arc_geometry_and_sign_convention():
    arc = Arc((0, 0, 0), (1, 0, 0), (0, 0, 1), np.pi / 2)  # right-handed about +z: towards +y
    np.testing.assert_allclose(arc.end_point, [0, 1, 0], atol=1e-15)
    assert arc.length == pytest.approx(np.pi / 2)
    _, t, k = arc.start_frame
    np.testing.assert_allclose(t, [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(k, [-1, 0, 0], atol=1e-15)  # towards the centre, |k| = 1/r
    neg = Arc((0, 0, 0), (1, 0, 0), (0, 0, 1), -np.pi / 2)
    np.testing.assert_allclose(neg.end_point, [0, -1, 0], atol=1e-15)


def test_arc_through_points():
    p0, p1, p2 = np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([-1.0, 0, 0])
    arc = Arc.through_points(p0 + 2, p1 + 2, p2 + 2)
    np.testing.assert_allclose(arc.centre, [2, 2, 2], atol=1e-14)
    assert arc.radius == pytest.approx(1.0)
    assert arc.sweep == pytest.approx(np.pi)
    np.testing.assert_allclose(arc.end_point, p2 + 2, atol=1e-14)
    assert np.min(np.linalg.norm(arc.evaluate(np.linspace(0, arc.length, 1001))[0] - (p1 + 2), axis=1)) < 1e-3
    # through three points going clockwise seen from +z: normal flips, sweep stays positive
    arc2 = Arc.through_points(p0, -p1, p2)
    np.testing.assert_allclose(arc2.normal, [0, 0, -1], atol=1e-15)
    assert np.min(np.linalg.norm(arc2.evaluate(np.linspace(0, arc2.length, 1001))[0] + p1, axis=1)) < 1e-3


def test_circle_constructors():
    c = Circle.horizontal((0.5, 0.0, 0.5), 0.1, start_angle=np.pi / 2)
    np.testing.assert_allclose(c.start_point, [0.5, 0.1, 0.5], atol=1e-15)
    np.testing.assert_allclose(c.end_point, c.start_point, atol=1e-15)
    assert c.length == pytest.approx(2 * np.pi * 0.1)
    np.testing.assert_allclose(c.start_frame[1], [-1, 0, 0], atol=1e-15)  # counter-clockwise from above
    v = Circle.from_centre((0.5, 0.0, 0.6), 0.1, (1.0, 0.0, 0.0))  # vertical, angle from world y
    np.testing.assert_allclose(v.start_point, [0.5, 0.1, 0.6], atol=1e-15)
    pts = v.evaluate(np.linspace(0, v.length, 50))[0]
    np.testing.assert_allclose(pts[:, 0], 0.5, atol=1e-15)
    assert pts[:, 2].max() == pytest.approx(0.7, abs=1e-3)
    assert isinstance(c.trimmed(0.1, 0.2), Arc) and not isinstance(c.trimmed(0.1, 0.2), Circle)


@pytest.mark.parametrize("make, words", [
    (lambda: Line((0, 0, 0), (0, 0, 0)), ["Line", "zero length"]),
    (lambda: Line((0, 0, 0), (np.nan, 0, 0)), ["Line", "NaN"]),
    (lambda: Line((0, 0), (1, 0)), ["Line", "3 numbers"]),
    (lambda: Arc((0, 0, 0), (0, 0, 0), (0, 0, 1), 1.0), ["Arc", "radius"]),
    (lambda: Arc((0, 0, 0), (1, 0, 0), (1, 0, 0), 1.0), ["Arc", "parallel to the radius"]),
    (lambda: Arc((0, 0, 0), (1, 0, 0), (0.3, 0, 1), 1.0), ["Arc", "not in the plane"]),
    (lambda: Arc((0, 0, 0), (1, 0, 0), (0, 0, 1), 0.0), ["Arc", "zero length"]),
    (lambda: Arc((0, 0, 0), (1, 0, 0), (0, 0, 0), 1.0), ["Arc", "normal", "zero length"]),
    (lambda: Arc((0, 0, 0), (1, 0, 0), (0, 0, 1), np.inf), ["Arc", "sweep", "not finite"]),
    (lambda: Arc.through_points((0, 0, 0), (1, 1, 1), (2, 2, 2)), ["collinear"]),
    (lambda: Circle.horizontal((0, 0, 0), 0.0), ["Circle", "radius"]),
    (lambda: Circle.horizontal((0, 0, 0), 0.1, direction=0), ["direction"]),
    (lambda: Circle((0, 0, 0), (1, 0, 0), (0, 0, 1), 1.0), ["Circle", "2 pi"]),
    (lambda: BezierSegment(np.zeros((6, 3))), ["Bezier", "cusp"]),
])
def test_degenerate_input_raises_path_error(make, words):
    with pytest.raises(PathError) as info:
        make()
    for w in words:
        assert w in str(info.value)


def _de_casteljau(points: np.ndarray, u: float) -> np.ndarray:
    """The Bezier curve with control points (n + 1, 3) at u, by repeated linear interpolation."""
    p = np.array(points, float)
    while len(p) > 1:
        p = (1.0 - u) * p[:-1] + u * p[1:]
    return p[0]


@settings(max_examples=60, deadline=None)
@given(points=st.lists(st.tuples(*[st.floats(-1.0, 1.0)] * 3), min_size=6, max_size=6),
       u=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=8))
def test_bezier_power_basis_matches_de_casteljau_and_its_hodographs(points, u):
    """BezierSegment.curve (monomial coefficients by Horner) against an independent evaluation: de Casteljau on
    the control points, and on their hodographs (differences times 5, 4, 3) for X', X'', X'''."""
    b = np.array(points, float)
    coef = BezierSegment._power_basis(b)
    uu = np.array(u)
    got = [BezierSegment._polyval(coef, uu, k) for k in range(4)]
    hodograph = b
    for k in range(4):
        want = np.array([_de_casteljau(hodograph, x) for x in uu])
        np.testing.assert_allclose(got[k], want, rtol=0, atol=1e-12 * 60 ** k)
        hodograph = (len(hodograph) - 1) * np.diff(hodograph, axis=0)


@pytest.mark.parametrize("eps", [0.3, 0.03, 0.003])
def test_curvature_peaks_are_where_a_dense_sample_peaks(eps):
    """Every local maximum of the curvature |p''| on 400001 arc lengths, and only those, is a peak, within two of
    their steps, with the curvature there (the central peak is 0.3 um wide at half height at eps = 0.003: 2049
    samples in u see it, a uniform grid in s would need millions)."""
    seg = near_cusp(eps)
    s = np.linspace(0.0, seg.length, 400001)
    kappa = np.linalg.norm(seg.evaluate(s)[2], axis=1)
    dense = s[1:-1][(kappa[1:-1] >= kappa[:-2]) & (kappa[1:-1] > kappa[2:])]
    peaks = np.array(seg.curvature_peaks)
    assert len(peaks) == len(dense) == 3  # the cusp's and one beyond each inflection
    assert np.all(np.abs(peaks - dense) < 2 * (s[1] - s[0]))
    central = np.linalg.norm(seg.evaluate(peaks[1:2])[2])
    assert central >= kappa.max() * (1 - 1e-6)
    assert central == pytest.approx(2 * 0.05 / (0.1 * eps) ** 2, rel=1e-6)


def test_no_curvature_peaks_on_lines_arcs_and_straight_beziers():
    line = Line([0.4, 0.0, 0.4], [0.6, 0.0, 0.4])
    assert line.curvature_peaks == ()
    assert Arc.through_points([0.4, 0.0, 0.4], [0.5, 0.1, 0.4], [0.6, 0.0, 0.4]).curvature_peaks == ()
    straight = BezierSegment(np.linspace([0.4, 0.0, 0.4], [0.6, 0.0, 0.4], 6))
    assert straight.curvature_peaks == ()


def test_end_frames_are_evaluates_at_the_ends():
    """A line's start and end frames (its own short form) and a blend's (evaluated once) are evaluate's at 0 and at
    the length, to the bit, and a caller changing a returned frame does not change the next one."""
    rng = np.random.default_rng(5)
    for _ in range(100):
        line = Line(rng.normal(size=3), rng.normal(size=3) * 10.0 ** rng.uniform(-4, 1))
        bezier = BezierSegment(np.cumsum(rng.uniform(0.01, 0.1, (6, 3)), axis=0))
        for seg in (line, bezier):
            for _ in range(2):
                for frame, s in ((seg.start_frame, 0.0), (seg.end_frame, seg.length)):
                    for got, want in zip(frame, seg.evaluate(s)):
                        assert np.array_equal(got, want[0])
                        got += 1.0
