"""The wrist singularity (q5 = 0) along a lifted task path: smooth crossings, near passes, flips.

Spherical wrist (OPW angles t, :mod:`pathmotion.robot.opw`): M = R_0c^T R R_c^T = Rz(t4) Ry(t5) Rz(t6).
With m = M e3 = (cos t4 sin t5, sin t4 sin t5, cos t5), the wrist is singular where m_xy = 0 (t5 = 0):
there the pose fixes only t4 + t6, and the TCP Jacobian loses rank.

* **Crossing.** A path through the singularity at theta* has m_xy(theta) = (theta - theta*) u(theta)
  with u smooth, and a smooth lift: t4 = atan2(u_y, u_x), t5 = (theta - theta*) |u| (q5 changes sign),
  t6 from t4 + t6. The closed form's branch 0 (t5 >= 0) would turn q4 and q6 by pi there instead;
  :func:`pathmotion.robot.ik.continuous_wrist` changes wrist branch (t4 + pi, -t5, t6 + pi is the same
  pose) by minimum joint motion. Here theta* is located (root of the signed t5 on that branch) and,
  where |t5| < ``defaults.WRIST_WINDOW``, Phi and Phi', Phi'', Phi''' come from a Chebyshev interpolant
  of the continuous closed-form IK: J^-1 [dp; w] is undetermined at theta* (dt4/dtheta there depends
  on u', i.e. on the path's second derivative) and ill-conditioned nearby. The interpolant takes
  Phi .. Phi''' from J^-1 [dp; w] at the window's regular edges (Hermite conditions) and is certified:
  its TCP pose matches the IK's between its nodes to ``defaults.WRIST_FIT_TOLERANCE`` and its Phi',
  Phi'', Phi''' agree with a fit of higher degree (``WRIST_FIT_DERIVATIVE_TOLERANCE``); otherwise the
  lower degrees of ``WRIST_FIT_DEGREES`` are tried, then the window is halved (``WRIST_FIT_HALVINGS``).
* **Near pass / flip.** A path that misses the singularity by d > ``WRIST_CROSSING_TOLERANCE`` (in t5)
  has a continuous lift in which q4 and q6 turn by about pi over a theta interval ~ d / |u|; the branch
  on either side is fixed by continuity, so no branch choice removes the turn. When the Jacobian's
  smallest singular value there is below the lift's threshold (or the turn falls between reference
  samples) the lift refuses the path as a wrist flip and suggests a tool rotation, found by search,
  that keeps |sin q5| >= ``WRIST_CLEARANCE``; otherwise the path is planned, slowly.

Every wrist passage (a stretch with |sin q5| < ``WRIST_PASSAGE``) is reported with its speed cost:
the smallest path speed the joint velocity limits allow in it (and the joint that binds) against
the one at its edges.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import scipy.linalg
from scipy.optimize import brentq, minimize_scalar
from scipy.spatial.transform import Rotation

from .. import defaults
from ..errors import PathError, UnreachableError
from ..geometry import describe_point
from ..robot import Robot, jacobian
from ..robot.ik import ik_batch, opw_geometry
from ..robot.opw import opw_fk

log = logging.getLogger(__name__)

#: Degrees of the window fit, each with the degree of the second fit it is checked against, tried in turn
#: (a lower degree amplifies the IK's rounding less: short windows, little freedom) [-].
WRIST_FIT_DEGREES = ((9, 11), (7, 9), (5, 7), (3, 5))
#: The two fits' Phi', Phi'', Phi''' must agree to these, relative to max(1, |Phi^(k)|) [-]: far below what
#: the limits need (verification allows 1e-3 over a limit; Phi''' enters only jerk and torque-rate limits).
WRIST_FIT_DERIVATIVE_TOLERANCE = (1e-7, 1e-5, 1e-3)
#: A window edge takes Phi .. Phi''' from J^-1 (Hermite conditions: the lift stays C3 there) when
#: |sin q5| there is at least this [-]: J^-1's Phi''' is then accurate to ~1e-7 (relative).
REGULAR_EDGE = 1e-3
#: theta* this near a segment break or path end [relative to max(1, path length)] is taken to be on it [-].
SNAP = 1e-9
#: Largest joint difference [rad] between the two sides of a corner at q5 = 0 (both sides' fits evaluated
#: there; they are certified far below this) that still counts as continuous.
WRIST_CORNER_JUMP = 1e-6
#: Times the window is halved when its fit is not certified (a smaller window is nearer a polynomial) [-].
WRIST_FIT_HALVINGS = 3
#: Most reference samples the tool-rotation search lifts per candidate (a subsample beyond) [-].
SUGGESTION_SAMPLES = 2000
_AXES = "xyz"

IkAt = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class WristPassage:
    """A stretch of the path near the wrist singularity (|sin q5| < WRIST_PASSAGE).

    theta [m] where |q5| is smallest, min_abs_q5 [rad] there; crossed: q5 changes sign (the smooth
    branch through q5 = 0); q4, q6 [rad] at theta; region (lo, hi) [m]; q4_turn [rad]: change of q4
    across the region. Speed cost (set by :func:`with_speed_limits`): speed_limit [m/s], the smallest
    path speed the joint velocity limits allow in the region, at speed_limit_theta, bound by
    speed_limit_joint; speed_limit_outside [m/s] the same at the region's edges (the smaller; NaN when
    the region spans the path).
    """

    theta: float
    position: tuple[float, float, float]
    min_abs_q5: float
    crossed: bool
    q4: float
    q6: float
    region: tuple[float, float]
    q4_turn: float
    speed_limit: float = float("nan")
    speed_limit_theta: float = float("nan")
    speed_limit_joint: str = ""
    speed_limit_outside: float = float("nan")

    @property
    def speed_cost(self) -> float:
        """1 - speed_limit / speed_limit_outside: the fraction of the speed the passage costs [-]."""
        return 1.0 - self.speed_limit / self.speed_limit_outside

    def summary(self) -> dict:
        """JSON-ready dict (SI units, radians)."""
        finite = lambda x: float(x) if np.isfinite(x) else None  # noqa: E731
        return {"theta": self.theta, "position": list(self.position), "min_abs_q5": self.min_abs_q5,
                "crossed": self.crossed, "q4": self.q4, "q6": self.q6, "region": list(self.region),
                "q4_turn": self.q4_turn, "speed_limit_m_s": finite(self.speed_limit),
                "speed_limit_theta": finite(self.speed_limit_theta), "speed_limit_joint": self.speed_limit_joint,
                "speed_limit_outside_m_s": finite(self.speed_limit_outside),
                "speed_cost": finite(self.speed_cost)}


@dataclass(frozen=True, eq=False)
class WristWindow:
    """Phi on [lo, hi] [m] as a Chebyshev series: coef (K, n) on x = (2 theta - lo - hi) / (hi - lo)."""

    lo: float
    hi: float
    coef: np.ndarray

    def contains(self, theta: np.ndarray, side: str) -> np.ndarray:
        """(N,) bool: theta inside; an end belongs to the window on the side that evaluates into it."""
        inside = (theta > self.lo) & (theta < self.hi)
        end = (theta == self.lo) if side == "right" else (theta == self.hi)
        return inside | end

    def evaluate(self, theta: np.ndarray, order: int) -> list[np.ndarray]:
        """[Phi, Phi', ..., Phi^(order)] at theta (N,), each (N, n)."""
        scale = 2.0 / (self.hi - self.lo)
        x = (2.0 * np.asarray(theta, float) - self.lo - self.hi) / (self.hi - self.lo)
        out, c = [], self.coef
        for k in range(order + 1):
            out.append(np.polynomial.chebyshev.chebval(x, c).T if len(c) else np.zeros((len(x), c.shape[1])))
            c = np.polynomial.chebyshev.chebder(c, 1, scl=scale, axis=0) if len(c) > 1 else c[:0]
        return out


def signed_t5(robot: Robot, q: np.ndarray) -> np.ndarray:
    """OPW wrist angle t5 (N,) [rad] of configurations q (N, 6): q5 up to sign and offset."""
    return opw_geometry(robot).to_t(np.atleast_2d(q))[:, 4]


def find_passages(robot: Robot, task_path, theta: np.ndarray, q: np.ndarray, ik_at: IkAt,
                  threshold: float, q_start: np.ndarray) -> list[WristPassage]:
    """The wrist passages of a lifted reference (theta (N,), continuous q (N, 6)).

    ik_at(theta (M,)) -> (M, 6): the continuous closed-form IK (nearest to the reference). Raises the
    flip error (UnreachableError, reason "singular") for a passage that misses q5 = 0 and is too near
    it: the Jacobian's smallest singular value below ``threshold``, or q5 changing sign between
    reference samples (the turn of q4 and q6 is not even resolved)."""
    t5 = signed_t5(robot, q)
    near = np.abs(np.sin(t5)) < defaults.WRIST_PASSAGE
    if not near.any():
        return []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], near.astype(int), [0]])))
    out = []
    for first, stop in zip(edges[::2], edges[1::2]):
        k = first + int(np.argmin(np.abs(t5[first:stop])))
        star, d, sign_change = _locate(robot, theta, t5, k, ik_at)
        q_star = ik_at(np.array([star]))[0]
        lo_i, hi_i = max(first - 1, 0), min(stop, len(theta) - 1)
        crossed = d <= defaults.WRIST_CROSSING_TOLERANCE
        p_star = task_path.evaluate(star)[0]
        passage = WristPassage(
            theta=float(star), position=tuple(float(x) for x in p_star), min_abs_q5=float(d),
            crossed=bool(crossed and sign_change), q4=float(q_star[3]), q6=float(q_star[5]),
            region=(float(theta[lo_i]), float(theta[hi_i])), q4_turn=float(q[hi_i, 3] - q[lo_i, 3]))
        if not crossed:
            sigma = float(np.linalg.svd(jacobian(robot, q_star), compute_uv=False)[-1])
            if sign_change or sigma < threshold:
                raise UnreachableError(_flip_message(robot, task_path, theta, passage, q_star, sigma, threshold,
                                                     sign_change, q_start), reason="singular",
                                       position=passage.position)
        out.append(passage)
    return out


