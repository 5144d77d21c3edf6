"""The IRB140 acceleration figures of the limits file, derived from the torque and armature estimates (benchmarks/
irb140_acceleration_estimates.py, docs/robot.md): the torque-allowed single-axis accelerations with the rated payload,
checked here against recursive Newton-Euler (an algorithm independent of the mass matrix the derivation uses), and
the foundation moments they cause, checked against the static moment of the arm's centre of mass and ABB's figure."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import linprog

from benchmark_modules import load_benchmark
from pathmotion.robot import jacobian, load_robot, rnea

bench = load_benchmark("irb140_acceleration_estimates")


@pytest.fixture(scope="module")
def rated():
    return load_robot("irb140", payload=bench.RATED)


def test_the_files_figures_follow_the_stated_rule(rated):
    # 300 configurations instead of the script's 1000: the 90th percentile moves by less than one rounding step
    derived = bench.estimates(rated, bench.configurations(300, seed=3))
    np.testing.assert_allclose(rated.limits.acceleration, derived, atol=bench.ROUND_TO)
    for name in rated.limits.names:
        assert rated.limits.sources[name]["acceleration"] == "estimate"


def test_single_axis_bound_puts_one_joint_exactly_at_its_torque_limit(rated):
    torque = rated.limits.torque
    for q in bench.configurations(5, seed=7):
        g = rnea(rated, q, np.zeros(6), np.zeros(6))
        M = np.column_stack([rnea(rated, q, np.zeros(6), e) - g for e in np.eye(6)])
        bound = bench.single_axis_acceleration(M, g, torque)
        for i in range(6):
            taus = [rnea(rated, q, np.zeros(6), s * bound[i] * np.eye(6)[i]) for s in (1.0, -1.0)]
            ratio = [np.max(np.abs(t) / torque) for t in taus]
            assert min(ratio) == pytest.approx(1.0, abs=1e-9)  # the better direction touches a limit ...
            assert max(ratio) >= 1.0 - 1e-9  # ... and the worse one does not stay inside them


def test_tcp_acceleration_bound_is_feasible_and_tight(rated):
    q = bench.configurations(1, seed=11)[0]
    M, g, Jv = bench.mass_matrix(rated, q), bench.gravity(rated, q), jacobian(rated, q)[:3]
    d = bench.DIRECTIONS[2]
    s = bench.tcp_acceleration(M, g, Jv, rated.limits.torque, d)
    assert s > 1.0
    # a certificate: a qdd reaching 0.999 s d has RNEA torques inside the limits; none reaches 1.01 s d
    n = 6
    res = linprog(np.zeros(n), A_ub=np.vstack([M, -M]), b_ub=np.r_[rated.limits.torque - g, rated.limits.torque + g],
                  A_eq=Jv, b_eq=0.999 * s * d, bounds=[(None, None)] * n, method="highs")
    assert res.status == 0
    tau = rnea(rated, q, np.zeros(6), res.x)
    assert np.all(np.abs(tau) <= rated.limits.torque * (1 + 1e-6))
    over = linprog(np.zeros(n), A_ub=np.vstack([M, -M]), b_ub=np.r_[rated.limits.torque - g, rated.limits.torque + g],
                   A_eq=Jv, b_eq=1.01 * s * d, bounds=[(None, None)] * n, method="highs")
    assert over.status == 2  # infeasible


def test_torque_and_armature_estimates_stay_below_abbs_tcp_figure_with_the_rated_payload(rated):
    # the documented finding: with 6 kg 0.1 m beyond the flange the torques allow well under 57 m/s^2
    acc, force = bench.tcp_table(rated, bench.configurations(20, seed=5))
    assert acc.max() < bench.ABB_TCP_ACCELERATION
    assert force.max() < bench.ABB_TCP_ACCELERATION
    # the file's box alone admits it at the reach on axis 1 (0.81 m to the wrist centre): the torques bind first
    assert rated.limits.acceleration[0] * 0.81 >= bench.ABB_TCP_ACCELERATION


def test_foundation_moment_at_rest_is_the_static_moment_of_the_moving_mass(rated):
    model, data = rated.model, rated.model.createData()
    for q in bench.configurations(4, seed=13):
        mxy, mz = bench.foundation_moments(rated, q, np.zeros(6), np.zeros(6))
        pin.centerOfMass(model, data, q)  # data.com[1], data.mass[1]: the subtree carried by joint 1
        assert mxy == pytest.approx(data.mass[1] * 9.81 * np.hypot(*data.com[1][:2]), rel=1e-9)
        assert mz == pytest.approx(0.0, abs=1e-9)


def test_the_files_accelerations_keep_the_foundation_within_abbs_loads(rated):
    loads = bench.foundation_table(rated, bench.configurations(40, seed=17))
    assert loads[..., 0].max() < bench.ABB_FOUNDATION_MXY
    assert loads[..., 1].max() <= bench.ABB_FOUNDATION_MZ * (1 + 1e-9)
