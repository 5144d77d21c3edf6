"""The optimal blends a scenario asks for, before their search (:func:`pathmotion.api.searches.search` runs it):
on a task or waypoint path one :class:`BlendRequest`; on a chain (a task path with joint moves or dwells) a
:class:`ChainBlendRequest`, one BlendRequest per task run that has optimal corners."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..geometry import TaskPath


@dataclass(frozen=True)
class BlendRequest:
    """The optimal blends of one task path, before their search: ``sharp`` the task path with every
    blended corner sharp, ``blends`` the other blends {connection index: (kind, value)} applied with them,
    ``tolerances`` {connection index: tolerance [m]} of the optimal ones, ``names`` {connection index:
    scenario key} for errors, the corners kept ``planar`` and those whose blend joins the lines
    (``joined``), and how hard each corner is searched (``searches`` {connection index: "fast" | "thorough"},
    "fast" where absent)."""

    sharp: TaskPath
    blends: dict
    tolerances: dict[int, float]
    names: dict[int, str]
    planar: tuple[int, ...] = ()
    joined: tuple[int, ...] = ()
    searches: dict = dataclasses.field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class ChainBlendRequest:
    """The optimal blends of a chain, before their search: ``items`` the chain's items
    (:func:`pathmotion.lift.chain.lift_chain`), each task run with its blends applied except the runs in
    ``runs`` {item index: BlendRequest of that run, connection indices local to the run}, which are sharp;
    ``zones`` {motion connection: tolerance [m]} the joint-space zones (kept, not searched); ``q_start`` (n,)
    [rad] or None the chain's start."""

    items: tuple
    runs: dict
    zones: dict
    q_start: np.ndarray | None
