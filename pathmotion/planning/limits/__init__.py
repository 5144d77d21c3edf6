"""Limits as objects: one class per limit (one file each), and the registry the planner,
the verification, the settings and the scenario loading loop over.

Adding a limit: write a :class:`Limit` subclass in a new file here and append it to ``REGISTRY``
(and give its ``keys`` in the scenario file format, ``io/scenario.py``'s LimitsSpec).
The order of ``REGISTRY`` is the order of the ratios in messages and outputs.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import replace

import numpy as np

from ...errors import ScenarioError
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


class LimitChoices(Mapping):
    """{limit name: LimitChoice} for every registered limit (defaults where not given), checked by each
    limit's ``check_choice``; immutable and hashable, so settings holding it are too."""

    def __init__(self, choices: Mapping[str, LimitChoice] | None = None):
        given = dict(choices or {})
        unknown = sorted(set(given) - {cls.name for cls in REGISTRY})
        if unknown:
            raise ScenarioError(f"unknown limit(s) {unknown}; the limits are {[cls.name for cls in REGISTRY]}")
        self._choices = {cls.name: cls.check_choice(given.get(cls.name, cls.default_choice())) for cls in REGISTRY}

    def __getitem__(self, name: str) -> LimitChoice:
        return self._choices[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._choices)

    def __len__(self) -> int:
        return len(self._choices)

    def __hash__(self) -> int:
        return hash(tuple(self._choices.items()))

    def __repr__(self) -> str:
        return f"LimitChoices({self._choices!r})"

    def replace(self, name: str, **changes) -> "LimitChoices":
        """A copy with the choice of limit ``name`` changed (``on``, ``scale``, ``value``)."""
        return LimitChoices({**self._choices, name: replace(self._choices[name], **changes)})

    @classmethod
    def of(cls, source) -> "LimitChoices":
        """``source`` as LimitChoices: LimitChoices, {limit name: LimitChoice}, the ``[limits]`` keys
        {key: value} (e.g. ``{"use_torque": False, "jerk": [...]}``) or an object with them as attributes
        (a scenario's LimitsSpec)."""
        if isinstance(source, LimitChoices):
            return source
        if isinstance(source, Mapping) and source and all(isinstance(v, LimitChoice) for v in source.values()):
            return cls(source)
        return limit_choices(source)


def limit_keys() -> list[str]:
    """Every registered limit's ``[limits]`` keys, in registry order."""
    return [key for cls in REGISTRY for key in cls.keys]


def limit_choices(source) -> LimitChoices:
    """LimitChoices read by each registered limit's ``keys`` from a mapping {key: value} (missing keys keep the
    defaults, an unknown key is refused) or an object with the keys as attributes (a scenario's LimitsSpec)."""
    if isinstance(source, Mapping):
        unknown = sorted(set(source) - set(limit_keys()))
        if unknown:
            hint = "".join(f"; the switch of {k!r} is 'use_{k}'"
                           for k in unknown if f"use_{k}" in limit_keys())
            raise ScenarioError(f"unknown limit key(s) {unknown}{hint}; the keys are {limit_keys()}")
    out = {}
    for cls in REGISTRY:
        base = cls.default_choice()
        fields = {}
        for key, field in cls.keys.items():
            if isinstance(source, Mapping):
                fields[field] = source.get(key, getattr(base, field))
            else:
                fields[field] = getattr(source, key)
        if "value" in fields and "on" not in cls.keys.values():
            fields["on"] = fields["value"] is not None
        out[cls.name] = LimitChoice(**{**base.__dict__, **fields})
    return LimitChoices(out)


__all__ = [
    "AccelerationLimit", "EffectiveLimits", "LimitChoices", "JerkLimit", "TorqueRateLimit", "Limit", "LimitChoice", "PathPoints", "REGISTRY", "RowForm", "Rows",
    "TcpSpeedLimit", "TorqueLimit", "TorqueSpeedLimit", "VelocityLimit", "limit_choices", "limit_keys", "effective_limits_for", "tcp_gain",
]
