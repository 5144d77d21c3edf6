"""Time-optimal planning along a joint path: reduced dynamics, limits as objects (limits/) and
their canonical rows (limit_rows.py), reachability analysis, boundary conditions and periodic
cycles, segment-by-segment planning, baselines and verification. Entry point: :func:`plan`."""

from .baselines import Baseline, Baselines
from .boundary import Boundary
from .limits import REGISTRY, EffectiveLimits, Limit, LimitChoice
from .planner import LimitCurves, PlanResult, PlanSettings, effective_limits, plan
from .profile import Profile
from .reduced import ReducedDynamics, reduced_dynamics
from .retime import Retimer
from .trajectory import Samples, Trajectory
from .verify import LimitRatios, limit_ratios

__all__ = [
    "Baseline", "Baselines", "Boundary", "EffectiveLimits", "Limit", "LimitChoice", "LimitCurves", "LimitRatios",
    "PlanResult", "PlanSettings", "REGISTRY", "Profile", "ReducedDynamics", "Retimer", "Samples", "Trajectory", "effective_limits", "limit_ratios",
    "plan", "reduced_dynamics",
]
