"""Ortho-parallel arms with a spherical wrist (OPW): structure detection, FK and closed-form IK.

Kinematic model (Brandstötter, Angerer, Hofbaur 2014, "An analytical solution of the inverse
kinematics problem of industrial serial manipulators with an ortho-parallel basis and a
spherical wrist"), in OPW joint angles t = sign * q + offset (per joint):

    psi3 = atan2(a2, c3),  k = hypot(a2, c3)
    wrist centre in the frame turned by t1:
        cx1 = a1 + c2 sin t2 + k sin(t2 + t3 + psi3),  cy1 = b,
        cz1 = c1 + c2 cos t2 + k cos(t2 + t3 + psi3)
    C = Rz(t1) (cx1, cy1, cz1);   R_0c = Rz(t1) Ry(t2 + t3);   R_0e = R_0c Rz(t4) Ry(t5) Rz(t6)
    TCP: R_tcp = R_0e R_c,  p_tcp = C - R_tcp w   (w: wrist centre in the TCP frame, constant)

Inverse (all angles vectorized over N poses):

    C = p + R w,  rho^2 = Cx^2 + Cy^2,  r = sqrt(rho^2 - b^2)
    shoulder front: cx1 = +r,  back: cx1 = -r;   t1 = atan2(Cy, Cx) - atan2(b, cx1)
    dx = cx1 - a1,  dz = Cz - c1,  s^2 = dx^2 + dz^2
    D = (s^2 - c2^2 - k^2) / (2 c2 k),   t3 = e acos(D) - psi3,   e = +-1
    t2 = atan2(dx, dz) - e acos((s^2 + c2^2 - k^2) / (2 s c2))
    M = R_0c^T R R_c^T = Rz(t4) Ry(t5) Rz(t6):
        t4 = atan2(M23, M13) (+pi for the flipped wrist),  then with M' = Rz(-t4) M:
        t5 = atan2(M'13, M'33),  t6 = atan2(X21, X11) with X = Ry(-t5) M'

Branch index 4 * shoulder + 2 * elbow + wrist: shoulder 0 = front (cx1 > 0), 1 = back;
elbow 0 = up (elbow above the shoulder-wrist line: e = +1 in front, -1 at the back), 1 = down;
wrist 0 = t5 >= 0, 1 = flipped (t5 < 0); :func:`flip_wrist` maps one wrist branch to the other (a path
through t5 = 0 changes wrist branch to stay continuous, see :func:`pathmotion.robot.ik.ik_batch`). Degenerate cases (wrist centre on axis 1, t5 = 0) take
the redundant angle (t1, respectively t4) from a reference, so the solution stays continuous.

The OPW parameters of a robot are extracted from its Pinocchio model at q = 0 (axis directions and
points) and accepted only when the OPW forward kinematics matches Pinocchio's at seeded random
configurations to ``defaults.OPW_TOLERANCE``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import RobotModelError

TWO_PI = 2.0 * np.pi
SHOULDER = ("front", "back")
ELBOW = ("up", "down")
WRIST = ("no flip", "flip")
_REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}


def branch_name(branch: int) -> str:
    """Human-readable name of a branch index 0..7, e.g. 'shoulder front, elbow up, wrist no flip'."""
    return f"shoulder {SHOULDER[branch >> 2]}, elbow {ELBOW[(branch >> 1) & 1]}, wrist {WRIST[branch & 1]}"


@dataclass(frozen=True)
class OPWGeometry:
    """OPW parameters [m] of an arm, with the map from robot joints q to OPW angles t.

    t = sign * q + offset (sign, offset: (6,)); ``tcp_rotation`` R_c (3, 3) with R_tcp = R_0e R_c;
    ``wrist_in_tcp`` (3,) the wrist centre in the TCP frame [m]; ``c4`` the signed distance from the
    wrist centre to the flange along axis 6 [m] (informative: the IK works with the TCP).
    """

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    sign: np.ndarray
    offset: np.ndarray
    tcp_rotation: np.ndarray
    wrist_in_tcp: np.ndarray

    @property
    def k(self) -> float:
        """Distance from axis 3 to the wrist centre [m]."""
        return float(np.hypot(self.a2, self.c3))

    @property
    def psi3(self) -> float:
        return float(np.arctan2(self.a2, self.c3))

    def to_q(self, t: np.ndarray) -> np.ndarray:
        """Robot joint angles (wrapped to [-pi, pi]) from OPW angles t (..., 6)."""
        return wrap(self.sign * (t - self.offset))

    def to_t(self, q: np.ndarray) -> np.ndarray:
        return self.sign * np.asarray(q, float) + self.offset


def flip_wrist(geo: OPWGeometry, q: np.ndarray) -> np.ndarray:
    """The other wrist branch of configurations q (..., 6): t4 + pi, -t5, t6 + pi is the same pose
    (Rz(t4 + pi) Ry(-t5) Rz(t6 + pi) = Rz(t4) Ry(t5) Rz(t6)); joints wrapped to [-pi, pi]."""
    t = geo.to_t(np.asarray(q, float)).copy()
    t[..., 3] += np.pi
    t[..., 4] = -t[..., 4]
    t[..., 5] += np.pi
    return geo.to_q(t)


def wrap(x):
    """Angle(s) wrapped to [-pi, pi]."""
    return x - TWO_PI * np.round(x / TWO_PI)


def rot_z(t: np.ndarray) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(np.shape(t) + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1.0
    return out


def rot_y(t: np.ndarray) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(np.shape(t) + (3, 3))
    out[..., 0, 0], out[..., 0, 2], out[..., 2, 0], out[..., 2, 2], out[..., 1, 1] = c, s, -s, c, 1.0
    return out


def opw_fk(geo: OPWGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TCP position (N, 3) and rotation (N, 3, 3) of configurations q (N, 6) by the OPW model."""
    t = geo.to_t(np.atleast_2d(q))
    t23 = t[:, 1] + t[:, 2]
    cx1 = geo.a1 + geo.c2 * np.sin(t[:, 1]) + geo.k * np.sin(t23 + geo.psi3)
    cz1 = geo.c1 + geo.c2 * np.cos(t[:, 1]) + geo.k * np.cos(t23 + geo.psi3)
    c1, s1 = np.cos(t[:, 0]), np.sin(t[:, 0])
    centre = np.column_stack([c1 * cx1 - s1 * geo.b, s1 * cx1 + c1 * geo.b, cz1])
    r_tcp = rot_z(t[:, 0]) @ rot_y(t23) @ rot_z(t[:, 3]) @ rot_y(t[:, 4]) @ rot_z(t[:, 5]) @ geo.tcp_rotation
    return centre - r_tcp @ geo.wrist_in_tcp, r_tcp


