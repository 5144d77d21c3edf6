"""Realism switches of the closed-loop simulation (all off by default, all seeded).

* model mismatch: the plant's links have mass and rotational inertia scaled by (1 +- inertia_error),
  the sign drawn per link (or the same for all, ``inertia_sign``); an unmodelled payload is added at the flange. The controller keeps the
  nominal robot.
* joint friction: tau_f = F_v qd + F_c tanh(qd / v_c) (smooth Coulomb, so RK4 stays accurate).
* sensors: encoder quantization of q, Gaussian noise on q and qd.
* a delay of ``delay`` samples between measurement and torque.

Random draws use ``numpy.random.default_rng(seed)``: the same Realism gives the same run, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import SimulationError
from ..robot import Payload, Robot


#: Longest command delay the realism switch models [samples].
MAX_DELAY = 4


def _per_joint(name: str, value, n: int) -> np.ndarray:
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 else np.asarray(value, float)
    if arr.shape != (n,):
        raise SimulationError(f"Realism.{name} has {arr.size} values for a robot with {n} joints; give 1 or {n}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise SimulationError(f"Realism.{name} = {arr.tolist()}; values must be finite and >= 0")
    return arr.copy()


@dataclass(frozen=True)
class Realism:
    """What makes the plant differ from the controller's model. Units: inertia_error [-] (0.1 = 10 %),
    payload_mass [kg], payload_com (3,) [m] in the flange frame, payload_inertia (3,) [kg m^2]
    principal moments about its centre of mass (flange axes), viscous_friction [N m s/rad] and
    coulomb_friction [N m] (one value or one per joint), coulomb_smoothing [rad/s],
    encoder_resolution [rad] (0: none), position_noise [rad], velocity_noise [rad/s] (standard
    deviations), delay: the torque computed from sample k is applied during sample k + delay (True: 1);
    inertia_sign: +1 or -1 scales every link the same way, 0 draws the sign per link."""

    inertia_error: float = 0.0
    payload_mass: float = 0.0
    payload_com: tuple[float, float, float] = defaults.REALISTIC_PAYLOAD_COM
    payload_inertia: tuple[float, float, float] = defaults.REALISTIC_PAYLOAD_INERTIA
    viscous_friction: float | tuple[float, ...] = 0.0
    coulomb_friction: float | tuple[float, ...] = 0.0
    coulomb_smoothing: float = defaults.COULOMB_SMOOTHING_SPEED
    encoder_resolution: float = 0.0
    position_noise: float = 0.0
    velocity_noise: float = 0.0
    delay: int = 0
    seed: int = 0
    inertia_sign: int = 0

    def __post_init__(self):
        for name in ("inertia_error", "payload_mass", "encoder_resolution", "position_noise", "velocity_noise"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise SimulationError(f"Realism.{name} = {v!r}; it must be a finite number >= 0")
        if self.inertia_error >= 1:
            raise SimulationError(f"Realism.inertia_error = {self.inertia_error:g}; it must be < 1 (masses stay > 0)")
        if self.inertia_sign not in (-1, 0, 1):
            raise SimulationError(f"Realism.inertia_sign = {self.inertia_sign!r}; give -1, 0 (drawn per link) or 1")
        if not (int(self.delay) == self.delay and 0 <= int(self.delay) <= MAX_DELAY):
            raise SimulationError(f"Realism.delay = {self.delay!r}; give a whole number of samples 0..{MAX_DELAY}")
        from ..errors import RobotModelError
        from ..robot.model import Payload

        try:  # the unmodelled payload passes the planning payload's checks (finite products, lever)
            Payload(float(self.payload_mass), tuple(np.asarray(self.payload_com, float).tolist()))
        except (RobotModelError, ValueError, TypeError) as exc:
            raise SimulationError(f"Realism payload (simulate.realism.payload_*): {exc}") from None
        if not self.coulomb_smoothing > 0:
            raise SimulationError(f"Realism.coulomb_smoothing = {self.coulomb_smoothing!r}; it must be > 0 rad/s")

    @classmethod
    def realistic(cls, seed: int = 0, **changes) -> "Realism":
        """Every switch on with the figures of :mod:`pathmotion.defaults` (REALISTIC_*), 6 joints."""
        values = dict(
            inertia_error=defaults.REALISTIC_INERTIA_ERROR, payload_mass=defaults.REALISTIC_PAYLOAD_MASS,
            payload_com=defaults.REALISTIC_PAYLOAD_COM, payload_inertia=defaults.REALISTIC_PAYLOAD_INERTIA,
            viscous_friction=defaults.REALISTIC_VISCOUS_FRICTION,
            coulomb_friction=defaults.REALISTIC_COULOMB_FRICTION,
            encoder_resolution=defaults.REALISTIC_ENCODER_RESOLUTION,
            position_noise=defaults.REALISTIC_POSITION_NOISE, velocity_noise=defaults.REALISTIC_VELOCITY_NOISE,
            delay=True, seed=seed,
        )
        values.update(changes)
        return cls(**values)

    def link_scales(self, n: int) -> np.ndarray:
        """Mass/inertia factor of each of the n links, 1 +- inertia_error with seeded signs."""
        if self.inertia_sign:
            return np.full(n, 1.0 + self.inertia_error * self.inertia_sign)
        signs = np.random.default_rng([self.seed, 1]).choice([-1.0, 1.0], size=n)
        return 1.0 + self.inertia_error * signs

    def friction(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(viscous (n,), Coulomb (n,))."""
        return _per_joint("viscous_friction", self.viscous_friction, n), _per_joint("coulomb_friction",
                                                                                 self.coulomb_friction, n)


