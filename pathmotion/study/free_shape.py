"""The physical limit of cornering: the minimum-time motion of the whole arm whose TCP stays within
``delta`` of a sharp polyline (a reference, not a planner).

Formulation (direct multiple shooting in time with an exact integrator). The motion is split into
phases; phase i has its own duration T_i (free, > 0), N_i intervals of length h_i = T_i / N_i and
a piecewise-constant joint acceleration u_k (6,) per interval, so with states (q_k, qd_k)

    q_{k+1} = q_k + h qd_k + h^2 / 2 u_k        qd_{k+1} = qd_k + h u_k

holds exactly in continuous time. Hence the velocity limit (qd is linear on each interval) and the
acceleration limit (u is constant) hold everywhere when they hold at the nodes. The geometric
constraints are imposed at every node and every interval midpoint (q(t) is quadratic there):

* tool orientation fixed: vee(R_ref^T R(q) - R(q)^T R_ref) / 2 = 0 (3 smooth equations, zero at
  R = R_ref);
* the TCP p(q) within the phase's tube: each phase belongs to one line segment j of the polyline
  (start P_j, unit direction t_j) and a progress range [s_lo, s_hi]; each constrained point has its
  own progress variable s in that range and |p(q) - P_j - t_j s| <= r, imposed in the smooth "norm"
  form sqrt(|gap|^2 + (0.3 r)^2) <= sqrt(1.09) r (r = 0: the equality p(q) = P_j + t_j s). Its
  gradient is about 1 on the boundary at any r; the squared form |gap|^2 <= r^2 has 2 r there
  (2e-4 at 0.1 mm) and a slack of r^2, IPOPT crawled to its iteration cap on every 0.1 mm whole
  tube with it, and IPOPT's bound relaxation (1e-8) widened its tube by 41 % at 0.1 mm (0.5 % at
  1 mm). This is the capsule of segment j, smooth in (q, s); the union of capsules at
  a corner is the union of the phases: the node shared by two phases lies in both capsules. (The
  distance to the polyline itself is not differentiable at the corner; a time-optimal motion runs
  through the capsules in order, so fixing the order loses nothing.)

Torque limits (optional, ``torque=True``): |tau_j(q, qd, u_k)| <= tau_max_j (robot.limits.torque)
with the planner's torque model (:mod:`.symbolic_dynamics`: RNEA with payload, gravity, armature) at
TORQUE_POINTS of every interval: both ends (each node from both sides, with the acceleration of the
interval before and after) and the midpoint, where q is quadratic and qd linear. Between them the
torque is not bounded exactly; the dense verification reports its largest ratio (max_torque_ratio).

Variants: the *whole tube* (r = delta over the whole segment; one phase per segment, or split like
the corner-confined tube when started from it) and the *corner-confined* tube (r = delta only
within [L_j - a, L_j] before and [0, b] after each corner, r = 0 elsewhere: four phases per corner;
a stretch outside the spans that their capsules cover joins them, :func:`effective_spans`).

Rest to rest: q_0, q_N are the IK solutions of the stop-at-corner plan at the path's ends, qd = 0
there. The objective is sum T_i. The initial guess is pathmotion's own time-optimal stop at every
corner (:func:`pathmotion.planning.plan`), sampled at the phase times, or a given feasible motion
(the optimal blend's, for the corner-confined tube), sampled where its TCP crosses the phase
boundaries. IPOPT starts with a small barrier parameter and bound push (TUBE_IPOPT): the tube's
slack is of the order of r, and the default push (1e-2) throws a feasible start far out. A failed
start is retried (STARTS, :func:`_solve_with_restarts`).

Convergence: solved on a sequence of meshes (each warm-started from the previous one); the
reported value is the Richardson extrapolation of the last three durations, the convergence error
its distance from the finest (a sequence whose last two changes differ in sign: the finest, its
last change as the error). Each solution is verified on a dense resample of the exact
piecewise-quadratic q(t): joint velocity, acceleration and torque ratios, TCP distance to the sharp
path, orientation error.

Feasible bound (:func:`feasible_bound`): a mesh imposes the tube only at its points, so between them the TCP may
leave it (0.13 mm, 1.9 % of a 7 mm tube, at 135 deg on 200 intervals) and every mesh's duration, and their
extrapolation, may lie below the true minimum time. The finest mesh re-solved in a tube shrunk by its dense excess,
until its dense resample holds the given tube, is a motion that meets every constraint: its duration is an upper
bound of the true minimum time. The two bracket it.

Units: SI (m, s, rad). CasADi is imported lazily (``pip install "pathmotion[optimal]"``).
"""

from __future__ import annotations

import logging
import signal
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import numpy as np

from ..errors import PathError, PathmotionError
from .symbolic import casadi_module, rodrigues
from .symbolic_dynamics import inverse_dynamics_function

log = logging.getLogger(__name__)

#: Meshes (total intervals) of the convergence sequence.
MESHES = (25, 50, 100, 200)
#: Interior points (fractions of an interval) where the tube is imposed, besides the nodes; the
#: orientation is imposed at the nodes and the midpoint (more equations would overconstrain).
TUBE_POINTS = (0.25, 0.5, 0.75)
#: Points (fractions of an interval) where the torque limit is imposed (torque=True): both ends (the
#: nodes, with the acceleration of the interval before and after) and the midpoint. The quarter points
#: too changed nothing measurable (90 degree turn, delta = 0, 100 intervals: same duration to 1e-11 s,
#: dense torque ratio 1.0 either way) at 1.7 times the solve time; at 2 mm the dense ratio is 1.00001.
TORQUE_POINTS = (0.0, 0.5, 1.0)
#: Dense resample of the verification: points per interval.
VERIFY_POINTS_PER_INTERVAL = 16
#: The feasible bound: its tube is shrunk by this times the dense excess on the first retry, twice that factor on each
#: next one (the excess need not scale with the radius: at 30 deg / 5 mm the TCP passes outside the corner's vertex
#: between the last point of one segment's phase and the first of the next, 0.147, 0.011, 0.0026 mm at shrinks of
#: 1.1 times each), at most FEASIBLE_SOLVES solves, checked on a resample this many times denser than the
#: verification's.
FEASIBLE_SHRINK = 1.1
FEASIBLE_SOLVES = 4
FEASIBLE_RESAMPLE = 4
#: The feasible bound's stretches held on the line (the corner-confined tube outside its spans, radius 0) count as
#: held within this distance [m]: a piecewise-quadratic q(t) cannot keep the TCP on a line between its points, and
#: no radius to shrink is left there (60 deg / 5 mm: 3 um off the line after the corner stretches held).
FEASIBLE_LINE_TOLERANCE = 1e-5
#: IPOPT: convergence tolerance and iteration cap.
IPOPT_TOL = 1e-9
IPOPT_MAX_ITER = 1500
#: IPOPT options of the norm-form tube: a small initial barrier and bound push (the tube's slack is
#: of the order of its radius, 1e-4 m at 0.1 mm, where the default push of 1e-2 throws the start out).
TUBE_IPOPT = {"mu_init": 1e-4, "bound_push": 1e-8, "bound_frac": 1e-8, "max_iter": 600}
#: The last resort: IPOPT's defaults (continuation that way converged at 90 degrees, 1 mm, corner-
#: confined, where a small barrier hit the cap).
FALLBACK_IPOPT = {"max_iter": 1000}
#: Starts tried per mesh until IPOPT converges: (source, IPOPT options, tube form); source "previous"
#: is the previous mesh's solution resampled (the start on the first mesh), "start" the given start,
#: "stop" the stop at the corners (the last resort from a given start: the whole tube from the
#: corner-confined solutions hit the caps at 30 degrees 0.1 mm on 50 intervals).
STARTS = (("previous", TUBE_IPOPT, "norm"), ("start", TUBE_IPOPT, "norm"), ("previous", FALLBACK_IPOPT, "norm"))
STARTS_WARM = (("start", TUBE_IPOPT, "norm"), ("previous", TUBE_IPOPT, "norm"), ("previous", FALLBACK_IPOPT, "norm"),
               ("stop", TUBE_IPOPT, "norm"))
