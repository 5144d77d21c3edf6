"""Inverse kinematics of the TCP: closed form for OPW arms, damped least squares for any other arm.

Poses are TCP poses in the base frame: position (3,) [m] and rotation (3, 3), or batches
(N, 3) / (N, 3, 3). Configurations are (n,) / (N, n) [rad], inside the robot's joint ranges.

* Closed form (:mod:`pathmotion.robot.opw`, equations and branch convention there): used when the
  robot's kinematics has the OPW structure (6R, ortho-parallel basis, spherical wrist), detected from
  the model and verified against its forward kinematics (``Robot.opw_detection``). The wrist centre
  is found from the TCP pose through the tool, so the tool frame needs no special care. Every branch
  gives joint angles in [-pi, pi]; joints whose range is wider than that also get the 2*pi-shifted
  copies (IRB140: joint 4 +-200 deg, joint 6 +-400 deg).
* :func:`ik` picks, over the 8 branches and the in-range 2*pi shifts, the solution nearest (Euclidean)
  to ``q_ref``; :func:`ik_all` lists all of them; :func:`ik_batch` keeps the branch chosen at the first
  point for the whole batch and each joint on the 2*pi turn continuous with the previous point.
* :func:`ik_dls`: Levenberg-Marquardt damped least squares from ``q_ref``, clamped to the joint ranges;
  used for arms without the closed form (any URDF, any number of joints).

Failures raise :class:`~pathmotion.errors.UnreachableError` with ``reason`` "reach" (distance and
reach given), "joint_range" (joint, value and range), "singular" (wrist q5 = 0, shoulder, elbow
stretched) or "not_converged" (DLS), and for batches ``index`` = the first bad point.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import PathmotionError, RobotModelError, UnreachableError
from .kinematics import fk, jacobian
from .model import Robot
from .opw import TWO_PI, OPWGeometry, OPWSolutions, branch_gap, branch_name, branch_of, flip_wrist, solve, wrap

#: Slack of the joint-range test [rad]: a closed-form solution up to this far beyond a limit counts
#: as on it and is clamped to it. Away from singularities the closed form is exact to ~1e-15 rad, but
#: near the stretched or folded elbow (and the shoulder) an angle comes from acos / sqrt of a quantity
#: rounded by a few ulps, so it is known only to a few sqrt(eps) = 1.5e-8 rad (4.5e-8 measured on the
#: IRB140 range-boundary grid), and the wrist angles inherit that error through R_0c. 1e-6 rad is 20x
#: that and still far below any joint encoder's resolution (1e-6 rad moves a 1 m arm by 1 um).
#: Near the wrist singularity q4 and q6 get that error times 1/|sin q5|; there the slack bounds the
#: TCP's turn instead (:func:`_into_range`).
IK_RANGE_SLACK = 1e-6
#: Two closed-form solutions closer than this [rad] (max over joints) are the same solution (at an
#: elbow singularity the elbow-up and elbow-down branches coincide to the accuracy above).
IK_SAME_SOLUTION = IK_RANGE_SLACK
#: DLS: damping above which no step can reduce the error any more (the iteration gives up) [-].
DLS_MAX_DAMPING = 1e6
#: |sin q5| below which a large q4 jump is attributed to the wrist singularity in messages [-].
WRIST_NEAR_SINGULAR = 0.1
#: ik_batch's first-point solutions kept (:func:`_first_solution`): a blend search lifts hundreds of paths from
#: the same start pose and reference.
FIRST_POINT_CACHE = 64


def opw_geometry(robot: Robot) -> OPWGeometry:
    """The robot's OPW parameters; RobotModelError saying why when the arm has no closed form."""
    geo, why = robot.opw_detection
    if geo is None:
        raise RobotModelError(f"robot {robot.name}: {why}")
    return geo


def has_closed_form(robot: Robot) -> bool:
    """True when IK of ``robot`` uses the closed (OPW) form, False when it uses damped least squares."""
    return robot.opw_detection[0] is not None


# ----------------------------------------------------------------------------------------------
# Input checks


