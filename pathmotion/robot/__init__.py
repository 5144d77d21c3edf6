"""Robot model: Pinocchio model + limits + payload + tool; kinematics, IK and dynamics."""

from .dynamics import aba, coriolis_matrix, gravity, kinetic_energy, mass_matrix, potential_energy, rnea
from .kinematics import fk, frame_acceleration_bias, jacobian, manipulability
from .limits import JointLimits, limits_from_toml
from .model import Payload, Robot, Tool, builtin_robot_names, load_robot

__all__ = [
    "JointLimits", "Payload", "Robot", "Tool", "aba", "builtin_robot_names", "coriolis_matrix", "fk",
    "frame_acceleration_bias", "gravity", "jacobian", "kinetic_energy", "limits_from_toml", "load_robot",
    "manipulability", "mass_matrix", "potential_energy", "rnea",
]
