"""Controller gains: value objects with their defaults in :mod:`pathmotion.defaults`."""

from __future__ import annotations

from dataclasses import dataclass

from .. import defaults
from ..errors import SimulationError


def _check_positive(owner: str, **values) -> None:
    for name, value in values.items():
        if not (isinstance(value, (int, float)) and value > 0):
            raise SimulationError(f"{owner}.{name} = {value!r}; it must be a number > 0")


@dataclass(frozen=True)
class OrbitalGains:
    """Weights of the orbital controller's LQR (docs/control.md).

    bandwidth [rad/s] and damping [-]: the transverse position error z is weighted so that a
    decoupled double integrator would close with natural frequency ``bandwidth`` and damping
    ``damping`` (Q_z = w^4, Q_zdot = 2 w^2 (2 zeta^2 - 1), R = 1); damping >= 1/sqrt(2).
    speed_rate [1/s]: rate at which I = theta_dot^2 - x* is driven to zero, expressed through the
    joint speed error along the path; min_speed [rad/s]: planned joint speed |Phi'| theta_dot* below
    which that weight stops growing and (open paths) the plan is played on the clock, as near stops;
    terminal_time_to_go [s]: open paths, how much longer (planned time) the clock play lasts on each
    side of such a slow stretch; at the end of the path the final configuration is then held.
    """

    bandwidth: float = defaults.ORBITAL_BANDWIDTH
    damping: float = defaults.ORBITAL_DAMPING
    speed_rate: float = defaults.ORBITAL_SPEED_RATE
    min_speed: float = defaults.ORBITAL_MIN_SPEED
    terminal_time_to_go: float = defaults.TERMINAL_TIME_TO_GO

    def __post_init__(self):
        _check_positive("OrbitalGains", bandwidth=self.bandwidth, damping=self.damping,
                        speed_rate=self.speed_rate, min_speed=self.min_speed)
        if self.damping < 2**-0.5:
            raise SimulationError(f"OrbitalGains.damping = {self.damping:g}; the LQR form needs damping >= 0.7072")
        if not self.terminal_time_to_go >= 0:
            raise SimulationError(f"OrbitalGains.terminal_time_to_go = {self.terminal_time_to_go!r}; give a time >= 0 s")

    @property
    def stiffness(self) -> float:
        """w^2 [1/s^2], the gain of the terminal/hold computed-torque loop."""
        return self.bandwidth**2

    @property
    def velocity_gain(self) -> float:
        """2 zeta w [1/s]."""
        return 2.0 * self.damping * self.bandwidth


@dataclass(frozen=True)
class TrackingGains:
    """Joint-space error dynamics e'' + 2 zeta w e' + w^2 e = 0: natural frequency ``bandwidth``
    [rad/s] and ``damping`` [-]. Used by the computed-torque baseline (gains per unit inertia) and the
    PD + gravity baseline (gains scaled per joint by the diagonal of M at the start configuration)."""

    bandwidth: float = defaults.COMPUTED_TORQUE_BANDWIDTH
    damping: float = defaults.COMPUTED_TORQUE_DAMPING

    def __post_init__(self):
        _check_positive("TrackingGains", bandwidth=self.bandwidth, damping=self.damping)

    @property
    def stiffness(self) -> float:
        return self.bandwidth**2

    @property
    def velocity_gain(self) -> float:
        return 2.0 * self.damping * self.bandwidth


def default_pd_gains() -> TrackingGains:
    """Gains of the PD + gravity baseline from :mod:`pathmotion.defaults`."""
    return TrackingGains(bandwidth=defaults.PD_BANDWIDTH, damping=defaults.PD_DAMPING)
