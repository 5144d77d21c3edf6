"""Online identification of the payload and the joint friction the controller's model lacks (a structured
disturbance model; docs/control.md, "Payload and friction identification").

A payload rigidly fixed to the flange body changes the joint torques linearly in that body's inertial parameters
(Pinocchio's dynamic parameters in the body's joint frame: m, m c, I about the frame's origin). The estimator
takes the mass and the first moment, pi = (m, m c_x, m c_y, m c_z) (a point mass: its gravity and its
translational inertia), and each joint's viscous and Coulomb friction (F_v, F_c):

    tau_true(q, qd, a) = RNEA_nom(q, qd, a) + Y(q, qd, a) theta + (what is left: link inertia errors, the payload's
                         rotational inertia, noise),
    Y = [first 4 columns of the flange body in pin.computeJointTorqueRegressor | diag(qd) | diag(tanh(qd / v_s))],
    theta = (d_pi (4), F_v (n), F_c (n)).

d_pi is what the model lacks: an unknown payload (m > 0) or one the model believes in but the arm does not carry
(m < 0: a phantom). Each sample the controller has the residual of the disturbance observer,

    r_k = tau_applied - RNEA_nom(q_mid, qd_mid, a_k),   a_k = (qd_k - qd_k-1) / Ts,   (q, qd)_mid the sample's middle

(tau_applied the command ``delay`` samples old, saturated), and r_k = Y_k theta + e_k: a linear regression,
solved by a Kalman filter:

* prior theta ~ N(0, P0): standard deviations m0, m0 l (x3) for the payload (m0 the robot's rated payload, l a lever
  of the flange's scale; :func:`prior_scales`) and a fraction of each torque limit for the friction
  (:func:`friction_scales`);
* theta is a stationary Gauss-Markov process with correlation time T (``payload_memory``): per sample theta <- rho
  theta, P <- rho^2 P + (1 - rho^2) P0, rho = exp(-Ts / T). This is the forgetting: what the motion stops exciting
  relaxes to the prior (bounded) instead of growing without bound as with exponential forgetting;
* the noise is an acceleration error, e = M(q) w, w ~ N(0, sigma^2 I), sigma^2 = sigma_m^2 + 2 sigma_v^2 / Ts^2:
  what the model misses (``payload_noise`` sigma_m [rad/s^2]) and the measured speed's noise differenced over a
  sample (``payload_speed_noise`` sigma_v [rad/s]); the regression is weighted as the joint acceleration error it
  leaves (M^-1 r = M^-1 Y theta + w), taken in as n scalar updates;
* bounds after each update (physics): the flange body's mass stays >= 0 (a phantom cannot remove more than the
  model has there), friction >= 0 (it dissipates).

The regression does not involve the estimate: r_k is measured whatever the controller commanded, so the estimate
converges on its own (no loop through it). The payload's rotational inertia is left to the observer on purpose: it
enters the wrist's small inertia directly (0.1 kg m^2 on the IRB140's sixth axis), it is the part the finite-
difference accelerations and a light joint's friction corrupt most, and an error of it is the most harmful (with it
estimated, a friction-only plant drove the sixth axis' model inertia negative within 0.1 s).
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import SimulationError

#: Payload parameters estimated: m and m c (Pinocchio's dynamic parameters 0..3 of the flange body).
PAYLOAD_PARAMETERS = 4
#: Dynamic parameters of one rigid body in Pinocchio's joint torque regressor.
BODY_PARAMETERS = 10


def prior_scales(mass: float, lever: float) -> np.ndarray:
    """Prior standard deviations (4,) of d_pi = (m, m c) for a payload of ``mass`` [kg] at a ``lever`` [m] from the
    flange body's frame: (mass, mass lever (x3))."""
    return np.array([mass] + [mass * lever] * 3, float)


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
def _spd_solve(a, b):
    """a^-1 b for a symmetric positive definite a (n, n) and b (n, k), by Cholesky (small n: plain loops, no
    LAPACK call)."""
    n, k = b.shape
    low = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            acc = a[i, j]
            for m in range(j):
                acc -= low[i, m] * low[j, m]
            low[i, j] = math.sqrt(acc) if i == j else acc / low[j, j]
    x = np.empty((n, k))
    for c in range(k):
        for i in range(n):  # L z = b
            acc = b[i, c]
            for m in range(i):
                acc -= low[i, m] * x[m, c]
            x[i, c] = acc / low[i, i]
        for i in range(n - 1, -1, -1):  # L^T x = z
            acc = x[i, c]
            for m in range(i + 1, n):
                acc -= low[m, i] * x[m, c]
            x[i, c] = acc / low[i, i]
    return x


