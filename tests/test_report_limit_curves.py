"""The phase plane's new limit curves: each limit's maximum-velocity curve written to
phase_plane.csv against a brute-force computation on RNEA, the optimum without the jerk limits, and
the report's rows for the new limits."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api
from pathmotion.io import schema
from pathmotion.planning.limit_curves import limit_curves
from pathmotion.report import figures, interactive
from pathmotion.report.html import build_report
from pathmotion.report.tables import read_columns, read_json
from pathmotion.robot import rnea
from pathmotion.scenarios import scenario_path

#: Path positions of the brute-force check (fractions of the circle).
FRACTIONS = (0.03, 0.17, 0.26, 0.41, 0.55, 0.72, 0.9)
BISECTIONS = 80


def _feasible(robot, q, dq, ddq, x, tau_max, envelope=None) -> bool:
    """Some theta_ddot u keeps every |tau_j| within its limit at x = theta_dot^2: tau is affine in u,
    tau(u) = tau(0) + u (tau(1) - tau(0)), both from RNEA; ``envelope`` (knee, at_max, qd_max) lowers the
    limit with the joint speed |dq_j| sqrt(x) as the envelope's definition says."""
    qd = dq * np.sqrt(x)
    tau0 = rnea(robot, q[None], qd[None], (ddq * x)[None])[0]
    slope = rnea(robot, q[None], qd[None], (ddq * x + dq)[None])[0] - tau0
    limit = np.array(tau_max, float)
    if envelope is not None:
        knee, at_max, qd_max = envelope
        ratio = np.abs(qd) / qd_max
        limit = limit * np.where(ratio <= knee, 1.0, 1.0 - (1.0 - at_max) / (1.0 - knee) * (ratio - knee))
    lo, hi = -np.inf, np.inf
    for t0, s, lim in zip(tau0, slope, limit):
        if lim < 0:
            return False
        if abs(s) < 1e-12:
            if abs(t0) > lim:
                return False
            continue
        a, b = sorted(((-lim - t0) / s, (lim - t0) / s))
        lo, hi = max(lo, a), min(hi, b)
    return lo <= hi


def _largest_x(robot, q, dq, ddq, tau_max, envelope=None) -> float:
    """The largest feasible x by bisection (x = 0 is feasible: gravity is within the limits)."""
    lo, hi = 0.0, 1.0
    while _feasible(robot, q, dq, ddq, hi, tau_max, envelope):
        lo, hi = hi, 2 * hi
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _feasible(robot, q, dq, ddq, mid, tau_max, envelope) else (lo, mid)
    return lo


@pytest.fixture(scope="module")
def smooth():
    return api.load(scenario_path("circle_smooth"))


def test_torque_and_envelope_curves_match_a_bisection_on_rnea(smooth):
    path, robot, settings = smooth.path, smooth.robot, smooth.plan_settings
    theta = path.domain[0] + np.array(FRACTIONS) * (path.domain[1] - path.domain[0])
    curves = limit_curves(path, robot, settings, theta)
    assert list(curves) == ["velocity", "torque", "torque_speed"]  # jerk has no curve; acceleration is off
    tau_max = 0.8 * robot.limits.torque  # circle_smooth keeps 20 % free
    envelope = (0.5, 0.5, robot.limits.velocity)
    q, dq, ddq = path.evaluate(theta)
    for k in range(len(theta)):
        torque = _largest_x(robot, q[k], dq[k], ddq[k], tau_max)
        env = _largest_x(robot, q[k], dq[k], ddq[k], tau_max, envelope)
        assert curves["torque"][k] ** 2 == pytest.approx(torque, rel=1e-7)
        assert curves["torque_speed"][k] ** 2 == pytest.approx(env, rel=1e-6)
        speed = np.min(robot.limits.velocity / np.abs(dq[k]))
        assert curves["velocity"][k] == pytest.approx(speed, rel=1e-12)
    # the envelope binds below the flat torque limit somewhere, so its check above is not the torque one again
    assert np.any(curves["torque_speed"] < 0.99 * curves["torque"])


TEXT = """
name = "jerk_joint"
[robot]
name = "irb140"
[path]
type = "joint"
waypoints = [[0.0, 0.2, -0.3, 0.0, 0.5, 0.0], [0.8, 0.5, -0.6, 0.4, 0.9, 0.5], [1.2, 0.1, -0.2, 0.8, 0.4, 1.0]]
[limits]
use_jerk = true
torque_reserve = 0.2
torque_speed = { knee = 0.5, at_max_speed = 0.5 }
[plan]
grid_points = 60
verify = "off"
"""


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("curves") / "plan"
    setup = api.load_text(TEXT)
    result = api.plan_scenario(setup)
    api.write_plan(setup, result, out)
    return setup, result, out


