"""Batched kinematics of a serial chain of revolute joints: all N configurations at once in numpy.

Pinocchio evaluates one configuration per call, a few microseconds each from Python; a path table of
2001 points spent ~5 ms in those calls per quantity. For a chain whose joints are all one-axis revolute
joints, each the child of the one before, the same quantities follow from N-point array recursions
(world frame, joint i's origin p_i and axis z_i, the frame origin p):

    R_i = R_{i-1} Rp_i Rot(a_i, q_i),  p_i = p_{i-1} + R_{i-1} tp_i,  z_i = R_{i-1} Rp_i a_i
    J column i = [z_i x (p - p_i); z_i]                                   (LOCAL_WORLD_ALIGNED)
    w_i = w_{i-1} + z_i qd_i,  dw_i = dw_{i-1} + w_{i-1} x z_i qd_i       (qdd = 0)
    a_i = a_{i-1} + dw_{i-1} x r_i + w_{i-1} x (w_{i-1} x r_i),  r_i = p_i - p_{i-1}

so Jdot qd (the classical acceleration of the frame at qdd = 0) is (a at p, dw_n). One order higher, with qdd
and zero joint jerk (z_i turns with w_{i-1}, r_i with w_{i-1}):

    dw_i  = dw_{i-1} + (w_{i-1} x z_i) qd_i + z_i qdd_i
    ddw_i = ddw_{i-1} + (dw_{i-1} x z_i + w_{i-1} x (w_{i-1} x z_i)) qd_i + 2 (w_{i-1} x z_i) qdd_i
    j_i   = j_{i-1} + ddw x r + 2 dw x (w x r) + w x (dw x r + w x (w x r))   (body i-1's w, dw, ddw)

so the classical jerk at zero joint jerk, 2 Jdot qdd + Jddot qd, is (j at p, ddw_n). Equal to Pinocchio's
to round-off (tests/test_robot_serial_batch.py). :func:`chain_of` returns None for any other model, and
the callers then use Pinocchio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .joints import REVOLUTE, joint_motion


@dataclass(frozen=True)
class Chain:
    """rot (n, 3, 3), trans (n, 3): each joint's placement in its parent's frame; axis (n, 3) unit rotation
    axes in the joint frames; tool_rot (3, 3), tool_trans (3,): the frame in its joint's frame."""

    rot: np.ndarray
    trans: np.ndarray
    axis: np.ndarray
    tool_rot: np.ndarray
    tool_trans: np.ndarray


def chain_of(model, frame_id: int) -> Chain | None:
    """The serial revolute chain from the base to frame ``frame_id`` of a Pinocchio model, or None when the
    model is not one (another joint type, a branch, joints not moving the frame, nq != nv)."""
    n = model.njoints - 1
    if n < 1 or model.nq != n or model.nv != n or model.frames[frame_id].parentJoint != n:
        return None
    axes = []
    for i in range(1, n + 1):
        joint = model.joints[i]
        motion = joint_motion(joint)
        if model.parents[i] != i - 1 or joint.idx_q != i - 1 or joint.idx_v != i - 1:
            return None
        if motion is None or motion[0] != REVOLUTE:
            return None
        axes.append(motion[1])
    placements = [model.jointPlacements[i] for i in range(1, n + 1)]
    tool = model.frames[frame_id].placement
    return Chain(rot=np.array([m.rotation for m in placements]), trans=np.array([m.translation for m in placements]),
                 axis=np.array(axes, dtype=float), tool_rot=np.array(tool.rotation),
                 tool_trans=np.array(tool.translation))


@numba.njit(cache=True)
def _mul3(a, b, out):
    """out = a @ b for 3 x 3 arrays, written out (numba's @ calls BLAS, slow at this size)."""
    for i in range(3):
        x0, x1, x2 = a[i, 0], a[i, 1], a[i, 2]
        for j in range(3):
            out[i, j] = x0 * b[0, j] + x1 * b[1, j] + x2 * b[2, j]


