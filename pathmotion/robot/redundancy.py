"""Redundancy resolution along a path for arms with more than 6 joints: Phi defined by an ODE in theta.

The same ODE lifts 6-joint arms without closed-form IK (UR): then J# = J^-1 and N = 0 (gain 0).

A TCP pose path p(theta), R(theta) has the twist per unit theta xi = [p'; w] (6,) and its
derivative xi' = [p''; w'] (world axes; w is the tool's angular velocity per unit theta). For an
arm with n > 6 joints, q = Phi(theta) is defined as the solution of

    Phi'(theta) = f(theta, Phi),     f(theta, q) = J#(q) xi(theta) + N(q) k (q_ref - q),     Phi(0) = q_0

* J (6, n): TCP Jacobian, LOCAL_WORLD_ALIGNED; W = diag(1 / qd_max^2); J# = W^-1 J^T (J W^-1 J^T)^-1
  the W-weighted pseudo-inverse. J# xi is the joint rate with the smallest sum (Phi'_j / qd_max_j)^2
  that moves the TCP along the path: low joint speed, measured against each joint's limit.
* N = I - J# J projects onto the null space (self-motion that leaves the TCP still). k [1/m] (default
  ``defaults.REDUNDANCY_NULLSPACE_GAIN``) pulls the joints toward q_ref (the start configuration)
  at that rate per metre of path, so the arm neither drifts along a long or repeated path nor
  leaves the neighbourhood it started in.
* q_0 = the IK solution (damped least squares) nearest to the start configuration.

Because J J# = I and J N = 0 for every q, J(q) f(theta, q) = xi(theta) everywhere: the TCP follows the
path exactly, whatever q the integration holds. Differentiating along Phi' = f gives Phi'' exactly:

    Phi'' = J# xi' + dJ# xi + dN k (q_ref - q) - N k Phi'
    dJ#   = W^-1 Jd^T A^-1 - J# dA A^-1,   A = J W^-1 J^T,   dA = Jd W^-1 J^T + J W^-1 Jd^T
    dN    = -(dJ# J + J# Jd)

with Jd = dJ/dq . Phi' (Pinocchio's Jacobian time variation at qd = Phi'). So J Phi'' + Jd Phi' = xi'
holds exactly as well (the TCP's acceleration per unit theta^2 is the path's). What is exact: Phi' and
Phi'' as functions of (theta, Phi(theta)). What is numerical: Phi itself, the ODE's solution, held
as a dense RK4 reference (step ``defaults.LIFT_REFERENCE_STEP`` / 2) with a cubic Hermite interpolant
between samples; at every evaluation the interpolated q is projected back onto the pose (Gauss-Newton
steps q += J# e, e = pose error) so that FK(Phi) is the path to rounding (1e-12 m). Phi''' (jerk
limits) is exact too: :func:`resolved_third_derivative`, with J'' from :func:`jacobian_second_rate`.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import UnreachableError
from .kinematics import fk, jacobian
from .model import Robot

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: Gauss-Newton projection onto the pose: stop when the largest error is below this [m, rad] ...
PROJECTION_TOLERANCE = 1e-12
#: ... or after this many steps (1 or 2 are needed from the RK4 reference).
PROJECTION_ITERATIONS = 6


def joint_weights(robot: Robot) -> np.ndarray:
    """W^-1 = diag(qd_max^2) (n,) [rad^2/s^2]: the inverse weights of the weighted pseudo-inverse."""
    return np.asarray(robot.limits.velocity, float) ** 2


def weighted_pinv(jac: np.ndarray, winv: np.ndarray) -> np.ndarray:
    """J# = W^-1 J^T (J W^-1 J^T)^-1, (N, n, 6) from J (N, 6, n) and winv (n,)."""
    jw = jac * winv[None, None, :]
    a = jw @ np.swapaxes(jac, 1, 2)
    return np.swapaxes(np.linalg.solve(a, jw), 1, 2)


