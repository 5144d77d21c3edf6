"""Batched inverse dynamics compiled with numba, for the planner's reduced dynamics and certification.

Pinocchio has no batched call from Python: robot/dynamics.py loops over its C++ RNEA, and at a few
microseconds of Python overhead per call the three calls per grid point of the reduced dynamics
(planning/reduced.py) dominated the planner's time with torque limits. This module runs the
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

from ..robot.joints import joint_motion



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
    """The kernels' view of a Pinocchio ``model`` (computed once per model object, which must not change
    afterwards: a Robot's model does not), or None when a joint type is not supported."""
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
        motion = joint_motion(joint)
        if joint.idx_v != b or motion is None:
            return None
        kind[b], axis[b] = motion
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


@njit(cache=True, nogil=True)
def _joint_rotation(kind, axis, angle, rot0, out, b):
    """out[b] = rot0 @ R(axis, angle) for a revolute joint, rot0 for a prismatic one (3, 3)."""
    if kind != 0:
        for i in range(3):
            for j in range(3):
                out[b, i, j] = rot0[i, j]
        return
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    x, y, z = axis[0], axis[1], axis[2]
    r00, r01, r02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
    r10, r11, r12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
    r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
    for i in range(3):
        a0, a1, a2 = rot0[i, 0], rot0[i, 1], rot0[i, 2]
        out[b, i, 0] = a0 * r00 + a1 * r10 + a2 * r20
        out[b, i, 1] = a0 * r01 + a1 * r11 + a2 * r21
        out[b, i, 2] = a0 * r02 + a1 * r12 + a2 * r22


@njit(cache=True, nogil=True)
def _transforms(kind, axis, rot, pos, q, R, P):
    """R (B, 3, 3), P (B, 3): each joint's rotation and translation in its parent's frame at q (B,)."""
    for b in range(len(kind)):
        _joint_rotation(kind[b], axis[b], q[b], rot[b], R, b)
        for k in range(3):
            P[b, k] = pos[b, k]
            if kind[b] == 1:
                P[b, k] += (axis[b, 0] * rot[b, k, 0] + axis[b, 1] * rot[b, k, 1] + axis[b, 2] * rot[b, k, 2]) * q[b]


@njit(cache=True, nogil=True, inline="always")  # inlined: no call per body
def _body_force(b, mass, com, inertia, M, F):
    """The spatial force F[b + 1] (force, moment about the body origin) body ``b`` needs for its motion M[b + 1]
    (velocity and acceleration, body frame): f = I a + v x* (I v)."""
    i = b + 1
    # I (mass m, com c, inertia ic about c) times (lin, ang): h = m (lin + ang x c),
    # n = ic ang + c x h; v x* (h, n) = (w x h, w x n + v x h)
    m, c0, c1, c2 = mass[b], com[b, 0], com[b, 1], com[b, 2]
    w0, w1, w2, v0, v1, v2 = M[i, 0], M[i, 1], M[i, 2], M[i, 3], M[i, 4], M[i, 5]
    a0, a1, a2, l0, l1, l2 = M[i, 6], M[i, 7], M[i, 8], M[i, 9], M[i, 10], M[i, 11]
    f0 = m * (l0 + a1 * c2 - a2 * c1)
    f1 = m * (l1 + a2 * c0 - a0 * c2)
    f2 = m * (l2 + a0 * c1 - a1 * c0)
    n0 = inertia[b, 0, 0] * a0 + inertia[b, 0, 1] * a1 + inertia[b, 0, 2] * a2 + c1 * f2 - c2 * f1
    n1 = inertia[b, 1, 0] * a0 + inertia[b, 1, 1] * a1 + inertia[b, 1, 2] * a2 + c2 * f0 - c0 * f2
    n2 = inertia[b, 2, 0] * a0 + inertia[b, 2, 1] * a1 + inertia[b, 2, 2] * a2 + c0 * f1 - c1 * f0
    h0 = m * (v0 + w1 * c2 - w2 * c1)
    h1 = m * (v1 + w2 * c0 - w0 * c2)
    h2 = m * (v2 + w0 * c1 - w1 * c0)
    k0 = inertia[b, 0, 0] * w0 + inertia[b, 0, 1] * w1 + inertia[b, 0, 2] * w2 + c1 * h2 - c2 * h1
    k1 = inertia[b, 1, 0] * w0 + inertia[b, 1, 1] * w1 + inertia[b, 1, 2] * w2 + c2 * h0 - c0 * h2
    k2 = inertia[b, 2, 0] * w0 + inertia[b, 2, 1] * w1 + inertia[b, 2, 2] * w2 + c0 * h1 - c1 * h0
    F[i, 0] = f0 + w1 * h2 - w2 * h1
    F[i, 1] = f1 + w2 * h0 - w0 * h2
    F[i, 2] = f2 + w0 * h1 - w1 * h0
    F[i, 3] = n0 + w1 * k2 - w2 * k1 + v1 * h2 - v2 * h1
    F[i, 4] = n1 + w2 * k0 - w0 * k2 + v2 * h0 - v0 * h2
    F[i, 5] = n2 + w0 * k1 - w1 * k0 + v0 * h1 - v1 * h0


