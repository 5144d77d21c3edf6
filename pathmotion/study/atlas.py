"""The corner atlas: for each turn angle and tolerance, the duration of every way to take
the corner, against the physical limit.

Geometry: two lines of ATLAS_SEGMENT_LENGTH in the horizontal plane z = ATLAS_HEIGHT, the first along
+x ending at ATLAS_CORNER, the second turning left by ``angle_deg`` (0 = straight on, 180 = back).
The IRB140 from rest to rest, tool down, joint velocity and acceleration limits (as in the reference turn of
benchmarks/right_turn.py), and with ``torque`` its joint torque limits too, for every motion and both references
(the ``torque`` column; the optima's cache key then holds the torque limits, payload, armature and
gravity). ``torque_reserve`` r (the ``torque_reserve`` column, the scenario key ``[limits] torque_reserve``)
keeps r tau_max of every joint free for feedback: every motion is planned, and both references are solved,
within (1 - r) tau_max (planning/limits/torque.py's TorqueLimit), while the closed-loop check's plant has the
whole tau_max, as a scenario's simulate run does. The robot is the built-in IRB140 or any arm a robot file
describes (:mod:`.robot_file`). Per row (``corners.csv``, ATLAS_COLUMNS):

* ``stop_s``: the time-optimal stop at the corner; ``circle_s``: the transition circle whose deviation
  is the tolerance; ``g2_s``: the symmetric G2 blend; ``optimal_s``: the tolerance-optimal blend
  (planning/blend_search.py; its entry / exit cuts in ``optimal_entry_m`` / ``optimal_exit_m``, its
  racing-line offsets outside the turn in ``optimal_offset_entry_m`` / ``optimal_offset_exit_m``, 0
  for one quintic, and its offset pieces' rise out of the corner's plane (along the turn's normal: up
  at a left turn) where they meet the corner quintic in ``optimal_rise_entry_m`` / ``optimal_rise_exit_m``,
  0 in the plane); ``quintic_s``: the search's best single quintic;
* ``industrial_zone_s``: a constant TCP speed (the planner's constant_speed baseline: the highest
  speed held everywhere, trapezoid ramps at the ends) on the path with an ABB-style parabolic zone:
  a parabola from the entry to the exit point at distance z from the corner, z such that its
  deviation z sin(angle) / 4 is the tolerance, capped at half the segments as ABB does;
* ``free_shape_optimum_s`` (whole tube) and ``corner_optimum_s`` (deviation only within the optimal
  blend's own span), from :mod:`.free_shape`, with their convergence errors (``*_error_s``);
  None when an NLP did not converge, or converged above a motion feasible in its tube (a local
  optimum; the whole tube also above the corner-confined reference by more than both errors, since its
  tube contains the other): ``status`` then says which. The corner-confined NLP is tried from the
  optimal blend's plan and from the stop (CORNER_STARTS), the whole tube from the corner-confined
  solutions, the stop and the blend (WHOLE_STARTS), until one start gives a reference (best_reference);
* ``corner_bound_s``: the corner-confined tube's feasible bound (:func:`corner_bound`), an upper bound of its true
  minimum time, and ``gap_to_corner_bound`` = optimal_s / corner_bound_s - 1, a lower bound of the blend's true gap;
  None (``status`` says why) where no solve held the tube;
* ``gain_vs_stop`` = 1 - optimal_s / stop_s; ``gap_to_optimum`` = optimal_s / free_shape_optimum_s - 1;
  ``capture`` = (stop_s - optimal_s) / (stop_s - free_shape_optimum_s), the share of the whole-tube
  gain the optimal blend takes.

Each row is one point of the sweep machinery (:func:`~pathmotion.study.sweep.run_sweep` with this
module's point function), so it runs in local processes or on a Dask cluster and resumes; the free-
shape optima are cached on disk in ``out/optimum_cache`` keyed by their inputs (a shared folder
when the workers are remote).
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np

from .. import defaults
from ..errors import PathError, PathmotionError, ScenarioError
from ..io.atomic import write_json, write_text
from ..io.files import mark_result

log = logging.getLogger(__name__)

ATLAS_SEGMENT_LENGTH = 0.2
ATLAS_CORNER = (0.5, -0.05, 0.45)
#: Columns of corners.csv.
ATLAS_COLUMNS = ("angle_deg", "tolerance_m", "torque", "torque_reserve", "status", "stop_s", "circle_s", "g2_s",
                 "quintic_s", "optimal_s", "free_shape_optimum_s", "free_shape_error_s", "corner_optimum_s",
                 "corner_error_s", "corner_bound_s", "industrial_zone_s", "gain_vs_stop", "gain_vs_zone", "gain_vs_g2",
                 "gap_to_optimum", "gap_to_corner_optimum", "gap_to_corner_bound", "capture", "optimal_entry_m",
                 "optimal_exit_m", "optimal_offset_entry_m", "optimal_offset_exit_m", "optimal_rise_entry_m", "optimal_rise_exit_m", "closed_loop_ok",
                 "closed_loop_path_accuracy_m", "closed_loop_cornering_deviation_m", "closed_loop_cycle_s", "error")
#: Bump when the free-shape formulation changes, so cached optima are recomputed; the corner-confined
#: optima have their own (3: its restarts changed, so a cached failure is solved again; 3 / 4: the tube
#: constraint in norm form with a small barrier, free_shape.STARTS; whole tube 4: from the corner-confined one).
OPTIMUM_VERSION = 4
CORNER_OPTIMUM_VERSION = 4
#: Bump when the feasible bound's method (free_shape.feasible_bound) changes, so cached bounds are recomputed.
BOUND_VERSION = 1
#: Bump when a row's content changes, so the sweep recomputes its points (the optima stay cached; 6: the torque
#: column and the whole tube's retries; 7: the feasible bound). Not bumped for the torque_reserve column: a torque-free
#: row's is empty, as a point recorded before it reads, and a torque atlas' spec holds its reserve, so its points are
#: new.
ROW_VERSION = 7
#: IPOPT statuses counted as converged.
CONVERGED_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
#: Largest distance [m] of the simulated TCP from the planned path for the closed-loop check.
CLOSED_LOOP_PATH_ACCURACY = 1e-3
#: Smallest angle from 0 and 180 degrees a corner may have [deg].
ANGLE_MARGIN_DEG = 1.0


def corner_points(angle_deg: float, length: float = ATLAS_SEGMENT_LENGTH) -> np.ndarray:
    """The atlas' sharp path (3, 3) [m]: start, corner, end (a left turn by ``angle_deg``)."""
    a = float(angle_deg)
    if not ANGLE_MARGIN_DEG <= a <= 180.0 - ANGLE_MARGIN_DEG:
        raise PathError(f"corner atlas: angle {a:g} deg is not a corner; give turn angles strictly between "
                        f"{ANGLE_MARGIN_DEG:g} and {180 - ANGLE_MARGIN_DEG:g} deg (0 = straight on, 180 = reversal)")
    c = np.asarray(ATLAS_CORNER, float)
    r = np.radians(a)
    return np.array([c - (length, 0.0, 0.0), c, c + length * np.array([np.cos(r), np.sin(r), 0.0])])


