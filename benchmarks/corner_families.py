"""Extensions of the optimal blend's search, tried at one atlas corner, each from the search's fastest blend
(where the blend stays above the free-shape optimum, do other starts or a richer corner help?).

* ``--tilts``: wide starts tilted between outwards and the corner's normal, per side (entry/exit angles [deg]: 0
  outwards, 90 along the normal, negative below the plane), each the joint stage (``--plans`` plans) from the
  search's fastest blend with both free ends' offset pieces bulged to the tube's edge in that direction
  (WIDE_PROFILE), as the search's own wide starts do at 0 and +-90 deg. At 135 deg / 7 mm the optimum runs at the
  tube's edge up along the entry and out and 20 deg down along the exit (``replan_optimum.py --profile``).
* ``--splits``: the corner quintic split at u (de Casteljau) into two G2 quintics through a free apex state
  (position, tangent, curvature vector, and the four end speeds: 11 coordinates), COBYQA over them (``--plans``
  plans, the certified deviation <= the tolerance as its constraint), the offset pieces fixed. At 135 deg / 7 mm the
  optimum turns with two curvature peaks and drops from 75 to 8 1/m within 4 mm after the corner
  (``replan_optimum.py --speeds``); one quintic has a single peak.
* ``--knots``: the same split in any of the blend's three pieces at once (entry/corner/exit split points u, ``-``
  for a piece not split; 11 coordinates per knot, COBYQA over all of them): free places for short curvature ramps
  along the offset pieces too. At 60 deg / 10 mm the optimum holds its curvature after the corner up to +70 mm and
  drops within 20 mm (``replan_optimum.py --profile``); the blend's exit ramps over 40 mm.

Prints each try's coarse-grid (search) and full-grid durations against the search's blend.

    python benchmarks/corner_families.py 135 0.007 --tilts 90/-20,60/-20,90/0,0/-20,45/-45,90/-90
    python benchmarks/corner_families.py 135 0.007 --splits 0.3,0.5,0.7 --plans 600
    python benchmarks/corner_families.py 135 0.007 --tilts 90/-45,90/-20,90/0,0/0 --plans 250 --share 1
    python benchmarks/corner_families.py 60 0.01 --knots=0.5/0.5/0.5,-/-/0.3,-/0.7/0.3 --plans 600
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

#: A knot's curvature coordinates move it by shares of its own curvature, or of this times tolerance / (the piece's
#: control polygon length)^2 [1/m] where the piece hardly turns (an offset piece): of the order of the curvature that
#: a graph within the tolerance of its line can have over that length.
KNOT_CURVATURE = 8.0

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("angle", type=float, help="turn angle [deg]")
    ap.add_argument("tolerance", type=float, help="tube radius [m]")
    ap.add_argument("--tilts", default="", help="entry/exit tilt pairs [deg], comma-separated")
    ap.add_argument("--splits", default="", help="split points u of the corner quintic, comma-separated")
    ap.add_argument("--knots", default="",
                    help="entry/corner/exit split points u of the blend's three pieces ('-': not split), "
                         "comma-separated (as --knots=...: a leading - would be read as an option)")
    ap.add_argument("--plans", type=int, default=300, help="plans per try")
    ap.add_argument("--radius", type=float, default=0.3, help="the splits' initial COBYQA trust radius (scaled box)")
    ap.add_argument("--share", type=float, default=None,
                    help="the tilts' first trust region, a share of the mean step (default TRUST_RADIUS_SHARE; the "
                         "wide restart's RESTART_RADIUS_SHARE is 1)")
    a = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    import pathmotion.planning.blend_search as bs
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _settings, _task, corner_points

    robot = load_robot("irb140")
    task = _task(corner_points(a.angle))
    full = _settings(verify=False, baselines=False)
    coarse = bs.replace_settings(full, grid_points=bs.SEARCH_GRID_POINTS)
    t0 = time.process_time()
    obj = bs._Objective(robot, task, {}, 0, a.tolerance, coarse, None, free_ends=(True, True))
    bs._search_corner(obj, True, bs.THOROUGH)
    T, shape, x = obj.best()
    print(f"{a.angle:g} deg, {a.tolerance * 1e3:g} mm: the search's blend (stages 1-6 and the global stage, "
          f"no polish): coarse {T:.5f} s, full {bs.duration_with(robot, task, {0: shape}, full):.5f} s "
          f"({obj.plans} plans, {time.process_time() - t0:.0f} s CPU)", flush=True)
    for pair in filter(None, a.tilts.split(",")):
        angles = tuple(float(v) for v in pair.split("/"))
        tilt(bs, robot, task, coarse, full, a.tolerance, bs._extended(x), angles, a.plans,
             bs.TRUST_RADIUS_SHARE if a.share is None else a.share)
    for u in filter(None, a.splits.split(",")):
        split(bs, robot, task, coarse, full, a.tolerance, shape, {1: float(u)}, a.plans, a.radius)
    for triple in filter(None, a.knots.split(",")):
        knots = {i: float(u) for i, u in enumerate(triple.split("/")) if u != "-"}
        split(bs, robot, task, coarse, full, a.tolerance, shape, knots, a.plans, a.radius)


def tilt(bs, robot, task, coarse, full, tol, x, angles, plans, share) -> None:
    from pathmotion.errors import PathmotionError

    *near_end, far, near, offset = bs.WIDE_PROFILE
    sides = ((bs._W_A, bs._C_A, bs._D_A, (bs._V_A, bs._VN_A, bs._VF_A), bs._DEPARTURE),
             (bs._W_B, bs._C_B, bs._D_B, (bs._V_B, bs._VN_B, bs._VF_B), bs._ARRIVAL))
    for (w, c_far, c_near, rise, end), angle in zip(sides, angles):
        lateral, normal = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        x[[w, c_far, c_near]] = max(lateral, 0.0) * offset, lateral * far, lateral * near
        x[list(rise)] = normal * offset, normal * near, normal * far
        x[end] = (lateral * near_end[0], lateral * near_end[1], normal * near_end[0], normal * near_end[1])
    obj = bs._Objective(robot, task, {}, 0, tol, coarse, None, free_ends=(True, True))
    for _ in range(bs.WIDE_RUN_TRIES):  # as the search's wide starts: shorten the runs until the corner fits
        try:
            obj.shape(x)
            break
        except PathmotionError:
            x[[bs._L_A, bs._L_B]] = np.maximum(x[[bs._L_A, bs._L_B]] * bs.WIDE_RUN_SHRINK, bs.RUN_RANGE[0])
    t0 = time.process_time()
    first = obj(x)
    bs._joint_stage(obj, plans, False, x, share=share)
    T, shape, _ = obj.best()
    cpu = time.process_time() - t0
    print(f"  tilt {angles[0]:+g}/{angles[1]:+g} deg: start {first:.5f}, coarse {T:.5f} s, full "
          f"{bs.duration_with(robot, task, {0: shape}, full):.5f} s ({obj.plans} plans, {cpu:.0f} s CPU); rises {shape.rise_entry[0] * 1e3:+.2f} / {shape.rise_exit[0] * 1e3:+.2f} mm, offsets "
          f"{shape.offset_entry * 1e3:.2f} / {shape.offset_exit * 1e3:.2f} mm", flush=True)


def _state(b: np.ndarray, end: bool) -> tuple:
    """(point, unit tangent, curvature vector, speed |X'|) of the quintic ``b`` (6, 3) at u = 1 if ``end`` else 0."""
    from pathmotion.geometry.segments import BezierSegment

    segment = BezierSegment(b)
    frame = segment.end_frame if end else segment.start_frame
    return (*frame, 5.0 * float(np.linalg.norm(b[5] - b[4] if end else b[1] - b[0])))


def _halves(b: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    rows = [b]
    while len(rows[-1]) > 1:
        rows.append((1 - u) * rows[-1][:-1] + u * rows[-1][1:])
    return np.array([r[0] for r in rows]), np.array([r[-1] for r in rows[::-1]])


def _knot(b: np.ndarray, u: float, tol: float):
    """(build, box) of the quintic ``b`` (6, 3) split at u (de Casteljau) into two G2 quintics through a free knot
    state: build(y) gives the two halves' control points for y (11,): the knot's offset (side, along, up) [tol],
    tangent tilt (side, up), curvature (in the turn, out of it) [share of its own curvature, or of
    KNOT_CURVATURE / (piece's polygon length)^2 where the piece hardly turns], and the log of the four end speeds."""
    import pathmotion.geometry.blends as bl

    s0, s1 = _state(b, False), _state(b, True)
    left, right = _halves(b, u)
    pm, tm, km, _ = _state(left, True)
    up = np.cross(s0[1], s1[1])
    if np.linalg.norm(up) < 1e-9:  # a piece that ends parallel to where it starts: any normal of its tangent
        up = np.cross(tm, (0.0, 0.0, 1.0) if abs(tm[2]) < 0.9 else (1.0, 0.0, 0.0))
    up /= np.linalg.norm(up)
    side = np.cross(up, tm)
    k_in = float(km @ side)
    floor = KNOT_CURVATURE * tol / float(np.sum(np.linalg.norm(np.diff(b, axis=0), axis=1))) ** 2
    k_scale = k_in if abs(k_in) >= floor else floor
    speeds = (s0[3] * u, _state(left, True)[3], _state(right, False)[3], s1[3] * (1 - u))

    def build(y):
        p = pm + tol * (y[0] * side + y[1] * tm + y[2] * up)
        t = tm + y[3] * side + y[4] * up
        t /= np.linalg.norm(t)
        n = np.cross(up, t)
        n /= np.linalg.norm(n)
        k = (k_in + y[5] * k_scale) * n + y[6] * abs(k_scale) * np.cross(t, n)
        la, lm1, lm2, lb = (s * np.exp(f) for s, f in zip(speeds, y[7:]))
        return [bl._hermite_points(s0[:3], (p, t, k), la, lm1), bl._hermite_points((p, t, k), s1[:3], lm2, lb)]

    box = [[-1.0, 1.0]] * 3 + [[-0.5, 0.5]] * 2 + [[-0.9, 3.0], [-1.0, 1.0]] + [[-1.0, 1.0]] * 4
    return build, box


def split(bs, robot, task, coarse, full, tol, shape, knots: dict, plans, radius) -> None:
    """COBYQA over the knot states of the blend's pieces split at ``knots`` {piece (0 entry, 1 corner, 2 exit): u}."""
    from scipy.optimize import minimize

    import pathmotion.geometry.blends as bl
    from pathmotion.lift.constraint import lift
    from pathmotion.errors import PathmotionError
    from pathmotion.geometry import TaskPath
    from pathmotion.geometry.orientation import FixedOrientation
    from pathmotion.geometry.segments import BezierSegment
    from pathmotion.planning import plan

    label = ("split at u = " + "/".join(f"{knots[i]:g}" if i in knots else "-" for i in range(3)) if set(knots) != {1}
             else f"split at u = {knots[1]:g}")
    c = bl._corner(task, 0, ("corner",), "corner_families")
    pieces = list(bl._shape_pieces(c, shape, "corner_families"))
    if len(pieces) != 3:
        print(f"  {label}: the blend has {len(pieces)} pieces, not entry, corner and exit; skipped")
        return
    splits = {i: _knot(pieces[i], u, tol) for i, u in sorted(knots.items())}

    def build(y):  # each split piece's 11 coordinates in piece order
        out, at = [], 0
        for i, b in enumerate(pieces):
            if i in splits:
                out += splits[i][0](y[at:at + 11])
                at += 11
            else:
                out.append(b)
        return out

    deviations: dict = {}

    def deviation(y) -> float:
        key = tuple(np.round(y, 12))
        if key not in deviations:
            try:
                deviations[key] = bl._pieces_deviation(c.A, c.B, build(y))
            except PathmotionError:
                deviations[key] = float("inf")
        return deviations[key]

    count, fastest = [0], [float("inf"), None]

    def duration(y, settings=coarse) -> float:
        try:
            path = TaskPath(tuple(BezierSegment(q) for q in build(y)), FixedOrientation())
            count[0] += 1
            return float(plan(lift(robot, path, original=task), robot, settings).profile.duration)
        except PathmotionError:
            return 10.0

    def f(y):
        T = duration(y)
        if T < fastest[0] and deviation(y) <= tol:
            fastest[:] = [T, np.array(y)]
        return T

    box = np.array([row for i in splits for row in splits[i][1]])
    t0 = time.process_time()
    y0 = np.zeros(len(box))
    unchanged = duration(y0, full)
    minimize(f, y0, method="COBYQA", bounds=box,
             constraints=[{"type": "ineq", "fun": lambda y: (tol - min(deviation(y), 1.0)) / tol}],
             options={"maxfev": plans, "scale": True, "initial_tr_radius": radius, "final_tr_radius": 1e-4})
    full_T = duration(fastest[1], full) if fastest[1] is not None else float("nan")
    print(f"  {label}: unchanged {unchanged:.5f} s (full); COBYQA coarse {fastest[0]:.5f} s, "
          f"full {full_T:.5f} s ({count[0]} plans, {time.process_time() - t0:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