def _locate(robot: Robot, theta, t5, k: int, ik_at: IkAt) -> tuple[float, float, bool]:
    """theta* near reference sample k where |t5| is smallest on the continuous branch, that |t5|, and
    whether t5 changes sign there (a root of t5, by Brent; otherwise a bounded minimum of |t5|)."""
    a_i, b_i = max(k - 1, 0), min(k + 1, len(theta) - 1)

    def f(x):
        return float(signed_t5(robot, ik_at(np.array([x])))[0])

    if t5[a_i] * t5[b_i] < 0:
        star = brentq(f, theta[a_i], theta[b_i], xtol=1e-15, maxiter=200)
        return star, abs(f(star)), True
    if t5[k] == 0.0:  # exactly on q5 = 0 at sample k, no sign change across its neighbours (handled above)
        return float(theta[k]), 0.0, False
    res = minimize_scalar(lambda x: abs(f(x)), bounds=(theta[a_i], theta[b_i]), method="bounded",
                          options={"xatol": 1e-14})
    star = float(res.x) if abs(f(res.x)) < abs(t5[k]) else float(theta[k])
    return star, abs(f(star)), False


def crossing_windows(robot: Robot, task_path, theta, q, passages, ik_at: IkAt,
                     derivatives_at: Callable, q_start: np.ndarray) -> tuple[WristWindow, ...]:
    """Certified interpolation windows around each passage that reaches q5 = 0 (min |q5| within
    WRIST_CROSSING_TOLERANCE), on the lifted reference theta (N,) [m], q (N, 6) [rad]; ik_at as in
    :func:`find_passages`; derivatives_at(theta (M,), side) -> (Phi, Phi', Phi'', Phi''') by J^-1, each
    (M, 6)."""
    lo, hi = task_path.domain
    cuts = np.unique(np.concatenate([[lo, hi], np.asarray(task_path.breaks, float), _orientation_keys(task_path)]))
    t5 = signed_t5(robot, q)
    windows = []
    for ps in passages:
        if ps.min_abs_q5 > defaults.WRIST_CROSSING_TOLERANCE:
            continue
        k = int(np.clip(np.searchsorted(theta, ps.theta), 1, len(theta) - 1))
        a_i, b_i = max(k - 2, 0), min(k + 1, len(theta) - 1)
        slope = abs(t5[b_i] - t5[a_i]) / (theta[b_i] - theta[a_i])
        h = min(defaults.WRIST_WINDOW / max(slope, 1e-300), defaults.WRIST_WINDOW_MAX)
        star = ps.theta
        nearest = float(cuts[np.argmin(np.abs(cuts - star))])
        if abs(nearest - star) <= SNAP * max(1.0, hi - lo):  # at a path end or a corner (up to rounding)
            star = nearest
        for _ in range(WRIST_FIT_HALVINGS + 1):  # a smaller window is nearer a polynomial
            fits = [_fit(robot, a, b, ik_at, derivatives_at, star) for a, b in _pieces(star, h, cuts)]
            if all(f[0] is not None for f in fits):
                break
            h *= 0.5
        else:
            if lo < star < hi and np.any(cuts == star):  # a corner at q5 = 0: the split need not match
                _corner_error(robot, task_path, theta, star, None, q_start)
            raise PathError(
                f"the wrist singularity crossing at theta = {star:.6f} m could not be resolved to the accuracy the "
                f"planner needs (TCP pose error {max(f[1] for f in fits):.2e} m, derivative disagreement "
                f"{max(f[2] for f in fits):.2e} x its tolerance, window half-width down to {2 * h:.2g} m): the path is "
                "not smooth enough there (a segment end, orientation key or another singularity next to it); move "
                "that off the crossing or the path off the singularity")
        _check_corner(robot, task_path, theta, star, [f[0] for f in fits], q_start)
        windows += [f[0] for f in fits]
    return tuple(windows)


