"""Each end rule of the closed loop on hand-made samples: the verdict, where it starts, and the interpolated
crossing times (checked against the linear interpolation written out by hand)."""

import numpy as np
import pytest

from pathmotion.simulation import Failure, SimulationSettings
from pathmotion.simulation.end_rules import (Arrival, Deviation, Diverged, EndCrossing, Laps, LeftRange, RestArrival,
                                             Sample, Timeout, end_rules)

Q = np.zeros(6)


def sample(t=0.1, theta=0.5, deviation=0.0, along=0.0, speed2=1.0, ok=True, q=Q, previous=0.49, arrived=False, k=25):
    return Sample(k, t, theta, 1.0, deviation, along, speed2, ok, q, Q, previous, arrived)


def test_diverged_on_the_state_and_on_a_non_finite_torque():
    rule = Diverged()
    assert rule.check(sample()) is None
    f = rule.check(sample(ok=False, t=0.2, theta=0.7))
    assert isinstance(f, Failure) and (f.reason, f.t, f.theta) == ("diverged", 0.2, 0.7)
    assert rule.check_torque(sample(), Q, Q, True, False) is None
    f = rule.check_torque(sample(), np.full(6, np.nan), Q, False, False)
    assert f.reason == "diverged" and "non-finite torque" in f.message


def test_end_crossing_interpolates_the_crossing_and_drops_the_sample():
    rule = EndCrossing(end=1.0, sample_time=0.004)
    assert rule.check(sample(theta=0.999)) is None
    # previous 0.99, extended theta 1.0 + 0.01 = 1.01: the end is crossed half-way through the sample
    a = rule.check(sample(t=0.4, theta=1.0, along=0.01, previous=0.99))
    assert a == Arrival(pytest.approx(0.4 - 0.002), stop=True, keep=False)


def test_left_range_past_either_end_by_more_than_the_threshold():
    rule = LeftRange(0.0, 1.0, threshold=0.05, speed_eps=1e-12)
    assert rule.check(sample(theta=0.5, along=1.0)) is None  # inside the domain: never
    assert rule.check(sample(theta=1.0, along=0.04)) is None  # 0.04 rad past the end
    f = rule.check(sample(theta=1.0, along=0.03, speed2=4.0))  # 0.03 * |Phi'| = 0.06 rad
    assert f.reason == "left_path_range" and "past its end" in f.message and "0.06" in f.message
    assert rule.check(sample(theta=0.0, along=-0.06)).reason == "left_path_range"
    assert rule.check(sample(theta=0.0, along=0.06)) is None  # back inside
    assert rule.check(sample(theta=1.0, along=0.06, speed2=1e-13)) is None  # Phi' = 0: along means nothing


def test_deviation_above_the_threshold():
    rule = Deviation(0.05)
    assert rule.check(sample(deviation=0.05)) is None
    f = rule.check(sample(deviation=0.0501))
    assert f.reason == "deviation" and "0.0501" in f.message


def test_rest_arrival_interpolates_the_ball_entry_credits_the_plan_and_settles():
    q_end = np.ones(6)
    rule = RestArrival(q_end, tolerance=1e-3, from_theta=0.9, planned=2.0, plan_arrival=1.9, settle_time=0.1,
                       sample_time=0.01)
    assert rule.check(sample(theta=0.5, q=q_end)) is None  # in the ball but not in the end's stretch
    assert rule.check(sample(t=1.0, theta=0.95, q=q_end - 3e-3)) is None  # 3 mrad away
    a = rule.check(sample(t=1.01, theta=0.97, q=q_end - 0.5e-3))  # 0.5 mrad: entered at 1.0 + 0.01 * 2/2.5
    assert a.stop is False and a.time == pytest.approx(1.0 + 0.01 * 0.8 + 0.1)
    assert rule.check(sample(t=1.10, theta=0.99, q=q_end)) is None  # settling
    assert rule.check(sample(t=1.11, theta=1.0, q=q_end)) == Arrival(None)


def test_laps_ends_a_closed_path_with_the_mean_period():
    rule = Laps(lo=0.0, length=2.0, laps=3, sample_time=0.01)
    assert rule.check(sample(theta=5.99)) is None
    a = rule.check(sample(t=3.0, theta=6.02, previous=5.98))  # 3 turns crossed half-way through the sample
    assert a.stop and a.keep and a.time == pytest.approx((3.0 - 0.005) / 3)


def test_timeout_only_before_arrival():
    rule = Timeout(budget=4.0, domain=(0.0, 1.0))
    assert rule.check(sample(t=3.99)) is None
    assert rule.check(sample(t=4.0, arrived=True)) is None
    f = rule.check(sample(t=4.0, theta=0.3))
    assert f.reason == "timeout" and "4 s" in f.message


@pytest.mark.parametrize("closed, moving", [(True, False), (False, False), (False, True)])
def test_the_rule_list_per_kind_of_path(closed, moving):
    from pathmotion.control import PathTable
    from pathmotion.joint_path import SplineJointPath
    from pathmotion.planning.profile import Profile

    pts = np.array([[0.0] * 6, [0.5, 0.2, 0.1, 0.0, 0.3, 0.1], [1.0, 0.1, 0.3, 0.2, 0.1, 0.4]])
    table = PathTable.from_path(SplineJointPath.from_waypoints(pts), 101)
    if closed:
        table = PathTable(table.grid, table.coeffs, table.domain, True, table.n)
    profile = Profile(np.array([0.0, 0.5, 1.0]), np.array([1.0 if closed or moving else 0.0, 2.0, 1.0 if moving or
                                                           closed else 0.0]))
    kinds = [type(r).__name__ for r in end_rules(table, profile, table.evaluate_scalar(1.0)[0], 4.0,
                                                 SimulationSettings())]
    if closed:
        assert kinds == ["Diverged", "Deviation", "Laps", "Timeout"]
    else:
        assert kinds == ["Diverged", *(["EndCrossing"] if moving else []), "LeftRange", "Deviation", "RestArrival",
                         "Timeout"]