# ----------------------------------------------------------------------------------------------
# Structure detection


def detect_opw(model: pin.Model, tcp_frame_id: int, flange_frame_id: int, lower, upper) -> OPWGeometry:
    """OPW geometry of a Pinocchio model, or RobotModelError saying which condition fails.

    Conditions: 6 revolute joints in a serial chain; axis 1 vertical through the base origin;
    axes 2 and 3 parallel and horizontal; axes 4, 5, 6 meet in one point with 5 normal to 4 and 6;
    axis 4 normal to axis 2. The extracted parameters are then checked against Pinocchio's FK.
    """
    tol = defaults.OPW_TOLERANCE
    if model.nv != 6 or model.nq != 6:
        raise RobotModelError(f"not an OPW arm: {model.nv} joints, the closed form needs 6")
    for j in range(1, 7):
        if model.joints[j].shortname() not in _REVOLUTE or model.parents[j] != j - 1:
            raise RobotModelError(f"not an OPW arm: joint {model.names[j]} is not revolute in a serial chain")
    data = model.createData()
    q0 = np.zeros(6)
    pin.computeJointJacobians(model, data, q0)
    pin.updateFramePlacements(model, data)
    axis = [None] + [np.array(data.J[3:, j - 1]) for j in range(1, 7)]
    point = [None] + [np.array(data.oMi[j].translation) for j in range(1, 7)]
    z = np.array([0.0, 0.0, 1.0])

    def fail(why):
        raise RobotModelError(f"not an OPW arm: {why}")

    if np.linalg.norm(np.cross(axis[1], z)) > tol or np.hypot(point[1][0], point[1][1]) > tol:
        fail("axis 1 is not the vertical axis through the base origin")
    if np.linalg.norm(np.cross(axis[2], axis[3])) > tol or abs(axis[2] @ z) > tol:
        fail("axes 2 and 3 are not parallel and horizontal")
    if abs(axis[4] @ axis[5]) > tol or abs(axis[5] @ axis[6]) > tol:
        fail("axis 5 is not normal to axes 4 and 6")
    # wrist centre: least-squares point of axes 4, 5, 6
    projectors = [np.eye(3) - np.outer(axis[j], axis[j]) for j in (4, 5, 6)]
    centre = np.linalg.solve(sum(projectors), sum(p @ point[j] for p, j in zip(projectors, (4, 5, 6))))
    if max(np.linalg.norm(p @ (centre - point[j])) for p, j in zip(projectors, (4, 5, 6))) > tol:
        fail("axes 4, 5, 6 do not meet in one point (no spherical wrist)")

    y = axis[2] / np.linalg.norm(axis[2])
    x = np.cross(y, z)
    if point[2] @ x < 0:
        x, y = -x, -y
    if abs(axis[4] @ y) > tol:
        fail("axis 4 is not normal to axes 2 and 3")
    s1 = np.sign(axis[1] @ z)
    o1 = np.arctan2(x[1], x[0])
    a1, c1, b = float(point[2] @ x), float(point[2] @ z), float(centre @ y)
    v23 = point[3] - point[2]
    v23 = v23 - (v23 @ y) * y
    c2 = float(np.linalg.norm(v23))
    o2 = np.arctan2(v23 @ x, v23 @ z)
    v3c = centre - point[3]
    v3c = v3c - (v3c @ y) * y
    fore = axis[4] if axis[4] @ v3c >= 0 else -axis[4]
    phi23 = np.arctan2(fore @ x, fore @ z)
    ex = np.cross(y, fore)
    c3, a2 = float(v3c @ fore), float(v3c @ ex)
    r0c = np.column_stack([ex, y, fore])
    w5 = r0c.T @ axis[5]
    o4 = np.arctan2(-w5[0], w5[1])
    w6 = rot_z(o4).T @ r0c.T @ axis[6]
    o5 = np.arctan2(w6[0], w6[2])
    sign = np.array([s1, np.sign(axis[2] @ y), np.sign(axis[3] @ y), np.sign(axis[4] @ fore), 1.0, 1.0])
    offset = np.array([o1, o2, phi23 - o2, o4, o5, 0.0])
    r0e = r0c @ rot_z(o4) @ rot_y(o5)
    tcp = data.oMf[tcp_frame_id]
    flange = data.oMf[flange_frame_id]
    geo = OPWGeometry(
        a1=a1, a2=a2, b=b, c1=c1, c2=c2, c3=c3, c4=float((flange.translation - centre) @ axis[6]),
        sign=sign, offset=offset, tcp_rotation=r0e.T @ tcp.rotation,
        wrist_in_tcp=tcp.rotation.T @ (centre - tcp.translation),
    )
    _check_fk(model, data, geo, tcp_frame_id, lower, upper)
    return geo


