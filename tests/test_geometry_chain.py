"""TaskPath: one coordinate over the chain, derivatives at any theta, sides at breaks, connection
classification, closed paths and bad input."""

import numpy as np
import pytest
from geometry_support import central_difference, interior_thetas

from pathmotion.errors import PathError
from pathmotion.geometry import (Arc, Circle, Line, TaskPath, circle_with_radial_line, circle_with_vertical_circle,
                                 horizontal_circle, with_g2_blend, with_transition)


def _mixed_chain() -> TaskPath:
    """Line -> tangent arc (tangent joint) -> line at a corner -> out-of-plane line (corner)."""
    a = Line((0, 0, 0), (0.3, 0, 0))
    b = Arc((0.3, 0.2, 0), (0.3, 0, 0), (0, 0, 1), np.pi / 2)  # ends at (0.5, 0.2, 0) heading +y
    c = Line(b.end_point, b.end_point + (0.0, 0.0, 0.2))
    d = Line(c.end_point, c.end_point + (0.1, 0.1, 0.0))
    return TaskPath((a, b, c, d))


def _paths():
    base = circle_with_radial_line()
    return {
        "mixed": _mixed_chain(),
        "circle": horizontal_circle(),
        "circle+line": base,
        "circle+vertical": circle_with_vertical_circle(),
        "transition": with_transition(base, 0, 0.04),
        "g2": with_g2_blend(base, 0, 0.005),
        "g2-3d": with_g2_blend(_mixed_chain(), 2, 0.01),
    }


PATHS = _paths()


@pytest.mark.parametrize("name", PATHS)
def test_chain_derivatives_match_finite_differences(name):
    path = PATHS[name]
    th = interior_thetas(path, 40, seed=11)
    p, dp, ddp = path.evaluate(th)
    assert p.shape == (len(th), 3)
    np.testing.assert_allclose(central_difference(lambda x: path.evaluate(x)[0], th), dp, atol=1e-9)
    np.testing.assert_allclose(central_difference(lambda x: path.evaluate(x)[1], th), ddp,
                               atol=1e-8 * max(1.0, np.abs(ddp).max()))
    np.testing.assert_allclose(np.linalg.norm(dp, axis=1), 1.0, atol=1e-12)  # theta is arc length


@pytest.mark.parametrize("name", [k for k, p in PATHS.items() if p.breaks])
def test_position_continuous_at_breaks_and_sides(name):
    path = PATHS[name]
    br = np.asarray(path.breaks)
    left, right = path.evaluate(br, side="left")[0], path.evaluate(br, side="right")[0]
    np.testing.assert_allclose(left, right, atol=1e-12)
    np.testing.assert_array_equal(path.segment_index(br, "right"), np.arange(1, len(br) + 1))
    np.testing.assert_array_equal(path.segment_index(br, "left"), np.arange(0, len(br)))
    # side="left" at a break continues the preceding segment: one-sided differences agree
    h = 1e-6
    fd_left = (path.evaluate(br, "left")[0] - path.evaluate(br - h)[0]) / h
    np.testing.assert_allclose(fd_left, path.evaluate(br, "left")[1], atol=1e-4)
    fd_right = (path.evaluate(br + h)[0] - path.evaluate(br, "right")[0]) / h
    np.testing.assert_allclose(fd_right, path.evaluate(br, "right")[1], atol=1e-4)


def test_scalar_and_vector_shapes_and_domain():
    path = PATHS["mixed"]
    p, dp, ddp = path.evaluate(0.1)
    assert p.shape == dp.shape == ddp.shape == (3,)
    np.testing.assert_allclose(p, [0.1, 0, 0])
    pose = path.pose(np.array([0.0, path.length]))
    assert [x.shape for x in pose] == [(2, 3), (2, 3), (2, 3), (2, 3, 3), (2, 3), (2, 3)]
    assert path.domain == (0.0, pytest.approx(0.3 + 0.1 * np.pi + 0.2 + np.sqrt(0.02)))
    assert path.segment_index(0.1) == 0
    with pytest.raises(PathError, match="outside the path's range"):
        path.evaluate(path.length + 1e-3)
    with pytest.raises(PathError, match="NaN"):
        path.evaluate(np.nan)
    with pytest.raises(PathError, match="side"):
        path.evaluate(0.1, side="middle")


