"""Programs of many segments: blending N corners in one pass (against applying each blend to a whole path in turn),
evaluating a path of many segments (against each segment evaluated alone), the constant-speed baseline's
per-speed test (against max_feasible_scale on the whole problem), the fast and thorough optimal-blend searches
(within the tolerance by a dense distance check, never slower than the symmetric G2 blend planned independently),
the corners searched on worker processes (the same blends as in one process), and a generated contour program
planned end to end."""

import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pathmotion import api
from pathmotion.geometry import FixedOrientation, Line, TaskPath, with_g2_blend
from pathmotion.geometry.blends import with_blends
from pathmotion.geometry.deviation import distance_to_segments
from pathmotion.lift.constraint import lift
from pathmotion.planning import PlanSettings, plan
from pathmotion.planning import baselines as bl
from pathmotion.planning import blend_search as bs
from pathmotion.robot import load_robot

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from program_contour import points, scenario  # noqa: E402

SETTINGS = PlanSettings(start="zero", end="zero",
                        limits={"use_velocity": True, "use_acceleration": True, "use_torque": False}, grid_points=400,
                        verify=False, baselines=False)
ROBOT = load_robot("irb140")


def _contour_path(n: int) -> TaskPath:
    pts = np.array(points(n))
    return TaskPath(tuple(Line(a, b) for a, b in zip(pts[:-1], pts[1:])), FixedOrientation())


def test_blends_in_one_pass_equal_blends_applied_one_by_one():
    """with_blends on 60 corners builds one path; applying each G2 blend (with the same shared-segment shares) to a
    whole TaskPath in turn, last corner first, each edit a new TaskPath, gives the same path."""
    from pathmotion import defaults
    from pathmotion.geometry import blends

    path = _contour_path(61)
    one_pass = with_blends(path, {k: ("g2", 0.0005) for k in range(60)})
    by_one = path
    for k in reversed(range(60)):
        c = blends._corner(path, k, ("corner",), "test", shared=(k > 0, k < 59))
        c = blends._Corner(by_one.connection(k), by_one.segments[k], by_one.segments[k + 1], c.max_a, c.max_b)
        by_one = blends._with_g2_blend(by_one, c, 0.0005, defaults.G2_BLEND_SHAPE)
        assert isinstance(by_one, TaskPath)
    assert len(one_pass.segments) == len(by_one.segments) == 61 + 60
    theta = np.linspace(0.0, by_one.length, 5001)
    for a, b in zip(one_pass.evaluate(theta), by_one.evaluate(theta)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    assert [c.kind for c in one_pass.connections] == [c.kind for c in by_one.connections]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 400))
def test_path_evaluation_groups_points_by_segment(seed, n):
    """TaskPath.evaluate at unsorted points (with repeats and the breaks themselves) equals each point evaluated on
    its own segment (segment_index, offsets), on a 40-segment contour."""
    path = _contour_path(40)
    rng = np.random.default_rng(seed)
    theta = np.concatenate([rng.uniform(0.0, path.length, n), rng.choice(path.offsets, 5)])
    for side in ("right", "left"):
        p, dp, ddp = path.evaluate(theta, side)
        k = path.segment_index(theta, side)
        for i in range(len(theta)):
            q = path.segments[k[i]].evaluate(np.array([theta[i] - path.offsets[k[i]]]))
            np.testing.assert_allclose(p[i], q[0][0], atol=1e-15)
            np.testing.assert_allclose(dp[i], q[1][0], atol=1e-15)
            np.testing.assert_allclose(ddp[i], q[2][0], atol=1e-12)


def test_constant_speed_test_agrees_with_max_feasible_scale():
    """The baseline's O(K) test of a cruise speed v with ramps of a agrees with max_feasible_scale >= 1 on the
    trapezoid profile, over a grid of (v, a) that spans feasible and infeasible pairs, on a blended corner."""
    setup = api.load_text('name = "c"\n[robot]\nname = "irb140"\n[path]\ntype = "task"\n[[path.segments]]\n'
                          'type = "line"\nstart = [0.4, -0.1, 0.45]\nend = [0.5, -0.1, 0.45]\n[[path.segments]]\n'
                          'type = "line"\nend = [0.5, 0.1, 0.45]\n[[path.blends]]\ntype = "g2"\ntolerance = 0.005\n'
                          '[plan]\ngrid_points = 600\n')
    caught = {}
    original = bl.constant_speed_baseline

    def spy(problem, sol, chain_args, gain_right, gain_left, *args):
        caught.update(problem=problem, sol=sol, chain_args=chain_args, right=gain_right, left=gain_left)
        return original(problem, sol, chain_args, gain_right, gain_left, *args)

    bl.constant_speed_baseline = spy
    try:
        api.plan_scenario(setup)
    finally:
        bl.constant_speed_baseline = original
    problem, sol = caught["problem"], caught["sol"]
    cuts = bl._cuts(caught["chain_args"], problem.size)
    (i0, i1), = zip(cuts[:-1], cuts[1:])
    sub, x_opt = problem.slice(i0, i1), bl._piece_values(sol, caught["chain_args"], cuts)[0]
    gain = caught["right"][i0:i1 + 1].copy()
    gain[-1] = caught["left"][i1]
    rests = (x_opt[0] <= 0.0, x_opt[-1] <= 0.0)
    v_top = float(np.max(np.sqrt(x_opt) * gain))
    rows = bl._TrapezoidRows.of(sub, gain, rests)
    outcomes = set()
    for a in np.geomspace(1e-2, 1e4, 13):
        ramp = rows.ramps(a, v_top)
        for v in np.linspace(0.02, 1.0, 50) * v_top:
            x = bl._trapezoid(sub.grid, gain, sub.x_max, v, a, *rests)
            expected = bl.max_feasible_scale(sub, x) >= 1.0
            assert rows.holds(v, ramp) == expected, (v, a)
            outcomes.add(expected)
    assert outcomes == {True, False}