def test_the_plan_folder_holds_every_limit_curve_and_the_second_order_optimum(written):
    setup, result, out = written
    cols = read_columns(out / schema.PHASE_PLANE_FILE, (schema.PHASE_THETA, schema.PHASE_SECOND_ORDER))
    assert schema.limit_curve_names(cols) == ["velocity", "acceleration", "torque", "torque_speed"]
    assert schema.steady_curve_names(cols) == ["jerk"]
    again = limit_curves(setup.path, setup.robot, setup.plan_settings, cols[schema.PHASE_THETA])
    for name, curve in again.items():
        assert np.allclose(cols[schema.limit_curve_column(name)], curve, rtol=1e-12)
    # all limits together allow no more than the strictest one alone (one u must meet them all)
    lowest = np.min([cols[schema.limit_curve_column(n)] for n in again], axis=0)
    assert np.all(cols[schema.PHASE_POINTWISE] <= lowest * (1 + 1e-9))
    summary = read_json(out / "summary.json")
    second = summary[schema.SECOND_ORDER_DURATION.key]
    assert second < summary[schema.DURATION.key]  # the jerk limit costs time
    # the second-order optimum stays under every limit's own curve (checked against RNEA above); not under the
    # pointwise column, which is the third-order plan's curve (it can lie below the second-order plan's: 5 % with
    # the torque-derived accelerations of docs/robot.md, where both profiles ride it)
    assert np.all(cols[schema.PHASE_SECOND_ORDER] <= lowest * (1 + 1e-3) + 1e-9)
    enforced = read_json(out / "limits.json")["enforced"]
    assert enforced["torque"] == pytest.approx((0.8 * setup.robot.limits.torque).tolist())
    assert enforced["jerk"] == pytest.approx(setup.robot.limits.jerk.tolist())
    assert enforced["torque_speed"] == {"knee": [0.5] * 6, "at_max_speed": [0.5] * 6}


def test_both_phase_planes_draw_and_name_every_curve(written):
    _, _, out = written
    cols = read_columns(out / schema.PHASE_PLANE_FILE)
    summary = read_json(out / "summary.json")
    labels = [t.get_text() for t in figures.phase_plane(cols, summary).get_legend().get_texts()]
    expected = ["joint velocity limit", "joint acceleration limit", "joint torque limit (20 % kept free)",
                "torque-speed envelope (20 % kept free)", "jerk limit at constant speed"]
    assert all(e in labels for e in expected), labels
    assert any(lab.startswith("without jerk / torque-rate limits (") for lab in labels)
    fig = interactive.phase_plane_figure(cols, {"optimal": summary[schema.DURATION.key]}, "joint", summary)
    names = [trace.name for trace in fig.data]
    assert all(e in names for e in expected) and "without jerk / torque-rate limits" in names


def test_report_lists_the_new_limits_and_their_ratios(written, tmp_path):
    _, result, out = written
    html = build_report(out.parent).read_text()
    for key in (schema.MAX_JERK_RATIO, schema.MAX_TORQUE_SPEED_RATIO, schema.MAX_TORQUE_RATE_RATIO,
                schema.TORQUE_RESERVE, schema.SECOND_ORDER_DURATION):
        assert f'title="{key.key}"' in html, key.key
    assert "Limits the plan enforced" in html
    for row in ("jerk [rad/s³]", "torque (with 20 % reserve) [N m]", "torque-speed envelope [knee / at top speed]"):
        assert row in html, row
    assert "0.5 / 0.5" in html


def _constant_speed_ratio(robot, path, theta0: float, speed: float, which: str, limit) -> float:
    """Largest |jerk| / limit or |torque rate| / limit over the joints of the motion theta(t) = theta0 +
    speed t at t = 0, by central differences in time of q (jerk) or of RNEA's torque (torque rate)."""
    h = 2e-3 / speed

    def q_at(t):
        return path.evaluate(theta0 + speed * np.asarray(t, float))[0]

    if which == "jerk":
        q = q_at([2 * h, h, -h, -2 * h])
        value = (q[0] - 2 * q[1] + 2 * q[2] - q[3]) / (2 * h**3)
    else:
        h = 1e-5 / speed
        t = np.array([h, -h])
        q, dq, ddq = path.evaluate(theta0 + speed * t)
        tau = rnea(robot, q, dq * speed, ddq * speed**2)
        value = (tau[0] - tau[1]) / (2 * h)
    return float(np.max(np.abs(value) / limit))


def test_steady_speed_curves_are_where_constant_speed_reaches_the_third_order_limits(smooth):
    from pathmotion.planning import PlanSettings
    from pathmotion.planning.limit_curves import steady_curves

    path, robot = smooth.path, smooth.robot
    settings = PlanSettings(limits={"use_acceleration": False, "use_jerk": True, "use_torque_rate": True, "torque_rate_scale": 0.05})
    theta = path.domain[0] + np.array(FRACTIONS) * (path.domain[1] - path.domain[0])
    curves = steady_curves(path, robot, settings, theta)
    assert list(curves) == ["jerk", "torque_rate"]
    limits = {"jerk": robot.limits.jerk, "torque_rate": 0.05 * robot.limits.torque_rate}
    for name, curve in curves.items():
        for k, th in enumerate(theta):
            assert _constant_speed_ratio(robot, path, th, curve[k], name, limits[name]) == pytest.approx(1, rel=2e-3)
            for below in (0.3, 0.7, 0.95):  # and within the limit at every slower constant speed
                assert _constant_speed_ratio(robot, path, th, below * curve[k], name, limits[name]) <= 1.0


@pytest.mark.parametrize("name", ["abb_cycle", "circle_smooth"])
def test_limit_curves_from_the_plans_path_data_equal_those_of_a_fresh_path_evaluation(name):
    """The phase plane's limit curves reuse the plan's final path data (PlanResult.path_points) on its grid; they
    equal the curves of the path evaluated afresh there (up to round-off)."""
    setup = api.load(scenario_path(name))
    result = api.plan_scenario(setup)
    grid = result.profile.grid
    reused = limit_curves(setup.path, setup.robot, result.settings, grid, result.path_points)
    fresh = limit_curves(setup.path, setup.robot, result.settings, grid)
    assert result.path_points is not None and np.array_equal(result.path_points[0].theta, grid)
    assert reused.keys() == fresh.keys() and reused
    for key in fresh:
        np.testing.assert_allclose(reused[key], fresh[key], rtol=1e-12, atol=0, err_msg=key)
