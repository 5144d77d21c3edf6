"""What a Pinocchio joint does, read once for every module that builds its own kinematics or dynamics
from the model (robot/serial_batch.py, planning/fast_rnea.py, study/free_shape.py,
study/symbolic_dynamics.py)."""

from __future__ import annotations

import numpy as np

#: Revolute joints.
REVOLUTE = 0
#: Prismatic joints.
PRISMATIC = 1
#: Pinocchio joint short names with a fixed axis: (kind, axis).
_ALIGNED = {"JointModelRX": (REVOLUTE, (1.0, 0.0, 0.0)), "JointModelRY": (REVOLUTE, (0.0, 1.0, 0.0)),
            "JointModelRZ": (REVOLUTE, (0.0, 0.0, 1.0)), "JointModelPX": (PRISMATIC, (1.0, 0.0, 0.0)),
            "JointModelPY": (PRISMATIC, (0.0, 1.0, 0.0)), "JointModelPZ": (PRISMATIC, (0.0, 0.0, 1.0))}
_UNALIGNED = {"JointModelRevoluteUnaligned": REVOLUTE, "JointModelPrismaticUnaligned": PRISMATIC}


def joint_motion(joint) -> tuple[int, np.ndarray] | None:
    """(REVOLUTE or PRISMATIC, unit axis (3,) in the joint frame) of a Pinocchio joint model, or None
    for any other joint type (spherical, free, planar, ...)."""
    name = joint.shortname()
    if name in _ALIGNED:
        kind, axis = _ALIGNED[name]
        return kind, np.array(axis)
    if name in _UNALIGNED:
        return _UNALIGNED[name], np.asarray(joint.extract().axis, float).copy()
    return None


__all__ = ["PRISMATIC", "REVOLUTE", "joint_motion"]