def test_connection_classification_known_cases():
    conns = PATHS["mixed"].connections
    assert [c.kind for c in conns] == ["tangent", "corner", "corner"]
    assert conns[0].angle == pytest.approx(0.0, abs=1e-12)
    assert conns[0].curvature_jump == pytest.approx(1 / 0.2)
    assert conns[1].angle == pytest.approx(np.pi / 2)
    assert conns[2].angle == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(conns[1].position, [0.5, 0.2, 0.0], atol=1e-15)
    assert PATHS["mixed"].kinks == (conns[1].theta, conns[2].theta)
    assert conns[1].theta == pytest.approx(0.3 + 0.1 * np.pi)

    # 30 degree line-line corner
    t = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0])
    c = TaskPath((Line((-1, 0, 0), (0, 0, 0)), Line((0, 0, 0), t))).connections[0]
    assert c.kind == "corner" and c.angle == pytest.approx(np.pi / 6)

    # smooth: a line continued by a line, an arc continued by the same circle
    straight = TaskPath((Line((0, 0, 0), (1, 0, 0)), Line((1, 0, 0), (2, 0, 0))))
    assert straight.connections[0].kind == "smooth" and straight.kinks == ()
    arc1 = Arc((0, 0, 0), (1, 0, 0), (0, 0, 1), 1.0)
    arc2 = Arc((0, 0, 0), arc1.end_point, (0, 0, 1), 1.0)
    assert TaskPath((arc1, arc2)).connections[0].kind == "smooth"

    # thesis cases
    corner = PATHS["circle+line"].connections[0]
    assert corner.kind == "corner" and corner.angle == pytest.approx(np.pi / 2)
    tangent = PATHS["circle+vertical"].connections[0]
    assert tangent.kind == "tangent" and tangent.curvature_jump == pytest.approx(np.hypot(10.0, 10.0))


def test_closed_paths():
    assert PATHS["circle"].closed and PATHS["circle"].closure.kind == "smooth"
    assert not PATHS["circle+line"].closed and PATHS["circle+line"].closure is None
    assert PATHS["circle+vertical"].closed and PATHS["circle+vertical"].closure.kind == "tangent"
    square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 0)]
    sq = TaskPath(tuple(Line(a, b) for a, b in zip(square[:-1], square[1:])))
    assert sq.closed and sq.closure.kind == "corner" and sq.closure.angle == pytest.approx(np.pi / 2)
    assert sq.breaks == (1.0, 2.0, 3.0) and sq.kinks == (1.0, 2.0, 3.0)


def test_segments_that_do_not_meet_raise():
    a = Line((0, 0, 0), (1, 0, 0))
    b = Line((1, 0.01, 0), (2, 0, 0))
    with pytest.raises(PathError) as info:
        TaskPath((a, b))
    msg = str(info.value)
    assert "segments 0" in msg and "and 1" in msg and "gap 0.01 m" in msg and "Line (1, 0.01, 0)" in msg


def test_bad_chain_input():
    with pytest.raises(PathError, match="at least one segment"):
        TaskPath(())
    with pytest.raises(PathError, match="not a path segment"):
        TaskPath((Line((0, 0, 0), (1, 0, 0)), "arc"))
    with pytest.raises(PathError, match="connection 5 does not exist"):
        PATHS["mixed"].connection(5)


def test_circle_chain_positions():
    path = PATHS["circle+line"]
    np.testing.assert_allclose(path.evaluate(np.pi * 0.1)[0], [0.4, 0.0, 0.5], atol=1e-15)
    np.testing.assert_allclose(path.evaluate(path.length)[0], [0.5, 0.0, 0.5], atol=1e-15)
    assert isinstance(path.segments[0], Circle)


@pytest.mark.parametrize("side", ["right", "left"])
def test_stacked_evaluation_is_each_segments_own_bit_for_bit(side):
    """TaskPath.evaluate evaluates lines and blends stacked (one compiled call for every blend): at unsorted thetas,
    the breaks and points beyond a segment's ends (clipped), the same floats as each segment's own evaluate."""
    path = with_g2_blend(with_g2_blend(with_g2_blend(_mixed_chain(), 2, 0.01), 1, 0.01), 0, 0.005)
    assert {type(s).__name__ for s in path.segments} == {"Line", "Arc", "BezierSegment"}
    rng = np.random.default_rng(3)
    th = np.concatenate([rng.uniform(0.0, path.length, 3000), path.offsets, np.linspace(0, path.length, 517)])
    got = path.evaluate(th, side)
    k = path.segment_index(th, side)
    for i in range(len(th)):
        want = path.segments[k[i]].evaluate(np.array([th[i] - path.offsets[k[i]]]))
        for g, w in zip(got, want):
            assert np.array_equal(g[i], w[0])


def test_cross3_is_numpy_cross_bit_for_bit():
    """classify's angle between tangents: chain.cross3 gives np.cross's floats (so connections' angles and kinds
    stay the same)."""
    from pathmotion.geometry.chain import cross3

    rng = np.random.default_rng(3)
    for scale in (1e-8, 1.0, 1e6):
        for _ in range(2000):
            a, b = rng.normal(size=3) * scale, rng.normal(size=3)
            assert np.array_equal(cross3(a, b), np.cross(a, b))
    assert np.array_equal(cross3((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), (0.0, 0.0, 1.0))
