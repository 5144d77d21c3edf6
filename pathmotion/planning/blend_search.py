"""The tolerance-optimal blend: at each corner, the G2 blend shape (geometry/blends.py, G2Shape) that
minimises the time-optimal duration of the whole path within a certified deviation bound.

Every candidate shape is sized by :func:`~pathmotion.geometry.blends.g2_shape_for_tolerance` (its corner quintic
the largest whose certified deviation is <= the tolerance), so ``blend_max_deviation_m`` stays certified whatever the
search picks. Shapes are ranked by fast plans (SEARCH_GRID_POINTS, no verification), in stages, each from the fastest
blend so far:

1. the corner quintic (balance, shape_entry, shape_exit): bounded scalar searches (Brent), from the symmetric blend;
2. at a line-line corner, the racing line: S-curve offset pieces out to w_A / w_B outside the turn over runs
   l_A / l_B, scalar searches of offsets, runs and balance (RACING_CYCLES passes);
3. free offset pieces (their lateral Bernstein coefficients next to the offset free): Nelder-Mead, FREE_PLANS;
4. the rise out of the corner's plane: each side's profile turned about its line (RISE_ANGLES), then
   Nelder-Mead over the in- and out-of-plane profiles, RISE_PLANS in all (skipped at corners in ``planar``);
5. free ends, where a neighbour is the path's first (last) segment, the motion rests there and the fastest joined
   blend reaches it within the tolerance: the offset piece leaves (reaches) the end at an angle (G2Shape.departure /
   arrival), Nelder-Mead, END_PLANS;
6. the joint stage, where a free end made the blend faster: every coordinate at once by COBYQA (JOINT_PLANS), an
   end it then reaches freed too (the late free end); the wide starts (free ends bulged to the tube's edge outwards,
   WIDE_PLANS, and along the normal, WIDE_NORMAL_PLANS), the wide restart (RESTART_PLANS, a wider first trust
   region) and, where the motion rests at both ends and ``wide_crossed_plans`` > 0 (not by default), the crossed
   wide starts (CROSSED_DIRECTIONS); then, at every line-line corner, joined or not, the global stage: CMA-ES (pycma)
   over every coordinate at once from the fastest blend, GLOBAL_PLANS. The stages before it are local searches, each
   from the fastest blend so far, and end in a local optimum; a population that samples the coupled coordinates
   together finds faster blends (docs/study.md, "The global stage");
7. the capped retry: where the neighbouring segments, not the tolerance, capped the blend (it deviates less than
   CAPPED_SHARE of the tolerance), stages 1-6 again within the deviation it reached; the faster search is kept;
8. the polish: COBYQA on the full grid's duration (POLISH_PLANS) from the POLISH_STARTS fastest distinct candidates
   (or on a fixed grid of ``polish_grid_points``, its blend then planned on the full grid).

On a path of several corners each corner is searched from the symmetric blends at the others, then (the neighbour
pass, ``neighbour_pass``) once more from its own blend with its neighbours' found blends in place: the corners at
even places first, then those at odd places, so each half's corners are independent. A corner's blend sets the speed
at which its neighbours' windows are entered and left, and so what is fastest there.

Offsets and coefficients are searched in units of the tolerance, runs in units of sqrt(tolerance RUN_SCALE_LENGTH)
(an S-curve's lateral acceleration ~ w v^2 / l^2). On a path of more than two segments each corner is searched on its
window (_Window: its segments out to the neighbouring blended or sharp corners, entered and left at the speeds a plan
of the whole path has there), so a plan costs the same however many corners the path has; the windows' results are
then planned together on the whole path.

Guarantees: the symmetric blend and the fastest of each class (one quintic, S-curves, in the plane, joined to the
lines, before the joint stage, before the wide starts, before the restart, before the crossed starts, before the
global stage, the capped search's; of both passes where the neighbour pass ran) are re-planned on the full grid and
the fastest is kept, so the result is never slower than any of them; the polish keeps it unless it finds a faster one
on the full grid. About 255 plans per corner before the
global stage, 785-1550 with free ends and the wide starts, and the global stage's GLOBAL_PLANS (all twice when
capped), then the polish's 150 on the full grid.

How hard each corner is searched is a :class:`SearchSettings`: ``THOROUGH`` runs every stage above (the corner
atlas' search); ``FAST`` (scenarios' default, ``search = "fast"``) runs stages 1-2 (FAST_STEPS golden steps, one
racing pass) on the search grid, a short stage 4 where the tolerance is at least FAST_RISE_TOLERANCE_SHARE of the
shorter segment (then the polish moves only the racing line's coordinates and the free ends), short stages 5-6 where a free end applies (the wide starts outwards and along the
normal each planned once after the joint stage, FAST_WIDE_SCREEN: where one is faster, the polish starts from it; no
restart or global stage), and a short polish (FAST_POLISH_PLANS) on a fixed grid (FAST_POLISH_GRID_POINTS), its
COBYQA runs on lean models (n + LEAN_MODEL_EXTRA points: in so few plans the default's first model is never complete),
without the neighbour pass. Each corner is searched from the symmetric blends at the others (a :class:`_CornerJob`),
so ``workers`` > 1 searches the corners on local processes with the same result; where the corners are polished on
their windows, those polishes are independent too (a :class:`_PolishJob` each) and run on the same processes.

Why each stage, with the measurements that chose its plans and starts, and the families tried and not kept:
docs/study.md, "The optimal blend's search".
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import warnings
from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import Bounds, minimize, minimize_scalar

from .. import defaults
from ..lift.constraint import lift
from ..errors import PathmotionError
from ..geometry import Line, TaskPath
from ..geometry.orientation import FixedOrientation
from ..geometry.blends import G2Shape, g2_shape_for_tolerance, with_blends, with_shaped_g2_blends
from ..io.processes import WorkerPool
from .boundary import at_rest
from .planner import PlanSettings, plan

log = logging.getLogger(__name__)

#: Search box of the quintic's coordinates (balance, shape_entry, shape_exit).
BALANCE_RANGE = (0.2, 0.8)
SHAPE_RANGE = (0.25, 1.0)
#: Search box of the racing line's offsets [tolerance] and runs [sqrt(tolerance RUN_SCALE_LENGTH)];
#: the runs start at 1.
OFFSET_RANGE = (0.0, 0.999)
RUN_RANGE = (0.3, 2.0)
RUN_SCALE_LENGTH = 0.64
#: Box of the free offset pieces' Bernstein coefficients [tolerance]: inside it the pieces stay
#: within the tolerance of their line (convex hull), so few candidates are rejected.
COEFFICIENT_RANGE = (-1.0, 1.0)
#: Steps of the bounded scalar searches (scipy's minimize_scalar, Brent): the quintic's (and its
#: cycles), the racing line's (and its passes); plans of the free offset pieces' Nelder-Mead stage.
GOLDEN_STEPS = 6
SEARCH_CYCLES = 1
RACING_STEPS = 4
RACING_CYCLES = 2
FREE_PLANS = 60
RISE_PLANS = 90
#: The rise stage's grid of turn angles per side [deg] (> 0 towards the corner's normal).
RISE_ANGLES = (-90.0, -45.0, 0.0, 45.0, 90.0)
#: Steps of the rise stage's scalar search of each angle.
RISE_ANGLE_STEPS = 5
#: Plans of the free-ends stage (a corner whose offset piece reaches a path end where the motion rests).
END_PLANS = 80
#: Plans of the joint stage (every coordinate of a blend with a free end at once).
JOINT_PLANS = 150
#: Plans of the wide starts (the joint stage from free ends bulged out to the tube's edge): outwards, and along
#: the corner's normal.
WIDE_PLANS = 300
WIDE_NORMAL_PLANS = 150
#: Plans of each crossed wide start (one resting side outwards, the other along the normal) when they run
#: (``wide_crossed_plans``), and its first trust region, a share of the mean step (at 135 deg / 2 mm every plan of a
#: start at 1 was rejected: its first points, a radius from the tube's edge, left the corner quintic no room). They do
#: not run by default (CROSSED_DEFAULT_PLANS): with the global stage after them they found nothing faster at the three
#: corners they were built for (135 deg / 7 mm 0.80947 against 0.80948 s without, 135 deg / 2 mm 0.86031 against
#: 0.85813 s, 120 deg / 5 mm 0.81192 against 0.81152 s: `python benchmarks/blend_search_stages.py --stage crossed`),
#: and they cost 4-12 s of CPU per corner.
WIDE_CROSSED_PLANS = 150
WIDE_CROSSED_RADIUS_SHARE = 0.5
CROSSED_DEFAULT_PLANS = 0
#: The crossed starts' directions (entry, exit): along the corner's normal up or down (not after the side the fastest
#: blend rises to, as the wide start along the normal: at 120 deg / 5 mm that blend's entry sinks by 0.01 mm, and only
#: the start up along it is faster, 0.81774 -> 0.81533 s), the other side outwards.
CROSSED_DIRECTIONS = (("up", "out"), ("down", "out"), ("out", "up"), ("out", "down"))
#: Plans of the wide restart (the joint stage once more from the fastest blend, with RESTART_RADIUS_SHARE).
RESTART_PLANS = 150
#: The joint stage's COBYQA, in its box scaled to [-1, 1]: the initial trust radius as a share of the
#: mean initial step, and the final radius.
TRUST_RADIUS_SHARE = 0.25
TRUST_RADIUS_FINAL = 1e-4
#: The wide restart's initial trust radius, as TRUST_RADIUS_SHARE: four times as wide, so its first models span the
#: neighbouring basins instead of the one the joint stage ended in.
RESTART_RADIUS_SHARE = 1.0
#: The lean quadratic models (SearchSettings.lean_models) of n coordinates interpolate n + LEAN_MODEL_EXTRA points, the
#: fewest COBYQA takes.
LEAN_MODEL_EXTRA = 2


#: The global stage (CMA-ES over every coordinate, from the fastest blend): plans, the initial step size in the box
#: scaled to [-1, 1] and pycma's seed (the search is deterministic). At 60 deg / 10 mm, from the stages' blend
#: (0.61355 s), 3000 plans ended at 0.61092-0.61167 s in two runs, 10000 at 0.61027 s; step 0.3 at 0.61065 s. Over
#: the atlas' 20 rows the gain at 2500 plans is 0.00-0.09 % short of the gain at 3000, which would take the atlas
#: past 10 minutes on 2 cores (benchmarks/atlas_rows.py).
GLOBAL_PLANS = 2500
GLOBAL_SIGMA = 0.15
GLOBAL_SEED = 1
#: Grid points of the search's fast plans.
SEARCH_GRID_POINTS = 300
#: A corner whose fastest blend deviates less than this share of its tolerance is searched once more at the
#: deviation it reached (stage 7).
CAPPED_SHARE = 0.95
#: Plans of the full-grid polish (stage 8) per corner.
POLISH_PLANS = 150
#: The polish runs from this many of the fastest distinct full-grid candidates (stage 8). At 30 deg / 5 mm over
#: eleven tolerances within 1e-6 of 5 mm a second start ended faster in 3 runs (by 0.001-0.10 %), a third in none,
#: for about 6 s more CPU per start and corner (28-35 s for the search; benchmarks/search_spread.py --polish-starts
#: 3): not worth the atlas' time budget by default.
POLISH_STARTS = 1
#: The fast search's polish: plans per corner from its fastest blend, on a fixed grid of FAST_POLISH_GRID_POINTS (a
#: plan there costs a fraction of one on the adaptive full grid; its blend is then planned on the full grid). On nine
#: atlas rows it kept 7 points less to 2 points more of the thorough search's gain than 30 plans on the full grid, for
#: about 1 s less CPU per corner.
FAST_POLISH_PLANS = 30
FAST_POLISH_GRID_POINTS = 1000
#: The fast polish's initial trust radius, a share of its steps (as the wide restart's): it starts from the racing
#: line of a short search, farther from a local optimum than the thorough search's blend. On the 20 atlas rows it kept
#: 81.4 % of the thorough search's gain over G2 where TRUST_RADIUS_SHARE kept 78.8 % (0.4 and 0.6: 78.8 and 79.5 %),
#: on 4 rows outside them 83.5 % against 83.4 %, in the same plans.
FAST_POLISH_RADIUS_SHARE = 1.0
#: The fast search's free ends (stages 5-6 without the wide starts), where the motion rests at a path end that the
#: fastest joined blend reaches: plans of the free-ends stage and of the joint stage.
FAST_END_PLANS = 20
FAST_JOINT_PLANS = 30
#: The fast search's wide starts (_wide_screen), each planned once after its joint stage where the motion rests at a
#: path end: outwards and along the corner's normal (the crossed starts found nothing more on the atlas rows the
#: screen helps, 150 deg / 5 mm and 120 deg / 1 mm).
FAST_WIDE_SCREEN = ("out", "normal")
#: The fast search's golden steps per scalar search of the quintic stage: the racing line searches the blend again
#: after it. On the 20 atlas rows and 4 others (45 deg / 2 mm, 75 deg / 7 mm, 105 deg / 3 mm, 135 deg / 7 mm) 3 steps
#: gained as much over G2 as 6 (0.8 % more in sum) in 14 plans less per corner (0.3 s of CPU), 2 steps 2 % less.
FAST_STEPS = 3
#: The fast search's passes of the racing line's scalar searches: on eight atlas rows (30 deg / 1, 5 mm, 60 deg / 1,
#: 10 mm, 90 deg / 5 mm, 120 deg / 1, 10 mm, 150 deg / 5 mm) one pass kept 81.4 % of the thorough search's summed
#: gain over G2 where two kept 81.5 %, in 40 plans less per corner (about 0.5 s of CPU).
FAST_RACING_CYCLES = 1
#: The fast search's racing line: its runs' range [run unit] and the runs its offsets are first searched from.
#: Where the thorough blend spans both whole lines (120 deg / 5 mm: runs of 0.18 and 0.13 m, 3.2 and 2.3 run units)
#: the racing line within RUN_RANGE stops short of it.
FAST_RUN_RANGE = (0.3, 4.0)
FAST_RUN_STARTS = (1.0, 2.0)
#: The fast search's rise (stage 4, FAST_RISE_PLANS plans, its grid of turn angles FAST_RISE_ANGLES) where the tolerance
#: is at least FAST_RISE_TOLERANCE_SHARE of the shorter of the corner's two segments: there the fastest blends rise out
#: of the corner's plane (at 60-120 deg / 10 mm the thorough search's entry piece turns 35-47 deg from outwards towards
#: the normal; at 30 deg / 5 and 10 mm both pieces turn 45-90 deg), which the racing line and the short joint stage do
#: not reach. Where the rise ran, the polish moves only the racing line's seven coordinates and the free ends
#: (FAST_RISE_POLISH_RACING): with the rise's 17 coordinates and more, 30 lean plans mostly build COBYQA's first model
#: (120 deg / 10 mm after a 90-plan rise: 0.34158 s over every coordinate, 0.34071 s over the racing line's and the
#: free ends'). Interleaved on the atlas' ten rows at 5 and 10 mm (0.2 m lines; load 3.4-3.5) it gained 1.7 points of
#: gain over G2 in sum (30 deg / 5 mm 0.37 -> 0.78 %, 60 deg / 10 mm 2.11 -> 2.52 %, 90 deg / 10 mm 4.94 -> 5.34 %,
#: 150 deg / 10 mm 0.05 -> 0.23 %; 60 deg / 5 mm 3.80 -> 3.79 %) for 18.0 s of CPU against 14.4 s. The full grid of
#: RISE_ANGLES in 60 plans kept 0.2 points less (30 deg / 10 mm 1.24 against 1.39 %), 90 plans lost 120 deg / 10 mm
#: (3.62 against 4.19 %); without -45 deg the grid kept the same but at 30 deg / 10 mm (1.43 %, in 100 plans more).
FAST_RISE_PLANS = 45
FAST_RISE_ANGLES = (-45.0, 0.0, 45.0, 90.0)
FAST_RISE_TOLERANCE_SHARE = 0.02
FAST_RISE_POLISH_RACING = True

#: Search coordinates x: balance, shape_entry, shape_exit, offset_entry, offset_exit [tolerance],
#: run_entry, run_exit [run unit] (7: S-curve offset pieces), then (11: free offset pieces) each
#: piece's other lateral Bernstein coefficients [tolerance] (far, near: c3, c4 before the corner,
#: c2, c1 after it; the offsets are c5 and c0, the coefficients at the line's end 0; far = near =
#: offset is the S-curve), then (17: with a rise) the same three coefficients of each piece's
#: profile along the corner's normal [tolerance] (rise, near, far: entry, then exit).
_BALANCE, _SHAPE_A, _SHAPE_B, _W_A, _W_B, _L_A, _L_B, _C_A, _D_A, _C_B, _D_B = range(11)
_V_A, _VN_A, _VF_A, _V_B, _VN_B, _VF_B = range(11, 17)
#: (25: with free rest ends) the departure's and the arrival's four coefficients [tolerance] (G2Shape).
_DEPARTURE, _ARRIVAL = slice(17, 21), slice(21, 25)


@dataclass(frozen=True)
class OptimalBlend:
    """The chosen blends: ``shapes`` {connection index: G2Shape}, the blended ``path``, its full-grid
    ``duration`` [s], the symmetric G2 blend's ``symmetric_duration`` [s], the best quintic's
    ``quintic_duration`` [s], the best blend in the corner's plane's ``planar_duration`` [s] and the
    best joined to the lines at the path's ends' ``joined_duration`` [s] (full grid), and ``plans`` run."""

    shapes: dict
    path: TaskPath
    duration: float
    symmetric_duration: float
    plans: int
    quintic_duration: float = float("nan")
    planar_duration: float = float("nan")
    joined_duration: float = float("nan")


def _side(w: float, far: float, near: float, run: float) -> tuple[float, float]:
    """(slope [-], bend [1/m]) at the corner end of an offset piece over ``run`` [m] whose lateral
    Bernstein coefficients from the corner end are ``w``, ``near``, ``far`` [m] (then 0, 0, 0):
    dw/dd = 5 (near - w) / run, d2w/dd2 = 20 (w - 2 near + far) / run^2 (d from the corner)."""
    return 5.0 * (near - w) / run, 20.0 * (w - 2.0 * near + far) / run ** 2


class _Objective:
    """Duration of the path with the blend coordinates x (7,), (11,) or (17,) at one corner (others
    fixed), cached. Its candidate shapes carry no deviation bound (nan: g2_shape_for_tolerance's ``certify``);
    :meth:`certified` bounds those the search returns."""

    def __init__(self, robot, original: TaskPath, shapes: dict, corner: int, tolerance: float,
                 settings: PlanSettings, q_start, free_ends: tuple[bool, bool] = (False, False),
                 shared: tuple[bool, bool] | None = None, label: int | None = None):
        self.robot, self.original, self.shapes, self.corner = robot, original, dict(shapes), corner
        self.free_ends = self.resting = free_ends  # free_ends: narrowed by the free-ends stages to those reached
        self.tolerance, self.settings, self.q_start = tolerance, settings, q_start
        self.run_unit = float(np.sqrt(tolerance * RUN_SCALE_LENGTH))
        chosen = set(shapes)
        # shared and label: as on the whole path when ``original`` is a corner's window (_Window)
        self.shared = (corner - 1 in chosen, corner + 1 in chosen) if shared is None else tuple(shared)
        self.label = corner if label is None else label
        self.cache: dict[tuple, tuple[float, G2Shape | None]] = {}  # (x, free ends or None): (duration, shape)
        self.planned: dict[G2Shape, float] = {}  # duration per shape: coordinates that build one planned already
        self.built: dict[G2Shape, tuple] = {}  # per shape the (coordinates, free ends) that built it first
        self.bounded: dict[G2Shape, G2Shape] = {}  # per shape the same with its deviation bound (certified)
        self.plans = 0  # plans run
        self.tried = 0  # coordinates whose shape was built (a stage's budget: the same whether planned or not)
        self.risen = False  # the polish moves only the racing line's coordinates and the free ends (rise_polish_racing)

    def shape(self, x, free_ends: tuple[bool, bool] | None = None, certify: bool = False) -> G2Shape:
        """The shape of coordinates x, its free ends' coordinates read for ``free_ends`` (default: the objective's
        current ones); its deviation bound only if ``certify``."""
        x = np.asarray(x, float)
        free_ends = self.free_ends if free_ends is None else free_ends
        tol = self.tolerance
        w = (x[_W_A] * tol, x[_W_B] * tol)
        runs = (x[_L_A] * self.run_unit, x[_L_B] * self.run_unit)
        slopes, bends = [0.0, 0.0], [0.0, 0.0]
        if len(x) > _C_A:
            for j, (far, near) in enumerate(((_C_A, _D_A), (_C_B, _D_B))):
                slopes[j], bends[j] = _side(w[j], x[far] * tol, x[near] * tol, runs[j])
        rises = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.0)]
        if len(x) > _V_A:
            for j, (rise, near, far) in enumerate(((_V_A, _VN_A, _VF_A), (_V_B, _VN_B, _VF_B))):
                rises[j] = (x[rise] * tol, *_side(x[rise] * tol, x[far] * tol, x[near] * tol, runs[j]))
        ends = [None, None]
        if len(x) > _DEPARTURE.start:
            ends = [tuple(x[part] * tol) if free else None for part, free in zip((_DEPARTURE, _ARRIVAL), free_ends)]
        return g2_shape_for_tolerance(self.original, self.corner, tol, float(x[_BALANCE]), float(x[_SHAPE_A]),
                                      float(x[_SHAPE_B]), shared=self.shared, offsets=w, runs=runs,
                                      slopes=tuple(slopes), bends=tuple(bends), rises=tuple(rises),
                                      departure=ends[0], arrival=ends[1], certify=certify)

    def certified(self, shape: G2Shape) -> G2Shape:
        """``shape`` (one this objective built) with its certified deviation bound: built again from the coordinates
        and free ends that built it, with the bound (the same geometry: the sizing is deterministic); once per
        shape."""
        if shape not in self.bounded:
            x, free_ends = self.built[shape]
            self.bounded[shape] = self.shape(x, free_ends, certify=True)
        return self.bounded[shape]

    def key(self, x) -> tuple:
        """The cache key of x: its coordinates, rounded, and with free ends' coordinates the free ends they are
        read for (the same x is another shape when the stages free another end)."""
        x = np.asarray(x, float)
        return tuple(np.round(x, 12)), (self.free_ends if len(x) > _DEPARTURE.start else None)

    def __call__(self, x) -> float:
        key = self.key(x)
        if key not in self.cache:
            try:
                shape = self.shape(x)
            except PathmotionError as exc:  # e.g. S-curves too long for the segments
                log.debug("blend search: coordinates %s rejected (%s)", key, exc)
                self.cache[key] = (float("inf"), None)
                return float("inf")
            self.tried += 1
            self.built.setdefault(shape, (np.array(x, float), self.free_ends))
            if shape not in self.planned:  # e.g. runs of sides without an offset, which size no piece
                self.planned[shape] = duration_with(self.robot, self.original, {**self.shapes, self.corner: shape},
                                                    self.settings, self.q_start)
                self.plans += 1
            self.cache[key] = (self.planned[shape], shape)
        return self.cache[key][0]

    def best(self, quintic_only: bool = False, s_curve_only: bool = False, planar: bool = False,
             joined: bool = False) -> tuple[float, G2Shape, tuple]:
        """(duration, shape, x) of the fastest coordinates seen (only offsets 0 if ``quintic_only``,
        only S-curve offset pieces if ``s_curve_only``, only in the corner's plane if ``planar``,
        only joined to both lines if ``joined``: no free end)."""
        found = [(v[0], v[1], k[0]) for k, v in self.cache.items()
                 if v[1] is not None and not (quintic_only and v[1].racing)
                 and not (s_curve_only and len(k[0]) > _C_A) and not (planar and not v[1].planar)
                 and not (joined and not _joined(v[1]))]
        return min(found, key=lambda r: r[0])


def duration_with(robot, original: TaskPath, shapes: dict, settings: PlanSettings, q_start=None) -> float:
    """Time-optimal duration [s] of ``original`` with the blends ``shapes``; inf if it cannot be
    lifted or planned (a shape the search must avoid)."""
    try:
        path = lift(robot, with_shaped_g2_blends(original, shapes), q_start, original=original)
        return float(plan(path, robot, settings).profile.duration)
    except PathmotionError as exc:
        log.debug("blend search: shape rejected (%s)", exc)
        return float("inf")


@dataclass(frozen=True)
class _Window:
    """A corner's window: ``path`` the consecutive segments of the whole path from the connection before the corner
    where the motion's speed is pinned (a blended or sharp corner: _window) to the one after it, or to the path's
    ends; the corner is its connection ``corner``. Planned under ``settings``: the path's own end conditions where the
    window ends where the path does, else the path speeds [m/s] a plan of the whole path has at those connections;
    lifted from ``q_start``."""

    path: TaskPath
    corner: int
    settings: PlanSettings
    q_start: np.ndarray | None


def _connection_states(robot, original: TaskPath, shapes: dict, settings: PlanSettings,
                       q_start) -> tuple[dict, dict] | None:
    """({connection index: path speed [m/s]}, {connection index: joint configuration (n,) [rad]}) of a plan of
    ``original`` with the blends ``shapes`` under ``settings``, at every connection (the closing one too): the
    slowest grid point within reach of a blended corner's quintic (_quintic_reach: the dip, not a free end's piece
    that may run to a path end at rest), else the grid point nearest the connection. None if the path cannot be
    lifted or planned."""
    try:
        blended = with_shaped_g2_blends(original, shapes)
        joint = lift(robot, blended, q_start, original=original)
        profile = plan(joint, robot, settings).profile
    except PathmotionError as exc:
        log.debug("blend search: no windows (%s)", exc)
        return None
    points = blended.evaluate(profile.grid)[0]
    configs = joint.evaluate(profile.grid)[0]
    speeds, states = {}, {}
    for c in original.connections + ((original.closure,) if original.closure is not None else ()):
        d = np.linalg.norm(points - np.asarray(c.position), axis=1)
        shape = shapes.get(c.index)
        near = np.flatnonzero(d <= _quintic_reach(shape)) if shape is not None else np.array([], int)
        i = int(near[np.argmin(profile.x[near])]) if near.size else int(np.argmin(d))
        speeds[c.index], states[c.index] = float(np.sqrt(profile.x[i])), configs[i]
    return speeds, states


def _quintic_reach(shape: G2Shape) -> float:
    """Distance [m] from the vertex within which ``shape``'s corner quintic lies: its longer cut (the totals less the
    offset pieces' runs; a free end's run is its whole segment), plus the deviation for the pieces' offsets."""
    sides = shape.sides
    return max(shape.entry - (shape.run_entry if sides[0] else 0.0),
               shape.exit - (shape.run_exit if sides[1] else 0.0)) + shape.deviation


