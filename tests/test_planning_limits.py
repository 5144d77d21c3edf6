"""Limits as objects: a limit is one class in the registry; modes are enums validated at the edge.

The toy limits below (a bound on the path speed theta_dot, order 1, and on the path acceleration
theta_ddot, order 2) are defined here only, registered for one test, and must then be enforced by
the planner, reported by the verification and set through PlanSettings keywords. The independent
check is the analytic trapezoid in theta: with |theta_dot| <= v and |theta_ddot| <= a on theta in
[0, L], the least time is L / v + v / a (when v^2 / a < L).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from pathmotion import api, defaults
from pathmotion.errors import ScenarioError
from pathmotion.io.scenario import LimitsSpec, parse_scenario
from pathmotion.modes import BoundaryMode, Connections
from pathmotion.planning import REGISTRY, PlanSettings, effective_limits, plan
from pathmotion.planning.limits import Limit, LimitChoice, Rows, limit_choices

sys.path.insert(0, str(Path(__file__).parent))
from planning_paths import PolylinePath  # noqa: E402

TOL = defaults.LIMIT_TOLERANCE
OFF = {"use_velocity": False, "use_acceleration": False, "use_torque": False}
FAST = dict(baselines=False, grid_points=200)


class PathSpeedLimit(Limit):
    """Toy order-1 limit: theta_dot <= v_max [unit theta / s]."""

    name = "path_speed"
    order = 1
    per_joint = False
    unit = "1/s"
    keys = {"path_speed": "value"}

    def __init__(self, v_max):
        self.v_max = v_max

    @classmethod
    def default_choice(cls):
        return LimitChoice(on=False)

    @classmethod
    def from_robot(cls, robot, choice):
        return None if choice.value is None else cls(choice.value)

    def bound(self, points, scale):
        return (self.v_max * scale[:, 0]) ** 2

    def ratios(self, samples, robot):
        return (np.abs(samples.theta_dot) / self.v_max)[:, None]

    def enforced(self):
        return float(self.v_max)

    def column_name(self, j, joint_names):
        return "path"


class PathAccelerationLimit(Limit):
    """Toy order-2 limit: -a_max <= theta_ddot <= a_max, i.e. rows (a, b, c) = (1, 0, 0)."""

    name = "path_acceleration"
    order = 2
    per_joint = False
    unit = "1/s^2"
    keys = {"path_acceleration": "value"}

    def __init__(self, a_max):
        self.a_max = a_max

    def enforced(self):
        return float(self.a_max)

    @classmethod
    def default_choice(cls):
        return LimitChoice(on=False)

    @classmethod
    def from_robot(cls, robot, choice):
        return None if choice.value is None else cls(choice.value)

    def rows(self, points, scale, x_ref=None):
        k = len(points.theta)
        lim = self.a_max * scale
        return Rows(np.ones((k, 1)), np.zeros((k, 1)), np.zeros((k, 1)), -lim, lim)

    def ratios(self, samples, robot):
        return (np.abs(samples.theta_ddot) / self.a_max)[:, None]

    def column_name(self, j, joint_names):
        return "path"


@pytest.fixture()
def toy_registry():
    """REGISTRY with the two toy limits appended (one line each), restored afterwards."""
    REGISTRY.append(PathSpeedLimit)
    REGISTRY.append(PathAccelerationLimit)
    try:
        yield
    finally:
        REGISTRY.remove(PathSpeedLimit)
        REGISTRY.remove(PathAccelerationLimit)


def test_a_registered_limit_class_is_enforced_and_verified(toy_registry, irb140):
    line = PolylinePath.through([np.zeros(6), np.array([0.4, 0.2, -0.2, 0.1, 0.1, 0.0])])
    v, a = 0.8, 2.0  # v^2 / a = 0.32 < L = 1: cruise between two ramps
    res = plan(line, irb140, PlanSettings(limits={**OFF, "path_speed": v, "path_acceleration": a}, **FAST))
    assert res.duration == pytest.approx(1.0 / v + v / a, rel=1e-3)
    assert res.ratios.path_speed == pytest.approx(1.0, abs=TOL)  # both bind
    assert res.ratios.path_acceleration == pytest.approx(1.0, abs=TOL)
    s = res.trajectory.sample(1e-3)  # independent of the verification's own resample
    assert np.max(np.abs(s.theta_ddot)) <= a * (1 + TOL) and np.max(s.theta_dot) <= v * (1 + TOL)
    summary = res.ratios.summary()
    assert summary["max_path_acceleration_ratio"] == res.ratios.path_acceleration
    assert summary["max_torque_ratio"] is None  # off
    settings = PlanSettings(limits={**OFF, "path_speed": v}, **FAST)
    assert settings.limits["path_speed"].value == v and settings.limits["path_acceleration"].value is None


def test_toy_limit_reads_from_scenario_keys(toy_registry):
    choices = limit_choices({"path_speed": 0.5, "use_torque": False})
    assert choices["path_speed"] == LimitChoice(on=True, scale=1.0, value=0.5)
    assert choices["path_acceleration"].on is False and choices["torque"].on is False
    with pytest.raises(ScenarioError, match=r"limits\.path_speed must be > 0"):
        PlanSettings(limits={"path_speed": -1.0})


def test_registry_keys_match_the_scenario_file_format():
    keys = {k for cls in REGISTRY for k in cls.keys}
    overrides = {"velocity", "acceleration", "torque"}  # the robot's joint limits, replaced per joint
    assert keys == set(LimitsSpec.model_fields) - overrides
    assert len({cls.name for cls in REGISTRY}) == len(REGISTRY)
    assert len({cls.summary_key() for cls in REGISTRY}) == len(REGISTRY)


def test_scenario_limits_become_settings():
    sc = parse_scenario('[path]\ntype = "joint"\nwaypoints = [[0.0], [1.0]]\n'
                        '[limits]\nuse_torque = false\nvelocity_scale = 0.5\ntcp_speed = 0.3\n')
    settings = PlanSettings(limits=limit_choices(sc.limits))
    limits = settings.limits
    assert limits["torque"].on is False and limits["velocity"].scale == 0.5 and limits["tcp_speed"].value == 0.3
    assert limits["acceleration"].on is True and limits["acceleration"].scale == 1.0
    # Python takes the same keys as the scenario file
    assert PlanSettings(limits={"use_torque": False, "velocity_scale": 0.5, "tcp_speed": 0.3}) == settings


def test_unknown_limit_key_is_refused_and_a_switch_named():
    with pytest.raises(ScenarioError, match="unknown limit key"):
        PlanSettings(limits={"snap": True})  # jerk is a limit; snap is not
    with pytest.raises(ScenarioError, match=r"limits\.jerk holds the limits .*the switch is limits\.use_jerk"):
        PlanSettings(limits={"jerk": True})  # the values are [rad/s^3]
    with pytest.raises(ScenarioError, match="the switch of 'torque' is 'use_torque'"):
        PlanSettings(limits={"torque": False})


def test_settings_are_a_plain_frozen_value():
    """Equal settings hash equal whichever form the limits were given in; replace() checks again."""
    import dataclasses

    a = PlanSettings(grid_points=100, limits={"use_jerk": True, "jerk_scale": 0.5})
    b = dataclasses.replace(PlanSettings(), grid_points=100, limits=a.limits)
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.grid_points = 3
    with pytest.raises(ScenarioError, match="duration_tolerance"):
        dataclasses.replace(a, duration_tolerance=0.5)


def test_modes_are_enums_validated_once():
    s = PlanSettings(start="max", end=0.5, connections="zero")
    assert s.start is BoundaryMode.MAX and s.end == 0.5 and s.connections is Connections.ZERO
    assert s.connections == "zero"  # the enum's value is the string of files and outputs
    for bad in (dict(connections="smooth"), dict(start="fast"), dict(end="stop")):
        with pytest.raises(ScenarioError, match="must be one of"):
            PlanSettings(**bad)


def test_every_registered_limit_says_what_it_enforces():
    """Each class implements ``enforced`` (the base refuses), so limits.json cannot silently omit one."""
    missing = [cls.__name__ for cls in REGISTRY if cls.enforced is Limit.enforced]
    assert not missing, f"limits without enforced(): {missing}"
    with pytest.raises(NotImplementedError, match="enforced"):
        Limit.enforced(PathAccelerationLimit(1.0))


def test_limits_json_lists_every_active_limit_with_its_values(irb140):
    """All seven limits on: "enforced" names each active limit, JSON-ready, and its values follow from the
    robot's limits and the settings (scales, reserve, user values)."""
    settings = PlanSettings(limits={"velocity_scale": 0.5, "torque_scale": 0.9, "torque_reserve": 0.2, "tcp_speed": 1.2, "torque_speed": ((0.4,), (0.6,)), "use_jerk": True, "use_torque_rate": True, "jerk_scale": 0.5})
    active = [lim.name for lim in effective_limits(irb140, settings)]
    assert active == [cls.name for cls in REGISTRY]
    enforced = json.loads(json.dumps(api.enforced_limits(irb140, settings)))
    assert list(enforced) == active
    lim = irb140.limits
    assert enforced["velocity"] == pytest.approx((0.5 * lim.velocity).tolist())
    assert enforced["acceleration"] == pytest.approx(lim.acceleration.tolist())
    assert enforced["torque"] == pytest.approx((0.9 * 0.8 * lim.torque).tolist())
    assert enforced["tcp_speed"] == 1.2
    assert enforced["torque_speed"] == {"knee": [0.4] * 6, "at_max_speed": [0.6] * 6}
    assert enforced["jerk"] == pytest.approx((0.5 * lim.jerk).tolist())
    assert enforced["torque_rate"] == pytest.approx(lim.torque_rate.tolist())


