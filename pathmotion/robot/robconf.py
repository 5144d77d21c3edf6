"""ABB's configuration data (confdata, robconf [cf1, cf4, cf6, cfx]) of a 6-axis arm, and IK on the branch
it names.

* cf1, cf4, cf6: the quadrant of axes 1, 4 and 6, floor(q / (pi/2)): 0 for [0, 90) deg, 1 for [90, 180),
  -1 for [-90, 0), -2 for [-180, -90), and so on past a turn.
* cfx: the arm/wrist configuration number 0..7 = 4 * behind_axis_1 + 2 * behind_lower_arm + wrist_negative,
  where behind_axis_1: the wrist centre (origin of joint 5) lies behind axis 1 (negative x in the frame
  of joint 1); behind_lower_arm: it lies behind the lower arm (the line from joint 2 to joint 3, seen in
  that frame's x-z plane, forward being the side the upper arm points to at q = 0); wrist_negative: q5 < 0.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import UnreachableError
from .ik import ik_all
from .model import Robot

#: A joint within this of a quadrant boundary [rad] matches the quadrants on both sides (a target taught at
#: exactly 90 deg is stored with rounding either way).
QUADRANT_SLACK = 1e-6
_QUARTER = 0.5 * np.pi


def robconf_of(robot: Robot, q) -> tuple[int, int, int, int]:
    """(cf1, cf4, cf6, cfx) of the configuration q (6,) [rad]."""
    q = np.asarray(q, dtype=float)
    cf1, cf4, cf6 = (int(np.floor(q[j] / _QUARTER)) for j in (0, 3, 5))
    behind_axis, behind_arm = _arm_sides(robot, q)
    return cf1, cf4, cf6, 4 * int(behind_axis) + 2 * int(behind_arm) + int(q[4] < 0.0)


def _arm_sides(robot: Robot, q: np.ndarray) -> tuple[bool, bool]:
    """(wrist centre behind axis 1, wrist centre behind the lower arm) at q."""
    model, data = robot.model, robot.data
    pin.forwardKinematics(model, data, q)
    base = data.oMi[1]
    local = [base.actInv(data.oMi[j]).translation for j in (2, 3, 5)]
    j2, j3, wrist = local
    a, d = j3 - j2, wrist - j2
    return bool(wrist[0] < 0.0), bool(a[0] * d[2] - a[2] * d[0] > 0.0)


def _quadrant_ok(value: float, quadrant: int) -> bool:
    lo, hi = quadrant * _QUARTER, (quadrant + 1) * _QUARTER
    return lo - QUADRANT_SLACK <= value < hi + QUADRANT_SLACK


def ik_robconf(robot: Robot, position, rotation, robconf, where: str = "target") -> np.ndarray:
    """The IK solution (6,) [rad] of the TCP pose (position (3,) [m], rotation (3, 3)) on the branch
    ``robconf`` = (cf1, cf4, cf6, cfx) names, inside the joint ranges. UnreachableError naming ``where``
    when the pose is out of reach or no solution has that robconf (the message lists the ones that exist)."""
    conf = tuple(int(c) for c in robconf)
    if len(conf) != 4 or not 0 <= conf[3] <= 7:
        raise UnreachableError(f"{where}: robconf {list(robconf)} must be [cf1, cf4, cf6, cfx] with cfx in 0..7")
    try:
        solutions = ik_all(robot, position, rotation)
    except UnreachableError as exc:
        raise UnreachableError(f"{where}: {exc}", reason=exc.reason) from None
    found = []
    for q in solutions:
        have = robconf_of(robot, q)
        found.append(have)
        if have[3] == conf[3] and all(_quadrant_ok(q[j], c) for j, c in zip((0, 3, 5), conf[:3])):
            return q
    listed = ", ".join(str(list(c)) for c in sorted(set(found)))
    raise UnreachableError(f"{where}: no IK solution of this pose has robconf {list(conf)} inside the joint "
                           f"ranges; the pose is reached with robconf {listed}: give one of these", reason="reach")
