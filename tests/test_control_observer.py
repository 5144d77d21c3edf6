"""The orbital controller's disturbance observer (pathmotion/control/observer.py) and the design of its gain.

Independent checks: the scalar loop the gain is designed on closes with the designed poles e^(s Ts) (no observer,
nominal plant); on the nominal plant the observer adds only its own filter pole 1 - g (the model is right, so
there is nothing to estimate); the gain is the largest stable one over the stated inertia range (a slightly larger
gain is unstable inside it); on the IRB140, the estimate of a constant external torque converges to that torque,
also while the command saturates; and on the arm in closed loop the observer makes an unknown payload track,
while an observer designed for a narrower inertia range than the plant's makes a phantom payload oscillate."""

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest
from closed_loop_laps import orbital_lap, periodic_circle_plan
from scipy.linalg import solve_discrete_are

from pathmotion import defaults
from pathmotion.control import OrbitalGains
from pathmotion.control.observer import (ESTIMATE, DisturbanceObserver, _chain_step, chain_feedback, chain_loop,
                                         loop_radius, observer_gain, stationary_riccati)
from pathmotion.simulation import Plant, Realism

#: The designed closed-loop rates of one transverse direction (integral_rate, bandwidth twice) [1/s].
DESIGNED = np.array([defaults.ORBITAL_INTEGRAL_RATE, defaults.ORBITAL_BANDWIDTH, defaults.ORBITAL_BANDWIDTH])


def _without_estimate(a: np.ndarray) -> np.ndarray:
    keep = np.delete(np.arange(a.shape[0]), ESTIMATE)
    return a[np.ix_(keep, keep)]


def test_sampled_chain_closes_with_the_designed_poles():
    """No observer, nominal plant, 1 ms: the loop's decay rates -ln|lambda| / Ts are the designed 20, 40, 40 /s
    (the sampled LQR places e^(s Ts); the controller's rectangle-rule integral moves them by a few percent)."""
    ts = 0.001
    a00, _, a_s, _ = chain_loop(chain_feedback(OrbitalGains(), ts, 0, True), ts, 0)
    eig = np.linalg.eigvals(_without_estimate(a00 + a_s))
    rates = np.sort(-np.log(np.abs(eig[np.abs(eig) > 1e-9])) / ts)
    assert np.allclose(rates, np.sort(DESIGNED), rtol=0.05), rates


def test_continuous_chain_gains_are_the_clock_gains_and_the_sampled_ones_tend_to_them():
    gains = OrbitalGains()
    kp, kd, ki = gains.clock_gains
    assert np.allclose(chain_feedback(gains, 0.004, 2, False), [ki, kp, kd, 0.0, 0.0])
    sampled = chain_feedback(gains, 1e-4, 0, True)
    assert np.allclose(sampled, [ki, kp, kd], rtol=0.01), sampled


@pytest.mark.parametrize("delay", [0, 2])
def test_doubling_riccati_equals_scipy_with_cross_term_and_singular_delay_blocks(delay):
    rng = np.random.default_rng(delay)
    d, m = 3, 1
    a = np.eye(d) + 0.05 * rng.normal(size=(d, d))
    b = rng.normal(size=(d, m))
    a_aug = np.zeros((d + delay, d + delay))  # the delayed command: singular shift blocks
    a_aug[:d, :d] = a
    b_aug = np.zeros((d + delay, m))
    if delay:
        a_aug[:d, d] = b[:, 0]
        a_aug[d:-1, d + 1:] = np.eye(delay - 1)
        b_aug[-1, 0] = 1.0
    else:
        b_aug = b
    root = rng.normal(size=(d + delay + m, d + delay + m))
    joint = root @ root.T + 0.1 * np.eye(d + delay + m)  # [[Q, S], [S^T, R]] positive definite
    q, s, r = joint[:-m, :-m], joint[:-m, -m:], joint[-m:, -m:]
    expected = solve_discrete_are(a_aug, b_aug, q, r, s=s)
    assert np.allclose(stationary_riccati(a_aug, b_aug, q, r, s), expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_loop_map_is_bilinear_in_the_gain_and_the_inverse_inertia_ratio():
    k = chain_feedback(OrbitalGains(), 0.004, 1, True)
    a00, ag, a_s, ags = chain_loop(k, 0.004, 1)
    rng = np.random.default_rng(3)
    for g, r in zip(rng.uniform(0, 1, 4), rng.uniform(0.3, 3, 4)):
        direct = np.column_stack([_chain_step(e, k, 0.004, 1, g, 1 / r) for e in np.eye(a00.shape[0])])
        assert np.allclose(a00 + g * ag + (a_s + g * ags) / r, direct, atol=1e-12)


@pytest.mark.parametrize("delay", [0, 1, 2])
def test_on_the_nominal_plant_the_observer_only_adds_its_filter_pole(delay):
    ts, g = 0.004, 0.37
    a00, ag, a_s, ags = chain_loop(chain_feedback(OrbitalGains(), ts, delay, True), ts, delay)
    without = np.linalg.eigvals(_without_estimate(a00 + a_s))
    with_observer = np.linalg.eigvals(a00 + g * ag + a_s + g * ags)
    expected = np.concatenate([without, [1.0 - g]])
    # the delay's shift blocks give a multiple eigenvalue at 0, which rounding splits into roots of size eps^(1/k)
    # (5.8e-5 at delay 2 on one CPU, 2e-10 on another): compare the characteristic polynomials, whose
    # coefficients are well-conditioned, not the roots
    got, want = np.poly(with_observer).real, np.poly(expected).real
    assert np.allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max()), (got, want)