def _check_corner(robot: Robot, task_path, theta, star: float, fits: list[WristWindow], q_start) -> None:
    """A corner at q5 = 0 whose two sides arrive with different q4 (and q6): the wrist would have to turn
    with the TCP at rest, which no q = Phi(theta) can do; UnreachableError with a tool rotation."""
    left = [w for w in fits if w.hi == star]
    right = [w for w in fits if w.lo == star]
    if not (left and right):
        return
    q_left = left[0].evaluate(np.array([star]), 0)[0][0]
    q_right = right[0].evaluate(np.array([star]), 0)[0][0]
    if float(np.max(np.abs(q_right - q_left))) > WRIST_CORNER_JUMP:
        _corner_error(robot, task_path, theta, star, q_right - q_left, q_start)


def _corner_error(robot: Robot, task_path, theta, star: float, jump, q_start) -> None:
    """Raise the error for a corner at q5 = 0 whose sides need different q4/q6 splits (jump (6,) or None)."""
    size = ("" if jump is None else
            f" by {jump[3]:+.3f} rad (q6 by {jump[5]:+.3f} rad)")
    position = task_path.evaluate(star)[0]
    raise UnreachableError(
        f"{describe_point(task_path, star, position)}: "
        f"the path has a corner exactly at the wrist singularity (q5 = 0) where q4 would have to jump{size} with "
        f"the TCP at rest, which no path-following motion can do; "
        f"{suggest_tool_rotation(robot, task_path, theta, q_start)}, or move the corner off the singularity",
        reason="singular", position=position)


