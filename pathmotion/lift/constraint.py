"""Lift a task-space path to joint space: the virtual holonomic constraint q = Phi(theta).

For a TaskPath with pose p(theta), R(theta) and its theta-derivatives (dp, ddp; w, dw, where
w is the angular velocity of the tool per unit theta, world axes):

    Phi(theta)   = IK(p, R) on one solution branch, continuous along the path
    Phi'(theta)  = J(Phi)^-1 [dp; w]
    Phi''(theta) = J(Phi)^-1 ([ddp; dw] - Jdot(Phi, Phi') Phi')
    Phi'''(theta) = J(Phi)^-1 ([dddp; ddw] - 2 Jdot Phi'' - Jddot Phi')

with J the 6 x 6 TCP Jacobian (LOCAL_WORLD_ALIGNED) and Jdot Phi' the classical acceleration of
the TCP at qd = Phi', qdd = 0. No finite differences: the accuracy is the same at any grid.

Phi''' (for jerk limits, :meth:`TaskJointPath.evaluate3`) differentiates J Phi'' + Jdot Phi' =
[ddp; dw] once more. 2 Jdot Phi'' + Jddot Phi' is the classical jerk of the TCP (d/dt of its
classical acceleration) at qd = Phi', qdd = Phi'' and zero joint jerk: :func:`tcp_jerk_bias` gets
it exactly from Pinocchio's analytic derivatives of the frame acceleration.

Construction samples the path densely (``defaults.LIFT_REFERENCE_STEP``) to fix the branch and
the 2*pi turns of each joint, and checks reachability, joint ranges and the distance to
singularity along the whole path, raising an error that names theta, the segment and the joint.

Arms without the closed form (:class:`ResolvedRateJointPath`): Phi is the solution of an ODE in theta,
Phi' = J# xi + N k (q_ref - Phi). With more than 6 joints its null-space part keeps joint speed low
and pulls toward the start configuration; with 6 (e.g. a UR arm) J# = J^-1 and N = 0, so it follows
the IK branch reached from the start configuration. Phi', Phi'' and Phi''' are exact there too
(equations in :mod:`pathmotion.robot.redundancy`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from .. import defaults
from . import wrist_crossing
from ..errors import PathError, UnreachableError
from ..geometry import describe_point
from .joint_path import JointPath
from ..robot import Robot, jacobian
from ..robot.kinematics import jacobian_and_bias
from ..robot import kinematics, redundancy
from ..robot.serial_batch import jerk_bias_batch
from ..robot.ik import IK_RANGE_SLACK, has_closed_form, ik_batch, ik_dls, ik_nearest

log = logging.getLogger(__name__)
TWO_PI = 2.0 * np.pi
#: A redundant arm's lifted path is closed only when it returns to its start configuration within this
#: [rad]: the null-space ODE need not come back to the same posture on a closed task path.
CLOSURE_MATCH = 1e-6
#: A closed-form arm's lifted loop is closed when its ends differ by at most this [rad] (modulo 2*pi): a loop
#: that starts at q5 = 0 has q4 and q6 there from the wrist window's limit, known to ~1e-6; a wrist branch
#: that changed along the loop differs by pi.
LOOP_CLOSURE = 1e-4
_LOCAL = pin.ReferenceFrame.LOCAL


@dataclass(frozen=True)
class PathCheck:
    """What the lift found along the path.

    min_singular_value: smallest singular value of the TCP Jacobian along the path and its theta;
    range_margin: smallest distance of any joint to its range limits [rad], with theta and joint;
    kinks: theta of the sharp corners (the planner must stop there);
    wrist_passages: :class:`~pathmotion.lift.wrist_crossing.WristPassage` per stretch near q5 = 0 (crossings
    on the smooth branch included; the singular-value check skips their interpolation windows).
    """

    min_singular_value: float
    min_singular_theta: float
    range_margin: float
    range_margin_theta: float
    range_margin_joint: str
    kinks: tuple[float, ...]
    samples: int
    wrist_passages: tuple = ()


@dataclass(frozen=True, eq=False)
class TaskJointPath(JointPath):
    """q = Phi(theta) for a task-space path, on one IK branch (the wrist branch continuous through
    q5 = 0). Build with :func:`lift`.

    wrist_windows: :class:`~pathmotion.lift.wrist_crossing.WristWindow` intervals around wrist singularity
    crossings, where Phi and its derivatives come from a certified interpolant of the continuous IK
    (J is singular at the crossing); elsewhere Phi is the closed form and its derivatives J^-1 (...)."""

    robot: Robot | None = None
    task_path: object = None
    original_task_path: object = None
    reference_theta: np.ndarray = field(default=None, repr=False)
    reference_q: np.ndarray = field(default=None, repr=False)
    check: PathCheck | None = None
    wrist_windows: tuple = ()

    def _reference_at(self, theta: np.ndarray) -> np.ndarray:
        ref_t, ref_q = self.reference_theta, self.reference_q
        return np.column_stack([np.interp(theta, ref_t, ref_q[:, j]) for j in range(self.n)])

    def _ik(self, theta: np.ndarray) -> np.ndarray:
        """The closed-form IK (M, n) at theta (M,) on the reference's branch and turns."""
        p, _, _, rot, _, _ = self.task_path.pose(theta)
        return ik_nearest(self.robot, p, rot, self._reference_at(theta))

    def _lifted(self, th: np.ndarray, side: str, order: int) -> list[np.ndarray]:
        """[Phi, Phi', ..., Phi^(order)] (order 2 or 3) at theta (N,): closed form and J^-1, or a wrist window."""
        return self._lifted_parts(((th, side),), order)[0]

    def _lifted_parts(self, parts, order: int) -> list[list[np.ndarray]]:
        """:meth:`_lifted` of each (theta (N_k,), side) of ``parts``, in one pass: the poses per part, the IK and
        J^-1 of all points at once (point by point, so each part's values are those of its own pass)."""
        poses = [self.task_path.pose3(t, side=s) if order == 3 else self.task_path.pose(t, side=s) for t, s in parts]
        pose = poses[0] if len(parts) == 1 else tuple(np.concatenate(x) for x in zip(*poses))
        th = parts[0][0] if len(parts) == 1 else np.concatenate([t for t, _ in parts])
        inside = np.full(len(th), -1)
        for i, window in enumerate(self.wrist_windows):
            contains = np.concatenate([window.contains(t, s) for t, s in parts])
            inside[(inside < 0) & contains] = i
        reg = inside < 0
        out = [np.empty((len(th), self.n)) for _ in range(order + 1)]
        if reg.any():  # the IK where the closed form holds; a window's interpolant gives Phi inside it
            part = [x[reg] for x in pose]
            dp, ddp = part[1], part[2]
            rot, w, dw = (part[4], part[5], part[6]) if order == 3 else (part[3], part[4], part[5])
            q = ik_nearest(self.robot, part[0], rot, self._reference_at(th[reg]))
            out[0][reg] = q
            dq, ddq = joint_derivatives(self.robot, q, dp, ddp, w, dw)
            out[1][reg], out[2][reg] = dq, ddq
            if order == 3:
                out[3][reg] = joint_third_derivative(self.robot, q, dq, ddq, part[3], part[7])
        for i, window in enumerate(self.wrist_windows):
            m = inside == i
            if m.any():
                for k, values in enumerate(window.evaluate(th[m], order)):
                    out[k][m] = values
        if len(parts) == 1:
            return [out]
        ends = np.cumsum([0] + [len(t) for t, _ in parts])
        return [[o[a:b] for o in out] for a, b in zip(ends[:-1], ends[1:])]

    def evaluate(self, theta, side: str = "right"):
        th, scalar = self._check_theta(theta)
        out = self._lifted(th, side, 2)
        return tuple(o[0] for o in out) if scalar else tuple(out)

    def evaluate_sides(self, theta, at) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """(evaluate(theta, "right"), evaluate(theta[at], "left")), in one pass (a plan's grid and its breaks)."""
        th, _ = self._check_theta(np.atleast_1d(theta))
        right, left = self._lifted_parts(((th, "right"), (th[np.asarray(at, int)], "left")), 2)
        return tuple(right), tuple(left)

    def evaluate3(self, theta, side: str = "right"):
        """(Phi, Phi', Phi'', Phi''') at theta, each (N, n) or (n,); Phi''' [rad/m^3] exact (from the
        certified interpolant inside a wrist window)."""
        th, scalar = self._check_theta(theta)
        out = self._lifted(th, side, 3)
        return tuple(o[0] for o in out) if scalar else tuple(out)


