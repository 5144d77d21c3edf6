"""The joint-space lift q = Phi(theta): checked against forward kinematics, finite differences and
independent continuity; bad paths raise errors naming where."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pathmotion.errors import PathError, UnreachableError
from pathmotion.geometry import (FixedOrientation, Line, TaskPath, circle_with_radial_line, circle_with_vertical_circle,
                                 horizontal_circle, with_g2_blend, with_transition)
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.lift.constraint import lift
from pathmotion.robot import fk

PATHS = {
    "circle": lambda: horizontal_circle(),
    "corner": lambda: circle_with_radial_line(),
    "vertical": lambda: circle_with_vertical_circle(),
    "transition": lambda: with_transition(circle_with_radial_line(), 0, 0.04),
    "g2": lambda: with_g2_blend(circle_with_radial_line(), 0, 0.005),
}


@pytest.fixture(scope="module", params=sorted(PATHS))
def lifted(request, irb140):
    task = PATHS[request.param]()
    return task, lift(irb140, task)


def test_fk_of_phi_is_the_task_path(lifted, irb140):
    task, path = lifted
    theta = np.random.default_rng(1).uniform(*task.domain, 10_000)
    q = path(theta)
    pos, rot = fk(irb140, q)
    p_task, _, _, r_task, _, _ = task.pose(theta)
    assert np.abs(pos - p_task).max() < 1e-9
    assert np.abs(rot - r_task).max() < 1e-9


def test_derivatives_match_central_differences(lifted):
    task, path = lifted
    lo, hi = task.domain
    h = 1e-5
    theta = np.random.default_rng(2).uniform(lo + 2 * h, hi - 2 * h, 500)
    breaks = np.asarray(task.breaks)
    if breaks.size:  # keep the difference stencil inside one segment
        theta = theta[np.min(np.abs(theta[:, None] - breaks[None, :]), axis=1) > 3 * h]
    q, dq, ddq = path.evaluate(theta)
    qp, dqp, _ = path.evaluate(theta + h)
    qm, dqm, _ = path.evaluate(theta - h)
    np.testing.assert_allclose(dq, (qp - qm) / (2 * h), atol=1e-7 * max(1.0, np.abs(dq).max()))
    np.testing.assert_allclose(ddq, (dqp - dqm) / (2 * h), atol=1e-5 * max(1.0, np.abs(ddq).max()))


def test_branch_never_flips_and_joints_stay_continuous(lifted, irb140):
    task, path = lifted
    theta = np.linspace(*task.domain, 20_001)
    q, dq, _ = path.evaluate(theta)
    step = np.abs(np.diff(q, axis=0))
    # a continuous Phi moves at most |Phi'| dtheta between neighbours (plus a corner's jump in Phi', not in Phi)
    bound = np.maximum(np.abs(dq[:-1]), np.abs(dq[1:])) * np.diff(theta)[:, None] * 1.01 + 1e-12
    assert np.all(step <= bound + 1e-6)
    assert np.all(q >= irb140.limits.lower - 1e-12) and np.all(q <= irb140.limits.upper + 1e-12)


def test_evaluation_order_does_not_matter(lifted):
    task, path = lifted
    theta = np.random.default_rng(3).uniform(*task.domain, 300)
    order = np.argsort(theta)
    np.testing.assert_array_equal(path(theta)[order], path(theta[order]))
    np.testing.assert_allclose(path(theta[5]), path(theta)[5], atol=1e-15)


def test_corners_are_reported_as_kinks(irb140):
    task = circle_with_radial_line()
    path = lift(irb140, task)
    assert path.kinks == pytest.approx((2 * np.pi * 0.1,))
    left = path.evaluate(path.kinks[0], side="left")[1]
    right = path.evaluate(path.kinks[0], side="right")[1]
    assert np.linalg.norm(left - right) > 0.1  # Phi' really jumps there
    assert lift(irb140, with_g2_blend(task, 0, 0.005)).kinks == ()


def test_check_reports_singularity_margin_and_range_margin(irb140):
    path = lift(irb140, horizontal_circle())
    assert path.check.min_singular_value > 0.05
    assert 0 <= path.check.min_singular_theta <= path.length
    assert path.check.range_margin > 0 and path.check.range_margin_joint in irb140.joint_names


def test_unreachable_point_names_theta_and_segment(irb140):
    far = TaskPath((Line((0.5, 0.0, 0.5), (1.2, 0.0, 0.5)),))
    with pytest.raises(UnreachableError, match=r"theta = 0\.\d+ m \(segment 1\).*reach"):
        lift(irb140, far)


def test_path_near_the_wrist_singularity_is_refused_as_a_flip(irb140):
    # tool held horizontal (its orientation at the zero pose) while the TCP rises 1 mm beside the line
    # through the zero pose (q5 = 0 there): q5 comes within ~3e-3 rad of 0 without crossing it, so q4
    # and q6 would turn by ~pi (a path exactly through it is lifted: tests/test_lift_wrist.py)
    rot = fk(irb140, np.zeros(6))[1]
    beside = TaskPath((Line((0.515, 0.001, 0.65), (0.515, 0.001, 0.78)),), FixedOrientation(rot))
    with pytest.raises(UnreachableError, match=r"theta = 0\.06\d+ m .*wrist singularity.*wrist flip"):
        lift(irb140, beside)


def test_start_configuration_with_wrong_size_is_an_error(irb140):
    with pytest.raises(PathError, match="6 joints"):
        lift(irb140, horizontal_circle(), q_start=np.zeros(3))


@settings(max_examples=25, deadline=None)
@given(st.floats(0.35, 0.6), st.floats(-0.2, 0.2), st.floats(0.25, 0.7), st.floats(0.03, 0.12))
def test_random_reachable_circles_lift_exactly(irb140, cx, cy, cz, radius):
    task = horizontal_circle(centre=(cx, cy, cz), radius=radius)
    try:
        path = lift(irb140, task)
    except UnreachableError:
        return  # some random circles leave the workspace or meet a singularity: that is allowed
    theta = np.linspace(*task.domain, 257)
    assert np.abs(fk(irb140, path(theta))[0] - task.evaluate(theta)[0]).max() < 1e-9


def test_joint_spline_derivatives_match_differences():
    wp = np.random.default_rng(42).uniform(-1.5, 1.5, size=(5, 6))
    path = SplineJointPath.from_waypoints(wp)
    np.testing.assert_allclose(path(np.linspace(0, 1, 5)), wp, atol=1e-14)
    _, d0, _ = path.evaluate(np.array([0.0, 1.0]))
    np.testing.assert_allclose(d0, 0.0, atol=1e-12)  # clamped ends
    theta = np.linspace(0.01, 0.99, 50)
    h = 1e-6
    q, dq, ddq = path.evaluate(theta)
    np.testing.assert_allclose(dq, (path(theta + h) - path(theta - h)) / (2 * h), atol=1e-6)


def test_joint_spline_rejects_bad_waypoints():
    with pytest.raises(PathError, match="identical"):
        SplineJointPath.from_waypoints([[0, 0], [0, 0], [1, 1]])
    with pytest.raises(Exception, match="NaN"):
        SplineJointPath.from_waypoints([[0, np.nan], [1, 1]])


def test_the_least_singular_values_are_the_full_decompositions():
    """smallest_singular_values_where_least (the lift's singularity check) gives numpy's smallest singular value at
    every point it decomposes and the same least value and first place over each mask as the full decomposition, on
    smooth joint paths through and away from the wrist singularity (some the check's dense kind, some coarse)."""
    from pathmotion.lift.constraint import smallest_singular_values_where_least
    from pathmotion.robot import jacobian, load_robot

    robot = load_robot("irb140")
    rng = np.random.default_rng(7)
    for trial in range(60):
        n = int(rng.integers(5, 400))
        t = np.linspace(0.0, 1.0, n)[:, None]
        q0, q1 = rng.uniform(-1.0, 1.0, 6), rng.uniform(-1.0, 1.0, 6)
        if trial % 3 == 0:
            q0[4], q1[4] = -0.3, 0.3  # through q5 = 0
        q = q0 + (q1 - q0) * t * (0.05 if trial % 2 else 1.0) + 0.2 * np.sin(3.0 * t * rng.uniform(1.0, 4.0, 6))
        jac = jacobian(robot, q)
        masks = (np.ones(n, bool), rng.uniform(size=n) > 0.3)
        got = smallest_singular_values_where_least(jac, masks)
        full = np.linalg.svd(jac, compute_uv=False)[:, -1]
        done = np.isfinite(got)
        assert np.array_equal(got[done], full[done])
        for mask in masks:
            want, have = np.where(mask, full, np.inf), np.where(mask, got, np.inf)
            assert np.argmin(have) == np.argmin(want) and np.min(have) == np.min(want)
