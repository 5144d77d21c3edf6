"""Re-timing on the fly: the time-optimal rest of a plan from a measured state, a stop that keeps the
path, and a resume from rest, for a controller that changes its mind while the arm moves.

Built once per plan (:class:`Retimer`), everything that does not depend on the state is computed at
construction, on the plan's own grid: the canonical rows lo <= a u + b x + c <= hi at every grid point
(both sides of each connection; x = theta_dot^2, u = theta_ddot), the interval rows P x_i + Q x_{i+1} <= R
of planning/topp.py, and the controllable sets K_i (backward reachability from the plan's end, and to rest
at the end for the stop). A query then costs one compiled forward pass over the remaining points:

* ``remaining``: one interval from the state's theta to the next grid point (rows interpolated at theta),
  then the greedy pass through K (time-optimal, Pham & Pham 2018).
* ``stop``: the lowest profile (the least x_{i+1} the rows allow from x_i: maximum deceleration) until x
  can reach 0 inside an interval; the stop point in that interval from the rows at both of its ends.
* override s: every limit scaled as a controller's override does (velocity x s, acceleration and the
  dynamic part of the torque x s^2, jerk and torque rate x s^3) maps the problem onto itself with
  x -> x / s^2, u -> u / s^2: the answer is s^2 times the unit-override answer from (x / s^2, u / s^2),
  with no extra data. A state above the override's envelope (the override was just lowered) brakes with
  the full limits (the lowest profile) until it enters the envelope s^2 K, and goes on from there.
* A state above K (no in-limit motion reaches the end as the plan requires) raises
  :class:`StateInfeasibleError`: the limit factor that would save it (the same scaling: x0 / max K),
  how fast the in-limit braking still is at the path's end and how far past it it would stop.

Third-order limits (jerk, torque rate): ``remaining`` from a moving state is the compiled pass of
planning/retime_jerk.py (a walk that merges into the smooth time-optimal ceiling profile, solved at
construction); for a state on the plan where it gives none, the plan's own motion from the state
(:meth:`Retimer._plan_tail`). Where neither gives an answer, and with ``reference=True``, the second-order
answer is the first linearization point of the project's sequential LP (planning/third_order.py) on the
remaining grid, started at the state's x and u. The stop searches the shortest stop distance whose smooth
profile exists (LP solves, tens to hundreds of milliseconds).
"""

from __future__ import annotations

import logging

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from .. import defaults
from ..errors import InfeasibleError, PathmotionError, StateInfeasibleError
from ..modes import BoundaryMode, Connections
from .grid_data import grid_breaks, grid_rows, sample_grid, with_knots
from .planner import PlanResult, certified_bounds, effective_limits, start_scale, tightened
from .profile import Profile
from .retime_jerk import JerkPass
from . import retime_stop, smooth
from .retime_kernels import brake, fine_brake, greedy_from, least_u, step_down, step_up, stop_inside
from .third_order import solve_from_state
from .limit_rows import limit_rows
from .topp import _interval_rows, _project, controllable_sets
from .verify import LimitRatios, limit_ratios, summarize_intervals
from .trajectory import Trajectory

log = logging.getLogger(__name__)

#: A state closer to the next grid point than this fraction of its interval starts its first interval
#: at the point after (no sliver interval, whose rows would lose the b x terms to round-off) [-].
MERGE_FRACTION = 1e-6
#: Second order: the first interval keeps the state's acceleration, but none that leaves less than this fraction
#: of the larger of the state's x and the greedy step's at its end (it would all but stop there) [-].
KEPT_FLOOR = 0.25
#: Relative slack on a state's membership in a controllable set [-] (round-off of the rows).
STATE_TOLERANCE = 1e-7
#: A state may lie this much (relative, in x) above its controllable bound: a plan's own state between its grid
#: points reads up to ~4e-5 above the bound the interpolated rows give there; the motion from it exceeds the
#: limits by about as much [-].
STATE_ABOVE_K = 1e-4
#: Fixed-point iterations for the stop point inside its interval (rows interpolated there) [-].
STOP_ITERATIONS = 4
#: Intervals the second-order stop's last interval (to rest) is cut into [-].
STOP_SUBDIVISION = 4
#: Points of the finer grid the second-order stop is computed on again, and its reach relative to the first
#: answer's stop distance [-].
STOP_POINTS = 1200
STOP_REACH = 1.1
#: The rows there are interpolated linearly between the plan's points, and every bound is narrowed by this
#: times the interpolation's error at the middle of its plan interval (as certify.py's REMAINDER_SAFETY) [-].
INTERPOLATION_SAFETY = 2.0
#: Third-order stop: grid points of each trial stop, the growth of the trial distance and the relative
#: accuracy of its bisection [-].
SMOOTH_STOP_POINTS = 40
SMOOTH_STOP_GROWTH = 1.25
SMOOTH_STOP_ACCURACY = 0.01
#: Third-order stop: its grid is graded towards the state by this many geometric points from this fraction of
#: the trial distance up to the uniform spacing [-].
SMOOTH_STOP_GRADED = 12
SMOOTH_STOP_FIRST = 1e-4
#: Third-order: the speed-up cap of the first linearization point is sampled at this many times over this
#: horizon [s] (cubically graded towards the state) [-], [s].
JERK_CAP_SAMPLES = 400
JERK_CAP_HORIZON = 5.0
#: Third-order: relative lowerings of x at the state tried when the LP from the state itself is infeasible
#: by round-off, or above a limit by less than the limit tolerance [-].
START_NUDGES = (1e-6, 1e-5, 1e-4, defaults.LIMIT_TOLERANCE)
#: Relative slack of the state's share of the limits against 1 + the limit tolerance (round-off) [-].
SHARE_SLACK = 1e-9
#: Third-order: a state within this of the plan's own (x relative to the plan's x there, u relative to the plan's
#: largest |u|) lies on the plan, whose motion from it is an answer where the compiled pass finds none [-].
PLAN_STATE_TOLERANCE = 1e-4
#: ... and each plan interval its motion is re-expressed on (another interpolation coordinate) carries at least this
#: many points [-], ...
PLAN_TAIL_SUBDIVISION = 8
#: ... and enough that the path jerk's relative change across each of its parts stays below the first of these
#: (the next where the result fails its certificate): the plan's u is linear in xi = (theta - a)^(1/3) there, so
#: its du/dtheta changes by about (2/3) delta / (theta - a) across a part of length delta, which u linear in the new
#: coordinate (nearly theta) averages, half of that change above the plan's jerk at the part's end: parts of at
#: most 1.5 change (theta - a) [-]
PLAN_TAIL_JERK_CHANGE = (2e-3, 5e-4)
#: ... on at most this many points (more parts: that size is not tried; each costs its certificate) [-].
PLAN_TAIL_POINTS = 4000


