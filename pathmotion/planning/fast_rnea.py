"""Batched inverse dynamics compiled with numba, for the planner's reduced dynamics and certification.

Pinocchio has no batched call from Python: robot/dynamics.py loops over its C++ RNEA, and at a few
microseconds of Python overhead per call the three calls per grid point of the reduced dynamics
(planning/reduced.py) dominated the planner's time with torque limits (issue 14). This module runs the
same recursive Newton-Euler algorithm (Featherstone's, in each body's frame, as Pinocchio does)
over all points in one compiled loop, and the three coefficient sets share one pass of kinematics.

Supported models: chains and trees of one-degree-of-freedom revolute and prismatic joints (any axis),
with the joint armature of ``model.armature`` on the diagonal (as Pinocchio's ``rnea``). Any other
joint type (:func:`supported` is False) falls back to Pinocchio, point by point.
tests/test_planning_fast_rnea.py compares every output with Pinocchio's ``rnea``.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

#: Pinocchio joint short names handled here: revolute (kind 0) or prismatic (kind 1) and their axis.
_JOINTS = {"JointModelRX": (0, (1.0, 0.0, 0.0)), "JointModelRY": (0, (0.0, 1.0, 0.0)),
           "JointModelRZ": (0, (0.0, 0.0, 1.0)), "JointModelPX": (1, (1.0, 0.0, 0.0)),
           "JointModelPY": (1, (0.0, 1.0, 0.0)), "JointModelPZ": (1, (0.0, 0.0, 1.0))}
_UNALIGNED = {"JointModelRevoluteUnaligned": 0, "JointModelPrismaticUnaligned": 1}


@dataclass(frozen=True, eq=False)
class ChainData:
    """The model as arrays for the kernels; bodies 1 .. B in Pinocchio's order (parent before child).
    parent (B,) (0: the base), kind (B,) (0 revolute, 1 prismatic), axis (B, 3), placement R (B, 3, 3)
    and p (B, 3) of each joint in its parent's frame, mass (B,), com (B, 3) and inertia about the com
    (B, 3, 3) in the body frame, armature (B,), gravity (3,) [m/s^2]."""

    parent: np.ndarray
    kind: np.ndarray
    axis: np.ndarray
    rot: np.ndarray
    pos: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    armature: np.ndarray
    gravity: np.ndarray


_CACHE: dict[int, ChainData | None] = {}


def chain_data(model) -> ChainData | None:
    """The kernels' view of a Pinocchio ``model`` (computed once per model), or None when a joint type
    is not supported."""
    key = id(model)
    if key not in _CACHE:
        _CACHE[key] = _extract(model)
        weakref.finalize(model, _CACHE.pop, key, None)
    return _CACHE[key]


def _extract(model) -> ChainData | None:
    nb = model.njoints - 1
    if nb < 1 or model.nq != nb or model.nv != nb:
        return None
    kind, axis = np.zeros(nb, np.int64), np.zeros((nb, 3))
    for b in range(nb):
        joint = model.joints[b + 1]
        name = joint.shortname()
        if joint.idx_v != b:
            return None
        if name in _JOINTS:
            kind[b], axis[b] = _JOINTS[name][0], _JOINTS[name][1]
        elif name in _UNALIGNED:
            kind[b] = _UNALIGNED[name]
            axis[b] = np.asarray(joint.extract().axis, float)
        else:
            return None
    inert = [model.inertias[b + 1] for b in range(nb)]
    place = [model.jointPlacements[b + 1] for b in range(nb)]
    return ChainData(np.array([model.parents[b + 1] for b in range(nb)], np.int64), kind, axis,
                     np.array([np.asarray(m.rotation) for m in place]), np.array([np.asarray(m.translation) for m in place]),
                     np.array([float(i.mass) for i in inert]), np.array([np.asarray(i.lever) for i in inert]),
                     np.array([np.asarray(i.inertia) for i in inert]), np.asarray(model.armature, float).copy(),
                     np.asarray(model.gravity.linear, float).copy())


def supported(robot) -> bool:
    """True when the robot's model runs on the compiled kernels."""
    return chain_data(robot.model) is not None