def resolved_rate(robot: Robot, q, twist, q_ref, gain: float, winv) -> np.ndarray:
    """f(theta, q) = J# xi + N k (q_ref - q), (N, n); q (N, n), twist xi (N, 6)."""
    q = np.atleast_2d(q)
    jac = jacobian(robot, q).reshape(len(q), 6, robot.n)
    pinv = weighted_pinv(jac, winv)
    pull = gain * (q_ref[None, :] - q)
    null = pull - np.einsum("nij,njk,nk->ni", pinv, jac, pull)
    return np.einsum("nij,nj->ni", pinv, twist) + null


def jacobian_rate(robot: Robot, q, qd) -> np.ndarray:
    """Jd = dJ/dq . qd (N, 6, n): the time derivative of the LOCAL_WORLD_ALIGNED TCP Jacobian at
    velocity qd (Pinocchio's getFrameJacobianTimeVariation)."""
    model, data = robot.model, robot.data
    fid = robot.tcp_frame_id
    q, qd = np.atleast_2d(q), np.atleast_2d(qd)
    out = np.empty((len(q), 6, robot.n))
    for k in range(len(q)):
        pin.computeJointJacobiansTimeVariation(model, data, q[k], qd[k])
        pin.updateFramePlacements(model, data)
        out[k] = pin.getFrameJacobianTimeVariation(model, data, fid, _LWA)
    return out


def resolved_derivatives(robot: Robot, q, twist, dtwist, q_ref, gain: float, winv) -> tuple[np.ndarray, np.ndarray]:
    """(Phi', Phi'') (N, n) at configurations q (N, n) on the path, task twist xi (N, 6) and its
    theta-derivative xi' (N, 6); the formulas of the module docstring, no finite differences."""
    q = np.atleast_2d(q)
    jac = jacobian(robot, q).reshape(len(q), 6, robot.n)
    pinv = weighted_pinv(jac, winv)
    pull = gain * (q_ref[None, :] - q)
    eye = np.eye(robot.n)[None]
    null = eye - pinv @ jac
    dq = np.einsum("nij,nj->ni", pinv, twist) + np.einsum("nij,nj->ni", null, pull)
    jd = jacobian_rate(robot, q, dq)
    jw = jac * winv[None, None, :]
    a_inv = np.linalg.inv(jw @ np.swapaxes(jac, 1, 2))
    jdw = jd * winv[None, None, :]
    da = jdw @ np.swapaxes(jac, 1, 2) + jw @ np.swapaxes(jd, 1, 2)
    dpinv = np.swapaxes(jdw, 1, 2) @ a_inv - pinv @ da @ a_inv
    dnull = -(dpinv @ jac + pinv @ jd)
    ddq = (np.einsum("nij,nj->ni", pinv, dtwist) + np.einsum("nij,nj->ni", dpinv, twist)
           + np.einsum("nij,nj->ni", dnull, pull) - gain * np.einsum("nij,nj->ni", null, dq))
    return dq, ddq


def _mv(m, v):
    return np.einsum("nij,nj->ni", m, v)


