"""A robot program's configurations on a lifted path: the start branch its robconf names, and the
ConfL / ConfJ \\On check at every target.

* :func:`program_start` -- the joint vector at the path's start with the first target's robconf
  (:func:`pathmotion.robot.robconf.ik_robconf`); the lift follows the branch continuously from there.
* :func:`check_targets` -- at each target whose move holds its robconf (ConfL \\On), the planned
  configuration must have that robconf; with \\Off the lift's continuous branch (the one nearest the
  previous configuration) is taken as the controller does, and nothing is checked.

Both need an arm with the closed form (OPW); for any other arm the robconf is not defined and is
ignored with a log note.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..errors import UnreachableError
from ..robot import Robot
from ..robot.ik import has_closed_form
from ..robot.robconf import ik_robconf, robconf_of
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


def program_start(robot: Robot, position, rotation, start: TargetConf) -> np.ndarray | None:
    """The joint vector (6,) [rad] at the start pose (position (3,) [m], rotation (3, 3)) with the start
    target's robconf; None when it has none (or the arm has no closed form). UnreachableError naming the
    target when the robconf cannot reach the pose."""
    if start.robconf is None or not _closed_form(robot):
        return None
    return ik_robconf(robot, position, rotation, start.robconf, start.label)


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
        have = robconf_of(robot, q[k])
        if have != tuple(target.robconf):
            raise UnreachableError(
                f"{target.label}: the move arrives with robconf [{', '.join(map(str, have))}], not the programmed "
                f"[{', '.join(map(str, target.robconf))}] (ConfL/ConfJ \\On; a linear move keeps its arm "
                "configuration); change the target's robconf, move through a MoveJ, or use ConfL \\Off",
                reason="robconf")


__all__ = ["TargetConf", "check_targets", "program_start"]