def rnea_batch(robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """tau = M(q) qdd + C(q, qd) qd + G(q) [N m] (N, n) at N points (q, qd, qdd (N, n)), compiled."""
    c = chain_data(robot.model)
    q, qd, qdd = (np.ascontiguousarray(np.atleast_2d(a), dtype=float) for a in (q, qd, qdd))
    out = np.empty_like(q)
    _rnea_kernel(c.parent, c.kind, c.axis, c.rot, c.pos, c.mass, c.com, c.inertia, c.armature, c.gravity,
                 q, qd, qdd, out)
    return out


def reduced_batch(robot, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(alpha, beta, gamma) (N, n) of the reduced dynamics (planning/reduced.py) at N path points,
    q = Phi, dq = Phi', ddq = Phi'' (N, n): alpha = M Phi', beta = M Phi'' + C(Phi, Phi') Phi',
    gamma = G, from one pass of kinematics per point."""
    c = chain_data(robot.model)
    q, dq, ddq = (np.ascontiguousarray(np.atleast_2d(a), dtype=float) for a in (q, dq, ddq))
    alpha, beta, gamma = (np.empty_like(q) for _ in range(3))
    _reduced_kernel(c.parent, c.kind, c.axis, c.rot, c.pos, c.mass, c.com, c.inertia, c.armature, c.gravity,
                    q, dq, ddq, alpha, beta, gamma)
    return alpha, beta, gamma


@njit(cache=True)
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True)
def _joint_rotation(kind, axis, angle, rot0, out):
    """out = rot0 @ R(axis, angle) for a revolute joint, rot0 for a prismatic one (3, 3)."""
    if kind != 0:
        out[:, :] = rot0
        return
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    x, y, z = axis[0], axis[1], axis[2]
    r00, r01, r02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
    r10, r11, r12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
    r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
    for i in range(3):
        a0, a1, a2 = rot0[i, 0], rot0[i, 1], rot0[i, 2]
        out[i, 0] = a0 * r00 + a1 * r10 + a2 * r20
        out[i, 1] = a0 * r01 + a1 * r11 + a2 * r21
        out[i, 2] = a0 * r02 + a1 * r12 + a2 * r22


@njit(cache=True)
def _body_pass(parent, kind, axis, mass, com, inertia, armature, qd, qdd, g, R, P, work, tau):
    """One RNEA at one point: qd, qdd (B,), base acceleration -g (3,); R (B, 3, 3), P (B, 3) the joint
    transforms at q (precomputed); work (9, B + 1, 3) scratch; writes tau (B,)."""
    nb = len(parent)
    work[:] = 0.0
    w, v, aw, av, fl, fn = work[0], work[1], work[2], work[3], work[4], work[5]  # row 0: the base
    tmp, tmp2, s = work[6, 0], work[7, 0], work[8, 0]
    hl, hn = work[6, 1], work[7, 1]
    for k in range(3):
        av[0, k] = -g[k]
    for b in range(nb):
        i, lam = b + 1, parent[b]
        r, p = R[b], P[b]
        # parent's motion at this body's origin, in this body's frame: R^T (v + w x p), R^T w
        _cross(w[lam], p, tmp)
        _cross(aw[lam], p, tmp2)
        for k in range(3):
            w[i, k] = r[0, k] * w[lam, 0] + r[1, k] * w[lam, 1] + r[2, k] * w[lam, 2]
            v[i, k] = r[0, k] * (v[lam, 0] + tmp[0]) + r[1, k] * (v[lam, 1] + tmp[1]) + r[2, k] * (v[lam, 2] + tmp[2])
            aw[i, k] = r[0, k] * aw[lam, 0] + r[1, k] * aw[lam, 1] + r[2, k] * aw[lam, 2]
            av[i, k] = r[0, k] * (av[lam, 0] + tmp2[0]) + r[1, k] * (av[lam, 1] + tmp2[1]) + r[2, k] * (av[lam, 2] + tmp2[2])
        # joint motion S qd, S qdd; a += v x (S qd)
        for k in range(3):
            s[k] = axis[b, k] * qd[b]
        if kind[b] == 0:
            _cross(w[i], s, tmp)
            _cross(v[i], s, tmp2)
            for k in range(3):
                aw[i, k] += tmp[k] + axis[b, k] * qdd[b]
                av[i, k] += tmp2[k]
                w[i, k] += s[k]
        else:
            _cross(w[i], s, tmp)
            for k in range(3):
                av[i, k] += tmp[k] + axis[b, k] * qdd[b]
                v[i, k] += s[k]
        # f = I a + v x* (I v), I at the body origin: h = m (v + w x c), n = Ic w + c x h
        _inertia_times(mass[b], com[b], inertia[b], av[i], aw[i], fl[i], fn[i])
        _inertia_times(mass[b], com[b], inertia[b], v[i], w[i], hl, hn)
        _cross(w[i], hl, tmp)
        _cross(w[i], hn, tmp2)
        for k in range(3):
            fl[i, k] += tmp[k]
            fn[i, k] += tmp2[k]
        _cross(v[i], hl, tmp)
        for k in range(3):
            fn[i, k] += tmp[k]
    for b in range(nb - 1, -1, -1):
        i, lam = b + 1, parent[b]
        if kind[b] == 0:
            tau[b] = axis[b, 0] * fn[i, 0] + axis[b, 1] * fn[i, 1] + axis[b, 2] * fn[i, 2]
        else:
            tau[b] = axis[b, 0] * fl[i, 0] + axis[b, 1] * fl[i, 1] + axis[b, 2] * fl[i, 2]
        tau[b] += armature[b] * qdd[b]
        if lam > 0:
            r, p = R[b], P[b]
            for k in range(3):
                tmp[k] = r[k, 0] * fl[i, 0] + r[k, 1] * fl[i, 1] + r[k, 2] * fl[i, 2]
                tmp2[k] = r[k, 0] * fn[i, 0] + r[k, 1] * fn[i, 1] + r[k, 2] * fn[i, 2]
            _cross(p, tmp, hl)
            for k in range(3):
                fl[lam, k] += tmp[k]
                fn[lam, k] += tmp2[k] + hl[k]


@njit(cache=True)
def _inertia_times(m, c, ic, lin, ang, out_l, out_n):
    """Spatial inertia (mass m, com c, inertia ic about the com) times the motion (lin, ang), at the origin."""
    t0 = ang[1] * c[2] - ang[2] * c[1]
    t1 = ang[2] * c[0] - ang[0] * c[2]
    t2 = ang[0] * c[1] - ang[1] * c[0]
    out_l[0], out_l[1], out_l[2] = m * (lin[0] + t0), m * (lin[1] + t1), m * (lin[2] + t2)
    out_n[0] = ic[0, 0] * ang[0] + ic[0, 1] * ang[1] + ic[0, 2] * ang[2] + c[1] * out_l[2] - c[2] * out_l[1]
    out_n[1] = ic[1, 0] * ang[0] + ic[1, 1] * ang[1] + ic[1, 2] * ang[2] + c[2] * out_l[0] - c[0] * out_l[2]
    out_n[2] = ic[2, 0] * ang[0] + ic[2, 1] * ang[1] + ic[2, 2] * ang[2] + c[0] * out_l[1] - c[1] * out_l[0]


@njit(cache=True)
def _transforms(kind, axis, rot, pos, q, R, P):
    for b in range(len(kind)):
        _joint_rotation(kind[b], axis[b], q[b], rot[b], R[b])
        for k in range(3):
            P[b, k] = pos[b, k] + (axis[b, 0] * rot[b, k, 0] + axis[b, 1] * rot[b, k, 1] + axis[b, 2] * rot[b, k, 2]) \
                * q[b] if kind[b] == 1 else pos[b, k]


@njit(cache=True)
def _rnea_kernel(parent, kind, axis, rot, pos, mass, com, inertia, armature, gravity, q, qd, qdd, out):
    nb = len(parent)
    R, P, work = np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((9, nb + 1, 3))
    for n in range(q.shape[0]):
        _transforms(kind, axis, rot, pos, q[n], R, P)
        _body_pass(parent, kind, axis, mass, com, inertia, armature, qd[n], qdd[n], gravity, R, P, work, out[n])


@njit(cache=True)
def _reduced_kernel(parent, kind, axis, rot, pos, mass, com, inertia, armature, gravity, q, dq, ddq, alpha, beta, gamma):
    nb = len(parent)
    R, P, work = np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((9, nb + 1, 3))
    zero, nog = np.zeros(nb), np.zeros(3)
    for n in range(q.shape[0]):
        _transforms(kind, axis, rot, pos, q[n], R, P)
        _body_pass(parent, kind, axis, mass, com, inertia, armature, zero, zero, gravity, R, P, work, gamma[n])
        _body_pass(parent, kind, axis, mass, com, inertia, armature, zero, dq[n], nog, R, P, work, alpha[n])
        _body_pass(parent, kind, axis, mass, com, inertia, armature, dq[n], ddq[n], nog, R, P, work, beta[n])
