"""Discrete-time controllers of the closed loop: orbital stabilization and two time-indexed baselines."""

from .baselines import CONTROLLER_NAMES, ComputedTorqueController, PDGravityController, TimeReference
from .gains import OrbitalGains, TrackingGains, default_pd_gains
from .laws import computed_torque, pd_gravity
from .orbital import OrbitalController, OrbitalDesign, lqr_weights
from .payload import PayloadEstimator
from .path_table import PathTable
from .profile_lookup import ProfileLookup
from .riccati import solve_riccati
from .transverse import TransverseBasis, project, transverse_linearization

__all__ = [
    "CONTROLLER_NAMES", "ComputedTorqueController", "OrbitalController", "OrbitalDesign", "OrbitalGains",
    "PDGravityController", "PathTable", "PayloadEstimator", "ProfileLookup", "TimeReference", "TrackingGains", "TransverseBasis",
    "computed_torque", "default_pd_gains", "lqr_weights", "pd_gravity", "project", "solve_riccati",
    "transverse_linearization",
]