def _window(original: TaskPath, corner: int, settings: PlanSettings, states: tuple[dict, dict], q_start,
            blended: Sequence[int]) -> _Window | None:
    """Connection ``corner``'s window (_Window) from the speeds and configurations ``states`` of
    :func:`_connection_states`, the connections in ``blended`` blended. It reaches out over smooth and tangent
    connections to the nearest blended or sharp corner each way (there the speed sits at a dip that the corner's
    shape hardly moves, or at a stop), else to the path's end (round the closure of a periodic path); None where it
    would be the whole path."""
    speeds, configs = states
    n = len(original.segments)
    cyclic = settings.periodic and original.closure is not None

    def pinned(j: int) -> bool:  # the connection after segment j (j = n - 1: the closure)
        c = original.closure if j == n - 1 else original.connections[j]
        return c.index in blended or c.kind == "corner"

    first, last, count = corner, corner + 1, 2
    while not (first == 0 and not cyclic) and not pinned((first - 1) % n) and count < n:
        first, count = (first - 1) % n, count + 1
    while not (last == n - 1 and not cyclic) and not pinned(last) and count < n:
        last, count = (last + 1) % n, count + 1
    if count >= n:
        return None
    opens, closes = first == 0 and not cyclic, last == n - 1 and not cyclic
    path = TaskPath(tuple(original.segments[(first + i) % n] for i in range(count)), original.tool_orientation)
    windowed = replace_settings(settings, periodic=False, start=settings.start if opens else speeds[(first - 1) % n],
                                end=settings.end if closes else speeds[last])
    return _Window(path, (corner - first) % n, windowed, q_start if opens else configs[(first - 1) % n])


