"""Controller gains: value objects with their defaults in :mod:`pathmotion.defaults`."""

from __future__ import annotations

from dataclasses import dataclass
import math

from .. import defaults
from ..errors import SimulationError


def _check_positive(owner: str, **values) -> None:
    for name, value in values.items():
        if not (isinstance(value, (int, float)) and value > 0):
            raise SimulationError(f"{owner}.{name} = {value!r}; it must be a number > 0")


def _check_products(owner: str, **products) -> None:
    """The derived gains (weights, stiffness) must be finite: a bandwidth of 1e100 overflows w^4."""
    for name, value in products.items():
        if not all(math.isfinite(v) for v in value):
            raise SimulationError(f"{owner}: the derived {name} overflow ({value}); give a bandwidth of at most "
                                  f"{defaults.MAX_GAIN:g} rad/s and moderate rates")


class _no_overflow_error:
    """Python floats raise OverflowError on ** overflow; report it as the non-finite gain it is."""

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is OverflowError:
            raise SimulationError(f"controller gains overflow ({exc}); give a bandwidth of at most "
                                  f"{defaults.MAX_GAIN:g} rad/s and moderate rates") from None
        return False


class _SecondOrder:
    """Gains of e'' + 2 zeta w e' + w^2 e = 0 from ``bandwidth`` w [rad/s] and ``damping`` zeta [-]."""

    @property
    def stiffness(self) -> float:
        """w^2 [1/s^2]."""
        return self.bandwidth**2

    @property
    def velocity_gain(self) -> float:
        """2 zeta w [1/s]."""
        return 2.0 * self.damping * self.bandwidth


