"""Two sub-optimal references planned on the same discretized problem as the optimum.

fitted (the thesis' method): a smooth curve fitted to the optimal theta_dot(theta) — per segment,
theta_dot = w(theta) exp(p(theta)) with p a Chebyshev polynomial (a Fourier series on a periodic
cycle) fitted by least squares to log(theta_dot / w), and w = sqrt(distance to an end where the
optimum starts or stops from rest), so the fit keeps the square-root shape there — scaled to lie
FITTED_PROFILE_MARGIN below the optimum, then reduced until every limit holds: exactly on the
planner's discretization (a closed-form largest scale), then by the plan's own verification (the certified
bound on every grid interval, or the dense resample with ``verify = "dense"`` or "off").

constant_speed: the highest constant TCP speed that can be held along the whole path, with ramps of
constant TCP acceleration at the ends where the motion starts or stops (what a commercial
controller does "at maximum velocity": a trapezoid in TCP speed over the TCP arc length). The
(speed, acceleration) pair of least duration that satisfies every limit on the planner's
discretization is searched; on a periodic cycle there are no ramps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from .. import defaults
from ..errors import InfeasibleError
from ..modes import Connections
from .profile import Profile
from .segments import Solution, join_segments
from .topp import IntervalProblem
from .trajectory import Trajectory
from .verify import LimitRatios, sample_ratios, summarize, worst_outside

_VERIFY_ROUNDS = 6
#: An end of a fitted piece is at rest when its theta_dot is below this fraction of the piece's largest [-].
REST_FRACTION = 1e-12
#: Floor of theta_dot / w in the log fit, relative to the largest theta_dot (keeps the log finite) [-].
LOG_FLOOR = 1e-9
#: Relative margin below the largest feasible scale, so that round-off keeps a profile feasible [-].
FEASIBLE_MARGIN = 1e-9
#: The TCP is taken as not moving where |J_v Phi'| is below this fraction of its largest value [-].
STILL_GAIN_FRACTION = 1e-12
#: Constant-speed baseline: TCP accelerations searched [m/s^2] (log grid: lowest, highest, points),
#: and the points of the refinement around the best.
RAMP_ACCELERATIONS = (1e-2, 1e4, 19)
RAMP_REFINE_POINTS = 15
#: A baseline is verified on at most this many samples (a program's motion of minutes at 0.1 ms would need
#: millions; the baselines are references, the optimal plan is verified interval by interval) [-].
BASELINE_SAMPLES = 400_000


@dataclass(frozen=True, eq=False)
class Baseline:
    """A reference profile with its verification ratios; ``description`` says what it is."""

    name: str
    profile: Profile
    ratios: LimitRatios
    description: str

    @property
    def duration(self) -> float:
        return self.profile.duration


@dataclass(frozen=True, eq=False)
class Baselines:
    """The two baselines; ``constant_speed`` is None when no constant TCP speed meets the plan's
    boundary conditions and limits (``constant_speed_error`` then says why): the optimal plan stands
    without it."""

    fitted: Baseline
    constant_speed: Baseline | None
    constant_speed_error: str | None = None


def max_feasible_scale(problem: IntervalProblem, x: np.ndarray) -> float:
    """Largest s with s * x feasible on the discretized problem (x (K,) >= 0): each row
    P x_i + Q x_{i+1} <= R scales linearly in s, and so does 0 <= x <= x_max (inf: no row bounds the scale)."""
    return float(_max_scale(problem.P, problem.Q, problem.R, problem.x_max, np.asarray(x, float)))


@njit(cache=True, error_model="numpy")
def _interval_scale(P, Q, R, i, xa, xb):
    """The least R / den over the rows of interval i (P, Q, R (K-1, M)) with den = P xa + Q xb > 0 [-]: the scale of
    (xa, xb) at which the first row binds; inf if none, nan if a ratio is nan (numpy's min: it stops there)."""
    best = np.inf
    for r in range(P.shape[1]):
        den = P[i, r] * xa + Q[i, r] * xb
        if den > 0.0:
            v = R[i, r] / den
            if v < best or v != v:
                best = v
                if v != v:
                    break
    return best


@njit(cache=True, error_model="numpy")
def _max_scale(P, Q, R, x_max, x):
    """min over the intervals of :func:`_interval_scale` at x, and over the points with x > 0 of x_max / x; one
    pass, no (K, M) temporaries."""
    best = np.inf
    for i in range(P.shape[0]):
        v = _interval_scale(P, Q, R, i, x[i], x[i + 1])
        if v < best or v != v:
            best = v
    for i in range(x.shape[0]):
        if x[i] > 0.0:
            v = x_max[i] / x[i]
            if v < best or v != v:
                best = v
    return best


@dataclass(frozen=True, eq=False)
class _TrapezoidRows:
    """The limit rows of one piece arranged for the constant-speed search (:func:`_trapezoid` profiles with cruise
    speed v and ramp acceleration a): where the ramp speed is at least v (cruise) x = v^2 / gain^2, so a row joining
    two cruise points holds while v^2 <= R / (P / gain_i^2 + Q / gain_(i+1)^2), its ``cruise`` bound (K-1,),
    the least over the interval's rows; a point on a ramp, at rest or not moving has x independent of v
    (:meth:`ramps`, once per a). A test costs O(K), not O(K M)."""

    problem: IntervalProblem
    gain: np.ndarray
    rests: tuple[bool, bool]
    cruise: np.ndarray
    cap: np.ndarray
    moving: np.ndarray

    @classmethod
    def of(cls, problem: IntervalProblem, gain: np.ndarray, rests: tuple[bool, bool]) -> "_TrapezoidRows":
        moving = gain > STILL_GAIN_FRACTION * gain.max()
        inv = np.where(moving, 1.0 / np.where(moving, gain, 1.0) ** 2, np.nan)
        return cls(problem, gain, rests, _cruise_bounds(problem.P, problem.Q, problem.R, inv),
                   problem.x_max / np.where(moving, inv, np.nan), moving)

    def ramps(self, a: float, v_top: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For ramp acceleration a: the x (K,) of every point as if v were unbounded (finite where x does not depend on
        v: ramps, rest, still TCP; inf where it cruises), whether each row (K-1,) between two such points holds, and
        whether each such point (K,) keeps x <= x_max; for cruise speeds up to ``v_top`` (a point whose ramp is
        faster cruises at every such speed)."""
        sub = self.problem
        x = _trapezoid(sub.grid, self.gain, sub.x_max, np.inf, a, *self.rests)
        with np.errstate(divide="ignore"):
            fixed = (x < v_top ** 2 / self.gain ** 2) | ~self.moving
        ok = _fixed_rows_hold(sub.P, sub.Q, sub.R, np.where(fixed, x, 0.0), fixed)
        with np.errstate(divide="ignore", invalid="ignore"):
            caps = ~fixed | (x <= 0) | (sub.x_max / np.where(x > 0, x, 1.0) >= 1.0)
        return x, ok, caps

    def holds(self, v: float, ramp: tuple[np.ndarray, np.ndarray, bool]) -> bool:
        """Whether the trapezoid of cruise speed v (and the a of ``ramp`` = :meth:`ramps`) meets every row and x_max
        (as ``max_feasible_scale >= 1`` does, the cruise rows up to round-off): :func:`_holds`, one pass."""
        x_inf, ok, caps = ramp
        sub = self.problem
        return bool(_holds(float(v) ** 2, x_inf, self.moving, self.gain, caps, ok, self.cruise, self.cap, sub.P, sub.Q,
                           sub.R))


@njit(cache=True, error_model="numpy")
def _cruise_bounds(P, Q, R, inv):
    """(K-1,): per interval :func:`_interval_scale` at ``inv`` (K,) = 1 / gain^2 (nan where still; a nan den binds
    no row). One pass instead of (K-1, M) temporaries (some 50 MB each on a program's grid)."""
    out = np.empty(P.shape[0])
    for i in range(P.shape[0]):
        out[i] = _interval_scale(P, Q, R, i, inv[i], inv[i + 1])
    return out


@njit(cache=True, error_model="numpy")
def _holds(v2, x_inf, moving, gain, caps, ok, cruise, cap, P, Q, R):
    """_TrapezoidRows.holds for v^2 = ``v2``: a point is fixed (on a ramp, at rest, or the TCP still: x = x_inf, not
    v's) where x_inf < v^2 / gain^2 or it does not move, else it cruises (x = v^2 / gain^2); a fixed point keeps its
    ``caps``, a cruising one x <= ``cap``; a row between two fixed points holds where ``ok``, between two cruising
    ones while v^2 <= ``cruise``, and between one of each where R / (P x_i + Q x_i+1) >= 1 (den > 0). Stops at the
    first violation."""
    k = x_inf.shape[0]
    fixed = np.empty(k, np.bool_)
    x = np.empty(k)
    for i in range(k):
        cruise_x = v2 / (gain[i] * gain[i])
        fixed[i] = x_inf[i] < cruise_x or not moving[i]
        if fixed[i]:
            if not caps[i]:
                return False
            x[i] = x_inf[i]
        else:
            if cap[i] < v2:
                return False
            x[i] = cruise_x
    for i in range(k - 1):
        if fixed[i] and fixed[i + 1]:
            if not ok[i]:
                return False
        elif not fixed[i] and not fixed[i + 1]:
            if not v2 <= cruise[i]:
                return False
        elif not _interval_scale(P, Q, R, i, x[i], x[i + 1]) >= 1.0:
            return False
    return True


@njit(cache=True, error_model="numpy")
def _fixed_rows_hold(P, Q, R, x, fixed):
    """(K - 1,) whether every row of each interval between two ``fixed`` points holds at x (K,): R / den >= 1
    where den = P x_i + Q x_i+1 > 0; True on the other intervals."""
    ok = np.ones(P.shape[0], np.bool_)
    for i in range(P.shape[0]):
        if fixed[i] and fixed[i + 1]:
            ok[i] = _interval_scale(P, Q, R, i, x[i], x[i + 1]) >= 1.0
    return ok


def _cuts(chain_args: dict, size: int) -> list[int]:
    split = set(chain_args["stops"])
    if chain_args["connections"] != Connections.CHAIN:
        split |= set(chain_args["breaks"])
    return sorted(split | {0, size - 1})


def _piece_values(sol: Solution, chain_args: dict, cuts: list[int]) -> list[np.ndarray]:
    if chain_args["connections"] == Connections.MAX:
        return [p.x for p in sol.segment_profiles]
    return [sol.x[i0:i1 + 1] for i0, i1 in zip(cuts[:-1], cuts[1:])]


def _fit_piece(theta: np.ndarray, x: np.ndarray, periodic: bool, degree: int) -> np.ndarray:
    v = np.sqrt(np.maximum(x, 0.0))
    t = (theta - theta[0]) / (theta[-1] - theta[0])
    w = np.ones_like(t)
    tiny = REST_FRACTION * max(v.max(), np.finfo(float).tiny)
    if v[0] <= tiny:
        w *= np.sqrt(t)
    if v[-1] <= tiny:
        w *= np.sqrt(1.0 - t)
    ok = w > 0
    y = np.log(np.maximum(v[ok] / w[ok], LOG_FLOOR * v.max()))
    if periodic:
        cols = [np.ones_like(t)]
        for h in range(1, max(degree // 2, 1) + 1):
            cols += [np.cos(2 * np.pi * h * t), np.sin(2 * np.pi * h * t)]
        basis = np.stack(cols, axis=1)
    else:
        basis = np.polynomial.chebyshev.chebvander(2.0 * t - 1.0, degree)
    coef, *_ = np.linalg.lstsq(basis[ok], y, rcond=None)
    fit = w * np.exp(basis @ coef)
    return fit**2


def dense_check(path, robot, limits, settings) -> Callable:
    """The baselines' verification on the dense resample: ``check(profile, jumps)`` -> (worst ratio outside the jump
    intervals, LimitRatios), sampled every verify_sample_time, or at most BASELINE_SAMPLES samples on a long motion."""
    def check(prof: Profile, jumps) -> tuple[float, LimitRatios]:
        traj = Trajectory(path, prof, robot)
        dt = max(settings.verify_sample_time, prof.duration / BASELINE_SAMPLES)
        samples, r = sample_ratios(traj, limits, dt, jumps)
        return worst_outside(samples, r, jumps), summarize(samples, r, limits, dt, (), robot.joint_names)
    return check


def _verified(name, description, problem, cuts, pieces, check: Callable, settings) -> Baseline:
    """Join, verify with ``check`` (see :func:`compute_baselines`), and scale x down until the ratios pass (bounded)."""
    for _ in range(_VERIFY_ROUNDS):
        prof, jumps = join_segments(problem.grid, cuts, pieces)
        worst, ratios = check(prof, jumps)
        if worst <= 1.0 + settings.limit_tolerance:
            return Baseline(name, prof, ratios, description)
        pieces = [p / worst for p in pieces]
    raise InfeasibleError(f"{name} baseline: limits still exceeded after {_VERIFY_ROUNDS} reductions "
                          f"({ratios.worst}); switch baselines off or raise grid_points")


def fitted_baseline(problem, sol, chain_args, check, settings, periodic_cycle) -> Baseline:
    cuts = _cuts(chain_args, problem.size)
    pieces = []
    for (i0, i1), x in zip(zip(cuts[:-1], cuts[1:]), _piece_values(sol, chain_args, cuts)):
        fit = _fit_piece(problem.grid[i0:i1 + 1], x, periodic_cycle, defaults.FITTED_PROFILE_DEGREE)
        moving = fit > 0
        below = (1.0 - settings.fitted_margin) ** 2 * np.min(x[moving] / fit[moving])
        fit = fit * below
        fit *= min(1.0, max_feasible_scale(problem.slice(i0, i1), fit) * (1.0 - FEASIBLE_MARGIN))
        pieces.append(fit)
    text = (f"smooth fit (degree {defaults.FITTED_PROFILE_DEGREE}) of log theta_dot, "
            f"{100 * settings.fitted_margin:g} % below the optimum, verified")
    return _verified("fitted", text, problem, cuts, pieces, check, settings)


def _piece_time(theta: np.ndarray, x: np.ndarray) -> float:
    sq = np.sqrt(x)
    den = sq[:-1] + sq[1:]
    return float(np.sum(np.where(den > 0, 2.0 * np.diff(theta) / np.where(den > 0, den, 1.0), np.inf)))


def _trapezoid(theta, gain, x_max, v, a, rest_start, rest_end) -> np.ndarray:
    """x (K,) of a TCP-speed trapezoid on one piece: speed min(v, sqrt(2 a s), sqrt(2 a (S - s)))
    in TCP arc length s (ramps only at ends where the motion is at rest); where the TCP does not
    move (gain = 0) the joint limits' bound x_max applies."""
    arc = np.concatenate([[0.0], np.cumsum(0.5 * (gain[1:] + gain[:-1]) * np.diff(theta))])
    speed = np.full_like(theta, v)
    if rest_start:
        speed = np.minimum(speed, np.sqrt(2.0 * a * arc))
    if rest_end:
        speed = np.minimum(speed, np.sqrt(2.0 * a * np.maximum(arc[-1] - arc, 0.0)))
    moving = gain > STILL_GAIN_FRACTION * gain.max()
    x = np.where(moving, speed**2 / np.where(moving, gain, 1.0) ** 2, x_max)
    if rest_start:
        x[0] = 0.0
    if rest_end:
        x[-1] = 0.0
    return x


def constant_speed_baseline(problem, sol, chain_args, gain_right, gain_left, check, settings,
                            periodic_cycle) -> Baseline:
    """Trapezoid in TCP speed: the (cruise speed v, TCP acceleration a) pair of least duration for
    which the motion is feasible (searched: a on a logarithmic grid refined around the best, the
    largest feasible v for each a by bisection); a periodic cycle has no ramps."""
    cuts = _cuts(chain_args, problem.size)
    spans = list(zip(cuts[:-1], cuts[1:]))
    x_opt = _piece_values(sol, chain_args, cuts)
    subs = [problem.slice(i0, i1) for i0, i1 in spans]
    rests = [(x[0] <= 0.0, x[-1] <= 0.0) for x in x_opt]

    gains = []
    for i0, i1 in spans:  # each piece seen from its own side of a connection
        g = gain_right[i0:i1 + 1].copy()
        g[-1] = gain_left[i1]
        gains.append(g)

    def pieces_for(v, a):
        return [_trapezoid(sub.grid, g, sub.x_max, v, a, r0, r1) for sub, g, (r0, r1) in zip(subs, gains, rests)]

    def best_speed(a):
        ramp = [rows.ramps(a, v_top) for rows in arranged]

        def feasible(v):
            return all(rows.holds(v, r) for rows, r in zip(arranged, ramp))

        lo, hi = 0.0, v_top
        if feasible(hi):
            return hi
        while hi - lo > defaults.BASELINE_SPEED_TOLERANCE * v_top:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if feasible(mid) else (lo, mid)
        return lo

    def duration(a):
        v = best_speed(a)
        if v <= 0:
            return np.inf, v
        return sum(_piece_time(sub.grid, x) for sub, x in zip(subs, pieces_for(v, a))), v

    v_top = float(np.max(np.sqrt(np.concatenate(x_opt)) * np.concatenate(gains)))
    arranged = [_TrapezoidRows.of(sub, g, r) for sub, g, r in zip(subs, gains, rests)]
    ramps = any(r0 or r1 for r0, r1 in rests)
    accs = np.geomspace(*RAMP_ACCELERATIONS) if ramps else np.array([1.0])
    results = [duration(a) for a in accs]
    k = int(np.argmin([r[0] for r in results]))
    if ramps:  # refine around the best grid value
        fine = np.geomspace(accs[max(k - 1, 0)], accs[min(k + 1, len(accs) - 1)], RAMP_REFINE_POINTS)
        accs = np.concatenate([accs, fine])
        results += [duration(a) for a in fine]
        k = int(np.argmin([r[0] for r in results]))
    (t_best, v), a = results[k], accs[k]
    if not np.isfinite(t_best):
        raise InfeasibleError("constant-speed baseline: no constant TCP speed (with TCP acceleration ramps) meets "
                              "this plan's boundary conditions and limits (e.g. a 'max' or given start/end speed)")
    text = (f"constant TCP speed {v:.6g} m/s" +
            (f" with TCP acceleration ramps of {a:.4g} m/s^2" if ramps else " (periodic, no ramps)"))
    return _verified("constant_speed", text, problem, cuts, pieces_for(v * (1.0 - FEASIBLE_MARGIN), a), check,
                     settings)


def compute_baselines(problem: IntervalProblem, sol: Solution, chain_args: dict, gain_right: np.ndarray,
                      gain_left: np.ndarray, check: Callable, settings) -> Baselines:
    """Both baselines for a solved problem (see the module docstring). gain_right / gain_left (K,):
    TCP speed per unit theta_dot, |J_v Phi'| [m per unit theta], on each side of every point. ``check(profile,
    jumps)`` verifies a joined baseline: (its worst limit ratio outside the jump intervals, its LimitRatios), the
    planner's certified bound per grid interval or :func:`dense_check`."""
    periodic_cycle = bool(chain_args["periodic"]) and not ({0, problem.size - 1} & set(chain_args["stops"]))
    periodic_cycle = periodic_cycle and chain_args["connections"] != Connections.MAX and len(_cuts(chain_args, problem.size)) == 2
    fitted = fitted_baseline(problem, sol, chain_args, check, settings, periodic_cycle)
    try:
        constant = constant_speed_baseline(problem, sol, chain_args, gain_right, gain_left, check, settings,
                                           periodic_cycle)
    except InfeasibleError as exc:
        return Baselines(fitted, None, str(exc))
    return Baselines(fitted, constant)