def _corner_window(robot, original: TaskPath, shapes: dict, corner: int, settings: PlanSettings, q_start,
                   states: tuple[dict, dict] | None = None) -> _Window | None:
    """``corner``'s window under ``settings``, its ends from ``states`` (default: a plan of the whole path with
    ``shapes`` under ``settings``); None (search the whole path) where the path or the window with the corner's
    current shape cannot be planned."""
    states = states or _connection_states(robot, original, shapes, settings, q_start)
    window = None if states is None else _window(original, corner, settings, states, q_start, list(shapes))
    if window is None:
        return None
    if not np.isfinite(duration_with(robot, window.path, {window.corner: shapes[corner]}, window.settings,
                                     window.q_start)):
        log.info("blend search: corner %d: its window cannot be planned with the blend it starts from; searched on "
                 "the whole path", corner)
        return None
    return window


def _windows_apply(original: TaskPath) -> bool:
    """Whether a corner's search runs on its window: a path of more than two segments with one tool orientation
    (orientation keys along the path would need remapping into each window)."""
    return len(original.segments) > 2 and isinstance(original.tool_orientation, FixedOrientation)


def _objective(robot, original: TaskPath, shapes: dict, corner: int, tolerance: float, settings: PlanSettings,
               q_start, ends: tuple[bool, bool], window: _Window | None) -> _Objective:
    """The search's objective for ``corner``: on the whole path, or on its ``window`` (the blend's sizing, its
    neighbours' shares included, is the same: the window holds the same two segments around it)."""
    if window is None:
        return _Objective(robot, original, shapes, corner, tolerance, settings, q_start, ends)
    chosen = set(shapes)
    return _Objective(robot, window.path, {window.corner: shapes[corner]}, window.corner, tolerance, window.settings,
                      window.q_start, ends, shared=(corner - 1 in chosen, corner + 1 in chosen), label=corner)


#: Stand-in for an infeasible candidate's duration [s] in the scalar searches (Brent's parabolic
#: step needs finite values).
_INFEASIBLE = 1e9


def _line_search(f: Callable, x: np.ndarray, indices: tuple[int, ...], lo: float, hi: float, steps: int) -> None:
    """Bounded scalar search (scipy's Brent, about ``steps`` + 2 plans) of f over t in [lo, hi] with
    the coordinates ``indices`` of x set to t (f caches every point, so the best one seen is kept
    whatever the search returns)."""
    def along(t):
        y = np.array(x, float)
        y[list(indices)] = t
        return min(f(y), _INFEASIBLE)

    minimize_scalar(along, bounds=(lo, hi), method="bounded", options={"maxiter": steps + 2, "xatol": 1e-4})


#: The racing stage's moves: (coordinates set together, range).
_RACING_MOVES = (((_W_A, _W_B), OFFSET_RANGE), ((_L_A, _L_B), RUN_RANGE), ((_W_A,), OFFSET_RANGE),
                 ((_W_B,), OFFSET_RANGE), ((_L_A,), RUN_RANGE), ((_L_B,), RUN_RANGE), ((_BALANCE,), BALANCE_RANGE))


def _racing_stage(objective: _Objective, search: "SearchSettings") -> None:
    """Stage 2: the offsets searched together from the fastest blend with its runs at each of ``search.run_starts``
    (after the first), then ``search.racing_cycles`` passes of _RACING_MOVES' scalar searches, the runs within
    ``search.run_range``, each from the fastest blend so far."""
    for run in search.run_starts[1:]:
        x = np.array(objective.best()[2])
        x[[_L_A, _L_B]] = run
        _line_search(objective, x, (_W_A, _W_B), *OFFSET_RANGE, search.racing_steps)
    for _ in range(search.racing_cycles):
        for indices, box in _RACING_MOVES:
            box = search.run_range if box == RUN_RANGE else box
            _line_search(objective, np.array(objective.best()[2]), indices, *box, search.racing_steps)


