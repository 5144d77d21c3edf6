"""Transition circles and G2 blends: analytic deviations, tangency / curvature continuity at the
blend ends, the guaranteed deviation bound (hypothesis, checked by brute force), fit errors."""

import re

import numpy as np
import pytest
from geometry_support import incoming, outgoing
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq
from scipy.spatial import cKDTree

from pathmotion.errors import PathError
from pathmotion.geometry import (Arc, BezierSegment, Line, TaskPath, certified_max, circle_with_radial_line,
                                 circle_with_radial_line_transition,
                                 circle_with_vertical_circle, largest_g2_tolerance, largest_transition_radius,
                                 max_deviation, with_g2_blend, with_g2_blends, with_transition, with_transitions)


def _line_corner(delta: float, length: float = 1.0) -> TaskPath:
    """Two lines of ``length`` meeting at the origin, tangents turning by ``delta`` [rad]."""
    return TaskPath((incoming("line", length, 0, True), outgoing("line", length, 0, True, delta)))


# --- transition circle -------------------------------------------------------------------------
@pytest.mark.parametrize("deg", [20.0, 60.0, 90.0, 135.0, 165.0])
def test_transition_line_line_deviation_is_analytic(deg):
    """Turning angle delta, interior angle phi = pi - delta, fillet radius r. The centre is at
    r / sin(phi/2) from the corner on the bisector; the arc midpoint is farthest from both lines,
    at distance r (1 - sin(phi/2)) = r (1 - cos(delta/2)) from them (r (1/sin(phi/2) - 1) from the
    corner point itself)."""
    delta, r = np.radians(deg), 0.05
    path = _line_corner(delta)
    new = with_transition(path, 0, r)
    phi = np.pi - delta
    dev = max_deviation(new, path)
    expected = r * (1.0 - np.sin(phi / 2))
    assert dev.lower <= expected * (1 + 1e-12) + 1e-15 and expected <= dev.upper * (1 + 1e-12)
    assert dev.upper - dev.lower <= 1e-4 * dev.upper
    arc = new.segments[1]
    mid = arc.evaluate(arc.length / 2)[0][0]
    assert np.linalg.norm(mid) == pytest.approx(r * (1 / np.sin(phi / 2) - 1), rel=1e-12)
    assert isinstance(arc, Arc) and arc.radius == pytest.approx(r, rel=1e-12)
    assert new.segments[0].length == pytest.approx(1.0 - r * np.tan(delta / 2), rel=1e-12)


def test_transition_thesis_circle_line_deviation_and_limit():
    """Horizontal circle (centre O, radius R) then a line from P = O + R x towards O. The fillet
    centre C = (sqrt((R - r)^2 - r^2), -r) relative to O is r from the line and R - r from O. A
    fillet point X is at distance R - |X| from the circle and |X_y| from the line; the largest
    min of the two lies where they are equal (root found with brentq)."""
    R, r = 0.1, 0.04
    path = circle_with_radial_line(radius=R)
    new = with_transition(path, 0, r)
    O = np.array(path.segments[0].centre)
    C = np.array([np.sqrt((R - r) ** 2 - r ** 2), -r])
    np.testing.assert_allclose(new.segments[1].centre, O + [C[0], C[1], 0.0], atol=1e-13)
    a0 = np.arctan2(C[1], C[0])  # fillet starts on the circle (direction O -> C), ends on the line at pi/2

    def point(alpha):
        return C + r * np.array([np.cos(alpha), np.sin(alpha)])

    gap = lambda alpha: (R - np.linalg.norm(point(alpha))) - abs(point(alpha)[1])  # noqa: E731
    alpha = brentq(gap, a0 + 1e-12, np.pi / 2 - 1e-12, xtol=1e-15)
    expected = abs(point(alpha)[1])
    dev = max_deviation(new, path)
    assert dev.lower <= expected * (1 + 1e-12) and expected <= dev.upper * (1 + 1e-12)
    assert expected == pytest.approx(0.018986, abs=1e-6)  # 19 mm for the thesis' r_t = 0.04 m
    thesis = circle_with_radial_line_transition()  # r_t = 0.04 m by default
    np.testing.assert_allclose(thesis.segments[1].centre, new.segments[1].centre, atol=1e-15)
    # the fillet needs |OC| = R - r >= r: the largest radius is R / 2
    assert largest_transition_radius(path, 0) == pytest.approx(R / 2, rel=1e-6)


