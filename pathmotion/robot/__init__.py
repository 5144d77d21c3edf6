"""Robot model: Pinocchio model + limits + payload + tool; kinematics, IK and dynamics."""

from .dynamics import aba, coriolis_matrix, gravity, kinetic_energy, mass_matrix, potential_energy, rnea
from .ik import has_closed_form, ik, ik_all, ik_batch, ik_dls, ik_nearest, opw_geometry
from .kinematics import fk, frame_acceleration_bias, jacobian, manipulability
from .limits import JointLimits, limits_from_toml
from .model import Payload, Robot, Tool, builtin_robot_names, load_robot
from .opw import OPWGeometry, branch_name

__all__ = [
    "JointLimits", "OPWGeometry", "Payload", "Robot", "Tool", "aba", "branch_name", "builtin_robot_names",
    "coriolis_matrix", "fk", "frame_acceleration_bias", "gravity", "has_closed_form", "ik", "ik_all",
    "ik_batch", "ik_dls", "ik_nearest", "jacobian", "kinetic_energy", "limits_from_toml", "load_robot", "manipulability",
    "mass_matrix", "opw_geometry", "potential_energy", "rnea",
]
