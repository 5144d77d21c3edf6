"""Closed-loop simulation: the plant (rigid-body dynamics, realism switches), the loop and its metrics."""

from .closed_loop import PlantModel, SimulationSettings, make_controller, prepare_loop, simulate
from .end_rules import Arrival, EndRule, Sample, end_rules
from .metrics import FAILURE_REASONS, Failure, SimulationResult, polish_projection, tcp_path_deviation
from .plant import Plant
from .realism import Realism, Sensor, plant_model

__all__ = [
    "Arrival", "EndRule", "FAILURE_REASONS", "Failure", "Plant", "PlantModel", "Realism", "Sample", "Sensor",
    "SimulationResult", "SimulationSettings",
    "end_rules", "make_controller", "plant_model", "prepare_loop", "polish_projection", "simulate",
    "tcp_path_deviation",
]