def _task(points: np.ndarray):
    from ..geometry import FixedOrientation, Line, TaskPath

    return TaskPath(tuple(Line(a, b) for a, b in zip(points[:-1], points[1:])), FixedOrientation())


def check_inputs(angles: Sequence[float], tolerances: Sequence[float],
                 meshes: Sequence[int] | None = None) -> tuple[int, ...]:
    """The checked meshes (``meshes``, default defaults.ATLAS_MESHES, as whole interval counts); PathError for
    an angle of (about) 0 or 180 deg, a tolerance that is not positive or not below half a segment, or
    meshes that are not at least two interval counts each twice the previous (every reference needs a
    convergence error). (A tolerance that no G2 blend can use up at some angle is that row's error,
    with the largest that fits.)"""
    from .free_shape import check_meshes

    checked = check_meshes(meshes or defaults.ATLAS_MESHES, least=2)
    for a in angles:
        corner_points(a)
    half = 0.5 * ATLAS_SEGMENT_LENGTH
    for tol in tolerances:
        if not (np.isfinite(tol) and 0 < tol < half):
            mm = f"; mm? the unit is m (e.g. {tol:g} mm = {tol * 1e-3:g} m)" if 0 < tol * 1e-3 < half else ""
            raise PathError(f"corner atlas: tolerance {tol!r} m must be a positive distance below half a segment "
                            f"({half:g} m){mm}")
    return checked


def check_torque_reserve(reserve, torque: bool, name: str = "torque_reserve", switch: str = "torque") -> float:
    """The feedback reserve [-] of an atlas: ``reserve`` checked as the planner checks ``[limits] torque_reserve``
    (a number in [0, defaults.MAX_TORQUE_RESERVE)), defaults.TORQUE_RESERVE with ``torque`` when None, 0 without;
    a ScenarioError naming the option ``name`` (and ``switch``, the torque option) otherwise, also for a reserve
    given without torque limits (it is a share of them)."""
    from ..planning.limits.torque import check_reserve

    if reserve is None:
        return defaults.TORQUE_RESERVE if torque else 0.0
    if not torque:
        raise ScenarioError(f"{name} {reserve!r} without {switch}: the reserve is a share of the joint torque limits, "
                            f"which the atlas enforces only with {switch}; add {switch}, or drop {name}")
    try:
        return check_reserve(reserve)
    except ScenarioError:
        raise ScenarioError(f"{name} {reserve!r}: give the fraction of each torque limit kept free for feedback, a "
                            f"number in [0, {defaults.MAX_TORQUE_RESERVE:g}) (e.g. 0.2; as the scenario key "
                            "[limits] torque_reserve)") from None


# ------------------------------------------------------------------------------------ one row
def _settings(torque: bool = False, torque_reserve: float | None = None, **kw):
    """The atlas' plan settings: rest to rest, velocity and acceleration limits, torque limits when ``torque`` (with
    ``torque_reserve`` [-] when given); ``kw``: other PlanSettings fields."""
    from ..planning import PlanSettings

    limits = {"use_velocity": True, "use_acceleration": True, "use_torque": torque}
    if torque_reserve is not None:
        limits["torque_reserve"] = torque_reserve
    return PlanSettings(start="zero", end="zero", limits=limits, **kw)


def reserved(robot, torque_reserve: float):
    """``robot`` with the torque limits the planner enforces under the feedback reserve r, (1 - r) tau_max
    (TorqueLimit.from_robot), for the free-shape NLPs, which take the robot's limits; ``robot`` itself for r = 0."""
    import dataclasses

    from ..planning.limits.base import LimitChoice
    from ..planning.limits.torque import TorqueLimit

    if not torque_reserve:
        return robot
    limit = TorqueLimit.from_robot(robot, TorqueLimit.check_choice(LimitChoice(value=torque_reserve)))
    return robot.with_limits(dataclasses.replace(robot.limits, torque=np.asarray(limit.enforced(), float)))


def _duration(robot, task, original=None, torque: bool = False, **kw) -> float:
    from ..lift.constraint import lift
    from ..planning import plan

    settings = _settings(torque, baselines=False, **kw)
    return float(plan(lift(robot, task, original=original), robot, settings).profile.duration)