def joint_derivatives(robot: Robot, q, dp, ddp, w, dw) -> tuple[np.ndarray, np.ndarray]:
    """Phi' and Phi'' (N, n) from the task-space derivatives through the TCP Jacobian."""
    jac, bias_at = jacobian_and_bias(robot, q)
    twist = np.concatenate([dp, w], axis=1)
    dq = np.linalg.solve(jac, twist[..., None])[..., 0]
    bias = bias_at(dq)
    acc = np.concatenate([ddp, dw], axis=1) - bias
    ddq = np.linalg.solve(jac, acc[..., None])[..., 0]
    return dq, ddq


def tcp_jerk_bias(robot: Robot, q, qd, qdd) -> np.ndarray:
    """Classical jerk of the TCP at zero joint jerk, 2 Jdot(q, qd) qdd + Jddot(q, qd, qdd) qd, (N, 6).

    q, qd, qdd (N, n). Rows 0-2: d3p/dt3 of the TCP origin, rows 3-5: d2w/dt2, world axes.
    Exact: with the body (LOCAL) twist V = (v, w) and its derivative A = dV/dt (Pinocchio's frame
    acceleration in LOCAL), the world classical acceleration is (R (dv + w x v), R dw), so

        d3p/dt3 = R (w x (dv + w x v) + ddv + dw x v + w x dv),    d2w/dt2 = R (w x dw + ddw)

    with dA/dt = dA/dq qd + dA/dv qdd (+ dA/da * 0) from ``getFrameAccelerationDerivatives``
    (analytic partial derivatives, no finite differences). Batches of a serial revolute chain (at least
    ``SERIAL_BATCH_MIN`` points) use the compiled recursion of :mod:`.robot.serial_batch` instead (equal to
    round-off); other models keep Pinocchio.
    """
    model, data = robot.model, robot.data
    fid = robot.frame_id(None)
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
    n = len(q)
    chain = robot.serial_chain(fid) if n >= kinematics.SERIAL_BATCH_MIN else None
    if chain is not None:
        return jerk_bias_batch(chain, q, qd, qdd)
    vel, acc, dacc, rot = np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 3, 3))
    for k in range(n):  # Pinocchio per point; the vector algebra below for all points at once
        pin.computeForwardKinematicsDerivatives(model, data, q[k], qd[k], qdd[k])
        pin.updateFramePlacements(model, data)
        _, da_dq, da_dv, _ = pin.getFrameAccelerationDerivatives(model, data, fid, _LOCAL)
        vel[k] = pin.getFrameVelocity(model, data, fid, _LOCAL).vector
        acc[k] = pin.getFrameAcceleration(model, data, fid, _LOCAL).vector
        dacc[k] = da_dq @ qd[k] + da_dv @ qdd[k]
        rot[k] = data.oMf[fid].rotation
    v, w, dv, dw, ddv, ddw = vel[:, :3], vel[:, 3:], acc[:, :3], acc[:, 3:], dacc[:, :3], dacc[:, 3:]
    lin = np.cross(w, dv + np.cross(w, v)) + ddv + np.cross(dw, v) + np.cross(w, dv)
    ang = np.cross(w, dw) + ddw
    return np.concatenate([np.einsum("kij,kj->ki", rot, lin), np.einsum("kij,kj->ki", rot, ang)], axis=1)