#: The free stage's box and initial simplex steps, per coordinate (_BALANCE ... _D_B).
_FREE_BOX = (BALANCE_RANGE, SHAPE_RANGE, SHAPE_RANGE, OFFSET_RANGE, OFFSET_RANGE, RUN_RANGE, RUN_RANGE,
             COEFFICIENT_RANGE, COEFFICIENT_RANGE, COEFFICIENT_RANGE, COEFFICIENT_RANGE)
_FREE_STEP = (0.05, 0.05, 0.05, 0.05, 0.05, 0.1, 0.1, 0.15, 0.15, 0.15, 0.15)


def _free_stage(objective: _Objective, plans: int) -> None:
    """Nelder-Mead (scipy, bounded, about ``plans`` plans) over all 11 coordinates from the fastest
    S-curve racing line with its nonzero offsets at the top of OFFSET_RANGE (its offset pieces'
    coefficients far = near = offset), or from that line itself if the wider one does not fit: the
    free-shape optimum runs at the edge of the tube before and after the corner, and from there the
    simplex found faster blends than from the racing line's own offsets (60 degrees 10 mm: 0.6363 s
    against 0.6404 s; 90 degrees 10 mm: 0.6976 s against 0.7003 s)."""
    box = np.array(_FREE_BOX)
    x7 = np.array(objective.best(s_curve_only=True)[2])
    wide = x7.copy()
    wide[[i for i in (_W_A, _W_B) if x7[i] > 0]] = OFFSET_RANGE[1]
    x0, fallback = (np.clip(np.concatenate([x, [x[_W_A], x[_W_A], x[_W_B], x[_W_B]]]), box[:, 0], box[:, 1])
                    for x in (wide, x7))
    if not np.isfinite(objective(x0)):  # e.g. the wider corner leaves no room for the pieces
        x0 = fallback
    _nelder_mead(objective, x0, box, _FREE_STEP, plans)


def _extended(x, size: int = _ARRIVAL.stop) -> np.ndarray:
    """Coordinates x (7,), (11,), (17,) or (25,) as ``size`` (>= 11) of them: an S-curve racing line's free
    coefficients are its offsets (far = near = offset), the coordinates x lacks after them 0."""
    x = np.array(x, float)
    if len(x) <= _C_A:
        x = np.concatenate([x, [x[_W_A], x[_W_A], x[_W_B], x[_W_B]]])
    return np.concatenate([x, np.zeros(size - len(x))])


def _nelder_mead(f: Callable, x0: np.ndarray, box: np.ndarray, steps: Sequence[float], plans: int) -> None:
    """scipy's bounded, adaptive Nelder-Mead on f from x0 (about ``plans`` evaluations), its initial
    simplex x0 plus each step (minus where plus leaves the box)."""
    simplex = [x0] + [np.clip(x0 + np.eye(len(x0))[i] * (steps[i] if x0[i] + steps[i] <= box[i, 1] else -steps[i]),
                              box[:, 0], box[:, 1]) for i in range(len(x0))]
    minimize(f, x0, method="Nelder-Mead", bounds=box,
             options={"maxfev": plans, "initial_simplex": np.array(simplex), "adaptive": True, "xatol": 1e-4,
                      "fatol": 1e-6})


#: The rise stage's coordinates (in-plane profile, then along the normal), box and initial simplex steps.
_RISE_COORDS = (_W_A, _W_B, _C_A, _D_A, _C_B, _D_B, _V_A, _VN_A, _VF_A, _V_B, _VN_B, _VF_B)
_RISE_BOX = (OFFSET_RANGE, OFFSET_RANGE) + (COEFFICIENT_RANGE,) * 10
_RISE_STEP = (0.1,) * 6 + (0.15,) * 6


def _rise_room(objective: _Objective, share: float) -> bool:
    """Whether the tolerance leaves the rise room: at least ``share`` of the shorter of the corner's two segments."""
    segments = objective.original.segments[objective.corner:objective.corner + 2]
    return objective.tolerance >= share * min(segment.length for segment in segments)


def _rise_stage(objective: _Objective, plans: int, angles: Sequence[float] = RISE_ANGLES) -> None:
    """Each side's planar profile turned about its line (grid of RISE_ANGLES, then a scalar search
    per angle), then Nelder-Mead over the offset pieces' profiles in and out of the corner's plane
    (_RISE_COORDS) from the fastest, the other coordinates fixed at the fastest planar blend's;
    about ``plans`` plans in all."""
    base = _extended(objective.best(planar=True, joined=True)[2][:_V_A], _DEPARTURE.start)
    idx = list(_RISE_COORDS)
    box = np.array(_RISE_BOX)
    sides = (base[[_W_A, _D_A, _C_A]], base[[_W_B, _D_B, _C_B]])  # (offset, near, far) per side

    def turned(angles) -> np.ndarray:  # the 12 coordinates in _RISE_COORDS order
        (wa, na, fa), (wb, nb, fb) = (p * np.cos(np.radians(a)) for p, a in zip(sides, angles))
        up = [p * np.sin(np.radians(a)) for p, a in zip(sides, angles)]
        return np.clip([wa, wb, fa, na, fb, nb, *up[0], *up[1]], box[:, 0], box[:, 1])

    def f(y):
        x = base.copy()
        x[idx] = y
        return objective(x)

    start = objective.tried
    grid = min(((f(turned(a)), a) for a in itertools.product(angles, angles)), key=lambda r: r[0])
    angles = list(grid[1])
    for side in (0, 1):
        def along(a, side=side):
            trial = list(angles)
            trial[side] = a
            return min(f(turned(trial)), _INFEASIBLE)

        found = minimize_scalar(along, bounds=(max(angles[side] - 45.0, -90.0), min(angles[side] + 45.0, 90.0)),
                                method="bounded", options={"maxiter": RISE_ANGLE_STEPS + 2, "xatol": 0.5})
        if found.fun < along(angles[side]):  # (cached: no plan)
            angles[side] = float(found.x)
    y0 = turned(angles)
    left = plans - (objective.tried - start)
    if left > len(y0) + 1:
        _nelder_mead(f, y0, box, _RISE_STEP, left)


#: The free-ends stage's box and initial simplex step [tolerance].
_END_BOX = COEFFICIENT_RANGE
_END_STEP = 0.3


def _end_stage(objective: _Objective, plans: int, planar: bool) -> None:
    """Nelder-Mead (about ``plans`` plans) over the coefficients next to the path's start and end where the
    motion rests (objective.resting, narrowed here in objective.free_ends to the ends the fastest blend joined to
    the lines already reaches within the tolerance; the lateral ones only if ``planar``), from 0, the other
    coordinates fixed at that blend's: its offset pieces then run on to the path's start (end) and may leave
    (reach) it at an angle. The free-shape optimum does (60 deg / 10 mm: it dives 4.5 mm in the first 10 mm of
    arc). Only those ends: elsewhere the blend would start deviating far from the corner, and its tube would no
    longer be the one the corner-confined optimum of its span has (whose end stretches shorter than the
    tolerance join it)."""
    _, shape, x = objective.best(joined=True, planar=planar)
    objective.free_ends = tuple(f and r for f, r in zip(objective.resting, _reached(objective, shape)))
    _free_ends(objective, x, objective.free_ends, plans, planar)


def _late_end_stage(objective: _Objective, plans: int, planar: bool) -> bool:
    """After the joint stage: the ends where the motion rests that its fastest blend reaches within the tolerance
    but stage 5 left joined (the blend it started from stopped short) are freed too, Nelder-Mead (about ``plans``
    plans) over their coefficients from that blend; True if there was one (then the joint stage runs again). At
    30 deg / 5 mm the joint stage stretched the entry from 191.6 to 199.6 mm of the 200 mm line."""
    _, shape, x = objective.best()
    late = tuple(r and reach and not f
                 for r, reach, f in zip(objective.resting, _reached(objective, shape), objective.free_ends))
    if not any(late):
        return False
    objective.free_ends = tuple(f or n for f, n in zip(objective.free_ends, late))
    log.info("blend search: corner %d: the joint stage's blend reaches the path's %s within the tolerance; "
             "freed there too", objective.label, " and ".join(e for e, n in zip(("start", "end"), late) if n))
    _free_ends(objective, x, late, plans, planar)
    return True


def _reached(objective: _Objective, shape: G2Shape) -> tuple[bool, bool]:
    """Whether ``shape`` reaches within the tolerance of the path's start (its entry) and end (its exit)."""
    A, B = objective.original.segments[objective.corner], objective.original.segments[objective.corner + 1]
    return shape.entry >= A.length - objective.tolerance, shape.exit >= B.length - objective.tolerance


def _end_indices(ends: tuple[bool, bool], planar: bool) -> list[int]:
    """Coordinates of the departure's (``ends[0]``) and the arrival's (``ends[1]``) coefficients: the two lateral
    ones, and unless ``planar`` the two along the corner's normal."""
    return [i for part, free in zip((_DEPARTURE, _ARRIVAL), ends) if free
            for i in range(part.start, part.stop)[:2 if planar else 4]]


def _free_ends(objective: _Objective, x, ends: tuple[bool, bool], plans: int, planar: bool) -> None:
    """Nelder-Mead (about ``plans`` plans) over the departure's (``ends[0]``) and the arrival's (``ends[1]``)
    coefficients (only the lateral ones if ``planar``) from 0, the other coordinates fixed at x's."""
    base = _extended(x)
    idx = _end_indices(ends, planar)
    if not idx:
        return

    def f(y):
        trial = base.copy()
        trial[idx] = y
        return objective(trial)

    box = np.array([_END_BOX] * len(idx))
    _nelder_mead(f, np.zeros(len(idx)), box, [_END_STEP] * len(idx), plans)


#: The joint stage's box and initial steps per coordinate, _BALANCE ... _VF_B (the free ends': _END_BOX, _END_STEP).
_JOINT_BOX = _FREE_BOX + (COEFFICIENT_RANGE,) * 6
_JOINT_STEP = _FREE_STEP[:_C_A] + _RISE_STEP[2:]


def _joint_box(profile: Sequence[int], ends: Sequence[int], start=None) -> tuple[np.ndarray, np.ndarray]:
    """(box (m, 2), initial steps (m,)) of the coordinates ``profile`` (indices below _DEPARTURE.start) followed by
    the free ends' ``ends``: _JOINT_BOX and _JOINT_STEP, then _END_BOX and _END_STEP; widened to hold ``start`` (m,)
    when given (a search whose racing line ran beyond RUN_RANGE: SearchSettings.run_range)."""
    box = np.array([_JOINT_BOX[i] for i in profile] + [_END_BOX] * len(ends), float)
    if start is not None:
        box = np.column_stack([np.minimum(box[:, 0], start), np.maximum(box[:, 1], start)])
    return box, np.array([_JOINT_STEP[i] for i in profile] + [_END_STEP] * len(ends))


