"""What one stage of the optimal blend search (planning/blend_search.py) buys.

Per atlas-style corner (two 0.2 m lines, rest to rest, velocity and acceleration limits: the atlas'
settings), the search without the stage and with it, one after the other on the same corner: the full-grid
duration of each, the gain, the plans and the CPU time. The search is deterministic, so one run each.
``--stage joint`` (the default): the joint stage (stage 6, ``joint_plans`` 0 / JOINT_PLANS), which runs only
where a free end made the blend faster (a corner whose blend reaches a path end where the motion rests),
elsewhere both are the same. ``--stage polish``: the full-grid polish (stage 8, ``polish_plans`` 0 /
POLISH_PLANS), which runs at every corner. ``--stage wide``: both wide starts (after stage 6, ``wide_plans`` and
``wide_normal_plans`` 0 / WIDE_PLANS and WIDE_NORMAL_PLANS), which run where the motion rests at an end of the
corner's neighbours. ``--stage crossed``: the two crossed wide starts (after the wide restart, ``wide_crossed_plans``
0 / WIDE_CROSSED_PLANS), which run where the motion rests at both ends. ``--stage global``: the global stage (CMA-ES
after the local stages, ``global_plans`` 0 / GLOBAL_PLANS), which runs at every line-line corner. ``--stage none``:
the search as it is, once per corner (its CPU time; to compare two versions of the code, run it beside itself with
PYTHONPATH on a worktree of the other commit).

    python benchmarks/blend_search_stages.py                       # the default corners below
    python benchmarks/blend_search_stages.py 60:0.01 45:0.007     # ANGLE_DEG:TOLERANCE_M ...
    python benchmarks/blend_search_stages.py --stage polish 120:0.001
    python benchmarks/blend_search_stages.py --stage crossed 135:0.007 135:0.002 105:0.007 45:0.002
    python benchmarks/blend_search_stages.py --stage global 60:0.01 60:0.005 30:0.005 120:0.005
    git worktree add ../old COMMIT && PYTHONPATH=../old python benchmarks/blend_search_stages.py --stage none
"""

from __future__ import annotations

import argparse
import os
import time

#: Atlas corners with free ends and corners outside the atlas' angles.
DEFAULT_CORNERS = ("60:0.01", "30:0.005", "30:0.01", "90:0.01", "120:0.01", "45:0.007", "105:0.007", "135:0.004")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corners", nargs="*", default=list(DEFAULT_CORNERS), help="ANGLE_DEG:TOLERANCE_M")
    ap.add_argument("--stage", choices=("joint", "polish", "wide", "crossed", "global", "none"), default="joint",
                    help="the stage turned off and on (none: the search once, as it is)")
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    import pathmotion
    from pathmotion.planning.blend_search import (GLOBAL_PLANS, JOINT_PLANS, POLISH_PLANS, WIDE_CROSSED_PLANS,
                                                  WIDE_NORMAL_PLANS, WIDE_PLANS, optimal_blends)
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _settings, _task, corner_points

    robot = load_robot("irb140")
    settings = _settings(verify=False, baselines=False)
    if a.stage == "none":
        _once(a.corners, robot, settings, pathmotion.__file__)
        return
    on = {"joint": {"joint_plans": JOINT_PLANS}, "polish": {"polish_plans": POLISH_PLANS},
          "wide": {"wide_plans": WIDE_PLANS, "wide_normal_plans": WIDE_NORMAL_PLANS},
          "crossed": {"wide_crossed_plans": WIDE_CROSSED_PLANS}, "global": {"global_plans": GLOBAL_PLANS}}[a.stage]
    off = dict.fromkeys(on, 0)
    print(f"stage: {a.stage} ({off} / {on})")
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores)")
    print(f"{'corner':>12} {'without [s]':>12} {'with [s]':>10} {'gain':>8} {'plans':>11} {'cpu [s]':>13}")
    for text in a.corners:
        angle, tol = (float(v) for v in text.split(":"))
        task = _task(corner_points(angle))
        runs = []
        for plans in (off, on):
            t0 = time.process_time()
            found = optimal_blends(robot, task, tol, settings=settings, **plans)
            runs.append((found.duration, found.plans, time.process_time() - t0))
        (t_without, p_without, c_without), (t_with, p_with, c_with) = runs
        print(f"{angle:5.0f}/{tol * 1e3:4.1f} mm {t_without:12.5f} {t_with:10.5f} {1 - t_with / t_without:8.2%} "
              f"{p_without:5d}/{p_with:<5d} {c_without:6.1f}/{c_with:<6.1f}")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


def _once(corners, robot, settings, where: str) -> None:
    """The search as it is, once per corner: its duration, plans and CPU time."""
    from pathmotion.planning.blend_search import optimal_blends
    from pathmotion.study.atlas import _task, corner_points

    print(f"code: {where}")
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores)")
    print(f"{'corner':>12} {'duration [s]':>13} {'plans':>6} {'cpu [s]':>8} {'deviation [m]':>14}")
    for text in corners:
        angle, tol = (float(v) for v in text.split(":"))
        t0 = time.process_time()
        found = optimal_blends(robot, _task(corner_points(angle)), tol, settings=settings)
        print(f"{angle:5.0f}/{tol * 1e3:4.1f} mm {found.duration:13.6f} {found.plans:6d} {time.process_time() - t0:8.1f} "
              f"{found.shapes[0].deviation:14.8g}", flush=True)
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