#: IPOPT options of a start with multipliers (WithMultipliers): IPOPT takes the given primal and dual point
#: (warm_start_init_point) and pushes it off the bounds by no more than 1e-9 (default 1e-3), with a barrier that starts
#: at 1e-9 and adapts (mu_strategy adaptive). Why: at 30 deg / 0.1 mm the whole tube from the corner-confined solutions
#: hit the cap on 100 intervals with TUBE_IPOPT (the barrier of 1e-4 pushed the iterate off the active bounds); with
#: their multipliers and the monotone barrier fixed at 1e-9 it hit the cap too (600 iterations on 25 intervals, tiny
#: steps), with a monotone barrier from 1e-6 on 50 intervals; the adaptive barrier converged.
WARM_IPOPT = {"warm_start_init_point": "yes", "warm_start_bound_push": 1e-9, "warm_start_bound_frac": 1e-9,
              "warm_start_slack_bound_push": 1e-9, "warm_start_slack_bound_frac": 1e-9,
              "warm_start_mult_bound_push": 1e-9, "mu_init": 1e-9, "mu_strategy": "adaptive", "max_iter": 600}
#: Node density of the corner-confined tube's stretches at a corner relative to the rest.
CORNER_DENSITY = 4.0
#: Smallest phase duration [s] and the fewest intervals a phase gets.
MIN_PHASE_DURATION = 1e-4
MIN_PHASE_INTERVALS = 3
#: Clamp of the observed convergence order used by the extrapolation.
ORDER_RANGE = (0.5, 4.0)
#: Polyline segments shorter than this [m] are an error.
MIN_SEGMENT_LENGTH = 1e-6
#: A corner span longer than its segment by at most this [m] is rounding (a blend over a whole segment ends
#: at 0.2 + 7e-17 m) and is clipped to the segment; by more, an error.
SPAN_ROUNDING = 1e-9
#: Smoothing of the "norm" tube constraint, relative to the radius (see _tube).
NORM_SMOOTHING = 0.3


# ----------------------------------------------------------------------------------- kinematics
def _axis(joint) -> np.ndarray:
    """Unit axis (3,) of a revolute joint; PathmotionError for any other joint type."""
    from ..robot.joints import REVOLUTE, joint_motion

    motion = joint_motion(joint)
    if motion is None or motion[0] != REVOLUTE:
        raise PathmotionError(f"the free-shape solver handles chains of revolute joints; joint type "
                              f"{joint.shortname()} is not one (lock it with load_robot(..., locked_joints=...))")
    return motion[1]


def tcp_function(robot, frame: str | int | None = None):
    """CasADi Function q (n,) -> (p (3,), R (3, 3)) of ``frame`` (default TCP) in the base frame,
    built from the Pinocchio model's joint placements and axes (a chain of revolute joints)."""
    ca = casadi_module()
    model = robot.model
    fid = robot.frame_id(frame)
    q = ca.SX.sym("q", robot.n)
    poses: dict[int, tuple] = {0: (ca.SX.eye(3), ca.SX.zeros(3, 1))}
    for i in range(1, model.njoints):
        if model.joints[i].nq != 1:
            raise PathmotionError(f"the free-shape solver handles one-coordinate joints; {model.names[i]} has "
                                  f"{model.joints[i].nq}")
        R0, p0 = poses[model.parents[i]]
        placement = model.jointPlacements[i]
        Rj = R0 @ ca.DM(placement.rotation)
        pj = p0 + R0 @ ca.DM(placement.translation)
        poses[i] = (Rj @ rodrigues(ca, _axis(model.joints[i]), q[model.joints[i].idx_q]), pj)
    frm = model.frames[fid]
    parent = frm.parentJoint if hasattr(frm, "parentJoint") else frm.parent
    R0, p0 = poses[parent]
    p = p0 + R0 @ ca.DM(frm.placement.translation)
    R = R0 @ ca.DM(frm.placement.rotation)
    return ca.Function("tcp", [q], [p, R], ["q"], ["p", "R"])


# ----------------------------------------------------------------------------------- problem
@dataclass(frozen=True)
class Phase:
    """A stretch of the motion near segment ``segment`` of the polyline: progress s in [s_lo, s_hi]
    [m] along it, TCP within ``radius`` [m] of that stretch (0: on it); ``density``: relative node
    density (the stretches at a corner get more nodes, where the TCP turns fast)."""

    segment: int
    s_lo: float
    s_hi: float
    radius: float
    density: float = 1.0


@dataclass(frozen=True)
class Polyline:
    """Sharp path: points (m, 3) [m], with unit directions and lengths of its m - 1 line segments."""

    points: np.ndarray

    def __post_init__(self):
        p = np.asarray(self.points, float)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2:
            raise PathError(f"free shape: the sharp path needs >= 2 points of 3 coordinates, got shape {p.shape}")
        lengths = np.linalg.norm(np.diff(p, axis=0), axis=1)
        if np.any(lengths < MIN_SEGMENT_LENGTH):
            k = int(np.argmin(lengths))
            raise PathError(f"free shape: segment {k + 1} of the sharp path has length {lengths[k]:.3g} m; "
                            "remove repeated points")
        object.__setattr__(self, "points", p)

    @property
    def lengths(self) -> np.ndarray:
        return np.linalg.norm(np.diff(self.points, axis=0), axis=1)

    @property
    def directions(self) -> np.ndarray:
        return np.diff(self.points, axis=0) / self.lengths[:, None]

    def distance(self, pts: np.ndarray) -> np.ndarray:
        """Distance [m] (N,) of points (N, 3) to the polyline."""
        pts = np.atleast_2d(pts)
        best = np.full(len(pts), np.inf)
        for P, t, L in zip(self.points[:-1], self.directions, self.lengths):
            s = np.clip((pts - P) @ t, 0.0, L)
            best = np.minimum(best, np.linalg.norm(pts - P - s[:, None] * t, axis=1))
        return best


