"""Controller geometry: path table, projection, transverse coordinates, linearization, Riccati.

Independent references: the exact spline (table), dense sampling (projection), central finite
differences of the exact dynamics q_ddot = v (transverse linearization), scipy's algebraic Riccati
solver (Riccati differential equation on a constant system).
"""

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.linalg import solve_continuous_are

from pathmotion.control import (OrbitalDesign, OrbitalGains, PathTable, ProfileLookup, TransverseBasis, lqr_weights,
                                project, solve_riccati, transverse_linearization)
from pathmotion.control import kernels
from pathmotion.control.orbital import with_integral
from pathmotion.lift.joint_path import JointPath, SplineJointPath
from pathmotion.planning.profile import Profile

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


@pytest.fixture(scope="module")
def spline():
    return SplineJointPath.from_waypoints(WAYPOINTS)


@pytest.fixture(scope="module")
def table(spline):
    return PathTable.from_path(spline)


def trapezoid(v=0.9, a=2.0):
    ta = v * v / (2 * a)
    return Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))


@dataclass(frozen=True, eq=False)
class LinePath(JointPath):
    """q = q0 + d theta on [0, 1]: Phi'' = 0, constant transverse basis."""

    q0: np.ndarray = None
    d: np.ndarray = None

    def evaluate(self, theta, side="right"):
        th, scalar = self._check_theta(theta)
        q = self.q0 + th[:, None] * self.d
        dq = np.broadcast_to(self.d, q.shape).copy()
        out = (q, dq, np.zeros_like(q))
        return tuple(o[0] for o in out) if scalar else out


def test_table_matches_the_exact_spline(spline, table):
    theta = np.random.default_rng(0).uniform(0, 1, 500)
    exact = spline.evaluate(theta)
    tab = table.evaluate(theta)
    # cubic pieces: quintic Hermite is exact inside a piece, O(h^3 jump(Phi''')) across a knot
    for k, tol in enumerate((1e-9, 1e-6, 1e-3)):
        assert np.max(np.abs(tab[k] - exact[k])) < tol
    for th in theta[:50]:
        for k, v in enumerate(table.evaluate_scalar(th)):
            assert np.allclose(v, tab[k][list(theta).index(th)], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(0.05, 0.95), offset=st.lists(st.floats(-1e-3, 1e-3), min_size=6, max_size=6),
       start=st.floats(-0.02, 0.02))
def test_projection_is_the_local_minimum_of_the_distance(theta, offset, start):
    path = SplineJointPath.from_waypoints(WAYPOINTS)
    table = PathTable.from_path(path, 801)
    q = path(theta) + np.asarray(offset)
    th, (phi, dphi, _) = project(table, q, theta + start)
    assert abs(dphi @ (q - phi)) < 1e-8  # first-order condition (4 iterations from up to 2 % away)
    dense = np.linspace(theta - 0.05, theta + 0.05, 20001)
    dist = np.linalg.norm(path(np.clip(dense, 0, 1)) - q, axis=1)
    assert np.linalg.norm(q - phi) <= dist.min() + 1e-9
    assert abs(th - dense[np.argmin(dist)]) < 2e-5


def test_projection_at_clamped_end_where_phi_prime_vanishes(spline, table):
    assert np.allclose(spline.evaluate(0.0)[1], 0.0)  # clamped: Phi'(0) = 0
    q = spline(0.01)
    th, _ = project(table, q, 0.0)
    assert abs(th - 0.01) < 1e-7


def test_transverse_basis_is_orthonormal_and_its_derivative_matches_finite_differences(spline, table):
    basis = TransverseBasis.for_table(table, table.grid[100:-100])
    theta = np.linspace(0.1, 0.9, 50)
    _, dphi, ddphi = spline.evaluate(theta)
    e, de = basis.frames(dphi, ddphi)
    assert np.allclose(np.einsum("nij,nik->njk", e, e), np.eye(5), atol=1e-12)
    assert np.max(np.abs(np.einsum("ni,nij->nj", dphi, e))) < 1e-12
    h = 1e-6
    ep, _ = basis.frames(*spline.evaluate(theta + h)[1:])
    em, _ = basis.frames(*spline.evaluate(theta - h)[1:])
    assert np.max(np.abs((ep - em) / (2 * h) - de)) < 1e-5


