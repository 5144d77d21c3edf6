"""Where the optimal blend loses time against the corner-confined free-shape optimum.

For one atlas corner (angle, tolerance): the optimal blend (planning/blend_search.py), the corner-
confined free-shape optimum on the blend's own spans (study/free_shape.py, CasADi + IPOPT), and
pathmotion's planner along the optimum's OWN TCP path (study/optimum_path.py), as it is and pressed
into the corner's plane (its control points projected: exact for a Bezier). Every plan on the same
grid, rest to rest, velocity and acceleration limits (the atlas' settings).

    python benchmarks/replan_optimum.py 60 0.001
    python benchmarks/replan_optimum.py 120 0.01 --meshes 25,50,100 --grid 2000
    python benchmarks/replan_optimum.py 120 0.01 --rise-plans 0     # the blend search kept in the plane
    python benchmarks/replan_optimum.py 30 0.005 --plan-tolerance 1e-4 --behind   # converged plans; where time is lost
    python benchmarks/replan_optimum.py 135 0.007 --plan-tolerance 1e-4 --speeds  # speed and curvature at the turn
    python benchmarks/replan_optimum.py 60 0.01 --resample 1,4,10   # the optimum's curvature jumps kept / smoothed
    python benchmarks/replan_optimum.py 60 0.01 --smooth-windows 0:50,150:250   # smoothed only there [mm of arc]

Reading: "optimum path" within a few 0.01 % of the NLP's finest mesh means planner and NLP agree on
the same geometry (the gap of the blend is its shape family, not the planner); "in the plane" minus
"optimum path" is what the optimum gains by leaving the corner's plane. ``--resample k``: the optimum's path
re-built from its own geometry at every k-th NLP node (quintic Hermite pieces in arc length: X = p, X' = h p',
X'' = h^2 p'' at both ends of a piece of arc h), once with the curvature's one-sided values at each node (the jumps
the optimum's bang-bang accelerations put there kept) and once with their mean (G2, as every blend family is).
``--smooth-windows``: the same rebuild at every node, smoothed only at the nodes within each window of arc, and the
largest curvature jumps.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def _arguments() -> argparse.Namespace:
    """The command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("angle", type=float, help="turn angle [deg]")
    ap.add_argument("tolerance", type=float, help="tube radius [m]")
    ap.add_argument("--meshes", default="25,50,100", help="NLP meshes (intervals)")
    ap.add_argument("--grid", type=int, default=2000, help="planner grid points")
    ap.add_argument("--profile", action="store_true",
                    help="print the optimum's and the blend's paths every 10 mm of arc: distance from the sharp "
                         "path, height above the corner's plane, curvature")
    ap.add_argument("--plan-tolerance", type=float, default=None,
                    help="plan on the adaptive grid refined to this relative duration error instead of --grid points")
    ap.add_argument("--behind", action="store_true",
                    help="print how far the blend trails the optimum's own path (both planned) every 5 %% of arc")
    ap.add_argument("--speeds", action="store_true",
                    help="print both planned paths' speed, curvature and time every 4 mm of arc within 60 mm of the "
                         "corner (arc from each path's point nearest the sharp corner)")
    ap.add_argument("--resample", default="",
                    help="comma-separated k: replan the optimum's path rebuilt at every k-th node, its curvature jumps "
                         "kept and smoothed (G2)")
    ap.add_argument("--smooth-windows", default="",
                    help="comma-separated lo:hi [mm of the optimum's arc]: its path rebuilt at every node, smoothed "
                         "only within each window")
    ap.add_argument("--rise-plans", type=int, default=None,
                    help="plans of the blend search's out-of-plane stage (default RISE_PLANS; 0: in the plane)")
    return ap.parse_args()


def _print_resampled(a, nodes, optimum_path, own: float, duration) -> None:
    """--resample: the optimum's path rebuilt at every k-th node, with and without its curvature jumps."""
    for every in (int(k) for k in a.resample.split(",") if k):
        knots = nodes[::every]
        if knots[-1] < optimum_path.domain[1]:
            knots = np.append(knots, optimum_path.domain[1])
        cells = []
        for jumps in (True, False):
            T = duration(hermite_chain(optimum_path, knots, np.full(len(knots), jumps)))
            cells.append(f"{T:.5f} s ({100 * (T / own - 1):+.2f} %)")
        print(f"  optimum path rebuilt at every {every}. node ({len(knots) - 1} pieces): curvature jumps kept "
              f"{cells[0]}, smoothed (G2) {cells[1]}, vs the optimum path")


