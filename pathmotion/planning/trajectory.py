"""A time-parameterized motion along a joint path: theta(t), q(t), qd(t), qdd(t), tau(t)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import defaults
from ..errors import PathmotionError
from ..lift.joint_path import JointPath
from ..robot import Robot, rnea
from .fast_rnea import rnea_batch, supported
from .reduced import torque_derivative
from .profile import Profile


@dataclass(frozen=True)
class Samples:
    """Trajectory samples: t (N,) [s]; theta, theta_dot, theta_ddot (N,); q, qd, qdd, tau (N, n);
    theta_dddot (N,), qddd (N, n) [rad/s^3] and tau_dot (N, n) [N m/s] when asked for (else None)."""

    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray | None
    theta_dddot: np.ndarray | None = None
    qddd: np.ndarray | None = None
    tau_dot: np.ndarray | None = None


def motion_samples(path: JointPath, robot: Robot | None, t, theta, theta_dot, theta_ddot) -> Samples:
    """Samples (no third-order terms) of the motion theta, theta_dot, theta_ddot (N,) along ``path`` at times t
    (N,) [s]: q = Phi, qd = Phi' theta_dot, qdd = Phi' theta_ddot + Phi'' theta_dot^2, tau by inverse dynamics
    (None without a robot)."""
    theta, theta_dot, theta_ddot = (np.asarray(v, dtype=float) for v in (theta, theta_dot, theta_ddot))
    q, dq, ddq = path.evaluate(theta)
    qd = dq * theta_dot[:, None]
    qdd = dq * theta_ddot[:, None] + ddq * (theta_dot**2)[:, None]
    tau = None if robot is None else (rnea_batch if supported(robot) else rnea)(robot, q, qd, qdd)
    return Samples(np.asarray(t, dtype=float), theta, theta_dot, theta_ddot, q, qd, qdd, tau)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Path + profile (+ robot for torques). Sample it at any rate with :meth:`sample`."""

    path: JointPath
    profile: Profile
    robot: Robot | None = None

    @property
    def duration(self) -> float:
        return self.profile.duration

    def at_time(self, t, third: bool = False, torque_rate: bool = False) -> Samples:
        """Samples at the given times [s] (clipped to [0, duration]); ``third``: also theta_dddot
        and the joint jerk qddd = Phi' theta_dddot + 3 Phi'' theta_dot theta_ddot + Phi''' theta_dot^3
        (exact Phi'''); ``torque_rate``: also tau_dot = dtau/dq qd + dtau/dqd qdd + M qddd."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        theta, theta_dot, theta_ddot, theta_dddot = self.profile.state3_at_time(t)
        third = third or torque_rate
        if not third:
            theta_ddot = np.broadcast_to(theta_ddot, t.shape).copy()
            return motion_samples(self.path, self.robot, t, theta, theta_dot, theta_ddot)
        q, dq, ddq, dddq = self.path.evaluate3(theta)
        qd = dq * theta_dot[:, None]
        qdd = dq * theta_ddot[:, None] + ddq * (theta_dot**2)[:, None]
        tau = None if self.robot is None else (rnea_batch if supported(self.robot) else rnea)(self.robot, q, qd, qdd)
        qddd = (dq * theta_dddot[:, None] + 3.0 * ddq * (theta_dot * theta_ddot)[:, None]
                + dddq * (theta_dot**3)[:, None])
        tau_dot = torque_derivative(self.robot, q, qd, qdd, qddd) if torque_rate and self.robot is not None else None
        return Samples(t, theta, theta_dot, np.broadcast_to(theta_ddot, t.shape).copy(), q, qd, qdd, tau,
                       theta_dddot, qddd, tau_dot)

    def sample(self, dt: float = defaults.SAMPLE_TIME) -> Samples:
        """Samples every ``dt`` seconds from 0, the last one at exactly the duration."""
        return self.at_time(sample_times(self.duration, dt))


#: Round-off allowance when counting whole sample steps in a duration [steps], and the gap below
#: which the last step already ends at the duration [s].
STEP_ROUNDING = 1e-9
END_GAP = 1e-12


def sample_times(duration: float, dt: float, max_samples: int = defaults.MAX_TRAJECTORY_SAMPLES) -> np.ndarray:
    """Times (N,) [s] every ``dt`` from 0, the last at exactly ``duration`` [s]; a PathmotionError when
    ``dt`` is not > 0 or N would exceed ``max_samples`` (a motion far too long for that sample time)."""
    if not dt > 0 or not np.isfinite(dt):
        raise PathmotionError(f"sample time must be a finite number > 0 s, got {dt}")
    if not (np.isfinite(duration) and duration >= 0):
        raise PathmotionError(f"the motion's duration is {duration} s; it must be finite and >= 0")
    count = duration / dt + 1
    if count > max_samples:
        raise PathmotionError(
            f"sampling the {duration:.6g} s motion every {dt:g} s needs {count:.3g} samples, more than "
            f"{max_samples:,} (defaults.MAX_TRAJECTORY_SAMPLES): raise the sample time, or check the limits "
            "(a motion this long usually means a limit or a scale such as tcp_speed is far too small)")
    n = int(np.floor(duration / dt + STEP_ROUNDING))
    t = np.arange(n + 1) * dt
    if t[-1] < duration - END_GAP:
        t = np.append(t, duration)
    return t