def parabolic_zone(task, tolerance: float):
    """``task`` (two lines) with an ABB-style parabolic zone at its corner: a quadratic Bezier from the
    point z before the corner over the corner to the point z after it (degree-elevated to the
    quintic BezierSegment), z = 4 tolerance / sin(angle) capped at half the shorter segment."""
    from ..geometry.blends import _corner, _replace
    from ..geometry.segments import BezierSegment

    c = _corner(task, 0, ("corner",), "parabolic_zone")
    z = min(4.0 * tolerance / max(np.sin(c.conn.angle), 1e-12), 0.5 * min(c.A.length, c.B.length))
    q0 = c.A.evaluate(c.A.length - z)[0][0]
    q1 = c.A.end_frame[0]
    q2 = c.B.evaluate(z)[0][0]
    # degree elevation 2 -> 5: b_i = sum_j C(2, j) C(3, i - j) / C(5, i) Q_j
    from math import comb

    Q = (q0, q1, q2)
    b = np.array([sum(comb(2, j) * comb(3, i - j) * Q[j] for j in range(3) if 0 <= i - j <= 3) / comb(5, i)
                  for i in range(6)])
    return _replace(task, c, z, z, BezierSegment(b))


def industrial_zone_duration(robot, task, tolerance: float, torque: bool = False, torque_reserve: float = 0.0) -> float:
    """Constant-TCP-speed duration [s] on ``task`` with the parabolic zone (see parabolic_zone), within the torque
    limits too when ``torque`` (less the feedback reserve ``torque_reserve``)."""
    from ..lift.constraint import lift
    from ..planning import plan

    zoned = parabolic_zone(task, tolerance)
    result = plan(lift(robot, zoned, original=task), robot,
                  _settings(torque, baselines=True, torque_reserve=torque_reserve))
    return float(result.baselines.constant_speed.profile.duration)


def _dynamics(robot) -> dict:
    """What the torque limits depend on besides the robot's name: the limits [N m], the payload (mass [kg], centre
    of mass [m], inertia [kg m^2]), the drives' armature [kg m^2] and gravity [m/s^2]."""
    p, armature = robot.payload, robot.limits.armature
    return {"torque": list(map(float, robot.limits.torque)), "payload": [float(p.mass), list(map(float, p.com)),
            np.round(np.asarray(p.inertia, float), 12).tolist()], "gravity": list(map(float, robot.gravity)),
            "armature": None if armature is None else list(map(float, armature))}


def _kinematic_fields(robot) -> dict:
    """A digest of the URDF, the flange frame, the tool, the locked joints and the joint ranges of ``robot``."""
    lim, tool = robot.limits, robot.tool
    return {"urdf": hashlib.sha256(robot.urdf_text.encode()).hexdigest()[:20], "flange": robot.flange_frame,
            "tool": [np.round(np.asarray(tool.translation, float), 12).tolist(),
                     np.round(np.asarray(tool.rotation, float), 12).tolist()],
            "locked": [[k, float(v)] for k, v in robot.locked_joints],
            "range": [np.asarray(lim.lower, float).tolist(), np.asarray(lim.upper, float).tolist()]}


@functools.lru_cache(maxsize=None)
def _shipped_fields(name: str) -> str:
    """_kinematic_fields of the built-in robot ``name`` as shipped, as JSON (loaded once per process)."""
    from ..robot import load_robot

    return json.dumps(_kinematic_fields(load_robot(name)), sort_keys=True)


def _kinematics(robot) -> dict | None:
    """What a motion depends on besides the joint velocity and acceleration limits and the robot's name
    (_kinematic_fields); None for a built-in robot as shipped (its optima's keys are as before other robots could be
    given)."""
    from ..robot.model import BUILTIN_ROBOTS

    fields = _kinematic_fields(robot)
    key = robot.name.lower()
    shipped = key in BUILTIN_ROBOTS and json.dumps(fields, sort_keys=True) == _shipped_fields(key)
    return None if shipped else fields


def _optimum_key(robot, points, delta, spans, meshes, crowd=None, start=None, torque: bool = False,
                 torque_reserve: float = 0.0) -> str:
    """Cache key of a free-shape optimum: its inputs, the corner spans and the whole tube's crowd spans as the
    NLP lays its phases out (free_shape.effective_spans, so a solve whose spans gained absorbed stretches is not
    read back from a cache written before), ``start`` only for a retry from another start (CORNER_STARTS,
    WHOLE_STARTS), so that first attempts keep their keys, with ``torque`` the dynamics it depends on
    (_dynamics; without, the key is as before torque was an option) and a reserve above 0, and the robot's
    kinematics when it is not a built-in one as shipped (_kinematics). Keys written before the reserve and other
    robots were options stay: the built-in robot without torque, or with torque and no reserve."""
    from .free_shape import Polyline, effective_spans

    lengths = Polyline(points).lengths
    if spans is not None:
        spans = effective_spans(lengths, delta, spans)
    if crowd is not None:
        crowd = effective_spans(lengths, delta, crowd)
    fields = {"v": OPTIMUM_VERSION if spans is None else CORNER_OPTIMUM_VERSION, "robot": robot.name,
              "crowd": None if crowd is None else np.round(crowd, 12).tolist(),
              "velocity": list(map(float, robot.limits.velocity)),
              "acceleration": list(map(float, robot.limits.acceleration)),
              "points": np.round(points, 12).tolist(), "delta": float(delta),
              "spans": None if spans is None else np.round(spans, 12).tolist(), "meshes": list(meshes)}
    if start is not None:
        fields["start"] = start
    if torque:
        fields["dynamics"] = _dynamics(robot)
        if torque_reserve:
            fields["torque_reserve"] = float(torque_reserve)
    if (kinematics := _kinematics(robot)) is not None:
        fields["kinematics"] = kinematics
    return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:20]


