"""pathmotion: time-optimal path-constrained motion for robot arms, proven in closed-loop simulation.

The flow (each arrow a function, each box an immutable value)::

    scenario (TOML) -> Robot -> TaskPath -> JointPath q = Phi(theta) -> PlanResult (Profile, Trajectory)
                    -> SimulationResult -> files, figures, report
"""

from .api import (Setup, build, check_scenario, load, load_text, plan_scenario, simulate_scenario, write_plan,
                  write_simulation)
from .errors import (InfeasibleError, PathError, PathmotionError, RobotModelError, ScenarioError, SimulationError,
                     UnreachableError)
from .joint_path import JointPath, SplineJointPath
from .lift import TaskJointPath, lift
from .planning import PlanResult, PlanSettings, Profile, Trajectory, plan
from .robot import JointLimits, Payload, Robot, Tool, load_robot
from .simulation import SimulationResult, SimulationSettings, simulate

__version__ = "0.1.0"

__all__ = [
    "InfeasibleError", "JointLimits", "JointPath", "PathError", "PathmotionError", "Payload", "PlanResult",
    "PlanSettings", "Profile", "Robot", "RobotModelError", "ScenarioError", "Setup", "SimulationError",
    "SimulationResult", "SimulationSettings", "SplineJointPath", "TaskJointPath", "Tool", "Trajectory",
    "UnreachableError", "build", "check_scenario", "lift", "load", "load_robot", "load_text", "plan",
    "plan_scenario", "simulate", "simulate_scenario", "write_plan", "write_simulation",
]