def test_every_limit_reads_its_names_from_the_one_table():
    """Scenario keys, summary keys and report labels of each limit are one row of io/schema.py's LIMITS."""
    from pathmotion.io import schema
    from pathmotion.report import html, tables

    assert list(schema.LIMITS) == [cls.name for cls in REGISTRY]
    for cls in REGISTRY:
        row = schema.LIMITS[cls.name]
        assert cls.names is row and cls.keys is row.keys and cls.summary_key() == row.ratio.key
        assert html.LIMIT_UNITS[cls.name] == row.unit and html.LIMIT_ROW_LABELS[cls.name] == row.label
        assert tables.LIMIT_COLORS[cls.name] == row.color
        assert (tables.limit_curve_label(cls.name, {}) == row.curve) if row.curve else (
            tables.steady_curve_label(cls.name) == row.steady)


@pytest.mark.parametrize("name", ["corner_g2", "circle_smooth", "abb_cycle"])
def test_left_rows_assembled_at_the_breaks_equal_the_rows_of_every_left_point(name):
    """The planner (grid_data.grid_rows) assembles the left side's rows only where its path data differ from the right side's (the
    breaks); they equal limit_rows on every left point, bit for bit, with a linearization point x_ref too."""
    from pathmotion.planning import grid_data
    from pathmotion.planning.limit_rows import limit_rows
    from pathmotion.scenarios import scenario_path

    setup = api.load(scenario_path(name))
    limits = effective_limits(setup.robot, setup.plan_settings)
    path = setup.path
    theta = np.union1d(np.linspace(*path.domain, 301), [b for b in path.breaks if path.domain[0] < b < path.domain[1]])
    sampled = grid_data.sample_grid(path, setup.robot, theta, grid_data.grid_breaks(path, theta))
    scale = limits.unit_scale(len(theta), setup.robot.n)
    x_ref = np.random.default_rng(0).uniform(0.0, 4.0, len(theta))
    for ref in (None, x_ref):
        right = limit_rows(sampled.right, limits, scale, defaults.PLANNER_X_CAP, ref)
        fast = grid_data._left_rows(right, sampled.right, sampled.left, limits, scale, ref)
        full = limit_rows(sampled.left, limits, scale, defaults.PLANNER_X_CAP, ref)
        for a, b in zip((fast.a, fast.b, fast.c, fast.lo, fast.hi, fast.x_max),
                        (full.a, full.b, full.c, full.lo, full.hi, full.x_max)):
            np.testing.assert_array_equal(a, b)
    assert len(path.breaks) == 0 or not np.array_equal(full.b, right.b)  # the sides differ at the breaks


def test_scale_along_equals_the_settings_scale_where_it_is_constant(irb140):
    """plan's point-wise ``scale_along`` (a caller's local tightening), constant 0.6 on the acceleration limit,
    plans what the scenario's acceleration_scale = 0.6 plans; 0.6 on the second half of the path only gives a
    duration between the two."""
    line = PolylinePath.through([np.zeros(6), np.array([0.4, 0.2, -0.2, 0.1, 0.1, 0.0])])
    free = {"use_torque": False}
    full = plan(line, irb140, PlanSettings(limits=free, **FAST))
    scaled = plan(line, irb140, PlanSettings(limits={**free, "acceleration_scale": 0.6}, **FAST))
    along = plan(line, irb140, PlanSettings(limits=free, **FAST),
                 scale_along=lambda theta: {"acceleration": np.full(len(theta), 0.6)})
    assert along.duration == pytest.approx(scaled.duration, rel=1e-9)
    half = plan(line, irb140, PlanSettings(limits=free, **FAST),
                scale_along=lambda theta: {"acceleration": np.where(theta > 0.5 * theta[-1], 0.6, 1.0)})
    assert full.duration < half.duration < scaled.duration
