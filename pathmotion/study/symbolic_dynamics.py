"""Symbolic inverse dynamics tau(q, qd, qdd) as a CasADi Function, for the free-shape reference's
torque limits (:mod:`.free_shape`).

PyPI ``pin`` has no ``pinocchio.casadi``, so, like :func:`.free_shape.tcp_function`, this builds the
expression by hand from the Pinocchio model: the recursive Newton-Euler algorithm in each body's
frame (Featherstone's, as Pinocchio and pathmotion/planning/fast_rnea.py run it) over a chain or tree
of one-coordinate revolute or prismatic joints, with each body's inertia (``model.inertias``: mass,
centre of mass, rotational inertia about it; the robot's payload is already merged into the last
link), the base accelerating at -``model.gravity`` and the drives' armature (``model.armature``,
reflected rotor inertia) on the diagonal. That is the torque model of the planner's torque limit
(reduced dynamics from fast_rnea.py, or Pinocchio's ``rnea``), so the NLP and the planner limit the
same torque. No friction: neither does the planner.

Units: SI (q [rad or m], qd [rad/s], qdd [rad/s^2], tau [N m or N]).
"""

from __future__ import annotations

import numpy as np

from ..errors import PathmotionError
from ..robot.joints import REVOLUTE, joint_motion
from .symbolic import casadi_module, rodrigues


def _joint(model, i: int) -> tuple[int, np.ndarray]:
    """(kind, unit axis (3,)) of joint ``i`` of ``model``, or a PathmotionError naming it."""
    joint = model.joints[i]
    if joint.nq != 1 or joint.nv != 1:
        raise PathmotionError(f"symbolic dynamics: joint {model.names[i]} has {joint.nq} coordinates; only "
                              "one-coordinate revolute or prismatic joints are handled")
    motion = joint_motion(joint)
    if motion is None:
        raise PathmotionError(f"symbolic dynamics: joint {model.names[i]} is of type {joint.shortname()}; only "
                              "revolute and prismatic joints are handled (lock the others with "
                              "load_robot(..., locked_joints=...))")
    return motion


def _forces(ca, inertia, w, v, a, al):
    """Net force (linear (3,), moment about the body origin (3,)) on a body with spatial velocity
    (w, v) and acceleration (a, al) in its frame: f = I acc + v x* (I v), I the spatial inertia
    (mass m, centre of mass c, rotational inertia Ic about c)."""
    m, c, Ic = float(inertia.mass), ca.DM(np.asarray(inertia.lever, float)), ca.DM(np.asarray(inertia.inertia, float))
    f = m * (al + ca.cross(a, c))
    n = Ic @ a + ca.cross(c, f)
    h = m * (v + ca.cross(w, c))
    k = Ic @ w + ca.cross(c, h)
    return f + ca.cross(w, h), n + ca.cross(w, k) + ca.cross(v, h)


def inverse_dynamics_function(robot):
    """CasADi Function (q, qd, qdd) (n,) each -> tau (n,) = M(q) qdd + C(q, qd) qd + G(q) [N m], with
    the robot's payload, gravity and armature (the planner's torque model, see the module docstring)."""
    ca = casadi_module()
    model = robot.model
    n = robot.n
    if model.nq != n or model.nv != n:
        raise PathmotionError(f"symbolic dynamics: the model has nq = {model.nq}, nv = {model.nv} for {n} joints; "
                              "only one-coordinate revolute or prismatic joints are handled (lock the others with "
                              "load_robot(..., locked_joints=...))")
    q, qd, qdd = (ca.SX.sym(name, n) for name in ("q", "qd", "qdd"))
    armature = np.asarray(model.armature, float)
    zero = ca.SX.zeros(3, 1)
    # base: at rest, accelerating upwards at -g (gravity as an inertial force on every body)
    motion = {0: (zero, zero, zero, -ca.DM(np.asarray(model.gravity.linear, float)))}
    frames, forces = {}, {}
    for i in range(1, model.njoints):
        kind, axis = _joint(model, i)
        k = model.joints[i].idx_v
        placement = model.jointPlacements[i]
        R = ca.DM(placement.rotation) @ (rodrigues(ca, axis, q[k]) if kind == REVOLUTE else ca.DM.eye(3))
        p = ca.DM(placement.translation) + (ca.DM(placement.rotation) @ ca.DM(axis) * q[k] if kind != REVOLUTE else 0)
        frames[i] = (R, p)
        pw, pv, pa, pl = motion[model.parents[i]]
        # the parent's motion at this body's origin, in this body's frame
        w, v = R.T @ pw, R.T @ (pv + ca.cross(pw, p))
        a, al = R.T @ pa, R.T @ (pl + ca.cross(pa, p))
        s = ca.DM(axis) * qd[k]
        if kind == REVOLUTE:  # acc += (w x s, v x s) + (axis qdd, 0); w += s
            a, al = a + ca.cross(w, s) + ca.DM(axis) * qdd[k], al + ca.cross(v, s)
            w = w + s
        else:  # prismatic: acc += (0, w x s + axis qdd); v += s
            al = al + ca.cross(w, s) + ca.DM(axis) * qdd[k]
            v = v + s
        motion[i] = (w, v, a, al)
        forces[i] = _forces(ca, model.inertias[i], w, v, a, al)
    tau = [None] * n
    for i in range(model.njoints - 1, 0, -1):
        kind, axis = _joint(model, i)
        k = model.joints[i].idx_v
        f, m = forces[i]
        tau[k] = ca.dot(ca.DM(axis), m if kind == REVOLUTE else f) + armature[k] * qdd[k]
        lam = model.parents[i]
        if lam > 0:  # the parent takes (R f, R m + p x R f)
            R, p = frames[i]
            fp = R @ f
            pf, pm = forces[lam]
            forces[lam] = (pf + fp, pm + R @ m + ca.cross(p, fp))
    return ca.Function("rnea", [q, qd, qdd], [ca.vertcat(*tau)], ["q", "qd", "qdd"], ["tau"])


__all__ = ["inverse_dynamics_function"]
