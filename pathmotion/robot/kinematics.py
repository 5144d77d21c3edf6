"""Forward kinematics and Jacobians (Pinocchio), single configurations or batches.

Shapes: q (n,) or (N, n); positions (3,) / (N, 3); rotations (3, 3) / (N, 3, 3); Jacobians
(6, n) / (N, 6, n) in LOCAL_WORLD_ALIGNED form: rows 0-2 the linear velocity of the frame origin
in world axes [m/s per rad/s], rows 3-5 the angular velocity in world axes.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import pinocchio as pin

from .model import Robot
from .serial_batch import acceleration_bias_batch, bias_from, chain_frames, jacobian_batch, jacobian_from

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: Batches of at least this many configurations of a serial revolute chain use :mod:`.serial_batch`'s array
#: recursions instead of one Pinocchio call per configuration (equal to round-off; faster from ~20 points).
SERIAL_BATCH_MIN = 32


def _as_batch(q, n):
    q = np.asarray(q, dtype=float)
    single = q.ndim == 1
    q = np.atleast_2d(q)
    if q.shape[1] != n:
        from ..errors import PathmotionError

        raise PathmotionError(f"configuration has {q.shape[1]} joints, the robot has {n}")
    return q, single


def fk(robot: Robot, q, frame: str | int | None = None):
    """Pose of ``frame`` (default TCP) in the base frame: (position, rotation)."""
    model, data = robot.model, robot.data
    fid = robot.frame_id(frame)
    qs, single = _as_batch(q, robot.n)
    pos = np.empty((len(qs), 3))
    rot = np.empty((len(qs), 3, 3))
    for k, qk in enumerate(qs):
        pin.forwardKinematics(model, data, qk)
        placement = pin.updateFramePlacement(model, data, fid)  # this frame alone (half the time of all frames)
        pos[k] = placement.translation
        rot[k] = placement.rotation
    return (pos[0], rot[0]) if single else (pos, rot)


def jacobian(robot: Robot, q, frame: str | int | None = None) -> np.ndarray:
    """Geometric Jacobian of ``frame`` (default TCP), LOCAL_WORLD_ALIGNED, (6, n) or (N, 6, n)."""
    model, data = robot.model, robot.data
    fid = robot.frame_id(frame)
    qs, single = _as_batch(q, robot.n)
    chain = robot.serial_chain(fid) if len(qs) >= SERIAL_BATCH_MIN else None
    if chain is not None:
        return jacobian_batch(chain, qs)
    out = np.empty((len(qs), 6, robot.n))
    for k, qk in enumerate(qs):
        out[k] = pin.computeFrameJacobian(model, data, qk, fid, _LWA)
    return out[0] if single else out


def frame_acceleration_bias(robot: Robot, q, qd, frame: str | int | None = None) -> np.ndarray:
    """Jdot(q, qd) qd of ``frame``: the classical (not spatial) acceleration at qdd = 0, (6,) or (N, 6).

    Rows 0-2: linear acceleration of the frame origin, rows 3-5: angular acceleration, world axes.
    """
    model, data = robot.model, robot.data
    fid = robot.frame_id(frame)
    qs, single = _as_batch(q, robot.n)
    qds, _ = _as_batch(qd, robot.n)
    chain = robot.serial_chain(fid) if len(qs) >= SERIAL_BATCH_MIN else None
    if chain is not None:
        return acceleration_bias_batch(chain, qs, qds)
    zero = np.zeros(robot.n)
    out = np.empty((len(qs), 6))
    for k in range(len(qs)):
        pin.forwardKinematics(model, data, qs[k], qds[k], zero)
        pin.updateFramePlacements(model, data)
        acc = pin.getFrameClassicalAcceleration(model, data, fid, _LWA)
        out[k, :3] = acc.linear
        out[k, 3:] = acc.angular
    return out[0] if single else out


def jacobian_and_bias(robot: Robot, q) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """(:func:`jacobian` of the TCP (N, 6, n) at configurations q (N, n), qd (N, n) -> :func:`frame_acceleration_bias`
    (N, 6) at q, qd): the same values, a serial chain's frames at q computed once for both (the lift's Phi' needs J,
    then Phi'' the bias at Phi')."""
    qs, _ = _as_batch(q, robot.n)
    chain = robot.serial_chain(robot.frame_id(None)) if len(qs) >= SERIAL_BATCH_MIN else None
    if chain is None:
        return jacobian(robot, q), lambda qd: frame_acceleration_bias(robot, q, qd)
    frames = chain_frames(chain, qs)
    return jacobian_from(frames), lambda qd: bias_from(frames, _as_batch(qd, robot.n)[0])


def manipulability(robot: Robot, q, frame: str | int | None = None) -> np.ndarray:
    """Singularity measure: smallest singular value of the 6 x n Jacobian, () or (N,)."""
    jac = jacobian(robot, q, frame)
    return np.linalg.svd(jac, compute_uv=False)[..., -1]
