"""``pathmotion check``: what a built scenario is (path, corners, feasibility) and every test ``plan`` and
``simulate`` run before they write."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import defaults
from ..errors import InfeasibleError
from ..io import exports, schema
from ..lift.joint_move import PiecewiseJointPath
from ..planning.reduced import reduced_dynamics
from ..planning.trajectory import sample_times
from ..simulation import prepare_loop
from .plan import plan_scenario, reserve_summary
from .setup import Setup
from .simulate import simulation_settings

#: |dq/dtheta| / qd_max below which a path point is treated as not moving the joints [s/rad-of-theta]
#: (its velocity-limited theta_dot is then 1e12, i.e. unlimited).
STILL_PATH_SPEED = 1e-12


def path_is_closed(setup: Setup) -> bool:
    """Whether the path ends where it starts (a full circle does), whether or not it is planned as a
    periodic cycle (``plan.periodic``; a closed path run once is planned as an open motion). A chain with joint moves
    or dwells is always an open motion."""
    if isinstance(setup.path, PiecewiseJointPath):
        return False
    if setup.task_path is not None:
        return bool(setup.task_path.closed)
    q = setup.path.evaluate(np.array(setup.path.domain, float))[0]
    return bool(np.allclose(q[0], q[-1], rtol=0, atol=defaults.PATH_GAP_TOLERANCE))


def check_scenario(setup: Setup) -> dict:
    """What ``pathmotion check`` reports: the path lifted (reachable, in range, away from
    singularities: errors otherwise), its corners, pointwise feasibility (gravity torque below the
    limits, the largest admissible speed > 0 everywhere), and every test plan and simulate run before
    they write (the plan is solved, nothing is written): an OK means plan and simulate start. The setup
    must have run its searches (:func:`pathmotion.api.search`)."""
    setup.require_searched("check_scenario")
    path, robot = setup.path, setup.robot
    out: dict[str, Any] = {schema.SCENARIO.key: setup.name, schema.ROBOT.key: robot.name, "joints": robot.n,
                           schema.PATH_KIND.key: "task" if setup.task_path is not None else "joint",
                           schema.PATH_LENGTH.key: float(path.length), "closed": path_is_closed(setup),
                           "periodic": bool(setup.scenario.plan.periodic)}
    if setup.task_path is not None:
        out["segments"] = len(setup.task_path.segments)
        out["connections"] = [c.describe() for c in setup.task_path.connections]
    out["sharp_corners_theta"] = list(path.kinks)
    check = getattr(path, "check", None)
    if check is not None:
        out[schema.MIN_SINGULAR_VALUE.key] = check.min_singular_value
        out["min_singular_value_theta"] = check.min_singular_theta
        out[schema.JOINT_RANGE_MARGIN.key] = check.range_margin
        out["joint_range_margin_joint"] = check.range_margin_joint
        out[schema.WRIST_CROSSINGS.key] = [ps.summary() for ps in check.wrist_passages]
    out.update(_pointwise_feasibility(setup))
    out.update(_check_like_plan_and_simulate(setup))
    out[schema.EXPORT_NOTES.key] = list(exports.unsupported_exports(robot.n).values())
    return out


def _pointwise_feasibility(setup: Setup) -> dict:
    """The gravity torque's largest share of its limit (InfeasibleError at or above 1) and the smallest
    velocity-limited path speed [rad/s of theta], on 400 points of the path."""
    path, robot = setup.path, setup.robot
    torque, velocity = setup.plan_settings.limits["torque"], setup.plan_settings.limits["velocity"]
    out = {}
    theta = np.linspace(*path.domain, 400)
    q, dq, ddq = path.evaluate(theta)
    if torque.on:
        red = reduced_dynamics(robot, q, dq, ddq)
        ratio = np.abs(red.gamma) / robot.limits.torque / torque.scale
        k, j = np.unravel_index(np.argmax(ratio), ratio.shape)
        out["max_gravity_torque_ratio"] = float(ratio[k, j])
        if ratio[k, j] >= 1:
            raise InfeasibleError(f"gravity torque of {robot.joint_names[j]} at theta = {theta[k]:.4f} is "
                                  f"{abs(red.gamma[k, j]):.1f} N m, above its limit "
                                  f"{robot.limits.torque[j] * torque.scale:.1f} N m; "
                                  "raise the torque limit or move the path")
    if velocity.on:
        speed = np.abs(dq) / robot.limits.velocity / velocity.scale
        peak = np.max(speed, axis=1)
        vmax = 1.0 / np.maximum(peak, STILL_PATH_SPEED)
        out["min_velocity_limited_theta_dot"] = float(np.min(vmax))
    return out


def _check_like_plan_and_simulate(setup: Setup) -> dict:
    """Every test ``plan`` and ``simulate`` run before they write, so that check's OK means OK: the plan
    itself (its boundary, limit and tightening checks), the trajectory's sample count at
    plan.sample_time, the simulation settings (gains, realism), the closed loop's sample budget and
    the loop's set-up (the controller's design, e.g. the orbital Riccati sweep, through the design
    cache, which simulate then reads; the plant)."""
    result = plan_scenario(setup)
    sample_times(result.profile.duration, setup.scenario.plan.sample_time)
    settings = simulation_settings(setup)
    prepare_loop(setup.robot, setup.path, result.profile, setup.scenario.simulate.controller, settings)
    return {schema.DURATION.key: float(result.profile.duration),
            schema.WORST_LIMIT.key: None if result.ratios is None else result.ratios.worst, **reserve_summary(setup)}