def _check_fk(model, data, geo: OPWGeometry, tcp_frame_id: int, lower, upper) -> None:
    rng = np.random.default_rng(defaults.OPW_CHECK_SEED)
    lo = np.maximum(np.asarray(lower, float), -np.pi)
    hi = np.minimum(np.asarray(upper, float), np.pi)
    qs = rng.uniform(lo, hi, size=(defaults.OPW_CHECK_CONFIGURATIONS, 6))
    pos, rot = opw_fk(geo, qs)
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        ref = data.oMf[tcp_frame_id]
        err = max(np.max(np.abs(ref.translation - pos[k])), np.max(np.abs(ref.rotation - rot[k])))
        if err > defaults.OPW_TOLERANCE:
            raise RobotModelError(
                f"not an OPW arm: the extracted OPW model differs from the URDF's forward kinematics by "
                f"{err:.3g} at q = {np.round(q, 4).tolist()}"
            )


# ----------------------------------------------------------------------------------------------
# Closed-form inverse kinematics


@dataclass(frozen=True)
class OPWSolutions:
    """All 8 OPW branches of N poses.

    q (N, 8, 6): robot joint angles wrapped to [-pi, pi] (NaN where the branch does not reach);
    reach_ok (N, 8) bool; centre (N, 3) wrist centre [m]; shoulder_radius (N,) horizontal distance of the wrist centre from axis 1
    minus the offset b [m]; arm_distance (N, 2) shoulder-to-wrist-centre distance in the arm plane for
    the front/back shoulder [m]; sin_wrist (N, 8) sin t5; elbow_angle (N, 2) acos D [rad], half the turn of t3
    between the two elbow branches, for the front/back shoulder.
    """

    q: np.ndarray
    reach_ok: np.ndarray
    centre: np.ndarray
    shoulder_radius: np.ndarray
    arm_distance: np.ndarray
    sin_wrist: np.ndarray
    elbow_angle: np.ndarray