@njit(cache=True, nogil=True, inline="always")  # inlined: no call per body
def _backward_pass(parent, kind, axis, armature, qdd, R, P, F, tau, n):
    """tau[n] (B,) from the bodies' forces F, tip to base: each joint takes its axis' component (plus the
    armature's torque), each parent the child's force carried to its frame."""
    nb = len(parent)
    for b in range(nb - 1, -1, -1):
        i, lam = b + 1, parent[b]
        off = 3 if kind[b] == 0 else 0
        tau[n, b] = axis[b, 0] * F[i, off] + axis[b, 1] * F[i, off + 1] + axis[b, 2] * F[i, off + 2] \
            + armature[b] * qdd[n, b]
        if lam > 0:  # the parent takes (R f, R n + p x R f)
            p0, p1, p2 = P[b, 0], P[b, 1], P[b, 2]
            t0 = R[b, 0, 0] * F[i, 0] + R[b, 0, 1] * F[i, 1] + R[b, 0, 2] * F[i, 2]
            t1 = R[b, 1, 0] * F[i, 0] + R[b, 1, 1] * F[i, 1] + R[b, 1, 2] * F[i, 2]
            t2 = R[b, 2, 0] * F[i, 0] + R[b, 2, 1] * F[i, 1] + R[b, 2, 2] * F[i, 2]
            F[lam, 0] += t0
            F[lam, 1] += t1
            F[lam, 2] += t2
            F[lam, 3] += R[b, 0, 0] * F[i, 3] + R[b, 0, 1] * F[i, 4] + R[b, 0, 2] * F[i, 5] + p1 * t2 - p2 * t1
            F[lam, 4] += R[b, 1, 0] * F[i, 3] + R[b, 1, 1] * F[i, 4] + R[b, 1, 2] * F[i, 5] + p2 * t0 - p0 * t2
            F[lam, 5] += R[b, 2, 0] * F[i, 3] + R[b, 2, 1] * F[i, 4] + R[b, 2, 2] * F[i, 5] + p0 * t1 - p1 * t0