@pytest.mark.parametrize("name", ["line-line", "line-arc", "arc-line", "arc-arc"])
def test_transition_is_tangent_at_both_ends(name):
    kin, kout = name.split("-")
    path = TaskPath((incoming(kin, 0.5, 0.3, False), outgoing(kout, 0.5, 0.4, True, np.radians(70))))
    new = with_transition(path, 0, 0.05)
    assert [c.kind for c in new.connections] == ["tangent", "tangent"]  # G1: curvature jumps
    for c in new.connections:
        assert c.angle < 1e-9
        assert c.curvature_jump > 1.0
    assert new.segments[1].radius == pytest.approx(0.05, rel=1e-12)
    assert max_deviation(new, path).upper < 0.05


def test_with_transitions_rounds_every_corner_of_a_square():
    pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0.5, 0)]
    sq = TaskPath(tuple(Line(a, b) for a, b in zip(pts[:-1], pts[1:])))
    new = with_transitions(sq, 0.1)
    assert len(new.segments) == 7 and new.kinks == ()
    assert new.length == pytest.approx(sq.length - 3 * 0.1 * (2 - np.pi / 2))
    # the shared middle segments give each corner at most half: r tan(45 deg) <= 0.5 -> r <= 0.5
    with pytest.raises(PathError) as info:
        with_transitions(sq, 0.6)
    r_max = float(re.search(r"largest radius that fits is ([0-9.e-]+) m", str(info.value)).group(1))
    assert r_max == pytest.approx(0.5, rel=1e-5)
    assert len(with_transitions(sq, r_max).segments) == 7
    only = with_transitions(sq, 0.3, corners=[1])
    assert len(only.segments) == 5 and len(only.kinks) == 2


def test_transition_radius_too_large_names_the_corner_and_the_largest_radius():
    path = _line_corner(np.pi / 2, length=0.2)
    with pytest.raises(PathError) as info:
        with_transition(path, 0, 0.5)
    msg = str(info.value)
    assert "connection 0" in msg and "(0, 0, 0)" in msg and "90 deg" in msg
    r_max = float(re.search(r"largest radius that fits is ([0-9.e-]+) m", msg).group(1))
    assert r_max == pytest.approx(0.2, rel=1e-5)  # cut r tan(45 deg) = r <= 0.2
    with_transition(path, 0, r_max)  # and it fits


@pytest.mark.parametrize("make, words", [
    (lambda p: with_transition(p, 0, np.nan), ["positive number"]),
    (lambda p: with_transition(p, 0, -0.1), ["positive number"]),
    (lambda p: with_transition(p, 3, 0.1), ["connection 3 does not exist"]),
    (lambda p: with_g2_blend(p, 0, np.nan), ["positive distance"]),
    (lambda p: with_g2_blend(p, 0, 0.01, shape=0.0), ["shape"]),
])
def test_bad_blend_arguments(make, words):
    with pytest.raises(PathError) as info:
        make(_line_corner(np.pi / 3))
    for w in words:
        assert w in str(info.value)


def test_transition_needs_a_planar_sharp_corner():
    tangent = circle_with_vertical_circle()
    with pytest.raises(PathError, match="is tangent; only corner"):
        with_transition(tangent, 0, 0.01)
    # a horizontal arc followed by a line leaving upwards at 45 deg: not in the arc's plane
    arc = incoming("arc", 0.3, 0.2, True)
    path = TaskPath((arc, Line((0, 0, 0), (0.1, 0.0, 0.1))))
    with pytest.raises(PathError) as info:
        with_transition(path, 0, 0.01)
    assert "not in the corner's plane" in str(info.value) and "with_g2_blend" in str(info.value)
    assert "the planes are 90 deg apart, sine 1 > 1e-09" in str(info.value)  # the arc's and the corner's: how far
    new = with_g2_blend(path, 0, 1e-3)  # the G2 blend works in 3-D
    assert [c.kind for c in new.connections] == ["smooth", "smooth"]


# --- G2 blend ------------------------------------------------------------------------------
def _brute_force_deviation(blend: BezierSegment, original: TaskPath, spacing: float) -> tuple[float, float]:
    """(lower, upper) estimates of the largest distance of ``blend`` from ``original`` by nearest
    neighbours among original points ``spacing`` apart: kd-distance d_k satisfies
    d_k - spacing/2 <= true distance <= d_k. The blend is sampled on its own Bezier parameter."""
    x = blend.curve(np.linspace(0.0, 1.0, 4001))[0]
    reach = np.max(np.linalg.norm(x - x[0], axis=1)) * 3 + spacing
    pts = []
    for seg in original.segments:
        s = np.arange(0.0, seg.length + spacing, spacing)
        p = seg.evaluate(np.minimum(s, seg.length))[0]
        pts.append(p[np.linalg.norm(p - x[0], axis=1) <= 2 * reach])
    d = cKDTree(np.concatenate(pts)).query(x)[0]
    return float(np.max(d) - spacing / 2), float(np.max(d))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kinds=st.sampled_from(["line-line", "line-arc", "arc-line", "arc-arc"]),
       deg=st.floats(10.0, 170.0),
       lengths=st.tuples(st.floats(0.1, 0.6), st.floats(0.1, 0.6)),
       radii=st.tuples(st.floats(0.08, 1.0), st.floats(0.08, 1.0)),
       lefts=st.tuples(st.booleans(), st.booleans()),
       fraction=st.floats(0.02, 0.95))
