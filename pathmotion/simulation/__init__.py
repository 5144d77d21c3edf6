"""Closed-loop simulation: the plant (rigid-body dynamics, realism switches), the loop and its metrics."""

from .closed_loop import SimulationSettings, make_controller, simulate
from .metrics import FAILURE_REASONS, Failure, SimulationResult, polish_projection, tcp_path_deviation
from .plant import Plant
from .realism import Realism, Sensor, plant_model

__all__ = [
    "FAILURE_REASONS", "Failure", "Plant", "Realism", "Sensor", "SimulationResult", "SimulationSettings",
    "make_controller", "plant_model", "polish_projection", "simulate", "tcp_path_deviation",
]