def _joint_stage(objective: _Objective, plans: int, planar: bool, x=None, share: float = TRUST_RADIUS_SHARE,
                 lean: bool = False) -> None:
    """COBYQA (about ``plans`` plans) over every coordinate of the fastest blend when it has a free end
    (the corner quintic, the offset pieces' profiles in and, unless ``planar``, out of the plane, and the
    free ends' coefficients), from it (or from the 25 coordinates ``x``), its initial trust radius ``share`` of the
    mean step, its models ``lean`` or not (_trust_region). The earlier stages chose the profiles for a blend joined to
    the lines; with a free end other profiles are faster."""
    x = np.array(objective.best()[2] if x is None else x, float)
    if len(x) < _ARRIVAL.stop:  # the fastest blend is joined to the lines: stages 3-4 searched it
        return
    profile = list(range(_V_A if planar else _DEPARTURE.start))
    ends = _end_indices(objective.free_ends, planar)
    idx = profile + ends
    box, steps = _joint_box(profile, ends, x[idx])

    def f(y):
        trial = x.copy()
        trial[idx] = y
        return objective(trial)

    _trust_region(f, np.clip(x[idx], box[:, 0], box[:, 1]), box, steps, plans, share, lean)


#: A wide start's Bernstein coefficients of a free end's offset piece [tolerance] towards the tube's edge, after the
#: 0 at the path's end point, in order towards the corner quintic: the free end's two, far, near, the offset.
WIDE_PROFILE = (0.6, 1.0, 1.0, 0.9, 0.6)
#: A wide start whose runs leave the corner quintic no room has them shortened by this factor, at most this often.
WIDE_RUN_SHRINK = 0.7
WIDE_RUN_TRIES = 6


def _wide_stage(objective: _Objective, plans: int, planar: bool, along_normal: bool = False,
                crossed: tuple[str, str] | None = None, share: float = TRUST_RADIUS_SHARE,
                lean: bool = False, screen: bool = False) -> None:
    """The joint stage (about ``plans`` plans; none if ``screen``: the wide start is planned alone) from a wide start:
    the fastest blend so far (in the corner's plane if ``planar``) with the offset piece of every side whose neighbour
    ends where the motion rests (objective.resting) freed at that end and bulged out to the tube's edge (WIDE_PROFILE):
    outwards in the corner's plane, at the sides not free yet, or (``along_normal``, not ``planar``) along the corner's normal at every resting side, towards the
    side of the plane the fastest blend rises to there (up if it stays in the plane). Nothing if there is no such
    side. The whole-tube optimum does both (benchmarks/right_turn.py, docs/study.md): on benchmarks/right_turn.py's turn at 10 mm it
    leaves the start outwards and runs at the tube's edge 50 mm before the corner, where the fastest joined blend used
    45 mm of the 100 mm entry line and stage 5 left that end joined; at the atlas' 30 deg / 10 mm it rises out of
    the plane by 7-10 mm along both lines. ``crossed`` (a direction per side, "out", "up" or "down" along the corner's
    normal; only at a corner resting at both ends): each side in its own direction (the optimum at 135 deg / 7 mm runs
    up along the entry and out along the exit); ``share``, ``lean``: the joint stage's first trust region and models
    (_trust_region)."""
    if (along_normal or crossed) and planar:
        return
    _, shape, x = objective.best(planar=planar)
    x = _extended(x)
    free = (shape.departure is not None, shape.arrival is not None)
    if crossed is not None:
        wide = objective.resting if all(objective.resting) else (False, False)
    else:
        wide = objective.resting if along_normal else tuple(r and not f for r, f in zip(objective.resting, free))
    directions = crossed or (("normal" if along_normal else "out"),) * 2
    if not any(wide):
        return
    *near_end, far, near, offset = WIDE_PROFILE
    sides = ((_W_A, _C_A, _D_A, (_V_A, _VN_A, _VF_A), _DEPARTURE, shape.rise_entry[0]),
             (_W_B, _C_B, _D_B, (_V_B, _VN_B, _VF_B), _ARRIVAL, shape.rise_exit[0]))
    for bulge, direction, (w, c_far, c_near, rise, end, risen) in zip(wide, directions, sides):
        if not bulge:
            continue
        up = {"up": 1.0, "down": -1.0, "normal": 1.0 if risen >= 0.0 else -1.0}.get(direction)
        lateral, normal = (1.0, 0.0) if up is None else (0.0, up)
        x[[w, c_far, c_near]] = lateral * offset, lateral * far, lateral * near
        x[list(rise)] = normal * offset, normal * near, normal * far
        x[end] = (lateral * near_end[0], lateral * near_end[1], normal * near_end[0], normal * near_end[1])
    objective.free_ends = tuple(f or w for f, w in zip(free, wide))
    runs = [run for bulge, run in zip(wide, (_L_A, _L_B)) if bulge]
    for _ in range(WIDE_RUN_TRIES):  # a free end's run still sizes the corner quintic: shorten it until one fits
        try:
            objective.shape(x)
            break
        except PathmotionError:
            x[runs] = np.maximum(x[runs] * WIDE_RUN_SHRINK, RUN_RANGE[0])
    else:
        log.info("blend search: corner %d: no wide start fits", objective.label)
        return
    log.info("blend search: corner %d: the wide start %s frees the path's %s", objective.label,
             f"{crossed[0]} / {crossed[1]}" if crossed else "along the normal" if along_normal else "outwards",
             " and ".join(e for e, w in zip(("start", "end"), wide) if w))
    if screen:
        objective(x)
        return
    _joint_stage(objective, plans, planar, x, share, lean)


def _wide_screen(objective: _Objective, planar: bool, starts: Sequence) -> None:
    """Each wide start in ``starts`` planned once (_wide_stage: "out" outwards, "normal" along the corner's normal, or a
    pair of directions, crossed), then the free ends read as the fastest blend so far has them: where a wide start is
    faster than the blend the joint stage found, the polish starts from it. The wide starts lie in another basin than
    the racing line's: the blend spans the whole lines at the tube's edge and leaves (reaches) the path's end at rest
    off the line, which the racing line's scalar searches and the short free-ends and joint stages after them do not
    reach where the racing line ends short of that end (150 deg / 5 mm, 120 deg / 1 mm: the thorough search's free
    stage and wide starts end there)."""
    for start in starts:
        crossed = None if isinstance(start, str) else tuple(start)
        _wide_stage(objective, 0, planar, start == "normal", crossed, screen=True)
    shape = objective.best()[1]
    objective.free_ends = (shape.departure is not None, shape.arrival is not None)


def _trust_region(f: Callable, x0: np.ndarray, box: np.ndarray, steps: np.ndarray, plans: int,
                  share: float = TRUST_RADIUS_SHARE, lean: bool = False) -> None:
    """COBYQA (Powell's derivative-free trust-region method on quadratic models, bounded: scipy's, or the cobyqa package scipy wraps for lean models) on f
    from x0 (about ``plans`` evaluations), in the box scaled to [-1, 1], its initial trust radius
    ``share`` of the mean of ``steps`` there. Its models interpolate 2 n + 1 points (n coordinates), or n + 2 if
    ``lean`` (LEAN_MODEL_EXTRA): the first model costs that many plans, so with a budget under 2 n + 1 (a fast
    search's 30 plans over a free-ended blend's 25 coordinates) the default models only probe each coordinate once
    and never move, where the lean ones take a few trust-region steps. COBYQA moves its first point onto a bound (or a
    radius away from it) where x0 is within the radius of that bound (scipy's cobyqa/models.py), so near a bound x0
    itself is not planned."""
    radius = share * float(np.mean(2.0 * steps / (box[:, 1] - box[:, 0])))
    if not lean:
        minimize(f, x0, method="COBYQA", bounds=box,
                 options={"maxfev": plans, "scale": True, "initial_tr_radius": radius,
                          "final_tr_radius": TRUST_RADIUS_FINAL})
        return
    from cobyqa import minimize as cobyqa  # the COBYQA scipy wraps; scipy's wrapper does not pass nb_points

    cobyqa(f, x0, bounds=Bounds(box[:, 0], box[:, 1]),
           options={"maxfev": plans, "scale": True, "radius_init": radius, "radius_final": TRUST_RADIUS_FINAL,
                    "nb_points": len(x0) + LEAN_MODEL_EXTRA})


def _global_stage(objective: _Objective, plans: int, planar: bool) -> tuple[int, str]:
    """CMA-ES (pycma; at most ``plans`` plans, GLOBAL_SIGMA, GLOBAL_SEED) over every coordinate the joint stage
    moves, from the fastest blend (in the corner's plane if ``planar``), joined to the lines or not, in the box
    scaled to [-1, 1]. The earlier stages are local searches, each from the fastest blend so far; a population
    samples the coupled coordinates (the entry's profile, the corner quintic and the exit's profile) together
    (docs/study.md, "The global stage"). A shape that cannot be built or planned ranks behind every one that can,
    the farther from the start the worse, so that a population outside the feasible set is drawn back to it. The
    global NumPy random state is left as it was (pycma seeds it). Returns (candidates drawn, what stopped it). Where
    the fastest blend's offset pieces already fill their segments, nearly every candidate leaves the corner quintic no
    room and is rejected, and the stage finds nothing (benchmarks/blend_fuzz.py seed 29001: 0 of 2496 built)."""
    import cma  # imported when the stage runs: pycma takes 0.7 s to import, every CLI command would pay it

    _, shape, x = objective.best(planar=planar)
    x = np.array(x, float)
    ends = (shape.departure is not None, shape.arrival is not None)
    if len(x) >= _ARRIVAL.stop:
        objective.free_ends = ends  # the ends free in this shape: its coordinates read as it was built
    else:
        x, ends = _extended(x, _DEPARTURE.start), (False, False)
    profile, free = list(range(_V_A if planar else _DEPARTURE.start)), _end_indices(ends, planar)
    idx = profile + free
    box, _ = _joint_box(profile, free, x[idx])
    lo, span = box[:, 0], box[:, 1] - box[:, 0]
    z0 = np.clip(2.0 * (x[idx] - lo) / span - 1.0, -1.0, 1.0)

    def f(z) -> float:
        trial = x.copy()
        trial[idx] = lo + 0.5 * (np.asarray(z) + 1.0) * span
        value = objective(trial)
        return value if np.isfinite(value) else _INFEASIBLE + float(np.linalg.norm(np.asarray(z) - z0))

    state = np.random.get_state()
    try:
        with warnings.catch_warnings():  # pycma warns of flat fitness and the like through warnings
            warnings.simplefilter("ignore")
            es = cma.CMAEvolutionStrategy(z0, GLOBAL_SIGMA, {"bounds": [-1.0, 1.0], "maxfevals": plans,
                                                             "seed": GLOBAL_SEED, "verbose": -9})
            while not es.stop() and es.countevals + es.popsize <= plans:  # whole generations within the plans
                population = es.ask()
                es.tell(population, [f(z) for z in population])
    finally:
        np.random.set_state(state)
    return int(es.countevals), ", ".join(es.stop()) or "its plans"