def cached_optimum(cache: Path, robot, points, delta: float, spans=None, meshes=None, warm=None, crowd=None,
                   keep: list | None = None, start: str | None = None, torque: bool = False,
                   torque_reserve: float = 0.0) -> dict:
    """The free-shape optimum's record {duration, convergence_error, success, status, durations,
    statuses, iterations, verification}, read from ``cache`` or solved and written there. ``warm``:
    the start (see free_shape_optimum), or a function returning it, called only to solve; a
    FreeShapeOptimum start crowds the whole tube's nodes at its spans, given as ``crowd`` (they
    change the mesh, so they are in the key; the start itself is not, except as ``start``, the name
    of a retry's start, see best_reference). ``keep``: a list the solved FreeShapeOptimum is
    appended to. ``torque``: with the robot's joint torque limits (in the key and the record), less the feedback
    reserve ``torque_reserve`` (solved on ``reserved(robot, torque_reserve)``; a reserve above 0 is in the key and the
    record, and the verification's max_torque_ratio is against the reduced limits)."""
    from . import free_shape as fs

    meshes = tuple(meshes or defaults.ATLAS_MESHES)
    f = Path(cache) / f"{_optimum_key(robot, points, delta, spans, meshes, crowd, start, torque, torque_reserve)}.json"
    if f.is_file():
        return json.loads(f.read_text())
    t0 = time.process_time()
    opt = fs.free_shape_optimum(reserved(robot, torque_reserve), points, delta, spans, meshes,
                                warm=warm() if callable(warm) else warm, torque=torque)
    if keep is not None:
        keep.append(opt)
    rec = {"duration": opt.duration, "convergence_error": opt.convergence_error, "success": opt.success,
           "status": opt.status, "durations": list(opt.durations), "statuses": [s.status for s in opt.solutions],
           "iterations": [s.iterations for s in opt.solutions], "delta": delta,
           "spans": None if spans is None else [list(map(float, s)) for s in spans], "meshes": list(meshes),
           "verification": opt.solutions[-1].verification, "cpu_s": time.process_time() - t0, "torque": torque}
    if start is not None:
        rec["start"] = start
    if torque and torque_reserve:
        rec["torque_reserve"] = torque_reserve
    write_json(f, rec)
    return rec


def reference_value(rec: dict) -> tuple[float | None, float | None, str | None]:
    """(duration [s], convergence error [s], note) of a cached optimum record: the extrapolation when
    every mesh converged (note None); when all but the coarsest did, the extrapolation over the finer
    ones (two: the finest, its change from the other as the error); when all but the finest did and at
    least three coarser ones remain (a fitted order), the extrapolation over those; each with a note
    saying so; else (None, None, "NLP not converged (statuses)")."""
    from .free_shape import extrapolate

    statuses = rec.get("statuses", [rec["status"]])
    if rec["success"]:
        return rec["duration"], rec["convergence_error"], None
    converged = [s in CONVERGED_STATUSES for s in statuses]
    if len(statuses) >= 3 and all(converged[1:]):
        value, error = extrapolate(rec["durations"][1:])
        return value, error, (f"coarsest mesh not converged ({statuses[0]}); value of the {len(statuses) - 1} finer "
                              "meshes")
    if len(statuses) >= 4 and all(converged[:-1]):
        value, error = extrapolate(rec["durations"][:-1])
        return value, error, (f"finest mesh not converged ({statuses[-1]}); value of the {len(statuses) - 1} "
                              "coarser meshes")
    return None, None, f"NLP not converged ({', '.join(statuses)})"


def closed_loop_check(robot, path, profile, tolerance: float) -> dict:
    """The planned motion simulated (orbital controller, SAMPLE_TIME): ``closed_loop_ok`` when it
    tracked (no failure), the TCP stayed within CLOSED_LOOP_PATH_ACCURACY of the planned path and
    the cornering deviation from the sharp path is within ``tolerance`` plus that tracking error;
    with ``closed_loop_path_accuracy_m`` and ``closed_loop_cornering_deviation_m`` [m]."""
    from .. import defaults
    from ..simulation import SimulationSettings, simulate

    sim = simulate(robot, path, profile, "orbital", SimulationSettings(sample_time=defaults.SAMPLE_TIME))
    acc = sim.path_accuracy()
    corner = None if sim.cornering_deviation is None else float(np.max(sim.cornering_deviation))
    ok = (sim.tracking_ok and acc <= CLOSED_LOOP_PATH_ACCURACY and corner is not None
          and corner <= tolerance + acc)
    return {"closed_loop_ok": bool(ok), "closed_loop_path_accuracy_m": acc,
            "closed_loop_cornering_deviation_m": corner, "closed_loop_cycle_s": sim.cycle_time}


#: A reference may exceed a motion feasible in its tube (the stop, the optimal blend: planner durations, good to
#: ~0.05 %) by its own convergence error plus this fraction of that motion's duration [-] (0.2 %).
FEASIBLE_MARGIN = 0.002


def _finite(error: float | None) -> float:
    """A convergence error [s], 0 when there is none (one mesh: NaN)."""
    return error if error is not None and np.isfinite(error) else 0.0


def local_optimum_note(value: float, error: float | None, feasible: float) -> str | None:
    """A note when a converged reference ``value`` [s] lies above ``feasible`` [s], the shorter of the stop and the
    optimal blend (both lie in either tube, so the minimum time is at most it), by more than its convergence ``error``
    [s] and FEASIBLE_MARGIN: IPOPT converged to a local optimum, which is no reference; else None."""
    if value - feasible <= _finite(error) + FEASIBLE_MARGIN * feasible:
        return None
    return (f"local optimum {value:.4f} s, above the feasible {feasible:.4f} s (stop or optimal blend) by more than "
            "its convergence error: not a reference")


#: Starts of the corner-confined NLP (both lie in its tube): the optimal blend's own plan and the stop at the corner.
#: The first is the blend for a single quintic (its spans are a few mm, where the stop's start hit the cap), the stop
#: for a racing line (its spans reach most of the segments: from the blend, 90 deg 10 mm took 800 + 1007 iterations
#: on 25 intervals, from the stop 711 / 68 / 151 on 25 / 50 / 100, 13 s CPU). When a start's result is no reference
#: (not converged, or above a motion feasible in the tube: a local optimum), the other is tried and the lowest
#: reference kept.
CORNER_STARTS = ("blend", "stop")
#: Starts of the whole-tube NLP, in order: the corner-confined optimum's solutions mesh by mesh (its tube is inside the
#: whole one, so each is feasible; the whole tube's nodes then crowd at its spans), then, when that gives no reference,
#: the same with their multipliers (free_shape.WithMultipliers: a primal-dual warm start; the only start that converged
#: at 30 deg / 0.1 mm), the stop and the optimal blend's plan (one phase per segment), the lowest reference kept as for
#: CORNER_STARTS.
WHOLE_STARTS = ("corner", "corner_multipliers", "stop", "blend")


