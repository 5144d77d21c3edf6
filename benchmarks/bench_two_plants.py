"""The shipped scenarios on both plants: the built-in RK4 plant and MuJoCo (a second, independent plant).

For each scenario in scenarios/*.toml: plan once, simulate the scenario's controller on ``plant = "builtin"``
and on ``plant = "mujoco"`` (same controller, sample time and realism), and print the verdict, the cycle time
(and the relative difference, target within 1 %), the TCP path accuracy and the largest joint deviation of each.
Then the friction rows: circle_zero with docs/control.md's joint friction (REALISTIC_VISCOUS_FRICTION,
REALISTIC_COULOMB_FRICTION; MuJoCo maps it to dof_damping and dof_frictionloss) and with 2 N m s/rad + 2 N m on
every joint (a hard case for the orbital controller).
Run: python benchmarks/bench_two_plants.py [scenario names...]   (needs ``pip install "pathmotion[mujoco]"``)
"""

from __future__ import annotations

import dataclasses
import os
import sys
from pathlib import Path

from pathmotion import api, defaults
from pathmotion.simulation import Realism, simulate

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
#: Friction rows: label -> (scenario, the realism of both plants).
FRICTION_ROWS = {
    "circle_zero + friction (docs values)": ("circle_zero", Realism(
        viscous_friction=defaults.REALISTIC_VISCOUS_FRICTION, coulomb_friction=defaults.REALISTIC_COULOMB_FRICTION)),
    "circle_zero + 2 N m s/rad, 2 N m": ("circle_zero", Realism(viscous_friction=2.0, coulomb_friction=2.0)),
}


def run(name: str, label: str | None = None, realism: Realism | None = None) -> list[str]:
    """One table row per plant pair: scenario, verdicts, cycle times and their difference, accuracies.
    ``realism``: replaces the scenario's (per-joint values, which the scenario file cannot give)."""
    setup = api.load(SCENARIOS / f"{name}.toml", {})
    plan = api.plan_scenario(setup)
    out = {}
    for plant in ("builtin", "mujoco"):
        settings = dataclasses.replace(api.simulation_settings(setup), plant=plant)
        if realism is not None:
            settings = dataclasses.replace(settings, realism=realism)
        out[plant] = simulate(setup.robot, setup.path, plan.profile, setup.scenario.simulate.controller,
                              settings).summary()
    b, m = out["builtin"], out["mujoco"]
    cb, cm = b.get("cycle_time_s"), m.get("cycle_time_s")
    diff = f"{abs(cm - cb) / cb:.1e}" if cb and cm else "-"

    def verdict(s):
        return "ok" if s["tracking_ok"] else f"fail ({s['failure']['reason']})"

    def cyc(s):
        return f"{s['cycle_time_s']:.4f}" if s.get("cycle_time_s") else "-"

    return [label or name, setup.scenario.simulate.controller, verdict(b), verdict(m), cyc(b), cyc(m), diff,
            f"{b['path_accuracy_m'] * 1e3:.3f}", f"{m['path_accuracy_m'] * 1e3:.3f}",
            f"{b['max_joint_deviation_rad']:.2e}", f"{m['max_joint_deviation_rad']:.2e}"]


def main(names: list[str]) -> None:
    friction = not names
    names = names or sorted(p.stem for p in SCENARIOS.glob("*.toml"))
    head = ["scenario", "controller", "verdict builtin", "verdict mujoco", "cycle builtin [s]", "cycle mujoco [s]",
            "rel. diff", "path acc. builtin [mm]", "path acc. mujoco [mm]", "joint dev. builtin [rad]",
            "joint dev. mujoco [rad]"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name in names:
        print("| " + " | ".join(run(name)) + " |", flush=True)
    for label, (name, realism) in (FRICTION_ROWS.items() if friction else ()):
        print("| " + " | ".join(run(name, label, realism)) + " |", flush=True)
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f} (2 cores)")


if __name__ == "__main__":
    main(sys.argv[1:])