def _print_smoothed(a, nodes, optimum_path, own: float, duration) -> None:
    """--smooth-windows: the optimum's path smoothed (G2) only within each window of its arc."""
    if a.smooth_windows:
        jump = np.array([np.linalg.norm(np.subtract(*(optimum_path.pose(np.array([x]), side=side)[2][0]
                                                      for side in ("left", "right")))) for x in nodes])
        away = np.flatnonzero((nodes > 0.01) & (nodes < nodes[-1] - 0.01))  # the short pieces at a resting end aside
        inner = away[np.argsort(jump[away])[::-1][:5]]
        print("  the optimum's largest curvature jumps between its pieces, 10 mm or more from its ends: "
              + ", ".join(f"{jump[i]:.2f} 1/m at {nodes[i] * 1e3:.1f} mm" for i in inner)
              + f" of {nodes[-1] * 1e3:.1f} mm (median {np.median(jump[away]):.2f} 1/m)")
        for window in a.smooth_windows.split(","):
            lo, hi = (float(v) * 1e-3 for v in window.split(":"))
            T = duration(hermite_chain(optimum_path, nodes, (nodes < lo) | (nodes > hi)))
            print(f"  optimum path rebuilt at every node, smoothed (G2) only within {lo * 1e3:g}-{hi * 1e3:g} mm of "
                  f"arc: {T:.5f} s ({100 * (T / own - 1):+.2f} %) vs the optimum path")


def _print_behind(a, profiles: dict) -> None:
    """--behind: how far the blend trails the optimum's own path, every 5 % of arc."""
    if a.behind:
        print(f"  the blend behind the optimum's own path (arc lengths {profiles['blend'][1] * 1e3:.1f} / "
              f"{profiles['optimum'][1] * 1e3:.1f} mm), at shares of each one's arc:")
        for share in np.linspace(0.0, 1.0, 21):
            t = {k: float(np.interp(share * L, p.grid, p.times)) for k, (p, L) in profiles.items()}
            print(f"    {share:4.2f}: optimum path {t['optimum']:.4f} s, blend {t['blend']:.4f} s, "
                  f"behind {1e3 * (t['blend'] - t['optimum']):+6.2f} ms")


def _print_speeds(a, pts, profiles: dict, optimum_path, best) -> None:
    """--speeds: both planned paths' speed, curvature and time near the corner."""
    if a.speeds:
        print("  speed [m/s], curvature [1/m] and time [s] within 60 mm of each path's point nearest the corner:")
        near = {}
        for name, path in (("optimum", optimum_path), ("blend", best.path)):
            theta = np.linspace(0.0, path.domain[1], 20001)
            p, _, ddp = path.pose(theta)[:3]
            apex = theta[int(np.argmin(np.linalg.norm(p - pts[1], axis=1)))]
            near[name] = (theta, theta - apex, np.linalg.norm(ddp, axis=1))
        for d in np.arange(-0.06, 0.06 + 1e-9, 0.004):
            cells = []
            for name in ("optimum", "blend"):
                profile, _ = profiles[name]
                theta, rel, curvature = near[name]
                i = int(np.argmin(np.abs(rel - d)))
                cells.append(f"{name} {np.sqrt(profile.x_at(theta[i])):.3f} m/s, {curvature[i]:6.1f} 1/m, "
                             f"{np.interp(theta[i], profile.grid, profile.times):.4f} s")
            print(f"    {d * 1e3:+4.0f} mm: " + "   ".join(cells))


def _print_profile(a, pts, normal, optimum_path, best) -> None:
    """--profile: both paths every 10 mm of arc (distance, height, curvature)."""
    from pathmotion.study import free_shape as fs

    if a.profile:
        for name, path in (("optimum", optimum_path), ("optimal blend", best.path)):
            print(f"  {name}'s path every 10 mm of arc (from the corner's arc position on the sharp path):")
            theta = np.arange(0.0, path.domain[1], 0.01)
            p, _, ddp = path.pose(theta)[:3]
            dist = fs.Polyline(pts).distance(p)
            for th, x, d, k in zip(theta, p, dist, np.linalg.norm(ddp, axis=1)):
                print(f"    arc {th - np.linalg.norm(pts[1] - pts[0]):+.3f} m: {d * 1e3:6.3f} mm from the sharp path, "
                      f"{(x - pts[1]) @ normal * 1e3:+7.3f} mm above the corner's plane, curvature {k:7.2f} 1/m")


