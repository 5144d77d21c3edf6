"""A failed closed-loop run stops at its first failure and its summary says that its figures cover t in
[0, t_end] only; SimulationSettings.run_to_end (``simulate --full``) goes on to the end of the motion with the
same first failure as the verdict."""

import dataclasses

from pathmotion import api
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import simulate


def test_a_failed_run_says_what_its_figures_cover_and_full_runs_on():
    setup = api.load(scenario_path("corner_max"))  # leaves the 1 mm tolerance at the corner (the thesis' case)
    result = api.plan_scenario(setup)
    stopped = api.simulate_scenario(setup, result)
    s = stopped.summary()
    assert not stopped.tracking_ok and stopped.stopped_at_failure
    assert s["figures_cover_t_s"] == [0.0, float(stopped.t[-1])]
    assert f"t in [0, {stopped.t[-1]:.4g}] s only" in s["coverage_note"] and "--full" in s["coverage_note"]
    assert stopped.t[-1] < result.profile.duration
    full = api.simulate_scenario(setup, result, full=True)
    f = full.summary()
    assert not full.tracking_ok and not full.stopped_at_failure and f["coverage_note"] is None
    assert full.failure.t == stopped.failure.t and full.failure.reason == stopped.failure.reason
    assert full.t[-1] >= result.profile.duration  # on to the end of the motion
    n = len(stopped.t)  # the same run up to the stop (deterministic plant), then more
    assert (full.q[:n] == stopped.q[:n]).all()
    assert f["path_accuracy_m"] >= s["path_accuracy_m"]
    same = simulate(setup.robot, setup.path, result.profile, "orbital",
                    dataclasses.replace(api.simulation_settings(setup), run_to_end=True))
    assert same.t[-1] == full.t[-1]
