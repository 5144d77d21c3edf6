"""The compiled Riccati sweep and the knot-based continuous design against independent references.

References: scipy's adaptive RK45 (``solve_riccati_adaptive``, a Python right-hand side) on the same data; the
scalar Riccati equation's closed form; the design solved on every table point with that adaptive integrator.
"""

from dataclasses import dataclass

import numpy as np
import pytest

from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable
from pathmotion.control.orbital import integral_size, lqr_weights, with_integral
from pathmotion.control.path_table import _HERMITE5
from pathmotion.control.profile_lookup import ProfileLookup
from pathmotion.control.riccati import solve_riccati
from pathmotion.control.transverse import TransverseBasis, transverse_linearization
from pathmotion.lift.joint_path import JointPath, SplineJointPath

from control_reference import solve_riccati_adaptive

from tests.planning_paths import CONTROL_WAYPOINTS as WAYPOINTS, trapezoid


def test_scalar_riccati_matches_its_closed_form():
    # -p' = 2 a p - p^2 / r + q, p(T) = 0: p(t) = c tanh(c (T - t) / r + ...) with a = 0: p = sqrt(q r) tanh(...)
    q, r, horizon = 4.0, 1.0, 2.0
    times = np.linspace(0.0, horizon, 1001)
    big = len(times)
    p = solve_riccati(times, np.zeros((big, 1, 1)), np.ones((big, 1, 1)), np.full((big, 1, 1), q), np.eye(1) * r,
                      np.zeros((1, 1)))
    exact = np.sqrt(q * r) * np.tanh(np.sqrt(q / r) * (horizon - times))
    assert np.max(np.abs(p[:, 0, 0] - exact)) < 1e-8


def test_compiled_sweep_matches_adaptive_rk45_on_a_transverse_linearization():
    table = PathTable.from_path(SplineJointPath.from_waypoints(WAYPOINTS))
    lookup, gains = ProfileLookup(trapezoid()), OrbitalGains()
    theta = table.grid[300:1700:3]  # knots ~2 ms apart in planned time, as the design's
    times = lookup.times(theta)
    basis = TransverseBasis.for_table(table, theta)
    a, b = with_integral(*transverse_linearization(table, basis, lookup, theta), integral_size(gains, 6))
    _, dphi, _ = table.evaluate(theta)
    q, r = lqr_weights(gains, dphi, lookup.states(theta)[:, 0])
    p_end = 10.0 * np.eye(a.shape[1])
    fast = solve_riccati(times, a, b, q, r, p_end)
    slow = solve_riccati_adaptive(times, a, b, q, r, p_end)
    err = np.linalg.norm(fast - slow, axis=(1, 2)) / np.linalg.norm(slow, axis=(1, 2))
    assert err.max() < 1e-4


def test_knot_design_matches_the_adaptive_design_on_every_table_point():
    table = PathTable.from_path(SplineJointPath.from_waypoints(WAYPOINTS))
    profile = trapezoid()
    design = OrbitalDesign.build(table, profile, OrbitalGains())
    lookup, gains = ProfileLookup(profile), OrbitalGains()
    active = np.nonzero(np.any(design.riccati != 0, axis=(1, 2)))[0]
    theta = table.grid[active]
    times = lookup.times(theta)
    a, b = with_integral(*transverse_linearization(table, design.basis, lookup, theta), integral_size(gains, 6))
    _, dphi, _ = table.evaluate(theta)
    q, r = lqr_weights(gains, dphi, lookup.states(theta)[:, 0])
    slow = solve_riccati_adaptive(times, a, b, q, r, design.riccati[active[-1]])
    k_slow = np.linalg.solve(r, np.transpose(b, (0, 2, 1))) @ slow
    err = np.linalg.norm(design.gain[active] - k_slow, axis=(1, 2)) / np.max(np.linalg.norm(k_slow, axis=(1, 2)))
    assert err.max() < 1e-3


@dataclass(frozen=True, eq=False)
class TwoParabolas(JointPath):
    """q = theta d + theta^2 c1 on [0, 1], then continuing with Phi' and Phi'' jumping (c2, d2) on [1, 2]."""

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        d, c1, d2, c2 = np.arange(1.0, 7.0), np.linspace(-1, 1, 6), np.linspace(2, 0, 6), np.full(6, 0.3)
        second = (th > 1 if side == "left" else th >= 1)[:, None]
        s = (th - 1)[:, None]
        q = np.where(second, d + c1 + s * d2 + s**2 * c2, th[:, None] * d + th[:, None] ** 2 * c1)
        dq = np.where(second, d2 + 2 * s * c2, d + 2 * th[:, None] * c1)
        ddq = np.where(second, 2 * c2 + 0 * s, 2 * c1 + 0 * s)
        out = (q, dq, ddq)
        return tuple(o[0] for o in out) if scalar else out


def test_table_built_from_one_sided_evaluations_equals_two_full_evaluations():
    path = TwoParabolas(n=6, domain=(0.0, 2.0), breaks=(1.0,), kinks=(1.0,))
    table = PathTable.from_path(path, 300)  # 1.0 is not on the even grid: the break is added
    grid = table.grid
    assert 1.0 in grid
    left, right = path.evaluate(grid[:-1], side="right"), path.evaluate(grid[1:], side="left")
    h = np.diff(grid)[:, None]
    data = np.stack([left[0], left[1] * h, left[2] * h**2, right[0], right[1] * h, right[2] * h**2], axis=1)
    assert np.allclose(table.coeffs, np.einsum("kj,mjn->mkn", _HERMITE5, data), rtol=0, atol=1e-13)
    # and the table reproduces both one-sided values at the break
    i = int(np.searchsorted(grid, 1.0))
    assert np.allclose(table.coeffs[i - 1].sum(axis=0), path.evaluate(1.0, side="left")[0], atol=1e-13)
    assert np.allclose(table.coeffs[i, 1] / (grid[i + 1] - grid[i]),
                       path.evaluate(1.0, side="right")[1], atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_riccati_reports_a_blow_up(bad):
    from pathmotion.errors import SimulationError
    times = np.linspace(0, 1, 11)
    a = np.full((11, 1, 1), bad)
    with pytest.raises(SimulationError, match="Riccati"):
        solve_riccati(times, a, np.ones((11, 1, 1)), np.ones((11, 1, 1)), np.eye(1), np.zeros((1, 1)))