def _pieces(star: float, h: float, cuts: np.ndarray) -> list[tuple[float, float]]:
    """[star - h, star + h] clipped to the domain (cuts[0], cuts[-1]) and cut at every segment break and
    orientation key inside it (Phi is analytic within each piece; star itself needs no cut: the fit
    weights a node by |sin q5|, so a node at or next to star does not count)."""
    a, b = max(star - h, cuts[0]), min(star + h, cuts[-1])
    pts = np.concatenate([[a], cuts[(cuts > a) & (cuts < b)], [b]])
    return [(float(lo), float(hi)) for lo, hi in zip(pts[:-1], pts[1:])]


def _orientation_keys(task_path) -> np.ndarray:
    """theta (K,) [m] of the tool orientation's keys (Phi is analytic between them; none when fixed)."""
    keys = getattr(getattr(task_path, "tool_orientation", None), "key_thetas", lambda: ())()
    return np.asarray(keys, dtype=float).reshape(-1)


def _fit(robot: Robot, a: float, b: float, ik_at: IkAt, derivatives_at: Callable,
         star: float) -> tuple[WristWindow | None, float, float]:
    """Phi on [a, b] as a Chebyshev series (see the module docstring): Hermite conditions (Phi .. Phi'''
    by J^-1) at each edge that is not theta* and has |sin q5| >= REGULAR_EDGE, closed-form IK values at
    interior Chebyshev nodes. Certified when its TCP pose matches the IK's between the nodes to
    WRIST_FIT_TOLERANCE and its derivatives agree with a fit of a higher degree (relative
    WRIST_FIT_DERIVATIVE_TOLERANCE); the degrees of WRIST_FIT_DEGREES are tried in turn. Returns (the
    window or None, pose error, derivative disagreement relative to its tolerance)."""
    edges = []
    for x, side in ((a, "right"), (b, "left")):
        q = ik_at(np.array([x]))
        if x != star and abs(np.sin(signed_t5(robot, q)[0])) >= REGULAR_EDGE:
            edges.append((x, [d[0] for d in derivatives_at(np.array([x]), side)]))
    count = 3 * max(c for _, c in WRIST_FIT_DEGREES)
    checks = 0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (np.arange(count) + 0.25) / count)  # not the centre
    t5_of = lambda q: signed_t5(robot, q)  # noqa: E731
    worst = (np.inf, np.inf)
    for degree, check_degree in WRIST_FIT_DEGREES:
        if degree < 4 * len(edges) + 1:  # the edge conditions need the freedom
            continue
        fit = _hermite_fit(a, b, edges, ik_at, degree, t5_of)
        other = _hermite_fit(a, b, edges, ik_at, check_degree, t5_of)
        value_err = _pose_error(robot, fit.evaluate(checks, 0)[0], ik_at(checks))
        one, two = fit.evaluate(checks, 3), other.evaluate(checks, 3)
        # disagreement of Phi^(k), relative to max(1, |Phi^(k)|) and to its tolerance (<= 1: certified)
        deriv_err = max(float(np.max(np.abs(one[k] - two[k])) / max(1.0, np.max(np.abs(one[k]))))
                        / WRIST_FIT_DERIVATIVE_TOLERANCE[k - 1] for k in (1, 2, 3))
        log.debug("wrist window [%.6g, %.6g], degree %d: pose error %.2e, derivative disagreement %.2e", a, b,
                  degree, value_err, deriv_err)
        if value_err <= defaults.WRIST_FIT_TOLERANCE and deriv_err <= 1.0:
            return fit, value_err, deriv_err
        worst = min(worst, (value_err, deriv_err), key=lambda e: e[1])
    return None, worst[0], worst[1]


