"""Online identification of the payload the controller's model lacks (a structured disturbance model).

A payload rigidly fixed to the flange body changes the joint torques linearly in that body's ten inertial
parameters pi = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz) (Pinocchio's dynamic parameters,
in the body's joint frame, I about the joint frame's origin):

    tau_true(q, qd, a) = RNEA_nom(q, qd, a) + Y(q, qd, a) d_pi,     Y = the flange body's 10 columns of
                                                                        pin.computeJointTorqueRegressor

d_pi is what the model lacks: an unknown payload (d_pi > 0) or one the model believes in but the arm does not
carry (m < 0: a phantom). Each sample the controller has the residual of the disturbance observer,

    r_k = tau_applied - RNEA_nom(q_mid, qd_mid, a_k),    a_k = (qd_k - qd_k-1) / Ts,   (q, qd)_mid the sample's middle

(tau_applied the command ``delay`` samples old, saturated), and r_k = Y_k d_pi + e_k: a linear regression. The
estimator is a Kalman filter on d_pi:

* prior d_pi ~ N(0, P0), P0 = diag(m0^2, (m0 l)^2 (x3), (m0 l^2)^2 (x6)): m0 the robot's rated payload, l a lever
  of the flange's scale (:func:`prior_scales`);
* d_pi is a stationary Gauss-Markov process with correlation time T (``payload_memory``): per sample
  d_pi <- rho d_pi, P <- rho^2 P + (1 - rho^2) P0, rho = exp(-Ts / T). This is the forgetting: the information
  decays with time constant T/2, and directions the motion never excites (at rest, everything but the gravity
  terms) relax to the prior instead of growing without bound as with exponential forgetting;
* the measurement noise is an acceleration error: e = M(q) w, w ~ N(0, sigma^2 I), sigma = ``payload_noise``
  [rad/s^2]. It stands for the speed noise differenced over a sample and for what no payload explains (link
  inertia errors, friction): the regression is weighted as the joint acceleration error it leaves, M^-1 r = M^-1 Y
  d_pi + w, and the update is n scalar Kalman updates on the rows of M^-1 (Y, r).

The regression does not depend on the estimate: r_k - Y_k d_pi is measured, whatever the controller commanded. So
the estimate converges (to noise) on its own, and the loop sees a model error that shrinks over time; there is
no loop through the estimate to destabilize (docs/control.md, "Payload identification").
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import SimulationError

#: Number of inertial parameters of one rigid body (Pinocchio's dynamic parameters).
BODY_PARAMETERS = 10


def prior_scales(mass: float, lever: float) -> np.ndarray:
    """Prior standard deviations (10,) of d_pi for a payload of ``mass`` [kg] at a ``lever`` [m] from the
    flange body's frame: (m, m c (3), I about the origin (6)) -> (mass, mass lever, mass lever^2)."""
    return np.array([mass] + [mass * lever] * 3 + [mass * lever**2] * 6, float)


def prior_mass(robot) -> float:
    """Prior mass scale [kg] of the payload the model may lack: the rated payload of a built-in robot
    (``defaults.RATED_PAYLOAD``), else ``defaults.PAYLOAD_MASS_FRACTION`` of the arm's own link mass."""
    rated = defaults.RATED_PAYLOAD.get(robot.name.lower())
    if rated is not None:
        return float(rated)
    model = robot.model
    return defaults.PAYLOAD_MASS_FRACTION * float(sum(model.inertias[i].mass for i in range(1, model.njoints)))


def friction_scales(robot) -> np.ndarray:
    """Prior standard deviations (2n,) of the joints' viscous [N m s/rad] and Coulomb [N m] friction:
    ``defaults.FRICTION_PRIOR_FRACTION`` of each torque limit, the viscous one reaching it at the velocity limit."""
    coulomb = defaults.FRICTION_PRIOR_FRACTION * np.asarray(robot.limits.torque, float)
    return np.concatenate([coulomb / np.asarray(robot.limits.velocity, float), coulomb])


@numba.njit(cache=True)
def kalman_step(estimate, covariance, prior, rho, mass_matrix, regressor, residual, noise2):
    """One sample of the payload filter, in place: the Gauss-Markov prediction (estimate (p,) *= rho, covariance
    (p, p) <- rho^2 covariance + (1 - rho^2) diag(prior (p,))), then the measurement residual (n,) = regressor
    (n, p) estimate + mass_matrix (n, n) w, w ~ N(0, noise2 I), whitened by the mass matrix (M^-1 e = w) and taken
    in as n scalar updates."""
    p = estimate.shape[0]
    n = residual.shape[0]
    decay = rho * rho
    for i in range(p):
        estimate[i] *= rho
        for j in range(p):
            covariance[i, j] *= decay
        covariance[i, i] += (1.0 - decay) * prior[i]
    rows = np.linalg.solve(mass_matrix, regressor)  # M^-1 Y: the noise M w becomes w
    values = np.linalg.solve(mass_matrix, residual)
    ph = np.empty(p)
    for k in range(n):
        h = rows[k]
        for i in range(p):
            acc = 0.0
            for j in range(p):
                acc += covariance[i, j] * h[j]
            ph[i] = acc
        s = noise2
        innovation = values[k]
        for i in range(p):
            s += h[i] * ph[i]
            innovation -= h[i] * estimate[i]
        for i in range(p):
            estimate[i] += ph[i] * innovation / s
        for i in range(p):
            for j in range(p):
                covariance[i, j] -= ph[i] * ph[j] / s


