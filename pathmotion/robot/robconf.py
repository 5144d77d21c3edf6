"""ABB's configuration data (confdata, robconf [cf1, cf4, cf6, cfx]) of a 6-axis arm, and IK on the branch
it names.

* cf1, cf4, cf6: the quadrant of axes 1, 4 and 6, floor(q / (pi/2)): 0 for [0, 90) deg, 1 for [90, 180),
  -1 for [-90, 0), -2 for [-180, -90), and so on past a turn.
* cfx: the arm/wrist configuration number 0..7 = 4 * behind_axis_1 + 2 * behind_lower_arm + wrist_negative,
  where behind_axis_1: the wrist centre (origin of joint 5) lies behind axis 1 (negative x in the frame
  of joint 1); behind_lower_arm: it lies behind the lower arm (the line from joint 2 to joint 3, seen in
  that frame's x-z plane, forward being the side the upper arm points to at q = 0); wrist_negative: q5 < 0.
  On a boundary (a shoulder or elbow singularity, q5 = 0, a joint at a multiple of 90 deg) within the slacks
  below, both sides match.
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
#: A wrist centre within this of axis 1 or of the lower arm's line [m] matches both sides (the shoulder and
#: elbow singularities, where the branches meet and IK is accurate to about the square root of round-off).
SIDE_SLACK = 1e-6
_QUARTER = 0.5 * np.pi


def robconf_of(robot: Robot, q) -> tuple[int, int, int, int]:
    """(cf1, cf4, cf6, cfx) of the configuration q (6,) [rad]; a joint within QUADRANT_SLACK below a quadrant
    boundary (e.g. -1e-17 rad) counts in the quadrant above it."""
    q = np.asarray(q, dtype=float)
    cf1, cf4, cf6 = (int(np.floor((q[j] + QUADRANT_SLACK) / _QUARTER)) for j in (0, 3, 5))  # a boundary: above
    axis, arm, wrist = cfx_margins(robot, q)
    return cf1, cf4, cf6, 4 * int(axis < 0.0) + 2 * int(arm < 0.0) + int(wrist < 0.0)


def cfx_margins(robot: Robot, q: np.ndarray) -> tuple[float, float, float]:
    """Signed distances whose signs make cfx: (wrist centre in front of axis 1 [m], in front of the lower arm [m],
    q5 [rad]); negative means behind / negative (a bit of cfx set)."""
    model, data = robot.model, robot.data
    pin.forwardKinematics(model, data, q)
    base = data.oMi[1]
    j2, j3, wrist = (base.actInv(data.oMi[j]).translation for j in (2, 3, 5))
    a, d = j3 - j2, wrist - j2
    arm = (a[2] * d[0] - a[0] * d[2]) / max(float(np.hypot(a[0], a[2])), 1e-300)
    return float(wrist[0]), float(arm), float(q[4])


def has_robconf(robot: Robot, q: np.ndarray, conf: tuple[int, ...]) -> bool:
    """q has robconf ``conf``, a joint or margin within the slack of a boundary matching both sides."""
    if not all(_quadrant_ok(q[j], c) for j, c in zip((0, 3, 5), conf[:3])):
        return False
    bits = ((conf[3] >> 2) & 1, (conf[3] >> 1) & 1, conf[3] & 1)
    return all(abs(m) <= slack or (m < 0.0) == bool(b)
               for m, b, slack in zip(cfx_margins(robot, q), bits, (SIDE_SLACK, SIDE_SLACK, QUADRANT_SLACK)))


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
        raise exc.in_context(where) from exc
    for q in solutions:
        if has_robconf(robot, q, conf):
            return q
    listed = ", ".join(str(list(c)) for c in sorted({robconf_of(robot, q) for q in solutions}))
    raise UnreachableError(f"{where}: no IK solution of this pose has robconf {list(conf)} inside the joint "
                           f"ranges; the pose is reached with robconf {listed}: give one of these", reason="reach")