def _pose_error(robot: Robot, q: np.ndarray, q_ik: np.ndarray) -> float:
    """Largest TCP pose difference (position [m] and rotation-matrix entries) between q and q_ik (N, 6).
    Not joint values: near q5 = 0 the IK's q4 and q6 alone carry rounding / |q5| and, on a path missing
    the singularity by d <= WRIST_CROSSING_TOLERANCE, a deviation ~ d / |q5| that leaves the pose within d."""
    geo = opw_geometry(robot)
    p1, r1 = opw_fk(geo, q)
    p2, r2 = opw_fk(geo, q_ik)
    return float(max(np.max(np.abs(p1 - p2)), np.max(np.abs(r1 - r2))))


def _hermite_fit(a: float, b: float, edges, ik_at: IkAt, degree: int, signed_t5_of) -> WristWindow:
    """Chebyshev series of ``degree`` matching Phi^(k) (k = 0..3) at each edge in ``edges``
    [(theta, [Phi, .., Phi'''])] exactly and, in the least-squares sense, the IK at 2 * degree first-kind
    Chebyshev nodes of [a, b], weighted by |sin q5| (averages the IK's rounding instead of
    interpolating it)."""
    half = 0.5 * (b - a)
    count = 2 * degree
    x_nodes = np.cos(np.pi * (np.arange(count) + 0.5) / count)
    values = ik_at(0.5 * (a + b) + half * x_nodes)
    # q4 and q6 alone are rounded to ~eps / |q5| (their sum is exact): weight each node by |sin q5|
    weight = np.abs(np.sin(signed_t5_of(values)))[:, None]
    weight = weight / max(float(weight.max()), 1e-300)
    fit_rows, fit_rhs = weight * np.polynomial.chebyshev.chebvander(x_nodes, degree), weight * values
    unit = np.eye(degree + 1)
    rows, rhs = [], []
    for x, derivs in edges:
        xe = -1.0 if x == a else 1.0
        for k in range(4):
            row = np.polynomial.chebyshev.chebval(xe, np.polynomial.chebyshev.chebder(unit, k, axis=0) if k else unit)
            scale = 1.0 / np.max(np.abs(row))
            rows.append(scale * row)
            rhs.append(scale * derivs[k] * half**k)
    if not rows:
        return WristWindow(a, b, np.linalg.lstsq(fit_rows, fit_rhs, rcond=None)[0])
    # equality-constrained least squares: coef = particular + null-space part
    con, con_rhs = np.array(rows), np.array(rhs)
    particular = np.linalg.lstsq(con, con_rhs, rcond=None)[0]
    null = scipy.linalg.null_space(con)
    free = np.linalg.lstsq(fit_rows @ null, fit_rhs - fit_rows @ particular, rcond=None)[0]
    return WristWindow(a, b, particular + null @ free)