def _rows_rot_z_inv(t: np.ndarray, rows: tuple) -> tuple:
    """Rows of Rz(t)^T M from the rows (each (N, 3)) of M (N, 3, 3), t (N,): element-wise, no stacked 3 x 3
    products."""
    c, s = np.cos(t)[:, None], np.sin(t)[:, None]
    return c * rows[0] + s * rows[1], c * rows[1] - s * rows[0], rows[2]


def _rows_rot_y_inv(t: np.ndarray, rows: tuple) -> tuple:
    """Rows of Ry(t)^T M from the rows (each (N, 3)) of M (N, 3, 3), t (N,)."""
    c, s = np.cos(t)[:, None], np.sin(t)[:, None]
    return c * rows[0] - s * rows[2], rows[1], s * rows[0] + c * rows[2]


def solve(geo: OPWGeometry, positions: np.ndarray, rotations: np.ndarray,
          t1_ref: np.ndarray, t4_ref: np.ndarray, branches=range(8)) -> OPWSolutions:
    """Closed-form IK of N TCP poses, all 8 branches.

    positions (N, 3) [m]; rotations (N, 3, 3); t1_ref, t4_ref (N,) OPW angles used where the
    shoulder (wrist centre on axis 1), respectively the wrist (t5 = 0), is degenerate. Only the
    branches listed in ``branches`` are computed (the others stay NaN / False; a shoulder none of whose branches is
    listed is skipped, its arm_distance and elbow_angle NaN).
    """
    wanted = set(branches)
    n_pts = len(positions)
    centre = positions + rotations @ geo.wrist_in_tcp
    rho2 = centre[:, 0] ** 2 + centre[:, 1] ** 2
    radius = np.sqrt(np.maximum(rho2 - geo.b**2, 0.0))
    shoulder_ok = rho2 - geo.b**2 >= -defaults.IK_REACH_ROUNDING
    k, c2 = geo.k, geo.c2
    dz = centre[:, 2] - geo.c1
    q = np.full((n_pts, 8, 6), np.nan)
    reach_ok = np.zeros((n_pts, 8), dtype=bool)
    sin_wrist = np.full((n_pts, 8), np.nan)
    arm_distance = np.empty((n_pts, 2))
    elbow_angle = np.empty((n_pts, 2))
    g = rotations @ geo.tcp_rotation.T
    g = (g[:, 0], g[:, 1], g[:, 2])  # rows (N, 3) of R R_c^T
    for shoulder in (0, 1):
        if not wanted & set(range(4 * shoulder, 4 * shoulder + 4)):  # none of its branches: its columns stay NaN
            arm_distance[:, shoulder] = elbow_angle[:, shoulder] = np.nan
            continue
        cx1 = radius if shoulder == 0 else -radius
        degenerate = radius < defaults.IK_DEGENERATE
        t1 = np.where(degenerate, t1_ref, np.arctan2(centre[:, 1], centre[:, 0]) - np.arctan2(geo.b, cx1))
        dx = cx1 - geo.a1
        s2 = dx**2 + dz**2
        s = np.sqrt(s2)
        arm_distance[:, shoulder] = s
        cos3 = (s2 - c2**2 - k**2) / (2.0 * c2 * k)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos2 = (s2 + c2**2 - k**2) / (2.0 * s * c2)
        ok = shoulder_ok & (np.abs(cos3) <= 1.0 + defaults.IK_REACH_ROUNDING) & (s > 0)
        acos3 = np.arccos(np.clip(cos3, -1.0, 1.0))
        elbow_angle[:, shoulder] = acos3
        acos2 = np.arccos(np.clip(np.nan_to_num(cos2), -1.0, 1.0))
        gamma = np.arctan2(dx, dz)
        h = _rows_rot_z_inv(t1, g)  # Rz(t1)^T g
        for elbow in (0, 1):
            if not wanted & {4 * shoulder + 2 * elbow, 4 * shoulder + 2 * elbow + 1}:
                continue
            e = (1.0 if elbow == 0 else -1.0) * (1.0 if shoulder == 0 else -1.0)
            t3 = e * acos3 - geo.psi3
            t2 = gamma - e * acos2
            m = _rows_rot_y_inv(t2 + t3, h)  # rows of (Rz(t1) Ry(t2 + t3))^T R R_c^T
            m13, m23 = m[0][:, 2], m[1][:, 2]
            wrist_degenerate = np.hypot(m13, m23) < defaults.IK_DEGENERATE
            t4p = np.where(wrist_degenerate, t4_ref, np.arctan2(m23, m13))
            for wrist in (0, 1):
                br = 4 * shoulder + 2 * elbow + wrist
                if br not in wanted:
                    continue
                t4 = t4p if wrist == 0 else t4p + np.pi
                if wrist == 1:
                    t4 = np.where(wrist_degenerate, t4_ref, t4)
                mp0, mp1, mp2 = _rows_rot_z_inv(t4, m)
                t5 = np.arctan2(mp0[:, 2], mp2[:, 2])
                # the first column of Ry(t5)^T Rz(t4)^T m
                t6 = np.arctan2(mp1[:, 0], np.cos(t5) * mp0[:, 0] - np.sin(t5) * mp2[:, 0])
                t = np.column_stack([t1, t2, t3, t4, t5, t6])
                q[:, br] = np.where(ok[:, None], geo.to_q(t), np.nan)
                reach_ok[:, br] = ok
                sin_wrist[:, br] = np.sin(t5)
    return OPWSolutions(q=q, reach_ok=reach_ok, centre=centre, shoulder_radius=radius, arm_distance=arm_distance,
                        sin_wrist=sin_wrist, elbow_angle=elbow_angle)


