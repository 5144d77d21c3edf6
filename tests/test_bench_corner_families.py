"""The knot of benchmarks/corner_families.py (--splits, --knots): a quintic split into two quintics through a knot
state keeps its ends' position, tangent and curvature (G2 with its neighbours) and joins G2 at the knot, for any
knot coordinates; with the knot's coordinates 0 the knot sits on the piece; both checked by BezierSegment's
own evaluation."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion.geometry.segments import BezierSegment

from benchmark_modules import load_benchmark

families = load_benchmark("corner_families")

TOL = 0.01
# a planar corner quintic (60 deg turn) and an offset piece that hardly turns, both rising a little out of the plane
PIECES = (np.array([[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.08, 0.002, 0.001], [0.11, 0.03, 0.001],
                    [0.12, 0.06, 0.0], [0.135, 0.09, 0.0]]),
          np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.04, 0.0, 0.0], [0.06, 0.0004, 0.0002],
                    [0.08, 0.0009, 0.0003], [0.1, 0.0012, 0.0003]]))


def _frames(b: np.ndarray):
    seg = BezierSegment(b)
    return seg.start_frame, seg.end_frame


@settings(max_examples=40, deadline=None)
@given(piece=st.sampled_from(range(len(PIECES))), u=st.floats(0.2, 0.8),
       unit=st.lists(st.floats(0.0, 1.0), min_size=11, max_size=11))
def test_a_knot_keeps_the_pieces_ends_and_joins_g2(piece, u, unit):
    b = PIECES[piece]
    build, box = families._knot(b, u, TOL)
    box = np.array(box)
    y = box[:, 0] + np.array(unit) * (box[:, 1] - box[:, 0])
    left, right = build(y)
    (p0, t0, k0), (p1, t1, k1) = _frames(b)
    (q0, s0, c0), (qm, sm, cm) = _frames(left)
    (rm, um, dm), (q1, s1, c1) = _frames(right)
    for got, want in ((q0, p0), (s0, t0), (c0, k0), (q1, p1), (s1, t1), (c1, k1), (rm, qm), (um, sm), (dm, cm)):
        np.testing.assert_allclose(got, want, atol=1e-9)


def test_with_zero_coordinates_the_knot_is_on_the_piece():
    """The knot at u is the piece's own point and tangent there, evaluated by BezierSegment (not by the de Casteljau
    split the knot is built from)."""
    for b in PIECES:
        build, _ = families._knot(b, 0.4, TOL)
        left, _ = build(np.zeros(11))
        x, dx, _ = BezierSegment(b).curve(np.array([0.4]))
        np.testing.assert_allclose(left[5], x[0], atol=1e-12)
        np.testing.assert_allclose(BezierSegment(left).end_frame[1], dx[0] / np.linalg.norm(dx[0]), atol=1e-12)