def joint_third_derivative(robot: Robot, q, dq, ddq, dddp, ddw) -> np.ndarray:
    """Phi''' (N, n) = J^-1 ([dddp; ddw] - tcp_jerk_bias(Phi, Phi', Phi'')), from the task-space third
    derivatives dddp (N, 3) [1/m^2] and ddw (N, 3) [rad/m^3]."""
    jac = jacobian(robot, q)
    rhs = np.concatenate([dddp, ddw], axis=1) - tcp_jerk_bias(robot, q, dq, ddq)
    return np.linalg.solve(jac, rhs[..., None])[..., 0]


def lift(robot: Robot, task_path, q_start=None, *, original=None,
         reference_step: float = defaults.LIFT_REFERENCE_STEP,
         singularity_threshold: float = defaults.SINGULARITY_THRESHOLD) -> TaskJointPath:
    """Lift ``task_path`` to joint space for ``robot``.

    q_start: (n,) configuration the branch is chosen to be closest to at theta = 0 (default:
    the zero (calibration) configuration, clipped to the ranges). original: the path before blends replaced its corners
    (kept for deviation metrics). Raises UnreachableError / PathError naming theta and segment.
    """
    if robot.n < 6:
        raise PathError(f"task-space paths need an arm with at least 6 joints; {robot.name} has {robot.n} joints "
                        f"{list(robot.joint_names)} (give a joint-space path instead)")
    lo, hi = task_path.domain
    steps = (hi - lo) / reference_step
    if not (np.isfinite(steps) and steps <= defaults.LIFT_MAX_REFERENCE_SAMPLES):
        raise UnreachableError(
            f"the path is {hi - lo:.6g} m long: more than {defaults.LIFT_MAX_REFERENCE_SAMPLES:,} reference points "
            f"{reference_step:g} m apart, far beyond the reach of any arm; check the points (units are metres)",
            reason="reach")
    count = max(int(np.ceil(steps)) + 1, 50)
    theta = np.linspace(lo, hi, count)
    breaks = np.asarray(task_path.breaks, dtype=float)
    theta = np.unique(np.concatenate([theta, breaks[(breaks > lo) & (breaks < hi)]]))
    given = q_start is not None
    if q_start is None:
        q_start = np.clip(np.zeros(robot.n), robot.limits.lower, robot.limits.upper)
    q_start = np.asarray(q_start, dtype=float)
    if q_start.shape != (robot.n,):
        raise PathError(f"start configuration has {q_start.size} values, the robot has {robot.n} joints")
    if robot.n > 6 or not has_closed_form(robot):
        if given:
            return _lift_ode(robot, task_path, q_start, original, reference_step, singularity_threshold)
        return _lift_ode_from_starts(robot, task_path, original, reference_step, singularity_threshold)
    p, dp, ddp, rot, w, dw = task_path.pose(theta)
    try:
        q = ik_batch(robot, p, rot, q_start)
    except UnreachableError as exc:
        idx = getattr(exc, "index", None)
        if idx is None:
            raise
        raise UnreachableError(describe_point(task_path, theta[idx], p[idx]) + f": {exc}", reason=exc.reason,
                               position=p[idx]) from exc
    # continuity: unwrap every joint along the dense reference
    q = np.unwrap(q, axis=0)
    path = TaskJointPath(
        n=robot.n, domain=(lo, hi), closed=bool(getattr(task_path, "closed", False)),
        kinks=tuple(float(k) for k in task_path.kinks), breaks=tuple(float(b) for b in task_path.breaks),
        peaks=task_path.curvature_peaks, joint_names=robot.joint_names, robot=robot, task_path=task_path,
        original_task_path=original, reference_theta=theta, reference_q=q,
    )
    passages = wrist_crossing.find_passages(robot, task_path, theta, q, path._ik, singularity_threshold, q_start)
    windows = wrist_crossing.crossing_windows(robot, task_path, theta, q, passages, path._ik,
                                              path.evaluate3, q_start)
    path = replace(path, wrist_windows=windows)
    check = _check_path(robot, task_path, theta, q, p, singularity_threshold, windows)
    passages = tuple(wrist_crossing.with_speed_limits(ps, path, robot.limits.velocity, theta) for ps in passages)
    return replace(path, check=replace(check, wrist_passages=passages), closed=_closes(path))


