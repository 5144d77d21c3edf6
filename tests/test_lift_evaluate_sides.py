"""A lifted path's both sides in one pass (JointPath.evaluate_sides, what the planner samples a grid with) against
the two separate passes, evaluate(theta, "right") and evaluate(theta[at], "left"): the same floats, on random blend
shapes of a corner (the optimal-blend search's plans) and through a wrist crossing; the search's durations are those of
plans sampled with the separate passes, to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion.geometry import FixedOrientation, Line, TaskPath
from pathmotion.geometry.blends import g2_shape_for_tolerance, with_shaped_g2_blends
from pathmotion.lift.constraint import lift
from pathmotion.planning import planner
from pathmotion.planning.grid import make_grid
from pathmotion.robot import fk
from pathmotion.robot.serial_batch import chain_of
from pathmotion.study.atlas import _settings, _task, corner_points


def _random_shapes(task, tolerance, count, seed):
    """``count`` racing-line shapes of the corner with random balance, quintic shapes, offsets and runs."""
    rng = np.random.default_rng(seed)
    shapes = []
    while len(shapes) < count:
        b, sa, sb = rng.uniform([0.3, 0.4, 0.4], [0.7, 1.0, 1.0])
        w = rng.uniform(0.0, 0.9, 2) * tolerance
        runs = rng.uniform(0.5, 2.0, 2) * np.sqrt(tolerance * 0.64)
        shapes.append(g2_shape_for_tolerance(task, 0, tolerance, b, sa, sb, offsets=tuple(w), runs=tuple(runs)))
    return shapes


def _separate(path, theta, at):
    return path.evaluate(theta, "right"), path.evaluate(theta[at], "left")


def _assert_same(one, two):
    """The right side bit for bit; the left side to round-off: its few points alone take Pinocchio's acceleration
    bias, in one pass with the grid the compiled serial-chain recursion (equal to round-off, robot/serial_batch.py)."""
    for a, b in zip(one[0], two[0]):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(one[1], two[1]):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(b))))


@pytest.mark.parametrize("angle, tolerance", [(30.0, 0.001), (90.0, 0.005), (150.0, 0.01)])
def test_both_sides_in_one_pass_equal_the_separate_passes_on_random_shapes(irb140, angle, tolerance):
    task = _task(corner_points(angle))
    for shape in _random_shapes(task, tolerance, 4, seed=int(angle)):
        path = lift(irb140, with_shaped_g2_blends(task, {0: shape}))
        grid = make_grid(path, 300)
        at = np.array(list(grid.breaks) + [len(grid.theta) - 1])
        assert len(grid.breaks) == 4  # offset piece, corner quintic, offset piece: the left side differs there
        right, left = path.evaluate_sides(grid.theta, at)
        _assert_same((right, left), _separate(path, grid.theta, at))
        assert np.max(np.abs(left[1] - right[1][at])) > 0.0  # Phi'' jumps at the quintic's joins: two sides seen


def test_both_sides_in_one_pass_through_a_wrist_crossing(irb140):
    p, r = fk(irb140, np.zeros(6))  # q5 = 0 at the line's middle: a wrist window there
    path = lift(irb140, TaskPath((Line(p - (0, 0.05, 0), p + (0, 0.05, 0)),), FixedOrientation(r)))
    assert path.wrist_windows
    theta = np.linspace(*path.domain, 301)
    at = np.arange(0, 301, 7)
    _assert_same(path.evaluate_sides(theta, at), _separate(path, theta, at))


def test_a_plan_sampled_in_one_pass_has_the_separate_passes_durations(irb140, monkeypatch):
    task = _task(corner_points(90.0))
    settings = _settings(False, verify=False, baselines=False)
    paths = [lift(irb140, with_shaped_g2_blends(task, {0: s})) for s in _random_shapes(task, 0.005, 3, seed=5)]
    one = [planner.plan(p, irb140, settings).duration for p in paths]
    monkeypatch.setattr(type(paths[0]), "evaluate_sides", lambda self, theta, at: _separate(self, theta, at))
    np.testing.assert_allclose([planner.plan(p, irb140, settings).duration for p in paths], one, rtol=1e-12, atol=0)


def test_the_robots_serial_chain_is_the_models(irb140):
    fid = irb140.frame_id(None)
    cached, fresh = irb140.serial_chain(fid), chain_of(irb140.model, fid)
    assert cached is irb140.serial_chain(fid)
    for name in ("rot", "trans", "axis", "tool_rot", "tool_trans"):
        np.testing.assert_array_equal(getattr(cached, name), getattr(fresh, name))