def branch_of(geo: OPWGeometry, positions: np.ndarray, rotations: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The branch indices 0..7 (N,) that OPW angles t (N, 6) lie on, for the poses positions (N, 3) [m], rotations
    (N, 3, 3): the shoulder whose t1 is nearer, the elbow from the sign of t3 + psi3, the wrist from the sign of
    sin t5. Exact for solutions of the poses; for other t, the branch they are nearest to by these three angles
    (a guess that :func:`branch_gap` can prove)."""
    centre = positions + rotations @ geo.wrist_in_tcp
    radius = np.sqrt(np.maximum(centre[:, 0] ** 2 + centre[:, 1] ** 2 - geo.b**2, 0.0))
    phi = np.arctan2(centre[:, 1], centre[:, 0])
    front, back = (np.abs(wrap(t[:, 0] - phi + np.arctan2(geo.b, cx1))) for cx1 in (radius, -radius))
    shoulder = (back < front).astype(int)
    e = np.where(wrap(t[:, 2] + geo.psi3) >= 0.0, 1.0, -1.0) * np.where(shoulder == 0, 1.0, -1.0)
    return 4 * shoulder + 2 * (e < 0.0).astype(int) + (np.sin(t[:, 4]) < 0.0).astype(int)


def branch_gap(geo: OPWGeometry, sol: OPWSolutions, branch) -> np.ndarray:
    """(N,) a lower bound [rad] on the joint-space distance (Euclidean, each joint the shorter way round) from
    branch ``branch``'s solution (an index, or one per point (N,)) to any other branch's solution of the same
    pose; 0 where branches may meet.

    The other wrist turns q4 by pi (0 where t5 is degenerate); the other elbow turns q3 by 2 acos D; the other
    shoulder turns q1 by atan2(b, r) - atan2(b, -r) (pi when b = 0; 0 where the shoulder is degenerate). Each
    distance is at least its one joint's turn. Needs ``branch`` computed in ``sol``.
    """
    clear = 1e3 * defaults.IK_DEGENERATE
    points = np.arange(len(sol.q))
    branch = np.broadcast_to(branch, points.shape)
    wrist = np.where(np.abs(sol.sin_wrist[points, branch]) > clear, np.pi, 0.0)
    twice = 2.0 * sol.elbow_angle[points, branch >> 2]
    elbow = np.minimum(twice, TWO_PI - twice)
    r = sol.shoulder_radius
    shoulder = np.where(r > clear, np.abs(wrap(np.arctan2(geo.b, r) - np.arctan2(geo.b, -r))), 0.0)
    return np.minimum(np.minimum(wrist, elbow), shoulder)
