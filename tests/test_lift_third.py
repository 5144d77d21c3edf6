"""The exact third derivatives: segments p''', slerp orientation d2w/dtheta2, the TCP jerk bias and the
lift's Phi''' against central finite differences of the (independently computed) second derivatives."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pathmotion import defaults
from pathmotion.lift.constraint import lift, tcp_jerk_bias
from pathmotion.geometry import (Arc, Line, SlerpOrientation, TaskPath, circle_with_radial_line,
                                 circle_with_vertical_circle, horizontal_circle, with_g2_blend, with_transition)
from pathmotion.lift.joint_path import SplineJointPath

H = 1e-5  # finite-difference step [m of theta]
# central differences of the second derivative: truncation ~ H^2 |Phi^(5)| / 6, rounding ~ eps |Phi''| / H;
# both are below 2e-6 of max |Phi'''| on these paths, so 1e-5 relative leaves margin and still catches
# any missing term (each term of Phi''' is of order 1e-2..1 of the maximum)
RTOL = 1e-5


def _rotating_circle():
    down = np.array(defaults.TOOL_DOWN_ROTATION)
    tilt = [Rotation.from_rotvec(v).as_matrix() @ down for v in ([0, 0, 0], [0.2, -0.1, 0.3], [-0.1, 0.25, -0.2])]
    base = horizontal_circle()
    keys = (0.0, 0.3 * base.length, base.length)
    return TaskPath(base.segments, SlerpOrientation(keys, np.array(tilt)))


def _line_arc():
    line = Line((0.4, -0.1, 0.5), (0.5, -0.1, 0.5))
    arc = Arc((0.5, 0.0, 0.5), (0.5, -0.1, 0.5), (0.0, 0.0, 1.0), np.pi / 2)
    return TaskPath((line, arc))


PATHS = {
    "circle": horizontal_circle,
    "vertical": circle_with_vertical_circle,
    "line_arc": _line_arc,
    "transition": lambda: with_transition(circle_with_radial_line(), 0, 0.04),
    "g2": lambda: with_g2_blend(circle_with_radial_line(), 0, 0.005),
    "rotating": _rotating_circle,
}


def _inside(task, theta, width):
    """theta away from every break and orientation key (the third derivative may jump there)."""
    marks = np.concatenate([np.asarray(task.breaks), np.asarray(task.tool_orientation.key_thetas())])
    if marks.size == 0:
        return theta
    return theta[np.min(np.abs(theta[:, None] - marks[None, :]), axis=1) > width]


def _check(exact, fd):
    scale = max(1.0, float(np.abs(exact).max()))
    err = float(np.abs(exact - fd).max())
    assert err <= RTOL * scale, f"max |exact - fd| = {err:.3g}, {err / scale:.2g} of max |exact| = {scale:.4g}"


@pytest.mark.parametrize("name", sorted(PATHS))
def test_task_path_third_derivatives_match_differences(name):
    task = PATHS[name]()
    lo, hi = task.domain
    theta = _inside(task, np.random.default_rng(4).uniform(lo + 3 * H, hi - 3 * H, 400), 3 * H)
    p, dp, ddp, dddp, rot, w, dw, ddw = task.pose3(theta)
    np.testing.assert_array_equal(np.concatenate([p, dp, ddp]), np.concatenate(task.evaluate(theta)))
    _check(dddp, (task.evaluate(theta + H)[2] - task.evaluate(theta - H)[2]) / (2 * H))
    _check(ddw, (task.orientation(theta + H)[2] - task.orientation(theta - H)[2]) / (2 * H))
    if name == "rotating":
        assert np.abs(ddw).max() > 1.0  # the orientation really turns, so its term is tested


def test_tcp_jerk_bias_is_the_time_derivative_of_the_classical_acceleration(irb140):
    # along q(t) = q0 + v t + a t^2 / 2 (zero joint jerk) the TCP's classical acceleration is
    # J(q) a + Jdot(q, qd) qd; its time derivative at t = 0 is what tcp_jerk_bias returns
    from pathmotion.robot import frame_acceleration_bias, jacobian

    rng = np.random.default_rng(5)
    for _ in range(5):
        q0, v, a = rng.uniform(-1.5, 1.5, 6), rng.normal(size=6), rng.normal(size=6)

        def acc(t):
            q, qd = q0 + v * t + 0.5 * a * t * t, v + a * t
            return jacobian(irb140, q) @ a + frame_acceleration_bias(irb140, q, qd)

        h = 1e-4
        _check(tcp_jerk_bias(irb140, q0, v, a)[0], (acc(h) - acc(-h)) / (2 * h))


@pytest.fixture(scope="module", params=sorted(PATHS))
def lifted(request, irb140):
    task = PATHS[request.param]()
    return task, lift(irb140, task)


def test_phi_third_matches_differences_of_phi_second(lifted):
    task, path = lifted
    lo, hi = task.domain
    theta = _inside(task, np.random.default_rng(6).uniform(lo + 3 * H, hi - 3 * H, 200), 3 * H)
    q, dq, ddq, dddq = path.evaluate3(theta)
    ref = path.evaluate(theta)
    for mine, theirs in zip((q, dq, ddq), ref):
        np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-12)
    _check(dddq, (path.evaluate(theta + H)[2] - path.evaluate(theta - H)[2]) / (2 * H))


def test_phi_third_scalar_and_sides_at_a_break(irb140):
    task = with_transition(circle_with_radial_line(), 0, 0.04)
    path = lift(irb140, task)
    b = task.breaks[0]
    left, right = path.evaluate3(b, side="left")[3], path.evaluate3(b, side="right")[3]
    assert left.shape == (6,)
    # the curvature jumps at the transition's ends, so Phi''' differs on the two sides ...
    assert np.linalg.norm(left - right) > 1e-3 * np.linalg.norm(right)
    # ... and each side is the limit from its own segment
    _check(left, path.evaluate3(b - 1e-9, side="left")[3])
    _check(right, path.evaluate3(b + 1e-9, side="right")[3])


def test_joint_spline_third_derivative():
    wp = np.random.default_rng(7).uniform(-1.0, 1.0, (6, 6))
    path = SplineJointPath.from_waypoints(wp)
    knots = np.linspace(0.0, 1.0, len(wp))
    theta = np.random.default_rng(8).uniform(3 * H, 1 - 3 * H, 300)
    theta = theta[np.min(np.abs(theta[:, None] - knots[None, :]), axis=1) > 3 * H]
    q, dq, ddq, dddq = path.evaluate3(theta)
    _check(dddq, (path.evaluate(theta + H)[2] - path.evaluate(theta - H)[2]) / (2 * H))
    # at an interior knot the two sides are the one-sided limits (a cubic spline's Phi''' jumps there)
    k = knots[2]
    _check(path.evaluate3(k, side="left")[3], path.evaluate3(k - 1e-9)[3])
    _check(path.evaluate3(k, side="right")[3], path.evaluate3(k + 1e-9)[3])
    assert np.abs(path.evaluate3(k, side="left")[3] - path.evaluate3(k, side="right")[3]).max() > 1e-3