def with_speed_limits(passage: WristPassage, path, velocity: np.ndarray, theta: np.ndarray) -> WristPassage:
    """The passage with its speed cost: velocity-limited path speed min_j v_j / |Phi'_j| [m/s] over the
    reference samples theta in its region plus theta*, and at the region's edges."""
    lo, hi = passage.region
    inner = np.unique(np.concatenate([theta[(theta >= lo) & (theta <= hi)], [lo, hi, passage.theta]]))
    dq = path.evaluate(inner)[1]
    with np.errstate(divide="ignore"):
        bound = velocity / np.abs(dq)
    k, j = np.unravel_index(np.argmin(bound), bound.shape)
    edges = [x for x in (lo, hi) if path.domain[0] < x < path.domain[1]]
    outside = float("nan")
    if edges:
        with np.errstate(divide="ignore"):
            outside = float(np.min(velocity / np.abs(path.evaluate(np.array(edges))[1])))
    q_star = path.evaluate(passage.theta)[0]  # the smooth branch's split at q5 = 0 (the IK's is arbitrary)
    return replace(passage, q4=float(q_star[3]), q6=float(q_star[5]), speed_limit=float(bound[k, j]),
                   speed_limit_theta=float(inner[k]), speed_limit_joint=path.joint_names[j],
                   speed_limit_outside=outside)