def _poses(positions, rotations, batch: bool) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(positions, dtype=float)
    r = np.asarray(rotations, dtype=float)
    want_p, want_r = ((-1, 3), (-1, 3, 3)) if batch else ((3,), (3, 3))
    if p.ndim != len(want_p) or p.shape[-1] != 3 or r.ndim != len(want_r) or r.shape[-2:] != (3, 3):
        raise PathmotionError(
            f"IK: positions must have shape {'(N, 3)' if batch else '(3,)'} and rotations "
            f"{'(N, 3, 3)' if batch else '(3, 3)'}; got {p.shape} and {r.shape}"
        )
    p, r = p.reshape(-1, 3), r.reshape(-1, 3, 3)
    if len(p) != len(r):
        raise PathmotionError(f"IK: {len(p)} positions but {len(r)} rotations")
    bad = ~(np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(r), axis=(1, 2)))
    if bad.any():
        i = int(np.argmax(bad))
        where = f" at point {i}" if batch else ""
        raise PathmotionError(
            f"IK: pose{where} contains NaN or inf (position {p[i].tolist()}, rotation {r[i].tolist()}); "
            "give finite numbers"
        )
    # one tool orientation along a path (every plan of a blend search lifts hundreds of points): checked once
    checked = r[:1] if len(r) > 1 and np.all(r == r[0]) else r
    dev = np.max(np.abs(np.swapaxes(checked, 1, 2) @ checked - np.eye(3)), axis=(1, 2))
    bad = (dev > defaults.ROTATION_TOLERANCE) | (np.linalg.det(checked) < 0)
    if bad.any():
        i = int(np.argmax(bad))
        where = f" at point {i}" if batch else ""
        raise PathmotionError(
            f"IK: rotation{where} is not a proper rotation matrix (max |R^T R - I| = {dev[i]:.3g}, "
            f"det = {np.linalg.det(r[i]):.6g}); give an orthonormal matrix with det +1"
        )
    return p, r


def _reference(robot: Robot, q_ref) -> np.ndarray:
    q = np.asarray(q_ref, dtype=float)
    if q.shape != (robot.n,):
        raise PathmotionError(f"IK: q_ref has shape {q.shape}, the robot has {robot.n} joints")
    if not np.all(np.isfinite(q)):
        raise PathmotionError(f"IK: q_ref contains NaN or inf ({q.tolist()}); give finite numbers")
    return q


# ----------------------------------------------------------------------------------------------
# Messages


def _fmt_pose(p, r) -> str:
    rv = pin.log3(r)
    return (f"TCP position ({p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}) m, rotation vector "
            f"({rv[0]:.4f}, {rv[1]:.4f}, {rv[2]:.4f}) rad")


def _reach_message(geo: OPWGeometry, sol: OPWSolutions, i: int, branches=range(8)) -> str:
    c = sol.centre[i]
    rho = float(np.hypot(c[0], c[1]))
    if rho < abs(geo.b) - defaults.IK_REACH_ROUNDING:
        return (f"out of reach: the wrist centre ({c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f}) m is {rho:.4f} m from "
                f"axis 1, inside the shoulder offset |b| = {abs(geo.b):.4f} m")
    shoulders = sorted({b >> 2 for b in branches})
    inner, outer = abs(geo.c2 - geo.k), geo.c2 + geo.k
    dist = ", ".join(f"{sol.arm_distance[i, s]:.4f} m ({('front', 'back')[s]} shoulder)" for s in shoulders)
    return (f"out of reach: the wrist centre ({c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f}) m is {dist} from the "
            f"joint-2 axis; the arm reaches {inner:.4f} to {outer:.4f} m from it "
            f"(upper arm c2 = {geo.c2:.4f} m, forearm {geo.k:.4f} m)")


def _range_violation(robot: Robot, q: np.ndarray) -> str:
    lo, hi = robot.limits.lower, robot.limits.upper
    for j in range(robot.n):
        excess = max(lo[j] - q[j], q[j] - hi[j])
        if excess > IK_RANGE_SLACK:
            return (f"joint {robot.joint_names[j]} = {q[j]:.4f} rad ({np.degrees(q[j]):.1f} deg) is outside "
                    f"its range [{lo[j]:.4f}, {hi[j]:.4f}] rad by {excess:.3g} rad")
    return "all joints in range"


