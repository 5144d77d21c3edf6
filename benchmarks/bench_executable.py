"""What executable motion buys: the IRB140 circle in closed loop with the realism of docs/control.md.

Every case is planned, then run in the same closed loop: the orbital controller with its default gains and
design (the sampled design with the delay in the model, the disturbance observer, the payload and friction
identification) at 4 ms on a plant with
``Realism.realistic(seed=0)`` (10 % link inertia error, an unmodelled 6 kg payload 0.1 m beyond the flange,
friction on every axis, 20-bit encoder, noise, one-sample delay), given as the scenario's
``[simulate.realism]`` so that ``torque_reserve = "auto"`` searches in that very loop. The cases:

* plain: ``circle_zero`` on torque alone (acceleration estimates off), no reserve: the torque-limited optimum;
* smooth: ``circle_smooth`` as shipped: jerk limits (the IRB140 estimates), reserve 0.2, torque-speed envelope;
* smooth, auto: ``circle_smooth`` with ``torque_reserve = "auto"``;
* plain, auto: ``circle_zero`` on torque alone with ``torque_reserve = "auto"`` (the reserve without jerk limits);
* smooth, jerk x k (``--jerk-scales``): ``circle_smooth`` with ``limits.jerk_scale = k``, reserve 0.2 and "auto".

A run that fails the verdict stops where it fails, so it has no cycle time; the columns "relaxed" run the
same plan to the end with the verdict widened (path tolerance 0.5 m, joint tolerance 1 rad, no saturation
limit, 3 s observed after the arrival) and give the time from which the TCP stays within 1 mm of the end
point, the largest TCP distance from the planned path, and that distance after the start-up (``START_UP``, where
the unknown payload's step at t = 0 sags the TCP): how long the motion takes, and how far the TCP strays, when
nothing stops it.

Run: python benchmarks/bench_executable.py [--jerk-scales 4,6,8]
     options: --continuous-design (simulate.sampled_design = false); --gains k=v,... overrides the default gains,
     e.g. bandwidth=80,integral_rate=40 (raised gains) or observer_range=2 (a faster disturbance observer, robust
     for a narrower range of plant inertias); --no-identification (simulate.identify_payload = false: the
     disturbance observer alone); --seed S (Realism.realistic(seed=S)); --smooth-only (only circle_smooth)
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

import numpy as np

from pathmotion import api, defaults
from pathmotion.robot import fk
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import Realism, simulate

#: docs/control.md's realistic plant as scenario keys (Realism.realistic(seed=0); checked in main()).
REALISM = {
    "inertia_error": defaults.REALISTIC_INERTIA_ERROR, "payload_mass": defaults.REALISTIC_PAYLOAD_MASS,
    "payload_com": list(defaults.REALISTIC_PAYLOAD_COM), "viscous_friction": list(defaults.REALISTIC_VISCOUS_FRICTION),
    "coulomb_friction": list(defaults.REALISTIC_COULOMB_FRICTION),
    "encoder_resolution": defaults.REALISTIC_ENCODER_RESOLUTION, "position_noise": defaults.REALISTIC_POSITION_NOISE,
    "velocity_noise": defaults.REALISTIC_VELOCITY_NOISE, "delay": True, "seed": 0,
}
#: The widened verdict of the "relaxed" columns: path tolerance [m], joint tolerance [rad], saturation limit [s],
#: time observed after the arrival [s]; and the distance from the end point [m] within which the TCP has arrived.
RELAXED = {"path_tolerance": 0.5, "joint_tolerance": 1.0, "saturation_limit": 1e3, "settle_time": 3.0}
ARRIVED = defaults.PATH_TOLERANCE
#: The start-up [s] the last column leaves out: the unknown payload appears as a step at t = 0 (the controller's
#: integral and observer start empty) and sags the TCP in the first ~30 ms, before the plan has moved.
START_UP = 0.1
TORQUE_ONLY = {"limits.use_acceleration": False}


def cases(jerk_scales: list[float]) -> list[tuple[str, str, dict]]:
    """(label, shipped scenario, overrides) of every case."""
    out = [("plain (torque only, no reserve)", "circle_zero", TORQUE_ONLY),
           ("smooth (jerk + reserve 0.2 + envelope)", "circle_smooth", {}),
           ("smooth, reserve auto", "circle_smooth", {"limits.torque_reserve": "auto"}),
           ("plain, reserve auto", "circle_zero", {**TORQUE_ONLY, "limits.torque_reserve": "auto"})]
    for k in jerk_scales:
        out += [(f"smooth, jerk x {k:g}", "circle_smooth", {"limits.jerk_scale": k}),
                (f"smooth, jerk x {k:g}, reserve auto", "circle_smooth",
                 {"limits.jerk_scale": k, "limits.torque_reserve": "auto"})]
    return out


def loop_overrides(sampled_design: bool = defaults.ORBITAL_SAMPLED_DESIGN, gains: dict | None = None,
                   seed: int = 0, identify: bool = defaults.PAYLOAD_IDENTIFICATION) -> dict:
    """The closed loop every case runs in, as scenario keys (gains: overrides of the default orbital gains; seed:
    the realism's seed, which draws the inertia errors' signs and the noise; identify: the payload identification)."""
    out = {f"simulate.realism.{k}": v for k, v in REALISM.items()}
    out["simulate.realism.seed"] = seed
    out.update({"simulate.controller": "orbital", "simulate.sampled_design": sampled_design,
                "simulate.identify_payload": identify})
    gains = gains or {}
    out.update({f"simulate.gains.{k}": v for k, v in gains.items()})
    return out


def _mm(v) -> str:
    return "-" if v is None else f"{v * 1e3:.2f}"


def _s(v) -> str:
    return "-" if v is None else f"{v:.4f}"


def settled(setup, sim) -> float | None:
    """Time [s] from which the TCP stays within ARRIVED of the path's end point (None: not by the run's end)."""
    end = fk(setup.robot, setup.path.evaluate(np.array([setup.path.domain[1]]))[0])[0][0]
    away = np.flatnonzero(np.linalg.norm(sim.tcp - end, axis=1) > ARRIVED)
    k = 0 if not away.size else away[-1] + 1
    return float(sim.t[k]) if k < len(sim.t) - 1 else None


def _never(summary: dict) -> str:
    """The relaxed cell of a run that never settles at the end: why it stopped."""
    f = summary["failure"]
    return "never" + ("" if f is None else f" ({f['reason']} at t = {f['t']:.2f} s)")


def row(label: str, name: str, overrides: dict, loop: dict) -> list[str]:
    """One table row: the case planned (and its reserve searched) and run in the closed loop, then relaxed."""
    start = time.perf_counter()
    setup = api.search(api.load(scenario_path(name), {**overrides, **loop}))
    result = api.plan_scenario(setup)
    s = api.simulation_summary(setup, result, api.simulate_scenario(setup, result))
    settings = dataclasses.replace(api.simulation_settings(setup), **RELAXED)
    relaxed_run = simulate(setup.robot, setup.path, result.profile, setup.scenario.simulate.controller, settings)
    relaxed, rc = relaxed_run.summary(), settled(setup, relaxed_run)
    later = relaxed_run.path_deviation[relaxed_run.t >= START_UP]
    planned, cycle = result.duration, s["cycle_time_s"]
    verdict = "yes" if s["tracking_ok"] else f"**no** ({s['failure']['reason']} at t = {s['failure']['t']:.3f} s)"
    search = setup.reserve_search
    torque = setup.plan_settings.limits["torque"]
    reserve = torque.value if torque.on else None
    tried = "" if search is None else " (" + ", ".join(f"{t.reserve:g} {t.verdict.value}" for t in search.trials) + ")"
    return [label, f"{reserve:g}{tried}" if reserve is not None else "-", _s(planned), _s(cycle),
            "-" if cycle is None else f"{cycle / planned:.3f}", _mm(s["path_accuracy_m"]), verdict,
            f"{s['max_commanded_torque_ratio']:.2f}", _s(rc) if rc is not None else _never(relaxed),
            _mm(relaxed["path_accuracy_m"]), _mm(float(later.max()) if later.size else None),
            f"{time.perf_counter() - start:.0f}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--continuous-design", action="store_true",
                        help="simulate.sampled_design = false (default: the sampled design, the project's default)")
    parser.add_argument("--gains", default="", help="orbital gains overriding the defaults, e.g. "
                        "bandwidth=80,integral_rate=40 or observer_range=2")
    parser.add_argument("--jerk-scales", default="", help="extra rows: circle_smooth with limits.jerk_scale = k")
    parser.add_argument("--seed", type=int, default=0, help="the realism's seed (Realism.realistic(seed))")
    parser.add_argument("--no-identification", action="store_true",
                        help="simulate.identify_payload = false (the disturbance observer alone)")
    parser.add_argument("--smooth-only", action="store_true", help="only the row 'smooth' (circle_smooth as shipped)")
    args = parser.parse_args()
    gains = {k: float(v) for k, v in (item.split("=") for item in args.gains.split(",") if item)}
    sampled = defaults.ORBITAL_SAMPLED_DESIGN and not args.continuous_design
    loop = loop_overrides(sampled, gains, args.seed, not args.no_identification)
    probe = api.simulation_settings(api.load(scenario_path("circle_zero"), loop)).realism
    assert probe == Realism.realistic(seed=args.seed), "REALISM must be docs/control.md's realistic plant"
    head = ["case", "torque reserve (runs)", "planned [s]", "cycle [s]", "cycle / planned", "path accuracy [mm]",
            "tracks within 1 mm", "max commanded torque / limit", "relaxed: within 1 mm of the end from [s]",
            "relaxed: path accuracy [mm]", f"relaxed: path accuracy after {START_UP:g} s [mm]", "wall [s]"]
    print(f"orbital controller, 4 ms, sampled_design = {str(sampled).lower()}, gains {gains or 'default'}, payload "
          f"identification {'off' if args.no_identification else 'on'}; realism: Realism.realistic(seed={args.seed})")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    rows = cases([float(k) for k in args.jerk_scales.split(",") if k])
    if args.smooth_only:
        rows = [r for r in rows if r[0].startswith("smooth (")]
    for label, name, overrides in rows:
        print("| " + " | ".join(row(label, name, overrides, loop)) + " |", flush=True)
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f} (2 cores)")


if __name__ == "__main__":
    main()
