"""ABB robot configurations (robconf [cf1, cf4, cf6, cfx]) of joint vectors, and the IK solution a
robconf names.

ABB's convention for a six-axis arm:

* cf1, cf4, cf6: the quadrant of axes 1, 4 and 6, floor(q / 90 deg): 0 for [0, 90) deg, 1 for
  [90, 180), -1 for [-90, 0), -2 for [-180, -90), and so on past a half turn.
* cfx in 0..7: 4 * (wrist centre behind axis 1) + 2 * (wrist centre behind the lower arm) + (axis 5
  negative).

On an OPW arm (:mod:`pathmotion.robot.opw`) the three cfx bits are the closed form's branch bits:
"behind axis 1" is the back shoulder, "behind the lower arm" the elbow-down branch (the wrist centre
on the far side of the line through axes 2 and 3), and the last bit the sign of q5. So a robconf picks
one of the 8 branches and, through cf1/cf4/cf6, one of its 2 pi turns of axes 1, 4 and 6.
"""

from __future__ import annotations

import numpy as np

from ..errors import UnreachableError
from .ik import ik_all, opw_geometry
from .kinematics import fk
from .model import Robot
from .opw import branch_of

#: A joint angle this close above a quadrant boundary [rad] counts as in the quadrant above (robconf
#: of a target computed from rounded numbers must not flip at exactly 0 or 90 deg).
QUADRANT_SLACK = 1e-9


def quadrant(angle: float) -> int:
    """ABB's cf of a joint angle [rad]: floor(angle / 90 deg)."""
    return int(np.floor((angle + QUADRANT_SLACK) / (0.5 * np.pi)))


def robconf_of(robot: Robot, q) -> tuple[int, int, int, int]:
    """(cf1, cf4, cf6, cfx) of the joint vector ``q`` (6,) [rad] of an OPW arm."""
    q = np.asarray(q, float)
    geo = opw_geometry(robot)
    p, r = fk(robot, q)
    branch = int(branch_of(geo, p[None], r[None], geo.to_t(q)[None])[0])
    cfx = 4 * (branch >> 2) + 2 * ((branch >> 1) & 1) + int(q[4] < 0.0)
    return quadrant(q[0]), quadrant(q[3]), quadrant(q[5]), cfx


def ik_robconf(robot: Robot, position, rotation, robconf, where: str) -> np.ndarray:
    """The joint vector (6,) [rad] reaching the TCP pose (position (3,) [m], rotation (3, 3)) with
    ``robconf`` (cf1, cf4, cf6, cfx); UnreachableError naming ``where`` and the robconfs that do reach
    the pose when none has this one."""
    want = tuple(int(c) for c in robconf)
    solutions = ik_all(robot, position, rotation)
    confs = [robconf_of(robot, q) for q in solutions]
    for q, conf in zip(solutions, confs):
        if conf == want:
            return q
    have = ", ".join(f"[{', '.join(map(str, c))}]" for c in sorted(set(confs)))
    raise UnreachableError(f"{where}: robconf [{', '.join(map(str, want))}] cannot reach this pose within the joint "
                           f"ranges; the configurations that do: {have}; change the robconf (or the target)",
                           reason="robconf")


__all__ = ["ik_robconf", "quadrant", "robconf_of"]
