"""Offline refinement of a shaped reference against the drive file's own model (model-based iterative learning).

The analytic shaping (reference.py) inverts the known dynamics one piece at a time; what it leaves (the servo's
finite stiffness against the gear reaction, the speed-deviation clamp, the cycle-rate staircase of the servo
reference, the coupling between axes) shows when the nominal arm (:class:`.drives.VirtualArm`: the
controller's robot model, the built-in plant, lockstep) runs the table. The refinement holds the table
``EGM_REFINE_TAIL`` past its end and adds a motor-side correction u (N, n) [rad] on the EGM cycle grid (its
first sample 0: the first reference stays the robot's start) to the shaped motor position m before the
low-pass inverse, so that sent = shaped + P u with

    P u = lowpass^-1(u) on position, lowpass^-1(du/dt) on the speed reference (linear between cycles).

Iteration j runs the arm and takes the link-side error against the reference's own (shaped) motion at the plan
time the arm follows, e_j(k) = q_plan((k + 1) dt - d) - q_j(k) (d: the table's delay, EGM's transport delay:
the references are not led by it), weighted per joint by how far it moves the TCP, less its
component along the path's tangent (path accuracy is a distance from the path, not a lag; at rest at the
path's end all of it counts). The norm-optimal step per axis i is

    u_(j+1),i = u_j,i + s (G_i^T G_i + g (lambda I + mu D^T D))^-1 G_i^T e_j,i

(g = max diag G_i^T G_i, lambda = EGM_REFINE_REGULARIZATION, mu = EGM_REFINE_SMOOTHING, D the first difference:
a smooth correction, whose speed reference stays well inside the joint speed limits) with G_i the
lower-triangular Toeplitz matrix of axis i's response to one cycle's unit correction, measured on the same arm
at rest at the start (linear: no torque limit active). Of the steps s in STEPS, the one with the least RMS
transverse error is taken if that error falls; no fall ends the iterations, so the error the refinement
returns never exceeds its start's. The start is the analytic table, or its plain form (the shaped motion plus
the gear deflection, no low-pass inverse) when the nominal arm follows the path better with it; the
refined table then says so (``plain``) and its correction is the learned one on top of the plain form, so
that a re-timed segment (stop, override, resume: built unrefined) continues in the plain form too.
The wrist axes' and the coupling terms the diagonal model misses are what the next iteration sees.
"""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np

from .. import defaults
from ..robot import Robot, fk
from .drive_file import DriveParameters
from .drives import VirtualArm
from .reference import ReferenceTable, lowpass, lowpass_alpha, motor_correction

log = logging.getLogger(__name__)

#: The step sizes tried along each iteration's update (the best one that lowers the error is taken).
STEPS = (1.0,)


def run_nominal(robot: Robot, drives: DriveParameters, table: ReferenceTable, cycles: int) -> np.ndarray:
    """Link-side joints (cycles, n) [rad] of the nominal arm after each EGM cycle k (time (k + 1) x cycle) fed
    the table's references at plan times k x cycle (clipped into the joint limits, as the streamer sends them)."""
    lim = robot.limits
    arm = VirtualArm(robot, drives, table.plan[0])
    out = np.empty((cycles, robot.n))
    for k in range(cycles):
        q, qd = table.at(k * drives.cycle)[:2]
        arm.cycle(np.clip(q, lim.lower, lim.upper), np.clip(qd, -lim.velocity, lim.velocity))
        out[k] = arm.state.q
    return out


