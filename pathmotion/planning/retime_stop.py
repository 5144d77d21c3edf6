"""Compiled jerk-limited stop: the shortest stop along the path from a moving state (theta, theta_dot,
theta_ddot) within every limit of the plan (velocity, acceleration, torque, jerk, torque rate).

The stop is integrated in time with a piecewise constant path jerk (steps of about the estimated stop time
over STEPS_PER_STOP):

* braking: the jerk turns theta_ddot = u towards ``depth`` times the least u the order-2 rows allow (tracking
  it as it moves with theta and x = theta_dot^2), as fast as the order-3 rows allow at both ends of a step;
* tail: from a braking point, m steps at the largest jerk the order-3 rows allow (their velocity terms can
  forbid the positive jerk of a close at speed), then the constant-jerk close J = u^2 / (2 theta_dot) that
  brings u to 0 as theta_dot reaches 0 (distance 2 x / (3 |u|)), checked along its length.

Of the depths DEPTHS (until DEPTH_MISSES in a row stop no sooner), the braking points (a coarse stride, then
halving strides around the best) and the m, the stop that ends first is taken; along a tail, the first close
the jerk allows. The rows are those the compiled remaining pass stores at Retimer
construction (planning/retime_jerk.py: order-2 rows, x_max and order-3 rows at the CHECK_POINTS of every plan
interval), interpolated linearly between neighbouring check points, and met with MARGIN to spare (faded in
from the state's own share where the state itself takes more: of the order-2 rows its u's, of the order-3 rows
the least any jerk takes, apart). A step's jerk is checked as the smooth profile realizes it (u linear along the
step's theta). :func:`profile_of` turns the points into the project's smooth profile (u linear in xi = (theta_stop -
theta)^(1/3) per interval, where the close is exact).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import defaults

#: Share of every limit the stop keeps free for the linear interpolation of the rows and the discrete jerk [-].
MARGIN = 0.01
#: Braking steps per stop: the time step is the estimated stop time over this [-].
STEPS_PER_STOP = 200
#: Fewest steps of a stop: a stop of fewer is searched again with a shorter step [-].
MIN_STEPS = 100
#: Bounds of the time step [s] and the most steps a stop may take [-].
DT_MIN, DT_MAX, MAX_STEPS = 1e-5, 2e-3, 20000
#: Points along the constant-jerk tail where its limits are checked [-].
TAIL_POINTS = 8
#: Steps over which the state's own share of the limits fades to 1 - MARGIN [-].
FADE_STEPS = 10
#: Share of the time step of the steps while the margin fades in [-].
FADE_DT = 0.125
#: Braking points tried as the switch to the tail at first (a stride of their number over this) [-].
COARSE = 16
#: A tail is checked at least every this fraction of each plan interval along it [-].
CHECK_SPACING = 0.125
#: A braking step that breaks a row sends the braking this many steps back, to aim at this share of its depth, at
#: most this many times per braking [-].
REWIND, RECOVER_DEPTH, RECOVER_TRIES = 10, 0.85, 4
#: Braking depths tried: shares of the least u the order-2 rows allow [-].
DEPTHS = np.array([1.0, 0.85, 0.7, 0.55, 0.4, 0.25])
#: The search over the depths ends after this many in a row that stop no sooner than the best so far [-].
DEPTH_MISSES = 2
#: Intervals of the tail in the returned profile (equal in xi) [-].
TAIL_INTERVALS = 4
#: Re-evaluations of the order-3 rows at a braking step's end [-].
END_PASSES = 3
#: Fixed-point iterations of the close's start x and stop point [-].
CLOSE_ITERATIONS = 3
#: Share of x_max the stop may take: the state's own x may lie on it within the plans' limit tolerance, and the
#: stop brakes from there [-].
X_SHARE = (1.0 + defaults.LIMIT_TOLERANCE) ** 2
#: A step's jerk moved into its bounds lands this fraction of their range inside them [-].
FIT_INSET = 1e-6
#: Relative slack of the checks (round-off) [-].
SLACK = 1e-9
#: The most of the order-2 limits the state itself may take; the braking fades from there to 1 - MARGIN [-].
STATE_SHARE_MAX = defaults.RETIME_STATE_SHARE_MAX


@njit(cache=True, nogil=True, inline="always")
def _locate(s, grid):
    """(plan interval g, check segment q, weight w) of theta = s: between check points q and q + 1."""
    g = np.searchsorted(grid, s, side="right") - 1
    g = min(max(g, 0), grid.shape[0] - 2)
    f = (s - grid[g]) / (grid[g + 1] - grid[g]) * 4.0
    q = min(max(int(f), 0), 3)
    w = min(max(f - q, 0.0), 1.0)
    return g, q, w


@njit(cache=True, nogil=True, inline="always")
def _at(arr, q, g, r, w):
    return (1.0 - w) * arr[q, g, r] + w * arr[q + 1, g, r]


@njit(cache=True, nogil=True)
def _u_range(s, x, keep, grid, p2, px):
    """(least, largest) u the order-2 rows allow at (s, x) with ``keep`` of the limits; (inf, -inf) when x is
    above X_SHARE x_max."""
    g, q, w = _locate(s, grid)
    if x > X_SHARE * ((1.0 - w) * px[q, g] + w * px[q + 1, g]):
        return np.inf, -np.inf
    a_, b_, c_, lo_, hi_ = p2
    low, high = -np.inf, np.inf
    for r in range(a_.shape[2]):
        a, b, c = _at(a_, q, g, r, w), _at(b_, q, g, r, w), _at(c_, q, g, r, w)
        lo, hi = keep * _at(lo_, q, g, r, w), keep * _at(hi_, q, g, r, w)
        rest = b * x + c
        slack = SLACK * (abs(lo) + abs(hi))
        if a > 0.0:
            low, high = max(low, (lo - slack - rest) / a), min(high, (hi + slack - rest) / a)
        elif a < 0.0:
            low, high = max(low, (hi + slack - rest) / a), min(high, (lo - slack - rest) / a)
        elif rest > hi + slack or rest < lo - slack:
            return np.inf, -np.inf
    return low, high


@njit(cache=True, nogil=True)
def state_share(s, x, u, grid, p2):
    """The largest share of an order-2 limit the state (s, x, u) takes on the interpolated rows [-]."""
    g, q, w = _locate(s, grid)
    a_, b_, c_, lo_, hi_ = p2
    share = 0.0
    for r in range(a_.shape[2]):
        val = _at(a_, q, g, r, w) * u + _at(b_, q, g, r, w) * x + _at(c_, q, g, r, w)
        lo, hi = _at(lo_, q, g, r, w), _at(hi_, q, g, r, w)
        if val > 0.0 and hi > 0.0:
            share = max(share, val / hi)
        elif val < 0.0 and lo < 0.0:
            share = max(share, val / lo)
    return share


@njit(cache=True, nogil=True)
def _j_range(s, x, u, keep, grid, p3):
    """(least, largest) path jerk the order-3 rows |a3 j + sqrt(x) (a u + b x + c)| <= keep lim allow at
    (s, x, u)."""
    g, q, w = _locate(s, grid)
    a3_, a_, b_, c_, lim_ = p3
    sx = np.sqrt(max(x, 0.0))
    low, high = -np.inf, np.inf
    for r in range(a3_.shape[2]):
        a3 = _at(a3_, q, g, r, w)
        rest = sx * (_at(a_, q, g, r, w) * u + _at(b_, q, g, r, w) * x + _at(c_, q, g, r, w))
        lim = keep * _at(lim_, q, g, r, w) * (1.0 + SLACK)
        if a3 > 0.0:
            low, high = max(low, (-lim - rest) / a3), min(high, (lim - rest) / a3)
        elif a3 < 0.0:
            low, high = max(low, (lim - rest) / a3), min(high, (-lim - rest) / a3)
        elif abs(rest) > lim:
            return np.inf, -np.inf
    return low, high


#: Bisection steps of :func:`jerk_share` [-].
JERK_SHARE_ITERATIONS = 40


@njit(cache=True, nogil=True)
def jerk_share(s, x, u, grid, p3):
    """The least share of the order-3 limits at which the interpolated rows allow a path jerk at the state (s, x,
    u) [-]: the state's own (its jerk is free, only its u and x enter the rows), by bisection up to STATE_SHARE_MAX;
    inf above it."""
    low, high = 0.0, STATE_SHARE_MAX
    jlo, jhi = _j_range(s, x, u, high, grid, p3)
    if jlo > jhi:
        return np.inf
    for _ in range(JERK_SHARE_ITERATIONS):
        mid = 0.5 * (low + high)
        jlo, jhi = _j_range(s, x, u, mid, grid, p3)
        if jlo <= jhi:
            high = mid
        else:
            low = mid
    return high


@njit(cache=True, nogil=True)
def _start_shares(s0, x0, u0, share, share3, grid, p2, p3, px):
    """The shares of the order-2 and of the order-3 limits the braking starts with (_keep): for each order, 1 -
    MARGIN where the state meets its rows with the margin (u within the order-2 rows; some jerk within the order-3
    rows), else ``share`` or ``share3`` (the state's own), at least 1 - MARGIN. The orders apart: a state above
    its order-2 rows (the rows' linear interpolation between check points reads up to a few per cent high) gives
    the stop's jerk, which it chooses, no share of the jerk limits above 1 - MARGIN."""
    lo, hi = _u_range(s0, x0, 1.0 - MARGIN, grid, p2, px)
    if lo <= u0 <= hi:
        share = 1.0 - MARGIN
    jlo, jhi = _j_range(s0, x0, u0, 1.0 - MARGIN, grid, p3)
    if jlo <= jhi:
        share3 = 1.0 - MARGIN
    return max(share, 1.0 - MARGIN), max(share3, 1.0 - MARGIN)


#: The certificate that a state cannot turn its deceleration (:func:`cannot_turn`) bounds |u| along the motion by
#: this many times the largest of the state's and the least the order-2 rows allow [-].
TURN_U_SAFETY = 2.0


@njit(cache=True, nogil=True)
def cannot_turn(s0, x0, u0, grid, p2, p3, px):
    """Whether no motion from the state (s0, x0 = theta_dot^2 > 0, u0 = theta_ddot < 0) within the interpolated
    rows (at any share of the limits up to STATE_SHARE_MAX) turns its deceleration to 0 before theta_dot runs out:
    the path jerk J allowed anywhere the motion can go before it rests (theta within 2 x0 / |u0| of s0, x <= x0,
    |u| <= U) is bounded above (every order-3 row |a3 J + sqrt(x) (a u + b x + c)| <= lim gives J <= (lim +
    sqrt(x0) (|a| U + |b| x0 + |c|)) / |a3|, at most its largest over the check points of a segment where a3 keeps
    its sign), and theta_dot <= v0 + u0 t + J t^2 / 2 reaches 0 while u <= u0 + J t < 0 when u0^2 > 2 J v0. Then
    neither a stop nor a motion on (both need u = 0 where they rest) exists. U: TURN_U_SAFETY times the largest of
    |u0| and the least u the order-2 rows allow at the region's check points (x = 0 and x0)."""
    if not (u0 < 0.0 and x0 > 0.0):
        return False
    keep = STATE_SHARE_MAX + 2.0 * defaults.LIMIT_TOLERANCE
    v0 = np.sqrt(x0)
    g0, q0, _ = _locate(s0, grid)
    g1, q1, _ = _locate(min(s0 + 2.0 * x0 / -u0, grid[-1]), grid)
    first, last = 4 * g0 + q0, 4 * g1 + q1
    top = -u0
    for idx in range(first, last + 2):  # the check points bounding the region's segments
        g, q = min(idx // 4, grid.shape[0] - 2), idx - 4 * min(idx // 4, grid.shape[0] - 2)
        pt = grid[g] + (grid[g + 1] - grid[g]) * q / 4.0
        for x in (0.0, x0):
            lo = _u_range(pt, x, keep, grid, p2, px)[0]
            if np.isfinite(lo):
                top = max(top, -lo)
    u_top = TURN_U_SAFETY * top
    a3_, a_, b_, c_, lim_ = p3
    jerk = np.inf
    for r in range(a3_.shape[2]):
        row = 0.0
        for idx in range(first, last + 1):
            g, q = idx // 4, idx % 4
            d0, d1 = a3_[q, g, r], a3_[q + 1, g, r]
            if not d0 * d1 > 0.0:
                row = np.inf
                break
            for e in range(2):
                qe = q + e
                rest = v0 * (abs(a_[qe, g, r]) * u_top + abs(b_[qe, g, r]) * x0 + abs(c_[qe, g, r]))
                row = max(row, (keep * lim_[qe, g, r] * (1.0 + SLACK) + rest) / abs(a3_[qe, g, r]))
        jerk = min(jerk, row)
    return u0 * u0 > 2.0 * jerk * v0


@njit(cache=True, nogil=True)
def _close_ok_at(st, xt, at, jerk, keep, keep3, grid, p2, p3, px):
    """Whether the close's state (theta st, x xt, u at, constant path jerk) meets the order-2 rows with ``keep`` and
    the order-3 rows with ``keep3`` of the limits."""
    lo, hi = _u_range(st, xt, keep, grid, p2, px)
    if not lo <= at <= hi:
        return False
    jlo, jhi = _j_range(st, xt, at, keep3, grid, p3)
    return jlo <= jerk <= jhi


@njit(cache=True, nogil=True)
def _close_time(s, v, a, jerk, period, target):
    """The time [s] at which the constant-jerk close from (s, v, a) reaches theta = target (bisection: theta(t)
    rises over the close)."""
    lo_t, hi_t = 0.0, period
    for _ in range(60):
        t = 0.5 * (lo_t + hi_t)
        if s + v * t + 0.5 * a * t * t + jerk * t**3 / 6.0 < target:
            lo_t = t
        else:
            hi_t = t
    return 0.5 * (lo_t + hi_t)


@njit(cache=True, nogil=True)
def _tail_ok(s, v, a, keep, keep3, s_end, grid, p2, p3, px):
    """Whether the constant-jerk close from (s, theta_dot v, u = a < 0) to rest ends before s_end and meets every
    row (order 2 with ``keep``, order 3 with ``keep3`` of the limits) at TAIL_POINTS points equal in time, at
    points CHECK_SPACING of each plan interval it spans apart, and on both sides of every plan grid point it passes
    (the rows jump there where the path's Phi''' does: a spline knot). The checks in an interval do not depend on
    the other intervals' lengths: a knot's sliver of an interval does not multiply the checks of the whole close."""
    if a >= 0.0:
        return False
    jerk = a * a / (2.0 * v)
    period = 2.0 * v / -a
    dist = v * period / 3.0
    if s + dist > s_end:
        return False
    g0 = min(max(np.searchsorted(grid, s, side="right") - 1, 0), grid.shape[0] - 2)
    g1 = min(max(np.searchsorted(grid, s + dist, side="right") - 1, g0), grid.shape[0] - 2)
    for i in range(TAIL_POINTS + 1):
        t = period * i / TAIL_POINTS
        st = s + v * t + 0.5 * a * t * t + jerk * t**3 / 6.0
        vt = v + a * t + 0.5 * jerk * t * t
        if not _close_ok_at(st, vt * vt, a + jerk * t, jerk, keep, keep3, grid, p2, p3, px):
            return False
    parts = int(round(1.0 / CHECK_SPACING))
    for k in range(g0, g1 + 1):  # inside every plan interval the close spans
        for i in range(1, parts):
            target = grid[k] + (grid[k + 1] - grid[k]) * i / parts
            if target <= s or target >= s + dist:
                continue
            t = _close_time(s, v, a, jerk, period, target)
            vt = v + a * t + 0.5 * jerk * t * t
            if not _close_ok_at(target, vt * vt, a + jerk * t, jerk, keep, keep3, grid, p2, p3, px):
                return False
    for k in range(g0 + 1, g1 + 1):  # the plan grid points inside the close, on both sides
        target = grid[k]
        t = _close_time(s, v, a, jerk, period, target)
        vt = v + a * t + 0.5 * jerk * t * t
        at = a + jerk * t
        left = target - 1e-12 * max(abs(target), 1.0)
        if not (_close_ok_at(target, vt * vt, at, jerk, keep, keep3, grid, p2, p3, px)
                and _close_ok_at(left, vt * vt, at, jerk, keep, keep3, grid, p2, p3, px)):
            return False
    return True


@njit(cache=True, nogil=True)
def _advance(s, v, a, jerk, dt):
    """(s, v, a) after dt at constant jerk."""
    return (s + v * dt + 0.5 * a * dt * dt + jerk * dt**3 / 6.0, v + a * dt + 0.5 * jerk * dt * dt,
            a + jerk * dt)


@njit(cache=True, nogil=True)
def _fit(s, v, a, jerk, dt, jlo, jhi, keep, keep3, grid, p2, p3, px):
    """The jerk of a step of length dt from (s, v, a), moved (END_PASSES times) into what the order-3 rows allow at
    both of its ends (jlo, jhi at its start), as the smooth profile realizes it: its u is linear along the
    step's theta, so its jerk at a point is the step's times the speed there over the step's mean speed; ``keep``
    of the order-2 limits, ``keep3`` of the order-3 ones. Returns (s, v, a) after it and whether the step meets
    every row (order 2 at its end too)."""
    for _ in range(END_PASSES + 1):
        s1, v1, a1 = _advance(s, v, a, jerk, dt)
        if v1 <= 0.0:
            return s1, v1, a1, False
        mean = (s1 - s) / dt
        elo, ehi = _j_range(s1, v1 * v1, a1, keep3, grid, p3)
        low = max(jlo * mean / v, elo * mean / v1)
        high = min(jhi * mean / v, ehi * mean / v1)
        if low > high:
            return s1, v1, a1, False
        if low <= jerk <= high:
            lo, hi = _u_range(s1, v1 * v1, keep, grid, p2, px)
            return s1, v1, a1, lo <= a1 <= hi
        inset = FIT_INSET * (high - low)  # inside: the bounds move a little with the jerk's end state
        jerk = min(max(jerk, low + inset), high - inset)
    return s1, v1, a1, False


@njit(cache=True, nogil=True)
def _step(s, v, a, keep, keep3, depth, dt, grid, p2, p3, px):
    """One braking step of length dt: the jerk that brings u towards ``depth`` times the least u the rows allow
    at the step's end, within the order-3 rows (_fit); (s, v, a) after it, and whether it meets the rows."""
    jlo, jhi = _j_range(s, v * v, a, keep3, grid, p3)
    if jlo > jhi:
        return s, v, a, False
    sp, vp = s + v * dt + 0.5 * a * dt * dt, v + a * dt
    jerk = 0.0
    for _ in range(END_PASSES):  # the target u where the step ends
        target = depth * _u_range(sp, vp * vp, keep, grid, p2, px)[0]
        jerk = min(max((target - a) / dt, jlo), jhi)
        sp, vp, _ = _advance(s, v, a, jerk, dt)
        if vp <= 0.0:
            break
    return _fit(s, v, a, jerk, dt, jlo, jhi, keep, keep3, grid, p2, p3, px)


@njit(cache=True, nogil=True)
def _up_step(s, v, a, keep, keep3, dt, grid, p2, p3, px):
    """One step of length dt at the largest jerk the order-3 rows allow (_fit); (s, v, a) after it and whether it
    meets the rows."""
    jlo, jhi = _j_range(s, v * v, a, keep3, grid, p3)
    if jlo > jhi:
        return s, v, a, False
    return _fit(s, v, a, jhi, dt, jlo, jhi, keep, keep3, grid, p2, p3, px)


@njit(cache=True, nogil=True, inline="always")
def _keep(k, share):
    """The share of the limits kept at braking step k: ``share`` (the state's own, at least 1 - MARGIN), fading to
    1 - MARGIN over FADE_STEPS steps."""
    fade = min(k / FADE_STEPS, 1.0)
    return max(share, 1.0 - MARGIN) * (1.0 - fade) + (1.0 - MARGIN) * fade


@njit(cache=True, nogil=True, inline="always")
def _dt(k, dt):
    """The length of step k [s]: dt, FADE_DT dt while the margin fades in (a step's profile realizes its jerk
    within about its share of the distance to the stop, which the margin covers only once it is in full)."""
    return dt * FADE_DT if k < FADE_STEPS else dt


@njit(cache=True, nogil=True)
def _brake(s0, x0, u0, share, share3, depth, recover, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u):
    """The braking steps from the state (aimed at ``depth`` times the least u the rows allow; ``share`` and
    ``share3`` the state's own shares of the order-2 and order-3 limits, see _keep) until a step
    breaks a row or reaches s_end (a tail from there would end after it): their points (the state first) into
    out_s, out_x, out_u; returns their number. With ``recover``, where a step breaks a row (the least u rises faster
    than the jerk rows let u follow), the braking goes back REWIND steps and aims shallower (RECOVER_DEPTH times,
    once more for every further break before it passes that point by REWIND steps; RECOVER_TRIES breaks in all),
    then at ``depth`` again."""
    s, v, a = s0, np.sqrt(x0), u0
    out_s[0], out_x[0], out_u[0] = s, x0, a
    k, dead, tries, breaks, top = 0, -1, 0, 0, min(out_s.shape[0] - 1, MAX_STEPS)
    while k < top:
        aim = depth * RECOVER_DEPTH ** tries if k < dead + REWIND else depth
        s, v, a, ok = _step(s, v, a, _keep(k, share), _keep(k, share3), aim, _dt(k, dt), grid, p2, p3, px)
        if recover and not ok and k >= REWIND and breaks < RECOVER_TRIES:
            tries = tries + 1 if k <= dead + REWIND else 1
            breaks, dead, k = breaks + 1, k, k - REWIND
            s, v, a = out_s[k], np.sqrt(out_x[k]), out_u[k]
            continue
        if not ok or s >= s_end:
            return k + 1
        out_s[k + 1], out_x[k + 1], out_u[k + 1] = s, v * v, a
        k += 1
    return min(out_s.shape[0], MAX_STEPS + 1)


@njit(cache=True, nogil=True)
def _tail(k, steps, best, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u, write):
    """The tails from braking point k: m = 0.. steps at the largest jerk (_up_step), then the constant-jerk close
    to rest (_tail_ok). Returns (m, stop point) of the one that stops first and before ``best``, (-1, best) when
    none; with ``write``, its m points after point k into out_s, out_x, out_u (``steps`` = that m)."""
    s, v, a = out_s[k], np.sqrt(out_x[k]), out_u[k]
    best_m = -1
    for m in range(steps + 1):
        keep, keep3 = _keep(k + m, share), _keep(k + m, share3)
        if a >= 0.0 or s >= best:
            break
        # the close's stop point moves back while the largest jerk is below the close's, then on: the first
        # close the jerk allows is the tail's best
        stop = s + 2.0 * v * v / (3.0 * -a)
        if not write and a * a / (2.0 * v) <= _j_range(s, v * v, a, keep3, grid, p3)[1]:
            if stop >= best:
                break
            if _tail_ok(s, v, a, keep, keep3, s_end, grid, p2, p3, px):
                best_m, best = m, stop
                break
        if m == steps:
            break
        s, v, a, ok = _up_step(s, v, a, keep, keep3, _dt(k + m, dt), grid, p2, p3, px)
        if not ok:
            break
        if write:
            out_s[k + m + 1], out_x[k + m + 1], out_u[k + m + 1] = s, v * v, a
    if write:
        return steps, s + 2.0 * v * v / (3.0 * -a)
    return best_m, best


@njit(cache=True, nogil=True)
def _best_switch(n, best, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u):
    """(k, m, stop point) of the braking point k < n and tail (_tail) that stop first: braking points at a stride
    of n / COARSE, then halving strides around the best; k = -1 when none stops before ``best``."""
    bk, bm = -1, -1
    stride = max(n // COARSE, 1)
    for k in range(0, n, stride):
        m, stop = _tail(k, MAX_STEPS, best, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u, False)
        if m >= 0:
            bk, bm, best = k, m, stop
    while stride > 1 and bk >= 0:
        stride //= 2
        centre = bk
        for k in (centre - stride, centre + stride):
            if 0 <= k < n:
                m, stop = _tail(k, MAX_STEPS, best, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u,
                                False)
                if m >= 0:
                    bk, bm, best = k, m, stop
    return bk, bm, best


@njit(cache=True, nogil=True)
def shortest(s0, x0, u0, share, share3, s_end, grid, p2, p3, px, out_s, out_x, out_u):
    """The stop of the least distance: for the braking depths of DEPTHS (until DEPTH_MISSES in a row stop no
    sooner) the braking (_brake) and its best switch to a tail (_best_switch). Fills out_s, out_x, out_u with
    its points (the state first, the close's start last) and returns (their number, the stop point); (-1, inf)
    when none is found. ``share``, ``share3``: the share of the order-2 and of the order-3 limits the state may
    take (see _keep; the state's own, :func:`state_share` and :func:`jerk_share`), where it does not leave the
    margin itself."""
    v = np.sqrt(x0)
    share, share3 = _start_shares(s0, x0, u0, share, share3, grid, p2, p3, px)
    lo, hi = _u_range(s0, x0, share, grid, p2, px)
    jlo, jhi = _j_range(s0, x0, u0, share3, grid, p3)
    if not lo <= u0 <= hi or jlo > jhi or lo >= 0.0:
        return -1, np.inf
    # time step: turn to the least u, brake at it, close; once more with the step the first answer's number of
    # steps calls for, where it took fewer than MIN_STEPS (the estimate overshot)
    period = v / -lo + abs(u0 - lo) / max(-jlo, 1e-12) + 2.0 * abs(lo) / max(-jlo, jhi, 1e-12)
    dt = min(max(period / STEPS_PER_STOP, DT_MIN), DT_MAX)
    n, stop = _search(s0, x0, u0, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u)
    if 0 <= n < MIN_STEPS and dt > DT_MIN:
        dt = max(dt * n / STEPS_PER_STOP, DT_MIN)
        n, stop = _search(s0, x0, u0, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u)
    return n, stop


@njit(cache=True, nogil=True)
def _search(s0, x0, u0, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u):
    """:func:`shortest` with the time step dt [s]: the braking at the full depth without and with its recovery
    (_brake), then at the other depths of DEPTHS."""
    best, best_depth, best_recover, bk, bm, misses = np.inf, -1.0, False, -1, -1, 0
    for d in range(DEPTHS.shape[0] + 1):
        depth, recover = DEPTHS[max(d - 1, 0)], d == 1
        n = _brake(s0, x0, u0, share, share3, depth, recover, min(s_end, best), dt, grid, p2, p3, px, out_s, out_x,
                   out_u)
        k, m, stop = _best_switch(n, best, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u)
        if k < 0:
            misses += best_depth > 0.0 and not recover
            if misses == DEPTH_MISSES:  # the stops lengthen with a shallower depth from here
                break
            continue
        best, best_depth, best_recover, bk, bm, misses = stop, depth, recover, k, m, 0
    if best_depth < 0.0 or bk + bm + 2 > out_s.shape[0]:
        return -1, np.inf
    _brake(s0, x0, u0, share, share3, best_depth, best_recover, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u)
    _, stop = _tail(bk, bm, np.inf, share, share3, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u, True)
    return bk + bm + 1, stop


@njit(cache=True, nogil=True)
def _x_to_rest(g, un, x0):
    """x (K,) of the smooth profile at rest at g[-1] only, u = un (K,) linear in xi = (g[-1] - theta)^(1/3) per
    interval, from x0: x_{k+1} = x_k + 2 (w0_k u_k + w1_k u_{k+1}) with the weights of planning/smooth.py (every
    interval's xi measured from the rest point)."""
    stop = g[-1]
    xs = np.empty(g.shape[0])
    xs[0] = x0
    for k in range(g.shape[0] - 1):
        d0, d1 = stop - g[k], stop - g[k + 1]
        xi0, xi1 = np.cbrt(d0), np.cbrt(d1)
        w1 = (0.75 * (d0 ** (4.0 / 3.0) - d1 ** (4.0 / 3.0)) - xi0 * (g[k + 1] - g[k])) / (xi1 - xi0)
        xs[k + 1] = xs[k] + 2.0 * ((g[k + 1] - g[k] - w1) * un[k] + w1 * un[k + 1])
    return xs


def profile_of(s, x, u, s_end, grid, p2, p3, px, keep=1.0 - MARGIN):
    """(grid, x, u_nodes) of the smooth profile through the braking and tail points (s, u) (n,) from the state's x
    (x[0]), u linear in xi = (stop - theta)^(1/3) on every interval (planning/smooth.py), x from it (x_{k+1} =
    x_k + 2 (w0_k u_k + w1_k u_{k+1})), and the constant-jerk close from the last point (TAIL_INTERVALS
    intervals equal in xi) to rest at stop = s[-1] + 2 x[-1] / (3 |u[-1]|) with that x (CLOSE_ITERATIONS fixed-
    point iterations: the coordinates depend on the stop). None when the close from that state breaks a row or
    an x <= 0 comes before the stop."""
    xs = x[:-1].copy()
    x_sw = x[-1]
    for _ in range(CLOSE_ITERATIONS):
        stop = s[-1] + 2.0 * x_sw / (3.0 * -u[-1])
        xi_sw = np.cbrt(stop - s[-1])
        xi = xi_sw * (1.0 - np.arange(1, TAIL_INTERVALS + 1) / TAIL_INTERVALS)
        g = np.concatenate([s, stop - xi[:-1] ** 3, [stop]])
        un = np.concatenate([u, u[-1] * xi / xi_sw])
        xs = _x_to_rest(g, un, x[0])
        x_sw = xs[len(s) - 1]
    if x_sw <= 0.0 or np.any(xs[:len(s)] <= 0.0):
        return None
    if not _tail_ok(s[-1], np.sqrt(x_sw), u[-1], keep, keep, s_end, grid, p2, p3, px):
        return None
    xs[len(s):-1] = x_sw * (xi[:-1] / xi_sw) ** 4  # the close's x, exact
    xs[-1] = 0.0
    return g, xs, un


# ------------------------------------------------------------------------------------ backward pass from rest

#: Fixed-point passes of a backward step's start [-].
BACK_PASSES = 1
#: Iterations on the stop point (each moves it by the gap between the braking and the backward pass) [-].
MEET_ITERATIONS = 12
#: The iterations end when the gap is below this fraction of the stop distance [-].
MEET_TOLERANCE = 1e-5
#: The backward pass's points closer to rest than this share of the stop distance are left to the constant-jerk
#: close from the last point before them (profile_of) [-].
CLOSE_SHARE = 0.01
#: Backward points tried as the end of the join from the braking [-].
JOIN_POINTS = 40


@njit(cache=True, nogil=True, inline="always")
def _narrow(low, high, q, bot, top):
    """[low, high] narrowed to the y with bot <= q y <= top (empty: low > high)."""
    if q > 0.0:
        return max(low, bot / q), min(high, top / q)
    if q < 0.0:
        return max(low, top / q), min(high, bot / q)
    if top < 0.0 or bot > 0.0:
        return np.inf, -np.inf
    return low, high


@njit(cache=True, nogil=True)
def _u_before(sp, xp, kp, u, ke, s, x, keep, grid, p2, p3, px):
    """(least, largest) u at the start (sp, xp) of a step that ends at (s, x, u): the order-2 rows at its start,
    and the order-3 rows at both ends with the step's jerk as the smooth profile realizes it there, (u - u_start)
    kp at the start and (u - u_start) ke at the end (linear in u_start)."""
    low, high = _u_range(sp, xp, keep, grid, p2, px)
    a3_, a_, b_, c_, lim_ = p3
    for end in range(2):
        pt, xt, k = (sp, xp, kp) if end == 0 else (s, x, ke)
        g, q, w = _locate(pt, grid)
        sx = np.sqrt(max(xt, 0.0))
        for r in range(a3_.shape[2]):
            a3, a = _at(a3_, q, g, r, w), _at(a_, q, g, r, w)
            lim = keep * _at(lim_, q, g, r, w) * (1.0 + SLACK)
            rest = sx * (_at(b_, q, g, r, w) * xt + _at(c_, q, g, r, w)) + a3 * k * u
            coef = -a3 * k + (sx * a if end == 0 else 0.0)
            if end == 1:
                rest += sx * a * u
            low, high = _narrow(low, high, coef, -lim - rest, lim - rest)
    return low, high


@njit(cache=True, nogil=True)
def _back_step(s, v, u, keep, dt, grid, p2, p3, px):
    """The start (s, v, u) of the step of length dt that ends at (s, v, u) with the least u there the rows allow
    (the hardest braking: the backward pass's greedy choice); ok False when the rows allow none."""
    up, vp = u, v - dt * u
    sp = s
    for _ in range(BACK_PASSES + 1):
        sp = s - (vp * dt + 0.5 * up * dt * dt + (u - up) * dt * dt / 6.0)
        mean = (s - sp) / dt
        if vp <= 0.0 or mean <= 0.0:
            return sp, vp, up, False
        lo, hi = _u_before(sp, vp * vp, vp / (mean * dt), u, v / (mean * dt), s, v * v, keep, grid, p2, p3, px)
        if lo > hi:
            return sp, vp, up, False
        up = lo
        vp = v - 0.5 * dt * (u + up)
    sp = s - (vp * dt + 0.5 * up * dt * dt + (u - up) * dt * dt / 6.0)
    mean = (s - sp) / dt
    if vp <= v or mean <= 0.0:
        return sp, vp, up, False
    # the range where the step starts now: u moved into it (by the fixed point's last change, well inside the
    # margin), the start moved with it
    lo, hi = _u_before(sp, vp * vp, vp / (mean * dt), u, v / (mean * dt), s, v * v, keep, grid, p2, p3, px)
    if lo > hi:
        return sp, vp, up, False
    up = min(max(up, lo), hi)
    vp = v - 0.5 * dt * (u + up)
    sp = s - (vp * dt + 0.5 * up * dt * dt + (u - up) * dt * dt / 6.0)
    return sp, vp, up, vp > v


@njit(cache=True, nogil=True)
def _backward(s_end, v_top, s_low, keep, dt, grid, p2, p3, px, bs, bv, bu):
    """The backward pass from rest at s_end: the constant-jerk close (the largest jerk the order-3 rows allow at
    rest) over the first step, then _back_step, until its speed passes v_top, it passes s_low or the rows allow
    no step. Its points (rest excluded, speed rising) into bs, bv, bu; returns their number."""
    jerk = _j_range(s_end, 0.0, 0.0, keep, grid, p3)[1]
    if not jerk > 0.0:
        return 0
    s, v, u = s_end - jerk * dt**3 / 6.0, 0.5 * jerk * dt * dt, -jerk * dt
    n = 0
    while n < bs.shape[0]:
        bs[n], bv[n], bu[n] = s, v, u
        n += 1
        if v > v_top or s < s_low:
            break
        s, v, u, ok = _back_step(s, v, u, keep, dt, grid, p2, p3, px)
        if not ok:
            break
    return n


@njit(cache=True, nogil=True)
def _contact(n, fs, fx, fu, nb, bs, bv, bu):
    """(gap, k, b): the least gap s_B(v) - s_F over the braking points k < n (fs, fx = v^2, fu) that brake (u < 0)
    at a speed the backward pass (bs, bv, bu; nb points, speed rising) reaches, s_B at the speed of F's point
    interpolated between backward points b and b + 1; (inf, -1, -1) when no such point."""
    best, bk, bb = np.inf, -1, -1
    if nb < 2:
        return best, bk, bb
    for k in range(n):
        v = np.sqrt(fx[k])
        if fu[k] >= 0.0 or v > bv[nb - 1] or v < bv[0]:
            continue
        b = max(min(np.searchsorted(bv[:nb], v) - 1, nb - 2), 0)
        w = (v - bv[b]) / (bv[b + 1] - bv[b])
        gap = (1.0 - w) * bs[b] + w * bs[b + 1] - fs[k]
        if gap < best:
            best, bk, bb = gap, k, b
    return best, bk, bb


@njit(cache=True, nogil=True)
def _b_u(s, nb, bs, bu):
    """u of the backward pass (nb points, s falling with the index) at s, linear between its points; its first
    point's u below them, its last's above."""
    if s >= bs[0]:
        return bu[0]
    if s <= bs[nb - 1]:
        return bu[nb - 1]
    lo, hi = 0, nb - 1  # bs[lo] > s >= bs[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if bs[mid] > s:
            lo = mid
        else:
            hi = mid
    w = (bs[lo] - s) / (bs[lo] - bs[hi])
    return (1.0 - w) * bu[lo] + w * bu[hi]


@njit(cache=True, nogil=True)
def _join_ok(s0, x0, u0, s1, v1, u1, keep, grid, p3):
    """Whether the step from (s0, x0, u0) to (s1, v1, u1) (u linear in theta) meets the order-3 rows at both ends."""
    v0 = np.sqrt(x0)
    mean = 0.5 * (v0 + v1)
    jerk = (u1 - u0) * mean / (s1 - s0)
    for end in range(2):
        s, v, u = (s0, v0, u0) if end == 0 else (s1, v1, u1)
        jlo, jhi = _j_range(s, v * v, u, keep, grid, p3)
        if not jlo <= jerk * v / mean <= jhi:
            return False
    return True


@njit(cache=True, nogil=True)
def _meet(n, s_end_max, keep, dt, grid, p2, p3, px, out_s, out_x, out_u, bs, bv, bu):
    """The stop from the braking points 0..n-1 in out_s, out_x, out_u: the stop point s_end whose backward pass
    (_backward) touches them (moved by the gap, MEET_ITERATIONS times at most, from where the braking comes to
    rest), and the stop's points (the braking up to the contact, then the backward pass's beyond it) written
    into out_s, out_x, out_u. Returns (their number, s_end); (-1, inf) when the passes do not touch before
    s_end_max or the join breaks a row."""
    v_top, last = 0.0, -1
    for k in range(n):
        if out_u[k] < 0.0:
            v_top, last = max(v_top, np.sqrt(out_x[k])), k
    if last < 0:
        return -1, np.inf
    s_end = out_s[last] + 2.0 * out_x[last] / (3.0 * -out_u[last])
    distance = s_end - out_s[0]
    gap, k, b, nb = np.inf, -1, -1, 0
    for _ in range(MEET_ITERATIONS):
        s_end = min(s_end, s_end_max)
        nb = _backward(s_end, v_top, out_s[0], keep, dt, grid, p2, p3, px, bs, bv, bu)
        gap, k, b = _contact(n, out_s, out_x, out_u, nb, bs, bv, bu)
        if k < 0 or (s_end >= s_end_max and gap < 0.0):
            return -1, np.inf
        if abs(gap) <= MEET_TOLERANCE * distance:
            break
        s_end -= gap
    if k < 0 or abs(gap) > MEET_TOLERANCE * distance:
        return -1, np.inf
    # the join where the braking's u crosses the backward pass's (tangent in speed, u continuous): a point
    # inserted there, the backward pass's points after it
    c, sc, xc, uc = -1, 0.0, 0.0, 0.0
    for o in range(2 * JOIN_POINTS):  # the crossing nearest to the contact
        i = k + (o + 1) // 2 * (1 if o % 2 else -1)
        if i < 0 or i >= n - 1:
            continue
        d0 = out_u[i] - _b_u(out_s[i], nb, bs, bu)
        d1 = out_u[i + 1] - _b_u(out_s[i + 1], nb, bs, bu)
        if d0 >= 0.0 > d1:
            w = d0 / (d0 - d1)
            c = i
            sc = (1.0 - w) * out_s[i] + w * out_s[i + 1]
            xc = (1.0 - w) * out_x[i] + w * out_x[i + 1]
            uc = (1.0 - w) * out_u[i] + w * out_u[i + 1]
            break
    if c >= 0:
        k = c + 1
        out_s[k], out_x[k], out_u[k] = sc, xc, uc
        b = nb - 1
    while b >= 0 and bs[b] <= out_s[k] + 1e-6 * distance:
        b -= 1
    # without a crossing (the braking ends on the backward pass): the first backward point whose step from the
    # contact the order-3 rows allow at both ends
    for _ in range(JOIN_POINTS if c < 0 else 0):
        if b < 0 or _join_ok(out_s[k], out_x[k], out_u[k], bs[b], bv[b], bu[b], keep, grid, p3):
            break
        b -= 1
    if b < 0:
        return -1, np.inf
    m = k + 1
    for i in range(b, -1, -1):  # the points closer to rest than CLOSE_SHARE of the distance: the close's
        if s_end - bs[i] < CLOSE_SHARE * distance and i < b:
            break
        if m >= out_s.shape[0]:
            return -1, np.inf
        out_s[m], out_x[m], out_u[m] = bs[i], bv[i] ** 2, bu[i]
        m += 1
    return m, s_end


@njit(cache=True, nogil=True)
def profile_ok(g, xs, un, keep, start_keep, start_keep3, grid, p2, p3, px):
    """Whether the smooth stop profile (g, xs, un) (K,), u linear in xi = (g[-1] - theta)^(1/3) per interval,
    meets the order-2 rows at its points and the order-3 rows at both ends of every interval but the last, with
    ``keep`` of the limits (``start_keep`` of the order-2 and ``start_keep3`` of the order-3 limits over the first
    FADE_STEPS intervals: the state's own shares)."""
    stop = g[-1]
    keep3 = keep
    for i in range(g.shape[0] - 2):
        if i == 0:
            keep, keep3, later = start_keep, start_keep3, keep
        elif i == FADE_STEPS:
            keep, keep3 = later, later
        lo, hi = _u_range(g[i], xs[i], keep, grid, p2, px)
        if not lo <= un[i] <= hi:
            return False
        xa, xb = np.cbrt(stop - g[i]), np.cbrt(stop - g[i + 1])
        slope = (un[i + 1] - un[i]) / (xb - xa)
        for e in range(2):
            s, x, u, xi = (g[i], xs[i], un[i], xa) if e == 0 else (g[i + 1], xs[i + 1], un[i + 1], xb)
            if x <= 0.0 or xi <= 0.0:
                continue
            jerk = -slope * np.sqrt(x) / (3.0 * xi * xi)
            jlo, jhi = _j_range(s, x, u, keep3, grid, p3)
            if not jlo <= jerk <= jhi:
                return False
    return True


@njit(cache=True, nogil=True)
def shortest_met(s0, x0, u0, share, share3, s_end, first, grid, p2, p3, px, out_s, out_x, out_u, bs, bv, bu):
    """The stop where the braking from the state meets the backward pass from rest: for the braking depths of
    DEPTHS from index ``first`` on, the first that meets (_meet). Returns (the number of points in out_s, out_x,
    out_u, the stop point, the depth's index); (-1, inf, -1) when none meets."""
    v = np.sqrt(x0)
    share, share3 = _start_shares(s0, x0, u0, share, share3, grid, p2, p3, px)
    lo, hi = _u_range(s0, x0, share, grid, p2, px)
    jlo, jhi = _j_range(s0, x0, u0, share3, grid, p3)
    if not lo <= u0 <= hi or jlo > jhi or lo >= 0.0:
        return -1, np.inf, -1
    period = v / -lo + abs(u0 - lo) / max(-jlo, 1e-12) + 2.0 * abs(lo) / max(-jlo, jhi, 1e-12)
    dt = min(max(period / STEPS_PER_STOP, DT_MIN), DT_MAX)
    m, stop, steps, d = _met_search(s0, x0, u0, share, share3, s_end, first, dt, grid, p2, p3, px, out_s, out_x,
                                    out_u, bs, bv, bu)
    if 0 <= steps < MIN_STEPS and dt > DT_MIN:
        dt = max(dt * steps / STEPS_PER_STOP, DT_MIN)
        m, stop, _, d = _met_search(s0, x0, u0, share, share3, s_end, first, dt, grid, p2, p3, px, out_s, out_x,
                                    out_u, bs, bv, bu)
    return m, stop, d


@njit(cache=True, nogil=True)
def _met_search(s0, x0, u0, share, share3, s_end, first, dt, grid, p2, p3, px, out_s, out_x, out_u, bs, bv, bu):
    """:func:`shortest_met` with the time step dt [s]: (points, stop point, the steps of the braking to the
    contact and of the backward pass beyond it, the depth's index) of the first depth from ``first`` on that
    meets; (-1, inf, steps of the longest braking, -1) when none."""
    most = 0
    for d in range(first, DEPTHS.shape[0]):
        n = _brake(s0, x0, u0, share, share3, DEPTHS[d], False, s_end, dt, grid, p2, p3, px, out_s, out_x, out_u)
        most = max(most, n)
        m, stop = _meet(n, s_end, 1.0 - MARGIN, dt, grid, p2, p3, px, out_s, out_x, out_u, bs, bv, bu)
        if m > 0:
            return m, stop, m + int((stop - out_s[m - 1]) / max(out_s[m - 1] - out_s[m - 2], 1e-300)), d
    return -1, np.inf, most, -1