def plant_model(robot: Robot, realism: Realism) -> pin.Model:
    """The plant's Pinocchio model: links scaled by ``realism.link_scales``, payloads at the flange.

    Scaling uses the dynamic parameters (m, m c, I about the joint origin), which are linear in the
    link: scaling them scales mass and inertia at a fixed centre of mass. The payload (the robot's
    nominal one plus the unmodelled one) is not scaled.
    """
    if realism.payload_mass > 0:
        unmodelled = pin.Inertia(realism.payload_mass, np.asarray(realism.payload_com, float),
                                 np.diag(np.asarray(realism.payload_inertia, float)))
        nominal = robot.payload
        total = unmodelled + pin.Inertia(nominal.mass, np.asarray(nominal.com, float), np.asarray(nominal.inertia, float))
        plant_robot = robot.with_payload(Payload(mass=total.mass, com=tuple(total.lever),
                                                 inertia=tuple(map(tuple, total.inertia))))
    else:
        plant_robot = robot
    model = pin.Model(plant_robot.model)
    if realism.inertia_error > 0:
        bare = robot.with_payload(Payload()).model
        scales = realism.link_scales(model.njoints - 1)
        for j in range(1, model.njoints):
            link = bare.inertias[j].toDynamicParameters()
            full = model.inertias[j].toDynamicParameters()
            model.inertias[j] = pin.Inertia.FromDynamicParameters(full + (scales[j - 1] - 1.0) * link)
    return model


class Sensor:
    """Encoder quantization and noise (seeded). ``measure(q, qd) -> (q_m, qd_m)``."""

    def __init__(self, realism: Realism):
        self.resolution = realism.encoder_resolution
        self.position_noise = realism.position_noise
        self.velocity_noise = realism.velocity_noise
        self.rng = np.random.default_rng([realism.seed, 2])
        self.exact = self.resolution == 0 and self.position_noise == 0 and self.velocity_noise == 0

    def measure(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.exact:  # the caller's arrays: controllers read them, never write
            return q, qd
        q_m = np.round(q / self.resolution) * self.resolution if self.resolution > 0 else q.copy()
        if self.position_noise > 0:
            q_m = q_m + self.rng.normal(0.0, self.position_noise, q.shape)
        qd_m = qd + self.rng.normal(0.0, self.velocity_noise, qd.shape) if self.velocity_noise > 0 else qd.copy()
        return q_m, qd_m