@pytest.mark.parametrize("ts, delay", [(0.001, 0), (0.001, 2), (0.004, 0), (0.004, 1)])
def test_observer_gain_is_the_largest_stable_on_the_inertia_range(ts, delay):
    gains = OrbitalGains()
    g = observer_gain(gains, ts, delay)
    assert 0 < g < 1
    parts = chain_loop(chain_feedback(gains, ts, delay, True), ts, delay)
    ratios = np.geomspace(1 / gains.observer_range, gains.observer_range, 401)
    assert np.max(loop_radius(parts, g, ratios)) < 1.0
    assert np.max(loop_radius(parts, min(1.0, g * 1.02 + 1e-3), ratios)) > 1.0


def test_observer_gain_shrinks_with_delay_and_range_and_is_off_where_the_loop_alone_fails():
    gains = OrbitalGains()
    assert observer_gain(gains, 0.004, 0) > observer_gain(gains, 0.004, 1)
    assert observer_gain(gains, 0.001, 1) > observer_gain(gains, 0.001, 2)
    assert observer_gain(dataclasses.replace(gains, observer_range=2.0), 0.004, 1) > observer_gain(gains, 0.004, 1)
    assert observer_gain(dataclasses.replace(gains, observer_range=math.inf), 0.001, 0) == 0.0
    assert observer_gain(gains, 0.012, 2) == 0.0  # the sampled loop alone is not stable over [1/3, 3] there


@pytest.mark.parametrize("delay, limit_scale", [(0, None), (1, None), (1, 0.5)])
def test_observer_estimates_a_constant_external_torque_without_winding_up(irb140, delay, limit_scale):
    """The IRB140 held at rest by a PD law through the nominal model, a constant external torque on every joint,
    the command ``delay`` samples late: the estimate converges to minus that torque (delta = tau_applied - model
    torque = -external). With every limit at half the torque the hold needs, the commands saturate throughout;
    the estimate uses the applied (saturated) torque and still converges, instead of winding up."""
    ts = 0.004
    q0 = np.array([0.0, 0.3, -0.2, 0.0, 0.5, 0.0])
    external = np.array([-20.0, 15.0, -10.0, 1.5, -2.0, 0.5])
    plant = Plant.from_robot(irb140, Realism())
    limit = plant.torque_limit.copy()
    if limit_scale is not None:
        hold = pin.computeGeneralizedGravity(irb140.model, irb140.model.createData(), q0) - external
        limit = limit_scale * np.abs(hold)
    observer = DisturbanceObserver(irb140.model, ts, 0.5, delay, limit)
    data = irb140.model.createData()
    q, qd, queue = q0.copy(), np.zeros(6), []
    for _ in range(150):
        observer.measure(q, qd)
        v = -400.0 * (q - q0) - 40.0 * qd
        queue.append(observer.command(pin.rnea(irb140.model, data, q, qd, v)))
        applied = np.clip(queue.pop(0) if len(queue) > delay else queue[0], -limit, limit)
        q, qd = plant.step(q, qd, applied + external, ts, 4)
    assert np.allclose(observer.estimate, -external, rtol=0.02, atol=0.02 * np.max(np.abs(external))), \
        observer.estimate


@pytest.fixture(scope="module")
def periodic_circle():
    return periodic_circle_plan()


def test_unknown_payload_tracks_with_the_observer_and_not_without(periodic_circle):
    """One lap of the thesis circle at 4 ms with a 6 kg payload the controller does not know (robustness matrix:
    0.50 mm with the observer, 1.92 mm without)."""
    setup, profile = periodic_circle
    realism = Realism(payload_mass=defaults.REALISTIC_PAYLOAD_MASS)
    on = orbital_lap(setup, profile, realism)
    off = orbital_lap(setup, profile, realism, gains=OrbitalGains(observer_range=math.inf))
    assert on["path_accuracy_m"] < defaults.PATH_TOLERANCE < off["path_accuracy_m"], (on, off)


def test_an_observer_designed_for_too_narrow_an_inertia_range_makes_a_phantom_payload_oscillate(periodic_circle):
    """The controller believes in a 6 kg payload the arm does not carry: the wrist's inertia is 0.39x the model's.
    Designed for [1/3, 3] (the default) the loop tracks (robustness matrix: 0.26 mm); designed for [1/2, 2] the
    observer's gain is larger (0.79 per sample against 0.38) and the loop oscillates until the torque saturates."""
    setup, profile = periodic_circle
    robust = orbital_lap(setup, profile, believed=defaults.REALISTIC_PAYLOAD_MASS)
    narrow = orbital_lap(setup, profile, believed=defaults.REALISTIC_PAYLOAD_MASS,
                         gains=OrbitalGains(observer_range=2.0))
    assert robust["path_accuracy_m"] < defaults.PATH_TOLERANCE and robust["saturation_time_s"] == 0.0, robust
    assert narrow["max_commanded_torque_ratio"] > 1.0 and narrow["saturation_time_s"] > 0.0, narrow


@pytest.mark.parametrize("value", [0.5, 0.0, -1.0, float("nan")])
def test_observer_range_below_one_is_refused(value):
    from pathmotion.errors import SimulationError

    with pytest.raises(SimulationError, match="observer_range"):
        OrbitalGains(observer_range=value)