class PayloadEstimator:
    """Running estimate ``estimate`` (10 + 2n,) of d_pi, the flange body's inertial parameters the nominal ``model``
    lacks, and of each joint's viscous [N m s/rad] and Coulomb [N m] friction (module docstring). ``joint``: index
    of the joint whose body carries the flange; ``sample_time`` [s]; ``prior`` (10 + 2n,) standard deviations;
    ``memory`` T [s]; ``noise`` sigma [rad/s^2]; ``smoothing`` v_s [rad/s] of the Coulomb term tanh(qd / v_s)."""

    def __init__(self, model: pin.Model, joint: int, sample_time: float, prior: np.ndarray, memory: float,
                 noise: float, smoothing: float = defaults.COULOMB_SMOOTHING_SPEED):
        if not 1 <= joint < model.njoints:
            raise SimulationError(f"payload identification: joint index {joint} is not a joint of the model "
                                  f"(1..{model.njoints - 1})")
        n = model.nv
        if np.shape(prior) != (BODY_PARAMETERS + 2 * n,):
            raise SimulationError(f"payload identification: {np.shape(prior)} prior scales; give "
                                  f"{BODY_PARAMETERS + 2 * n} (10 inertial parameters, then viscous and Coulomb "
                                  "friction per joint)")
        self.model, self.data = model, model.createData()
        self.columns = slice(BODY_PARAMETERS * (joint - 1), BODY_PARAMETERS * joint)
        self.prior = np.asarray(prior, float) ** 2
        self.rho = math.exp(-sample_time / memory) if math.isfinite(memory) else 1.0
        self.noise2 = float(noise) ** 2
        self.smoothing = float(smoothing)
        self.estimate = np.zeros(len(prior))
        self.covariance = np.diag(self.prior)
        self._rows = np.zeros((n, len(prior)))

    @classmethod
    def for_robot(cls, robot, sample_time: float, memory: float, noise: float) -> "PayloadEstimator":
        """The estimator of the payload at ``robot``'s flange and of its joints' friction: prior from
        :func:`prior_mass`, ``defaults.PAYLOAD_LEVER`` and :func:`friction_scales`."""
        model = robot.model
        joint = model.frames[model.getFrameId(robot.flange_frame)].parentJoint
        prior = np.concatenate([prior_scales(prior_mass(robot), defaults.PAYLOAD_LEVER), friction_scales(robot)])
        return cls(model, joint, sample_time, prior, memory, noise)

    def regressor(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> np.ndarray:
        """(n, 10 + 2n): d tau / d (pi, F_v, F_c) at (q, qd, a) [rad, rad/s, rad/s^2]: the flange body's columns of
        Pinocchio's joint torque regressor (gravity included), diag(qd), diag(tanh(qd / v_s))."""
        n = len(q)
        rows = self._rows
        rows[:, :BODY_PARAMETERS] = pin.computeJointTorqueRegressor(self.model, self.data, q, qd, a)[:, self.columns]
        idx = np.arange(n)
        rows[idx, BODY_PARAMETERS + idx] = qd
        rows[idx, BODY_PARAMETERS + n + idx] = np.tanh(qd / self.smoothing)
        return rows

    def torque(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The estimated payload's and friction's torque Y(q, qd, a) estimate (n,) [N m]."""
        return self.regressor(q, qd, a) @ self.estimate

    def update(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """Take in one sample's ``residual`` (n,) [N m] = tau_applied - RNEA_nom(q, qd, a) at the sample's middle;
        returns the part the updated estimate does not explain, residual - Y estimate (n,)."""
        y = self.regressor(q, qd, a)
        mass = pin.crba(self.model, self.data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        kalman_step(self.estimate, self.covariance, self.prior, self.rho, mass, y,
                    np.ascontiguousarray(residual), self.noise2)
        return residual - y @ self.estimate

    @property
    def mass(self) -> float:
        """The estimated payload mass [kg] (negative: the model carries a payload the arm lacks)."""
        return float(self.estimate[0])