@numba.njit(cache=True)
def kalman_step(estimate, covariance, prior, rho, mass_matrix, regressor, residual, noise2, low, high):
    """One sample of the filter, in place: the Gauss-Markov prediction (estimate (p,) *= rho, covariance (p, p) <-
    rho^2 covariance + (1 - rho^2) diag(prior (p,))), then the measurement residual (n,) = regressor (n, p)
    estimate + M w, w ~ N(0, noise2 I) (M = mass_matrix (n, n)), whitened (M^-1) and taken in as n scalar updates;
    the estimate is then clipped to [low, high] (p,)."""
    p = estimate.shape[0]
    n = residual.shape[0]
    decay = rho * rho
    for i in range(p):
        estimate[i] *= rho
        for j in range(p):
            covariance[i, j] *= decay
        covariance[i, i] += (1.0 - decay) * prior[i]
    rows = _spd_solve(mass_matrix, regressor)  # M^-1 Y: the noise M w becomes w
    values = _spd_solve(mass_matrix, residual.reshape(n, 1))[:, 0]
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
    for i in range(p):
        estimate[i] = min(max(estimate[i], low[i]), high[i])


@numba.njit(cache=True)
def identify_sample(estimate, covariance, prior, rho, mass_upper, body, qd, residual, noise2, low, high, smoothing,
                    remainder):
    """One sample of :class:`PayloadEstimator` compiled: Y = [body (n, 4) | diag(qd) | diag(tanh(qd / smoothing))],
    M from the upper triangle of ``mass_upper`` (n, n) (Pinocchio's crba fills only that), :func:`kalman_step`, then
    ``remainder`` (n,) = residual - body estimate[:4] (the residual the payload does not explain)."""
    n = qd.shape[0]
    p = estimate.shape[0]
    y = np.zeros((n, p))
    mass = np.empty((n, n))
    for i in range(n):
        for k in range(body.shape[1]):
            y[i, k] = body[i, k]
        y[i, body.shape[1] + i] = qd[i]
        y[i, body.shape[1] + n + i] = math.tanh(qd[i] / smoothing)
        for j in range(n):
            mass[i, j] = mass_upper[i, j] if j >= i else mass_upper[j, i]
    kalman_step(estimate, covariance, prior, rho, mass, y, residual, noise2, low, high)
    for i in range(n):
        acc = residual[i]
        for k in range(body.shape[1]):
            acc -= body[i, k] * estimate[k]
        remainder[i] = acc


@numba.njit(cache=True)
def feedforward(body, estimate, qd, smoothing, out, friction):
    """``friction`` (n,) = F_v qd + F_c tanh(qd / smoothing), the estimated friction at the joint velocity qd (n,);
    ``out`` (n,) += body (n, 4) estimate[:4] (the estimated payload's torque) + friction."""
    n = qd.shape[0]
    m = body.shape[1]
    for i in range(n):
        friction[i] = estimate[m + i] * qd[i] + estimate[m + n + i] * math.tanh(qd[i] / smoothing)
        acc = friction[i]
        for k in range(m):
            acc += body[i, k] * estimate[k]
        out[i] += acc