@dataclass(frozen=True, eq=False)
class _PolishJob:
    """One corner's polish (stage 8), self-contained (it runs in a worker process as well): the corner ``corner`` of
    ``original`` with the blends ``shapes``, from the coordinates ``x`` of its shape there (free ends ``free_ends``,
    those where the motion rests ``resting``, in units of ``tolerance`` [m]), ``plans`` plans under ``settings``;
    ``quintic`` (only the quintic's coordinates), ``planar``; ``states`` (_connection_states of a plan of the whole
    path with ``shapes``: the corner is polished on its window) or None (on the whole path); ``share``: the initial
    trust radius, ``lean``: lean models (_trust_region); ``start_T``: the duration [s] of the whole path with
    ``shapes`` under ``settings`` where a plan of it ran already (else None): on the whole path the start is then not
    planned again where ``x`` builds ``shapes[corner]``."""

    robot: object
    original: TaskPath
    shapes: dict
    corner: int
    x: tuple
    free_ends: tuple[bool, bool]
    resting: tuple[bool, bool]
    tolerance: float
    settings: PlanSettings
    q_start: object
    plans: int
    quintic: bool
    planar: bool
    states: tuple | None
    share: float = TRUST_RADIUS_SHARE
    lean: bool = False
    start_T: float | None = None
    racing_only: bool = False


def _polish_corner(job: _PolishJob) -> tuple[float, float, G2Shape, int]:
    """COBYQA (about ``job.plans`` plans) on the duration under ``job.settings`` from the coordinates ``job.x``: every
    coordinate the joint stage would move, with its steps, only the quintic's if ``job.quintic``, none out of the plane
    if ``job.planar``; on the corner's window where ``job.states`` gives one. Returns (the start's duration [s], the
    fastest duration [s], its shape, plans run, the window's check included)."""
    k = job.corner
    window = (_corner_window(job.robot, job.original, job.shapes, k, job.settings, job.q_start, job.states)
              if job.states is not None else None)
    fine = _objective(job.robot, job.original, job.shapes, k, job.tolerance, job.settings, job.q_start, job.resting,
                      window)
    fine.free_ends = job.free_ends
    if window is None and job.start_T is not None:
        fine.planned[job.shapes[k]] = job.start_T
    x = np.array(job.x, float)  # its shape: the chosen one up to the key's rounding (every shape is certified)
    start_T = fine(x)  # planned as given: COBYQA's first plan is not x when x is near a bound (_trust_region)
    idx = [i for i in range(min(len(x), _W_A if job.quintic else _C_A if job.racing_only else _DEPARTURE.start))
           if not (job.planar and i >= _V_A)]
    ends = _end_indices(fine.free_ends, job.planar) if len(x) >= _ARRIVAL.stop else []
    box, steps = _joint_box(idx, ends, x[idx + ends])

    def f(y):
        trial = x.copy()
        trial[idx + ends] = y
        return fine(trial)

    _trust_region(f, np.clip(x[idx + ends], box[:, 0], box[:, 1]), box, steps, job.plans, job.share, job.lean)
    best_T, best_shape, _ = fine.best()
    log.info("blend search: corner %d polished on %s: %.6g -> %.6g s in %d plans", k,
             "the whole path" if window is None else "its window", start_T, best_T, fine.plans)
    return start_T, best_T, fine.certified(best_shape), fine.plans + (window is not None)


def _polish(robot, original: TaskPath, shapes: dict, duration: float, searched: dict, settings: PlanSettings,
            q_start, plans: int, planar: Sequence[int], quintic: Sequence[int],
            windowed: bool = False, runner: _Runner | None = None,
            share: float = TRUST_RADIUS_SHARE, lean: bool = False, planned: bool = False) -> tuple[float, dict, int]:
    """Stage 8: :func:`_polish_corner` (about ``plans`` plans per corner, its initial trust radius ``share``, its models
    ``lean`` or not) on the duration under ``settings`` from the coordinates of each corner's chosen shape in
    ``shapes`` (found in the caches of that corner's searches, ``searched`` {corner: [_Objective]}), the other corners
    fixed; only the quintic's coordinates at the corners in ``quintic`` (no racing line searched there), none out of
    the plane at those in ``planar``. The searches ranked shapes on a coarse grid; this is the duration the blend is
    reported with. ``windowed``: each corner on its window (_Window, ends from one plan of the whole path with
    ``shapes``), the corners independent (by ``runner``), then planned together on the whole path; else one after the
    other on the whole path, each with the polished blends before it (``planned``: ``duration`` is
    :func:`duration_with`'s of ``shapes`` under ``settings``, so a corner's start is not planned again). Returns
    (duration [s], shapes, plans run), never slower than given."""
    given, shapes = shapes, dict(shapes)
    states = _connection_states(robot, original, given, settings, q_start) if windowed else None
    run = int(states is not None)
    jobs = []
    for k, objectives in searched.items():
        found = [(o, key) for o in objectives for key, (_, shape) in o.cache.items() if shape == shapes[k]]
        if not found:  # e.g. the symmetric blend of a corner whose search never tried it
            continue
        o, key = found[0]
        jobs.append(_PolishJob(robot, original, given, k, key[0], key[1] or o.free_ends, o.resting, o.tolerance,
                               settings, q_start, plans, k in quintic, k in planar, states, share, lean,
                               racing_only=any(objective.risen for objective in objectives)))
    if states is None:  # one after the other, each corner with the blends polished before it
        for job in jobs:
            _, best_T, best_shape, job_run = _polish_corner(dataclasses.replace(
                job, shapes=dict(shapes), start_T=duration if planned else None))
            run += job_run
            if best_T < duration:  # a plan of the whole path with these shapes
                duration, shapes[job.corner], planned = best_T, best_shape, True
        return duration, shapes, run
    for job, (start_T, best_T, best_shape, job_run) in zip(jobs, (runner or _Runner()).map(
            _polish_corner, [(job,) for job in jobs], "corner-polish")):
        run += job_run
        if best_T < start_T:  # each corner against its own start (on its window, or on the whole path)
            shapes[job.corner] = best_shape
    if shapes == given:
        return duration, shapes, run
    together = duration_with(robot, original, shapes, settings, q_start)  # the windows' gains, on the whole path
    log.info("blend search: the polished corners on the whole path: %.6g -> %.6g s", duration, together)
    return (together, shapes, run + 1) if together < duration else (duration, dict(given), run + 1)


@dataclass(frozen=True)
class SearchSettings:
    """How hard :func:`optimal_blends` searches each corner (the stages of the module docstring): ``cycles`` passes
    of the quintic stage's scalar searches of ``steps`` golden steps; ``racing`` the racing line (at line-line corners;
    ``racing_cycles`` passes of its searches of ``racing_steps`` steps, the runs within ``run_range`` [run unit], the
    offsets searched from each of ``run_starts`` first); plans (0 skips the stage; each runs on its
    own): ``free_plans`` the free offset pieces, ``rise_plans`` the rise, ``end_plans`` the free ends,
    ``joint_plans`` the joint stage, ``wide_plans`` / ``wide_normal_plans`` / ``wide_crossed_plans`` the wide starts,
    ``wide_screen`` wide starts each planned once after the joint stage (_wide_screen; empty: none),
    ``restart_plans`` the wide restart, ``global_plans`` the global stage; ``retry_capped`` stage 7;
    ``polish_plans`` stage 8 from ``polish_starts`` candidates, on ``polish_grid_points`` grid points (None: the full
    grid; else its blend confirmed there), its initial trust radius ``polish_radius_share`` (_trust_region);
    ``lean_models``: the joint stages' and the polish's COBYQA models on n + 2 points, not 2 n + 1 (_trust_region);
    ``search_grid_points`` the search's grid; ``rise_tolerance_share``: the rise runs only where the tolerance is at
    least that share of the shorter of the corner's segments (_rise_room); ``rise_polish_racing``: where it ran, the
    polish moves only the racing line's coordinates and the free ends;
    ``windows`` each corner on its window (else every plan on the whole path); ``neighbour_pass`` on a path of
    several corners, each searched again with its neighbours' found blends in place (_neighbour_pass)."""

    cycles: int = SEARCH_CYCLES
    steps: int = GOLDEN_STEPS
    racing_steps: int = RACING_STEPS
    racing_cycles: int = RACING_CYCLES
    run_range: tuple[float, float] = RUN_RANGE
    run_starts: tuple[float, ...] = (1.0,)
    racing: bool = True
    search_grid_points: int = SEARCH_GRID_POINTS
    free_plans: int = FREE_PLANS
    rise_plans: int = RISE_PLANS
    end_plans: int = END_PLANS
    joint_plans: int = JOINT_PLANS
    wide_plans: int = WIDE_PLANS
    wide_normal_plans: int = WIDE_NORMAL_PLANS
    wide_crossed_plans: int = CROSSED_DEFAULT_PLANS
    restart_plans: int = RESTART_PLANS
    wide_screen: tuple = ()
    global_plans: int = GLOBAL_PLANS
    retry_capped: bool = True
    polish_plans: int = POLISH_PLANS
    polish_starts: int = POLISH_STARTS
    windows: bool = True
    neighbour_pass: bool = True
    polish_grid_points: int | None = None
    polish_radius_share: float = TRUST_RADIUS_SHARE
    lean_models: bool = False
    rise_tolerance_share: float = 0.0
    rise_polish_racing: bool = False
    rise_angles: tuple = RISE_ANGLES


#: Every stage (the corner atlas' search; 15-60 s of CPU per corner).
THOROUGH = SearchSettings()
#: The quintic (short scalar searches) and the racing line (S-curve offset pieces, one pass) on the search grid, a short
#: rise where the tolerance leaves room (FAST_RISE_PLANS), short
#: free-ends and joint stages where the motion rests at a path end the blend reaches, the wide starts planned once each
#: where it rests at a path end (FAST_WIDE_SCREEN), each corner's winner polished
#: briefly on a fixed grid (benchmarks/bench_fast_search.py measures its cost and its share of the thorough search's
#: gain over the symmetric G2 blend on the corner atlas' rows: docs/results.md). No neighbour pass: on the z10 cycle it
#: found nothing faster for the fast search (1.2413 s either way) for 40 % more CPU.
FAST = SearchSettings(steps=FAST_STEPS, racing_cycles=FAST_RACING_CYCLES, run_range=FAST_RUN_RANGE,
                      run_starts=FAST_RUN_STARTS, free_plans=0, end_plans=FAST_END_PLANS,
                      joint_plans=FAST_JOINT_PLANS, wide_plans=0, wide_normal_plans=0, wide_screen=FAST_WIDE_SCREEN,
                      restart_plans=0, global_plans=0, rise_plans=FAST_RISE_PLANS,
                      rise_angles=FAST_RISE_ANGLES, rise_tolerance_share=FAST_RISE_TOLERANCE_SHARE,
                      rise_polish_racing=FAST_RISE_POLISH_RACING,
                      retry_capped=False, polish_plans=FAST_POLISH_PLANS, polish_grid_points=FAST_POLISH_GRID_POINTS,
                      polish_radius_share=FAST_POLISH_RADIUS_SHARE, neighbour_pass=False, lean_models=True)
