"""The output schema lists every summary key once, and the writers produce no key outside it."""

from __future__ import annotations

import numpy as np
import pytest

from pathmotion import api
from pathmotion.errors import PathError
from pathmotion.geometry import FixedOrientation, Line, TaskPath, with_transitions
from pathmotion.io import schema
from pathmotion.scenarios import scenario_path
from pathmotion.study.point import SUMMARY_KEYS

ALL = [v for v in vars(schema).values() if isinstance(v, schema.Key)]


def test_each_key_is_listed_once_with_a_consistent_display_scale():
    names = [k.key for k in ALL]
    # max_torque_ratio is two quantities (plan: torque of the plan; simulation: commanded torque),
    # kept apart in summary.json (top level vs "plan"); every other key is listed once
    dup = {n for n in names if names.count(n) > 1}
    assert dup <= {"max_torque_ratio"}
    for k in ALL:
        if k.key.endswith("_m") and k.unit:
            assert (k.unit, k.scale) == ("mm", 1e3), k
        if k.key.endswith("_rad") and k.unit == "mrad":
            assert k.scale == 1e3, k
    assert "max_corner_deviation_m" not in names
    assert SUMMARY_KEYS == schema.keys(schema.SWEEP_ROW)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("schema")
    setup = api.load(scenario_path("corner_g2"), {"plan.grid_points": 200})
    result = api.plan_scenario(setup)
    plan = api.write_plan(setup, result, out / "plan")
    sim = api.write_simulation(setup, result, api.simulate_scenario(setup, result), out)
    return plan, sim


def test_written_summaries_use_only_schema_keys(written):
    """Every written key is in the schema, or owned by a limit class (its ratio and settings keys:
    adding a limit stays one file)."""
    from pathmotion.planning.limits import REGISTRY

    plan, sim = written
    names = {k.key for k in ALL} | {cls.summary_key() for cls in REGISTRY}
    names |= {key for cls in REGISTRY for key in cls.extra_summary_keys}
    assert set(plan) <= names, set(plan) - names
    assert set(sim) - {"plan"} <= names, set(sim) - {"plan"} - names
    assert sim["max_sharp_deviation_m"] is not None and "max_corner_deviation_m" not in sim


def _short_zigzag(radius: float) -> str:
    """Three lines with a 2 cm middle segment: both corners blended ("all") must share it."""
    return f"""
name = "zigzag"
[robot]
name = "irb140"
[path]
type = "task"
[[path.segments]]
type = "line"
start = [0.45, -0.1, 0.5]
end = [0.5, -0.1, 0.5]
[[path.segments]]
type = "line"
end = [0.5, -0.08, 0.5]
[[path.segments]]
type = "line"
end = [0.55, -0.08, 0.5]
[[path.blends]]
corner = "all"
type = "circle"
radius = {radius}
"""


def test_scenario_blends_match_the_library_shared_segment_rule():
    """The scenario file and geometry.with_transitions blend the same path the same way (one
    implementation): same segments, same points; a radius that needs more than the shared share of
    the middle segment fails in both."""
    lines = (Line([0.45, -0.1, 0.5], [0.5, -0.1, 0.5]), Line([0.5, -0.1, 0.5], [0.5, -0.08, 0.5]),
             Line([0.5, -0.08, 0.5], [0.55, -0.08, 0.5]))
    library = with_transitions(TaskPath(lines, FixedOrientation()), 0.008)
    setup = api.load_text(_short_zigzag(0.008))
    task = setup.task_path
    assert [s.kind for s in task.segments] == [s.kind for s in library.segments]
    theta = np.linspace(*library.domain, 300)
    np.testing.assert_allclose(task.evaluate(theta)[0], library.evaluate(theta)[0], atol=1e-12)
    # 0.011 m: each corner would need 0.011 m of the 0.02 m middle segment, more than its shared share
    with pytest.raises(PathError):
        with_transitions(TaskPath(lines, FixedOrientation()), 0.011)
    with pytest.raises(PathError, match=r"path\.blends\[0\] \(corner 2\)"):
        api.load_text(_short_zigzag(0.011))
