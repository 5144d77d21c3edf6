"""The Python API the CLI is built on: scenario -> Setup -> plan -> simulation -> files, one module per job.

- :mod:`.setup`: parse and build (robot, task path, joint path); nothing plans there.
- :mod:`.searches`: the searches a scenario can ask for (optimal blends, ``torque_reserve = "auto"``), each
  made of many plans; :mod:`.reserve` is the reserve search's bisection and record.
- :mod:`.plan`: plan, summarize and write a plan; :mod:`.simulate`: the closed loop and its files;
  :mod:`.check`: ``pathmotion check``; :mod:`.failures`: why a result failed, as typed values; :mod:`.rapid`: a RAPID program's figures; :mod:`.program`: a task path as a robot program (orientation keys, start robconf, targets); :mod:`.demo`: shipped runs.

Each CLI subcommand is a few lines over these functions::

    setup = pathmotion.api.search(pathmotion.load("scenario.toml"))  # search: a no-op unless asked for
    result = pathmotion.plan_scenario(setup)
    pathmotion.write_plan(setup, result, "out/plan")
    sim = pathmotion.simulate_scenario(setup, result)
    pathmotion.write_simulation(setup, result, sim, "out/sim")
"""

from .check import check_scenario, path_is_closed
from .demo import DEMO_COLUMNS, DEMO_SCENARIOS, run_shipped, write_demo_table
from .failures import FailureKind, ResultFailure
from .plan import (enforced_limits, limit_settings_summary, phase_plane_columns, plan_failures, plan_scenario,
                   plan_summary, reserve_summary, second_order_plan, write_plan, write_report_data)
from .program import program_thetas
from .rapid import rapid_estimate, rapid_flange, rapid_zone_tolerances
from .searches import resolve_torque_reserve, search, search_blends
from .setup import (BlendRequest, Setup, build, build_path, build_robot, load, load_text, plan_settings,
                    reach_bound, split_first_segment)
from .simulate import (simulate_scenario, simulation_columns, simulation_settings, simulation_summary,
                       tracking_failure, write_simulation)

__all__ = [
    "BlendRequest", "DEMO_COLUMNS", "DEMO_SCENARIOS", "FailureKind", "ResultFailure", "Setup", "build", "build_path", "build_robot", "check_scenario",
    "enforced_limits", "limit_settings_summary", "load", "load_text", "path_is_closed", "phase_plane_columns",
    "plan_failures", "plan_scenario", "plan_settings", "plan_summary", "program_thetas", "rapid_estimate", "rapid_flange", "rapid_zone_tolerances",
    "reach_bound", "reserve_summary", "resolve_torque_reserve", "run_shipped", "search", "search_blends",
    "second_order_plan", "simulate_scenario", "simulation_columns", "simulation_settings", "simulation_summary",
    "split_first_segment", "tracking_failure", "write_demo_table", "write_plan", "write_report_data",
    "write_simulation",
]
