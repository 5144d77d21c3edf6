"""Torque reserve and torque-speed envelope, checked with torques computed independently
of the planner (Pinocchio's CRBA mass matrix and non-linear effects, not the RNEA the planner and
the verification use) on a dense resample of the planned motion."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pathmotion import api
from pathmotion.errors import ScenarioError
from pathmotion.planning import PlanSettings, plan

CIRCLE = "pathmotion/scenarios/circle_zero.toml"
GRID = 300
ENVELOPE = {"knee": 0.5, "at_max_speed": 0.5}


def _setup(**limits):
    overrides = {"limits.use_acceleration": False, "plan.grid_points": GRID}
    overrides.update({f"limits.{k}": v for k, v in limits.items()})
    return api.load(CIRCLE, overrides)


def _independent(setup, result, dt=2e-4):
    """(qd (N, n), tau (N, n)) with tau = M(q) qdd + h(q, qd) from CRBA (+ armature) and NLE."""
    s = result.trajectory.at_time(np.arange(0.0, result.duration, dt))
    model = setup.robot.model
    data = model.createData()
    tau = np.empty_like(s.q)
    for k in range(len(s.t)):
        m = pin.crba(model, data, s.q[k])
        m = np.triu(m) + np.triu(m, 1).T
        tau[k] = m @ s.qdd[k] + pin.nonLinearEffects(model, data, s.q[k], s.qd[k])
    return s.qd, tau


@pytest.fixture(scope="module")
def plain():
    setup = _setup(torque_reserve=0.0)  # the whole torque limit: the plan the reserve is compared with
    return setup, plan(setup.path, setup.robot, setup.plan_settings)


def test_reserve_keeps_torque_free(plain):
    setup = _setup(torque_reserve=0.2)
    res = plan(setup.path, setup.robot, setup.plan_settings)
    _, tau = _independent(setup, res)
    peak = np.max(np.abs(tau) / setup.robot.limits.torque)
    assert peak <= 0.8 * (1 + 1e-3)
    assert peak > 0.8 * 0.99  # the reduced limit binds
    assert res.ratios.summary()["torque_reserve"] == 0.2
    assert res.ratios.torque == pytest.approx(peak / 0.8, rel=2e-3)  # reported against the reduced limit
    assert res.duration > plain[1].duration
    # a second route to the same problem: the torque limits scaled by 0.8
    scaled = plan(setup.path, setup.robot, PlanSettings(grid_points=GRID,
                                                        limits={"use_acceleration": False, "torque_scale": 0.8,
                                                                "torque_reserve": 0.0},
                                                        baselines=False))
    assert res.duration == pytest.approx(scaled.duration, rel=1e-9)


def _envelope(qd, qd_max, knee, at_max):
    v = np.abs(qd) / qd_max
    return np.where(v <= knee, 1.0, 1.0 - (1.0 - at_max) * (v - knee) / (1.0 - knee))


@pytest.mark.parametrize("reserve", [0.0, 0.2])
def test_envelope_holds_and_binds(plain, reserve):
    setup = _setup(torque_speed=ENVELOPE, torque_reserve=reserve)
    res = plan(setup.path, setup.robot, setup.plan_settings)
    qd, tau = _independent(setup, res)
    lim = setup.robot.limits
    cap = (1 - reserve) * lim.torque * _envelope(qd, lim.velocity, 0.5, 0.5)
    ratio = np.abs(tau) / cap
    assert ratio.max() <= 1 + 1e-3
    assert ratio.max() > 0.99
    assert res.ratios.summary()["max_torque_speed_ratio"] == pytest.approx(ratio.max(), rel=2e-3)
    assert res.duration > plain[1].duration * (1 + 1e-3)  # the envelope costs time on this circle
    # where some joint runs above its knee, the envelope (not the flat limit) is what binds
    above = np.abs(qd) / lim.velocity > 0.55
    assert np.any(above)
    assert np.max(np.abs(tau)[above] / ((1 - reserve) * lim.torque)[None, :].repeat(len(qd), 0)[above]) < 0.98


def test_envelope_of_one_is_the_plain_torque_limit(plain):
    setup = _setup(torque_speed={"knee": 1.0, "at_max_speed": 1.0}, torque_reserve=0.0)  # the same limit as plain
    res = plan(setup.path, setup.robot, setup.plan_settings)
    assert res.duration == pytest.approx(plain[1].duration, rel=1e-9)


def test_per_joint_envelope():
    setup = _setup(torque_speed={"knee": [0.5] * 6, "at_max_speed": [0.5, 0.5, 0.5, 1.0, 1.0, 1.0]})
    res = plan(setup.path, setup.robot, setup.plan_settings)
    assert res.ratios.torque_speed <= 1 + 1e-3


@pytest.mark.parametrize("key, value", [
    ("torque_reserve", 0.5), ("torque_reserve", 0.7), ("torque_reserve", -0.1), ("torque_reserve", float("nan")),
    ("torque_speed", {"knee": 0.0, "at_max_speed": 0.5}), ("torque_speed", {"knee": 1.2, "at_max_speed": 0.5}),
    ("torque_speed", {"knee": 0.5, "at_max_speed": 0.0}), ("torque_speed", {"knee": 0.5, "at_max_speed": -1}),
    ("torque_speed", {"knee": float("nan"), "at_max_speed": 0.5}), ("torque_speed", {"knee": 0.5, "speed": 0.5}),
    ("torque_speed", {"knee": [0.5, 0.5], "at_max_speed": 0.5}),
])
def test_bad_inputs_name_the_key(key, value):
    with pytest.raises(ScenarioError, match=key):
        setup = _setup(**{key: value})
        plan(setup.path, setup.robot, setup.plan_settings)