def main() -> None:
    a = _arguments()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    import pathmotion.study.optimum_path as op
    from pathmotion.lift.constraint import lift
    from pathmotion.planning import plan
    from pathmotion.planning.blend_search import RISE_PLANS, optimal_blends
    from pathmotion.robot import load_robot
    from pathmotion.study import free_shape as fs
    from pathmotion.study.atlas import _settings, _task, corner_points

    robot = load_robot("irb140")
    pts = corner_points(a.angle)
    task = _task(pts)
    grid = {"grid_points": a.grid} if a.plan_tolerance is None else {"duration_tolerance": a.plan_tolerance}
    settings = _settings(baselines=False, verify=False, **grid)
    profiles = {}

    def duration(path, name=None) -> float:
        profile = plan(lift(robot, path, original=task), robot, settings).profile
        if name:
            profiles[name] = (profile, path.domain[1])
        return float(profile.duration)

    t0 = time.process_time()
    rise = RISE_PLANS if a.rise_plans is None else a.rise_plans
    best = optimal_blends(robot, task, a.tolerance, settings=_settings(verify=False, baselines=False), rise_plans=rise)
    shape = best.shapes[0]
    spans = [(shape.entry, shape.exit)]
    t1 = time.process_time()
    opt = fs.free_shape_optimum(robot, pts, a.tolerance, spans, tuple(int(m) for m in a.meshes.split(",")))
    t2 = time.process_time()
    sol = opt.solutions[-1]
    phases = fs.tube_phases(fs.Polyline(pts), a.tolerance, spans)
    optimum_path = op.optimum_task_path(robot, pts, phases, sol.motion)
    own = duration(optimum_path, "optimum")
    normal = np.cross(pts[1] - pts[0], pts[2] - pts[1])
    normal /= np.linalg.norm(normal)
    build = op._hermite_pieces

    def pressed(*args, **kw):  # control points projected onto the corner's plane
        return [b - np.outer((b - pts[1]) @ normal, normal) for b in build(*args, **kw)]

    op._hermite_pieces = pressed
    try:
        flat = duration(op.optimum_task_path(robot, pts, phases, sol.motion))
    finally:
        op._hermite_pieces = build
    blend = duration(best.path, "blend")
    print(f"{a.angle:g} deg, {a.tolerance * 1e3:g} mm, spans {shape.entry:.4f} / {shape.exit:.4f} m, "
          + (f"grid {a.grid}" if a.plan_tolerance is None else f"adaptive grid to {a.plan_tolerance:g}"))
    print(f"  corner-confined NLP: meshes {a.meshes}: {', '.join(f'{d:.5f}' for d in opt.durations)} s "
          f"(extrapolated {opt.duration:.5f} +- {opt.convergence_error * 1e3:.2f} ms, converged {opt.success}, "
          f"{t2 - t1:.0f} s CPU)")
    rows = (("optimum path", own), ("optimum path in the plane", flat), ("optimal blend", blend))
    for name, T in rows:
        print(f"  {name:28s} {T:.5f} s  {100 * (T / sol.duration - 1):+.2f} % vs the finest NLP mesh")
    nodes = np.concatenate([[0.0], np.cumsum([seg.length for seg in optimum_path.segments])])
    _print_resampled(a, nodes, optimum_path, own, duration)
    _print_smoothed(a, nodes, optimum_path, own, duration)
    _print_behind(a, profiles)
    _print_speeds(a, pts, profiles, optimum_path, best)
    _print_profile(a, pts, normal, optimum_path, best)
    print(f"  blend search: {best.plans} plans ({rise} out of the plane), {t1 - t0:.0f} s CPU; blend rises "
          f"{shape.rise_entry[0] * 1e3:+.2f} / {shape.rise_exit[0] * 1e3:+.2f} mm, offsets "
          f"{shape.offset_entry * 1e3:.2f} / {shape.offset_exit * 1e3:.2f} mm")


def hermite_chain(path, knots: np.ndarray, jumps: np.ndarray):
    """``path`` (a TaskPath, theta = arc length) rebuilt as one quintic Hermite piece in arc length between
    consecutive ``knots`` [m]: its position, h p' and h^2 p'' at both ends of a piece of arc h. ``jumps`` (one per
    knot): there each piece takes p'' from its own side of the knot (the path's curvature jump kept); elsewhere
    both take the mean (G2)."""
    from pathmotion.geometry import TaskPath
    from pathmotion.geometry.blends import _hermite_points
    from pathmotion.geometry.segments import BezierSegment

    states = []
    for s, keep in zip(knots, jumps):
        left, right = (path.pose(np.array([s]), side=side) for side in ("left", "right"))
        mean = 0.5 * (left[2][0] + right[2][0])
        states.append((right[0][0], right[1][0], left[2][0] if keep else mean, right[2][0] if keep else mean))
    pieces = [BezierSegment(_hermite_points((p0, t0, k0), (p1, t1, k1), h, h))
              for (p0, t0, _, k0), (p1, t1, k1, _), h in zip(states[:-1], states[1:], np.diff(knots))]
    return TaskPath(tuple(pieces), path.tool_orientation)


if __name__ == "__main__":
    main()
