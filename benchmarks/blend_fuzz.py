"""The tolerance-optimal blend (planning/blend_search.py, the default search with every stage) on random polylines in
the IRB140's workspace that no test or atlas row uses: 1-2 corners in space, segments 0.05-0.25 m, tolerances
0.5-15 mm, either end at rest or at its boundary-level speed, torque limits on a third of them. Each run either
raises a PathmotionError (printed: e.g. a tolerance too large, naming the largest that fits) or returns a blend that
is checked independently: its path sampled at 20001 points within the tolerance of the sharp polyline (analytic
projection), every certified deviation within it, never slower than the symmetric G2 blends, a finite duration.

    python benchmarks/blend_fuzz.py                          # seeds 1000-1199, up to 25 minutes
    python benchmarks/blend_fuzz.py --seeds 5000 --count 40 --budget 600

Prints one line per polyline and a summary; exits 2 if any blend broke a check or anything else was raised.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import traceback

import numpy as np


def polyline(seed: int) -> tuple[np.ndarray, float, str, str, bool]:
    """(points (3 or 4, 3) [m], tolerance [m], start, end, torque) of one random case."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 5))
    pts = [np.array([rng.uniform(0.35, 0.6), rng.uniform(-0.2, 0.2), rng.uniform(0.3, 0.6)])]
    while len(pts) < k:
        d = rng.normal(size=3)
        p = pts[-1] + d / np.linalg.norm(d) * rng.uniform(0.05, 0.25)
        if 0.3 < p[0] < 0.65 and -0.3 < p[1] < 0.3 and 0.25 < p[2] < 0.65:
            pts.append(p)
    tol = float(rng.uniform(0.0005, 0.015))
    start, end = (str(rng.choice(["zero", "zero", "max"])) for _ in range(2))
    return np.array(pts), tol, start, end, bool(rng.random() < 0.3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=1000, help="first seed")
    ap.add_argument("--count", type=int, default=200, help="polylines at most")
    ap.add_argument("--budget", type=float, default=1500.0, help="wall time [s] after which no new polyline starts")
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    from pathmotion.errors import PathmotionError
    from pathmotion.planning import PlanSettings
    from pathmotion.planning.blend_search import optimal_blends
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _task
    from pathmotion.study.free_shape import Polyline

    robot = load_robot("irb140")
    print(f"load {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    stop, counts = time.time() + a.budget, {"ok": 0, "error": 0, "bad": 0}
    for seed in range(a.seeds, a.seeds + a.count):
        if time.time() > stop:
            break
        pts, tol, start, end, torque = polyline(seed)
        tag = f"seed {seed}: {len(pts) - 2} corners, {tol * 1e3:.2f} mm, {start} -> {end}, torque {torque}"
        settings = PlanSettings(start=start, end=end,
                                limits={"use_velocity": True, "use_acceleration": True, "use_torque": torque})
        t0 = time.process_time()
        try:
            best = optimal_blends(robot, _task(pts), tol, settings=settings)
        except PathmotionError as exc:
            counts["error"] += 1
            print(f"{tag}: error: {exc}", flush=True)
            continue
        except Exception:  # anything else is a bug
            counts["bad"] += 1
            print(f"{tag}: RAISED", flush=True)
            traceback.print_exc()
            continue
        theta = np.linspace(*best.path.domain, 20001)
        dev = float(np.max(Polyline(pts).distance(best.path.pose(theta)[0])))
        certified = max(s.deviation for s in best.shapes.values())
        bad = [why for why, broken in (("not finite", not np.isfinite(best.duration)),
                                       ("slower than the symmetric G2", best.duration > best.symmetric_duration),
                                       ("outside the tolerance", dev > tol * (1 + 1e-6)),
                                       ("certified above the tolerance", certified > tol * (1 + 1e-9))) if broken]
        counts["bad" if bad else "ok"] += 1
        print(f"{tag}: {best.duration:.5f} s, symmetric G2 {best.symmetric_duration:.5f} s "
              f"({100 * (1 - best.duration / best.symmetric_duration):.1f} % faster), deviation {dev * 1e3:.3f} mm "
              f"(certified {certified * 1e3:.3f}), {best.plans} plans, {time.process_time() - t0:.0f} s CPU: "
              + ("BROKEN: " + ", ".join(bad) if bad else "ok"), flush=True)
    print(f"{counts['ok']} blends pass every check, {counts['error']} clean errors, {counts['bad']} broken")
    sys.exit(2 if counts["bad"] else 0)


if __name__ == "__main__":
    main()