#: The searches by name (scenario ``search = "fast" | "thorough"``).
SEARCHES = {"fast": FAST, "thorough": THOROUGH}


@dataclass(frozen=True, eq=False)
class _Found:
    """What one corner's search found (on the search grid): the fastest blend (``best``), the fastest of each class
    (one quintic, S-curves, in the corner's plane, joined to the lines), the fastest before each late stage (that
    stage's own candidate; ``best`` where it did not run), the first search's fastest when the capped retry won
    (``capped``), the searches themselves (``searched``: [_Objective], for the polish) and the ``plans`` run."""

    best: G2Shape
    quintic: G2Shape
    s_curve: G2Shape
    in_plane: G2Shape
    joined: G2Shape
    before_joint: G2Shape
    before_wide: G2Shape
    before_restart: G2Shape
    before_crossed: G2Shape
    before_global: G2Shape
    capped: G2Shape | None
    searched: tuple
    plans: int


@dataclass(frozen=True, eq=False)
class _CornerJob:
    """One corner's search, self-contained (it runs in a worker process as well): the path ``original`` with the
    symmetric blends ``shapes`` at every chosen corner, the ``corner``, its ``tolerance`` [m], the search's plan
    ``settings``, ``ends`` (free ends where the motion rests), ``racing`` (a line-line corner), ``planar``,
    ``windowed`` (on its window); ``warm``: (coordinates, free ends or None, the tolerance [m] they are in units
    of) of a blend to start from as well (the neighbour pass: the corner's first-pass blend)."""

    robot: object
    original: TaskPath
    shapes: dict
    corner: int
    tolerance: float
    settings: PlanSettings
    q_start: object
    ends: tuple[bool, bool]
    racing: bool
    planar: bool
    windowed: bool
    search: SearchSettings
    warm: tuple | None = None


@dataclass(frozen=True)
class _Stages:
    """The fastest blend so far before each late stage of one search (None where that stage did not run)."""

    before_joint: G2Shape | None = None
    before_wide: G2Shape | None = None
    before_restart: G2Shape | None = None
    before_crossed: G2Shape | None = None
    before_global: G2Shape | None = None


def _late_stages(objective: _Objective, search: SearchSettings, planar: bool) -> _Stages:
    """The free-ends stage and the stages after it (joint, wide starts, restart, crossed starts), where the corner
    has a free end; the fastest blend before each (module docstring)."""
    _end_stage(objective, search.end_plans, planar)
    before = objective.best()[1]
    if search.joint_plans > 0:
        _joint_stage(objective, search.joint_plans, planar, lean=search.lean_models)
        if _late_end_stage(objective, search.end_plans, planar):
            _joint_stage(objective, search.joint_plans, planar, lean=search.lean_models)
    before_wide = objective.best()[1]
    if search.wide_screen:
        _wide_screen(objective, planar, search.wide_screen)
    if search.wide_plans > 0:
        _wide_stage(objective, search.wide_plans, planar, lean=search.lean_models)
    if search.wide_normal_plans > 0:
        _wide_stage(objective, search.wide_normal_plans, planar, along_normal=True, lean=search.lean_models)
    ahead, before_restart, _ = objective.best()
    restart = search.restart_plans > 0 and search.joint_plans > 0  # the joint stage once more: not without it
    if restart:
        _joint_stage(objective, search.restart_plans, planar, share=RESTART_RADIUS_SHARE, lean=search.lean_models)
        log.info("blend search: corner %d: the wide restart: %.6g -> %.6g s (coarse grid)", objective.label,
                 ahead, objective.best()[0])
    crossed = search.wide_crossed_plans > 0 and search.joint_plans > 0  # joint stages, as the restart
    before_crossed = objective.best()[1]
    for directions in CROSSED_DIRECTIONS if crossed else ():
        _wide_stage(objective, search.wide_crossed_plans, planar, crossed=directions, share=WIDE_CROSSED_RADIUS_SHARE,
                    lean=search.lean_models)
    wide = search.wide_plans > 0 or search.wide_normal_plans > 0 or crossed or restart or bool(search.wide_screen)
    return _Stages(before if search.joint_plans > 0 or wide else None, before_wide if wide else None,
                   before_restart if restart else None, before_crossed if crossed else None)


def _search_corner(objective: _Objective, racing: bool, search: SearchSettings, planar: bool = False,
                   warm: tuple | None = None) -> _Stages:
    """Fill ``objective``'s cache: the quintic stage from the symmetric blend (or from ``warm``, (coordinates, free
    ends or None), where that is faster), then (``racing``) the racing-line stage
    from the best quintic, the free stage (``search.free_plans`` > 0), the rise (not ``planar``), the free ends and
    the stages after them (_late_stages, at a corner with a free end) and the global stage (module docstring).
    Returns the fastest blend before each late stage that ran (candidates of their own: a later stage's blend is
    faster on the search's coarse grid, not always on the full one)."""
    start = np.array([0.5, defaults.G2_BLEND_SHAPE, defaults.G2_BLEND_SHAPE, 0.0, 0.0, 1.0, 1.0])
    objective(start)
    if warm is not None:  # read with the free ends it was built with
        objective.free_ends = warm[1] or objective.free_ends
        objective(np.array(warm[0], float))
    for _ in range(search.cycles):
        for i, box in ((_BALANCE, BALANCE_RANGE), (_SHAPE_A, SHAPE_RANGE), (_SHAPE_B, SHAPE_RANGE)):
            _line_search(objective, np.array(objective.best()[2]), (i,), *box, search.steps)
    if not racing:
        return _Stages()
    found = _Stages()
    _racing_stage(objective, search)
    if search.free_plans > 0:
        _free_stage(objective, search.free_plans)
    if search.rise_plans > 0 and not planar and _rise_room(objective, search.rise_tolerance_share):
        _rise_stage(objective, search.rise_plans, search.rise_angles)
        objective.risen = search.rise_polish_racing
    if search.end_plans > 0 and any(objective.free_ends):
        found = _late_stages(objective, search, planar)
    if search.global_plans > 0:
        ahead, before_global, _ = objective.best()
        drawn, why = _global_stage(objective, search.global_plans, planar)
        log.info("blend search: corner %d: the global stage: %.6g -> %.6g s (coarse grid), %d candidates, "
                 "stopped by %s", objective.label, ahead, objective.best()[0], drawn, why)
        found = dataclasses.replace(found, before_global=before_global)
    return found


def _racing_possible(path: TaskPath, corner: int) -> bool:
    """A racing line needs a sharp corner between two lines."""
    return (path.connection(corner).kind == "corner" and isinstance(path.segments[corner], Line)
            and isinstance(path.segments[corner + 1], Line))


def _search_one(job: _CornerJob) -> _Found:
    """Stages 1-7 at one corner (module docstring): its search, and the capped retry where the neighbours, not the
    tolerance, capped the blend; the faster kept, the candidates of both."""
    k, search = job.corner, job.search
    window = (_corner_window(job.robot, job.original, job.shapes, k, job.settings, job.q_start)
              if job.windowed else None)
    plans = 2 * (window is not None)  # the whole path's plan for its ends, and the window's check
    obj = _objective(job.robot, job.original, job.shapes, k, job.tolerance, job.settings, job.q_start, job.ends,
                     window)
    warm = job.warm if job.warm is not None and np.isclose(job.warm[2], job.tolerance) else None
    stages = _search_corner(obj, job.racing, search, job.planar, None if warm is None else warm[:2])
    searched, capped = [obj], None
    reached = obj.certified(obj.best()[1]).deviation if search.retry_capped else job.tolerance
    if reached < CAPPED_SHARE * job.tolerance:  # the neighbours capped the blend: stage 7
        again = _objective(job.robot, job.original, job.shapes, k, reached, job.settings, job.q_start, job.ends,
                           window)
        stages_again = _search_corner(again, job.racing, search, job.planar)
        searched.append(again)
        log.info("blend search: corner %d: the fastest blend within %.6g m reached only %.6g m; searched again "
                 "within that: %.6g s against %.6g s (coarse grid)", k, job.tolerance, reached, again.best()[0],
                 obj.best()[0])
        if again.best()[0] < obj.best()[0]:
            capped, obj, stages = obj.best()[1], again, stages_again

    def fastest(**kind) -> G2Shape:  # over both searches when capped: the retry adds candidates, never drops any
        return min((o.best(**kind) for o in searched), key=lambda r: r[0])[1]

    def certified(shape: G2Shape | None) -> G2Shape | None:  # with its deviation bound, by the search that built it
        return None if shape is None else next(o for o in searched if shape in o.built).certified(shape)

    best = certified(obj.best()[1])
    plans += sum(o.plans for o in searched)
    log.info("blend search: corner %d: %d plans, shape %s", k, plans - 2 * (window is not None), best)
    classes = (fastest(quintic_only=True), fastest(s_curve_only=True), fastest(planar=True), fastest(joined=True),
               stages.before_joint or best, stages.before_wide or best, stages.before_restart or best,
               stages.before_crossed or best, stages.before_global or best, capped)
    return _Found(best, *(certified(shape) for shape in classes), tuple(searched), plans)


class _Runner:
    """Maps a function over argument tuples, in order: each call a task on the Dask cluster at ``scheduler``
    ([PROTOCOL://]HOST:PORT) when given, else on ``workers`` local processes (one pool for the whole search, started at
    its first map of more than one call, as many as that map's calls at most), else in this process. A context
    manager: the pool ends with it."""

    def __init__(self, workers: int = 1, scheduler: str | None = None):
        self.workers, self.scheduler, self._pool = workers, scheduler, None

    def map(self, fn: Callable, calls: list[tuple], label: str) -> list:
        if self.scheduler is not None and len(calls) > 1:
            from ..io.scheduler import run_on_cluster

            return list(run_on_cluster(self.scheduler, fn, calls, label))
        if self.workers <= 1 or len(calls) <= 1:
            return [fn(*call) for call in calls]
        if self._pool is None:
            self._pool = WorkerPool(min(self.workers, len(calls)))
        log.info("blend search: %d %s tasks on %d worker processes", len(calls), label, self._pool.workers)
        return self._pool.map(fn, calls)

    def __enter__(self) -> "_Runner":
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.__exit__(*exc)
            self._pool = None


