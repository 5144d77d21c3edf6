"""A robot program's ConfL / ConfJ \\On check on a lifted path: at each target whose move holds its
robconf, the planned configuration must have that robconf (:func:`check_targets`). With \\Off the
lift's continuous branch (the one nearest the previous configuration) is taken, as the controller
does, and nothing is checked. The path's start branch is the first target's robconf (its IK on that
robconf is where the lift starts). It needs an arm with the closed form (OPW); for any other arm the
robconf is not defined and is ignored with a log note.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..errors import UnreachableError
from ..robot import Robot
from ..robot.ik import has_closed_form
from ..robot.robconf import has_robconf, robconf_of
from .joint_path import JointPath

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TargetConf:
    """One program target: ``label`` (e.g. "line 12, target p10") for messages, ``robconf`` (cf1, cf4, cf6,
    cfx) or None, ``held`` True when ConfL / ConfJ \\On applies to the move that ends there."""

    label: str
    robconf: tuple[int, int, int, int] | None
    held: bool = True


def _closed_form(robot: Robot) -> bool:
    if robot.n == 6 and has_closed_form(robot):
        return True
    log.info("robconf ignored: %s has no closed-form IK, so ABB configurations are not defined for it", robot.name)
    return False


def check_targets(robot: Robot, path: JointPath, thetas, targets: list[TargetConf]) -> None:
    """UnreachableError naming the first target whose held robconf the planned configuration at
    ``thetas`` (K,) [m] (where the path passes each target) does not have, and the robconfs that do reach
    it."""
    if not any(t.robconf is not None and t.held for t in targets) or not _closed_form(robot):
        return
    q = path(np.asarray(thetas, float))
    for k, target in enumerate(targets):
        if target.robconf is None or not target.held:
            continue
        if not has_robconf(robot, q[k], tuple(target.robconf)):
            have = robconf_of(robot, q[k])
            raise UnreachableError(
                f"{target.label}: the move arrives with robconf [{', '.join(map(str, have))}], not the programmed "
                f"[{', '.join(map(str, target.robconf))}] (ConfL/ConfJ \\On; a linear move keeps its arm "
                "configuration); change the target's robconf, move through a MoveJ, or use ConfL \\Off",
                reason="robconf")


__all__ = ["TargetConf", "check_targets"]
