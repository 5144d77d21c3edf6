"""Tool orientation: default tool-down, slerp keys with C2 time-scaling, derivatives vs finite
differences, key remapping when a blend changes the length, bad input."""

import numpy as np
import pytest
from geometry_support import central_difference
from scipy.spatial.transform import Rotation

from pathmotion import defaults
from pathmotion.errors import PathError
from pathmotion.geometry import (FixedOrientation, SlerpOrientation, TaskPath, circle_with_radial_line,
                                 horizontal_circle, smoothstep5, with_g2_blend, with_transition)


def _skew_vector(m):
    return 0.5 * np.stack([m[:, 2, 1] - m[:, 1, 2], m[:, 0, 2] - m[:, 2, 0], m[:, 1, 0] - m[:, 0, 1]], axis=1)


def _keyed_path() -> TaskPath:
    base = horizontal_circle()
    L = base.length
    rots = Rotation.from_euler("xyz", [[180, 0, 0], [160, 20, 30], [200, -10, 90], [180, 0, 0]], degrees=True)
    return TaskPath(base.segments, SlerpOrientation((0.0, 0.2 * L, 0.55 * L, L), rots.as_matrix()))


def test_default_orientation_points_tool_down():
    path = horizontal_circle()
    R, w, dw = path.orientation(np.array([0.0, 0.3]))
    np.testing.assert_allclose(R[:, :, 2], [[0, 0, -1]] * 2)
    np.testing.assert_allclose(R[0], np.array(defaults.TOOL_DOWN_ROTATION))
    assert np.all(w == 0) and np.all(dw == 0)
    assert np.linalg.det(R[0]) == pytest.approx(1.0)


def test_smoothstep_is_c2_at_the_ends():
    s, ds, dds = smoothstep5(np.array([0.0, 1.0]))
    np.testing.assert_array_equal(s, [0.0, 1.0])
    np.testing.assert_array_equal(ds, [0.0, 0.0])
    np.testing.assert_array_equal(dds, [0.0, 0.0])
    tau = np.linspace(0.1, 0.9, 9)
    np.testing.assert_allclose(central_difference(lambda x: smoothstep5(x)[0], tau, 1e-4), smoothstep5(tau)[1], atol=1e-10)
    np.testing.assert_allclose(central_difference(lambda x: smoothstep5(x)[1], tau, 1e-4), smoothstep5(tau)[2], atol=1e-9)


def test_slerp_derivatives_match_finite_differences():
    path = _keyed_path()
    th = np.random.default_rng(5).uniform(1e-3, path.length - 1e-3, 60)
    R, w, dw = path.orientation(th)
    dR = central_difference(lambda x: path.orientation(x)[0], th)
    # dR/dtheta = [w]x R  <=>  dR R^T = [w]x
    np.testing.assert_allclose(_skew_vector(np.einsum("nij,nkj->nik", dR, R)), w, atol=1e-8)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", dR, R), -np.transpose(np.einsum("nij,nkj->nik", dR, R), (0, 2, 1)), atol=1e-8)
    np.testing.assert_allclose(central_difference(lambda x: path.orientation(x)[1], th), dw, atol=1e-7 * max(1.0, np.abs(dw).max()))
    assert np.abs(w).max() > 1.0  # the test path really rotates


def test_slerp_hits_keys_and_is_continuous_there():
    path = _keyed_path()
    keys = np.array(path.tool_orientation.thetas)
    R, w, dw = path.orientation(keys)
    np.testing.assert_allclose(R, path.tool_orientation.rotations, atol=1e-12)
    np.testing.assert_allclose(w, 0.0, atol=1e-15)
    np.testing.assert_allclose(dw, 0.0, atol=1e-15)
    dw_max = np.abs(path.orientation(np.linspace(0, path.length, 2001))[2]).max()
    eps = 1e-7
    for k in keys[1:-1]:
        a, b = path.orientation(np.array([k - eps, k + eps]))[1:]
        assert np.abs(a).max() < 1e-9 and np.abs(b).max() < 1e-4 * dw_max  # w ~ eps^2, dw ~ eps
    Rp = path.orientation(np.linspace(0, path.length, 500))[0]
    np.testing.assert_allclose(np.einsum("nji,njk->nik", Rp, Rp), np.broadcast_to(np.eye(3), (500, 3, 3)), atol=1e-12)


def test_keys_are_remapped_when_a_blend_changes_the_length():
    base = circle_with_radial_line()
    L = base.length
    rots = Rotation.from_euler("x", [[180], [150], [200]], degrees=True).as_matrix()
    path = TaskPath(base.segments, SlerpOrientation((0.1, 0.3, L), rots))
    for new in (with_transition(path, 0, 0.04), with_g2_blend(path, 0, 0.005)):
        th = new.tool_orientation.thetas
        assert th[:2] == (0.1, 0.3)  # before the blended stretch
        assert th[2] == pytest.approx(new.length)  # the last key stays at the end
        np.testing.assert_allclose(new.orientation(new.length)[0], rots[2], atol=1e-12)


@pytest.mark.parametrize("make, words", [
    (lambda: FixedOrientation(np.eye(3) * 2), ["not a proper rotation"]),
    (lambda: FixedOrientation(np.diag([1.0, 1.0, -1.0])), ["not a proper rotation"]),
    (lambda: FixedOrientation(np.full((3, 3), np.nan)), ["NaN"]),
    (lambda: SlerpOrientation((0.0, 0.0), np.stack([np.eye(3)] * 2)), ["increase strictly", "key 1"]),
    (lambda: SlerpOrientation((0.0, 1.0), np.stack([np.eye(3)])), ["one 3x3 rotation per key"]),
    (lambda: SlerpOrientation((0.0, 1.0), np.stack([np.eye(3), np.diag([1.0, -1.0, -1.0])])), ["half turn"]),
    (lambda: TaskPath(horizontal_circle().segments, SlerpOrientation((0.0, 5.0), np.stack([np.eye(3)] * 2))),
     ["outside the path's range"]),
])
def test_bad_orientation_input(make, words):
    with pytest.raises(PathError) as info:
        make()
    for w in words:
        assert w in str(info.value)