class Start(NamedTuple):
    """A start of a free-shape NLP: ``name`` (its cache key's ``start`` on a retry), ``warm`` (see cached_optimum),
    ``crowd`` (the whole tube's crowd spans of a FreeShapeOptimum start)."""

    name: str
    warm: object = None
    crowd: list | None = None


def _reference(rec: dict, feasible: float, inner: tuple | None = None) -> tuple[float | None, float | None, str | None]:
    """reference_value of ``rec``, None with a note when it lies above ``feasible`` [s] (local_optimum_note) or above
    ``inner`` = (value, error) [s], the reference of a tube inside its own (the corner-confined one for the whole
    tube), by more than both convergence errors."""
    value, error, note = reference_value(rec)
    if note is None and (local := local_optimum_note(value, error, feasible)):
        return None, None, local
    below, below_error = inner if inner is not None else (None, None)
    if note is None and below is not None and value - below > _finite(error) + _finite(below_error):
        return None, None, (f"local optimum {value:.4f} s, above the {below:.4f} s of the tube inside its own by "
                            "more than their convergence errors: not a reference")
    return value, error, note


@dataclass(frozen=True, eq=False)
class Reference:
    """A free-shape reference: value, error [s] (None: no reference) and note (None: converged) as reference_value;
    ``start``: the name of the start it came from (CORNER_STARTS, WHOLE_STARTS); ``solutions()``: its
    FreeShapeOptimum (solved again, once, when it came from the cache; the corner-confined one starts the whole tube
    and the feasible bound);
    ``durations``: its record's duration per mesh [s]."""

    value: float | None
    error: float | None
    note: str | None
    start: str
    solutions: object
    durations: tuple = ()


def best_reference(cache: Path, robot, points, tolerance: float, spans, meshes, starts, feasible: float,
                   inner: tuple | None = None, torque: bool = False, torque_reserve: float = 0.0) -> Reference:
    """The free-shape optimum (``spans``: corner-confined, None: whole tube) from the ``starts`` (Start), tried in
    order until one is a converged reference below ``feasible`` [s] (the shorter of the stop and the blend, which lie
    in either tube) and not above ``inner`` (see _reference): the lowest reference of those tried, else the first
    start's failure with every start's note. The first start's record keeps its cache key (no start in it), so a
    cached success is read as before; a retry is cached under its start's name."""
    from .free_shape import free_shape_optimum

    tried = []
    for i, start in enumerate(starts):
        keep: list = []
        rec = cached_optimum(cache, robot, points, tolerance, spans, meshes, warm=start.warm, crowd=start.crowd,
                             keep=keep, start=None if i == 0 else start.name, torque=torque,
                             torque_reserve=torque_reserve)
        tried.append((start, _reference(rec, feasible, inner), keep, tuple(rec["durations"])))
        if tried[-1][1][2] is None:
            break
        log.info("corner atlas: %s optimum from the %s: %s", "whole-tube" if spans is None else "corner-confined",
                 start.name, tried[-1][1][2])
    usable = [t for t in tried if t[1][0] is not None]
    start, (value, error, note), keep, durations = min(usable, key=lambda t: t[1][0]) if usable else tried[0]
    if not usable and len(tried) > 1:
        note = "; ".join(f"from the {s.name}: {r[2]}" for s, r, *_ in tried)

    def solutions():  # solved again only once when it came from the cache (the whole tube's starts and the bound)
        if not keep:
            warm = start.warm() if callable(start.warm) else start.warm
            keep.append(free_shape_optimum(reserved(robot, torque_reserve), points, tolerance, spans,
                                           tuple(meshes or defaults.ATLAS_MESHES), warm=warm, torque=torque))
        return keep[0]

    return Reference(value, error, note, start.name, solutions, durations)


def corner_reference(cache: Path, robot, points, tolerance: float, spans, meshes, blend, racing: bool,
                     feasible: float, torque: bool = False, torque_reserve: float = 0.0) -> Reference:
    """The corner-confined optimum within ``spans`` (best_reference) from the CORNER_STARTS (``blend``: the optimal
    blend's PlanResult; the blend first unless ``racing``)."""
    warms = {"blend": blend, "stop": None}
    order = CORNER_STARTS[::-1] if racing else CORNER_STARTS
    return best_reference(cache, robot, points, tolerance, spans, meshes, [Start(n, warms[n]) for n in order],
                          feasible, torque=torque, torque_reserve=torque_reserve)


def whole_reference(cache: Path, robot, points, tolerance: float, meshes, corner: Reference, spans, blend,
                    feasible: float, torque: bool = False, torque_reserve: float = 0.0) -> Reference:
    """The whole-tube optimum (best_reference) from the WHOLE_STARTS: the ``corner``-confined Reference's solutions
    (crowded at its ``spans``), without and with their multipliers, the stop, the optimal ``blend``'s PlanResult; not
    above the corner-confined reference by more than both errors (its tube is inside the whole one)."""
    from .free_shape import WithMultipliers

    starts = {"corner": Start("corner", corner.solutions, spans), "stop": Start("stop"), "blend": Start("blend", blend),
              "corner_multipliers": Start("corner_multipliers", lambda: WithMultipliers(corner.solutions()), spans)}
    return best_reference(cache, robot, points, tolerance, None, meshes, [starts[n] for n in WHOLE_STARTS], feasible,
                          (corner.value, corner.error), torque, torque_reserve)