def test_transverse_linearization_matches_finite_differences_of_the_dynamics(spline, table):
    """d x_perp/dt of q_ddot = v* + dv at a perturbed state vs A x_perp + B dv (first order)."""
    profile = trapezoid()
    lookup = ProfileLookup(profile)
    basis = TransverseBasis.for_table(table, table.grid[200:-200])
    rng = np.random.default_rng(3)
    for theta in (0.3, 0.55, 0.8):
        a, b = transverse_linearization(table, basis, lookup, np.array([theta - 1e-3, theta, theta + 1e-3]))
        a, b = a[1], b[1]
        phi, dphi, ddphi = spline.evaluate(theta)
        e, de = basis.frames(dphi[None], ddphi[None])
        e, de = e[0], de[0]
        x_star, u_star = lookup.state(theta)
        eps = 1e-5
        z, zd, i_dev = eps * rng.normal(size=5), eps * rng.normal(size=5), eps * rng.normal()
        dv = 1e-3 * rng.normal(size=6)
        theta_dot = np.sqrt(x_star + i_dev)
        q = phi + e @ z
        qd = (dphi + de @ z) * theta_dot + e @ zd
        v = dphi * u_star + ddphi * x_star + dv
        x0 = np.concatenate([z, zd, [i_dev]])
        dt = 1e-5

        def state_at(s):
            out = kernels.transverse_state(table.arrays, lookup.arrays, basis.arrays, table.projection(),
                                           q + qd * s + 0.5 * v * s * s, qd + v * s, theta)
            return np.concatenate([out[2], out[3], [out[4]]])

        assert np.allclose(state_at(0.0), x0, atol=1e-11)
        fd = (state_at(dt) - state_at(-dt)) / (2 * dt)
        lin = a @ x0 + b @ dv
        assert np.linalg.norm(fd - lin) < 1e-3 * np.linalg.norm(lin)


def test_riccati_differential_equation_converges_to_the_algebraic_solution():
    rng = np.random.default_rng(1)
    d, m = 5, 2
    a = rng.normal(size=(d, d))
    b = rng.normal(size=(d, m))
    q = np.diag(rng.uniform(1, 10, d))
    r = np.diag(rng.uniform(0.5, 2, m))
    times = np.linspace(0, 20, 41)
    ones = np.ones((len(times), 1, 1))
    p = solve_riccati(times, a * ones, b * ones, q * ones, r, np.zeros((d, d)))
    care = solve_continuous_are(a, b, q, r)
    assert np.allclose(p[0], care, rtol=1e-5, atol=1e-6 * np.abs(care).max())
    assert np.allclose(p[-1], 0.0)


@pytest.mark.parametrize("integral_rate", [0.0, 20.0])
def test_orbital_gains_on_a_straight_line_place_the_chain_poles(integral_rate):
    """On a line at constant speed the transverse system is LTI and decoupled: per direction a double integrator
    (or a triple one with the integral state). The Riccati solution must be the algebraic one, and the gains
    those of the characteristic polynomial (s + w_i)(s^2 + 2 zeta w s + w^2) expanded by hand:
    k_xi = w_i w^2, k_z = w^2 + 2 zeta w w_i, k_zdot = w_i + 2 zeta w."""
    path = LinePath(n=6, domain=(0.0, 1.0), q0=np.zeros(6), d=np.array([0.5, -0.3, 0.2, 0.4, 0.1, -0.6]))
    profile = Profile(np.linspace(0, 1, 5), np.full(5, 0.25))  # constant theta_dot: a constant LTI system
    gains = OrbitalGains(integral_rate=integral_rate)
    design = OrbitalDesign.build(PathTable.from_path(path, 201), profile, gains)
    mid = len(design.theta) // 2
    _, dphi, _ = path.evaluate(design.theta[mid:mid + 1])
    q, r = lqr_weights(gains, dphi, np.array([0.25]))
    table = design.table
    a, b = with_integral(*transverse_linearization(table, design.basis, design.profile,
                                                   design.theta[mid - 1:mid + 2]), 6 if integral_rate else 0)
    care = solve_continuous_are(a[1], b[1], q[0], r)
    assert np.allclose(design.riccati[mid], care, rtol=1e-4, atol=1e-6 * np.abs(care).max())
    k = design.gain[mid]
    e = design.basis.frames(dphi, np.zeros_like(dphi))[0][0]
    w, wi, zeta = gains.bandwidth, integral_rate, gains.damping
    # columns: (xi_z (5), xi_I) with integral action, then z (5), z_dot (5), I
    start = [0, 6, 11] if integral_rate else [0, 5]
    expected = ([wi * w * w] if integral_rate else []) + [w * w + 2 * zeta * w * wi, wi + 2 * zeta * w]
    for c, kj in zip(start, expected):
        assert np.allclose(e.T @ k[:, c:c + 5], kj * np.eye(5), rtol=1e-4, atol=1e-3 * kj), c
    assert np.allclose(gains.clock_gains, (expected[-2], expected[-1], wi * w * w))
    # closed loop: per transverse direction (s + w_i)(s^2 + 2 zeta w s + w^2); the speed chain (I, xi_I)
    # (s + lambda)(s + lambda_i). Compared as characteristic polynomials (zeta = 1 repeats roots).
    lam = gains.speed_rate
    chain = np.polymul([1, wi], [1, 2 * zeta * w, w * w]) if integral_rate else np.array([1, 2 * zeta * w, w * w])
    want = np.polymul(np.polymul(*[chain] * 2), np.polymul(*[chain] * 2))
    want = np.polymul(np.polymul(want, chain), np.polymul([1, lam], [1, wi]) if integral_rate else [1, lam])
    got = np.poly(a[1] - b[1] @ k)
    assert np.allclose(got, want, rtol=1e-3)
