"""The orbital controller designed for its sample time: the transverse linearization sampled with a
zero-order hold and the command applied one sample late, and a periodic discrete Riccati design on it.

Independent check: the closed loop of the SAMPLED linearization -- integrated here with RK4 through each hold
interval with A(theta*(t)), B(theta*(t)) varying inside it, not the design's frozen-midpoint matrix
exponential -- with the gains the controller reads (``gain_at`` the sample's theta) and the delay, over one
period of the thesis' periodic circle: the monodromy matrix must have spectral radius < 1. The gains designed
in continuous time fail that test at 12 ms with the delay (the issue's divergence)."""

import dataclasses

import numpy as np
import pytest

from pathmotion import api
from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable
from pathmotion.control.orbital import integral_size, with_integral
from pathmotion.control.riccati import solve_discrete_riccati, with_delay
from pathmotion.control.transverse import transverse_linearization
from pathmotion.planning import plan
from pathmotion.scenarios import scenario_path

from control_reference import discretize, sampled_cost_van_loan

#: RK4 steps per hold interval of the independent sampled model.
SUBSTEPS = 4


@pytest.fixture(scope="module")
def periodic_circle():
    setup = api.load(scenario_path("circle_periodic"))
    result = plan(setup.path, setup.robot, dataclasses.replace(setup.plan_settings, baselines=False))
    return PathTable.from_path(setup.path, 801), result.profile


def sampled_transitions(design: OrbitalDesign, ts: int):
    """(theta_k (N,), Phi_k (N, d, d), Gamma_k (N, d, n)) of the transverse linearization with its integral
    states over each hold interval of one period, by RK4 on d/dt [Phi, Gamma] = A [Phi, Gamma] + [0, B]."""
    lookup, table = design.profile, design.table
    period = lookup.duration
    count = int(round(period / ts))
    h = period / count / SUBSTEPS
    t = np.linspace(0.0, period, 2 * count * SUBSTEPS + 1)  # RK4 stages at the substep ends and middles
    theta = lookup.profile.state_at_time(t)[0]
    theta = np.maximum.accumulate(theta + 1e-12 * np.arange(len(theta)))
    a, b = with_integral(*transverse_linearization(table, design.basis, lookup, theta), integral_size(design.gains,
                                                                                                       table.n))
    d, n = b.shape[1], b.shape[2]
    phis, gammas = np.empty((count, d, d)), np.empty((count, d, n))
    for k in range(count):
        phi, gam = np.eye(d), np.zeros((d, n))
        for s in range(SUBSTEPS):
            i = 2 * (k * SUBSTEPS + s)

            def f(j, p, g):
                return a[j] @ p, a[j] @ g + b[j]

            k1 = f(i, phi, gam)
            k2 = f(i + 1, phi + 0.5 * h * k1[0], gam + 0.5 * h * k1[1])
            k3 = f(i + 1, phi + 0.5 * h * k2[0], gam + 0.5 * h * k2[1])
            k4 = f(i + 2, phi + h * k3[0], gam + h * k3[1])
            phi = phi + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            gam = gam + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        phis[k], gammas[k] = phi, gam
    return theta[::2 * SUBSTEPS][:count], phis, gammas


def gain_at(design: OrbitalDesign, theta: float) -> np.ndarray:
    """K(theta) (n, 2n-1), linear in theta between the design's grid points (the test's own lookup, independent of
    the compiled kernel's)."""
    theta = design.table.wrap(theta)
    grid = design.theta
    i = min(max(int(np.searchsorted(grid, theta, side="right")) - 1, 0), len(grid) - 2)
    w = (theta - grid[i]) / (grid[i + 1] - grid[i])
    return design.gain[i] + w * (design.gain[i + 1] - design.gain[i])