def corner_bound(cache: Path, robot, points, tolerance: float, spans, meshes, corner: Reference, torque: bool = False,
                 torque_reserve: float = 0.0) -> dict:
    """The feasible bound of the corner-confined tube (free_shape.feasible_bound, from the ``corner`` Reference's
    solutions): {duration [s], radius [m] of the tube it was solved in, solves, held_excess_m, verification (its
    dense check), cpu_s, torque, reference_start, torque_reserve (above 0)}, or {duration: None, error, ...} when no
    solve held the tube; read from ``cache`` or computed and written there (keyed as the corner-confined optimum,
    with BOUND_VERSION and the reference's start). Its duration is an upper bound of the true
    minimum time in the tube, so ``optimal_s`` over it, less 1, is a lower bound of the blend's true gap."""
    from . import free_shape as fs

    meshes = tuple(meshes or defaults.ATLAS_MESHES)
    key = _optimum_key(robot, points, tolerance, spans, meshes, start=f"bound-{BOUND_VERSION}-{corner.start}",
                       torque=torque, torque_reserve=torque_reserve)
    f = Path(cache) / f"{key}.json"
    if f.is_file():
        return json.loads(f.read_text())
    t0 = time.process_time()
    try:
        bound = fs.feasible_bound(reserved(robot, torque_reserve), points, tolerance, spans, meshes, torque=torque,
                                  optimum=corner.solutions())
        rec = {"duration": bound.duration, "radius": bound.radius, "solves": bound.solves,
               "held_excess_m": bound.check.get("held_excess_m"), "verification": bound.check}
    except PathmotionError as exc:
        rec = {"duration": None, "error": str(exc)}
    rec.update(cpu_s=time.process_time() - t0, torque=torque, reference_start=corner.start)
    if torque and torque_reserve:
        rec["torque_reserve"] = torque_reserve
    write_json(f, rec)
    return rec


def optimal_motion(robot, task, tolerance: float, torque: bool = False, torque_reserve: float = 0.0):
    """A row's optimal blend and its motion, as the atlas plans them: (OptimalBlend, the blended path lifted to
    joint space, its time-optimal PlanResult, verified), under the atlas' settings (``torque``, ``torque_reserve``)."""
    from ..lift.constraint import lift
    from ..planning import plan
    from ..planning.blend_search import optimal_blends

    kw = {"torque_reserve": torque_reserve}
    best = optimal_blends(robot, task, tolerance, settings=_settings(torque, verify=False, baselines=False, **kw))
    blended = lift(robot, best.path, original=task)
    return best, blended, plan(blended, robot, _settings(torque, baselines=False, **kw))


def atlas_row(robot, angle_deg: float, tolerance: float, cache: Path, meshes=None, row: dict | None = None,
              closed_loop: bool = True, torque: bool = False, torque_reserve: float | None = None,
              references: bool = True, bounds: bool = True) -> dict:
    """One row of corners.csv (ATLAS_COLUMNS except ``error``), filled into ``row`` as it goes (so a
    row that fails part way keeps what it had); ``torque``: every motion and both references within the
    robot's joint torque limits too, less the feedback reserve ``torque_reserve`` (check_torque_reserve; the
    closed-loop check's plant keeps the whole limits). ``references`` False: neither free-shape reference is
    looked up or solved (their columns None, ``status`` says so): the row's own work, as with every optimum
    cached (benchmarks/atlas_rows.py times it). ``bounds`` (with ``references``): the corner-confined tube's feasible
    bound too (corner_bound; ``corner_bound_s``, ``gap_to_corner_bound``)."""
    from ..geometry import with_g2_blend, with_transition
    from .corner import transition_radius_for_deviation

    pts = corner_points(angle_deg)
    task = _task(pts)
    row = {} if row is None else row
    row.update(angle_deg=float(angle_deg), tolerance_m=float(tolerance), torque=bool(torque))
    reserve = check_torque_reserve(torque_reserve, torque)
    row["torque_reserve"] = reserve if torque else None
    kw = {"torque_reserve": reserve}
    row["stop_s"] = _duration(robot, task, torque=torque, connections="zero", **kw)
    row["industrial_zone_s"] = industrial_zone_duration(robot, task, tolerance, torque, reserve)
    # the G2 blend's error names the largest tolerance that fits
    row["g2_s"] = _duration(robot, with_g2_blend(task, 0, tolerance), task, torque, **kw)
    radius = transition_radius_for_deviation(task, 0, tolerance)
    row["circle_s"] = _duration(robot, with_transition(task, 0, radius), task, torque, **kw)
    best, blended, warm = optimal_motion(robot, task, tolerance, torque, reserve)
    row["optimal_s"] = float(warm.profile.duration)
    row["quintic_s"] = best.quintic_duration
    shape = best.shapes[0]
    row["optimal_entry_m"], row["optimal_exit_m"] = shape.entry, shape.exit
    row["optimal_offset_entry_m"], row["optimal_offset_exit_m"] = shape.offset_entry, shape.offset_exit
    row["optimal_rise_entry_m"], row["optimal_rise_exit_m"] = shape.rise_entry[0], shape.rise_exit[0]
    row["gain_vs_stop"] = 1.0 - row["optimal_s"] / row["stop_s"]
    row["gain_vs_zone"] = 1.0 - row["optimal_s"] / row["industrial_zone_s"]
    row["gain_vs_g2"] = 1.0 - row["optimal_s"] / row["g2_s"]
    status = []
    feasible = min(row["stop_s"], row["optimal_s"])
    spans = [(shape.entry, shape.exit)]
    # the whole tube from the corner-confined solutions first, mesh by mesh (from the stop it found worse local optima,
    # e.g. 30 deg 0.1 mm 25 intervals 0.9014 s against the corner-confined 0.8717 s, and its extrapolation sat above
    # the corner-confined one at 10 mm), then from the other WHOLE_STARTS
    if references:
        corner = corner_reference(cache, robot, pts, tolerance, spans, meshes, warm, shape.racing, feasible, torque,
                                  reserve)
        whole = whole_reference(cache, robot, pts, tolerance, meshes, corner, spans, warm, feasible, torque, reserve)
    else:
        corner = whole = Reference(None, None, "not solved (references off)", "", None)
    for name, ref in (("free_shape_optimum", whole), ("corner_optimum", corner)):
        row[f"{name}_s"], row[name.replace("_optimum", "") + "_error_s"] = ref.value, ref.error
        if ref.note:
            status.append(f"{name}: {ref.note}")
    row["corner_bound_s"] = row["gap_to_corner_bound"] = None
    if references and bounds and corner.value is not None:
        bound = corner_bound(cache, robot, pts, tolerance, spans, meshes, corner, torque, reserve)
        if bound["duration"] is None:
            status.append(f"corner_bound: {bound['error']}")
        else:
            row["corner_bound_s"] = bound["duration"]
            row["gap_to_corner_bound"] = row["optimal_s"] / bound["duration"] - 1.0
    fso, co = row["free_shape_optimum_s"], row["corner_optimum_s"]
    row["gap_to_optimum"] = None if fso is None else row["optimal_s"] / fso - 1.0
    row["gap_to_corner_optimum"] = None if co is None else row["optimal_s"] / co - 1.0
    row["capture"] = None if fso is None else (row["stop_s"] - row["optimal_s"]) / (row["stop_s"] - fso)
    if closed_loop:  # the plant with the whole torque limits: the reserve is the controller's
        row.update(closed_loop_check(robot, blended, warm.profile, tolerance))
        if not row["closed_loop_ok"]:
            status.append("closed loop: out of tolerance")
    row["status"] = "; ".join(status) or "ok"
    return row