def _closes(path: TaskJointPath) -> bool:
    """A closed task path lifts to a closed joint path unless the wrist branch differs at the two ends (a
    loop that crosses q5 = 0 an odd number of times ends with q4 + pi, -q5, q6 + pi: the same pose);
    whole turns of a joint (2*pi) still close."""
    if not path.closed:
        return False
    ends = path.evaluate(np.array(path.domain))[0]
    gap = np.abs(np.angle(np.exp(1j * (ends[1] - ends[0]))))
    if np.max(gap) <= LOOP_CLOSURE:
        return True
    log.warning("the closed path's joint path does not close: joint %s differs by %.3f rad at its ends (the wrist "
                "branch changes along the loop); it is planned as an open motion only",
                path.joint_names[int(np.argmax(gap))], float(np.max(gap)))
    return False


@dataclass(frozen=True, eq=False)
class ResolvedRateJointPath(TaskJointPath):
    """q = Phi(theta) for an arm without closed-form IK (more than 6 joints, or 6 not of the OPW family):
    the solution of Phi' = f(theta, Phi) (see :mod:`pathmotion.robot.redundancy`), held as a dense
    reference; build with :func:`lift`.

    reference_dq_right / _left: f at each reference sample from the right / left of it (they differ
    at kinks); q_ref (n,) and gain [1/m]: the null-space pull; weights_inv: diag(qd_max^2) (n,)."""

    reference_dq_right: np.ndarray = field(default=None, repr=False)
    reference_dq_left: np.ndarray = field(default=None, repr=False)
    q_ref: np.ndarray = field(default=None, repr=False)
    gain: float = defaults.REDUNDANCY_NULLSPACE_GAIN
    weights_inv: np.ndarray = field(default=None, repr=False)

    def evaluate(self, theta, side: str = "right"):
        th, scalar = self._check_theta(theta)
        p, dp, ddp, rot, w, dw = self.task_path.pose(th, side=side)
        guess = redundancy.hermite(th, self.reference_theta, self.reference_q, self.reference_dq_right,
                                   self.reference_dq_left, side)
        q = redundancy.project_to_pose(self.robot, guess, p, rot, self.weights_inv)
        dq, ddq = redundancy.resolved_derivatives(self.robot, q, np.concatenate([dp, w], axis=1),
                                                  np.concatenate([ddp, dw], axis=1), self.q_ref, self.gain,
                                                  self.weights_inv)
        if scalar:
            return q[0], dq[0], ddq[0]
        return q, dq, ddq

    evaluate_sides = JointPath.evaluate_sides  # the ODE's Phi: its own evaluate per side

    def evaluate3(self, theta, side: str = "right"):
        """(Phi, Phi', Phi'', Phi''') at theta, each (N, n) or (n,); Phi''' exact (the ODE differentiated
        twice, :func:`pathmotion.robot.redundancy.resolved_third_derivative`)."""
        th, scalar = self._check_theta(theta)
        p, dp, ddp, dddp, rot, w, dw, ddw = self.task_path.pose3(th, side=side)
        guess = redundancy.hermite(th, self.reference_theta, self.reference_q, self.reference_dq_right,
                                   self.reference_dq_left, side)
        q = redundancy.project_to_pose(self.robot, guess, p, rot, self.weights_inv)
        dq, ddq, dddq = redundancy.resolved_third_derivative(
            self.robot, q, np.concatenate([dp, w], axis=1), np.concatenate([ddp, dw], axis=1),
            np.concatenate([dddp, ddw], axis=1), self.q_ref, self.gain, self.weights_inv)
        out = (q, dq, ddq, dddq)
        return tuple(o[0] for o in out) if scalar else out