class Retimer:
    """Re-timing of one plan from any state (see the module docstring). ``plan_result``: a PlanResult of
    an open or closed path planned with "chain" or "zero" connections (a continuous profile). Queries
    share work buffers: one Retimer per thread."""

    def __init__(self, plan_result: PlanResult):
        settings = plan_result.settings
        if settings.connections == Connections.MAX:
            raise PathmotionError("Retimer: a plan with connections = 'max' jumps in theta_dot at its connections; "
                                  "re-time a plan with connections 'chain' or 'zero'")
        traj = plan_result.trajectory
        self.plan, self.path, self.robot, self.settings = plan_result, traj.path, traj.robot, settings
        self.limits = limits = effective_limits(self.robot, settings)
        self.grid = grid = plan_result.profile.grid
        self.third_order = limits.third_order
        breaks = grid_breaks(self.path, grid)
        samp = sample_grid(self.path, self.robot, grid, breaks)
        self._scale = start_scale(limits, grid, self.robot.n, plan_result.scale_along)  # the plan's own limits
        x_ref = plan_result.profile.x if limits.relinearize else None
        problem, right, left = grid_rows(grid, samp, limits, self._scale, x_ref)
        stops = np.searchsorted(grid, [k for k in self.path.kinks if grid[0] < k < grid[-1]])
        if settings.connections == Connections.ZERO:
            stops = np.union1d(stops, breaks).astype(int)
        bound = np.full(len(grid), np.inf)
        bound[stops] = 0.0
        self._stops = np.append(np.asarray(stops, int), len(grid) - 1)
        self._problem = problem = problem.capped(bound)
        self._right, self._left = right, left  # LimitRows: C-contiguous float arrays, as the kernels take
        self._P, self._Q, self._R = problem.P, problem.Q, problem.R
        self._x_max = np.ascontiguousarray(problem.x_max)
        end = settings.end_condition
        end_x = float(problem.x_max[-1]) if end == BoundaryMode.MAX else float(plan_result.profile.x[-1])
        self._sets = controllable_sets(problem, 0.0 if end == BoundaryMode.MAX else end_x, end_x)
        self._rest_sets = self._sets if end_x == 0.0 else controllable_sets(problem, 0.0, 0.0)
        if self._sets.failed_at >= 0 or self._rest_sets.failed_at >= 0:
            raise InfeasibleError("Retimer: the plan's own limits admit no motion to its end on its grid "
                                  "(the plan was tightened beyond them?); plan again without tightening")
        self._klo, self._khi = np.ascontiguousarray(self._sets.lo), np.ascontiguousarray(self._sets.hi)
        self._rlo, self._rhi = np.ascontiguousarray(self._rest_sets.lo), np.ascontiguousarray(self._rest_sets.hi)
        self._no_target = np.full(len(grid), -1.0)
        self._buffer = np.empty(len(grid) + 1)
        self._fine_buffer = np.empty(STOP_POINTS)
        self._stop_buffers = tuple(np.empty(retime_stop.MAX_STEPS + 1) for _ in range(6))
        # rows of both sides stacked [right, left] for the compiled interpolation (retime_kernels.rows_at), and
        # the bounds of its error on every plan interval
        self._stacked = tuple(np.ascontiguousarray(np.stack([getattr(self._right, n), getattr(self._left, n)]))
                              for n in ("a", "b", "c", "lo", "hi", "x_max"))
        self._interpolation_error = self._row_interpolation_error(x_ref)
        self._jerk = self._jerk_pass() if self.third_order else None
        log.debug("retimer: %d grid points, %d rows per interval, %d stops", len(grid), self._P.shape[1],
                  len(self._stops))
        self._warm_up()

    def _row_interpolation_error(self, x_ref) -> np.ndarray:
        """(5, K - 1, m): INTERPOLATION_SAFETY x |exact - linear| of a, b, c, lo, hi at the middle of every plan
        interval (the largest error of linear interpolation of a smooth function on an interval is about its
        error at the middle: a parabola's)."""
        g = self.grid
        mids = 0.5 * (g[:-1] + g[1:])
        samp = sample_grid(self.path, self.robot, mids, ())
        ref = None if x_ref is None else np.interp(mids, g, x_ref)
        rows = limit_rows(samp.right, self.limits, start_scale(self.limits, mids, self.robot.n, self.plan.scale_along),
                          defaults.PLANNER_X_CAP, ref)
        out = np.zeros((5,) + rows.a.shape)
        for k, n in enumerate(("a", "b", "c", "lo", "hi")):
            exact, linear = getattr(rows, n), 0.5 * (getattr(self._right, n)[:-1] + getattr(self._left, n)[1:])
            with np.errstate(invalid="ignore"):
                diff = np.abs(exact - linear)
            out[k] = INTERPOLATION_SAFETY * np.where(np.isfinite(diff), diff, 0.0)
        return np.ascontiguousarray(out)

    def _jerk_pass(self) -> JerkPass | None:
        """The compiled third-order pass's data (planning/retime_jerk.py), its ceiling the smooth time-optimal
        profile to the plan's end from a free start; None when the sequential LP finds none."""
        g = self.grid
        samp = sample_grid(self.path, self.robot, g, with_knots(self.path, g, grid_breaks(self.path, g)), third=True)
        end = self.settings.end_condition
        end_x = None if end == BoundaryMode.MAX else float(self.plan.profile.x[-1])
        try:
            ceiling, scale = self._smooth_solve(g, self._khi.copy(), None, 0.0, end_x is not None and end_x == 0.0,
                                                end_x, with_scale=True)
        except InfeasibleError as err:
            log.warning("retimer: no smooth ceiling profile (%s); third-order queries solve LPs", err)
            return None
        return JerkPass(self.path, self.robot, g, samp, self.limits, scale, ceiling)

    def _warm_up(self) -> None:
        """One query of each kind, so that the first one in a control loop does not load the compiled kernels
        (third-order limits: the compiled remaining pass and stop)."""
        k = int(np.argmax(self.plan.profile.x))
        state = float(self.grid[k]), float(np.sqrt(self.plan.profile.x[k]))
        try:
            if self.third_order:
                self.remaining(*state)
                self.compiled_stop(*state)
                return
            self.remaining(float(self.grid[0]), 0.0)
            self.stop(*state)
        except PathmotionError:  # a plan that cannot be re-timed says so at the first real query
            pass

    # ----------------------------------------------------------------------------------------------- queries

    def remaining(self, theta: float, theta_dot: float, theta_ddot: float = 0.0, override: float = 1.0, *,
                  reference: bool = False, second_order: bool = False) -> Profile:
        """The time-optimal profile from the state (theta, theta_dot [unit theta / s], theta_ddot
        [unit theta / s^2]) to the plan's end under the plan's limits scaled by ``override`` in (0, 1]
        (velocity x override, acceleration and torque's dynamic part x override^2, jerk and torque rate x
        override^3). Its first point is the state. StateInfeasibleError when no motion within the limits
        ends as the plan does. ``reference`` (jerk limits): the sequential LP's answer instead of the compiled
        pass's (slow; the reference the pass is tested against). ``second_order=True`` leaves out the plan's jerk
        and torque-rate limits, as :meth:`stop`'s does: with them a state above the override's envelope is refused,
        without them it brakes into it with the full limits (the acceleration may step)."""
        theta, x0, u0 = self._state(theta, theta_dot, theta_ddot)
        s2 = _override(override) ** 2
        if self.third_order and not second_order:
            return self._smooth_remaining(theta, x0, u0, s2, reference)
        grid, x = self._remaining2(theta, x0, s2, u0)
        return Profile(grid, x)

    def override_remaining(self, theta: float, theta_dot: float, theta_ddot: float, override: float) -> Profile:
        """:meth:`remaining` at ``override`` < 1 as a controller applies an operator's lowered override: where the
        jerk-limited re-timer refuses the state (StateInfeasibleError: it lies above the override's envelope), the
        motion that brakes into it within the second-order limits (velocity, acceleration, torque; the acceleration
        may step), with a warning. At override 1 (the plan's own limits) a refusal is raised."""
        try:
            return self.remaining(theta, theta_dot, theta_ddot, override)
        except StateInfeasibleError as exc:
            if not self.third_order or override >= 1.0:
                raise
            log.warning("no jerk-limited override %.3g from theta = %.6g (%s); braking into it within the "
                        "second-order limits", override, theta, exc)
            return self.remaining(theta, theta_dot, theta_ddot, override, second_order=True)

    def stop(self, theta: float, theta_dot: float, theta_ddot: float = 0.0, *, second_order: bool = False,
             reference: bool = False) -> Profile:
        """The shortest stop along the path within the plan's limits (a category 2 stop: the arm stays on
        the path and stops with theta_dot = 0 at the profile's last grid point). The state must move
        (theta_dot > 0). StateInfeasibleError when no in-limit stop ends before the path's end (or the
        next kink, which the arm cannot pass at speed); its ``stop`` is then the least overshoot-free stop the
        limits allow (see :meth:`_jerk_unsaveable`). ``second_order=True`` leaves out the plan's jerk and
        torque-rate limits (velocity, acceleration and torque still hold; the acceleration may step). With jerk
        limits the stop is the compiled one (planning/retime_stop.py), certified (:meth:`_stop_certified`); where it
        finds none, the compiled pass's time-optimal motion to the next point where the plan's profile rests (a stop
        within every limit, the longest kind), or for a state on the plan the plan's own motion to that point, else
        the sequential LP's motion to that point (tens to hundreds of milliseconds); where none exists,
        StateInfeasibleError.
        ``reference``: the sequential-LP search for the shortest jerk-limited stop instead (slow; the reference the
        compiled stop is tested against)."""
        theta, x0, u0 = self._state(theta, theta_dot, theta_ddot)
        if x0 <= 0.0:
            raise PathmotionError(f"Retimer.stop: the arm is at rest at theta = {theta:.6g} (theta_dot = 0); "
                                  "there is nothing to stop")
        if self.third_order and not second_order and not reference:
            fast = self._compiled_stop(theta, x0, u0)
            if fast is not None:
                return fast
            turns = not self._cannot_turn(theta, x0, u0)
            # the state's share of its order-2 limits, once: above the pass's largest (its own share is at least
            # this one) neither the pass nor the LP answers
            share = self._start_share(theta, x0, u0) if turns else np.inf
            passes = share <= defaults.RETIME_STATE_SHARE_MAX * (1.0 + SHARE_SLACK)
            rest = self._to_next_rest(theta, x0, u0) if passes else None
            if rest is None:
                rest = self._plan_tail(theta, x0, u0, to_rest=True)
            if rest is None and turns:
                rest = self._lp_to_next_rest(theta, x0, u0, share)
            if rest is not None:
                log.info("retimer: no jerk-limited stop from theta = %.6g before the next rest point; the motion to "
                         "it (%.6g)", theta, rest.grid[-1])
                return rest
            raise self._jerk_unsaveable(theta, x0, u0)
        grid, x = self._fine_stop(theta, x0, *self._stop2(theta, x0))
        if self.third_order and not second_order:
            try:
                return self._smooth_stop(theta, x0, u0, grid[-1] - theta)
            except StateInfeasibleError as err:
                err.stop = Profile(grid, x) if err.stop is None else err.stop
                raise
        return Profile(grid, x)

    def _jerk_unsaveable(self, theta: float, x0: float, u0: float) -> StateInfeasibleError:
        """The error for a moving state from which neither a jerk-limited stop nor a motion to the next rest point
        is found (a state decelerating harder than the jerk limits can turn to 0 before the speed runs out, say).
        Its ``stop``: the shortest stop within the velocity, acceleration and torque limits (the least overshoot-free
        stop the limits allow once the jerk limit is given up; its acceleration steps), which a caller that must
        stop (execute) runs."""
        end = self.grid[self._next_stop(int(np.searchsorted(self.grid, theta, side="right")))]
        grid, x = self._fine_stop(theta, x0, *self._stop2(theta, x0))  # StateInfeasibleError: not even that
        return StateInfeasibleError(
            f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g}, theta_ddot = {u0:.6g} cannot stop within "
            f"the jerk and torque-rate limits before theta = {end:.6g} (the next kink or the path's end): its "
            f"acceleration cannot be turned to 0 before the motion comes to rest, nor can it go on to that point; "
            f"the shortest stop without the jerk limits (acceleration steps) ends at theta = {grid[-1]:.6g}. Brake "
            f"earlier or more gently, or raise the jerk limits", stop=Profile(grid, x))

    def _to_next_rest(self, theta: float, x0: float, u0: float) -> Profile | None:
        """Jerk limits: the compiled pass's remaining profile from the state up to its first rest point after it (a
        kink, a stop of the plan or the path's end): a stop within every limit where none shorter is found; None
        where the pass gives none."""
        return _to_rest(self._compiled(theta, x0, u0, 1.0))

    def _lp_to_next_rest(self, theta: float, x0: float, u0: float, share: float) -> Profile | None:
        """Jerk limits: the sequential LP's remaining profile from the state up to its first rest point after it,
        certified as every LP answer (tens to hundreds of milliseconds); None where the state's share of its
        order-2 limits (``share``: :meth:`_start_share`) already refuses it or the LP finds none."""
        if share > (1.0 + self.settings.limit_tolerance) * (1.0 + SHARE_SLACK):
            return None
        try:
            return _to_rest(self._smooth_remaining(theta, x0, u0, 1.0, reference=True))
        except StateInfeasibleError:
            return None

    def _plan_tail(self, theta: float, x0: float, u0: float, to_rest: bool) -> Profile | None:
        """Jerk limits: the plan's own motion from a state on its profile (x within PLAN_STATE_TOLERANCE of the
        plan's x at theta, relative, and u within it times the plan's largest |u|) up to its next rest point
        (``to_rest``) or its end: a motion within every limit that the compiled pass, which keeps PASS_MARGIN below
        the limits the plan runs at, may not find. Cut at theta, a plan interval nearer the rest point before it
        than the one after has its u interpolated in another coordinate (planning/smooth.py): those intervals
        carry points at the plan's own (x, u), at least PLAN_TAIL_SUBDIVISION and enough for the path jerk's change
        across each part to stay within the first of PLAN_TAIL_JERK_CHANGE (the next where the result fails its
        certificate), and the least change of (x, u) at the points from the state up to the first interval whose
        coordinate is the plan's makes x the integral of u again (with the state's small offset from the plan).
        None where the state is off the plan or where the result's certified bounds exceed the limits by more than
        the limit tolerance (beyond the state's own share) at every part size."""
        p = self.plan.profile
        if p.u_nodes is None or x0 <= 0.0:
            return None
        g, px, pu = p.grid, p.x, p.u_nodes
        i = int(min(max(np.searchsorted(g, theta, side="right") - 1, 0), len(g) - 2))
        origin, sign = p.coords
        x_p, u_p, _ = smooth.state(g, px, pu, origin, sign, np.array(i), np.array(theta))
        if abs(x0 - float(x_p)) > PLAN_STATE_TOLERANCE * float(x_p) or \
                abs(u0 - float(u_p)) > PLAN_STATE_TOLERANCE * float(np.max(np.abs(pu))):
            return None
        rests = np.nonzero(px[i + 1:] <= 0.0)[0]
        end = i + 1 + int(rests[0]) if to_rest and rests.size else len(g) - 1
        if to_rest and px[end] > 0.0:
            return None
        first_rest = i + 1 + (int(rests[0]) if rests.size else len(g))
        # plan intervals i.. whose coordinate changes once nothing before theta is part of the profile: before the
        # first rest point after theta, every interval is measured from that rest point (sign -1)
        changed = [k for k in range(i, min(end, first_rest)) if sign[k] >= 0]
        last = max(changed[-1] + 1 if changed else i + 1, i + 1)  # plan point from which the profile is the plan's
        share = retime_stop.state_share(theta, x0, u0, self.grid, self._jerk.p2) if self._jerk is not None else 0.0
        for change in PLAN_TAIL_JERK_CHANGE if last > i + 1 or sign[i] >= 0 else PLAN_TAIL_JERK_CHANGE[:1]:
            tail = self._plan_tail_on(theta, x0, u0, i, last, end, change)
            if tail is not None and self.certify(tail).max_ratio <= max(share, 1.0) + defaults.LIMIT_TOLERANCE:
                return tail
        return None

    def _plan_tail_on(self, theta: float, x0: float, u0: float, i: int, last: int, end: int,
                      change: float) -> Profile | None:
        """The plan's motion from the state (theta in plan interval i) to plan point ``end``, plan intervals i to
        ``last`` - 1 re-expressed on parts across which the path jerk changes by at most ``change`` (relative; see
        _plan_tail), not certified; None where that takes more than PLAN_TAIL_POINTS points or the re-expression
        fails (x <= 0 inside)."""
        p = self.plan.profile
        g, px, pu = p.grid, p.x, p.u_nodes
        origin, sign = p.coords
        parts = [_tail_parts(theta if k == i else g[k], g[k + 1], origin[k], sign[k], change)
                 if sign[k] >= 0 or k == i else 1 for k in range(i, last)]
        if sum(parts) + end - last > PLAN_TAIL_POINTS:
            return None
        pieces, idx = [], []
        for k, n in zip(range(i, last), parts):
            lo = theta if k == i else g[k]
            pieces.append(lo + (g[k + 1] - lo) * np.arange(n) / n)
            idx.append(np.full(n, k))
        fine, fidx = np.concatenate(pieces), np.concatenate(idx)
        xf, uf, _ = smooth.state(g, px, pu, origin, sign, fidx, fine)
        grid = np.concatenate([fine, g[last:end + 1]])
        x = np.concatenate([xf, px[last:end + 1]])
        u = np.concatenate([uf, pu[last:end + 1]])
        x[0], u[0] = x0, u0
        m = len(fine)  # points 1..m-1 are free; interval m-1 ends on the plan's point ``last``
        c_origin, c_sign = smooth.coordinates(grid, x <= 0.0)
        _, _, w0, w1 = smooth.weights(grid[:m + 1], c_origin[:m], c_sign[:m])
        resid = x[1:m + 1] - x[:m] - 2.0 * (w0 * u[:m] + w1 * u[1:m + 1])
        if m > 1:
            d = _least_jerk_change(grid[:m + 1], x[:m + 1], w0, w1, resid)
            x[1:m] += d[:m - 1]
            u[1:m] += d[m - 1:]
        elif abs(resid[0]) > PLAN_STATE_TOLERANCE * x0:
            return None
        if np.any(x[:m + 1] <= 0.0):
            return None
        return self._with_knots(Profile(grid, x, u))

    def compiled_stop(self, theta: float, theta_dot: float, theta_ddot: float = 0.0) -> Profile | None:
        """Jerk limits: the compiled stop alone (planning/retime_stop.py), None where it finds none."""
        theta, x0, u0 = self._state(theta, theta_dot, theta_ddot)
        if not self.third_order:
            raise PathmotionError("Retimer.compiled_stop: the plan has no jerk or torque-rate limit; use stop "
                                  "(its second-order stop is compiled)")
        return self._compiled_stop(theta, x0, u0) if x0 > 0.0 else None

    def _compiled_stop(self, theta: float, x0: float, u0: float) -> Profile | None:
        """The compiled jerk-limited stop (planning/retime_stop.py): where the braking meets the backward pass from
        rest, over the braking depths until its smooth profile meets the rows at its points and its certificate
        the limits (:meth:`_stop_certified`); else the search over braking points and tails, if certified; None
        when neither finds one. The braking starts with the state's own share of the order-2 rows and, apart,
        of the order-3 rows (the least at which some jerk meets them), each at least 1, fading to the margin."""
        jp = self._jerk
        if jp is None or self._cannot_turn(theta, x0, u0):
            return None
        end = float(self.grid[self._next_stop(int(np.searchsorted(self.grid, theta, side="right")))])
        s, x, u, bs, bv, bu = self._stop_buffers
        rows = (self.grid, jp.p2, jp.p3, jp.px)
        top, tol = retime_stop.STATE_SHARE_MAX, defaults.LIMIT_TOLERANCE
        share = min(max(retime_stop.state_share(theta, x0, u0, self.grid, jp.p2), 1.0), top)
        share3 = min(max(retime_stop.jerk_share(theta, x0, u0, self.grid, jp.p3), 1.0), top)
        depth = 0
        while depth >= 0:
            n, _, depth = retime_stop.shortest_met(theta, x0, u0, share, share3, end, depth, *rows, s, x, u, bs, bv,
                                                   bu)
            got = retime_stop.profile_of(s[:n], x[:n], u[:n], end, *rows, 1.0) if n > 0 else None
            if got is not None and retime_stop.profile_ok(*got, 1.0, share + tol, share3 + tol, *rows):
                stop = self._with_knots(Profile(*got))
                if self._stop_certified(stop, theta, x0, u0):
                    return stop
            depth = depth + 1 if 0 <= depth < len(retime_stop.DEPTHS) - 1 else -1
        n, _ = retime_stop.shortest(theta, x0, u0, share, share3, end, *rows, s, x, u)
        got = retime_stop.profile_of(s[:n], x[:n], u[:n], end, *rows) if n > 0 else None
        if got is None and n > 0:  # the close from the smooth form's x at the switch, checked on the full rows (as
            got = retime_stop.profile_of(s[:n], x[:n], u[:n], end, *rows, 1.0)  # the met stop's close)
        if got is None:
            return None
        stop = self._with_knots(Profile(*got))
        return stop if self._stop_certified(stop, theta, x0, u0) else None

    def _stop_certified(self, stop: Profile, theta: float, x0: float, u0: float) -> bool:
        """Whether the stop's certified bound (planning/certify.py) lies within 1 + the limit tolerance, or within
        the state's own share (:meth:`_own_share`, which its first interval holds) plus it: a compiled stop meets
        the rows interpolated between check points, which certifies nothing by itself."""
        tol = self.settings.limit_tolerance
        ratio = self.certify(stop).max_ratio
        if ratio <= (1.0 + tol) * (1.0 + SHARE_SLACK):
            return True
        return ratio <= (max(self._own_share(theta, x0, u0), 1.0) + tol) * (1.0 + SHARE_SLACK)

    def _own_share(self, theta: float, x0: float, u0: float) -> float:
        """The moving state's own share of the plan's limits on the exact rows at theta [-]: the largest of its
        order-2 ones (acceleration, torque) and the least share of the order-3 ones (jerk, torque rate) at which
        some path jerk J meets them all (the motion from the state chooses its jerk): of the rows |a3 J + r| <= lim
        (r = sqrt(x) (a u + b x + c)), min over J of max |a3 J + r| / lim, the largest over pairs of rows of
        w1 w2 |J1 - J2| / (w1 + w2) (w = |a3| / lim, J = -r / a3), and of |r| / lim where a3 = 0. With limits
        linearized around a profile (torque-speed), the interpolated rows' order-2 share."""
        if self.limits.relinearize:
            return float(retime_stop.state_share(theta, x0, u0, self.grid, self._jerk.p2))
        pts = sample_grid(self.path, self.robot, np.array([theta]), (), third=True).right
        scale = self.limits.unit_scale(1, self.robot.n)
        r2 = limit_rows(pts, self.limits, scale, defaults.PLANNER_X_CAP)
        val = r2.a[0] * u0 + r2.b[0] * x0 + r2.c[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.where(val > 0.0, val / r2.hi[0], np.where(val < 0.0, val / r2.lo[0], 0.0))
        share = float(np.max(np.where(np.isfinite(own), own, 0.0), initial=0.0))
        r3 = [lim.rows3(pts, scale[lim.name]) for lim in self.limits if lim.order == 3]
        if not r3:
            return share
        a3, a, b, c, lim = (np.concatenate([np.asarray(r[f], float)[0] for r in r3]) for f in range(5))
        rest = np.sqrt(x0) * (a * u0 + b * x0 + c)
        flat = a3 == 0.0
        share = max(share, float(np.max(np.abs(rest[flat]) / lim[flat], initial=0.0)))
        w, j = np.abs(a3[~flat]) / lim[~flat], -rest[~flat] / a3[~flat]
        with np.errstate(divide="ignore", invalid="ignore"):  # a limit off (inf): w = 0, no pair
            pair = w[:, None] * w[None, :] * np.abs(j[:, None] - j[None, :]) / (w[:, None] + w[None, :])
        return max(share, float(np.max(np.where(np.isfinite(pair), pair, 0.0), initial=0.0)))

    def _cannot_turn(self, theta: float, x0: float, u0: float) -> bool:
        """Jerk limits: whether the state's deceleration provably cannot be turned to 0 before it rests
        (retime_stop.cannot_turn): no jerk-limited stop nor motion on exists, none is searched for."""
        jp = self._jerk
        return jp is not None and bool(retime_stop.cannot_turn(theta, x0, u0, self.grid, jp.p2, jp.p3, jp.px))

    def _with_knots(self, p: Profile) -> Profile:
        """The smooth profile ``p`` with the path's spline knots inside it as grid points, x and u there from its own
        form (the same motion): no interval holds a knot inside, as on the planner's grids, which the certified
        bounds assume (planning/certify.py)."""
        knots = np.asarray(getattr(self.path, "knots", ()), float)
        knots = knots[(knots > p.grid[0]) & (knots < p.grid[-1]) & ~np.isin(knots, p.grid)]
        if not knots.size:
            return p
        origin, sign = p.coords
        i = np.searchsorted(p.grid, knots, side="right") - 1
        x, u, _ = smooth.state(p.grid, p.x, p.u_nodes, origin, sign, i, knots)
        order = np.argsort(np.concatenate([p.grid, knots]), kind="stable")
        return Profile(*(np.concatenate(pair)[order] for pair in ((p.grid, knots), (p.x, x), (p.u_nodes, u))))

    def compiled_remaining(self, theta: float, theta_dot: float, theta_ddot: float = 0.0,
                           override: float = 1.0) -> Profile | None:
        """Jerk limits: the compiled pass's remaining profile alone (planning/retime_jerk.py), None where it gives
        no answer (a state at rest, a state it finds no merge from: ``remaining`` then solves the sequential LP)."""
        theta, x0, u0 = self._state(theta, theta_dot, theta_ddot)
        if not self.third_order:
            raise PathmotionError("Retimer.compiled_remaining: the plan has no jerk or torque-rate limit; "
                                  "use remaining (its second-order pass is compiled)")
        return self._compiled(theta, x0, u0, _override(override) ** 2)

    def _compiled(self, theta: float, x0: float, u0: float, s2: float) -> Profile | None:
        i, j, f = self._locate(theta)
        if self._jerk is None or not self._jerk.applies(theta, i, j, x0):
            return None
        got = self._jerk.remaining(theta, i, f, j, x0 / s2, u0 / s2)
        if got is None:
            return None
        grid, x, u, own = got
        if own:  # a nearly resting state's stretch past its speed dip: its own part certified before it is taken
            share = max(retime_stop.state_share(theta, x0 / s2, u0 / s2, self.grid, self._jerk.p2), 1.0)
            if self.certify(Profile(grid[:own], x[:own], u[:own])).max_ratio > share + self.settings.limit_tolerance:
                return None
        return Profile(grid, x * s2, u * s2)

    def resume(self, theta: float) -> Profile:
        """The time-optimal profile from rest at ``theta`` to the plan's end."""
        return self.remaining(theta, 0.0, 0.0)

    def max_speed(self, theta: float, override: float = 1.0) -> float:
        """The largest theta_dot at ``theta`` from which the plan's end is reachable within the limits (at
        ``override``; the controllable set's bound, second-order limits) [unit theta / s]."""
        theta = self._state(theta, 0.0, 0.0)[0]
        i, j, f, _, P0, Q0, R0 = self._first(theta)
        hi = _project(P0, Q0, R0, 0, self._klo[j], self._khi[j], 0.0, self._x_max_at(i, f), 0.0)[1]
        return float(_override(override) * np.sqrt(max(hi, 0.0)))

    def certify(self, profile: Profile) -> LimitRatios:
        """Certified bound of every active limit's ratio over ``profile`` (planning/certify.py, as ``plan``'s
        default verification); within the limits when ``.within(settings.limit_tolerance)``."""
        bounds = certified_bounds(self.path, self.robot, profile, self.settings)
        return summarize_intervals(profile, bounds, self.limits, (), self.robot.joint_names)

    def dense_ratios(self, profile: Profile, dt: float | None = None) -> LimitRatios:
        """Every active limit's ratio on the dense time resample of ``profile`` (every ``dt`` [s], the plan's
        verification sample time by default): the independent check of :meth:`certify`."""
        dt = self.settings.verify_sample_time if dt is None else dt
        return limit_ratios(Trajectory(self.path, profile, self.robot), self.limits, dt,
                            joint_names=self.robot.joint_names)

    # --------------------------------------------------------------------------------------- second order

    def _state(self, theta, theta_dot, theta_ddot) -> tuple[float, float, float]:
        lo, hi = float(self.grid[0]), float(self.grid[-1])
        values = (theta, theta_dot, theta_ddot)
        if not all(isinstance(v, (int, float, np.floating, np.integer)) and np.isfinite(v) for v in values):
            raise PathmotionError(f"Retimer: theta, theta_dot and theta_ddot must be finite numbers, got {values}")
        if not lo <= theta < hi:
            raise PathmotionError(f"Retimer: theta = {theta:.6g} lies outside the plan's path [{lo:.6g}, {hi:.6g}) "
                                  "(at its end nothing remains)")
        if theta_dot < 0:
            raise PathmotionError(f"Retimer: theta_dot = {theta_dot:.6g} < 0; the re-timer moves forward along the "
                                  "path (plan the reversed path to move back)")
        return float(theta), float(theta_dot) ** 2, float(theta_ddot)

    def _first(self, theta: float) -> tuple[int, int, float, tuple, np.ndarray, np.ndarray, np.ndarray]:
        """(i, j, f, start rows, P0, Q0, R0): theta lies in grid interval i at the fraction f; the first
        interval runs from theta to grid point j (i + 1, or i + 2 when theta is within MERGE_FRACTION of
        i + 1); its rows (1, M) in planning/topp.py's interval form."""
        g = self.grid
        i, j, f = self._locate(theta)
        start = self._right.between(self._left, i, f)
        end = self._left.at(j)
        P0, Q0, R0 = _interval_rows(np.array([theta, g[j]]), *(v[None, :] for v in start), *(v[None, :] for v in end))
        return i, j, f, start, P0, Q0, R0

    def _locate(self, theta: float) -> tuple[int, int, float]:
        """(i, j, f): theta lies in grid interval i at the fraction f; the first interval runs from theta to grid
        point j (i + 1, or i + 2 when theta is within MERGE_FRACTION of i + 1)."""
        g = self.grid
        i = int(min(max(np.searchsorted(g, theta, side="right") - 1, 0), len(g) - 2))
        f = (theta - g[i]) / (g[i + 1] - g[i])
        j = i + 2 if (i + 2 < len(g) and f > 1.0 - MERGE_FRACTION and not np.isin(i + 1, self._stops)) else i + 1
        return i, j, f

    def _x_max_at(self, i: int, f: float) -> float:
        return float(min((1.0 - f) * self._right.x_max[i] + f * self._left.x_max[i + 1],
                         max(self._right.x_max[i], self._left.x_max[i + 1])))

    def _remaining2(self, theta: float, x0: float, s2: float, u0: float | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Second-order remaining profile (grid, x) from (theta, x0) at the override s^2 = ``s2``. Its first
        interval (theta to the next grid point) keeps the state's acceleration ``u0`` where the rows and K
        allow it, from a moving state (the nearest allowed u otherwise, and never one that leaves less than
        KEPT_FLOOR of the larger of x0 and the greedy step's x at the grid point; None: the greedy step), then the
        greedy pass."""
        g, P, Q, R = self.grid, self._P, self._Q, self._R
        i, j, f, _, P0, Q0, R0 = self._first(theta)
        y0 = x0 / s2
        lo, hi = _project(P0, Q0, R0, 0, self._klo[j], self._khi[j], 0.0, self._x_max_at(i, f), 0.0)
        out = self._buffer
        if lo * (1 - STATE_TOLERANCE) - STATE_TOLERANCE <= y0 <= hi * (1 + STATE_ABOVE_K):
            xj = max(step_up(P0, Q0, R0, 0, y0, self._khi[j]), self._klo[j])
            if u0 is not None and y0 > 0.0:  # the moving state's acceleration, within the rows and K_j
                low = max(step_down(P0, Q0, R0, 0, y0)[0], self._klo[j], KEPT_FLOOR * max(y0, xj))
                xj = min(max(y0 + 2.0 * (u0 / s2) * (g[j] - theta), low), xj)
            greedy_from(P, Q, R, self._klo, self._khi, j, xj, out)
            return np.concatenate([[theta], g[j:]]), s2 * np.concatenate([[y0], out[:len(g) - j]])
        lo1, hi1 = _project(P0, Q0, R0, 0, self._klo[j], self._khi[j], 0.0, np.inf, 0.0)
        if not (s2 < 1.0 and x0 <= hi1 * (1 + STATE_TOLERANCE)) or y0 < lo:
            raise self._unsaveable(theta, x0, hi1, "the plan's end")
        # the override was lowered under the state: brake with the full limits into the envelope s^2 K
        target = s2 * self._khi
        lo_j, hi_j = step_down(P0, Q0, R0, 0, x0)
        hi_j = min(hi_j, self._x_max[j])
        if lo_j > hi_j:
            raise self._unsaveable(theta, x0, hi1, "the plan's end")
        if lo_j <= target[j]:
            k, first = j, min(target[j], hi_j)
        else:
            k = brake(P, Q, R, j, lo_j, target, self._x_max, out)
            if k < 0:
                raise self._unsaveable(theta, x0, hi1, "the plan's end")
            first = out[k - j]
        braked = out[:k - j].copy() if k > j else np.empty(0)
        greedy_from(P, Q, R, self._klo, self._khi, k, first / s2, out)
        tail = s2 * out[:len(g) - k]
        tail[0] = first
        return np.concatenate([[theta], g[j:]]), np.concatenate([[x0], braked, tail])

    def _stop2(self, theta: float, x0: float) -> tuple[np.ndarray, np.ndarray]:
        """Second-order shortest stop (grid, x) from (theta, x0): maximum deceleration, stop point inside
        the interval where x can reach 0."""
        g = self.grid
        i, j, f, start, P0, Q0, R0 = self._first(theta)
        lo, hi = step_down(P0, Q0, R0, 0, x0)
        hi = min(hi, self._x_max[j])
        out = self._buffer
        if lo <= 0.0 <= hi:
            d = stop_inside(*start, *self._left.at(j), x0, g[j] - theta, STOP_ITERATIONS)
            return self._stop_grid(theta, x0, np.empty(0), np.empty(0), d, g[j] - theta)
        k = -1 if lo > hi else brake(self._P, self._Q, self._R, j, lo, self._no_target, self._x_max, out)
        if k >= -1:
            hi1 = _project(P0, Q0, R0, 0, self._rlo[j], self._rhi[j], 0.0, np.inf, 0.0)[1]
            raise self._unsaveable(theta, x0, hi1, "the path's end" if self._next_stop(j) == len(g) - 1
                                   else "the next kink")
        last = -k - 2  # the interval where x reaches 0
        xs = out[:last - j + 1].copy()
        d = stop_inside(*self._right.at(last), *self._left.at(last + 1), xs[-1], g[last + 1] - g[last],
                        STOP_ITERATIONS)
        return self._stop_grid(theta, x0, g[j:last + 1], xs, d, g[last + 1] - g[last])

    def _fine_stop(self, theta: float, x0: float, grid: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The stop again on STOP_POINTS uniform points from theta to the plan-grid stop's end, the rows
        interpolated linearly inside each plan interval: a stop spans few plan intervals, and the constant-u
        intervals' first-order error would lengthen it by percents. Returns the finer stop, or the plan-grid
        stop (grid, x) when the finer one does not end sooner."""
        xs = self._fine_buffer
        # a little past the first answer's end: the narrowed rows may need it; never past the next stop point
        end = min(theta + STOP_REACH * (grid[-1] - theta), self.grid[self._next_stop(int(np.searchsorted(self.grid,
                                                                                                          theta)))])
        k, d = fine_brake(self.grid, *self._stacked, self._interpolation_error, theta, x0, end, STOP_POINTS, xs,
                          STOP_ITERATIONS)
        if k < 0 or not np.isfinite(d):
            return grid, x
        h = (end - theta) / (STOP_POINTS - 1)
        fine = theta + h * np.arange(1, k + 1)
        return self._stop_grid(theta, x0, fine, xs[1:k + 1].copy(), d, h)

    @staticmethod
    def _stop_grid(theta, x0, inner_grid, inner_x, d, width) -> tuple[np.ndarray, np.ndarray]:
        """The stop's (grid, x): the state, the inner points, and the stop point ``d`` after the last of them
        (the interval's end ``width`` when the rows gave no shorter distance). The last interval (constant u, x
        linear in theta) carries STOP_SUBDIVISION points: the same motion, whose certified bound is then as
        tight as on the others (a stop where Phi' = 0 is one short interval, whose bound alone is loose)."""
        d = width if not np.isfinite(d) else min(max(d, 1e-9 * width), width)
        last = inner_grid[-1] if inner_grid.size else theta
        x_last = inner_x[-1] if inner_x.size else x0
        share = np.arange(1, STOP_SUBDIVISION) / STOP_SUBDIVISION
        return (np.concatenate([[theta], inner_grid, last + d * share, [last + d]]),
                np.concatenate([[x0], inner_x, x_last * (1.0 - share), [0.0]]))

    def _next_stop(self, j: int) -> int:
        return int(self._stops[np.searchsorted(self._stops, j)])

    def _unsaveable(self, theta: float, x0: float, x_top: float, where: str) -> StateInfeasibleError:
        """The error for a state above what the limits can save (x_top: the largest savable x there)."""
        g = self.grid
        factor = x0 / max(x_top, 1e-300)
        _, j, _, _, P0, Q0, R0 = self._first(theta)
        ks = self._next_stop(j)
        lo, hi = step_down(P0, Q0, R0, 0, x0)
        x_end = max(lo, 0.0) if lo <= hi else np.nan
        if ks > j and np.isfinite(x_end):
            out = np.full(ks - j + 2, np.nan)
            k = brake(self._P[:ks], self._Q[:ks], self._R[:ks], j, x_end, self._no_target[:ks + 1],
                      np.full(ks + 1, np.inf), out)
            x_end = 0.0 if k <= -2 else out[ks - j]
        past = np.nan
        if np.isfinite(x_end):
            u_least = least_u(*self._left.at(ks), x_end)[0]
            past = x_end / (-2.0 * u_least) if u_least < 0 else np.inf
        stop = None
        if np.isfinite(factor) and factor > 1.0:
            try:
                lam = factor * (1.0 + 10 * STATE_TOLERANCE)
                grid, x = self._stop2(theta, x0 / lam)
                stop = Profile(grid, x * lam)
            except PathmotionError:
                stop = None
        speed = np.sqrt(x_end) if np.isfinite(x_end) else np.nan
        braking = (f"Braking within the limits it still moves at theta_dot = {speed:.4g} at theta = {g[ks]:.6g} and "
                   f"would stop about {past:.4g} past it" if np.isfinite(speed) else
                   f"Braking within the limits it cannot stop before theta = {g[ks]:.6g}")
        return StateInfeasibleError(
            f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g} cannot be saved: no motion within the "
            f"limits reaches {where} as the plan requires (theta_dot <= {np.sqrt(max(x_top, 0.0)):.6g} there). "
            f"{braking}; a stop before it needs the acceleration and torque limits x {factor:.4g} (velocity x "
            f"{np.sqrt(factor):.4g}); lower the speed earlier or raise the limits",
            limit_factor=float(factor), end_speed=float(speed), overshoot=float(past), stop=stop)

    # --------------------------------------------------------------------------------------- third order

    def _smooth_solve(self, grid: np.ndarray, x_start: np.ndarray, x0: float | None, u0: float, rest_end: bool,
                      end_x: float | None, with_scale: bool = False):
        """The third-order profile on ``grid`` from (x0, u0) (rest when x0 = 0; a free start when x0 is None) by
        the sequential LP, linearized first around ``x_start``; at rest at its end (``rest_end``) or with x =
        ``end_x``. ``with_scale``: (profile, the limits' point-wise scales it was tightened to)."""
        breaks = grid_breaks(self.path, grid)
        samp = sample_grid(self.path, self.robot, grid, with_knots(self.path, grid, breaks), third=True)
        k = len(grid)
        rest = np.zeros(k, bool)
        rest[np.searchsorted(grid, [p for p in self.path.kinks if grid[0] < p < grid[-1]])] = True
        rest[-1] = rest_end
        fixed, fixed_u = {}, {}
        if x0 is not None and x0 <= 0.0:
            rest[0] = True
        elif x0 is not None:
            fixed[0], fixed_u[0] = x0, u0
        if not rest_end and end_x is not None:
            fixed[k - 1] = end_x
        scale, tol = self.limits.unit_scale(k, self.robot.n), self.settings.limit_tolerance
        for tighten in range(self.settings.max_tighten_iterations + 1):
            profile = self._smooth_lp(grid, samp, scale, np.where(rest, 0.0, x_start), rest, fixed, fixed_u)
            bounds = certified_bounds(self.path, self.robot, profile, self.settings)
            worst = max((float(b.max()) for b in bounds.values() if b.size), default=0.0)
            log.debug("retimer: third-order profile on %d points, worst certified ratio %.5f", k, worst)
            if worst <= 1.0 + tol:
                return (profile, scale) if with_scale else profile
            scale, x_start = tightened(scale, bounds, tol), profile.x
        raise InfeasibleError(f"third-order re-timing: the profile still exceeds a limit by {100 * (worst - 1):.3g} % "
                              f"between grid points after {tighten} tightening iterations; raise limit_tolerance")

    def _smooth_lp(self, grid, samp, scale, x_start, rest, fixed, fixed_u) -> Profile:
        """One sequential-LP solve. Its first tangents, taken at the second-order answer, can leave no
        feasible x next to a state with a given acceleration: then the profile with the acceleration free
        (as the planner starts) is the linearization point of the solve with it fixed. A start on the edge of
        the feasible set (the plan's own state, say) can be infeasible by round-off or by the plans' limit
        tolerance: it is retried with x_0 and u_0 moved towards 0 by START_NUDGES (relative)."""
        for nudge in (0.0, *START_NUDGES):
            moved = {i: v * (1.0 - nudge) if i == 0 else v for i, v in fixed.items()}
            moved_u = {i: v * (1.0 - nudge) for i, v in fixed_u.items()}
            try:
                return solve_from_state(grid, samp, self.limits, scale, x_start, rest, moved, moved_u)[0]
            except InfeasibleError:
                if not fixed_u:
                    raise
            if nudge == 0.0:
                try:
                    free = solve_from_state(grid, samp, self.limits, scale, x_start, rest, fixed, {})[0]
                    x_start = free.x
                    return solve_from_state(grid, samp, self.limits, scale, x_start, rest, moved, moved_u)[0]
                except InfeasibleError:
                    pass
        raise InfeasibleError(f"third-order limits: no smooth profile from theta_dot = {np.sqrt(fixed.get(0, 0.0)):.6g}"
                              f", theta_ddot = {fixed_u.get(0, 0.0):.6g} meets the limits on this grid")

    def _smooth_remaining(self, theta: float, x0: float, u0: float, s2: float, reference: bool = False) -> Profile:
        """Third-order remaining profile: the compiled pass (planning/retime_jerk.py) from a moving state, else
        (or with ``reference``) the sequential LP from the second-order answer (an upper bound)."""
        if not reference:
            fast = self._compiled(theta, x0, u0, s2)
            if fast is None and s2 == 1.0:
                fast = self._plan_tail(theta, x0, u0, to_rest=False)
            if fast is not None:
                return fast
            if self._cannot_turn(theta, x0 / s2, u0 / s2):
                raise StateInfeasibleError(
                    f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g}, theta_ddot = {u0:.6g} cannot go on "
                    f"within the jerk and torque-rate limits at override {np.sqrt(s2):.4g}: its deceleration cannot be "
                    "turned to 0 before theta_dot runs out; stop first (Retimer.stop, which carries the stop without "
                    "the jerk limits), or brake more gently", end_speed=np.nan)
            share = self._start_share(theta, x0 / s2, u0 / s2)
            if share > (1.0 + self.settings.limit_tolerance) * (1.0 + SHARE_SLACK):
                raise StateInfeasibleError(
                    f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g}, theta_ddot = {u0:.6g} takes "
                    f"{share:.4g} of its acceleration or torque limits at override {np.sqrt(s2):.4g}: no motion from it "
                    "is within the limits; stop first (Retimer.stop), or brake more gently", end_speed=np.nan)
            log.debug("retimer: no answer of the compiled pass from theta = %.6g; sequential LP", theta)
        try:
            grid, x2 = self._remaining2(theta, x0, s2)
        except StateInfeasibleError:  # the smooth interpolation may lie a little above the interval form's K
            _, j, _ = self._locate(theta)
            grid, x2 = np.concatenate([[theta], self.grid[j:]]), s2 * np.concatenate([[x0 / s2], self._khi[j:]])
        end = self.settings.end_condition
        end_x = None if end == BoundaryMode.MAX else float(self.plan.profile.x[-1]) / s2
        rest_end = end_x is not None and end_x == 0.0
        # graded towards the state, as the planner grades towards a start: the first intervals carry the turn
        # of the acceleration from the state's at the jerk limit
        step = grid[1] - grid[0]
        fine = np.union1d(grid, grid[0] + step * 0.5 ** np.arange(1, defaults.GRID_GRADING_LEVELS + 1))
        x2, grid = np.interp(fine, grid, x2), fine
        x_start = np.minimum(x2, self._jerk_cap(grid, x0, u0)) / s2
        try:
            p = self._smooth_solve(grid, x_start, x0 / s2, u0 / s2, rest_end, end_x)
        except InfeasibleError as err:
            raise StateInfeasibleError(
                f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g}, theta_ddot = {u0:.6g} cannot be "
                f"brought to the plan's end within the jerk and torque-rate limits at override {np.sqrt(s2):.4g} "
                f"({err}); stop first (Retimer.stop), or raise the override") from err
        return Profile(p.grid, p.x * s2, p.u_nodes * s2)

    def _start_share(self, theta: float, x0: float, u0: float) -> float:
        """The least share of the order-2 limits (acceleration, torque: the exact rows at theta, unit scale) the
        state (x0 > 0, u0) or the sequential LP's start moved towards 0 by START_NUDGES takes [-]: every profile
        the LP returns starts there with its certified bound (planning/certify.py, an upper bound on the ratio
        at the interval's start) within 1 + the limit tolerance, so a share above that has no answer. 0 for a
        state at rest (its u is free) and with limits linearized around a profile (torque-speed)."""
        if x0 <= 0.0 or self.limits.relinearize:
            return 0.0
        pts = sample_grid(self.path, self.robot, np.array([theta]), (), third=True).right
        rows = limit_rows(pts, self.limits, self.limits.unit_scale(1, self.robot.n), defaults.PLANNER_X_CAP)
        nudge = 1.0 - np.array((0.0, *START_NUDGES))[:, None]
        val = rows.a[0] * u0 * nudge + rows.b[0] * x0 * nudge + rows.c[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(val > 0.0, val / rows.hi[0], np.where(val < 0.0, val / rows.lo[0], 0.0))
        share = np.where(np.isfinite(share), share, 0.0)
        return float(np.min(np.max(share, axis=1)))

    def _jerk_cap(self, grid: np.ndarray, x0: float, u0: float) -> np.ndarray:
        """x (K,) on ``grid`` of the fastest speed-up from (x0, u0) at the state's path jerk bound (min over the
        joints of J_j / |Phi'_j|, held constant): the first linearization point stays below it. Far above, the
        first tangents of the jerk rows would leave no feasible x next to the state (the planner caps its
        start from rest the same way). inf where no jerk limit is active."""
        jerk = next((lim for lim in self.limits if lim.name == "jerk"), None)
        if jerk is None:
            return np.full(len(grid), np.inf)
        dphi = np.abs(np.asarray(self.path.evaluate(float(grid[0]))[1], float))
        with np.errstate(divide="ignore"):
            j = float(np.min(np.asarray(jerk.values, float) / dphi))
        t = np.linspace(0.0, 1.0, JERK_CAP_SAMPLES) ** 3 * JERK_CAP_HORIZON
        v0 = np.sqrt(x0)
        v = v0 + u0 * t + 0.5 * j * t**2
        theta = grid[0] + v0 * t + 0.5 * u0 * t**2 + j * t**3 / 6.0
        ok = np.concatenate([[True], np.diff(theta) > 0]) & (v >= 0)
        return np.interp(grid, theta[ok], v[ok] ** 2, right=np.inf)

    def _smooth_stop(self, theta: float, x0: float, u0: float, d2: float) -> Profile:
        """Third-order shortest stop: the least distance (from the second-order stop distance ``d2``, a lower
        bound, grown by SMOOTH_STOP_GROWTH, then bisected to SMOOTH_STOP_ACCURACY) whose smooth stop exists."""
        _, j, _ = self._locate(theta)
        d_max = float(self.grid[self._next_stop(j)] - theta)
        # graded towards the state: a state with a large acceleration turns it at the jerk limit within a
        # small fraction of the stop, which the uniform points alone do not resolve (no trial would succeed)
        unit = np.union1d(np.linspace(0.0, 1.0, SMOOTH_STOP_POINTS),
                          np.geomspace(SMOOTH_STOP_FIRST, 1.0 / (SMOOTH_STOP_POINTS - 1), SMOOTH_STOP_GRADED))

        def trial(d):
            grid = theta + d * unit
            try:
                return self._smooth_solve(grid, x0 * (1.0 - unit), x0, u0, True, None)
            except InfeasibleError:
                return None

        lo, d, best = d2, d2, None
        while best is None:
            d = min(d * SMOOTH_STOP_GROWTH, d_max)
            best = trial(d)
            if best is None and d >= d_max:
                raise StateInfeasibleError(
                    f"the state theta = {theta:.6g}, theta_dot = {np.sqrt(x0):.6g}, theta_ddot = {u0:.6g} cannot "
                    f"stop within the jerk limits before theta = {theta + d_max:.6g} (the path's end or a kink); "
                    f"without jerk limits it would stop after {d2:.4g}", end_speed=np.nan)
            if best is None:
                lo = d
        hi = d
        while hi - lo > SMOOTH_STOP_ACCURACY * hi:
            mid = 0.5 * (lo + hi)
            found = trial(mid)
            lo, hi, best = (lo, mid, found) if found is not None else (mid, hi, best)
        return best


def _to_rest(p: Profile | None) -> Profile | None:
    """The smooth profile ``p`` up to its first rest point after its start (None for None and where it does not
    rest: a plan that ends moving)."""
    if p is None or not np.any(p.x[1:] <= 0.0):
        return None
    k = int(np.argmax(p.x[1:] <= 0.0)) + 1
    return Profile(p.grid[:k + 1], p.x[:k + 1], p.u_nodes[:k + 1])


def _tail_parts(lo: float, hi: float, origin: float, sign: int, change: float) -> int:
    """The parts a plan interval [lo, hi] of the plan's tail is re-expressed on (Retimer._plan_tail): at least
    PLAN_TAIL_SUBDIVISION, and the path jerk's change across each within ``change`` (relative)."""
    if sign <= 0 or not lo > origin:  # xi = theta, or measured from the rest point after as in the cut profile
        return PLAN_TAIL_SUBDIVISION
    return max(PLAN_TAIL_SUBDIVISION, int(np.ceil((hi - lo) / (1.5 * change * (lo - origin)))))


def _least_jerk_change(grid, x, w0, w1, resid) -> np.ndarray:
    """(dx (m-1,), du (m-1,)) at the inner points of ``grid`` (m + 1,) that make x_{k+1} - x_k = 2 (w0_k u_k +
    w1_k u_{k+1}) on its m intervals again (``resid``: the left side minus the right side there; the ends fixed)
    with the least change of the path jerk theta_dddot = sqrt(x) du/dtheta (squares integrated over theta).
    The equality-constrained least squares by its KKT system, sparse (banded: every row couples neighbouring
    points), so its cost grows linearly with the points."""
    m = len(grid) - 1
    h = np.diff(grid)
    n = 2 * (m - 1)
    rows = np.arange(m - 1)
    # d resid_k / d (dx, du)
    a = sparse.coo_matrix((np.concatenate([np.ones(m - 1), -np.ones(m - 1), -2.0 * w1[:m - 1], -2.0 * w0[1:m]]),
                           (np.concatenate([rows, rows + 1, rows, rows + 1]),
                            np.concatenate([rows, rows, m - 1 + rows, m - 1 + rows]))), shape=(m, n)).tocsr()
    scale = np.sqrt(np.maximum(x[:-1], 0.0) / h)  # the jerk change on each interval, times sqrt(h)
    b = sparse.coo_matrix((np.concatenate([scale[:m - 1], -scale[1:m]]),
                           (np.concatenate([rows, rows + 1]), np.concatenate([m - 1 + rows, m - 1 + rows]))),
                          shape=(m, n)).tocsr()
    hess = (b.T @ b).tocsr()
    hess = hess + sparse.identity(n, format="csr") * (1e-12 * max(float(hess.diagonal().max()), 1.0))
    kkt = sparse.bmat([[hess, a.T], [a, None]], format="csc")
    return spsolve(kkt, np.concatenate([np.zeros(n), -resid]))[:n]


def _override(override) -> float:
    """``override`` checked: a number in (0, 1]."""
    if isinstance(override, bool) or not isinstance(override, (int, float, np.floating)) or not 0.0 < override <= 1.0:
        raise PathmotionError(f"Retimer: override must be a number in (0, 1] (1 = the plan's speed), got {override!r}")
    return float(override)
