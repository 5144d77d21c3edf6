"""A speed scale on the blend segments only (the thesis' transition-segment velocity, Fig. 7.10).

``plan.blend_speed_scale = s`` (0 < s <= 1) slows every blend segment (a transition circle or G2
blend that replaced a sharp corner) to s times the time-optimal profile's speed there, and plans
the rest of the path time-optimally around it:

* on each blend's theta range [a, b]:  x(theta) = s^2 x*(theta)   (x = theta_dot^2, x* optimal).
  This is the optimal profile uniformly slowed: joint velocities and accelerations are s and s^2
  times the optimal ones, torques tau = s^2 (tau* - gamma) + gamma lie between tau* and the gravity
  torque gamma, so it is within every limit;
* between the blends: the planner's own time-optimal profile (:func:`pathmotion.planning.plan` on
  that piece of the path) from the scenario's start condition or the blend's exit speed
  s sqrt(x*(b)) to the next blend's entry speed s sqrt(x*(a)) or the scenario's end condition.

The joined profile is then verified against every limit on a dense time resample, the planner's
check and tolerance. s > 1 is not offered: the optimal profile already touches a limit wherever
it can, so a faster blend would break one.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import defaults
from ..errors import InfeasibleError, ScenarioError
from ..geometry.deviation import distance_to_segments
from .planner import PlanResult, effective_limits, plan
from .profile import Profile
from .trajectory import Trajectory
from .verify import limit_ratios

#: Grid spacing, relative to max(1, path length), below which two pieces' end points are one shared
#: point (the second copy is dropped) [-].
SHARED_POINT = 1e-12


def blend_ranges(task_path, original_task_path) -> tuple[tuple[float, float], ...]:
    """theta ranges [m] (a, b) of the segments of ``task_path`` that are not part of
    ``original_task_path`` (the blends); () when there is no original path."""
    if task_path is None or original_task_path is None:
        return ()
    out = []
    for k, seg in enumerate(task_path.segments):
        mid = seg.evaluate(np.array([0.5 * seg.length]))[0]
        if distance_to_segments(mid, original_task_path.segments)[0] > defaults.BLEND_DETECTION_DISTANCE:
            out.append((float(task_path.offsets[k]), float(task_path.offsets[k + 1])))
    return tuple(out)


def _piece(path, lo: float, hi: float):
    """The joint path restricted to theta in [lo, hi] (same map, open)."""
    inner = tuple(t for t in path.breaks if lo < t < hi)
    return dataclasses.replace(path, domain=(lo, hi), closed=False, breaks=inner,
                               kinks=tuple(t for t in path.kinks if lo < t < hi),
                               peaks=tuple(t for t in path.peaks if lo < t < hi))


def capped_profile(setup, result: PlanResult, ranges, scale: float) -> Profile:
    """The profile of the module docstring (setup: as in :func:`cap_blend_speed`): s^2 x* on ``ranges`` (each (a, b) on the plan's grid),
    time-optimal re-plans between them. Raises the planner's errors (InfeasibleError...)."""
    prof, settings, path = result.profile, result.settings, setup.path
    lo, hi = path.domain
    grids, xs = [], []
    edges = [(lo, None), *[(a, b) for a, b in ranges], (None, hi)]
    for (left_a, left_b), (right_a, right_b) in zip(edges[:-1], edges[1:]):
        p0 = lo if left_b is None else left_b
        p1 = hi if right_a is None else right_a
        if p1 > p0:  # the free piece between two blends (or a path end and a blend)
            start = settings.start if left_b is None else scale * float(np.sqrt(prof.x_at(p0)))
            end = settings.end if right_a is None else scale * float(np.sqrt(prof.x_at(p1)))
            points = None if settings.grid_points is None else max(  # None: adaptive, as the plan
                defaults.BLEND_PIECE_MIN_POINTS, int(round(settings.grid_points * (p1 - p0) / (hi - lo))))
            piece = plan(_piece(path, p0, p1), setup.robot,
                         dataclasses.replace(settings, grid_points=points, start=start, end=end, baselines=False))
            grids.append(piece.profile.grid)
            xs.append(piece.profile.x)
        if right_a is not None:  # the blend itself: the optimal profile slowed
            inside = (prof.grid >= right_a) & (prof.grid <= right_b)
            grids.append(prof.grid[inside])
            xs.append(scale**2 * prof.x[inside])
    grid, x = np.concatenate(grids), np.concatenate(xs)
    keep = np.concatenate([[True], np.diff(grid) > SHARED_POINT * max(1.0, hi - lo)])
    return Profile(grid[keep], x[keep])


def cap_blend_speed(setup, result: PlanResult, scale: float) -> PlanResult:
    """``result`` with the path speed on the scenario's blends at ``scale`` (0 < scale <= 1) times the
    optimal one and time-optimal elsewhere (see the module docstring), verified against every limit.

    setup: any object with ``name``, ``path`` (JointPath), ``robot``, ``task_path`` and
    ``original_task_path`` (e.g. :class:`pathmotion.api.Setup`) whose task path has blends. ScenarioError without
    blends, for a periodic plan or a scale outside (0, 1]; InfeasibleError if the joined motion
    exceeds a limit."""
    if not (np.isfinite(scale) and 0.0 < scale <= 1.0):
        raise ScenarioError(f"plan.blend_speed_scale = {scale!r}; give a number in (0, 1] (1 = the optimal speed; "
                            "faster would break a limit)")
    if scale == 1.0:
        return result
    ranges = blend_ranges(setup.task_path, setup.original_task_path)
    if not ranges:
        raise ScenarioError(f"{setup.name}: plan.blend_speed_scale = {scale:g} needs a blend (path.blends) to act on; "
                            "add a 'circle' or 'g2' blend or leave the scale at 1")
    settings = result.settings
    if settings.periodic:
        raise ScenarioError(f"{setup.name}: plan.blend_speed_scale works on open motions; set plan.periodic = false "
                            "or leave the scale at 1")
    profile = capped_profile(setup, result, ranges, scale)
    traj = Trajectory(setup.path, profile, setup.robot)
    ratios = limit_ratios(traj, effective_limits(setup.robot, settings), settings.verify_sample_time,
                          joint_names=setup.robot.joint_names)
    if not ratios.within(settings.limit_tolerance):
        raise InfeasibleError(f"{setup.name}: with the blend speed at {scale:g} x optimal the motion exceeds a limit "
                              f"({ratios.worst}); raise plan.grid_points or change plan.blend_speed_scale")
    return dataclasses.replace(result, profile=profile, trajectory=traj, ratios=ratios, segment_profiles=(profile,))
