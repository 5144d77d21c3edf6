"""The monitor at a path that turns back over itself (a pick or place point left along the same line): equal
or nearly equal distances to both halves must not send theta back; a clearly nearer earlier half does.

Exact geometry: q = s e1 - h e2 is at distance h from the first half (theta = s) and at distance
(1 - s) sin(alpha) + h cos(alpha) from the second half, whose direction is (-cos alpha, sin alpha)."""

from dataclasses import dataclass

import numpy as np
import pytest

from pathmotion.control import PathTable
from pathmotion.lift.joint_path import JointPath
from pathmotion.simulation.monitor import BACKWARD_RATIO, monitor_state

ALPHA = 0.01


@dataclass(frozen=True, eq=False)
class OutAndBack(JointPath):
    """q = theta e1 on [0, 1], then back: e1 + (theta - 1) (-cos alpha, sin alpha) on [1, 2]."""

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        e1, d2 = np.eye(6)[0], np.array([-np.cos(ALPHA), np.sin(ALPHA), 0, 0, 0, 0])
        second = (th > 1 if side == "left" else th >= 1)[:, None]
        q = np.where(second, e1 + (th - 1)[:, None] * d2, th[:, None] * e1)
        dq = np.where(second, d2, e1 + 0 * q)
        out = (q, dq, np.zeros_like(q))
        return tuple(o[0] for o in out) if scalar else out


def state_for(ratio: float, s: float = 0.98) -> np.ndarray:
    """q at distance h from the first half and h / ratio from the second one."""
    h = ratio * (1 - s) * np.sin(ALPHA) / (1 - ratio * np.cos(ALPHA))
    return np.array([s, -h, 0, 0, 0, 0])


@pytest.mark.parametrize("ratio, back", [(0.9, False), (0.7, False), (0.3, True), (0.1, True)])
def test_theta_goes_back_across_the_turn_only_when_clearly_nearer(ratio, back):
    path = OutAndBack(n=6, domain=(0.0, 2.0), kinks=(1.0,), breaks=(1.0,))
    table = PathTable.from_path(path, 401)
    q = state_for(ratio)
    th, _, dev, _, _, ok = monitor_state(table.arrays, q, np.zeros(6), 1.02, table.projection(),
                                         np.full(6, 1e3), 0.0)
    h = -q[1]
    assert ok
    if back:  # distance ratio below sqrt(BACKWARD_RATIO): the first half, theta = s, distance h
        assert ratio**2 < BACKWARD_RATIO and th == pytest.approx(0.98, abs=1e-9) and dev == pytest.approx(h, rel=1e-6)
    else:  # stays on the second half, at the foot of the perpendicular from q (exact geometry)
        d2 = np.array([-np.cos(ALPHA), np.sin(ALPHA), 0, 0, 0, 0])
        along = (q - np.eye(6)[0]) @ d2
        foot = np.eye(6)[0] + along * d2
        assert np.linalg.norm(q - foot) == pytest.approx(h / ratio, rel=1e-9)  # the construction's distance
        assert th == pytest.approx(1.0 + along, abs=1e-9) and th > 1.0
        assert dev == pytest.approx(np.max(np.abs(q - foot)), rel=1e-6) and dev > h
