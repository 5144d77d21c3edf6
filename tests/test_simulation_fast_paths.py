"""The simulate stage's fast paths against the computations they replace: the re-projection after the run
(one exact path evaluation + Taylor series) against Newton with the exact path at every step."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import metrics


@pytest.fixture(scope="module")
def lifted():
    """{name: lifted task joint path}: an open blended corner, an open and a closed circle."""
    return {name: api.load(scenario_path(name)).path for name in ("corner_g2", "circle_zero", "circle_periodic")}


def _near_path(path, count: int, error: float, seed: int):
    """(q (K, n) off the path by ~1 mrad normal to it, the true foot theta (K,), a start theta off by ~error)."""
    rng = np.random.default_rng(seed)
    lo, hi = path.domain
    foot = np.sort(rng.uniform(lo, hi, count))
    phi, dphi, _ = path.evaluate(foot)
    off = rng.normal(scale=1e-3, size=phi.shape)
    unit = dphi / np.linalg.norm(dphi, axis=1, keepdims=True)
    off -= np.sum(off * unit, axis=1, keepdims=True) * unit  # normal to Phi': foot is (locally) the projection
    start = np.clip(foot + error * rng.uniform(-1.0, 1.0, count), lo, hi)
    return phi + off, foot, start


@pytest.mark.parametrize("name", ["corner_g2", "circle_zero"])
@pytest.mark.parametrize("error", [1e-10, 1e-4])
def test_polish_equals_exact_newton(lifted, name, error):
    path = lifted[name]
    q, _, start = _near_path(path, 200, error, seed=3)
    start[-1] = path.domain[1] + error  # past the end of an open path: evaluated at the end
    fast = metrics.polish_projection(path, q, start)
    exact = metrics._polish_exact(path, q, start.copy(), 2)
    assert np.max(np.abs(fast[0] - exact[0])) <= 1e-14
    assert np.max(np.abs(fast[1] - exact[1])) <= 1e-13
    # independent: the answer is a projection, Phi'(theta)^T (q - Phi(theta)) = 0, Phi from the exact path
    phi, dphi, _ = path.evaluate(fast[0])
    assert np.max(np.abs(fast[1] - phi)) <= 1e-13
    residual = (np.sum(dphi * (q - phi), axis=1) / np.linalg.norm(dphi, axis=1))[:-1]  # the last started elsewhere
    assert np.max(np.abs(residual)) <= (1e-12 if error < 1e-8 else 1e-9)


def test_polish_mixes_taylor_and_exact_samples_and_keeps_closed_turns(lifted):
    """Small and large first steps in one call, breaks and the domain's ends inside the steps, theta one turn
    ahead on a closed path: every sample as the exact loop gives it, theta kept unwrapped."""
    path = lifted["circle_periodic"]
    assert path.closed
    lo, hi = path.domain
    q, foot, start = _near_path(path, 120, 1e-10, seed=5)
    start[::3] = foot[::3] + 1e-5  # large first steps
    special = np.array([lo, hi, *path.breaks, *path.kinks])
    q_s = path.evaluate(np.clip(special, lo, hi))[0] + 1e-4
    q = np.vstack([q, q_s])
    start = np.concatenate([start, special + 5e-9]) + (hi - lo)  # one turn ahead
    first = metrics._newton_step(path, q, start, *path.evaluate(metrics._wrap(path, start)))
    local = metrics._smooth_step(path, metrics._wrap(path, start), first - start)
    assert local.any() and (~local).any()
    fast = metrics.polish_projection(path, q, start)
    exact = metrics._polish_exact(path, q, start.copy(), 2)
    assert np.all(fast[0] > hi - 1e-6)  # still one turn ahead
    assert np.max(np.abs(fast[0] - exact[0])) <= 1e-14
    assert np.max(np.abs(fast[1] - exact[1])) <= 1e-13


def test_smooth_step_refuses_a_break_in_reach(lifted):
    path = lifted["corner_g2"]
    b = [x for x in path.breaks if path.domain[0] < x < path.domain[1]][0]
    start = np.array([b - 1e-9, b - 3e-9, b, b + 1e-9])
    step = np.array([2e-9, 1e-9, 1e-9, 1e-9])
    assert metrics._smooth_step(path, start, step).tolist() == [False, True, False, True]


def test_table_of_a_lifted_path_equals_the_pinocchio_one(lifted, monkeypatch):
    """The controller's table of a lifted path, its Phi' and Phi'' from the batched chain kinematics, equals the
    table built with one Pinocchio call per point."""
    from pathmotion.control import PathTable
    from pathmotion.robot import kinematics

    path = lifted["corner_g2"]
    fast = PathTable.from_path(path)
    with monkeypatch.context() as m:
        m.setattr(kinematics, "SERIAL_BATCH_MIN", 10**9)
        reference = PathTable.from_path(path)
    assert np.array_equal(fast.grid, reference.grid)
    scale = np.max(np.abs(reference.coeffs))
    assert np.max(np.abs(fast.coeffs - reference.coeffs) / scale) <= 1e-12


def test_design_keeps_the_riccati_knots_only(lifted, tmp_path):
    """The sampled design keeps P at its knots (the controller reads K only); P on the grid, built on demand, and
    the cache entry's knots give the same stack, and the entry holds no grid-sized P."""
    from pathmotion.control import OrbitalGains, design_cache
    from pathmotion.control.orbital import _interpolate

    path = lifted["corner_g2"]
    profile = api.plan_scenario(api.load(scenario_path("corner_g2"))).profile
    design = design_cache.cached_design(path, profile, OrbitalGains(), 0.004, 1, folder=tmp_path)
    assert "riccati" not in vars(design)  # nothing built on the grid yet
    m, d = len(design.theta), design.gain.shape[2]
    p = design.riccati
    assert p.shape == (m, d, d)
    for seg in design.riccati_knots:
        inside = slice(seg.start, seg.stop)
        assert np.array_equal(p[inside], _interpolate(seg.knots, design.theta[inside], seg.values))
        assert len(seg.knots) < (seg.stop - seg.start) / 2  # the 4 ms samples are sparser than the table
    outside = np.ones(m, bool)
    for seg in design.riccati_knots:
        outside[seg.start:seg.stop] = False
    assert not np.any(p[outside])
    cached = design_cache.cached_design(path, profile, OrbitalGains(), 0.004, 1, folder=tmp_path)
    assert cached is not design and np.array_equal(cached.riccati, p) and np.array_equal(cached.gain, design.gain)
    (entry,) = tmp_path.glob("design-*.npz")
    with np.load(entry) as z:
        assert "riccati" not in z.files and z["riccati_values"].size < m * d * d / 2