@numba.njit(cache=True)
def _frames(rot, trans, axis, tool_trans, q):
    """(joint origins (N, n, 3), world joint axes (N, n, 3), frame origin (N, 3)) at q (N, n); compiled, one
    point at a time (no (N, 3, 3) temporaries)."""
    count, n = q.shape
    origins, axes, tip = np.empty((count, n, 3)), np.empty((count, n, 3)), np.empty((count, 3))
    r, m, turn, p = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    for k in range(count):
        r[:] = 0.0
        r[0, 0] = r[1, 1] = r[2, 2] = 1.0
        p[:] = 0.0
        for i in range(n):
            for row in range(3):
                p[row] += r[row, 0] * trans[i, 0] + r[row, 1] * trans[i, 1] + r[row, 2] * trans[i, 2]
            _mul3(r, rot[i], m)
            a0, a1, a2 = axis[i, 0], axis[i, 1], axis[i, 2]
            for row in range(3):
                origins[k, i, row] = p[row]
                axes[k, i, row] = m[row, 0] * a0 + m[row, 1] * a1 + m[row, 2] * a2
            s, c = np.sin(q[k, i]), np.cos(q[k, i])
            t = 1.0 - c  # Rodrigues: c I + s [a]x + (1 - c) a a^T
            turn[0, 0], turn[0, 1], turn[0, 2] = c + t * a0 * a0, t * a0 * a1 - s * a2, t * a0 * a2 + s * a1
            turn[1, 0], turn[1, 1], turn[1, 2] = t * a1 * a0 + s * a2, c + t * a1 * a1, t * a1 * a2 - s * a0
            turn[2, 0], turn[2, 1], turn[2, 2] = t * a2 * a0 - s * a1, t * a2 * a1 + s * a0, c + t * a2 * a2
            _mul3(m, turn, r)
        for row in range(3):
            tip[k, row] = p[row] + r[row, 0] * tool_trans[0] + r[row, 1] * tool_trans[1] + r[row, 2] * tool_trans[2]
    return origins, axes, tip


@numba.njit(cache=True)
def _jacobian(origins, axes, tip):
    """J (N, 6, n): columns [z_i x (p - p_i); z_i] from :func:`_frames`' output."""
    count, n = origins.shape[0], origins.shape[1]
    out = np.empty((count, 6, n))
    for k in range(count):
        for i in range(n):
            z0, z1, z2 = axes[k, i, 0], axes[k, i, 1], axes[k, i, 2]
            r0, r1, r2 = tip[k, 0] - origins[k, i, 0], tip[k, 1] - origins[k, i, 1], tip[k, 2] - origins[k, i, 2]
            out[k, 0, i], out[k, 1, i], out[k, 2, i] = z1 * r2 - z2 * r1, z2 * r0 - z0 * r2, z0 * r1 - z1 * r0
            out[k, 3, i], out[k, 4, i], out[k, 5, i] = z0, z1, z2
    return out


@numba.njit(cache=True)
def _rigid_step(acc, dw, w, r):
    """acc += dw x r + w x (w x r): the acceleration of a point r further on the same body (in place)."""
    c0, c1, c2 = w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]
    acc[0] += dw[1] * r[2] - dw[2] * r[1] + w[1] * c2 - w[2] * c1
    acc[1] += dw[2] * r[0] - dw[0] * r[2] + w[2] * c0 - w[0] * c2
    acc[2] += dw[0] * r[1] - dw[1] * r[0] + w[0] * c1 - w[1] * c0


@numba.njit(cache=True)
def _bias(origins, axes, tip, qd):
    """Jdot qd (N, 6) from :func:`_frames`' output and qd (N, n) (the recursion in the module docstring)."""
    count, n = origins.shape[0], origins.shape[1]
    out = np.empty((count, 6))
    w, dw, acc, r, prev = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(count):
        w[:], dw[:], acc[:], prev[:] = 0.0, 0.0, 0.0, 0.0
        for i in range(n):
            for j in range(3):
                r[j] = origins[k, i, j] - prev[j]
            _rigid_step(acc, dw, w, r)
            t0, t1, t2 = axes[k, i, 0] * qd[k, i], axes[k, i, 1] * qd[k, i], axes[k, i, 2] * qd[k, i]
            dw[0] += w[1] * t2 - w[2] * t1
            dw[1] += w[2] * t0 - w[0] * t2
            dw[2] += w[0] * t1 - w[1] * t0
            w[0], w[1], w[2] = w[0] + t0, w[1] + t1, w[2] + t2
            for j in range(3):
                prev[j] = origins[k, i, j]
        for j in range(3):
            r[j] = tip[k, j] - prev[j]
        _rigid_step(acc, dw, w, r)
        for j in range(3):
            out[k, j], out[k, 3 + j] = acc[j], dw[j]
    return out