def tcp_weights(robot: Robot, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """How far the TCP moves per radian of each joint at q (n,) [m/rad] (finite differences)."""
    p0 = fk(robot, q[None])[0][0]
    shifted = q[None] + h * np.eye(len(q))
    return np.linalg.norm(fk(robot, shifted)[0] - p0, axis=1) / h


def _responses(robot: Robot, drives: DriveParameters, table: ReferenceTable, inputs: int, outputs: int,
               horizon: int) -> list[np.ndarray]:
    """Per axis, the Toeplitz matrix (outputs, inputs) of its link response to a unit correction at one cycle,
    measured at rest at the table's start over ``horizon`` cycles (column 0, the start, left out: zeros; the
    last column, held after the table's end, the step response)."""
    amp, k0 = 1e-5, 2
    rest = dataclasses.replace(table, q=np.repeat(table.q[:1], len(table.t), axis=0), qd=np.zeros_like(table.qd),
                               correction=None)
    held = run_nominal(robot, drives, rest, k0 + horizon)
    out = []
    for i in range(robot.n):
        u = np.zeros((k0 + 2, robot.n))
        u[k0, i] = amp
        h = (run_nominal(robot, drives, _corrected(robot, rest, u, drives), k0 + horizon) - held)[k0:, i] / amp
        g = np.zeros((outputs, inputs))
        for c in range(1, inputs):
            span = min(len(h), outputs - c)
            g[c:c + span, c] = h[:span]
        last = np.cumsum(h)  # the last sample is held after the table's end: its response is the step response
        span = min(len(h), outputs - inputs + 1)
        g[inputs - 1:inputs - 1 + span, inputs - 1] = last[:span]
        g[inputs - 1 + span:, inputs - 1] = last[span - 1]
        out.append(g)
    return out


def _extended(table: ReferenceTable, tail: float) -> ReferenceTable:
    """The table held at its last row for ``tail`` [s] more (speed 0): room for a correction that calms the arm
    after the motion's end."""
    step = table.t[1] - table.t[0]
    extra = int(round(tail / step))
    if extra <= 0:
        return table

    def held(a, rest=None):
        return None if a is None else np.concatenate([a, np.repeat(a[-1:] if rest is None else rest, extra, axis=0)])

    motion = None if table.motion is None else held(table.motion, np.array([[table.motion[-1, 0], 0.0, 0.0]]))
    return dataclasses.replace(table, t=np.concatenate([table.t, table.t[-1] + step * np.arange(1, extra + 1)]),
                               q=held(table.q), qd=held(table.qd, np.zeros((1, table.qd.shape[1]))),
                               theta=held(table.theta), plan=held(table.plan), deflection=held(table.deflection),
                               motion=motion, correction=held(table.correction))


def _tangents(table: ReferenceTable, times: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Unit tangents (K, n) of the joint path, in the TCP-weighted joint metric, where the table's motion is at
    plan times (K,) (the path's direction at its end after the table's end)."""
    theta = np.array([table.at(x)[3] for x in times])
    tangent = weight * table.path.evaluate(theta)[1]
    return tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)


def _corrected(robot: Robot, table: ReferenceTable, u: np.ndarray, drives: DriveParameters,
               base: np.ndarray | None = None) -> ReferenceTable:
    """The table with the cycle-grid motor correction u (N, n) added (see the module's P u) on top of the
    correction ``base`` (K, n) at its rows (None: 0)."""
    tc = np.arange(len(u)) * drives.cycle
    dm = np.stack([np.interp(table.t, tc, u[:, j]) for j in range(u.shape[1])], axis=1)
    return motor_correction(table, dm if base is None else dm + base, drives, robot)


def refine_reference(robot: Robot, drives: DriveParameters, table: ReferenceTable,
                     iterations: int = defaults.EGM_REFINE_ITERATIONS,
                     tolerance: float = defaults.EGM_REFINE_TOLERANCE) -> tuple[ReferenceTable, list[float]]:
    """The table refined by at most ``iterations`` learning iterations on the nominal arm (see the module),
    stopping once the TCP-weighted RMS error is below ``tolerance`` [m]; returns it and the RMS error [m] of
    every accepted run (the analytic table's first, falling)."""
    start = time.process_time()
    dt = drives.cycle
    table = _extended(table, defaults.EGM_REFINE_TAIL)
    inputs = int(np.floor(table.end / dt)) + 1
    outputs = inputs + int(round(defaults.EGM_REFINE_SETTLE / dt))
    times = np.arange(1, outputs + 1) * dt
    shown = times - table.delay  # the plan time the arm follows: the references reach it table.delay late
    want = np.array([table.at(x)[2] for x in shown])
    weight = tcp_weights(robot, table.plan[0])
    weight = np.maximum(weight, defaults.EGM_REFINE_WEIGHT_FLOOR * weight.max())
    along = _tangents(table, shown, weight) * (shown < table.duration)[:, None]  # at rest at the end: all counts

    def transverse(q):
        """The weighted error orthogonal to the path (outputs, n) [m]: the part the path accuracy counts."""
        e = weight * (want - q)
        return e - np.sum(e * along, axis=1, keepdims=True) * along

    def cost(q):
        return float(np.sqrt(np.mean(np.sum(transverse(q) ** 2, axis=1))))

    q = run_nominal(robot, drives, table, outputs)
    costs = [cost(q)]
    if iterations <= 0 or costs[0] <= tolerance:
        return table, costs
    # the start: the analytic shaping, or its plain form (the motion plus the gear deflection: no
    # low-pass inverse) if the nominal arm follows the path better so (the analytic feed-forward asks the
    # motors for more than their torque where the plan runs at it)
    per = max(1, int(round(dt / (table.t[1] - table.t[0]))))
    base = lowpass(table.plan + table.deflection - table.q, lowpass_alpha(drives), per)
    plain = motor_correction(table, base, drives, robot)
    q_plain = run_nominal(robot, drives, plain, outputs)
    best = table
    if cost(q_plain) < costs[0]:
        q, best = q_plain, plain
        costs.append(cost(q_plain))
    else:
        base = None
    g = _responses(robot, drives, table, inputs, outputs, min(outputs, int(round(defaults.EGM_REFINE_HORIZON / dt))))
    solve = []
    diff = np.diff(np.eye(inputs), axis=0)
    for gi in g:
        gram = gi.T @ gi
        scale = max(float(np.max(np.diag(gram))), 1e-12)
        penalty = scale * (defaults.EGM_REFINE_REGULARIZATION * np.eye(inputs)
                           + defaults.EGM_REFINE_SMOOTHING * diff.T @ diff)
        solve.append(np.linalg.solve(gram + penalty, gi.T))
    u = np.zeros((inputs, robot.n))
    for _ in range(iterations):
        e = transverse(q) / weight
        du = np.stack([solve[i] @ e[:, i] for i in range(robot.n)], axis=1)
        du[0] = 0.0
        trials = []
        for s in STEPS:
            trial = _corrected(robot, table, u + s * du, drives, base)
            q_trial = run_nominal(robot, drives, trial, outputs)
            trials.append((cost(q_trial), s, q_trial, trial))
        c, s, q_trial, trial = min(trials, key=lambda x: x[0])
        if c >= costs[-1]:
            break
        u, q, best = u + s * du, q_trial, trial
        costs.append(c)
        if c <= tolerance:
            break
    if base is not None:  # the plain form: the correction on top of it (what a re-timed segment carries)
        best = dataclasses.replace(best, correction=best.correction - base, plain=True)
    log.info("reference refined on the nominal arm: TCP transverse RMS error %.4g -> %.4g mm (%s start, %d "
             "iterations), %.2f s CPU", 1e3 * costs[0], 1e3 * costs[-1], "analytic" if base is None else "plain",
             len(costs) - 1 - (base is not None), time.process_time() - start)
    return best, costs
