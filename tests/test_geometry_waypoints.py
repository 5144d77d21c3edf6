"""Waypoint paths: CSV and array input, blends within tolerance, orientation interpolated
along the path with derivatives checked by finite differences, and named errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import pathmotion as pm
from pathmotion.errors import PathError, ScenarioError, UnreachableError
from pathmotion.geometry import max_deviation, waypoint_path
from pathmotion.io.waypoints import load_waypoints_csv, parse_waypoints_csv
from pathmotion.robot import fk, load_robot

# An L-shaped route in front of the IRB140 (reachable with the tool down), three corners.
POINTS = np.array([[0.45, -0.10, 0.50], [0.55, -0.10, 0.50], [0.55, 0.10, 0.50], [0.55, 0.10, 0.40],
                   [0.45, 0.12, 0.40]])
FD_STEP = 1e-5  # [m of theta], central differences: truncation ~ step^2 * |f'''| / 6


def _csv(tmp_path, text, name="points.csv"):
    f = tmp_path / name
    f.write_text(text)
    return f


def _scenario(tmp_path, path_lines: str) -> str:
    text = "[path]\ntype = \"waypoints\"\n" + path_lines + "\n"
    (tmp_path / "s.toml").write_text(text)
    return str(tmp_path / "s.toml")


def _rotations_along(n):
    """Tool down, then turned about world z and tilted: one rotation per waypoint."""
    down = np.diag([1.0, -1.0, -1.0])
    angles = np.linspace(0.0, 0.6, n)
    tilt = np.linspace(0.0, 0.2, n)
    return np.stack([Rotation.from_euler("zy", [a, b]).as_matrix() @ down for a, b in zip(angles, tilt)])


def test_csv_round_trip_passes_through_every_waypoint(tmp_path):
    rows = "\n".join(",".join(f"{v:.6f}" for v in p) for p in POINTS)
    _csv(tmp_path, "# a comment line\nx, y, z\n" + rows + "\n\n")
    setup = pm.load(_scenario(tmp_path, 'file = "points.csv"'))
    task = setup.task_path
    assert len(task.segments) == len(POINTS) - 1 and len(task.kinks) == len(POINTS) - 2
    theta = np.asarray(task.offsets)
    q = setup.path(theta, side="left")
    pos = fk(setup.robot, q)[0]
    assert np.max(np.abs(pos - POINTS)) < 1e-9  # FK(Phi(theta_k)) is waypoint k
    # the same from an array through the API
    same = pm.waypoint_path(POINTS)
    assert np.allclose(same.offsets, task.offsets, atol=1e-15)


def test_blend_tolerance_rounds_every_corner_within_it():
    tol = 0.005
    blended = waypoint_path(POINTS, blend_tolerance=tol)
    sharp = waypoint_path(POINTS)
    assert blended.kinks == () and len(sharp.kinks) == 3
    kinds = [c.kind for c in blended.connections]
    assert "corner" not in kinds
    dev = max_deviation(blended, sharp).distance
    assert 0.9 * tol < dev <= tol * (1 + 1e-9)  # each blend uses the tolerance, none exceeds it
    # the ends stay at the first and last waypoints
    assert np.allclose(blended.evaluate(0.0)[0], POINTS[0])
    assert np.allclose(blended.evaluate(blended.length)[0], POINTS[-1])


def test_quaternion_and_rpy_columns_give_the_same_rotations(tmp_path):
    rots = _rotations_along(len(POINTS))
    quat = Rotation.from_matrix(rots).as_quat()[:, [3, 0, 1, 2]]  # w, x, y, z
    rpy = Rotation.from_matrix(rots).as_euler("ZYX")[:, ::-1]  # roll, pitch, yaw
    q_text = "x,y,z,qw,qx,qy,qz\n" + "\n".join(",".join(str(float(v)) for v in [*p, *q]) for p, q in zip(POINTS, quat))
    r_text = "yaw,pitch,roll,z,y,x\n" + "\n".join(",".join(str(float(v)) for v in [r[2], r[1], r[0], p[2], p[1], p[0]])
                                                 for p, r in zip(POINTS, rpy))
    pq, oq = load_waypoints_csv(_csv(tmp_path, q_text, "q.csv"))
    pr, orr = load_waypoints_csv(_csv(tmp_path, r_text, "r.csv"))
    assert np.allclose(pq, POINTS) and np.allclose(pr, POINTS)
    path_q, path_r = waypoint_path(pq, oq), waypoint_path(pr, orr)
    for path in (path_q, path_r):
        r_at, _, _ = path.orientation(np.asarray(path.offsets))
        assert np.max(np.abs(r_at - rots)) < 1e-12


def test_orientation_derivatives_match_finite_differences():
    path = waypoint_path(POINTS, _rotations_along(len(POINTS)), blend_tolerance=0.004)
    theta = np.linspace(0.01, path.length - 0.01, 37)
    r, w, dw, ddw = path.tool_orientation.evaluate3(theta)
    rp, wp, dwp, _ = path.tool_orientation.evaluate3(theta + FD_STEP)
    rm, wm, dwm, _ = path.tool_orientation.evaluate3(theta - FD_STEP)
    w_fd = np.array([Rotation.from_matrix(a @ b.T).as_rotvec() for a, b in zip(rp, rm)]) / (2 * FD_STEP)
    assert np.max(np.abs(w)) > 0.5  # the tool does turn
    assert np.max(np.abs(w_fd - w)) < 1e-6 * max(1.0, np.max(np.abs(w)))
    assert np.max(np.abs((wp - wm) / (2 * FD_STEP) - dw)) < 1e-5 * max(1.0, np.max(np.abs(dw)))
    assert np.max(np.abs((dwp - dwm) / (2 * FD_STEP) - ddw)) < 1e-4 * max(1.0, np.max(np.abs(ddw)))


def test_lift_includes_the_turning_tool():
    """Phi', Phi'' and Phi''' of the IRB140 lift against finite differences on a blended waypoint path
    whose tool turns, and FK(Phi) against the path's pose (position and rotation)."""
    robot = load_robot("irb140")
    path = waypoint_path(POINTS, _rotations_along(len(POINTS)), blend_tolerance=0.004)
    jp = pm.lift(robot, path)
    theta = np.linspace(0.02, path.length - 0.02, 29)
    q, dq, ddq, dddq = jp.evaluate3(theta)
    pos, rot = fk(robot, q)
    p_path, _, _, r_path, _, _ = path.pose(theta)
    assert np.max(np.abs(pos - p_path)) < 1e-9 and np.max(np.abs(rot - r_path)) < 1e-9
    hi = jp.evaluate3(theta + FD_STEP)
    lo = jp.evaluate3(theta - FD_STEP)
    for k, deriv in enumerate((dq, ddq, dddq)):
        fd = (hi[k] - lo[k]) / (2 * FD_STEP)
        assert np.max(np.abs(fd - deriv)) < 1e-5 * max(1.0, np.max(np.abs(deriv))), k