def start_candidates(robot: Robot) -> np.ndarray:
    """(k, n) starting configurations for the first point's IK when none is given: zero (clipped to the
    ranges), the middle of the ranges, then defaults.DLS_RANDOM_STARTS seeded uniform draws in the ranges
    (an infinite range bounded at +-pi)."""
    lo = np.where(np.isfinite(robot.limits.lower), robot.limits.lower, -np.pi)
    hi = np.where(np.isfinite(robot.limits.upper), robot.limits.upper, np.pi)
    rng = np.random.default_rng(defaults.DLS_RANDOM_START_SEED)
    return np.vstack([np.clip(np.zeros(robot.n), lo, hi), 0.5 * (lo + hi),
                      rng.uniform(lo, hi, (defaults.DLS_RANDOM_STARTS, robot.n))])


def _lift_ode_from_starts(robot: Robot, task_path, original, reference_step: float, threshold: float):
    """:func:`_lift_ode` from each of :func:`start_candidates` in turn (each start is also the reference the
    null-space motion stays near); the first that lifts the whole path, else the first start's error with
    the number of starts tried."""
    first = None
    candidates = start_candidates(robot)
    for k, q_start in enumerate(candidates):
        try:
            path = _lift_ode(robot, task_path, q_start, original, reference_step, threshold)
        except UnreachableError as exc:
            first = first or exc
            continue
        if k:
            log.info("lift: first point reached from start candidate %d of %d (%s)", k + 1, len(candidates),
                     "the middle of the joint ranges" if k == 1 else "a seeded random configuration")
        return path
    raise UnreachableError(f"{first} (tried {len(candidates)} starts: zero, the middle of the joint ranges and "
                           f"{defaults.DLS_RANDOM_STARTS} seeded random configurations; give "
                           "path.start_configuration near a configuration that reaches the first point)",
                           index=first.index, reason=first.reason) from None


