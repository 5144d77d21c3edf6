"""Limits as objects: one class per limit (one file each), and the registry the planner,
the verification, the settings and the scenario loading loop over.

Adding a limit: write a :class:`Limit` subclass in a new file here and append it to ``REGISTRY``
(and give its ``scenario_keys`` in the scenario file format, ``io/scenario.py``'s LimitsSpec).
The order of ``REGISTRY`` is the order of the ratios in messages and outputs.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from ...robot import Robot
from .acceleration import AccelerationLimit
from .base import Limit, LimitChoice, PathPoints, RowForm, Rows
from .jerk import JerkLimit
from .tcp_speed import TcpSpeedLimit, tcp_gain
from .torque import TorqueLimit
from .torque_rate import TorqueRateLimit
from .torque_speed import TorqueSpeedLimit
from .velocity import VelocityLimit

#: Every limit class, in output order.
REGISTRY: list[type[Limit]] = [VelocityLimit, AccelerationLimit, TorqueLimit, TcpSpeedLimit, TorqueSpeedLimit, JerkLimit,
                              TorqueRateLimit]


class EffectiveLimits:
    """The limits the planner enforces for one robot and settings: the active limit objects, in
    registry order (a limit that is off is absent)."""

    def __init__(self, active: tuple[Limit, ...]):
        self.active = tuple(active)

    def __iter__(self) -> Iterator[Limit]:
        return iter(self.active)

    def __len__(self) -> int:
        return len(self.active)

    def get(self, name: str) -> Limit | None:
        return next((lim for lim in self.active if lim.name == name), None)

    @property
    def third_order(self) -> bool:
        """Some active limit is of order 3 (jerk, torque rate): the smooth planner runs."""
        return any(lim.order == 3 for lim in self.active)

    @property
    def needs_torque_rate(self) -> bool:
        return any(lim.order == 3 and lim.needs_torque for lim in self.active)

    @property
    def relinearize(self) -> bool:
        """Some active limit's rows depend on x_ref (the planner iterates)."""
        return any(lim.relinearize for lim in self.active)

    @property
    def needs_torque(self) -> bool:
        return any(lim.needs_torque for lim in self.active)

    def unit_scale(self, k: int, n: int) -> dict[str, np.ndarray]:
        """Point-wise scale factors of 1: {name: (K, m)}."""
        return {lim.name: np.ones((k, lim.columns(n))) for lim in self.active}


def effective_limits_for(robot: Robot, choices: Mapping[str, LimitChoice]) -> EffectiveLimits:
    """The active limits of ``robot`` under the user's choices {name: LimitChoice} (registry defaults
    for a missing name)."""
    active = []
    for cls in REGISTRY:
        choice = choices.get(cls.name, cls.default_choice())
        lim = cls.from_robot(robot, choice, choices=choices) if cls.uses_choices else cls.from_robot(robot, choice)
        if lim is not None:
            active.append(lim)
    return EffectiveLimits(tuple(active))


def limit_choices(source, keys: str = "scenario_keys") -> dict[str, LimitChoice]:
    """{name: LimitChoice} read from an object (e.g. a scenario's LimitsSpec) or a mapping, by each
    registered limit's ``scenario_keys`` (or ``settings_keys``); missing keys keep the defaults."""
    out = {}
    for cls in REGISTRY:
        base = cls.default_choice()
        fields = {}
        for key, field in getattr(cls, keys).items():
            value = source.get(key, getattr(base, field)) if isinstance(source, Mapping) else getattr(source, key)
            fields[field] = value
        if "value" in fields and "on" not in getattr(cls, keys).values():
            fields["on"] = fields["value"] is not None
        out[cls.name] = cls.check_choice(LimitChoice(**{**base.__dict__, **fields}))
    return out


__all__ = [
    "AccelerationLimit", "EffectiveLimits", "JerkLimit", "TorqueRateLimit", "Limit", "LimitChoice", "PathPoints", "REGISTRY", "RowForm", "Rows",
    "TcpSpeedLimit", "TorqueLimit", "TorqueSpeedLimit", "VelocityLimit", "limit_choices", "effective_limits_for", "tcp_gain",
]