def test_g2_blend_deviation_never_exceeds_the_tolerance(kinds, deg, lengths, radii, lefts, fraction):
    kin, kout = kinds.split("-")
    la = min(lengths[0], 2.5 * radii[0]) if kin == "arc" else lengths[0]
    lb = min(lengths[1], 2.5 * radii[1]) if kout == "arc" else lengths[1]
    path = TaskPath((incoming(kin, la, radii[0], lefts[0]), outgoing(kout, lb, radii[1], lefts[1], np.radians(deg))))
    tol = fraction * largest_g2_tolerance(path, 0)
    new = with_g2_blend(path, 0, tol)
    lower, upper = _brute_force_deviation(new.segments[1], path, tol / 500)
    assert lower <= tol * (1 + 1e-9)  # guaranteed bound
    assert upper >= 0.99 * tol  # and the blend is as large as the tolerance allows
    # G2 at both ends: tangent and curvature vector continuous
    assert [c.kind for c in new.connections] == ["smooth", "smooth"]


@pytest.mark.parametrize("name", ["line-line", "line-arc", "arc-line", "arc-arc"])
def test_g2_blend_matches_tangent_and_curvature_of_neighbours(name):
    kin, kout = name.split("-")
    path = TaskPath((incoming(kin, 0.5, 0.3, False), outgoing(kout, 0.5, 0.4, True, np.radians(100))))
    new = with_g2_blend(path, 0, 0.004)
    a, blend, b = new.segments
    for (p0, t0, k0), (p1, t1, k1) in ((a.end_frame, blend.start_frame), (blend.end_frame, b.start_frame)):
        np.testing.assert_allclose(p0, p1, atol=1e-13)
        np.testing.assert_allclose(t0, t1, atol=1e-12)
        np.testing.assert_allclose(k0, k1, atol=1e-9)
    # independent check of curvature continuity: finite-difference curvature straddling the joints
    for th in new.breaks:
        k_left = new.evaluate(th - 1e-9, "left")[2]
        k_right = new.evaluate(th + 1e-9)[2]
        np.testing.assert_allclose(k_left, k_right, atol=1e-4)
    dev = max_deviation(new, path, rel_tol=1e-6)
    assert dev.upper <= 0.004 * (1 + 2e-6) and dev.lower >= 0.99 * 0.004


def test_g2_blend_of_the_thesis_tangent_joint():
    path = circle_with_vertical_circle()
    new = with_g2_blend(path, 0, 1e-3)
    assert [c.kind for c in new.connections] == ["smooth", "smooth"]
    blend = (new.breaks[0], new.breaks[1])
    assert max_deviation(new, path, theta_range=blend, rel_tol=1e-6).upper <= 1e-3 * (1 + 2e-6)
    assert len(with_g2_blends(path, 1e-3).segments) == 2  # only sharp corners by default
    assert len(with_g2_blends(path, 1e-3, corners=[0]).segments) == 3


def test_g2_tolerance_too_large_names_the_corner_and_the_largest_tolerance():
    path = _line_corner(np.pi / 2, length=0.1)
    with pytest.raises(PathError) as info:
        with_g2_blend(path, 0, 0.05)
    msg = str(info.value)
    assert "connection 0" in msg and "90 deg" in msg and "too large" in msg
    t_max = float(re.search(r"give a tolerance below ([0-9.e-]+) m", msg).group(1))
    assert t_max == pytest.approx(largest_g2_tolerance(path, 0), rel=1e-5)
    new = with_g2_blend(path, 0, 0.999 * t_max)
    assert new.segments[0].length < 1e-3  # the blend used almost all of the incoming line


def test_g2_blend_is_self_similar_for_line_corners():
    """Scaling a line-line corner scales the blend: the cut is proportional to the tolerance."""
    path = _line_corner(np.radians(75))
    cuts = [1.0 - with_g2_blend(path, 0, tol).segments[0].length for tol in (1e-3, 4e-3)]
    assert cuts[1] / cuts[0] == pytest.approx(4.0, rel=1e-3)