def _lift_ode(robot: Robot, task_path, q_start, original, reference_step: float,
                    singularity_threshold: float) -> ResolvedRateJointPath:
    """The lift of an arm without closed-form IK: Phi(0) by DLS IK from q_start, then the ODE (RK4) on a
    reference grid of half the usual step, then the same range and singularity checks. For 6 joints the
    null-space gain is 0 (N = 0 up to rounding)."""
    lo, hi = task_path.domain
    count = max(int(np.ceil(2.0 * (hi - lo) / reference_step)) + 1, 100)
    theta = np.linspace(lo, hi, count)
    breaks = np.asarray(task_path.breaks, dtype=float)
    theta = np.unique(np.concatenate([theta, breaks[(breaks > lo) & (breaks < hi)]]))
    p0, _, _, r0, _, _ = task_path.pose(theta[:1])
    try:
        q0 = ik_dls(robot, p0[0], r0[0], q_start)
    except UnreachableError as exc:
        raise UnreachableError(describe_point(task_path, theta[0], p0[0]) + f": {exc}", reason=exc.reason,
                               position=p0[0]) from exc
    winv = redundancy.joint_weights(robot)
    gain = defaults.REDUNDANCY_NULLSPACE_GAIN if robot.n > 6 else 0.0
    try:
        q, dq_r, dq_l = redundancy.integrate_path(robot, theta, task_path.pose, q0, q_start, gain, winv)
    except UnreachableError as exc:
        i = exc.index or 0
        p_i = task_path.evaluate(theta[i])[0]
        raise UnreachableError(describe_point(task_path, theta[i], p_i) + f": {exc}", reason=exc.reason,
                               position=p_i) from exc
    p = task_path.evaluate(theta)[0]
    check = _check_path(robot, task_path, theta, q, p, singularity_threshold)
    closed = bool(getattr(task_path, "closed", False)) and bool(np.max(np.abs(q[-1] - q[0])) < CLOSURE_MATCH)
    return ResolvedRateJointPath(
        n=robot.n, domain=(lo, hi), closed=closed, kinks=tuple(float(k) for k in task_path.kinks),
        breaks=tuple(float(b) for b in task_path.breaks), peaks=task_path.curvature_peaks,
        joint_names=robot.joint_names, robot=robot,
        task_path=task_path, original_task_path=original, reference_theta=theta, reference_q=q, check=check,
        reference_dq_right=dq_r, reference_dq_left=dq_l, q_ref=q_start, gain=gain, weights_inv=winv)

