"""The API's stages: loading builds without planning, the searches run only when asked for, and errors keep
their attributes when a caller adds its context."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

from pathmotion import api, planning
from pathmotion.errors import PathError, ScenarioError, UnreachableError
from pathmotion.scenarios import scenario_path

TURN = """
name = "turn"
[robot]
name = "irb140"
[path]
type = "waypoints"
points = [[0.4, -0.1, 0.45], [0.5, -0.1, 0.45], [0.5, 0.1, 0.45]]
blend_tolerance = 0.003
blend = "optimal"
[plan]
start = "zero"
end = "zero"
"""


@pytest.fixture
def no_planning(monkeypatch):
    """Any call of the planner fails the test."""
    def refuse(*args, **kwargs):
        raise AssertionError("the planner ran")

    monkeypatch.setattr(planning, "plan", refuse)
    monkeypatch.setattr("pathmotion.planning.blend_search.plan", refuse)
    monkeypatch.setattr("pathmotion.api.plan.plan", refuse)


def test_loading_optimal_blends_builds_without_planning(no_planning):
    setup = api.load_text(TURN)
    assert setup.pending == ("optimal blends",)
    assert setup.path is None and setup.task_path is None
    assert setup.blend_request.tolerances == {0: 0.003}
    assert len(setup.blend_request.sharp.segments) == 2  # the corner left sharp for the search
    with pytest.raises(ScenarioError, match=r"asks for optimal blends; run pathmotion\.api\.search"):
        api.plan_scenario(setup)
    with pytest.raises(ScenarioError, match="check_scenario"):
        api.check_scenario(setup)


def test_loading_optimal_blends_on_a_chain_builds_without_planning(no_planning):
    """A path with joint moves and a dwell: one request per task run with optimal corners, each run left sharp."""
    setup = api.load(Path(__file__).parent / "data" / "chains" / "mixed_optimal.toml")
    assert setup.pending == ("optimal blends",) and setup.path is None
    runs = setup.blend_request.runs
    assert sorted(runs) == [1, 3]  # items: joint move, run, dwell, run, joint move
    assert [r.tolerances for r in runs.values()] == [{0: 0.005}, {0: 0.005}]
    assert [len(r.sharp.segments) for r in runs.values()] == [2, 2]
    assert setup.blend_request.zones == {0: 0.005, 2: 0.005}  # the joint moves' zones (motion connections), kept
    with pytest.raises(ScenarioError, match=r"asks for optimal blends; run pathmotion\.api\.search"):
        api.plan_scenario(setup)


def test_loading_an_auto_reserve_builds_without_planning(no_planning):
    setup = api.load(scenario_path("circle_zero"), {"limits.torque_reserve": "auto"})
    assert setup.pending == ('torque_reserve = "auto"',) and setup.reserve_search is None
    assert setup.plan_settings.limits["torque"].value == 0.0  # the search's first run
    with pytest.raises(ScenarioError, match="torque_reserve"):
        api.plan_scenario(setup)


def test_search_is_a_no_op_without_searches():
    setup = api.load(scenario_path("circle_zero"), {"plan.grid_points": 50})
    assert setup.pending == () and api.search(setup) is setup


def test_in_context_keeps_type_and_attributes_and_pickles():
    exc = UnreachableError("out of reach", index=4, reason="reach", position=(0.9, 0.0, 0.4))
    wrapped = exc.in_context("path.points: at waypoint 2")
    assert type(wrapped) is UnreachableError and str(wrapped) == "path.points: at waypoint 2: out of reach"
    assert (wrapped.index, wrapped.reason, wrapped.position, wrapped.where) == (
        4, "reach", (0.9, 0.0, 0.4), "path.points: at waypoint 2")
    assert exc.where is None and str(exc) == "out of reach"  # the original is unchanged
    again = pickle.loads(pickle.dumps(wrapped))
    assert (str(again), again.index, again.reason, again.position, again.where) == (
        str(wrapped), 4, "reach", (0.9, 0.0, 0.4), wrapped.where)
    assert str(PathError("too short").in_context("path.segments[1]")) == "path.segments[1]: too short"


def test_a_lift_failure_carries_the_position_it_names():
    """The position is data, equal to the one the message names (to its 4 decimals)."""
    far = TURN.replace("[0.5, 0.1, 0.45]]", "[0.5, 0.1, 0.45], [1.5, 0.1, 0.45]]").replace(
        'blend = "optimal"', "").replace("blend_tolerance = 0.003", "")
    with pytest.raises(UnreachableError, match=r"path.points: between waypoints 2 and 3: ") as info:
        api.load_text(far)
    x, y, z = info.value.position
    assert f"position ({x:.4f}, {y:.4f}, {z:.4f}) m" in str(info.value)
    assert np.isclose(y, 0.1) and 0.5 < x < 1.5  # on the segment from waypoint 2 to 3


def test_failures_are_typed_values():
    """A 'max' connection makes the path speed jump there: the failure's kind and place are data (the place is
    the plan's own jump interval); a failed closed loop's summary gives a TRACKING failure with its time."""
    setup = api.load(scenario_path("corner_max"), {"plan.grid_points": 200})
    result = api.plan_scenario(setup)
    failures = api.plan_failures(result, setup)
    jumps = [f for f in failures if f.kind is api.FailureKind.SPEED_JUMP]
    assert len(jumps) == len(result.jump_intervals) >= 1
    a, b = result.jump_intervals[0]
    assert jumps[0].where == f"theta = {a:.6g} .. {b:.6g}" and jumps[0].record()["kind"] == "speed_jump"
    tracked = {"tracking_ok": True, "failure": None}
    failed = {"tracking_ok": False, "failure": {"reason": "path_tolerance", "t": 0.31, "theta": 0.2,
                                                "message": "the TCP left the path"}}
    assert api.tracking_failure(tracked) is None
    f = api.tracking_failure(failed)
    assert (f.kind, f.message, f.where) == (api.FailureKind.TRACKING, "tracking failed: the TCP left the path",
                                            "t = 0.31 s, theta = 0.2")