# ----------------------------------------------------------------------------------------------
# Closed form, single pose


def _wrist_budget(geo: OPWGeometry, q: np.ndarray) -> np.ndarray:
    """Largest move [rad] of q4 (with q6 compensating, see :func:`_into_range`) that turns the TCP by
    at most IK_RANGE_SLACK: IK_RANGE_SLACK / |sin t5|, at most pi; shape q.shape[:-1]."""
    s5 = np.abs(np.sin(geo.to_t(q)[..., 4]))
    return np.minimum(IK_RANGE_SLACK / np.maximum(s5, IK_RANGE_SLACK / np.pi), np.pi)


def _slack(geo: OPWGeometry, q: np.ndarray) -> np.ndarray:
    """Per-joint slack (..., 6) [rad] of the range test: IK_RANGE_SLACK, the wrist budget for q4 and q6."""
    slack = np.full(np.shape(q), IK_RANGE_SLACK)
    slack[..., 3] = slack[..., 5] = np.maximum(_wrist_budget(geo, q), IK_RANGE_SLACK)
    return slack


def _into_range(robot: Robot, geo: OPWGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solutions q (..., 6) moved onto the joint ranges, and a mask (...) of those that fit.

    A joint up to IK_RANGE_SLACK beyond a limit (rounding) is clipped onto it. Near the wrist
    singularity q4 and q6 individually carry the elbow's rounding error amplified by 1/|sin q5|
    (1e-5 rad at q5 = 1e-3 on the stretched arm), while the pose fixes only their near-null
    combination: moving t4 by d and t6 by -cos(t5) d turns the TCP by |sin t5| d. So q4 and q6 move
    together along that direction, by the smallest d that brings both into range, as long as the TCP
    turns by at most IK_RANGE_SLACK (:func:`_wrist_budget`).
    """
    lo, hi, tol = robot.limits.lower, robot.limits.upper, IK_RANGE_SLACK
    q = np.array(q, dtype=float)
    t5 = geo.to_t(q)[..., 4]
    c = -geo.sign[3] * geo.sign[5] * np.cos(t5)  # dq6 per dq4 along the near-null direction
    budget = _wrist_budget(geo, q)
    coupled = np.abs(c) > IK_RANGE_SLACK
    c_safe = np.where(coupled, c, 1.0)

    def moves(slack):  # interval of d keeping q4 and q6 within the ranges widened by slack
        a = np.where(coupled, (lo[5] - slack - q[..., 5]) / c_safe, -np.inf)
        b = np.where(coupled, (hi[5] + slack - q[..., 5]) / c_safe, np.inf)
        return (np.maximum.reduce([lo[3] - slack - q[..., 3], -budget, np.minimum(a, b)]),
                np.minimum.reduce([hi[3] + slack - q[..., 3], budget, np.maximum(a, b)]))

    with np.errstate(invalid="ignore"):
        # onto the ranges if the budget allows; else (both at a limit) split the overshoot, clipped below
        exact, widened = moves(0.0), moves(tol)
        d = np.where(exact[0] <= exact[1], np.clip(0.0, *exact),
                     np.where(widened[0] <= widened[1], np.clip(0.5 * (exact[0] + exact[1]), *widened), 0.0))
        q[..., 3] += d
        q[..., 5] += c * d
        ok = np.all((q >= lo - tol) & (q <= hi + tol), axis=-1)
    return np.clip(q, lo, hi), ok


def _nearest_in_range(robot: Robot, geo: OPWGeometry, q: np.ndarray,
                      q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Candidates (2, ..., n) for wrapped solutions q (..., n): the 2*pi shift nearest to q_ref within
    the widened wrist slack (:func:`_slack`), then within IK_RANGE_SLACK, each moved onto the ranges
    (:func:`_into_range`); and a mask (2, ...) of those that fit."""
    out, fits = [], []
    for slack in (_slack(geo, q), IK_RANGE_SLACK):
        k_lo, k_hi = _shift_bounds(robot, q, slack)
        k = np.clip(np.round((q_ref - q) / TWO_PI), k_lo, k_hi)
        fitted, ok = _into_range(robot, geo, q + TWO_PI * k)
        out.append(fitted)
        fits.append(ok & np.all(k_lo <= k_hi, axis=-1))
    return np.stack(out), np.stack(fits)


def _shift_bounds(robot: Robot, q, slack):
    """Smallest and largest k with q + 2*pi*k inside the range widened by ``slack`` [rad] (scalar or
    per joint)."""
    return (np.ceil((robot.limits.lower - slack - q) / TWO_PI), np.floor((robot.limits.upper + slack - q) / TWO_PI))


def _closest(robot: Robot, geo: OPWGeometry, sol: OPWSolutions, i: int, q_ref: np.ndarray,
             pose: str) -> tuple[np.ndarray, int]:
    """Solution of point i nearest to q_ref over all branches and shifts, and its branch."""
    qs = sol.q[i]
    reach = sol.reach_ok[i]
    if not reach.any():
        raise UnreachableError(f"{pose}: {_reach_message(geo, sol, i)}", reason="reach")
    with np.errstate(invalid="ignore"):
        shifted, fits = _nearest_in_range(robot, geo, qs, q_ref)
    ok = reach & fits  # (2, 8): two shift choices per branch
    if not ok.any():
        raw = qs + TWO_PI * np.round((q_ref - qs) / TWO_PI)
        dist = np.where(reach, np.linalg.norm(raw - q_ref, axis=1), np.inf)
        b = int(np.argmin(dist))
        raise UnreachableError(
            f"{pose}: no IK solution inside the joint ranges; on the branch nearest to q_ref "
            f"({branch_name(b)}) {_range_violation(robot, raw[b])}; "
            f"{int(reach.sum())} of 8 branches reach the pose, none within the ranges",
            reason="joint_range",
        )
    dist = np.where(ok, np.linalg.norm(shifted - q_ref, axis=-1), np.inf)
    choice, b = np.unravel_index(int(np.argmin(dist)), dist.shape)
    return shifted[choice, b], int(b)


def ik(robot: Robot, position, rotation, q_ref) -> np.ndarray:
    """Joint configuration (n,) [rad] reaching the TCP pose, nearest to ``q_ref`` (n,).

    Closed form over all branches and in-range 2*pi shifts for OPW arms; otherwise :func:`ik_dls`
    started at q_ref. Raises UnreachableError (reason reach / joint_range / not_converged).
    """
    p, r = _poses(position, rotation, batch=False)
    q_ref = _reference(robot, q_ref)
    geo = robot.opw_detection[0]
    if geo is None:
        return ik_dls(robot, p[0], r[0], q_ref)
    t_ref = geo.to_t(q_ref)
    sol = solve(geo, p, r, t_ref[None, 0], t_ref[None, 3])
    return _closest(robot, geo, sol, 0, q_ref, _fmt_pose(p[0], r[0]))[0]


def ik_all(robot: Robot, position, rotation) -> np.ndarray:
    """All closed-form solutions (k, 6) [rad] of a TCP pose inside the joint ranges.

    Ordered by branch (see :mod:`pathmotion.robot.opw`), then by 2*pi shift. At an exact wrist or
    shoulder singularity the redundant angle is the one of q = 0. Needs an OPW arm
    (RobotModelError otherwise); UnreachableError when no solution is in range.
    """
    p, r = _poses(position, rotation, batch=False)
    geo = opw_geometry(robot)
    t0 = geo.to_t(np.zeros(robot.n))
    sol = solve(geo, p, r, t0[None, 0], t0[None, 3])
    rows = []
    for b in range(8):
        if not sol.reach_ok[0, b]:
            continue
        q = sol.q[0, b]
        k_lo, k_hi = _shift_bounds(robot, q, _slack(geo, q))
        combos = np.array(list(itertools.product(*[q[j] + TWO_PI * np.arange(k_lo[j], k_hi[j] + 1)
                                                   for j in range(robot.n)]))).reshape(-1, robot.n)
        fitted, ok = _into_range(robot, geo, combos)
        for row in fitted[ok]:
            if not any(np.max(np.abs(row - other)) < IK_SAME_SOLUTION for other in rows):
                rows.append(row)
    if not rows:
        _closest(robot, geo, sol, 0, np.zeros(robot.n), _fmt_pose(p[0], r[0]))  # raises with the reason
    return np.array(rows)


# ----------------------------------------------------------------------------------------------
# Closed form, batch


def _forward_fill(values: np.ndarray, degenerate: np.ndarray, first: float) -> np.ndarray:
    """values with every degenerate entry replaced by the last non-degenerate one before it; leading
    degenerate entries take the first non-degenerate value (the limit along the path: a path that starts
    exactly at a singularity continues smoothly), ``first`` when every entry is degenerate."""
    idx = np.where(degenerate, -1, np.arange(len(values)))
    idx = np.maximum.accumulate(idx)
    if not degenerate.all():
        idx = np.where(idx < 0, int(np.argmin(degenerate)), idx)
    return np.where(idx < 0, first, values[np.maximum(idx, 0)])


def continuous_wrist(geo: OPWGeometry, q: np.ndarray, first: int) -> np.ndarray:
    """Configurations (N, 6) on one shoulder/elbow branch with the wrist branch chosen for continuity.

    q: the solutions on wrist branch 0 (t5 >= 0); ``first``: the wrist branch (0 or 1) at point 0.
    Between consecutive points the wrist branch changes when the flipped solution (:func:`flip_wrist`)
    is nearer (Euclidean, joints wrapped) than the unflipped one: minimum joint motion. Away from
    q5 = 0 the flip moves q4 and q6 by pi, so it is never nearer; where q5 passes through 0 it is the
    continuation (q5 changes sign, q4 and q6 stay smooth). The flip is an isometry and an
    involution, so one comparison per pair decides for either current branch.
    """
    flipped = flip_wrist(geo, q)
    if len(q) < 2:
        return flipped if first else q
    with np.errstate(invalid="ignore"):
        same = np.linalg.norm(wrap(np.diff(q, axis=0)), axis=1)
        other = np.linalg.norm(wrap(flipped[1:] - q[:-1]), axis=1)
        toggle = other < same
    parity = (first + np.concatenate([[0], np.cumsum(toggle)])) % 2
    return np.where(parity[:, None] == 1, flipped, q)


def ik_batch(robot: Robot, positions, rotations, q_ref, *,
             max_joint_step: float | None = defaults.IK_MAX_JOINT_STEP) -> np.ndarray:
    """Configurations (N, n) [rad] reaching N TCP poses (positions (N, 3), rotations (N, 3, 3)).

    The shoulder and elbow branch are the ones nearest to ``q_ref`` (n,) at point 0, kept for all
    points; the wrist branch follows :func:`continuous_wrist` (it changes where q5 passes through 0,
    so a path through the wrist singularity stays continuous); each joint takes the 2*pi turn
    continuous with the previous point. A joint change above
    ``max_joint_step`` [rad] between consecutive points is reported as a singularity (the path
    crosses it, or passes nearer than the point spacing resolves); None disables that check.
    Raises UnreachableError with ``index`` = first bad point. Arms without the closed form use
    :func:`ik_dls` point by point, each started at the previous solution.
    """
    p, r = _poses(positions, rotations, batch=True)
    q_ref = _reference(robot, q_ref)
    geo = robot.opw_detection[0]
    if geo is None:
        return _dls_batch(robot, p, r, q_ref)
    n_pts = len(p)
    try:
        q0, branch = _first_solution(robot, p[0].tobytes(), r[0].tobytes(), q_ref.tobytes())
    except UnreachableError as exc:
        raise UnreachableError(str(exc), index=0, reason=exc.reason) from None
    t0 = geo.to_t(q0)
    base = branch & ~1  # the wrist bit is chosen per point below
    t4_first = t0[3] if branch == base else t0[3] - np.pi
    sol = solve(geo, p, r, np.full(n_pts, t0[0]), np.full(n_pts, t4_first), branches=(base,))
    # exact singularities: take the redundant angle from the previous regular point (the first one at the start)
    shoulder_deg = sol.shoulder_radius < defaults.IK_DEGENERATE
    wrist_deg = np.abs(sol.sin_wrist[:, base]) < defaults.IK_DEGENERATE
    if shoulder_deg.any() or wrist_deg.any():
        t = geo.to_t(sol.q[:, base])
        t1 = _forward_fill(t[:, 0], shoulder_deg, t0[0])
        t4 = _forward_fill(t[:, 3], wrist_deg, t4_first)
        sol = solve(geo, p, r, t1, t4, branches=(base,))
    qb = continuous_wrist(geo, sol.q[:, base], branch & 1)
    bad_reach = ~sol.reach_ok[:, base]
    i_reach = int(np.argmax(bad_reach)) if bad_reach.any() else n_pts
    step = wrap(np.diff(qb, axis=0))
    i_jump = n_pts
    if max_joint_step is not None and n_pts > 1:
        with np.errstate(invalid="ignore"):
            jump = np.abs(step) > max_joint_step
        if jump.any():
            i_jump = int(np.argmax(jump.any(axis=1))) + 1
    step = np.nan_to_num(step)
    q_cont = q0 + np.concatenate([np.zeros((1, robot.n)), np.cumsum(step, axis=0)])
    q = qb + TWO_PI * np.round((q_cont - qb) / TWO_PI)
    fitted, fits = _into_range(robot, geo, q)
    i_range = int(np.argmin(fits)) if not fits.all() else n_pts
    i_bad = min(i_reach, i_jump, i_range)
    if i_bad == n_pts:
        return fitted
    where = f"point {i_bad}, {_fmt_pose(p[i_bad], r[i_bad])}"
    name = branch_name(branch)
    if i_bad == i_reach:
        raise UnreachableError(f"{where}: {_reach_message(geo, sol, i_bad, (base,))} (branch {name})",
                               index=i_bad, reason="reach")
    if i_bad == i_jump:
        raise UnreachableError(f"{where}: {_singular_message(robot, geo, sol, qb, base, i_bad)}",
                               index=i_bad, reason="singular")
    raise UnreachableError(
        f"{where}: {_range_violation(robot, q[i_bad])} on the branch followed from point 0 ({name}, wrist continuous); "
        "start from another q_ref or move the path", index=i_bad, reason="joint_range")


@lru_cache(maxsize=FIRST_POINT_CACHE)
def _first_solution(robot: Robot, position: bytes, rotation: bytes, q_ref: bytes) -> tuple[np.ndarray, int]:
    """ik_batch's first point: the closed-form solution of the pose (position (3,) [m] and rotation (3, 3), as
    float64 bytes) nearest to ``q_ref`` (n,) over all branches and shifts (read-only (n,) [rad]), and its branch.
    A pure function of its arguments, kept for FIRST_POINT_CACHE of them (the bytes are the exact floats)."""
    geo = robot.opw_detection[0]
    p, r, ref = (np.frombuffer(b).reshape(shape) for b, shape in ((position, (1, 3)), (rotation, (1, 3, 3)),
                                                                  (q_ref, (robot.n,))))
    t_ref = geo.to_t(ref)
    first = solve(geo, p, r, t_ref[None, 0], t_ref[None, 3])
    q0, branch = _closest(robot, geo, first, 0, ref, "point 0, " + _fmt_pose(p[0], r[0]))
    q0 = np.array(q0)
    q0.flags.writeable = False
    return q0, branch


def _singular_message(robot: Robot, geo: OPWGeometry, sol: OPWSolutions, qb, branch: int, i: int) -> str:
    raw = wrap(np.diff(qb[i - 1:i + 1], axis=0))[0]
    j = int(np.argmax(np.abs(raw)))
    moved = f"joint {robot.joint_names[j]} changes by {raw[j]:.3f} rad between points {i - 1} and {i}"
    if j in (3, 5) or (j == 4 and abs(sol.sin_wrist[i, branch]) < WRIST_NEAR_SINGULAR):
        what = (f"wrist singularity (q5 = 0): |sin q5| = {abs(sol.sin_wrist[i, branch]):.2e} "
                f"(q5 = {qb[i, 4]:.2e} rad)")
    elif j == 0:
        what = (f"shoulder singularity: the wrist centre is {sol.shoulder_radius[i]:.2e} m from axis 1")
    else:
        what = (f"elbow singularity (arm stretched or folded): wrist centre {sol.arm_distance[i, branch >> 2]:.4f} m "
                f"from the joint-2 axis, limits {abs(geo.c2 - geo.k):.4f}..{geo.c2 + geo.k:.4f} m")
    return (f"singular: {moved}; the path crosses or passes too near the {what}; move the path away "
            "from it or sample it more densely")


# ----------------------------------------------------------------------------------------------
# Damped least squares


def _pose_error(robot: Robot, q, p, r) -> np.ndarray:
    pos, rot = fk(robot, q)
    return np.concatenate([p - pos, pin.log3(r @ rot.T)])


def ik_dls(robot: Robot, position, rotation, q_ref, *, damping: float = defaults.DLS_DAMPING,
           max_iterations: int = defaults.DLS_MAX_ITERATIONS, tolerance: float = defaults.IK_TOLERANCE) -> np.ndarray:
    """IK of any arm by damped least squares (Levenberg-Marquardt), from ``q_ref`` (n,).

    Step dq = (J^T J + lambda^2 I)^-1 J^T e with e = (position error [m], rotation-vector error
    [rad]) in base axes and J the TCP Jacobian; lambda starts at ``damping``, grows by
    ``defaults.DLS_DAMPING_GROWTH`` after a rejected step and shrinks after an accepted one; steps
    are clamped to ``defaults.DLS_MAX_STEP`` [rad] and the joints to their ranges. Converged when
    the largest position and rotation errors are below ``tolerance``. Arms with fewer than 6 joints
    reach only poses consistent with their motion (e.g. FK outputs). Raises UnreachableError
    (reason "not_converged" or "singular") with the final residual.
    """
    p, r = _poses(position, rotation, batch=False)
    p, r = p[0], r[0]
    q_ref = _reference(robot, q_ref)
    lo, hi = robot.limits.lower, robot.limits.upper
    q = np.clip(q_ref, lo, hi)
    err = _pose_error(robot, q, p, r)
    lam = damping
    eye = np.eye(robot.n)
    for _ in range(max_iterations):
        if np.max(np.abs(err)) < tolerance:
            return q
        jac = jacobian(robot, q)
        try:  # a far tool (|t| ~ 1e9 m) makes J^T J + lambda^2 I singular in floating point
            dq = np.linalg.solve(jac.T @ jac + lam**2 * eye, jac.T @ err)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(dq)):
            break
        norm = np.linalg.norm(dq)
        if norm > defaults.DLS_MAX_STEP:
            dq *= defaults.DLS_MAX_STEP / norm
        q_new = np.clip(q + dq, lo, hi)
        err_new = _pose_error(robot, q_new, p, r)
        if np.linalg.norm(err_new) < np.linalg.norm(err):
            q, err = q_new, err_new
            lam = max(lam / defaults.DLS_DAMPING_GROWTH, damping)
        else:
            lam *= defaults.DLS_DAMPING_GROWTH
            if lam > DLS_MAX_DAMPING:
                break
    if np.max(np.abs(err)) < tolerance:
        return q
    sigma = np.linalg.svd(jacobian(robot, q), compute_uv=False)[min(robot.n, 6) - 1]
    at_limit = [robot.joint_names[j] for j in range(robot.n) if q[j] <= lo[j] or q[j] >= hi[j]]
    singular = sigma < defaults.SINGULARITY_THRESHOLD
    detail = (f"position error {np.linalg.norm(err[:3]):.3g} m, rotation error {np.linalg.norm(err[3:]):.3g} rad; "
              f"smallest Jacobian singular value {sigma:.3g}"
              + (" (singular)" if singular else "")
              + (f"; joints at a range limit: {at_limit}" if at_limit else ""))
    raise UnreachableError(
        f"{_fmt_pose(p, r)}: damped-least-squares IK from q_ref did not converge ({detail}); the pose may be "
        "out of reach, outside the joint ranges or singular; try another q_ref",
        reason="singular" if singular else "not_converged",
    )