@numba.njit(cache=True)
def _cross(a, b, out):
    """out = a x b for 3-vectors (out distinct from a and b)."""
    out[0], out[1], out[2] = a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@numba.njit(cache=True)
def _jerk_step(jerk, ddw, dw, w, r, u, t, s):
    """jerk += ddw x r + 2 dw x (w x r) + w x (dw x r + w x (w x r)): the jerk of a point r further on the
    same body (in place; u, t, s scratch 3-vectors)."""
    _cross(w, r, u)  # w x r
    _cross(dw, r, t)  # dw x r
    _cross(w, u, s)  # w x (w x r)
    for j in range(3):
        t[j] += s[j]
    _cross(w, t, s)
    for j in range(3):
        jerk[j] += s[j]
    _cross(dw, u, s)
    for j in range(3):
        jerk[j] += 2.0 * s[j]
    _cross(ddw, r, s)
    for j in range(3):
        jerk[j] += s[j]


@numba.njit(cache=True)
def _jerk_bias(origins, axes, tip, qd, qdd):
    """2 Jdot qdd + Jddot qd (N, 6) from :func:`_frames`' output, qd and qdd (N, n) (module docstring)."""
    count, n = origins.shape[0], origins.shape[1]
    out = np.empty((count, 6))
    w, dw, ddw, jerk, r, prev = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    z, wz, s, u, t = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(count):
        w[:], dw[:], ddw[:], jerk[:], prev[:] = 0.0, 0.0, 0.0, 0.0, 0.0
        for i in range(n):
            for j in range(3):
                r[j] = origins[k, i, j] - prev[j]
                z[j] = axes[k, i, j]
            _jerk_step(jerk, ddw, dw, w, r, u, t, s)
            v, a = qd[k, i], qdd[k, i]
            _cross(w, z, wz)
            _cross(dw, z, t)
            _cross(w, wz, s)
            for j in range(3):
                ddw[j] += (t[j] + s[j]) * v + 2.0 * wz[j] * a
            for j in range(3):
                dw[j] += wz[j] * v + z[j] * a
                w[j] += z[j] * v
                prev[j] = origins[k, i, j]
        for j in range(3):
            r[j] = tip[k, j] - prev[j]
        _jerk_step(jerk, ddw, dw, w, r, u, t, s)
        for j in range(3):
            out[k, j], out[k, 3 + j] = jerk[j], ddw[j]
    return out


def chain_frames(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joint origins (N, n, 3), world joint axes (N, n, 3), frame origin (N, 3)) [m] of the chain at q (N, n): what
    :func:`jacobian_from` and :func:`bias_from` take, so one configuration batch's frames serve both."""
    return _frames(chain.rot, chain.trans, chain.axis, chain.tool_trans, np.ascontiguousarray(q, float))


def jacobian_from(frames: tuple) -> np.ndarray:
    """LOCAL_WORLD_ALIGNED Jacobians (N, 6, n) of the chain's frame from its :func:`chain_frames`."""
    return _jacobian(*frames)


def bias_from(frames: tuple, qd: np.ndarray) -> np.ndarray:
    """Jdot(q, qd) qd (N, 6) from the chain's :func:`chain_frames` at q and qd (N, n) (acceleration_bias_batch)."""
    return _bias(*frames, np.ascontiguousarray(qd, float))


def jacobian_batch(chain: Chain, q: np.ndarray) -> np.ndarray:
    """LOCAL_WORLD_ALIGNED Jacobians (N, 6, n) of the chain's frame at q (N, n)."""
    return jacobian_from(chain_frames(chain, q))


def acceleration_bias_batch(chain: Chain, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Jdot(q, qd) qd (N, 6) of the chain's frame: its classical acceleration at qdd = 0, linear then angular,
    world axes, at q, qd (N, n)."""
    return bias_from(chain_frames(chain, q), qd)


def jerk_bias_batch(chain: Chain, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """2 Jdot(q, qd) qdd + Jddot(q, qd, qdd) qd (N, 6) of the chain's frame: its classical jerk at zero joint
    jerk (d3p/dt3 of the origin, then d2w/dt2), world axes, at q, qd, qdd (N, n)."""
    frames = _frames(chain.rot, chain.trans, chain.axis, chain.tool_trans, np.ascontiguousarray(q, float))
    return _jerk_bias(*frames, np.ascontiguousarray(qd, float), np.ascontiguousarray(qdd, float))
