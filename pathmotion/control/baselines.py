"""Time-indexed baselines: computed-torque tracking and PD + gravity, both of trajectory.at_time(t).

The reference is the planned trajectory sampled on the controller's clock, t_k = k Ts, precomputed
once (Trajectory.at_time on the exact path). The acceleration feedforward is taken at t_k + Ts/2, the
middle of the hold interval, as in the orbital controller. After the planned duration an open path's
reference holds the final configuration; a closed path's repeats with the period.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..lift.joint_path import JointPath
from ..planning.profile import Profile
from ..planning.trajectory import Trajectory
from ..robot import Robot, mass_matrix
from .gains import TrackingGains, default_pd_gains
from .laws import computed_torque, pd_gravity


@dataclass(frozen=True, eq=False)
class TimeReference:
    """Reference on the clock: q, qd (K, n) at t_k = k dt, qdd_ff (K, n) at t_k + dt/2."""

    dt: float
    q: np.ndarray
    qd: np.ndarray
    qdd_ff: np.ndarray

    @classmethod
    def sample(cls, path: JointPath, profile: Profile, dt: float, horizon: float) -> "TimeReference":
        """Sample the planned trajectory every ``dt`` seconds up to ``horizon`` seconds."""
        traj = Trajectory(path, profile)
        count = int(np.ceil(horizon / dt)) + 2
        t = np.arange(count) * dt
        t_mid = t + 0.5 * dt
        if path.closed:
            t, t_mid = t % profile.duration, t_mid % profile.duration
        at = traj.at_time(t)
        mid = traj.at_time(t_mid)
        qdd_ff = mid.qdd.copy()
        if not path.closed:
            qdd_ff[t_mid >= profile.duration] = 0.0
        return cls(float(dt), at.q, at.qd, qdd_ff)

    def index(self, t: float) -> int:
        return min(int(round(t / self.dt)), len(self.q) - 1)


class ComputedTorqueController:
    """tau = M(q) (qdd_ff + Kd (qd_ref - qd) + Kp (q_ref - q)) + C qd + G, nominal model."""

    name = "computed_torque"

    def __init__(self, reference: TimeReference, robot: Robot, gains: TrackingGains = TrackingGains()):
        self.reference = reference
        self.model = robot.model
        self.data = robot.model.createData()
        self.kp, self.kd = gains.stiffness, gains.velocity_gain

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        r = self.reference
        k = r.index(t)
        v = r.qdd_ff[k] + self.kd * (r.qd[k] - qd) + self.kp * (r.q[k] - q)
        return computed_torque(self.model, self.data, q, qd, v)


class PDGravityController:
    """tau = Kp (q_ref - q) + Kd (qd_ref - qd) + G(q): a decentralized industrial joint loop.

    Kp_j = w^2 M_jj(q_ref(0)), Kd_j = 2 zeta w M_jj(q_ref(0)) [N m/rad, N m s/rad], nominal model.
    """

    name = "pd_gravity"

    def __init__(self, reference: TimeReference, robot: Robot, gains: TrackingGains | None = None):
        gains = default_pd_gains() if gains is None else gains
        self.reference = reference
        self.model = robot.model
        self.data = robot.model.createData()
        inertia = np.diag(mass_matrix(robot, reference.q[0]))
        self.kp = gains.stiffness * inertia
        self.kd = gains.velocity_gain * inertia

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        r = self.reference
        k = r.index(t)
        return pd_gravity(self.model, self.data, q, qd, r.q[k], r.qd[k], self.kp, self.kd)


CONTROLLER_NAMES = ("orbital", "computed_torque", "pd_gravity")
