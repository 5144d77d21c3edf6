"""Each end rule of the closed loop on hand-made samples: the verdict, where it starts, and the interpolated
crossing times (checked against the linear interpolation written out by hand)."""

import numpy as np
import pytest

from pathmotion.simulation import Failure, SimulationSettings
from pathmotion.simulation.end_rules import (Arrival, Diverged, EndCrossing, JointTolerance, Laps, LeftRange,
                                             PathTolerance, Sample, Saturation, TcpArrival, Timeout, end_rules,
                                             plan_arrival_time)

Q = np.zeros(6)


def sample(t=0.1, theta=0.5, deviation=0.0, along=0.0, speed2=1.0, ok=True, q=Q, previous=0.49, arrived=False, k=25,
           distance=0.0, to_end=1.0):
    return Sample(k, t, theta, 1.0, deviation, along, speed2, ok, q, Q, previous, arrived, distance, to_end)


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


def test_joint_tolerance():
    rule = JointTolerance(0.05)
    assert rule.check(sample(deviation=0.05)) is None
    f = rule.check(sample(deviation=0.0501))
    assert f.reason == "joint_tolerance" and "0.0501" in f.message
    assert (f.value, f.limit, f.unit) == (0.0501, 0.05, "rad")


def test_path_tolerance_reports_one_excursion_where_it_started_and_how_far():
    rule = PathTolerance(1e-3)
    assert rule.check(sample(t=0.10, distance=1e-3)) is None  # on the tolerance: inside
    assert rule.check(sample(t=0.11, theta=0.6, distance=2e-3)) is None  # left: the excursion is under way
    assert rule.check(sample(t=0.12, theta=0.7, distance=11.7e-3)) is None
    assert rule.check(sample(t=0.13, theta=0.8, distance=5e-3)) is None
    f = rule.check(sample(t=0.14, theta=0.9, distance=0.5e-3))  # back: reported
    assert (f.reason, f.t, f.theta, f.value, f.limit, f.unit) == ("path_tolerance", 0.11, 0.6, 11.7e-3, 1e-3, "m")
    assert "11.7 mm" in f.message and "t = 0.12 s" in f.message
    open_rule = PathTolerance(1e-3)
    open_rule.check(sample(t=0.2, theta=0.3, distance=3e-3))
    f = open_rule.finish(sample(t=0.3))  # the run ends during the excursion
    assert (f.t, f.value) == (0.2, 3e-3)
    assert PathTolerance(1e-3).finish(sample()) is None


def test_saturation_only_for_a_stretch_longer_than_the_limit():
    rule, ts, tau = Saturation(limit=0.02, sample_time=0.004), 0.004, np.ones(6)
    for k in range(5):  # 5 samples = 0.02 s: at the limit, not over it
        assert rule.check_torque(sample(t=k * ts), 3 * tau, tau, True, True) is None
    assert rule.check_torque(sample(t=5 * ts), tau, tau, True, False) is None
    for k in range(6):  # 6 samples = 0.024 s
        assert rule.check_torque(sample(t=(10 + k) * ts, theta=0.4), 2 * tau, tau, True, True) is None
    f = rule.check_torque(sample(t=16 * ts), tau, tau, True, False)
    assert (f.reason, f.t, f.theta, f.unit) == ("saturation", 10 * ts, 0.4, "s")
    assert f.value == pytest.approx(0.024) and "2 x the limit" in f.message
    rule.check_torque(sample(t=1.0), 2 * tau, tau, True, True)
    assert rule.finish(sample(t=1.004)) is None  # one sample