class PayloadEstimator:
    """Running estimate ``estimate`` (4 + 2n,) of theta = (d_pi = (m, m c) of the payload the nominal ``model`` lacks
    at the flange body, F_v (n,) [N m s/rad], F_c (n,) [N m]) (module docstring). ``joint``: index of the joint whose
    body carries the flange; ``sample_time`` Ts [s]; ``prior`` (4 + 2n,) standard deviations; ``memory`` T [s];
    ``noise`` sigma_m [rad/s^2] and ``speed_noise`` sigma_v [rad/s]: the acceleration error is sigma^2 = sigma_m^2 +
    2 sigma_v^2 / Ts^2 (the model's error and the measured speed differenced over a sample); ``smoothing`` v_s
    [rad/s] of the Coulomb term tanh(qd / v_s)."""

    def __init__(self, model: pin.Model, joint: int, sample_time: float, prior: np.ndarray, memory: float,
                 noise: float, speed_noise: float = 0.0, smoothing: float = defaults.COULOMB_SMOOTHING_SPEED):
        n = model.nv
        if not 1 <= joint < model.njoints:
            raise SimulationError(f"payload identification: joint index {joint} is not a joint of the model "
                                  f"(1..{model.njoints - 1})")
        if np.shape(prior) != (PAYLOAD_PARAMETERS + 2 * n,):
            raise SimulationError(f"payload identification: {np.shape(prior)} prior scales; give "
                                  f"{PAYLOAD_PARAMETERS + 2 * n} (m, m c, then viscous and Coulomb friction per joint)")
        self.model, self.data = model, model.createData()
        self.n = n
        start = BODY_PARAMETERS * (joint - 1)
        self.columns = slice(start, start + PAYLOAD_PARAMETERS)
        self.prior = np.asarray(prior, float) ** 2
        self.rho = math.exp(-sample_time / memory) if math.isfinite(memory) else 1.0
        self.noise2 = float(noise) ** 2 + 2.0 * (float(speed_noise) / sample_time) ** 2
        self.smoothing = float(smoothing)
        self.estimate = np.zeros(len(prior))
        self.covariance = np.diag(self.prior)
        self.low = np.full(len(prior), -np.inf)
        self.high = np.full(len(prior), np.inf)
        self.low[0] = -model.inertias[joint].mass  # the flange body keeps a mass >= 0
        self.low[PAYLOAD_PARAMETERS:] = 0.0  # friction dissipates
        self.frame = pin.SE3.Identity()  # where :meth:`identified` states the centre of mass, in the joint frame

    @classmethod
    def for_robot(cls, robot, sample_time: float, memory: float, noise: float,
                  speed_noise: float) -> "PayloadEstimator":
        """The estimator of the payload at ``robot``'s flange and of its joints' friction: prior from
        :func:`prior_mass`, ``defaults.PAYLOAD_LEVER`` and :func:`friction_scales`."""
        model = robot.model
        joint = model.frames[model.getFrameId(robot.flange_frame)].parentJoint
        prior = np.concatenate([prior_scales(prior_mass(robot), defaults.PAYLOAD_LEVER), friction_scales(robot)])
        estimator = cls(model, joint, sample_time, prior, memory, noise, speed_noise)
        estimator.frame = model.frames[model.getFrameId(robot.flange_frame)].placement
        return estimator

    def payload_regressor(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> np.ndarray:
        """(n, 4): d tau / d (m, m c) of the flange body at (q, qd, a) [rad, rad/s, rad/s^2], gravity included."""
        return pin.computeJointTorqueRegressor(self.model, self.data, q, qd, a)[:, self.columns]

    def payload_torque(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The estimated payload's torque Y_pi(q, qd, a) d_pi_hat (n,) [N m] (gravity included)."""
        return self.payload_regressor(q, qd, a) @ self.estimate[:PAYLOAD_PARAMETERS]

    def friction_torque(self, qd: np.ndarray) -> np.ndarray:
        """The estimated friction F_v qd + F_c tanh(qd / v_s) (n,) [N m] at the joint velocity qd (n,) [rad/s]."""
        p, n = PAYLOAD_PARAMETERS, self.n
        return self.estimate[p:p + n] * qd + self.estimate[p + n:] * np.tanh(qd / self.smoothing)

    def update(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """Take in one sample's ``residual`` (n,) [N m] = tau_applied - RNEA_nom(q, qd, a) at the sample's middle;
        returns what the updated payload estimate does not explain, residual - Y_pi d_pi_hat (n,) (the friction
        stays in it: the controller compensates the friction at the PLANNED velocity and tells the observer so)."""
        body = self.payload_regressor(q, qd, a)
        mass = pin.crba(self.model, self.data, q)
        remainder = np.empty(self.n)
        identify_sample(self.estimate, self.covariance, self.prior, self.rho, mass, body, qd, residual, self.noise2,
                        self.low, self.high, self.smoothing, remainder)
        return remainder

    def torque(self, q: np.ndarray, qd: np.ndarray, a: np.ndarray, qd_friction: np.ndarray,
               out: np.ndarray) -> np.ndarray:
        """``out`` (n,) += :meth:`payload_torque` (q, qd, a) + :meth:`friction_torque` (qd_friction) [N m]; returns
        the friction part (n,)."""
        friction = np.empty(self.n)
        feedforward(self.payload_regressor(q, qd, a), self.estimate, qd_friction, self.smoothing, out, friction)
        return friction

    def identified(self) -> dict:
        """What the run identified, for the summary (SI units): the payload's mass [kg] (negative: a phantom) and
        its standard error [kg] (the filter's), whether the mass is significant (at least
        ``defaults.IDENTIFIED_SIGNIFICANCE`` standard errors from 0 and ``defaults.IDENTIFIED_MASS_FLOOR``), its
        centre of mass [m] in ``frame`` (the flange frame for :meth:`for_robot`, else the flange body's joint frame;
        None unless the mass is significant: m c / m would be noise), and each joint's viscous [N m s/rad] and
        Coulomb [N m] friction."""
        p, n, m = PAYLOAD_PARAMETERS, self.n, self.mass
        std = float(np.sqrt(max(self.covariance[0, 0], 0.0)))
        significant = abs(m) >= max(defaults.IDENTIFIED_SIGNIFICANCE * std, defaults.IDENTIFIED_MASS_FLOOR)
        com = self.frame.actInv(self.estimate[1:p] / m).tolist() if significant else None
        return {"mass_kg": m, "mass_std_kg": std, "significant": bool(significant), "com_m": com,
                "viscous_friction": self.estimate[p:p + n].tolist(), "coulomb_friction": self.estimate[p + n:].tolist()}

    @property
    def mass(self) -> float:
        """The estimated payload mass [kg] (negative: the model carries a payload the arm lacks)."""
        return float(self.estimate[0])
