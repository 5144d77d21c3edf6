"""The arm as a stick figure: the base, every joint origin, the flange and the TCP, for the 3-D view."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .model import Robot


def arm_points(robot: Robot, q) -> np.ndarray:
    """Stick-figure vertices of the arm at each configuration, (N, n + 3, 3) [m] in the base frame:
    the base origin, the origins of joints 1..n (Pinocchio's data.oMi), the flange frame, the TCP.

    q: (N, n) [rad] (or (n,), giving (n + 3, 3))."""
    model, data = robot.model, robot.data
    qs = np.atleast_2d(np.asarray(q, dtype=float))
    flange = model.getFrameId(robot.flange_frame)
    tcp = robot.tcp_frame_id
    out = np.empty((len(qs), model.njoints + 2, 3))
    for k, qk in enumerate(qs):
        pin.forwardKinematics(model, data, qk)
        pin.updateFramePlacements(model, data)
        for j in range(model.njoints):  # joint 0 is the universe: the base origin
            out[k, j] = data.oMi[j].translation
        out[k, -2] = data.oMf[flange].translation
        out[k, -1] = data.oMf[tcp].translation
    return out[0] if np.ndim(q) == 1 else out