@dataclass(frozen=True)
class OrbitalGains(_SecondOrder):
    """Weights of the orbital controller's LQR (docs/control.md).

    bandwidth [rad/s] and damping [-]: the transverse position error z is weighted so that a
    decoupled double integrator would close with natural frequency ``bandwidth`` and damping
    ``damping`` (Q_z = w^4, Q_zdot = 2 w^2 (2 zeta^2 - 1), R = 1); damping >= 1/sqrt(2).
    speed_rate [1/s]: rate at which I = theta_dot^2 - x* is driven to zero, expressed through the
    joint speed error along the path; min_speed [rad/s]: planned joint speed |Phi'| theta_dot* below
    which that weight stops growing and (open paths) the plan is played on the clock, as near stops;
    terminal_time_to_go [s]: open paths, how much longer (planned time) the clock play lasts on each
    side of such a slow stretch; at the end of the path the final configuration is then held.
    observer_range [-]: the disturbance observer's gain is the largest with which the sampled, delayed loop stays
    stable for every plant inertia between 1/observer_range and observer_range times the model's
    (:func:`.observer.observer_gain`; inf: no observer).
    payload_memory [s], payload_noise [rad/s^2], payload_speed_noise [rad/s]: the online payload identification's
    correlation time (its forgetting), the model error and the speed noise a sample's residual is weighted with
    (:mod:`.payload`; on with ``[simulate] identify_payload``).
    integral_rate [rad/s]: integral action on z (0: none). The transverse state is augmented with
    xi = int z dt and weighted so that a decoupled triple integrator closes with the poles
    (s + integral_rate)(s^2 + 2 zeta w s + w^2): a constant unmodelled torque (payload gravity)
    leaves no steady transverse error. The clock play near stops uses the same poles on the joint error.
    """

    bandwidth: float = defaults.ORBITAL_BANDWIDTH
    damping: float = defaults.ORBITAL_DAMPING
    speed_rate: float = defaults.ORBITAL_SPEED_RATE
    min_speed: float = defaults.ORBITAL_MIN_SPEED
    terminal_time_to_go: float = defaults.TERMINAL_TIME_TO_GO
    integral_rate: float = defaults.ORBITAL_INTEGRAL_RATE
    observer_range: float = defaults.ORBITAL_OBSERVER_RANGE
    payload_memory: float = defaults.PAYLOAD_MEMORY
    payload_noise: float = defaults.PAYLOAD_NOISE
    payload_speed_noise: float = defaults.PAYLOAD_SPEED_NOISE

    def __post_init__(self):
        _check_positive("OrbitalGains", bandwidth=self.bandwidth, damping=self.damping,
                        speed_rate=self.speed_rate, min_speed=self.min_speed, payload_memory=self.payload_memory,
                        payload_noise=self.payload_noise, payload_speed_noise=self.payload_speed_noise)
        if self.damping < 2**-0.5:
            raise SimulationError(f"OrbitalGains.damping = {self.damping:g}; the LQR form needs damping >= 0.7072")
        if not (isinstance(self.integral_rate, (int, float)) and self.integral_rate >= 0):
            raise SimulationError(f"OrbitalGains.integral_rate = {self.integral_rate!r}; give a rate >= 0 rad/s (0: off)")
        if not (isinstance(self.observer_range, (int, float)) and self.observer_range >= 1):
            raise SimulationError(f"OrbitalGains.observer_range = {self.observer_range!r}; give a factor >= 1 on the "
                                  "plant's inertia (inf: no disturbance observer)")
        if not self.terminal_time_to_go >= 0:
            raise SimulationError(f"OrbitalGains.terminal_time_to_go = {self.terminal_time_to_go!r}; give a time >= 0 s")
        with _no_overflow_error():
            _check_products("OrbitalGains", chain_weights=self.chain_weights, clock_gains=self.clock_gains)

    @property
    def chain_weights(self) -> tuple[float, float, float]:
        """LQR weights (q_xi, q_z, q_zdot) with R = 1 that close a triple integrator with the poles
        (s + w_i)(s^2 + 2 zeta w s + w^2) (w_i = integral_rate; for w_i = 0 the double integrator's
        (w^4, 2 w^2 (2 zeta^2 - 1)) and q_xi = 0). From the return-difference identity
        Delta(s) Delta(-s) = -s^6 + q_zdot s^4 - q_z s^2 + q_xi."""
        w, wi, c = self.bandwidth, self.integral_rate, 2.0 * self.damping**2 - 1.0
        return wi**2 * w**4, w**4 + 2.0 * wi**2 * w**2 * c, wi**2 + 2.0 * w**2 * c

    @property
    def clock_gains(self) -> tuple[float, float, float]:
        """(kp [1/s^2], kd [1/s], ki [1/s^3]) of the clock play: v = a_ref - kd e' - kp e - ki int e, the
        characteristic polynomial (s + w_i)(s^2 + 2 zeta w s + w^2) of the orbital law's z-chain."""
        w, wi, zeta = self.bandwidth, self.integral_rate, self.damping
        return w * w + 2.0 * zeta * w * wi, wi + 2.0 * zeta * w, wi * w * w


@dataclass(frozen=True)
class TrackingGains(_SecondOrder):
    """Joint-space error dynamics e'' + 2 zeta w e' + w^2 e = 0: natural frequency ``bandwidth``
    [rad/s] and ``damping`` [-]. Used by the computed-torque baseline (gains per unit inertia) and the
    PD + gravity baseline (gains scaled per joint by the diagonal of M at the start configuration)."""

    bandwidth: float = defaults.COMPUTED_TORQUE_BANDWIDTH
    damping: float = defaults.COMPUTED_TORQUE_DAMPING

    def __post_init__(self):
        _check_positive("TrackingGains", bandwidth=self.bandwidth, damping=self.damping)
        with _no_overflow_error():
            _check_products("TrackingGains", gains=(self.stiffness, self.velocity_gain))



def default_pd_gains() -> TrackingGains:
    """Gains of the PD + gravity baseline from :mod:`pathmotion.defaults`."""
    return TrackingGains(bandwidth=defaults.PD_BANDWIDTH, damping=defaults.PD_DAMPING)