def _within(found: bs.OptimalBlend, original: TaskPath, tol: float) -> float:
    """Largest distance [m] of 20,001 samples of the blended path from the sharp lines (independent of the
    certified bound)."""
    theta = np.linspace(0.0, found.path.length, 20001)
    return float(distance_to_segments(found.path.evaluate(theta)[0], original.segments).max())


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["fast", "thorough"])
def test_fast_and_thorough_within_tolerance_and_not_slower_than_g2(kind):
    """On a 90 deg corner of 0.2 m lines with a 5 mm tolerance both searches (the thorough one with a 300-plan global
    stage, to stay short) keep the blended path within the tolerance (dense distance to the sharp lines), are never
    slower than the symmetric G2 blend planned here on its own, and gain at least 0.5 % over it."""
    pts = np.array([[0.35, -0.1, 0.45], [0.55, -0.1, 0.45], [0.55, 0.1, 0.45]])
    path = TaskPath((Line(pts[0], pts[1]), Line(pts[1], pts[2])), FixedOrientation())
    search = bs.SEARCHES[kind] if kind == "fast" else bs.SearchSettings(global_plans=300)
    found = bs.optimal_blends(ROBOT, path, 0.005, settings=SETTINGS, search=search)
    g2 = plan(lift(ROBOT, with_g2_blend(path, 0, 0.005), original=path), ROBOT, SETTINGS).profile.duration
    assert _within(found, path, 0.005) <= 0.005 * (1 + 1e-6)
    assert found.duration <= g2 * (1 + 1e-9)
    assert found.duration < g2 * (1 - 0.005)  # a real gain: the racing line at least


def test_workers_give_the_same_blends():
    """Three corners searched and polished on their windows (fast search) on two worker processes give the same
    blends, plans and duration as in one process."""
    path = _contour_path(4)
    kw = dict(settings=SETTINGS, search=bs.FAST, polish_plans=4, racing_steps=2, steps=2)
    one = bs.optimal_blends(ROBOT, path, 0.001, **kw)
    two = bs.optimal_blends(ROBOT, path, 0.001, workers=2, **kw)
    assert one.shapes == two.shapes
    assert one.duration == two.duration and one.plans == two.plans
    assert one.duration <= one.symmetric_duration


def test_search_settings_from_the_scenario():
    """search = "thorough" is read from a blend, the default is fast, and a g2 blend with a search is an error."""
    from pathmotion.errors import ScenarioError
    from pathmotion.io.scenario import parse_scenario

    text = scenario(3, "optimal", 0.001)
    assert parse_scenario(text, "s").path.blends[0].search == "fast"
    assert parse_scenario(scenario(3, "optimal", 0.001, "thorough"), "s").path.blends[0].search == "thorough"
    with pytest.raises(ScenarioError, match="search is for 'optimal' blends"):
        parse_scenario(scenario(3, "g2", 0.001, "fast"), "s")
    assert parse_scenario(text, "s", {"plan.workers": 2}).plan.workers == 2


def test_generated_contour_program_plans():
    """A 120-move contour (119 G2 blends) is planned: it ends at the last target at rest, and its cycle is at least
    the path length over the fastest TCP speed the IRB140 reaches on it. (Larger programs: benchmarks/
    bench_programs.py; a plan costs about 0.1 s of CPU per move of this contour.)"""
    setup = api.load_text(scenario(120, "g2", 0.0005))
    assert len(setup.task_path.segments) == 120 + 119
    result = api.plan_scenario(setup)
    assert not api.plan_failures(result, setup)
    p_end = setup.task_path.evaluate(setup.task_path.length)[0]
    np.testing.assert_allclose(p_end, points(120)[-1], atol=5e-7)  # the scenario holds targets to 1 um
    assert result.profile.x[-1] == 0.0
    assert result.profile.duration > setup.task_path.length / 2.5  # IRB140 TCP speeds stay below 2.5 m/s here