def jacobian_second_rate(robot: Robot, q, qd, qdd) -> np.ndarray:
    """Jdd = d2J/dt2 (N, 6, n) of the LOCAL_WORLD_ALIGNED TCP Jacobian along q(t) with velocity qd and
    acceleration qdd (N, n), exact (no finite differences).

    Column i of J is [z_i x r_i; z_i] for a revolute joint (z_i its world axis, r_i = p_tcp - o_i from
    the joint's origin o_i on the axis) and [z_i; 0] for a prismatic one. z_i is fixed in the joint's
    frame, so z' = w_i x z and z'' = a_i x z + w_i x z', with w_i, a_i the frame's angular velocity and
    acceleration; r' and r'' are differences of the classical velocities and accelerations of the two
    points. Then (z x r)'' = z'' x r + 2 z' x r' + z x r''. All from one forwardKinematics(q, qd, qdd)."""
    model, data = robot.model, robot.data
    fid = robot.tcp_frame_id
    q, qd, qdd = (np.atleast_2d(x) for x in (q, qd, qdd))
    jac = jacobian(robot, q).reshape(len(q), 6, robot.n)
    out = np.empty((len(q), 6, robot.n))
    for k in range(len(q)):
        pin.forwardKinematics(model, data, q[k], qd[k], qdd[k])
        pin.updateFramePlacements(model, data)
        p_t = data.oMf[fid].translation
        v_t = pin.getFrameVelocity(model, data, fid, _LWA).linear
        a_t = pin.getFrameClassicalAcceleration(model, data, fid, _LWA).linear
        for i in range(robot.n):
            jid = i + 1  # nq = nv = 1 per joint (checked when the model is built): joint i + 1 moves v[i]
            vel = pin.getVelocity(model, data, jid, _LWA)
            acc = pin.getClassicalAcceleration(model, data, jid, _LWA)
            w_i, a_i = vel.angular, acc.angular
            revolute = np.linalg.norm(jac[k, 3:, i]) > 0.5
            z = jac[k, 3:, i] if revolute else jac[k, :3, i]
            dz = np.cross(w_i, z)
            ddz = np.cross(a_i, z) + np.cross(w_i, dz)
            if revolute:
                r, dr, ddr = p_t - data.oMi[jid].translation, v_t - vel.linear, a_t - acc.linear
                out[k, :3, i] = np.cross(ddz, r) + 2.0 * np.cross(dz, dr) + np.cross(z, ddr)
                out[k, 3:, i] = ddz
            else:
                out[k, :3, i], out[k, 3:, i] = ddz, 0.0
    return out