#: smallest_singular_values_where_least: every this many points a singular value decomposition; an absolute margin
#: [in units of the largest Jacobian's Frobenius norm] on the bounds for the rounding of both.
SV_STRIDE = 8
SV_MARGIN = 1e-10


def smallest_singular_values_where_least(jac: np.ndarray, masks) -> np.ndarray:
    """The smallest singular value (N,) of each Jacobian jac (N, 6, 6) that could be the least over any of the point
    sets ``masks`` ((N,) bool each), exactly numpy's (the decomposition is per matrix), inf at the others: the
    decomposition at every SV_STRIDE-th point (and the last), then at each point whose lower bound, by Weyl's
    inequality sigma_min(J_i) >= sigma_min(J_j) - |J_i - J_j|_F from the nearest of those, is not above the least of
    those in a mask it is in (less SV_MARGIN). Along a path the Jacobians change little between neighbours, so only
    points near the least ones are decomposed (a lift's singularity check: np.argmin of the result is np.argmin of
    the full decomposition over each mask)."""
    n = len(jac)
    if n <= 2 * SV_STRIDE:
        return np.linalg.svd(jac, compute_uv=False)[:, -1]
    sampled = np.unique(np.append(np.arange(0, n, SV_STRIDE), n - 1))
    out = np.full(n, np.inf)
    out[sampled] = np.linalg.svd(jac[sampled], compute_uv=False)[:, -1]
    nearest = sampled[np.clip(np.searchsorted(sampled, np.arange(n) - SV_STRIDE // 2), 0, len(sampled) - 1)]
    gap = np.sqrt(np.sum((jac - jac[nearest]) ** 2, axis=(1, 2)))
    margin = SV_MARGIN * max(1.0, float(np.sqrt(np.max(np.sum(jac ** 2, axis=(1, 2))))))
    lower = out[nearest] - gap - margin
    need = np.zeros(n, bool)
    for mask in masks:
        least = np.min(out[sampled][mask[sampled]], initial=np.inf)
        need |= mask & (lower <= least)
    need[sampled] = False
    if need.any():
        out[need] = np.linalg.svd(jac[need], compute_uv=False)[:, -1]
    return out


def _check_path(robot, task_path, theta, q, p, threshold, windows=()) -> PathCheck:
    lim = robot.limits
    below = q < lim.lower - IK_RANGE_SLACK
    above = q > lim.upper + IK_RANGE_SLACK
    if np.any(below | above):
        k, j = np.argwhere(below | above)[0]
        raise UnreachableError(
            f"{describe_point(task_path, theta[k], p[k])}: joint {lim.names[j]} would be at {q[k, j]:.4f} rad, outside "
            f"its range [{lim.lower[j]:.4f}, {lim.upper[j]:.4f}] on this IK branch; move the path or give "
            "path.start_configuration for another branch", reason="joint_range", position=p[k])
    margin = np.minimum(q - lim.lower, lim.upper - q)
    k, j = np.unravel_index(np.argmin(margin), margin.shape)
    crossing = np.zeros(len(theta), dtype=bool)
    for window in windows:  # a wrist crossing: Phi is the smooth branch's interpolant there
        crossing |= (theta >= window.lo) & (theta <= window.hi)
    sv = smallest_singular_values_where_least(jacobian(robot, q), (np.ones(len(theta), bool), ~crossing))
    ks = int(np.argmin(sv))
    checked = np.where(crossing, np.inf, sv)
    kc = int(np.argmin(checked))
    if checked[kc] < threshold:
        raise UnreachableError(
            f"{describe_point(task_path, theta[kc], p[kc])}: the arm is (near) singular there (smallest Jacobian "
            f"singular value {sv[kc]:.2e} < {threshold:g}); move the path away from the wrist/elbow/shoulder singularity",
            reason="singular", position=p[kc])
    return PathCheck(float(sv[ks]), float(theta[ks]), float(margin[k, j]), float(theta[k]), lim.names[j],
                     tuple(float(x) for x in task_path.kinks), len(theta))
