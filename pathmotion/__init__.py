"""pathmotion: time-optimal path-constrained motion for robot arms, proven in closed-loop simulation.

The flow (each arrow a function, each box an immutable value)::

    scenario (TOML) -> Robot -> TaskPath -> JointPath q = Phi(theta) -> PlanResult (Profile, Trajectory)
                    -> SimulationResult -> files, figures, report

The public names below are imported on first use (PEP 562), so ``import pathmotion`` and the
``pathmotion`` command start fast and the command can take over Ctrl-C/SIGTERM before NumPy,
Pinocchio and numba load.

Logging: every module logs to ``logging.getLogger(__name__)`` under the ``pathmotion`` logger, which has
only a NullHandler: a program shows the stages with e.g. ``logging.basicConfig(level=logging.INFO)``
(INFO: the planner's and the loop's stages; DEBUG: their details), the command with ``-v`` / ``-vv``.
"""

from __future__ import annotations

import importlib
import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())

_EXPORTS = {
    "api": ("Setup", "build", "check_scenario", "load", "load_text", "plan_scenario", "search", "simulate_scenario",
            "write_plan", "write_simulation"),
    "errors": ("InfeasibleError", "PathError", "PathmotionError", "RobotModelError", "ScenarioError",
               "SimulationError", "StateInfeasibleError", "UnreachableError"),
    "geometry": ("waypoint_path",),
    "lift": ("JointPath", "SplineJointPath", "TaskJointPath", "lift"),
    "planning": ("PlanResult", "PlanSettings", "Profile", "Retimer", "Trajectory", "plan"),
    "robot": ("JointLimits", "Payload", "Robot", "Tool", "load_robot"),
    "simulation": ("SimulationResult", "SimulationSettings", "simulate"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'pathmotion' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
