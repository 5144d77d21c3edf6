"""Run a planned scenario in its closed loop and write the simulation: simulation.csv/.parquet, summary.json."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np

from ..control import OrbitalGains, TrackingGains
from ..errors import ScenarioError, listed
from ..io import exports, schema
from ..io.atomic import write_json, write_text
from ..planning import PlanResult, Retimer
from ..simulation import Realism, SimulationSettings, simulate
from ..simulation.events import Event
from .failures import FailureKind, ResultFailure
from .plan import plan_summary, reserve_summary, write_report_data
from .setup import Setup

log = logging.getLogger(__name__)


def simulation_settings(setup: Setup) -> SimulationSettings:
    """The closed loop's settings from the scenario's ``[simulate]`` (gains checked against the controller)."""
    sim = setup.scenario.simulate
    rs = sim.realism
    realism_kwargs = dict(inertia_error=rs.inertia_error, payload_mass=rs.payload_mass,
                          viscous_friction=rs.viscous_friction, coulomb_friction=rs.coulomb_friction,
                          encoder_resolution=rs.encoder_resolution, position_noise=rs.position_noise,
                          velocity_noise=rs.velocity_noise, delay=rs.delay, seed=rs.seed)
    if rs.payload_com is not None:
        realism_kwargs["payload_com"] = rs.payload_com
    kwargs = dict(sample_time=sim.sample_time, substeps=sim.substeps, realism=Realism(**realism_kwargs),
                  path_tolerance=sim.path_tolerance, joint_tolerance=sim.joint_tolerance,
                  path_tolerance_deg=sim.path_tolerance_deg,
                  saturation_limit=sim.saturation_limit, laps=sim.laps, plant=sim.plant,
                  sampled_design=sim.sampled_design, identify_payload=sim.identify_payload,
                  events=tuple(Event(e.t, e.override, e.stop, e.resume) for e in sim.events))
    if sim.gains:
        cls, name = (OrbitalGains, "orbital_gains") if sim.controller == "orbital" else (
            TrackingGains, "computed_torque_gains" if sim.controller == "computed_torque" else "pd_gains")
        allowed = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(sim.gains) - set(allowed))
        if unknown:
            raise ScenarioError(f"simulate.gains: unknown gain(s) {listed(unknown)} for controller "
                                f"{getattr(sim.controller, 'value', sim.controller)!r}; allowed: {', '.join(allowed)}")
        base = getattr(SimulationSettings(), name)
        kwargs[name] = dataclasses.replace(base, **sim.gains)
    return SimulationSettings(**kwargs)


def simulate_scenario(setup: Setup, result: PlanResult, full: bool = False):
    """Closed-loop simulation of the planned motion with the scenario's controller and plant (the reserve
    search's run when ``result`` is the plan it chose; with simulate.events, the plan re-timed at each). ``full``: go on
    after the first failure to the end (SimulationSettings.run_to_end); by default the run stops there."""
    setup.require_searched("simulate_scenario")
    run = setup.reserve_run
    if run is not None and result is run[0] and run[1] is not None and not (full and not run[1].tracking_ok):
        return run[1]
    settings = dataclasses.replace(simulation_settings(setup), run_to_end=full)
    retimer = Retimer(result) if settings.events else None
    return simulate(setup.robot, setup.path, result.profile, setup.scenario.simulate.controller, settings,
                    retimer=retimer)


def tracking_failure(sim_summary: dict) -> ResultFailure | None:
    """Why a simulation summary's closed loop failed (message "tracking failed: <its failure message>", where
    "t = ... s, theta = ..."), None when it tracked: joins a simulate run's failures and is the reserve
    search's reason."""
    if sim_summary.get(schema.TRACKING_OK.key, True):
        return None
    failure = sim_summary.get(schema.FAILURE.key)
    if not failure:
        return ResultFailure(FailureKind.TRACKING, "tracking failed")
    return ResultFailure(FailureKind.TRACKING, f"tracking failed: {failure['message']}",
                         f"t = {failure['t']:.4g} s, theta = {failure['theta']:.4g}")


def simulation_summary(setup: Setup, result: PlanResult, sim) -> dict:
    """The simulation's summary keys plus the controller, the plant, the planned duration and the reserve search."""
    summary = dict(sim.summary())
    summary["controller"] = setup.scenario.simulate.controller
    summary[schema.PLANT.key] = setup.scenario.simulate.plant
    summary[schema.PLANNED_DURATION.key] = result.profile.duration
    summary.update(reserve_summary(setup))
    return summary


def simulation_columns(sim) -> dict[str, np.ndarray]:
    """simulation.csv columns: t, theta, q1..n, qd1..n, tau1..n, q_desired1..n, tcp xyz, desired tcp xyz,
    deviations (path_deviation; sharp_deviation: from the original sharp path, blended paths only)."""
    cols = {"t": sim.t, "theta": sim.theta}
    n = sim.q.shape[1]
    for name, arr in (("q", sim.q), ("qd", sim.qd), ("tau", sim.tau), ("q_desired", sim.q_desired)):
        cols.update({f"{name}{j + 1}": arr[:, j] for j in range(n)})
    for name, arr in (("tcp", sim.tcp), ("tcp_desired", sim.tcp_desired)):
        cols.update({f"{name}_{a}": arr[:, k] for k, a in enumerate("xyz")})
    cols["joint_deviation"] = sim.joint_deviation
    cols["path_deviation"] = sim.path_deviation
    if sim.corner_deviation is not None:
        cols["sharp_deviation"] = sim.corner_deviation
    return cols


def write_simulation(setup: Setup, result: PlanResult, sim, out: str | Path) -> dict:
    """Write simulation.csv/.parquet, summary.json (plan and simulation keys) and the report's data
    (limits.json, arm.csv, original_path.csv; see :func:`~.plan.write_report_data`)."""
    out = Path(out)
    log.info("writing the simulation to %s", out)
    out.mkdir(parents=True, exist_ok=True)
    cols = simulation_columns(sim)
    exports.write_table_csv(out / "simulation.csv", cols)
    exports.write_table_parquet(out / "simulation.parquet", cols)
    write_report_data(setup, out, sim.t, sim.q)
    summary = {"plan": plan_summary(setup, result)}
    summary.update(simulation_summary(setup, result, sim))
    if setup.scenario_text:
        write_text(out / "scenario.toml", setup.scenario_text)
    write_json(out / "summary.json", summary)
    return summary