def monodromy_radius(design: OrbitalDesign, ts: float, delay: int) -> float:
    """Spectral radius of one period of x_{k+1} = Phi x_k + Gamma u_{k-delay}, u_k = -K(theta_k) (x_k, commands in
    flight) with the design's scheduled gain; a gain without columns for the commands in flight ignores them."""
    theta, phis, gammas = sampled_transitions(design, ts)
    d, n = gammas.shape[1], gammas.shape[2]
    size = d + delay * n
    total = np.eye(size)
    for th, phi, gam in zip(theta, phis, gammas):
        gain = gain_at(design, th)
        k_full = np.zeros((n, size))
        k_full[:, :gain.shape[1]] = gain
        step = np.zeros((size, size))
        step[:d, :d] = phi
        if delay:
            step[:d, d:d + n] = gam
            for j in range(delay - 1):
                step[d + j * n:d + (j + 1) * n, d + (j + 1) * n:d + (j + 2) * n] = np.eye(n)
            step[size - n:, :] = -k_full
        else:
            step[:d, :] -= gam @ k_full
        total = step @ total
    return float(np.max(np.abs(np.linalg.eigvals(total))))


@pytest.mark.parametrize("ts", [0.001, 0.004, 0.012])
def test_the_sampled_design_stabilizes_the_sampled_linearization_with_a_delay(periodic_circle, ts):
    table, profile = periodic_circle
    design = OrbitalDesign.build(table, profile, OrbitalGains(), sample_time=ts, delay=1)
    assert design.gain.shape[2] == 3 * table.n - 1 + table.n  # (xi, z, z_dot, I) and one command in flight
    radius = monodromy_radius(design, ts, delay=1)
    assert radius < 1.0, radius


def test_the_continuous_design_does_not_at_12_ms_with_a_delay(periodic_circle):
    """The test above can fail: the gains designed in continuous time, applied at 12 ms one sample late."""
    table, profile = periodic_circle
    design = OrbitalDesign.build(table, profile, OrbitalGains())
    assert monodromy_radius(design, 0.012, delay=1) > 1.0


def test_discrete_riccati_on_a_double_integrator_matches_the_algebraic_solution():
    """Constant (Phi, Gamma) over a long horizon: the recursion converges to scipy's discrete algebraic Riccati
    solution, and the periodic form (any period) gives it too."""
    from scipy.linalg import solve_discrete_are

    a = np.array([[[0.0, 1.0], [0.0, 0.0]]] * 400)
    b = np.array([[[0.0], [1.0]]] * 400)
    phi, gam = with_delay(*discretize(a, b, 0.01), 1)
    q = np.zeros((400, 3, 3))
    q[:, 0, 0], q[:, 1, 1] = 1.0, 0.1
    r = np.array([[0.01]])
    care = solve_discrete_are(phi[0], gam[0], q[0], r)
    p, k = solve_discrete_riccati(phi, gam, q, r, np.zeros((3, 3)))
    assert np.allclose(p[0], care, rtol=1e-6, atol=1e-9)
    p2, _ = solve_discrete_riccati(phi[:50], gam[:50], q[:50], r, np.zeros((3, 3)), periodic=True)
    assert np.allclose(p2[0], care, rtol=1e-6, atol=1e-9)
    loop = phi[0] - gam[0] @ k[0]
    assert np.max(np.abs(np.linalg.eigvals(loop))) < 1.0


def test_the_integral_does_not_wind_up_while_the_torque_saturates(irb140):
    """Conditional integration: a sample whose torque is clipped leaves the integral where it was; the same
    sample with room to spare advances it by Ts (z, I)."""
    from pathmotion.control import OrbitalController
    from pathmotion.lift.joint_path import SplineJointPath
    from pathmotion.planning.profile import Profile

    waypoints = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0], [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                          [1.0, 0.1, 0.2, -0.2, 0.4, 1.2]])
    design = OrbitalDesign.build(PathTable.from_path(SplineJointPath.from_waypoints(waypoints)),
                                 Profile(np.array([0.0, 0.2, 0.8, 1.0]), np.array([0.0, 0.6, 0.6, 0.0])))
    phi, dphi, _ = design.table.evaluate_scalar(0.5)
    q, qd = phi + np.array([0.0, 0.004, -0.003, 0.002, 0.0, 0.001]), dphi * np.sqrt(0.6)
    runs = {}
    for name, limit in (("room", 1e6), ("clipped", 1e-3)):
        c = OrbitalController(design, irb140, 0.004)
        c.clock, c.theta, c.theta_dot = None, 0.5, float(np.sqrt(0.6))
        c.torque_limit = np.full(6, limit)
        c(1.0, q, qd)
        runs[name] = (c.xi.copy(), c.x_perp.copy())
    xi_room, x_perp = runs["room"]
    m = 5
    assert np.allclose(xi_room[:m], 0.004 * x_perp[6:6 + m]) and np.any(np.abs(xi_room) > 1e-9)
    assert np.allclose(runs["clipped"][0], 0.0, atol=1e-15)