# ------------------------------------------------------------------------------------ the sweep
def atlas_point(text: str, base_dir: str, overrides, traces: bool = False) -> dict:
    """Sweep point function (see sweep.run_sweep): ``text`` is the atlas spec (TOML: robot, or robot_file with
    robot_digest, meshes, cache folder, torque, torque_reserve, closed_loop), ``overrides`` the pairs (angle_deg, a),
    (tolerance_m, t). A failure is the row's ``error``, never a stopped atlas."""
    t0 = time.perf_counter()
    spec = tomllib.loads(text)
    given = dict(overrides)
    summary = {k: None for k in ATLAS_COLUMNS}
    torque = bool(spec.get("torque", False))
    summary.update(angle_deg=given["angle_deg"], tolerance_m=given["tolerance_m"], torque=torque)
    try:
        robot = _spec_robot(spec, Path(base_dir))
        cache = Path(base_dir) / spec["cache"]
        atlas_row(robot, given["angle_deg"], given["tolerance_m"], cache, spec.get("meshes"),
                  row=summary, closed_loop=spec.get("closed_loop", True), torque=torque,
                  torque_reserve=spec.get("torque_reserve"), references=spec.get("references", True),
                  bounds=spec.get("bounds", True))
        error = None
    except PathmotionError as exc:
        error = f"{type(exc).__name__}: {exc}"
        summary["status"] = "error"
    return {"summary": summary, "error": error, "trace": None, "wall_time_s": time.perf_counter() - t0}


def _spec_robot(spec: dict, base_dir: Path):
    """The atlas spec's robot: the built-in ``robot``, or the ``robot_file`` (robot_file.load_robot_file; relative
    to the spec's folder ``base_dir``) when it still describes the robot the atlas started with (``robot_digest``)."""
    from ..robot import load_robot
    from .robot_file import load_robot_file, robot_digest

    if "robot_file" not in spec:
        return load_robot(spec["robot"])
    robot = load_robot_file(base_dir / spec["robot_file"])
    if robot_digest(robot) != spec["robot_digest"]:
        raise ScenarioError(f"robot file {spec['robot_file']} (or a file it names) changed since this atlas started; "
                            "run the changed robot into another --out folder, or restore the file")
    return robot


@dataclass(frozen=True, eq=False)
class CornerAtlas:
    """rows: one dict per (angle, tolerance) with ATLAS_COLUMNS; out: folder; figures: PNGs written."""

    rows: list[dict]
    out: Path
    figures: tuple[Path, ...]


def corner_atlas(out, angles: Sequence[float], tolerances: Sequence[float], *, robot: str = "irb140",
                 meshes: Sequence[int] | None = None, workers: int = 2, scheduler: str | None = None,
                 on_result=None, figures: bool = True, closed_loop: bool = True, torque: bool = False,
                 torque_reserve: float | None = None, robot_file: str | Path | None = None,
                 references: bool = True, bounds: bool = True) -> CornerAtlas:
    """Run the atlas into ``out`` (corners.csv / .parquet, tdelta.png, gain_vs_angle.png; the points
    and the optimum cache under ``out``); resumes. ``torque``: every motion and both references within the
    robot's joint torque limits too (the ``torque`` column), less the feedback reserve ``torque_reserve``
    (check_torque_reserve; the ``torque_reserve`` column). ``robot_file``: the arm a robot file describes
    (robot_file.load_robot_file) instead of the built-in ``robot``. ``references`` False: every row without the
    free-shape references (atlas_row; the work of a run with every optimum cached, benchmarks/atlas_rows.py);
    ``bounds`` False: without the feasible bounds (one to four more NLPs per row uncached).
    Bad angles, tolerances, meshes, reserve or robot file raise before any work."""
    from .robot_file import load_robot_file, robot_digest
    from .sweep import load_finished, run_sweep, write_tables

    angles, tolerances = [float(a) for a in angles], [float(t) for t in tolerances]
    meshes = list(check_inputs(angles, tolerances, meshes))
    reserve = check_torque_reserve(torque_reserve, torque)
    if robot_file is None:
        arm = f'robot = "{robot}"\n'
    else:
        digest = robot_digest(load_robot_file(robot_file))
    out = Path(out)
    mark_result(out)
    if robot_file is not None:  # relative to the spec's folder, so the folder can move with its robot file
        where = os.path.relpath(Path(robot_file).resolve(), out.resolve())
        arm = f'robot_file = {json.dumps(where)}\nrobot_digest = "{digest}"\n'
    spec = out / "atlas_spec.toml"
    write_text(spec, f'version = {ROW_VERSION}\n{arm}meshes = {meshes}\nclosed_loop = '
                     f'{str(closed_loop).lower()}\ntorque = {str(torque).lower()}\n'
                     + (f"torque_reserve = {reserve!r}\n" if torque else "")
                     + ("" if references else "references = false\n")
                     + ("" if bounds else "bounds = false\n")
                     + 'cache = "optimum_cache"\n')  # relative to the spec's folder
    points, _ = run_sweep(spec, {"angle_deg": angles, "tolerance_m": tolerances}, out / "points_sweep",
                          workers=workers, scheduler=scheduler, on_result=on_result, point_fn=atlas_point)
    finished = load_finished(out / "points_sweep")
    rows = []
    for p in points:
        rec = finished.get(p.key)
        if rec is not None:
            rows.append({**{k: rec["summary"].get(k) for k in ATLAS_COLUMNS}, "error": rec["error"]})
    write_tables(out, rows, list(ATLAS_COLUMNS), stem="corners")
    written: tuple[Path, ...] = ()
    if figures and rows:
        written = (tdelta_figure(rows, out / "tdelta.png"), gain_figure(rows, out / "gain_vs_angle.png"))
    return CornerAtlas(rows, out, written)


