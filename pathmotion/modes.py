"""The modes a user chooses by name, as str-valued enums (their values are the strings of the
scenario files and outputs, so ``Connections.CHAIN == "chain"`` and JSON writes "chain").

Each is validated once where it enters: the scenario model (io/scenario.py) and the settings
objects' constructors (:func:`parse_mode` gives the error). Inside the package only members are
compared. This module imports nothing from the package but its errors.
"""

from __future__ import annotations

from enum import StrEnum
from typing import TypeVar

from .errors import ScenarioError


class Connections(StrEnum):
    """How segments connect in planning: one chain, stop at every connection, or plan each segment
    with the boundary-level velocity at its connections (see planning/segments.py)."""

    CHAIN = "chain"
    ZERO = "zero"
    MAX = "max"


class VerifyMode(StrEnum):
    """How the planner checks the continuous motion between grid points: a certified bound per grid
    interval (planning/certify.py), the dense time resample (planning/verify.py), or not at all."""

    CERTIFIED = "certified"
    DENSE = "dense"
    OFF = "off"


class BoundaryMode(StrEnum):
    """A named path velocity at a path end: rest, or the largest feasible (a number is the third kind)."""

    ZERO = "zero"
    MAX = "max"


class Controller(StrEnum):
    """Closed-loop controller: orbital stabilization or one of the two time-indexed baselines."""

    ORBITAL = "orbital"
    COMPUTED_TORQUE = "computed_torque"
    PD_GRAVITY = "pd_gravity"


class BlendType(StrEnum):
    """Corner blend: the thesis' transition circle, a curvature-continuous (G2) blend, or the
    asymmetric G2 blend whose shape minimises the time-optimal duration (planning/blend_search.py)."""

    CIRCLE = "circle"
    G2 = "g2"
    OPTIMAL = "optimal"


E = TypeVar("E", bound=StrEnum)


def parse_mode(enum: type[E], value, what: str) -> E:
    """``value`` as a member of ``enum``; ScenarioError naming ``what`` and the allowed values otherwise."""
    try:
        return enum(value)
    except ValueError:
        allowed = ", ".join(f"'{m.value}'" for m in enum)
        raise ScenarioError(f"{what} must be one of {allowed}, got {value!r}") from None