def test_the_sampled_cost_is_the_integral_of_the_continuous_one():
    """W of :func:`sampled_cost` against (a) the closed form for an integrator, x(s) = x + s u:
    int (x + s u)^2 ds = h x^2 + h^2 x u + h^3 u^2 / 3, and (b) composite Simpson quadrature of
    [Phi(s), Gamma(s)]^T Q [Phi(s), Gamma(s)] over 400 sub-intervals for a random 4-state, 2-input system."""
    from scipy.linalg import expm

    from pathmotion.control.riccati import sampled_cost

    h = 0.01
    phi, gam, w = sampled_cost(np.zeros((1, 1, 1)), np.ones((1, 1, 1)), np.ones((1, 1, 1)), h)
    assert np.allclose(w[0], [[h, h * h / 2], [h * h / 2, h**3 / 3]], rtol=1e-10, atol=0)
    assert np.allclose(phi[0], 1.0) and np.allclose(gam[0], h)
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(1, 4, 4)) * 20, rng.normal(size=(1, 4, 2))
    root = rng.normal(size=(4, 4))
    q = (root @ root.T * 1e4)[None]
    phi, gam, w = sampled_cost(a, b, q, h)
    block = np.zeros((6, 6))
    block[:4, :4], block[:4, 4:] = a[0], b[0]
    s = np.linspace(0.0, h, 401)
    vals = np.array([(lambda e: e[:4].T @ q[0] @ e[:4])(expm(block * si)) for si in s])
    simpson = h / 400 / 3 * (vals[0] + vals[-1] + 4 * vals[1:-1:2].sum(0) + 2 * vals[2:-1:2].sum(0))
    assert np.allclose(w[0], simpson, rtol=1e-8, atol=1e-8 * np.max(np.abs(simpson)))
    ex = expm(block * h)
    assert np.allclose(phi[0], ex[:4, :4]) and np.allclose(gam[0], ex[:4, 4:])


@pytest.mark.parametrize("delay", [0, 1])
def test_the_sampled_gains_tend_to_the_continuous_ones_on_a_triple_integrator(delay):
    """One transverse direction with integral action (xi' = z, z'' = dv) and the default weights: the sampled
    design's gain on (xi, z, z_dot) (scipy's discrete algebraic Riccati solution on the exactly sampled cost,
    the delay in the model) approaches the continuous LQR gain, to first order in Ts: within 0.6 % at 0.1 ms."""
    from scipy.linalg import solve_continuous_are, solve_discrete_are

    from pathmotion.control.riccati import sampled_cost

    q = np.diag(OrbitalGains().chain_weights)
    a = np.diag([1.0, 1.0], 1)
    b = np.array([[0.0], [0.0], [1.0]])
    k_c = (b.T @ solve_continuous_are(a, b, q, np.eye(1)))[0]
    errors = []
    for ts in (0.001, 0.0001):
        phi, gam, w = sampled_cost(a[None], b[None], q[None], ts)
        if delay:
            f, g = with_delay(phi, gam, 1)
            p = solve_discrete_are(f[0], g[0], w[0], np.eye(1) * ts)
            k = np.linalg.solve(ts + g[0].T @ p @ g[0], g[0].T @ p @ f[0])[0, :3]
        else:
            p = solve_discrete_are(phi[0], gam[0], w[0][:3, :3], np.eye(1) * ts + w[0][3:, 3:], s=w[0][:3, 3:])
            k = np.linalg.solve(ts + w[0][3:, 3:] + gam[0].T @ p @ gam[0], gam[0].T @ p @ phi[0] + w[0][3:, :3])[0]
        errors.append(np.max(np.abs(k / k_c - 1.0)))
    assert errors[1] < 0.006 and errors[1] < 0.15 * errors[0], errors