def _dls_batch(robot: Robot, p: np.ndarray, r: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    out = np.empty((len(p), robot.n))
    q = q_ref
    for i in range(len(p)):
        try:
            q = ik_dls(robot, p[i], r[i], q)
        except UnreachableError as exc:
            raise UnreachableError(f"point {i}: {exc}", index=i, reason=exc.reason) from None
        out[i] = q
    return out


BRANCH_PROOF_MARGIN = 1e-9  # [rad] kept between the nearest branch's distance and the bound on the others'


def _nearest_among(sol: OPWSolutions, candidates: np.ndarray, q_refs: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per point, the solution among the branches ``candidates`` (k,) nearest its reference (N, 6), on the 2*pi
    turns nearest it: (q (N, 6), its distance (N,) [rad], inf where no candidate reaches, its branch (N,))."""
    points = np.arange(len(q_refs))
    q = sol.q[:, candidates]
    qs = q + TWO_PI * np.round((q_refs[:, None, :] - q) / TWO_PI)
    with np.errstate(invalid="ignore"):
        dist = np.where(sol.reach_ok[:, candidates], np.linalg.norm(qs - q_refs[:, None, :], axis=2), np.inf)
    pick = np.argmin(dist, axis=1)
    return qs[points, pick], dist[points, pick], candidates[pick]


def _nearest_on_reference_branches(geo: OPWGeometry, p: np.ndarray, r: np.ndarray, t_ref: np.ndarray,
                                   q_refs: np.ndarray) -> np.ndarray | None:
    """:func:`ik_nearest`'s answer (N, 6) computed on the references' own branches only (one along a path, two
    across a wrist crossing: :func:`~pathmotion.robot.opw.branch_of`), or None where that cannot be proven.

    Proof: each point's nearest solution among those branches, at distance d from its reference, is the nearest
    of all eight if 2 d is below the bound on the distance between branches
    (:func:`~pathmotion.robot.opw.branch_gap`): every other branch is then farther than d (triangle inequality).
    The values are those the eight-branch solve gives (the same operations on the same arrays). None where the
    proof fails at any point: near a singularity, or a reference far off.
    """
    candidates = np.unique(branch_of(geo, p, r, t_ref))
    sol = solve(geo, p, r, t_ref[:, 0], t_ref[:, 3], branches=tuple(int(b) for b in candidates))
    q, d, branch = _nearest_among(sol, candidates, q_refs)
    return q if np.all(2.0 * d + BRANCH_PROOF_MARGIN < branch_gap(geo, sol, branch)) else None


def ik_nearest(robot: Robot, positions, rotations, q_refs) -> np.ndarray:
    """Configurations (N, n) reaching N TCP poses, each the solution nearest to its own reference
    ``q_refs`` (N, n) over all branches and 2*pi turns (no range filtering: the caller checks).

    For evaluating a path at arbitrary theta, in any order, against a dense continuous reference
    of the same path: the nearest solution is then the reference's branch and turn. Vectorized
    for closed-form arms; DLS from each reference otherwise.
    """
    p, r = _poses(positions, rotations, batch=True)
    q_refs = np.asarray(q_refs, dtype=float)
    if q_refs.shape != (len(p), robot.n):
        raise PathmotionError(f"IK: q_refs has shape {q_refs.shape}, expected {(len(p), robot.n)}")
    geo = robot.opw_detection[0]
    if geo is None:
        out = np.empty((len(p), robot.n))
        for i in range(len(p)):
            try:
                out[i] = ik_dls(robot, p[i], r[i], q_refs[i])
            except UnreachableError as exc:
                raise UnreachableError(f"point {i}: {exc}", index=i, reason=exc.reason) from None
        return out
    t_ref = geo.to_t(q_refs)
    if len(p):
        proven = _nearest_on_reference_branches(geo, p, r, t_ref, q_refs)
        if proven is not None:
            return proven
    sol = solve(geo, p, r, t_ref[:, 0], t_ref[:, 3])
    q, d, _ = _nearest_among(sol, np.arange(8), q_refs)
    unreached = ~np.isfinite(d)
    if unreached.any():
        i = int(np.argmax(unreached))
        raise UnreachableError(f"point {i}, {_fmt_pose(p[i], r[i])}: {_reach_message(geo, sol, i)}",
                               index=i, reason="reach")
    return q