def resolved_third_derivative(robot: Robot, q, twist, dtwist, ddtwist, q_ref, gain: float,
                              winv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Phi', Phi'', Phi''') (N, n): :func:`resolved_derivatives` and its theta-derivative along the ODE,
    with xi'' = [p'''; w''] (N, 6). With P = J#, A = J W^-1 J^T, p = k (q_ref - q) and ' = d/dtheta:

        Phi''' = P xi'' + 2 P' xi' + P'' xi + N'' p + 2 N' p' + N p'',   p' = -k Phi', p'' = -k Phi''
        A'' = J'' W^-1 J^T + 2 J' W^-1 J'^T + J W^-1 J''^T
        P'' = W^-1 J''^T A^-1 - 2 W^-1 J'^T A^-1 A' A^-1 - P A'' A^-1 + 2 P A' A^-1 A' A^-1
        N'' = -(P'' J + 2 P' J' + P J'')

    with J' = Jd(Phi, Phi') and J'' = Jdd(Phi, Phi', Phi'') (:func:`jacobian_second_rate`); exact."""
    q = np.atleast_2d(q)
    dq, ddq = resolved_derivatives(robot, q, twist, dtwist, q_ref, gain, winv)
    jac = jacobian(robot, q).reshape(len(q), 6, robot.n)
    j1 = jacobian_rate(robot, q, dq)
    j2 = jacobian_second_rate(robot, q, dq, ddq)
    t = (lambda m: np.swapaxes(m, 1, 2))
    w = winv[None, :, None]
    a_inv = np.linalg.inv(jac @ (w * t(jac)))
    a1 = j1 @ (w * t(jac)) + jac @ (w * t(j1))
    a2 = j2 @ (w * t(jac)) + 2.0 * j1 @ (w * t(j1)) + jac @ (w * t(j2))
    p0 = (w * t(jac)) @ a_inv
    p1 = (w * t(j1)) @ a_inv - p0 @ a1 @ a_inv
    p2 = ((w * t(j2)) @ a_inv - 2.0 * (w * t(j1)) @ a_inv @ a1 @ a_inv - p0 @ a2 @ a_inv
          + 2.0 * p0 @ a1 @ a_inv @ a1 @ a_inv)
    n0 = np.eye(robot.n)[None] - p0 @ jac
    n1 = -(p1 @ jac + p0 @ j1)
    n2 = -(p2 @ jac + 2.0 * p1 @ j1 + p0 @ j2)
    pull = gain * (q_ref[None, :] - q)
    dddq = (_mv(p0, ddtwist) + 2.0 * _mv(p1, dtwist) + _mv(p2, twist) + _mv(n2, pull)
            - 2.0 * gain * _mv(n1, dq) - gain * _mv(n0, ddq))
    return dq, ddq, dddq


def project_to_pose(robot: Robot, q, positions, rotations, winv) -> np.ndarray:
    """q (N, n) moved onto the TCP poses (positions (N, 3), rotations (N, 3, 3)) by weighted
    Gauss-Newton steps q += J# e (the smallest weighted joint change); UnreachableError with
    ``index`` if a point does not converge (a singular or unreachable pose)."""
    out = np.array(np.atleast_2d(q), dtype=float)
    for k in range(len(out)):
        qk = out[k]
        for _ in range(PROJECTION_ITERATIONS + 1):
            pos, rot = fk(robot, qk)
            err = np.concatenate([positions[k] - pos, pin.log3(rotations[k] @ rot.T)])
            if np.max(np.abs(err)) < PROJECTION_TOLERANCE:
                break
            jac = jacobian(robot, qk)[None]
            qk = qk + weighted_pinv(jac, winv)[0] @ err
        else:
            raise UnreachableError(f"point {k}: the joint path cannot be held on the pose (error "
                                   f"{np.max(np.abs(err)):.3g}); the arm is singular or out of reach there",
                                   index=k, reason="singular")
        out[k] = qk
    return out


def integrate_path(robot: Robot, theta: np.ndarray, pose, q0, q_ref, gain: float,
                   winv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phi on the grid ``theta`` (M,) by RK4 of Phi' = f from Phi(theta_0) = q0, projected onto the
    pose after each step; ``pose(theta, side)`` returns the TaskPath pose tuple (p, dp, ddp, R, w, dw).
    Returns (q (M, n), f at each sample from the right (M, n), f from the left (M, n)) -- they differ
    at kinks, where xi jumps."""
    mid = 0.5 * (theta[:-1] + theta[1:])
    right, left, middle = pose(theta, "right"), pose(theta, "left"), pose(mid, "right")
    xi_r = np.concatenate([right[1], right[4]], axis=1)
    xi_l = np.concatenate([left[1], left[4]], axis=1)
    xi_m = np.concatenate([middle[1], middle[4]], axis=1)
    q = np.empty((len(theta), robot.n))
    q[0] = q0
    for i in range(len(theta) - 1):
        h = theta[i + 1] - theta[i]
        k1 = resolved_rate(robot, q[i], xi_r[i:i + 1], q_ref, gain, winv)[0]
        k2 = resolved_rate(robot, q[i] + 0.5 * h * k1, xi_m[i:i + 1], q_ref, gain, winv)[0]
        k3 = resolved_rate(robot, q[i] + 0.5 * h * k2, xi_m[i:i + 1], q_ref, gain, winv)[0]
        k4 = resolved_rate(robot, q[i] + h * k3, xi_l[i + 1:i + 2], q_ref, gain, winv)[0]
        step = q[i] + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        try:
            q[i + 1] = project_to_pose(robot, step, right[0][i + 1:i + 2], right[3][i + 1:i + 2], winv)[0]
        except UnreachableError as exc:
            raise UnreachableError(str(exc), index=i + 1, reason=exc.reason) from None
    return q, resolved_rate(robot, q, xi_r, q_ref, gain, winv), resolved_rate(robot, q, xi_l, q_ref, gain, winv)


def hermite(theta: np.ndarray, ref_theta: np.ndarray, ref_q: np.ndarray, slope_right: np.ndarray,
            slope_left: np.ndarray, side: str) -> np.ndarray:
    """Cubic Hermite interpolation (N, n) of the samples ref_q (M, n) with the slopes f at each
    interval's ends (from the right at its start, from the left at its end)."""
    i = np.searchsorted(ref_theta, theta, side="right" if side == "right" else "left") - 1
    i = np.clip(i, 0, len(ref_theta) - 2)
    h = (ref_theta[i + 1] - ref_theta[i])[:, None]
    s = ((theta - ref_theta[i]) / h[:, 0])[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * ref_q[i] + h10 * h * slope_right[i] + h01 * ref_q[i + 1] + h11 * h * slope_left[i + 1]