def tube_phases(line: Polyline, delta: float, spans: Sequence[tuple[float, float]] | None = None,
                crowd: Sequence[tuple[float, float]] | None = None) -> list[Phase]:
    """Phases of the whole tube (``spans`` None) or of the corner-confined one (``spans[c]`` = (a, b)
    [m]: deviation allowed in the last a of the segment before corner c and the first b after it).
    ``crowd`` (whole tube): split it the same way, radius delta everywhere, so that its nodes crowd
    at the corners like the corner-confined tube's (one phase per segment without). Stretches the
    corner stretches' capsules cover are absorbed into them (:func:`effective_spans`)."""
    L = line.lengths
    given = crowd if spans is None else spans
    if given is not None and len(given) != len(L) - 1:
        raise PathError(f"free shape: {len(given)} corner spans given for {len(L) - 1} corners")
    if spans is None:
        return _split_phases(L, effective_spans(L, delta, crowd or [(0.0, 0.0)] * (len(L) - 1)), delta, delta)
    return _split_phases(L, effective_spans(L, delta, spans), delta, 0.0)


def effective_spans(lengths, delta: float, spans: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """``spans`` (a, b) [m] per corner with every stretch between them that the neighbouring corner
    stretches' capsules (radius ``delta``) cover absorbed into them: at a path end one no longer than
    delta, between two corners one no longer than 2 delta (split at its middle). Such a stretch's own
    constraint adds (next to) nothing to their caps, so nothing makes the motion cross it: its phase
    shrank to MIN_PHASE_DURATION with degenerate nodes, and IPOPT hit its cap on every mesh from
    every start (60 deg / 10 mm corner-confined, spans 198.05 / 199.9998 mm of 0.2 m: 1.95 mm and
    0.2 um stretches on the line). A span past its segment by rounding (SPAN_ROUNDING) is clipped to it.
    Spans without such a stretch come back unchanged."""
    L = np.asarray(lengths, float)

    def clipped(span: float, length: float) -> float:
        return float(min(span, length)) if span - length <= SPAN_ROUNDING else float(span)

    out = [[clipped(a, L[c]), clipped(b, L[c + 1])] for c, (a, b) in enumerate(spans)]
    n = len(out)
    for j in range(len(L)):  # the stretch of segment j outside the corner stretches: [lo, hi]
        lo = out[j - 1][1] if j > 0 else 0.0
        hi = L[j] - out[j][0] if j < n else L[j]
        before, after = j > 0 and out[j - 1][1] > 0, j < n and out[j][0] > 0  # corner stretches next to it
        if delta <= 0 or not 0 < hi - lo <= (before + after) * delta:
            continue
        if before and after:
            mid = float(0.5 * (lo + hi))
            out[j - 1][1], out[j][0] = mid, float(L[j] - mid)
        elif after:
            out[j][0] = float(L[j] - lo)
        else:
            out[j - 1][1] = float(hi)
    return [(a, b) for a, b in out]


def _split_phases(L: np.ndarray, spans, delta: float, outside: float) -> list[Phase]:
    """Per segment j: the stretch after the previous corner (spans[j - 1][1], radius delta, density
    CORNER_DENSITY), the middle (radius ``outside``), the stretch before the next corner (spans[j][0])."""
    phases = []
    for j in range(len(L)):
        lo = float(spans[j - 1][1]) if j > 0 else 0.0
        hi = float(L[j] - spans[j][0]) if j < len(L) - 1 else float(L[j])
        if lo < 0 or hi > L[j] or lo > hi:
            raise PathError(f"free shape: corner spans {spans} do not fit segment {j + 1} ({L[j]:.6g} m)")
        if j > 0 and lo > 0:
            phases.append(Phase(j, 0.0, lo, delta, CORNER_DENSITY))
        if hi > lo:
            phases.append(Phase(j, lo, hi, outside))
        if j < len(L) - 1 and hi < L[j]:
            phases.append(Phase(j, hi, float(L[j]), delta, CORNER_DENSITY))
    return phases


@dataclass(frozen=True, eq=False)
class Guess:
    """A motion sampled per phase: t (N+1,) [s] node times, q, qd (N+1, n), u (N, n), and the node
    index where each phase starts (len = phases + 1, last = N)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    u: np.ndarray
    breaks: tuple[int, ...]


@dataclass(frozen=True, eq=False)
class FreeShapeSolution:
    """One mesh's result: duration [s], solver status, success flag, the motion (a Guess) and its
    dense verification (max ratios of |qd|/qd_max and |qdd|/qdd_max, max TCP distance to the sharp
    path [m], max orientation error [rad], max excess of the distance over the allowed radius [m],
    max ratio of |tau| / tau_max, reported with or without torque limits)."""

    duration: float
    status: str
    success: bool
    motion: Guess
    verification: dict = field(default_factory=dict)
    iterations: int = -1
    #: The constraints' multipliers at the solution, by constraint (see solve_mesh); {} when not kept.
    multipliers: dict = field(default_factory=dict, repr=False)

    @property
    def intervals(self) -> int:
        return len(self.motion.u)


# ----------------------------------------------------------------------------------- initial guess
def stop_plan(robot, line: Polyline, rotation=None, grid_points: int | None = None, torque: bool = False):
    """pathmotion's time-optimal plan that stops at every corner of ``line`` (velocity and
    acceleration limits, and the whole torque limits when ``torque``, no feedback reserve, as the free-shape NLPs
    take them (a reserve: a reduced robot, study.atlas.reserved); tool orientation ``rotation`` (3, 3), default tool
    down): (JointPath, PlanResult)."""
    from ..lift.constraint import lift
    from ..geometry import FixedOrientation, Line, TaskPath
    from ..planning import PlanSettings, plan

    segs = tuple(Line(a, b) for a, b in zip(line.points[:-1], line.points[1:]))
    orient = FixedOrientation() if rotation is None else FixedOrientation(np.asarray(rotation, float))
    path = lift(robot, TaskPath(segs, orient))
    kw = {} if grid_points is None else {"grid_points": grid_points}
    settings = PlanSettings(start="zero", end="zero", connections="zero",
                            limits={"use_velocity": True, "use_acceleration": True, "use_torque": torque,
                                    "torque_reserve": 0.0}, baselines=False, **kw)
    return path, plan(path, robot, settings)


def guess_from_plan(result, line: Polyline, phases: Sequence[Phase], intervals: int) -> Guess:
    """The plan ``result`` (its trajectory runs along ``line`` with theta = arc length) sampled at
    ``intervals`` uniform steps split over ``phases`` in proportion to their durations."""
    prof, traj = result.profile, result.trajectory
    offsets = np.concatenate([[0.0], np.cumsum(line.lengths)])
    theta_b = [offsets[ph.segment] + ph.s_lo for ph in phases] + [offsets[phases[-1].segment] + phases[-1].s_hi]
    t_b = np.interp(theta_b, prof.grid, prof.times)
    t_b[0], t_b[-1] = 0.0, prof.duration
    def at_time(t):
        smp = traj.at_time(t)
        return smp.q, smp.qd

    return _resample(at_time, t_b, intervals, [ph.density for ph in phases])


def guess_from_motion(robot, result, line: Polyline, phases: Sequence[Phase], intervals: int,
                      samples: int = 4000) -> Guess:
    """A plan ``result`` whose TCP runs within the phases' tube along ANY path (e.g. a blended one)
    sampled like :func:`guess_from_plan`; the phase boundaries are the times where the TCP crosses
    them: the progress s_hi along the segment, or, between segments, the corner's bisector plane
    (a point inside the corner on it is equally far from both lines, so in both capsules)."""
    from ..robot import fk

    traj, T = result.trajectory, float(result.profile.duration)
    t = np.linspace(0.0, T, samples)
    pos = np.atleast_2d(fk(robot, traj.at_time(t).q)[0])
    t_b = [0.0]
    for a, b in zip(phases[:-1], phases[1:]):
        if a.segment == b.segment:
            f = (pos - line.points[a.segment]) @ line.directions[a.segment] - a.s_hi
        else:
            f = (pos - line.points[b.segment]) @ (line.directions[a.segment] + line.directions[b.segment])
        # the first crossing after the previous boundary: past 90 degrees the path's start already lies beyond s_hi
        # along the exit segment (150 deg: 173 mm), so a crossing searched from t = 0 put the whole exit line into
        # the exit's corner stretch, a start 0.18 m outside its tube
        after = (t > t_b[-1]) & (f >= 0)
        k = max(int(np.argmax(after)) if np.any(after) else len(t) - 1, 1)
        tc = t[k - 1] + (t[k] - t[k - 1]) * (-f[k - 1]) / (f[k] - f[k - 1]) if f[k - 1] < 0 <= f[k] else t[k - 1]
        t_b.append(float(np.clip(tc, t_b[-1] + MIN_PHASE_DURATION, T)))
    t_b.append(T)

    def at_time(tt):
        smp = traj.at_time(tt)
        return smp.q, smp.qd

    return _resample(at_time, np.array(t_b), intervals, [ph.density for ph in phases])


def _resample(at_time, t_b: np.ndarray, intervals: int, density: Sequence[float]) -> Guess:
    """Uniform nodes per phase (phase i spans [t_b[i], t_b[i+1]]) of a motion given by at_time(t),
    about ``intervals`` in all, in proportion to duration x density."""
    dur = np.diff(t_b)
    weight = dur * np.asarray(density, float)
    counts = np.maximum(MIN_PHASE_INTERVALS, np.round(intervals * weight / weight.sum()).astype(int))
    times, breaks = [np.array([0.0])], [0]
    for i, n in enumerate(counts):
        times.append(np.linspace(t_b[i], t_b[i + 1], n + 1)[1:])
        breaks.append(breaks[-1] + int(n))
    t = np.concatenate(times)
    q, qd = (np.asarray(a, float) for a in at_time(t))
    u = np.diff(qd, axis=0) / np.maximum(np.diff(t), MIN_PHASE_DURATION / max(counts))[:, None]
    return Guess(t, q, qd, u, tuple(breaks))


def _motion_at(motion: Guess):
    """at_time(t) -> (q, qd) of the exact piecewise-quadratic motion."""
    def at_time(t):
        t = np.clip(np.asarray(t, float), motion.t[0], motion.t[-1])
        k = np.clip(np.searchsorted(motion.t, t, side="right") - 1, 0, len(motion.u) - 1)
        tau = (t - motion.t[k])[:, None]
        u = motion.u[k]
        return motion.q[k] + motion.qd[k] * tau + 0.5 * u * tau ** 2, motion.qd[k] + u * tau
    return at_time


def _phase_times(motion: Guess) -> np.ndarray:
    return motion.t[list(motion.breaks)]


# ----------------------------------------------------------------------------------- the NLP
def _orientation_error(ca, R, R_ref):
    E = ca.DM(R_ref).T @ R
    return 0.5 * ca.vertcat(E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1])


def _tube(con: "_Constraints", ca, p, line: Polyline, ph: Phase, s0: float, form: str = "norm", key=()):
    """Constrain the TCP position expression p (3,) to the phase's capsule (with its own progress s).
    ``form`` (radius r > 0; r = 0 is the equality gap = 0):

    * "norm": sqrt(|gap|^2 + (e r)^2) <= sqrt(1 + e^2) r (e = NORM_SMOOTHING): exactly |gap| <= r, with
      a gradient of about 1 on the boundary and a value of the order of r, like the tube itself;
    * "squared": |gap|^2 <= r^2 (gradient 2 r on the boundary: 2e-4 at 0.1 mm; IPOPT relaxes its
      bound by 1e-8 m^2, a tube of sqrt(r^2 + 1e-8): 41 % wider at 0.1 mm, 0.5 % at 1 mm);
    * "scaled": |gap / r|^2 <= 1 (gradient 2 / r: 2e4 at 0.1 mm).

    ``con`` (the Opti's _Constraints) adds the constraints under ``key`` + ("s",) and + ("tube", form),
    form "on" for r = 0 (another constraint than an inequality: their multipliers do not carry over)."""
    opti = con.opti
    s = opti.variable()
    con(key + ("s",), opti.bounded(ph.s_lo, s, ph.s_hi))
    opti.set_initial(s, float(np.clip(s0, ph.s_lo, ph.s_hi)))
    gap = p - ca.DM(line.points[ph.segment]) - ca.DM(line.directions[ph.segment]) * s
    r = ph.radius
    if r == 0:
        con(key + ("tube", "on"), gap == 0)
    elif form == "norm":
        e2 = (NORM_SMOOTHING * r) ** 2
        con(key + ("tube", form), ca.sqrt(ca.sumsqr(gap) + e2) <= float(np.sqrt(r ** 2 + e2)))
    elif form == "scaled":
        con(key + ("tube", form), ca.sumsqr(gap / r) <= 1.0)
    elif form == "squared":
        con(key + ("tube", form), ca.sumsqr(gap) <= r ** 2)
    else:
        raise PathmotionError(f"free shape: tube form {form!r} is none of norm, squared, scaled")


class _Constraints:
    """An Opti's constraints by key: ``spans[key]`` = (first, end) rows of opti.lam_g (Opti orders its constraints as
    they are added), so that the multipliers of one NLP can start another on the same nodes whose constraints differ
    (a key names a constraint by what it constrains where: e.g. ("R", k, 0.5), the orientation at the middle of
    interval k)."""

    def __init__(self, opti):
        self.opti, self.spans = opti, {}

    def __call__(self, key: tuple, expr):
        if key in self.spans:
            raise PathmotionError(f"free shape: constraint {key} added twice")  # pragma: no cover - a coding error
        first = self.opti.ng
        self.opti.subject_to(expr)
        self.spans[key] = (first, self.opti.ng)

    def multipliers(self, lam_g) -> dict:
        """{key: its multipliers (rows,)} of the full multiplier vector ``lam_g`` (ng,)."""
        lam = np.atleast_1d(np.asarray(lam_g, float)).ravel()
        return {key: lam[a:b].copy() for key, (a, b) in self.spans.items()}

    def start(self, multipliers: dict) -> tuple[np.ndarray, int]:
        """(lam_g0 (ng,), rows matched): ``multipliers`` (another NLP's, by key) where a constraint of this NLP has
        the same key and size, 0 for the rest (constraints it did not have, e.g. the tube's inner points)."""
        lam = np.zeros(self.opti.ng)
        matched = 0
        for key, (a, b) in self.spans.items():
            given = multipliers.get(key)
            if given is not None and len(given) == b - a:
                lam[a:b] = given
                matched += b - a
        return lam, matched


def solve_mesh(robot, line: Polyline, phases: Sequence[Phase], guess: Guess, rotation,
               velocity_scale: float = 1.0, acceleration_scale: float = 1.0,
               ipopt: dict | None = None, form: str = "norm", torque: bool = False,
               multipliers: dict | None = None) -> FreeShapeSolution:
    """Solve the minimum-time NLP on the mesh of ``guess`` (its node counts per phase), from it;
    ``ipopt``: options over the defaults; ``form``: the tube constraint's form, "norm" (what STARTS
    uses), "squared" or "scaled" (:func:`_tube`; kept to compare the forms);
    ``torque``: also |tau| <= the robot's torque limits at TORQUE_POINTS of every interval (:func:`_torque`);
    ``multipliers``: a solution's on the same nodes (FreeShapeSolution.multipliers) as IPOPT's initial multipliers,
    by constraint (_Constraints.start; give WARM_IPOPT's options with them). The solution keeps its multipliers."""
    ca = casadi_module()
    tcp = tcp_function(robot)
    n = robot.n
    lim = robot.limits
    vmax, amax = lim.velocity * velocity_scale, lim.acceleration * acceleration_scale
    opti = ca.Opti()
    N = len(guess.u)
    Q, QD, U = opti.variable(n, N + 1), opti.variable(n, N + 1), opti.variable(n, N)
    T = opti.variable(len(phases))
    opti.set_initial(Q, guess.q.T)
    opti.set_initial(QD, guess.qd.T)
    opti.set_initial(U, guess.u.T)
    t_b = _phase_times(guess)
    opti.set_initial(T, np.diff(t_b))
    con = _Constraints(opti)
    _limits(con, (Q, QD, U, T), guess.q[[0, -1]], vmax, amax, lim)
    p_guess = _guess_positions(robot, guess)
    # a start with multipliers starts each inner point's progress at its own TCP position's (the chord's, else:
    # 1.5 mm off along the line at 30 deg / 0.1 mm on 25 intervals, where the motion accelerates)
    p_inner = _inner_positions(robot, guess) if multipliers else None
    torque_points = [] if torque else None
    for i, ph in enumerate(phases):
        k0, k1 = guess.breaks[i], guess.breaks[i + 1]
        h = T[i] / (k1 - k0)
        P, t = line.points[ph.segment], line.directions[ph.segment]
        for k in range(k0, k1):
            con(("q+", k), Q[:, k + 1] == Q[:, k] + h * QD[:, k] + 0.5 * h ** 2 * U[:, k])
            con(("qd+", k), QD[:, k + 1] == QD[:, k] + h * U[:, k])
            if torque:
                torque_points += _torque_points(Q, QD, U, k, h)
            p_a, p_b = p_guess[k], p_guess[k + 1]
            p, R = tcp(Q[:, k + 1])
            if k + 1 < N:  # q_N is fixed, its orientation too
                con(("R", k, 1.0), _orientation_error(ca, R, rotation) == 0)
            _tube(con, ca, p, line, ph, (p_b - P) @ t, form, (k, 1.0))
            if ph.radius == 0:  # on a line the nodes alone leave the NLP its degrees of freedom
                continue
            for i_f, f in enumerate(TUBE_POINTS):
                p, R = tcp(Q[:, k] + f * h * QD[:, k] + 0.5 * (f * h) ** 2 * U[:, k])
                if f == 0.5:
                    con(("R", k, f), _orientation_error(ca, R, rotation) == 0)
                p_f = p_a + f * (p_b - p_a) if p_inner is None else p_inner[k, i_f]
                _tube(con, ca, p, line, ph, (p_f - P) @ t, form, (k, f))
    if torque:
        _torque(con, ca, robot, torque_points, lim.torque)
    opti.minimize(ca.sum1(T))
    if multipliers:
        lam0, matched = con.start(multipliers)
        opti.set_initial(opti.lam_g, lam0)
        log.debug("free shape: %d of %d multipliers from the start", matched, len(lam0))
    opti.solver("ipopt", {"print_time": False, "expand": not torque},
                {"print_level": 0, "tol": IPOPT_TOL, "max_iter": IPOPT_MAX_ITER, "sb": "yes", **(ipopt or {})})
    try:
        with _interrupts_kept():
            sol = opti.solve()
        stats, value = sol.stats(), sol.value
    except RuntimeError:
        stats, value = opti.stats(), opti.debug.value
    status = str(stats.get("return_status", "unknown"))
    success = bool(stats.get("success", False))
    Tv = np.atleast_1d(np.asarray(value(T), float)).ravel()
    t = np.concatenate([[0.0]] + [np.linspace(0, Tv[i], guess.breaks[i + 1] - guess.breaks[i] + 1)[1:]
                                  + Tv[:i].sum() for i in range(len(phases))])
    motion = Guess(t, np.asarray(value(Q)).T, np.asarray(value(QD)).T, np.asarray(value(U)).T, guess.breaks)
    return FreeShapeSolution(float(Tv.sum()), status, success, motion,
                             verify(robot, line, phases, motion, rotation, vmax, amax), int(stats.get("iter_count", -1)),
                             con.multipliers(value(opti.lam_g)))


#: The signals whose Python handler (Python's default for SIGINT, the command line's for SIGINT and SIGTERM) raises
#: KeyboardInterrupt, which CasADi swallows inside a solve (_interrupts_kept).
INTERRUPT_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def _interrupts_kept() -> Iterator[None]:
    """An interrupt (Ctrl-C; SIGTERM under the command line) during a solve raised again after it. CasADi catches the
    KeyboardInterrupt, stops IPOPT and returns the solve as failed (NonIpopt_Exception_Thrown), so the meshes and
    starts went on as if IPOPT had failed, and `pathmotion corners` ran on to exit 0. In the main thread only (where
    signal handlers live), for the INTERRUPT_SIGNALS that have a Python handler, which still runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: h for s in INTERRUPT_SIGNALS if callable(h := signal.getsignal(s))}
    caught: list[int] = []

    def handler(signum, frame):
        caught.append(signum)
        previous[signum](signum, frame)

    for s in previous:
        signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        if caught:
            raise KeyboardInterrupt(f"signal {caught[0]} during an IPOPT solve")


def _limits(con, variables, ends: np.ndarray, vmax, amax, lim):
    """Phase durations T >= MIN_PHASE_DURATION, joint velocity (``vmax``), acceleration (``amax``) and position
    (``lim``) bounds at every node and interval, q at the ``ends`` (2, n) and at rest there (``variables``: Q, QD, U, T)."""
    Q, QD, U, T = variables
    opti = con.opti
    con(("T",), T >= MIN_PHASE_DURATION)
    for j in range(Q.shape[0]):
        con(("qd", j), opti.bounded(-vmax[j], QD[j, :], vmax[j]))
        con(("u", j), opti.bounded(-amax[j], U[j, :], amax[j]))
        con(("q", j), opti.bounded(lim.lower[j], Q[j, :], lim.upper[j]))
    con(("q", "start"), Q[:, 0] == ends[0])
    con(("q", "end"), Q[:, -1] == ends[1])
    con(("qd", "start"), QD[:, 0] == 0)
    con(("qd", "end"), QD[:, -1] == 0)


def _torque_points(Q, QD, U, k: int, h) -> list[tuple]:
    """(q, qd, qdd) at TORQUE_POINTS of interval k: q quadratic, qd linear, qdd = u_k constant there
    (its ends: the nodes with the acceleration of this interval)."""
    out = []
    for f in TORQUE_POINTS:
        if f in (0.0, 1.0):
            q, qd = Q[:, k + int(f)], QD[:, k + int(f)]
        else:
            q, qd = Q[:, k] + f * h * QD[:, k] + 0.5 * (f * h) ** 2 * U[:, k], QD[:, k] + f * h * U[:, k]
        out.append((q, qd, U[:, k]))
    return out


def _torque(con: "_Constraints", ca, robot, points: list[tuple], tau_max: np.ndarray):
    """|tau_j| <= tau_max_j, as tau / tau_max in [-1, 1], at the (q, qd, qdd) ``points``, each a call of
    one symbolic RNEA Function. The NLP is then not expanded (solve_mesh): CasADi differentiates the
    Function once for all calls, where expanding inlines every call (50 intervals at delta = 0: 18 s
    with expansion, 7 s without; one mapped call, unexpanded: 11 s)."""
    rnea = inverse_dynamics_function(robot)
    scale = ca.DM(1.0 / np.asarray(tau_max, float))
    for i, (q, qd, qdd) in enumerate(points):
        con(("tau", i), con.opti.bounded(-1.0, rnea(q, qd, qdd) * scale, 1.0))


def _guess_positions(robot, guess: Guess) -> np.ndarray:
    from ..robot import fk

    return np.atleast_2d(fk(robot, guess.q)[0])


def _within_intervals(motion: Guess, fractions) -> tuple[np.ndarray, np.ndarray]:
    """(q, qd), each (N, F, n), of the exact piecewise-quadratic ``motion`` at the ``fractions`` (F,) of each of
    its N intervals (0: the interval's start, 1: its end with that interval's acceleration)."""
    h = np.diff(motion.t)[:, None, None] * np.asarray(fractions, float)[None, :, None]  # (N, F, 1)
    q = motion.q[:-1, None] + motion.qd[:-1, None] * h + 0.5 * motion.u[:, None] * h ** 2
    return q, motion.qd[:-1, None] + motion.u[:, None] * h


def _inner_positions(robot, guess: Guess) -> np.ndarray:
    """TCP positions [m] (N, len(TUBE_POINTS), 3) of the exact piecewise-quadratic ``guess`` at TUBE_POINTS of
    each of its N intervals."""
    from ..robot import fk

    q = _within_intervals(guess, TUBE_POINTS)[0]
    return np.atleast_2d(fk(robot, q.reshape(-1, q.shape[-1]))[0]).reshape(len(guess.u), len(TUBE_POINTS), 3)


def _dense(robot, motion: Guess, per_interval: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(q (N, n), qd (N, n), TCP position (N, 3) [m], rotation (N, 3, 3)) of the motion at ``per_interval`` evenly
    spaced times per interval and its end."""
    from ..robot import fk

    tau = np.linspace(0.0, 1.0, per_interval, endpoint=False)
    t = np.concatenate([motion.t[k] + tau * (motion.t[k + 1] - motion.t[k]) for k in range(len(motion.u))]
                       + [motion.t[-1:]])
    q, qd = _motion_at(motion)(t)
    return (q, qd, *fk(robot, q))


def verify(robot, line: Polyline, phases: Sequence[Phase], motion: Guess, rotation, vmax, amax,
           per_interval: int = VERIFY_POINTS_PER_INTERVAL, dense: tuple | None = None) -> dict:
    """Dense check of a motion (see FreeShapeSolution.verification); ``dense``: its _dense resample at
    ``per_interval``, when the caller has it."""
    ratio = max_torque_ratio(robot, motion, per_interval)
    q, qd, pos, rot = _dense(robot, motion, per_interval) if dense is None else dense
    dist = line.distance(pos)
    R_ref = np.asarray(rotation, float)
    cosang = np.clip((np.einsum("ij,nij->n", R_ref, rot) - 1.0) / 2.0, -1.0, 1.0)
    return {"max_velocity_ratio": float(np.max(np.abs(qd) / vmax)),
            "max_acceleration_ratio": float(np.max(np.abs(motion.u) / amax)),
            "max_deviation_m": float(np.max(dist)),
            "max_excess_m": float(np.max(_excess(phases, line, pos))),
            "max_orientation_error_rad": float(np.max(np.arccos(cosang))),
            "max_torque_ratio": ratio,
            "samples": int(len(q))}


def max_torque_ratio(robot, motion: Guess, per_interval: int = VERIFY_POINTS_PER_INTERVAL) -> float:
    """Largest |tau_j| / tau_max_j (robot.limits.torque) of the exact piecewise-quadratic ``motion``,
    by Pinocchio's RNEA (independent of the NLP's symbolic one) at ``per_interval`` + 1 points of
    each interval, both ends with that interval's acceleration (so each node from both sides)."""
    from ..robot import rnea

    q, qd = _within_intervals(motion, np.linspace(0.0, 1.0, per_interval + 1))
    qdd = np.broadcast_to(motion.u[:, None], q.shape)
    n = robot.n
    tau = rnea(robot, q.reshape(-1, n), qd.reshape(-1, n), qdd.reshape(-1, n))
    return float(np.max(np.abs(tau) / robot.limits.torque))


def _excess(phases: Sequence[Phase], line: Polyline, pts: np.ndarray) -> np.ndarray:
    """Distance [m] (N,) of each point (N, 3) outside the union of the phases' capsules (<= 0 inside)."""
    return np.min(_phase_excess(phases, line, pts), axis=0)


def _phase_excess(phases: Sequence[Phase], line: Polyline, pts: np.ndarray) -> np.ndarray:
    """Distance [m] (len(phases), N) of each point (N, 3) outside each phase's capsule (<= 0 inside)."""
    out = np.empty((len(phases), len(pts)))
    for i, ph in enumerate(phases):
        P, t = line.points[ph.segment], line.directions[ph.segment]
        s = np.clip((pts - P) @ t, ph.s_lo, ph.s_hi)
        out[i] = np.linalg.norm(pts - P - s[:, None] * t, axis=1) - ph.radius
    return out


# ----------------------------------------------------------------------------------- convergence
@dataclass(frozen=True, eq=False)
class FreeShapeOptimum:
    """The converged reference: ``duration`` [s] (Richardson extrapolation over the meshes),
    ``convergence_error`` [s] (|extrapolated - finest|), ``success`` (IPOPT converged on every mesh),
    ``status`` (the first failing mesh's IPOPT status, else that of the finest), ``solutions`` (one
    per mesh, coarsest first), ``delta`` [m], ``spans`` (None: whole tube), ``torque`` (torque limits on)."""

    duration: float
    convergence_error: float
    success: bool
    status: str
    solutions: tuple[FreeShapeSolution, ...]
    delta: float
    spans: tuple | None
    torque: bool = False

    @property
    def durations(self) -> tuple[float, ...]:
        return tuple(s.duration for s in self.solutions)


@dataclass(frozen=True, eq=False)
class WithMultipliers:
    """A whole tube's start (free_shape_optimum's ``warm``): the corner-confined ``optimum``'s solutions, mesh by
    mesh, with their multipliers (a primal-dual warm start, WARM_IPOPT; the constraints both NLPs have keep theirs,
    the rest start at 0: the whole tube's inner points and orientation between the nodes of the stretches the
    corner-confined tube holds on the line, where its equalities p = P + t s become the tube's inequalities). The
    start is feasible only when each inner point's progress starts at its own TCP position (solve_mesh does so with
    multipliers): the chord's put it up to 1.5 mm off along the line (30 deg / 0.1 mm, 25 intervals)."""

    optimum: FreeShapeOptimum


def check_meshes(meshes: Sequence[int], least: int = 1) -> tuple[int, ...]:
    """``meshes`` as a tuple of interval counts: at least ``least`` of them, positive integers, each twice
    the previous (extrapolate assumes that ratio); PathError naming the fault otherwise."""
    try:
        out = tuple(int(m) for m in meshes)
        exact = all(float(m) == int(m) for m in meshes)
    except (TypeError, ValueError, OverflowError):
        out, exact = (), False
    example = "e.g. 25,50,100"
    if not exact or len(out) < least:
        raise PathError(f"free shape: meshes {list(meshes)!r} must be at least {least} whole interval counts, {example}")
    if out[0] < 1:
        raise PathError(f"free shape: meshes {list(out)} must be positive interval counts, {example}")
    if any(b != 2 * a for a, b in zip(out[:-1], out[1:])):
        raise PathError(f"free shape: meshes {list(out)} must each be twice the previous (the Richardson extrapolation "
                        f"assumes it), {example}")
    return out


def extrapolate(durations: Sequence[float], ratio: float = 2.0) -> tuple[float, float]:
    """Richardson extrapolation of durations on meshes refined by ``ratio``: (value, |value - finest|).
    The order comes from the last three (clamped to ORDER_RANGE); with fewer, the finest and the
    change of the last refinement, as when the last two changes differ in sign (the meshes are not in
    the asymptotic range: e.g. the coarsest found another local optimum)."""
    d = np.asarray(durations, float)
    if len(d) < 2:
        return float(d[-1]), float("nan")
    d1, d2 = (d[-2] - d[-3] if len(d) >= 3 else 0.0), d[-1] - d[-2]
    if len(d) < 3 or d1 * d2 < 0:
        return float(d[-1]), float(abs(d2))
    order = np.log(abs(d1 / d2)) / np.log(ratio) if d2 != 0 and d1 != 0 else ORDER_RANGE[1]
    order = float(np.clip(order, *ORDER_RANGE)) if np.isfinite(order) else ORDER_RANGE[1]
    value = d[-1] + d2 / (ratio ** order - 1.0)
    return float(value), float(abs(value - d[-1]))


def _solve_with_restarts(robot, line: Polyline, phases: Sequence[Phase], R_ref, intervals: int, start,
                         previous: FreeShapeSolution | None, warm: bool, stop=None,
                         torque: bool = False, multipliers=None) -> FreeShapeSolution:
    """One mesh, tried from the starts in STARTS (``warm``: STARTS_WARM, ``start`` a feasible motion
    near the optimum, e.g. the optimal blend in the corner-confined tube) until IPOPT converges; the
    first converged (else the last) solution. "previous" is the previous mesh's solution resampled
    (continuation; ``start`` on the first mesh), "start" is ``start`` (m -> Guess) on this mesh,
    "stop" is ``stop`` (m -> Guess: the stop at the corners; ``start`` when None); ``torque``: see solve_mesh.
    ``multipliers`` (m -> a solution's multipliers on the nodes of ``start``): the one try is ``start`` with them
    (WARM_IPOPT; see WithMultipliers).

    Why these: with the norm-form tube and a small barrier, the 0.1 mm whole tube at 90 degrees
    converged on 25 / 50 / 100 intervals (261 / 319 / 52 iterations, the last from the stop after
    continuation hit the cap), where the squared form hit the cap from every start. IPOPT's defaults
    are the last resort: continuation that way (squared form) converged at 90 degrees and 1 mm
    (corner-confined, spans 3.3 / 5.2 mm) when a small barrier (scaled form) did not."""
    density = [ph.density for ph in phases]

    def from_previous():
        prev = previous.motion
        return _resample(_motion_at(prev), _phase_times(prev), intervals, density)

    def fresh():
        return start(intervals)

    if multipliers is not None:
        return solve_mesh(robot, line, phases, fresh(), R_ref, ipopt=WARM_IPOPT, torque=torque,
                          multipliers=multipliers(intervals))
    cont = from_previous if previous is not None else fresh
    tries = []
    from_stop = fresh if stop is None else (lambda: stop(intervals))
    for src, options, form in STARTS_WARM if warm else STARTS:
        attempt = ({"previous": cont, "start": fresh}.get(src, from_stop), options, form)
        if attempt not in tries:  # without a previous mesh, "previous" is the start
            tries.append(attempt)
    for i, (guess, options, form) in enumerate(tries):
        sol = solve_mesh(robot, line, phases, guess(), R_ref, ipopt=options, form=form, torque=torque)
        if sol.success:
            break
        log.info("free shape mesh %d: start %d of %d ended %s after %d iterations", intervals, i + 1, len(tries),
                 sol.status, sol.iterations)
    return sol


def free_shape_optimum(robot, points, delta: float, spans: Sequence[tuple[float, float]] | None = None,
                       meshes: Sequence[int] = MESHES, rotation=None, warm=None,
                       torque: bool = False) -> FreeShapeOptimum:
    """The minimum-time rest-to-rest motion with the TCP within ``delta`` [m] of the polyline
    ``points`` (m, 3) [m] (whole tube, or only within ``spans`` around each corner), fixed tool
    ``rotation`` (default tool down), joint velocity and acceleration limits (and the robot's joint
    torque limits when ``torque``: the stop that starts it is then planned with them too), converged over
    ``meshes`` (total intervals, each twice the previous for the extrapolation). ``warm``: default
    the stop at every corner, refined mesh by mesh; or a plan (PlanResult) of a motion inside the
    tube to start every mesh from (the optimal blend's, for the corner-confined tube); or, for the
    whole tube, the corner-confined FreeShapeOptimum on the same meshes: its tube is inside the
    whole one, so each of its solutions is a start feasible on the same nodes (the whole tube then
    crowds its nodes at the corners like it) and the whole tube ends at or below it; or that optimum
    WithMultipliers, to start from its multipliers too."""
    from .. import defaults

    delta = float(delta)
    if not (np.isfinite(delta) and delta >= 0):
        raise PathError(f"free shape: delta must be a distance >= 0 [m], got {delta!r}")
    meshes = check_meshes(meshes)
    line = Polyline(points)
    R_ref = np.array(defaults.TOOL_DOWN_ROTATION) if rotation is None else np.asarray(rotation, float)
    duals = isinstance(warm, WithMultipliers)
    inner = warm.optimum if duals else warm if isinstance(warm, FreeShapeOptimum) else None
    if inner is not None and (spans is not None or len(inner.solutions) != len(meshes)):
        raise PathError("free shape: a FreeShapeOptimum start is for the whole tube, solved on the same meshes "
                        f"({len(inner.solutions)} solutions for meshes {tuple(meshes)})")
    phases = tube_phases(line, delta, spans, None if inner is None else inner.spans)
    stop_result = []

    def from_stop(m):
        if not stop_result:
            stop_result.append(stop_plan(robot, line, R_ref, torque=torque)[1])
        return guess_from_plan(stop_result[0], line, phases, m)

    if inner is not None:
        start = lambda m: inner.solutions[list(meshes).index(m)].motion  # noqa: E731
    elif warm is None:
        start = from_stop
    else:
        start = lambda m: guess_from_motion(robot, warm, line, phases, m)  # noqa: E731
    solutions: list[FreeShapeSolution] = []
    for m in meshes:
        sol = _solve_with_restarts(robot, line, phases, R_ref, m, start, solutions[-1] if solutions else None,
                                   warm is not None, from_stop, torque,
                                   (lambda m: inner.solutions[list(meshes).index(m)].multipliers) if duals else None)
        log.info("free shape delta=%g spans=%s mesh %d: T = %.6f s (%s, %d iterations)", delta, spans, m, sol.duration,
                 sol.status, sol.iterations)
        solutions.append(sol)
    ok = all(s.success for s in solutions)
    status = next((s.status for s in solutions if not s.success), solutions[-1].status)
    value, err = extrapolate([s.duration for s in solutions])
    return FreeShapeOptimum(value, err, ok, status, tuple(solutions), delta,
                            None if spans is None else tuple(map(tuple, spans)), torque)


@dataclass(frozen=True, eq=False)
class FeasibleBound:
    """A motion that meets every constraint of the free-shape problem in continuous time and holds its tube on a dense
    resample: ``duration`` [s] is an upper bound of the true minimum time. ``radius`` [m]: the shrunk tube it was
    solved in; ``optimum``: that solve (its finest solution is the motion); ``check``: the motion's verification
    against the given tube (:func:`verify`, FEASIBLE_RESAMPLE times denser; ``held_excess_m``: its excess with the
    on-line stretches FEASIBLE_LINE_TOLERANCE wide, <= 0); ``solves``: free-shape solves run for it."""

    duration: float
    radius: float
    optimum: FreeShapeOptimum
    check: dict
    solves: int


def feasible_bound(robot, points, delta: float, spans: Sequence[tuple[float, float]] | None = None,
                   meshes: Sequence[int] = MESHES, rotation=None, torque: bool = False,
                   optimum: FreeShapeOptimum | None = None) -> FeasibleBound:
    """The upper bound of the minimum time that brackets the reference (module docstring): ``optimum`` (or
    :func:`free_shape_optimum` with these arguments, from the stop) re-solved on ``meshes`` in the tube of ``delta``
    [m] shrunk by its finest solution's dense excess times FEASIBLE_SHRINK (doubled per retry), until the finest
    solution holds the tube of ``delta`` (checked FEASIBLE_RESAMPLE times denser than the verification) and the
    velocity and acceleration limits (and the torque limits with ``torque``) to 1e-6, at most FEASIBLE_SOLVES solves;
    the stretches held on the line (the corner-confined tube outside its spans) within FEASIBLE_LINE_TOLERANCE.
    The tool orientation is imposed at the nodes and midpoints, as in the reference; its largest error is in
    ``check``. PathmotionError if no solve holds the tube, one does not converge, or one exceeds a limit."""
    from .. import defaults

    line = Polyline(points)
    R_ref = np.array(defaults.TOOL_DOWN_ROTATION) if rotation is None else np.asarray(rotation, float)
    phases = tube_phases(line, float(delta), spans)
    held = [Phase(p.segment, p.s_lo, p.s_hi, max(p.radius, FEASIBLE_LINE_TOLERANCE), p.density) for p in phases]
    lim = robot.limits
    per_interval = VERIFY_POINTS_PER_INTERVAL * FEASIBLE_RESAMPLE
    radius, solves = float(delta), 0
    for attempt in range(FEASIBLE_SOLVES + 1):
        if optimum is None:
            if solves == FEASIBLE_SOLVES:
                break
            optimum = free_shape_optimum(robot, points, radius, spans, meshes, rotation, torque=torque)
            solves += 1
        finest = optimum.solutions[-1]
        if not optimum.success:
            raise PathmotionError(f"free shape: the feasible bound's solve in a tube of {radius * 1e3:.6g} mm did not "
                                  f"converge ({optimum.status}); give other meshes")
        dense = _dense(robot, finest.motion, per_interval)
        check = verify(robot, line, phases, finest.motion, R_ref, lim.velocity, lim.acceleration, per_interval, dense)
        per_phase = _phase_excess(held, line, dense[2])
        worst = int(np.argmax(np.min(per_phase, axis=0)))
        excess = float(np.min(per_phase[:, worst]))
        check["held_excess_m"] = excess  # against the tube with its on-line stretches FEASIBLE_LINE_TOLERANCE wide
        if excess > 0.0 and phases[int(np.argmin(per_phase[:, worst]))].radius == 0.0:
            off = excess + FEASIBLE_LINE_TOLERANCE  # the distance from the line itself
            raise PathmotionError(f"free shape: the solution leaves a stretch held on the line by {off * 1e3:.3g} mm "
                                  f"between its points (more than {FEASIBLE_LINE_TOLERANCE * 1e3:g} mm); a smaller tube "
                                  "cannot fix that: give finer meshes")
        limits = max(check["max_velocity_ratio"], check["max_acceleration_ratio"],
                     check["max_torque_ratio"] if torque else 0.0)
        if excess <= 0.0 and limits <= 1.0 + 1e-6:
            return FeasibleBound(finest.duration, radius, optimum, check, solves)
        if limits > 1.0 + 1e-6:
            raise PathmotionError(f"free shape: the solution in a tube of {radius * 1e3:.6g} mm exceeds a limit "
                                  f"{limits:.6g} times on the dense resample; a tube cannot fix that")
        radius -= FEASIBLE_SHRINK * 2.0 ** attempt * excess
        if radius <= 0.0:
            break
        log.info("free shape: the finest mesh leaves the tube by %.3g mm between its points; re-solved within %.6g mm",
                 excess * 1e3, radius * 1e3)
        optimum = None
    raise PathmotionError(f"free shape: no solve within {FEASIBLE_SOLVES} held the tube of {delta * 1e3:.6g} mm on the "
                          "dense resample; give finer meshes")


__all__ = ["FeasibleBound", "FreeShapeOptimum", "FreeShapeSolution", "Phase", "Polyline", "WithMultipliers",
           "check_meshes", "effective_spans", "extrapolate", "feasible_bound", "free_shape_optimum", "max_torque_ratio",
           "solve_mesh", "stop_plan", "tcp_function", "tube_phases", "verify"]