def test_tcp_arrival_interpolates_the_ball_entry_credits_the_plan_and_measures_the_settling():
    rule = TcpArrival(tolerance=1e-3, from_theta=0.9, planned=2.0, plan_arrival=1.9, settle_time=0.1,
                      sample_time=0.01)
    assert rule.check(sample(theta=0.5, to_end=0.0)) is None  # in the ball but not in the end's stretch
    assert rule.check(sample(t=1.0, theta=0.95, to_end=3e-3)) is None  # 3 mm away
    a = rule.check(sample(t=1.01, theta=0.97, to_end=0.5e-3))  # 0.5 mm: entered at 1.0 + 0.01 * 2/2.5
    assert a.stop is False and a.time == pytest.approx(1.0 + 0.01 * 0.8 + 0.1)
    assert rule.check(sample(t=1.05, theta=0.99, to_end=2e-3)) is None  # overshoots out of the ball
    assert rule.check(sample(t=1.06, theta=0.99, to_end=0.0)) is None  # back: entered at 1.05 + 0.01 * 1/2
    end = rule.check(sample(t=1.11, theta=1.0, to_end=0.0))
    assert end.stop and end.time is None and end.settle == pytest.approx(1.055 + 0.1)
    never = TcpArrival(1e-3, 0.9, 2.0, 1.9, 0.1, 0.01)
    never.check(sample(t=1.0, theta=0.95, to_end=0.0))
    assert never.check(sample(t=1.1, theta=0.99, to_end=5e-3)).settle is None  # outside at the end: not settled


def test_plan_arrival_time_on_a_straight_line_at_constant_speed():
    """TCP along x at 1 m/s for 1 s (theta = t): it enters the 1 mm ball around x = 1 at t = 0.999 s."""
    from pathmotion.planning.profile import Profile

    grid = np.linspace(0.0, 1.0, 11)
    line = np.stack([grid, np.zeros(11), np.zeros(11)], axis=1)
    t, theta = plan_arrival_time(grid, line, Profile(np.array([0.0, 1.0]), np.array([1.0, 1.0])), 1e-3)
    assert t == pytest.approx(0.999, abs=1e-9) and theta == pytest.approx(0.999, abs=1e-9)


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
    from pathmotion.lift.joint_path import SplineJointPath
    from pathmotion.planning.profile import Profile

    pts = np.array([[0.0] * 6, [0.5, 0.2, 0.1, 0.0, 0.3, 0.1], [1.0, 0.1, 0.3, 0.2, 0.1, 0.4]])
    table = PathTable.from_path(SplineJointPath.from_waypoints(pts), 101)
    if closed:
        table = PathTable(table.grid, table.coeffs, table.domain, True, table.n)
    profile = Profile(np.array([0.0, 0.5, 1.0]), np.array([1.0 if closed or moving else 0.0, 2.0, 1.0 if moving or
                                                           closed else 0.0]))
    line = np.stack([table.grid, np.zeros_like(table.grid), np.zeros_like(table.grid)], axis=1)
    kinds = [type(r).__name__ for r in end_rules(table, profile, line, 4.0, SimulationSettings())]
    judge = ["PathTolerance", "JointTolerance", "Saturation"]
    if closed:
        assert kinds == ["Diverged", *judge, "Laps", "Timeout"]
    else:
        assert kinds == ["Diverged", *(["EndCrossing"] if moving else []), "LeftRange", *judge, "TcpArrival",
                         "Timeout"]


@pytest.mark.parametrize("value", [0.0, -1e-3, float("nan"), float("inf")])
def test_a_path_tolerance_that_is_not_a_positive_distance_is_refused(value):
    from pathmotion.errors import ScenarioError, SimulationError
    from pathmotion.io.scenario import parse_scenario

    with pytest.raises(SimulationError, match="path_tolerance"):
        SimulationSettings(path_tolerance=value)
    text = ('[path]\ntype = "joint"\nwaypoints = [[0, 0, 0, 0, 0.5, 0], [0.5, 0.3, -0.2, 0.4, 0.8, 0.6]]\n'
            f'[simulate]\npath_tolerance = {value!r}\n')
    with pytest.raises(ScenarioError, match="path_tolerance"):
        parse_scenario(text)
