"""The feedback reserve the IRB140's closed loop needs: the smallest torque reserve with which each motion's plan
tracks, on the shipped scenarios and on seeded random motions in the workspace.

    PYTHONPATH=$PWD python benchmarks/irb140_torque_reserve.py [--random 4] [--json benchmarks/results/irb140_reserve.json]

Each case runs ``torque_reserve = "auto"`` (pathmotion.api.resolve_torque_reserve: plan + closed loop per tried
reserve, bisection over 0 .. AUTO_RESERVE_MAX in steps of AUTO_RESERVE_STEP) with the limits file as it is and the
scenario's own controller and tolerances. Random cases (seeded): circles of radius 0.05-0.15 m in a horizontal,
vertical or tilted plane; polylines of 3-4 straight moves stopping at each corner; the same polylines with G2
blends of 5-20 mm at every corner (a smooth spline-like path). All have the tool pointing down, centres in
x 0.40-0.60, y -0.20..0.20, z 0.35-0.60 m, start and end at rest; a draw the arm cannot reach is drawn again.
The default reserve (pathmotion/defaults.py TORQUE_RESERVE) is chosen from this table: docs/robot.md says how.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from result_json import Table

from pathmotion import api
from pathmotion.errors import PathmotionError
from pathmotion.robot import load_robot
from pathmotion.scenarios import scenario_path

#: Shipped scenarios measured: all but the two that fail on purpose at any reserve (circle_vertical: a speed jump
#: no arm can run; corner_max: the corner at full speed, far outside the path tolerance).
SHIPPED = ("circle_zero", "circle_periodic", "circle_max", "circle_smooth", "circle_vertical_chain", "corner_g2",
           "corner_transition", "corner_stop", "abb_cycle", "pick_place", "joint_waypoints")
#: The model error of a real arm the reserve has to cover (--realism): 10 % link mass and inertia error (the
#: inertias are CAD estimates), 1 kg at the flange the model does not know of (a gripper or part left out of the
#: payload), unmodelled Coulomb friction of 2 % of each torque limit.
REALISM = {"simulate.realism.inertia_error": 0.1, "simulate.realism.payload_mass": 1.0}
FRICTION_SHARE = 0.02
HEAD = '[robot]\nname = "irb140"\n\n[path]\ntype = "task"\norientation = "down"\n'
TAIL = '\n[plan]\nstart = "zero"\nend = "zero"\n'


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:.4f}" for x in v) + "]"


def _centre(rng) -> np.ndarray:
    return np.array([rng.uniform(0.40, 0.60), rng.uniform(-0.20, 0.20), rng.uniform(0.35, 0.60)])


def random_circle(rng) -> str:
    normal = [(0, 0, 1), (1, 0, 0), (0, 1, 0), (1, 0, 1), (0, 1, 1)][rng.integers(5)]
    return HEAD + (f'[[path.segments]]\ntype = "circle"\ncenter = {_vec(_centre(rng))}\n'
                   f"radius = {rng.uniform(0.05, 0.15):.4f}\nnormal = {_vec(normal)}\n") + TAIL


def random_polyline(rng, blend: bool) -> str:
    c = _centre(rng)
    points = [c + rng.uniform(-0.12, 0.12, 3) * (1, 1, 0.6) for _ in range(int(rng.integers(4, 6)))]
    text = HEAD + "".join(f'[[path.segments]]\ntype = "line"\n' + (f"start = {_vec(points[0])}\n" if k == 1 else "")
                          + f"end = {_vec(points[k])}\n" for k in range(1, len(points)))
    if blend:
        text += f'[[path.blends]]\ncorner = "all"\ntype = "g2"\ntolerance = {rng.uniform(0.005, 0.02):.4f}\n'
    return text + TAIL


def random_cases(count: int, seed: int = 0):
    """(name, TOML text) of ``count`` reachable random motions of each kind."""
    rng = np.random.default_rng(seed)
    makers = (("circle", random_circle), ("lines", lambda r: random_polyline(r, False)),
              ("blended", lambda r: random_polyline(r, True)))
    for kind, make in makers:
        found = 0
        while found < count:
            text = make(rng)
            try:
                api.load_text(text, where=f"random {kind}")
            except PathmotionError:
                continue
            found += 1
            yield f"random {kind} {found}", text


def overrides(realism: bool) -> dict:
    """The scenario overrides of every case: the reserve search, and with ``realism`` the model error."""
    out = {"limits.torque_reserve": "auto"}
    if realism:
        torque = load_robot("irb140").limits.torque
        out |= REALISM | {"simulate.realism.coulomb_friction": [round(float(v), 4) for v in FRICTION_SHARE * torque]}
    return out


def measure(name: str, setup) -> dict:
    """The reserve search on one case: the chosen reserve, the duration at reserve 0 and at the chosen one."""
    wall = time.perf_counter()
    searched = api.resolve_torque_reserve(setup)
    record = searched.reserve_search
    by_reserve = {t.reserve: t for t in record.trials}
    zero, chosen = by_reserve.get(0.0), by_reserve.get(record.chosen)
    return dict(case=name, reserve=record.chosen, tried=", ".join(f"{t.reserve:g} {t.verdict.value}" for t in record.trials),
                planned_0_s=None if zero is None or zero.planned_duration_s is None else round(zero.planned_duration_s, 4),
                planned_s=None if chosen is None else round(chosen.planned_duration_s, 4),
                accuracy_mm=None if chosen is None or chosen.path_accuracy_m is None else round(chosen.path_accuracy_m * 1e3, 3),
                wall_s=round(time.perf_counter() - wall, 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--random", type=int, default=4, help="random motions of each kind")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", choices=("shipped", "random"), help="measure one group only")
    ap.add_argument("--realism", action="store_true", help="the plant with REALISM's model error (default: nominal)")
    ap.add_argument("--json", help="write the table as JSON here (for benchmarks/results.py)")
    a = ap.parse_args()
    plant = ("10 % inertia error, 1 kg unmodelled payload, 2 % unmodelled Coulomb friction" if a.realism
             else "nominal plant")
    table = Table(f"The torque reserve each motion's closed loop needs (IRB140, limits file, {plant})",
                  [("case", "case"), ("reserve", "smallest reserve that tracks"), ("tried", "reserves tried"),
                   ("planned_0_s", "planned at reserve 0 [s]"), ("planned_s", "planned at that reserve [s]"),
                   ("accuracy_mm", "path accuracy [mm]"), ("wall_s", "search wall time [s]")])
    cases, over = [], overrides(a.realism)
    if a.only != "random":
        cases += [(n, lambda n=n: api.load(scenario_path(n), over)) for n in SHIPPED]
    if a.only != "shipped":
        cases += [(n, lambda t=t, n=n: api.load_text(t, where=n, overrides=over)) for n, t in random_cases(a.random, a.seed)]
    for name, load in cases:
        row = measure(name, load())
        table.add(**row)
        print(row, flush=True)
    reserves = [r["reserve"] for r in table.rows]
    needed = [r for r in reserves if r is not None]
    print(f"largest reserve needed: {max(needed):g}; cases with none that tracks: {reserves.count(None)}")
    if a.json:
        print(f"wrote {table.write(a.json)}")


if __name__ == "__main__":
    main()
