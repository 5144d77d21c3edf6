"""check means OK: every scenario of the bad-input catalogue that load, plan, the plan's
writing or the simulation settings refuse, ``check`` refuses too, with the same error class; and closed
polygons: ``corner = "all"`` blends the closing corner too, which ``corner = N`` names."""

import json

import numpy as np
import pytest

from pathmotion import api
from pathmotion.errors import PathmotionError, ScenarioError

from reliability_cases import CASES, _square
from test_reliability_inputs import write_case

#: reliability_cases' closed 0.2 m x 0.1 m rectangle, planned as a periodic cycle; CORNER is replaced per test.
SQUARE = _square("CORNER").replace('name = "line"', 'name = "square"').replace(
    "grid_points = 60", "grid_points = 120\nperiodic = true")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_check_refuses_what_plan_and_simulate_refuse(case, tmp_path):
    path = write_case(case, tmp_path)
    with pytest.raises(PathmotionError) as info:
        api.check_scenario(api.load(path, dict(case.overrides)))
    assert type(info.value) is case.error, f"{case.id}: {type(info.value).__name__}: {info.value}"


def test_corner_all_blends_the_closing_corner_of_a_closed_square():
    setup = api.load_text(SQUARE.replace("CORNER", '"all"'))
    task = setup.task_path
    # four blended corners; the path starts in the middle of segment 1, where its closure is smooth
    assert sum(type(s).__name__ == "Arc" for s in task.segments) == 4
    assert [c.kind for c in task.connections].count("corner") == 0 and task.closure.kind == "smooth"
    np.testing.assert_allclose(task.segments[0].start_point, (0.5, 0.0, 0.5), atol=1e-12)
    assert setup.path.closed and not setup.path.kinks
    # the closing corner is cut exactly like the others: its blend stays 0.02 m (1/sin 45 deg - 1) away
    p, _, _ = task.evaluate(np.linspace(*task.domain, 4001))
    corner = np.array([0.5, -0.1, 0.5])
    assert np.min(np.linalg.norm(p - corner, axis=1)) == pytest.approx(0.02 * (np.sqrt(2) - 1), rel=1e-3)
    result = api.plan_scenario(setup)
    assert result.ratios.max_ratio <= 1.0 + 1e-3
    report = api.check_scenario(setup)
    assert report["duration_s"] == pytest.approx(result.profile.duration)


def test_corner_n_names_the_closing_corner_and_n_plus_1_is_refused():
    only = api.load_text(SQUARE.replace("CORNER", "4")).task_path
    assert sum(type(s).__name__ == "Arc" for s in only.segments) == 1
    assert [c.kind for c in only.connections].count("corner") == 3  # the three interior ones stay sharp
    with pytest.raises(ScenarioError, match=r"numbered 1\.\.4 .*4 = the closing corner"):
        api.load_text(SQUARE.replace("CORNER", "5"))


ALL_NEAR_STOPS = """name = "all_near_stops"
[path]
type = "joint"
waypoints = [[0, 0, 0, 0, 0.5, 0], [0.3, 0.2, -0.2, 0.3, 0.8, 0.5]]
[plan]
grid_points = 50
[simulate]
controller = "orbital"
gains = { terminal_time_to_go = 1000.0 }
"""