# ----------------------------------------------------------------------------------------------
# The flip error and its suggestion


def _flip_message(robot: Robot, task_path, theta, passage: WristPassage, q_star: np.ndarray, sigma: float,
                  threshold: float, sign_change: bool, q_start) -> str:
    """The one-line flip error: where, how far from q5 = 0, the turn and its speed, a tool rotation."""
    turn = "about pi between two reference samples" if sign_change else f"{abs(passage.q4_turn):.2f} rad"
    # joint rates per metre of path there: J^-1 is ill-conditioned, but its size is the point
    _, dp, _, _, w, _ = task_path.pose(np.array([passage.theta]))
    rate = np.abs(np.linalg.lstsq(jacobian(robot, q_star), np.concatenate([dp[0], w[0]]), rcond=None)[0])
    with np.errstate(divide="ignore"):
        bound = robot.limits.velocity / rate
    j = int(np.argmin(bound))
    return (f"{describe_point(task_path, passage.theta, passage.position)}: "
            f"the path passes {passage.min_abs_q5:.2e} rad from the wrist singularity (q5 = 0) without crossing it, "
            f"so q4 and q6 must turn by {turn} there, q4 at {rate[3]:.2g} rad per m of path ({robot.joint_names[j]}'s "
            f"velocity limit allows {bound[j]:.2g} m/s; smallest Jacobian singular value {sigma:.2e} < {threshold:g}): "
            "a wrist flip, which no choice of wrist branch avoids; "
            f"{suggest_tool_rotation(robot, task_path, theta, q_start)}, or make the path pass exactly through "
            "the singularity (it is then crossed smoothly)")


def suggest_tool_rotation(robot: Robot, task_path, theta: np.ndarray, q_start: np.ndarray) -> str:
    """The smallest rotation of the tool frame about one of its own axes (1 deg steps, up to
    WRIST_MAX_TOOL_ROTATION) whose path, every orientation R -> R Rot(axis, angle), lifts on the branch
    from q_start (6,) [rad] inside the joint ranges with |sin q5| >= WRIST_CLEARANCE at the reference
    samples theta (N,) [m] (at most SUGGESTION_SAMPLES of them) and the segment breaks; a sentence."""
    th = theta if len(theta) <= SUGGESTION_SAMPLES else np.linspace(theta[0], theta[-1], SUGGESTION_SAMPLES)
    th = np.unique(np.concatenate([th, np.asarray(task_path.breaks, float)]))
    p, _, _, rot, _, _ = task_path.pose(th)
    for deg in range(1, defaults.WRIST_MAX_TOOL_ROTATION + 1):
        for axis in range(3):
            for sign in (1, -1):
                tilt = Rotation.from_rotvec(np.radians(sign * deg) * np.eye(3)[axis]).as_matrix()
                try:
                    q = ik_batch(robot, p, rot @ tilt, q_start)
                except UnreachableError:
                    continue
                if np.min(np.abs(np.sin(signed_t5(robot, q)))) >= defaults.WRIST_CLEARANCE:
                    name = f"R{_AXES[axis]}({sign * deg:+d} deg)"
                    return (f"rotating the tool frame by {sign * deg:+d} deg about its own {_AXES[axis]} axis "
                            f"(every path orientation R -> R {name}) keeps |sin q5| >= {defaults.WRIST_CLEARANCE:g} "
                            "along the path")
    return (f"no rotation of the tool frame about its own axes up to {defaults.WRIST_MAX_TOOL_ROTATION} deg keeps "
            f"|sin q5| >= {defaults.WRIST_CLEARANCE:g} along the path; move the path away from the singularity")