def test_csv_errors_name_line_and_column(tmp_path):
    with pytest.raises(ScenarioError, match=r"line 3, column y: 'abc' is not a number"):
        parse_waypoints_csv("x,y,z\n0.1,0.2,0.3\n0.2,abc,0.3\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"line 3, column z: 'nan' is not a finite number"):
        parse_waypoints_csv("x,y,z\n0.1,0.2,0.3\n0.2,0.1,nan\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"line 2 has 2 values"):
        parse_waypoints_csv("x,y,z\n0.1,0.2\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"no column\(s\) \['z'\]"):
        parse_waypoints_csv("x,y\n0.1,0.2\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"unknown column\(s\) \['w'\]"):
        parse_waypoints_csv("x,y,z,w\n0.1,0.2,0.3,1\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"orientation column\(s\) \['qz'\] missing"):
        parse_waypoints_csv("x,y,z,qw,qx,qy\n0.1,0.2,0.3,1,0,0\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"line 2, columns qw, qx, qy, qz: the quaternion has norm 2"):
        parse_waypoints_csv("x,y,z,qw,qx,qy,qz\n0.1,0.2,0.3,2,0,0,0\n0.2,0.2,0.3,1,0,0,0\n", "points.csv")
    with pytest.raises(ScenarioError, match=r"1 waypoint\(s\); a path needs at least 2"):
        parse_waypoints_csv("x,y,z\n0.1,0.2,0.3\n", "points.csv")
    with pytest.raises(ScenarioError, match="does not exist"):
        load_waypoints_csv(tmp_path / "missing.csv")
    with pytest.raises(ScenarioError, match="waypoint file .* is a folder"):
        load_waypoints_csv(tmp_path)
    # a byte-order mark (spreadsheet export) is not part of the first column's name
    points, _ = parse_waypoints_csv("\ufeffx,y,z\n0.1,0.2,0.3\n0.2,0.2,0.3\n", "points.csv")
    assert points.shape == (2, 3)


def test_path_errors_name_the_waypoint():
    with pytest.raises(PathError, match="at least 2 waypoints"):
        waypoint_path(POINTS[:1])
    with pytest.raises(PathError, match="waypoints 1 and 2 are the same point"):
        waypoint_path(np.vstack([POINTS[:2], POINTS[1:]]))
    bad = POINTS.copy()
    bad[2, 1] = np.nan
    with pytest.raises(PathError, match="waypoint 2 .* NaN"):
        waypoint_path(bad)
    with pytest.raises(PathError, match="3 orientations for 5 waypoints"):
        waypoint_path(POINTS, _rotations_along(3))
    with pytest.raises(PathError, match="blend_tolerance must be a distance >= 0"):
        waypoint_path(POINTS, blend_tolerance=-1.0)
    with pytest.raises(PathError, match="give a tolerance below"):
        waypoint_path(POINTS, blend_tolerance=0.5)


def test_unreachable_waypoint_is_named(tmp_path):
    far = POINTS.copy()
    far[3] = [1.6, 0.1, 0.4]  # beyond the IRB140's reach (0.81 m)
    rows = "\n".join(",".join(str(float(v)) for v in p) for p in far)
    _csv(tmp_path, "x,y,z\n" + rows + "\n")
    with pytest.raises(UnreachableError, match=r"path.file points.csv: between waypoints 2 and 3: .*out of reach"):
        pm.load(_scenario(tmp_path, 'file = "points.csv"'))


def test_scenario_keys(tmp_path):
    with pytest.raises(ScenarioError, match="exactly one"):
        pm.load(_scenario(tmp_path, "points = [[0.5, 0.0, 0.5], [0.6, 0.0, 0.5]]\nfile = \"p.csv\""))
    setup = pm.load(_scenario(tmp_path, "points = [[0.5, 0.0, 0.5], [0.6, 0.0, 0.5], [0.6, 0.1, 0.5]]\n"
                                        "blend_tolerance = 0.002"))
    assert setup.original_task_path is not None and setup.task_path.kinks == ()
    _csv(tmp_path, "x,y,z,roll,pitch,yaw\n0.5,0,0.5,3.14159,0,0\n0.6,0,0.5,3.14159,0,0.1\n")
    with pytest.raises(ScenarioError, match="must not be given too"):
        pm.load(_scenario(tmp_path, 'file = "points.csv"\norientation = "down"'))


def test_a_reversal_stays_sharp_with_a_warning_and_the_other_corners_are_blended(caplog):
    """A point the route turns back from (a pick point approached and left along the same line) cannot be
    rounded: blend_tolerance rounds every other corner and leaves that one sharp (the motion stops there)."""
    points = np.array([[0.45, -0.10, 0.50], [0.55, -0.10, 0.50], [0.55, 0.10, 0.50], [0.55, 0.0, 0.50],
                       [0.45, 0.05, 0.50]])
    tol = 0.004
    with caplog.at_level("WARNING", logger="pathmotion"):
        blended = waypoint_path(points, blend_tolerance=tol, where="path.points")
    sharp = waypoint_path(points)
    assert len(sharp.kinks) == 3 and len(blended.kinks) == 1
    reversal = float(np.sum(np.linalg.norm(np.diff(points[:3], axis=0), axis=1)))  # arc length to waypoint 2
    assert sharp.kinks[1] == pytest.approx(reversal)  # the reversal is waypoint 2, and it stays sharp:
    assert np.allclose(blended.evaluate(blended.kinks[0])[0], points[2], atol=1e-12)
    assert max_deviation(blended, sharp).distance <= tol * (1 + 1e-9)
    assert [r.levelname for r in caplog.records] == ["WARNING"]
    assert "path.points: the path turns back" in caplog.text and "(0.55, 0.1, 0.5)" in caplog.text


def test_an_optimal_blend_needs_a_blend_tolerance(tmp_path):
    with pytest.raises(ScenarioError, match="blend = \"optimal\" needs blend_tolerance > 0"):
        pm.load(_scenario(tmp_path, 'points = [[0.5, 0.0, 0.5], [0.6, 0.0, 0.5], [0.6, 0.1, 0.5]]\nblend = "optimal"'))
    with pytest.raises(ScenarioError, match="blend"):
        pm.load(_scenario(tmp_path, 'points = [[0.5, 0.0, 0.5], [0.6, 0.0, 0.5]]\nblend_tolerance = 0.001\n'
                                    'blend = "circle"'))