_CURVES = (("industrial_zone_s", "constant speed, parabolic zone", "x:"),
           ("circle_s", "transition circle", "o-"), ("g2_s", "G2 blend", "s-"), ("optimal_s", "optimal blend", "D-"),
           ("corner_optimum_s", "corner-confined optimum", "^-."), ("free_shape_optimum_s", "whole-tube optimum", "v-."))


def tdelta_figure(rows: list[dict], path: Path) -> Path:
    """T(delta): duration against tolerance, one panel per angle, every method; the stop, which does not depend on
    the tolerance, as a horizontal line across the panel. The legend sits right of the last panel."""
    from ..report.style import legend_outside
    from .figures import MM, _plt, _save

    plt = _plt()
    angles = sorted({r["angle_deg"] for r in rows})
    f, axes = plt.subplots(1, len(angles), figsize=(3.6 * len(angles), 3.8), squeeze=False)
    for ax, a in zip(axes[0], angles):
        mine = sorted((r for r in rows if r["angle_deg"] == a), key=lambda r: r["tolerance_m"])
        stops = [r["stop_s"] for r in mine if r.get("stop_s") is not None]
        if stops:
            ax.axhline(stops[0], color="k", ls="--", lw=1, label="stop at the corner")
        for key, label, style in _CURVES:
            pts = [(r["tolerance_m"] * MM, r[key]) for r in mine if r.get(key) is not None]
            if pts:
                ax.plot(*zip(*pts), style, label=label, ms=4)
        ax.set_xscale("log")
        ax.set_title(f"{a:g} deg turn")
        ax.set_xlabel("tolerance delta [mm]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("duration, rest to rest [s]")
    f.tight_layout()
    legend_outside(axes[0][-1], fontsize=7)
    return _save(f, path)


def gain_figure(rows: list[dict], path: Path) -> Path:
    """Gain over the stop against the turn angle: the optimal blend (solid) and the whole-tube
    optimum (dashed), one colour per tolerance."""
    from .figures import MM, _plt, _save

    plt = _plt()
    f, ax = plt.subplots(figsize=(7, 4.5))
    for i, tol in enumerate(sorted({r["tolerance_m"] for r in rows})):
        mine = sorted((r for r in rows if r["tolerance_m"] == tol and r.get("stop_s")), key=lambda r: r["angle_deg"])
        for key, style in (("optimal_s", "-"), ("free_shape_optimum_s", "--")):
            pts = [(r["angle_deg"], 100 * (1 - r[key] / r["stop_s"])) for r in mine if r.get(key) is not None]
            if pts:
                ax.plot(*zip(*pts), style, color=f"C{i}", marker="o", ms=3,
                        label=f"{tol * MM:g} mm" + (" optimal blend" if key == "optimal_s" else " whole-tube optimum"))
    ax.set_xlabel("turn angle [deg]")
    ax.set_ylabel("time saved against the stop [%]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    f.tight_layout()
    return _save(f, path)


def table_markdown(rows: list[dict]) -> str:
    """corners.csv as a Markdown table (durations in s, gains and gaps in %)."""
    def s(v):
        return "-" if v is None else f"{v:.4f}"

    def pct(v):
        return "-" if v is None else f"{100 * v:.1f} %"

    lines = ["| angle | tolerance | stop | zone (const. speed) | circle | G2 | optimal | corner opt. | whole-tube opt. "
             "| gain vs stop | gap to opt. | capture | status |", "|" + "---|" * 13]
    for r in rows:
        lines.append(f"| {r['angle_deg']:g} deg | {r['tolerance_m'] * 1000:g} mm | {s(r['stop_s'])} | "
                     f"{s(r['industrial_zone_s'])} | {s(r['circle_s'])} | {s(r['g2_s'])} | {s(r['optimal_s'])} | "
                     f"{s(r['corner_optimum_s'])} | {s(r['free_shape_optimum_s'])} | {pct(r['gain_vs_stop'])} | "
                     f"{pct(r['gap_to_optimum'])} | {pct(r['capture'])} | {r.get('status') or r.get('error')} |")
    return "\n".join(lines)


__all__ = ["ATLAS_COLUMNS", "CornerAtlas", "atlas_point", "atlas_row", "cached_optimum", "check_inputs",
           "corner_atlas", "corner_points", "industrial_zone_duration", "parabolic_zone", "reference_value",
           "table_markdown"]
