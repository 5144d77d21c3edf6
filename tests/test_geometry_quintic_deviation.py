"""The compiled certified maximum of a quintic's distance from lines (geometry/quintic_deviation.py) against
certified_max over the numpy curve and Line.closest (the same bracket, bit for bit), and against a dense sample
(an independent check of the bracket)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.geometry.deviation import certified_max, distance_to_segments
from pathmotion.geometry.quintic_deviation import bezier_lines_max, bezier_pieces_lines_max, quintic_lines_max
from pathmotion.geometry.segments import BezierSegment, Line

coordinate = st.floats(-0.5, 0.5)
point = st.tuples(coordinate, coordinate, coordinate)


def _numpy_max(coef, lines, lip, **kw):
    return certified_max(lambda u: distance_to_segments(BezierSegment._polyval(coef, u), lines), 0.0, 1.0, lip, **kw)


def _lipschitz(b):
    return 5.0 * float(np.max(np.linalg.norm(np.diff(b, axis=0), axis=1)))


@settings(max_examples=150, deadline=None)
@given(corner=point, ends=st.tuples(point, point), offsets=st.lists(point, min_size=6, max_size=6),
       scale=st.sampled_from([1e-5, 1e-3, 1e-2, 0.1]), stop=st.sampled_from([None, -1e-5, 0.0, 1e-5]))
def test_the_compiled_bracket_is_certified_max_bit_for_bit(corner, ends, offsets, scale, stop):
    """A quintic near a corner of two lines (the blend search's case), with and without the search's early stops
    (a threshold just below, at and just above the true bound): lower, upper and where are the same floats."""
    c = np.array(corner)
    a, e = c + np.array(ends[0]) + 0.01, c + np.array(ends[1]) - 0.01
    lines = (Line(a, c), Line(c, e))
    b = c + scale * np.array(offsets)
    coef, lip = BezierSegment._power_basis(b), _lipschitz(b)
    kw = {}
    if stop is not None:
        threshold = _numpy_max(coef, lines, lip).upper * (1.0 + stop)
        kw = {"stop_above": threshold, "stop_below": threshold}
    want, got = _numpy_max(coef, lines, lip, **kw), quintic_lines_max(coef, lines, lip, **kw)
    assert (got.lower, got.upper, got.theta) == (want.lower, want.upper, want.theta)


@settings(max_examples=150, deadline=None)
@given(corner=point, ends=st.tuples(point, point), offsets=st.lists(st.lists(point, min_size=6, max_size=6),
                                                                    min_size=1, max_size=3),
       scale=st.sampled_from([1e-5, 1e-3, 1e-2, 0.1]), stop=st.sampled_from([None, -1e-5, 0.0, 1e-5]))
def test_the_compiled_power_basis_and_pieces_are_the_numpy_ones_bit_for_bit(corner, ends, offsets, scale, stop):
    """bezier_lines_max (power basis and Lipschitz bound compiled too) against quintic_lines_max on numpy's power
    basis and bound, and bezier_pieces_lines_max against the loop over pieces that blends._pieces_deviation ran
    before (the largest upper bound, stopping once one is above the threshold): the same floats."""
    c = np.array(corner)
    lines = (Line(c + np.array(ends[0]) + 0.01, c), Line(c, c + np.array(ends[1]) - 0.01))
    pieces = [c + scale * np.array(o) for o in offsets]
    kw = {}
    if stop is not None:
        threshold = bezier_lines_max(pieces[0], lines).upper * (1.0 + stop)
        kw = {"stop_above": threshold, "stop_below": threshold}
    upper = 0.0
    for b in pieces:
        want = quintic_lines_max(BezierSegment._power_basis(b), lines, _lipschitz(b), **kw)
        got = bezier_lines_max(b, lines, **kw)
        assert (got.lower, got.upper, got.theta) == (want.lower, want.upper, want.theta)
        upper = max(upper, want.upper)
        if upper > kw.get("stop_above", np.inf):
            break
    assert bezier_pieces_lines_max(np.array(pieces), lines, **kw) == upper


def _independent_distance(x, lines):
    """Distance of points x (N, 3) from the nearest line: the projection through numpy's BLAS dot and norm."""
    out = np.full(len(x), np.inf)
    for line in lines:
        t = line.direction
        s = np.clip((x - line.start) @ t, 0.0, line.length)
        out = np.minimum(out, np.linalg.norm(line.start + s[:, None] * t - x, axis=1))
    return out


@settings(max_examples=60, deadline=None)
@given(corner=point, ends=st.tuples(point, point), offsets=st.lists(point, min_size=6, max_size=6))
def test_the_compiled_bracket_holds_on_a_dense_sample(corner, ends, offsets):
    """The bracket against an independent evaluation: the distance at ``where`` is ``lower``, no point of a
    20001-sample of the curve is farther than ``upper``, and the bracket is as narrow as asked (1e-4)."""
    c = np.array(corner)
    lines = (Line(c + np.array(ends[0]) + 0.01, c), Line(c, c + np.array(ends[1]) - 0.01))
    b = c + 0.02 * np.array(offsets)
    coef = BezierSegment._power_basis(b)
    got = quintic_lines_max(coef, lines, _lipschitz(b))
    at_where = _independent_distance(BezierSegment._polyval(coef, np.array([got.theta])), lines)[0]
    assert abs(at_where - got.lower) <= 1e-15 + 1e-12 * got.lower
    dense = _independent_distance(BezierSegment._polyval(coef, np.linspace(0.0, 1.0, 20001)), lines)
    assert dense.max() <= got.upper * (1.0 + 1e-12) + 1e-15
    assert got.upper - got.lower <= 1e-4 * got.upper + 1e-15


@settings(max_examples=40, deadline=None)
@given(corner=point, ends=st.tuples(point, point), tolerance=st.floats(1e-6, 1e-2),
       shape=st.sampled_from([0.3, 0.7, 1.0]), fraction=st.sampled_from([0.5, 1.0 - 1e-6]))
def test_the_compiled_g2_sizing_is_the_search_over_g2_deviation_bit_for_bit(corner, ends, tolerance, shape, fraction):
    """g2_lines_cut (the G2 blend's sizing at a line-line corner in one compiled call) against blends._largest
    over g2_deviation's certified bound (numpy control points, one compiled bound per check): the same cut, and
    the blend with that cut is within the tolerance by a bound computed afresh."""
    from pathmotion.geometry import blends
    from pathmotion.geometry.quintic_deviation import g2_lines_cut

    c = np.array(corner)
    A, B = Line(c + np.array(ends[0]) + 0.01, c), Line(c, c + np.array(ends[1]) - 0.01)
    start = fraction * min(A.length, B.length)

    def ok(cut):
        return blends.g2_deviation(A, B, cut, shape, stop_above=tolerance, stop_below=tolerance).upper <= tolerance

    want = blends._largest(ok, start, bisections=36)
    got = g2_lines_cut((A, B), shape, tolerance, start, bisections=36)
    assert got == want
    if got > 0.0:
        assert blends.g2_deviation(A, B, got, shape).upper <= tolerance