def test_with_g2_blends_on_a_polyline():
    pts = np.array([(0, 0, 0), (0.3, 0, 0), (0.3, 0.2, 0.1), (0.0, 0.3, 0.1), (0.0, 0.3, 0.4)], float)
    path = TaskPath(tuple(Line(a, b) for a, b in zip(pts[:-1], pts[1:])))
    new = with_g2_blends(path, 0.01)
    assert new.kinks == () and all(c.kind == "smooth" for c in new.connections)
    assert max_deviation(new, path, rel_tol=1e-6).upper <= 0.01 * (1 + 2e-6)


def test_certified_max_brackets_an_analytic_maximum():
    fn = lambda x: np.abs(np.sin(7 * x)) * np.exp(-x)  # noqa: E731  max at 7 x = atan(7)
    dev = certified_max(fn, 0.0, 3.0, lipschitz=7.0 + 1.0)
    x_star = np.arctan(7.0) / 7.0
    assert dev.lower <= fn(np.array([x_star]))[0] <= dev.upper
    assert dev.upper - dev.lower <= 1e-4 * dev.upper
    # distance of a parallel line 0.01 m away: exactly 0.01 everywhere
    a = TaskPath((Line((0, 0, 0), (1, 0, 0)),))
    b = TaskPath((Line((0, 0.01, 0), (1, 0.01, 0)),))
    assert max_deviation(a, b).lower == pytest.approx(0.01, rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(threshold=st.floats(0.0, 1.2), frequency=st.floats(1.0, 30.0))
def test_certified_max_stopped_below_a_threshold_answers_as_the_full_refinement(threshold, frequency):
    """The blend sizing asks only 'is the certified maximum <= t?' (stop_below = stop_above = t): the answer
    equals the fully refined bracket's, and a 'yes' is still a certified bound (above the true maximum)."""
    fn = lambda x: np.abs(np.sin(frequency * x)) * np.exp(-x)  # noqa: E731
    x_star = np.arctan(frequency) / frequency  # the maximum
    full = certified_max(fn, 0.0, 3.0, lipschitz=frequency + 1.0)
    quick = certified_max(fn, 0.0, 3.0, lipschitz=frequency + 1.0, stop_above=threshold, stop_below=threshold)
    assert (quick.upper <= threshold) == (full.upper <= threshold)
    assert quick.lower <= fn(np.array([x_star]))[0] <= quick.upper


@pytest.mark.parametrize("radius", [1e-4, 1e-3, 0.00647645, 0.02])
def test_small_transition_radii_fit(radius):
    """Regression: the fillet's Newton solve used a tolerance scaled by the radius, unattainable in
    floating point for small radii, and reported them as not fitting. For the thesis' circle + radial
    line the deviation tends to the line-line value r_t (1 - sin(45 deg)) as r_t / R -> 0 (the
    circle's curvature adds a relative error of order r_t / R, R = 0.1 m)."""
    from pathmotion.geometry import circle_with_radial_line, max_deviation, with_transition

    original = circle_with_radial_line()
    dev = max_deviation(with_transition(original, 0, radius), original).distance
    assert dev == pytest.approx(radius * (1 - np.sin(np.pi / 4)), rel=2 * radius / 0.1 + 1e-3)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), n=st.integers(16, 60), spread=st.floats(1e-3, 0.5))
def test_segment_index_distances_are_those_of_every_segment(seed, n, spread):
    """The indexed distance (balls about segment middles, a k-d tree) equals the minimum over every segment of a
    G2-blended random polyline (lines and quintic blends), for points near and far from it (to rounding: a blend's
    closest point is iterated on the batch of points it is given)."""
    from pathmotion.geometry.deviation import INDEX_MIN_SEGMENTS, SegmentIndex

    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(0.0, 0.05, (n // 2 + 2, 3)), axis=0)
    pts[1::2, 0] += 0.1  # a zigzag: corners a blend of 0.2 mm fits
    pts = np.vstack([pts, pts[-1] + (0.0, 0.6, 0.0)])  # and one long move: balls of very different radii
    try:
        path = with_g2_blends(TaskPath(tuple(Line(a, b) for a, b in zip(pts[:-1], pts[1:]))), 2e-4)
    except PathError:
        assume(False)
    segs = path.segments
    assert len(segs) >= INDEX_MIN_SEGMENTS
    q = path.evaluate(rng.uniform(0.0, path.length, 300))[0] + rng.normal(0.0, spread, (300, 3))
    brute = segs[0].closest(q)[1]
    for seg in segs[1:]:
        brute = np.minimum(brute, seg.closest(q)[1])
    np.testing.assert_allclose(SegmentIndex(segs).distance(q), brute, rtol=1e-12, atol=1e-15)