@njit(cache=True, nogil=True)
def _body_pass(parent, kind, axis, mass, com, inertia, armature, qd, qdd, g0, g1, g2, R, P, M, F, tau, n):
    """One RNEA at one point: qd, qdd (B,) rows ``n`` of (N, B) arrays, base acceleration -g; R, P the joint
    transforms at q (precomputed); scratch M (B + 1, 12) (angular and linear velocity, angular and
    linear acceleration, body frame; row 0 the base) and F (B + 1, 6) (force, moment about the body
    origin); writes tau[n] (B,). Scalar indexing only: array views cost reference counting."""
    nb = len(parent)
    for k in range(12):
        M[0, k] = 0.0
    M[0, 9], M[0, 10], M[0, 11] = -g0, -g1, -g2
    for b in range(nb):
        i, lam = b + 1, parent[b]
        p0, p1, p2 = P[b, 0], P[b, 1], P[b, 2]
        # the parent's motion at this body's origin: linear + angular x p; then R^T
        pw0, pw1, pw2 = M[lam, 0], M[lam, 1], M[lam, 2]
        pv0 = M[lam, 3] + pw1 * p2 - pw2 * p1
        pv1 = M[lam, 4] + pw2 * p0 - pw0 * p2
        pv2 = M[lam, 5] + pw0 * p1 - pw1 * p0
        pa0, pa1, pa2 = M[lam, 6], M[lam, 7], M[lam, 8]
        pl0 = M[lam, 9] + pa1 * p2 - pa2 * p1
        pl1 = M[lam, 10] + pa2 * p0 - pa0 * p2
        pl2 = M[lam, 11] + pa0 * p1 - pa1 * p0
        for k in range(3):
            r0, r1, r2 = R[b, 0, k], R[b, 1, k], R[b, 2, k]
            M[i, k] = r0 * pw0 + r1 * pw1 + r2 * pw2
            M[i, 3 + k] = r0 * pv0 + r1 * pv1 + r2 * pv2
            M[i, 6 + k] = r0 * pa0 + r1 * pa1 + r2 * pa2
            M[i, 9 + k] = r0 * pl0 + r1 * pl1 + r2 * pl2
        s0, s1, s2 = axis[b, 0] * qd[n, b], axis[b, 1] * qd[n, b], axis[b, 2] * qd[n, b]
        w0, w1, w2 = M[i, 0], M[i, 1], M[i, 2]
        v0, v1, v2 = M[i, 3], M[i, 4], M[i, 5]
        if kind[b] == 0:  # revolute: a += (v x s, w x s) + (0, axis qdd); w += s
            M[i, 6] += w1 * s2 - w2 * s1 + axis[b, 0] * qdd[n, b]
            M[i, 7] += w2 * s0 - w0 * s2 + axis[b, 1] * qdd[n, b]
            M[i, 8] += w0 * s1 - w1 * s0 + axis[b, 2] * qdd[n, b]
            M[i, 9] += v1 * s2 - v2 * s1
            M[i, 10] += v2 * s0 - v0 * s2
            M[i, 11] += v0 * s1 - v1 * s0
            w0, w1, w2 = w0 + s0, w1 + s1, w2 + s2
            M[i, 0], M[i, 1], M[i, 2] = w0, w1, w2
        else:  # prismatic: a += (w x s + axis qdd, 0); v += s
            M[i, 9] += w1 * s2 - w2 * s1 + axis[b, 0] * qdd[n, b]
            M[i, 10] += w2 * s0 - w0 * s2 + axis[b, 1] * qdd[n, b]
            M[i, 11] += w0 * s1 - w1 * s0 + axis[b, 2] * qdd[n, b]
            v0, v1, v2 = v0 + s0, v1 + s1, v2 + s2
            M[i, 3], M[i, 4], M[i, 5] = v0, v1, v2
        _body_force(b, mass, com, inertia, M, F)
    _backward_pass(parent, kind, axis, armature, qdd, R, P, F, tau, n)


@njit(cache=True, nogil=True)
def _rnea_kernel(parent, kind, axis, rot, pos, mass, com, inertia, armature, gravity, q, qd, qdd, out):
    nb = len(parent)
    R, P, M, F = np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb + 1, 12)), np.empty((nb + 1, 6))
    for n in range(q.shape[0]):
        _transforms(kind, axis, rot, pos, q[n], R, P)
        _body_pass(parent, kind, axis, mass, com, inertia, armature, qd, qdd, gravity[0], gravity[1], gravity[2],
                   R, P, M, F, out, n)


@njit(cache=True, nogil=True)
def _reduced_kernel(parent, kind, axis, rot, pos, mass, com, inertia, armature, gravity, q, dq, ddq, alpha, beta, gamma):
    nb = len(parent)
    R, P, M, F = np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb + 1, 12)), np.empty((nb + 1, 6))
    zero = np.zeros((1, nb))
    for n in range(q.shape[0]):
        _transforms(kind, axis, rot, pos, q[n], R, P)
        # gravity alone (row 0 of zero: no velocity, no acceleration), then the two gravity-free passes
        _body_pass(parent, kind, axis, mass, com, inertia, armature, zero, zero, gravity[0], gravity[1], gravity[2],
                   R, P, M, F, gamma[n:n + 1], 0)
        _body_pass(parent, kind, axis, mass, com, inertia, armature, zero, dq[n:n + 1], 0.0, 0.0, 0.0,
                   R, P, M, F, alpha[n:n + 1], 0)
        _body_pass(parent, kind, axis, mass, com, inertia, armature, dq, ddq, 0.0, 0.0, 0.0, R, P, M, F, beta, n)