def test_check_builds_the_design_simulate_uses(tmp_path):
    """The orbital controller's design runs in check too and is cached for simulate. A motion every point of
    which is within terminal_time_to_go of a stop has no orbital stretch: the design plays the whole plan on the
    clock (one zone from 0 to the planned duration), check passes and simulate tracks with it."""
    from typer.testing import CliRunner

    from pathmotion.cli import app

    scenario = tmp_path / "s.toml"
    scenario.write_text(ALL_NEAR_STOPS)
    runner = CliRunner()
    env = {"PATHMOTION_CACHE_DIR": str(tmp_path / "cache")}
    checked = runner.invoke(app, ["check", str(scenario)], env=env)
    assert checked.exit_code == 0, checked.output
    designs = list((tmp_path / "cache").glob("design-*.npz"))
    assert len(designs) == 1
    zones = np.load(designs[0])["zones"]
    simulated = runner.invoke(app, ["simulate", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"],
                              env=env)
    assert simulated.exit_code == 0, simulated.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["tracking_ok"]
    np.testing.assert_allclose(zones, [[0.0, summary["planned_duration_s"]]], rtol=1e-12)
    assert list((tmp_path / "cache").glob("design-*.npz")) == designs  # simulate read check's design
    # the same scenario with the default terminal time passes check, and the design it built is cached
    scenario.write_text(ALL_NEAR_STOPS.replace("gains = { terminal_time_to_go = 1000.0 }", ""))
    assert runner.invoke(app, ["check", str(scenario)], env=env).exit_code == 0
    assert len(list((tmp_path / "cache").glob("design-*.npz"))) == 2


def test_a_smooth_profile_answers_a_scalar_time_like_an_array():
    """The orbital controller asks a profile for the state at one time; a smooth (jerk-limited) profile used
    to fail there with an IndexError (found when check began to build the design: circle_smooth)."""
    from pathmotion.planning.profile import Profile

    grid = np.linspace(0.0, 1.0, 6)
    profile = Profile(grid, np.array([0.0, 0.5, 1.0, 1.0, 0.5, 0.0]), np.array([0.3, 0.4, 0.0, -0.2, -0.4, -0.3]))
    assert profile.smooth
    times = np.linspace(0.0, profile.duration, 9)
    along = profile.state3_at_time(times)
    for k, t in enumerate(times):
        one = profile.state3_at_time(float(t))
        assert all(np.shape(v) == () for v in one)
        np.testing.assert_allclose([float(v) for v in one], [v[k] for v in along], rtol=1e-12, atol=1e-12)
    # and at the times the profile reaches its grid points (by quadrature), theta is that grid point
    for theta, t in zip(grid, profile.times):
        assert float(profile.state3_at_time(float(t))[0]) == pytest.approx(theta, abs=1e-9)


@pytest.mark.parametrize("sampled", [True, False])
@pytest.mark.parametrize("bandwidth", [1e-9, 1e-300])
def test_a_vanishing_bandwidth_is_no_internal_error(bandwidth, sampled, tmp_path, monkeypatch):
    """A bandwidth of 1e-9 rad/s makes the LQR weights vanish: scipy's algebraic Riccati solver raised a
    ValueError (an internal error in simulate, and in check once it built the design; found by
    benchmarks/fuzz_cli.py). The design now starts from a zero terminal cost where the algebraic equation has
    no solution: check passes or refuses with a PathmotionError, for both designs, never another exception."""
    monkeypatch.setenv("PATHMOTION_CACHE_DIR", str(tmp_path))
    text = ALL_NEAR_STOPS.replace("terminal_time_to_go = 1000.0", f"bandwidth = {bandwidth!r}").replace(
        "0.8, 0.5]]", "0.8, 0.5], [0.5, 0.1, 0.0, 0.0, 0.6, 1.0]]")  # the fuzzer's joint path
    text += f"sampled_design = {str(sampled).lower()}\n"
    try:
        report = api.check_scenario(api.load_text(text))
    except PathmotionError:
        return
    assert report["duration_s"] > 0


def test_check_refuses_a_closed_loop_too_long_for_its_sample_budget():
    """simulate.sample_time = 1e-9 s: the closed loop of this short plan would hold over 1e8 samples, far above
    defaults.MAX_TRAJECTORY_SAMPLES; check (like simulate) refuses it before any array is built, and says
    how many samples and which setting to raise."""
    from pathmotion import defaults

    text = ALL_NEAR_STOPS.replace("gains = { terminal_time_to_go = 1000.0 }", "sample_time = 1e-9")
    setup = api.load_text(text)
    settings = api.simulation_settings(setup)
    duration = api.plan_scenario(setup).profile.duration
    samples = (settings.time_budget_factor * duration + settings.time_budget_margin) / 1e-9 + 1
    assert samples > 100 * defaults.MAX_TRAJECTORY_SAMPLES
    with pytest.raises(ScenarioError, match=r"simulate\.sample_time = 1e-09 s") as info:
        api.check_scenario(setup)
    message = str(info.value)
    assert f"{samples:.3g} samples" in message and "raise the sample time" in message
    assert f"the default is {defaults.SAMPLE_TIME:g} s" in message


def test_library_simulate_refuses_a_sample_budget_before_building_anything(monkeypatch):
    """The same guard holds for a library call of simulation.simulate (not only for the CLI's check and
    simulate): the budget's sample count is checked in prepare_loop before the controller's table or gains
    are built (the design is never reached)."""
    from dataclasses import replace

    from pathmotion import simulation
    from pathmotion.simulation import closed_loop

    setup = api.load_text(ALL_NEAR_STOPS.replace("gains = { terminal_time_to_go = 1000.0 }", "sample_time = 1e-9"))
    settings = replace(api.simulation_settings(setup), design_cache=False)
    profile = api.plan_scenario(setup).profile
    built = []
    monkeypatch.setattr(closed_loop.PathTable, "from_path", lambda *a, **k: built.append(a))
    with pytest.raises(ScenarioError, match=r"simulate\.sample_time = 1e-09 s.*MAX_TRAJECTORY_SAMPLES"):
        simulation.simulate(setup.robot, setup.path, profile, "pd_gravity", settings)
    assert built == []