def test_the_sampled_design_tends_to_the_continuous_design(periodic_circle):
    """The sampled design on the thesis circle (no delay) against the continuous one, column by column relative to
    the largest continuous gain of that column: the difference shrinks to first order in Ts (measured 9.5 % at
    2 ms, 2.5 % at 0.5 ms, 0.5 % at 0.1 ms: the discrete gain holds the designed poles on the sampled system,
    which takes about (1 - 50 Ts) of the continuous gain)."""
    table, profile = periodic_circle
    cont = OrbitalDesign.build(table, profile, OrbitalGains())
    scale = np.max(np.abs(cont.gain), axis=(0, 1))
    errors = []
    for ts in (0.002, 0.0005):
        sampled = OrbitalDesign.build(table, profile, OrbitalGains(), sample_time=ts, delay=0)
        errors.append(np.max(np.abs(sampled.gain - cont.gain) / scale))
    assert errors[1] < 0.035 and errors[1] < 0.35 * errors[0], errors


def test_the_series_sampled_cost_equals_van_loans_exponential():
    """sampled_cost (Taylor series of W and e^(C h) on 2^-s of the hold, then doubled) against the reference
    sampled_cost_van_loan (scipy.linalg.expm of Van Loan's doubled block, one sample at a time) on a stack whose
    |C h| runs from 1e-5 to 40 (no doubling to seven), with a zero system, a nilpotent chain and hold lengths
    that differ per sample: Phi, Gamma and W within 1e-12 of each sample's largest entry (measured 6e-14)."""
    from pathmotion.control.riccati import sampled_cost

    rng = np.random.default_rng(11)
    scales = np.array([0.0, 1e-3, 0.1, 1.0, 10.0, 50.0, 300.0, 1000.0, 1.0])
    a = rng.normal(size=(len(scales), 7, 7)) * scales[:, None, None]
    a[-1] = np.diag(np.ones(6), 1) * 40.0  # nilpotent: the series ends by itself
    b = rng.normal(size=(len(scales), 7, 3))
    root = rng.normal(size=(len(scales), 7, 7))
    q = root @ np.transpose(root, (0, 2, 1)) * np.logspace(-3, 6, len(scales))[:, None, None]
    h = rng.uniform(0.001, 0.012, len(scales))
    for ts in (0.004, h):
        for got, want in zip(sampled_cost(a, b, q, ts), sampled_cost_van_loan(a, b, q, ts)):
            scale = np.max(np.abs(want), axis=(1, 2), keepdims=True)
            assert np.all(np.abs(got - want) <= 1e-12 * scale)


def test_the_series_truncation_is_certified():
    """series_terms(theta) keeps the least number of terms whose tail sum_(n>p) theta^n / (n+1)! (summed here
    directly to n = 60) is at most SERIES_TOLERANCE: one term fewer would not be."""
    from math import factorial

    from pathmotion.control.riccati import SERIES_TOLERANCE, series_terms

    def tail(theta, p):
        return sum(theta**n / factorial(n + 1) for n in range(p + 1, 60))

    for theta in (1e-6, 0.01, 0.2, 0.5, 2.0):
        p = series_terms(theta)
        assert tail(theta, p) <= SERIES_TOLERANCE
        assert p == 0 or tail(theta, p - 1) > SERIES_TOLERANCE


@pytest.mark.parametrize("delay", [0, 1])
def test_the_design_equals_the_van_loan_reference_design(monkeypatch, delay):
    """The whole sampled design of the IRB140 spline (gains K and Riccati P on every table point) with the series
    sampled cost against the same design built with the reference sampled_cost_van_loan: within 1e-9 of each
    gain column's largest value (the two differ by round-off: measured 4e-13 on K, 6e-14 on P)."""
    from pathmotion.control import orbital
    from pathmotion.lift.joint_path import SplineJointPath

    from tests.planning_paths import CONTROL_WAYPOINTS, trapezoid

    table = PathTable.from_path(SplineJointPath.from_waypoints(CONTROL_WAYPOINTS), 801)
    fast = OrbitalDesign.build(table, trapezoid(), OrbitalGains(), sample_time=0.004, delay=delay)
    monkeypatch.setattr(orbital, "sampled_cost", sampled_cost_van_loan)
    reference = OrbitalDesign.build(table, trapezoid(), OrbitalGains(), sample_time=0.004, delay=delay)
    gain_scale = np.max(np.abs(reference.gain), axis=(0, 1))
    assert np.all(np.abs(fast.gain - reference.gain) <= 1e-9 * gain_scale)
    assert np.max(np.abs(fast.riccati - reference.riccati)) <= 1e-9 * np.max(np.abs(reference.riccati))
    assert fast.zones == reference.zones