def _search_all(jobs: list[_CornerJob], runner: _Runner) -> dict[int, _Found]:
    """Every corner's search, in corner order, by ``runner``."""
    return dict(zip((job.corner for job in jobs), runner.map(_search_one, [(job,) for job in jobs], "corner-search")))


#: The candidate classes of every corner, in the order they are planned on the full grid (ties: the first wins).
_CLASSES = ("quintic", "s_curve", "in_plane", "joined", "before_joint", "before_wide", "before_restart",
            "before_crossed", "before_global")


def optimal_blends(robot, original: TaskPath, tolerance: float | dict, corners: Sequence[int] | None = None,
                   settings: PlanSettings | None = None, q_start=None, *, search: SearchSettings = THOROUGH,
                   planar: Sequence[int] = (), joined_ends: Sequence[int] = (),
                   names: Mapping[int, str] | None = None, workers: int = 1, scheduler: str | None = None,
                   **changes) -> OptimalBlend:
    """The G2 blends within ``tolerance`` [m] (or {corner: tolerance}) at ``corners`` (connection indices, default
    every sharp corner) of ``original`` that minimise the time-optimal duration under ``settings`` (module docstring),
    searched as ``search`` says (``changes``: SearchSettings fields to override, e.g. ``polish_plans=0``). The
    corners in ``planar`` stay in their plane; those in ``joined_ends`` join the lines even at a path end where the
    motion rests. Each corner is searched from the symmetric blends at the others, so the corners are independent:
    ``workers`` > 1 searches them on that many local processes, ``scheduler`` (a Dask scheduler's address) on its
    cluster, with the same result. PathError as
    :func:`~pathmotion.geometry.with_blends` (prefixed with ``names[corner]`` when given) when the tolerance does not
    fit."""
    search = dataclasses.replace(search, **changes) if changes else search
    settings = settings or PlanSettings()
    chosen = [c.index for c in original.connections if c.kind == "corner"] if corners is None else sorted(corners)
    tol = dict(tolerance) if isinstance(tolerance, dict) else {k: float(tolerance) for k in chosen}
    # the symmetric blends, and their errors (a tolerance too large: the largest that fits)
    symmetric = with_blends(original, {k: ("g2", tol[k]) for k in chosen}, names)
    coarse = replace_settings(settings, grid_points=search.search_grid_points, verify=False, baselines=False)
    initial = {k: g2_shape_for_tolerance(original, k, tol[k], 0.5, defaults.G2_BLEND_SHAPE, defaults.G2_BLEND_SHAPE,
                                         shared=(k - 1 in chosen, k + 1 in chosen)) for k in chosen}
    rests = (False, False) if original.closed else _rests(settings)
    windowed = search.windows and _windows_apply(original)
    jobs = []
    for k in chosen:
        racing = search.racing and _racing_possible(original, k)
        free = racing and k not in joined_ends
        ends = (free and rests[0] and k == 0, free and rests[1] and k == len(original.segments) - 2)
        jobs.append(_CornerJob(robot, original, initial, k, tol[k], coarse, q_start, ends, racing, k in planar,
                               windowed, search))
    with _Runner(workers, scheduler) as runner:
        found, first = _search_all(jobs, runner), None
        if search.neighbour_pass and len(jobs) > 1:
            first, found = found, _neighbour_pass(jobs, found, runner)
        return _chosen(robot, original, symmetric, initial, found, settings, q_start, search, planar, windowed, runner,
                       first)


def _neighbour_pass(jobs: list[_CornerJob], found: dict[int, _Found], runner: _Runner) -> dict[int, _Found]:
    """Every corner searched again from its first-pass blend (``found``) with its neighbours' found blends in place:
    the corners at even places in corner order first (their neighbours' first-pass blends), then those at odd places
    (their neighbours' blends just found), so that each half's searches are independent (by ``runner``).
    A corner's blend changes the speed its neighbours' windows are entered and left at, and so their fastest blends.
    Returns what both passes found per corner: the second pass's blends, the candidates of both."""
    shapes = {**jobs[0].shapes, **{k: f.best for k, f in found.items()}}
    again: dict[int, _Found] = {}
    for half in (jobs[0::2], jobs[1::2]):
        redo = [dataclasses.replace(job, shapes=dict(shapes), warm=_coordinates(found[job.corner])) for job in half]
        for k, f in _search_all(redo, runner).items():
            again[k], shapes[k] = f, f.best
    log.info("blend search: the neighbour pass: %d corners searched again with their neighbours' blends", len(again))
    return {k: dataclasses.replace(again[k], searched=found[k].searched + again[k].searched,
                                   plans=found[k].plans + again[k].plans) for k in found}


def _coordinates(found: _Found) -> tuple | None:
    """(coordinates, free ends or None, tolerance [m]) of ``found.best`` in its search's cache; None if not there."""
    for objective in found.searched:
        for key, (_, shape) in objective.cache.items():
            if shape == found.best:
                return key[0], key[1], objective.tolerance
    return None


def _chosen(robot, original: TaskPath, symmetric: TaskPath, initial: dict, found: dict[int, _Found],
            settings: PlanSettings, q_start, search: SearchSettings, planar: Sequence[int],
            windowed: bool, runner: _Runner, first: dict[int, _Found] | None = None) -> OptimalBlend:
    """Stage 8 and the choice: every class's fastest blends (and the symmetric ones; those of the first pass
    ``first`` too where the neighbour pass ran) planned on the full grid, the fastest polished (module docstring; its
    corners by ``runner`` where they are polished on their windows); the OptimalBlend with the class durations."""
    plans = sum(f.plans for f in found.values())
    full = replace_settings(settings, verify=False, baselines=False)
    sym_T = float(plan(lift(robot, symmetric, q_start, original=original), robot, full).profile.duration)
    candidates = [(sym_T, initial, symmetric)]
    stages = _class_blends(initial, found) + (_class_blends(initial, first) if first else ())
    for stage in [c for i, c in enumerate(stages) if c not in stages[:i]]:
        candidates.append((duration_with(robot, original, stage, full, q_start), stage, None))
    plans += len(candidates)
    log.info("blend search: the candidates on the full grid: %s s", ", ".join(f"{c[0]:.6g}" for c in candidates))
    quintic_T = candidates[1][0]
    joined_T = min(c[0] for c in candidates if all(_joined(shape) for shape in c[1].values()))
    planar_T = min(c[0] for c in candidates if all(shape.planar for shape in c[1].values()))
    ranked = sorted(candidates, key=lambda c: c[0])  # stable: the first (symmetric) wins ties
    T, best, path = ranked[0]
    quintic_only = [k for k in found if not (search.racing and _racing_possible(original, k))]
    starts = [c for i, c in enumerate(ranked) if all(c[1] != d[1] for d in ranked[:i])][:search.polish_starts]
    searches = {k: list(f.searched) for k, f in found.items()}
    for start_T, start, _ in starts if search.polish_plans > 0 else ():
        polished_T, polished, polish_run = _polished(robot, original, start, start_T, searches, full, q_start, search,
                                                     planar, quintic_only, windowed, runner)
        plans += polish_run
        if polished_T < start_T:
            shapes_now = polished.values()  # the polished blend counts for the classes it still belongs to
            quintic_T = min(quintic_T, polished_T) if not any(s.racing for s in shapes_now) else quintic_T
            planar_T = min(planar_T, polished_T) if all(s.planar for s in shapes_now) else planar_T
            joined_T = min(joined_T, polished_T) if all(_joined(s) for s in shapes_now) else joined_T
        log.info("blend search: polished from the candidate of %.6g s: %.6g s (fastest so far %.6g s)", start_T,
                 polished_T, min(T, polished_T))
        if polished_T < T:
            T, best, path = polished_T, polished, None
    return OptimalBlend(best, symmetric if path is not None else with_shaped_g2_blends(original, best), T, sym_T,
                        plans, quintic_T, planar_T, joined_T)


def _class_blends(initial: dict, found: dict[int, _Found]) -> tuple[dict, ...]:
    """The blends {corner: G2Shape} of each candidate class (_CLASSES) of ``found``, the symmetric ``initial`` ones
    elsewhere; then the capped searches' own where any won, and the fastest blends."""
    shapes = {k: f.best for k, f in found.items()}
    capped = {k: f.capped for k, f in found.items() if f.capped is not None}
    return (tuple({**initial, **{k: getattr(f, name) for k, f in found.items()}} for name in _CLASSES)
            + (({**shapes, **capped},) if capped else ()) + ({**initial, **shapes},))


def _polished(robot, original: TaskPath, start: dict, start_T: float, searched: dict, full: PlanSettings, q_start,
              search: SearchSettings, planar: Sequence[int], quintic: Sequence[int],
              windowed: bool, runner: _Runner) -> tuple[float, dict, int]:
    """Stage 8 from the blends ``start`` (full-grid duration ``start_T`` [s]): :func:`_polish` under ``full``, or on
    ``search.polish_grid_points`` grid points and its blends then planned on the full grid. Returns (full-grid
    duration [s], shapes, plans run); ``start`` and ``start_T`` where the polish found nothing faster."""
    if search.polish_grid_points is None:
        return _polish(robot, original, start, start_T, searched, full, q_start, search.polish_plans, planar, quintic,
                       windowed, runner, search.polish_radius_share, search.lean_models)
    grid = replace_settings(full, grid_points=search.polish_grid_points)
    on_grid = duration_with(robot, original, start, grid, q_start)
    _, polished, run = _polish(robot, original, start, on_grid, searched, grid, q_start, search.polish_plans, planar,
                               quintic, windowed, runner, search.polish_radius_share, search.lean_models, planned=True)
    if polished == start:
        return start_T, start, run + 1
    T = duration_with(robot, original, polished, full, q_start)
    log.info("blend search: the polish on %d grid points, on the full grid: %.6g -> %.6g s", search.polish_grid_points,
             start_T, T)
    return (T, polished, run + 2) if T < start_T else (start_T, start, run + 2)


def _joined(shape: G2Shape) -> bool:
    """The blend joins the lines at both sides (no departure or arrival)."""
    return shape.departure is None and shape.arrival is None


def _rests(settings: PlanSettings) -> tuple[bool, bool]:
    """Whether the motion under ``settings`` starts / ends at rest (zero speed, not periodic)."""
    if settings.periodic:
        return False, False
    return at_rest(settings.start_condition), at_rest(settings.end_condition)


def replace_settings(settings: PlanSettings, **changes) -> PlanSettings:
    """A copy of ``settings`` with ``changes`` (checked again, as PlanSettings always is)."""
    return replace(settings, **changes)


__all__ = ["FAST", "OptimalBlend", "SEARCHES", "SearchSettings", "THOROUGH", "duration_with", "optimal_blends"]
