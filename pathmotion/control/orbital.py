"""Orbital stabilization of a planned motion (Shiriaev, Perram, Canudas-de-Wit 2005; Shiriaev,
Freidovich, Gusev 2010), for a fully actuated arm with a computed-torque inner loop.

Per sample (docs/control.md has the equations):

1. project the measured q onto the path near the previous theta -> theta, theta_dot, x_perp = (xi, z, z_dot, I)
   (xi = int z dt, the integral action, when ``OrbitalGains.integral_rate`` > 0);
2. v = v*(theta_m) - K(theta) x_perp, v* = Phi' u* + Phi'' x*, evaluated at theta_m = theta + theta_dot Ts/2
   (the middle of the coming hold interval), K from the Riccati equation of the transverse linearization;
3. tau = M(q) v + C(q, qd) qd + G(q) with the nominal model, plus (``identify_payload``) the identified payload's
   torque and the identified friction at the planned joint velocity (:mod:`.payload`), plus the disturbance
   observer's estimate of what is left (:mod:`.observer`).

Steps 1-2 are one compiled call (:func:`.kernels.orbital_command`). The clock never enters steps 1-3. Near stops (open
paths: the ends, kinks) the plan is played on the clock with the same closed-loop poles (and integral
action on the joint error), and the final configuration is then held; the integral state is carried
across the switches (xi = E^T xi_q one way, xi_q = E xi the other).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.linalg import solve_continuous_are, solve_discrete_are

from .. import defaults
from ..errors import SimulationError, require_finite
from ..planning.profile import Profile
from ..robot import Robot
from .gains import OrbitalGains
from .laws import computed_torque
from .observer import DisturbanceObserver, observer_gain
from .payload import PayloadEstimator
from .kernels import clock_command, orbital_command
from .path_table import PathTable
from .profile_lookup import ProfileLookup
from .riccati import sampled_cost, solve_discrete_riccati, solve_riccati, with_delay
from .threads import blas_single_threaded
from .transverse import ZERO_SPEED, TransverseBasis, transverse_linearization

log = logging.getLogger(__name__)

#: Relative mismatch allowed between the profile's and the path's theta ends, and between the start and end
#: speeds of a periodic profile [-].
DOMAIN_MATCH = 1e-9
#: An open segment's last sample shorter than this fraction of the sample time is merged into the one before [-].
SAMPLE_MERGE = 0.25
#: Sampled design: consecutive sample thetas are pushed apart by this times the path length (at rest the
#: profile gives equal thetas; the design needs them strictly increasing) [-].
SAMPLE_SEPARATION = 1e-12
#: Floor of the speed scale a periodic profile's end mismatch is measured against [rad^2/s^2].
SPEED2_FLOOR = 1e-12


def integral_size(gains: OrbitalGains, n: int) -> int:
    """Number of integral states xi = (int z dt (n-1), int I dt (1)): n with integral action, else 0."""
    return n if gains.integral_rate > 0 else 0


def lqr_weights(gains: OrbitalGains, dphi: np.ndarray, x_star: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q (N, d, d) and R (n, n) along the path from Phi' (N, n) and x* (N,); d = 2n - 1, or 3n - 1 with
    integral action (state (xi_z, xi_I, z, z_dot, I), xi_z = int z dt, xi_I = int I dt).

    Q = diag(q_xi I, q_xiI, q_z I, q_zdot I, q_I) with (q_xi, q_z, q_zdot) = ``gains.chain_weights``,
    q_I = (lambda^2 + lambda_i^2) / b^2, q_xiI = lambda^2 lambda_i^2 / b^2, 1 / b^2 = |Phi'|^4 / (4 max(|Phi'|^2 x*,
    v_min^2)), R = I: I weighted as the joint speed error along the path it means, |Phi'|^2 I / (2 |q_dot*|);
    lambda = speed_rate, lambda_i = integral_rate: the scalar chain I_dot = b u closes with (s + lambda)(s + lambda_i).
    """
    big, n = dphi.shape
    m = n - 1
    ni = integral_size(gains, n)
    q_xi, q_z, q_zd = gains.chain_weights
    speed2 = np.sum(dphi * dphi, axis=1)
    inv_b2 = speed2**2 / (4.0 * np.maximum(speed2 * x_star, gains.min_speed**2))
    lam, lam_i = gains.speed_rate, gains.integral_rate
    q_i = (lam**2 + lam_i**2) * inv_b2
    xi_cols = [np.full((big, m), q_xi), (lam * lam_i) ** 2 * inv_b2[:, None]] if ni else []
    diag = np.concatenate([*xi_cols, np.full((big, m), q_z), np.full((big, m), q_zd), q_i[:, None]], axis=1)
    d = ni + 2 * m + 1
    q = np.zeros((big, d, d))
    idx = np.arange(d)
    q[:, idx, idx] = diag
    return q, np.eye(n)


def with_integral(a: np.ndarray, b: np.ndarray, ni: int) -> tuple[np.ndarray, np.ndarray]:
    """The transverse linearization (a (N, d, d), b (N, d, n), state (z, z_dot, I)) augmented with ``ni``
    (0 or n) integral states xi_z' = z, xi_I' = I: state (xi_z, xi_I, z, z_dot, I)."""
    if ni == 0:
        return a, b
    big, d, n = b.shape
    m = n - 1
    aa = np.zeros((big, d + ni, d + ni))
    aa[:, ni:, ni:] = a
    aa[:, np.arange(m), ni + np.arange(m)] = 1.0
    aa[:, m, -1] = 1.0
    bb = np.zeros((big, d + ni, n))
    bb[:, ni:, :] = b
    return aa, bb


def clock_zones(times: np.ndarray, joint_speed: np.ndarray, min_speed: float, window: float, duration: float,
                arrivals: np.ndarray | None = None, min_gap: float = 0.0) -> tuple[tuple[float, float], ...]:
    """Planned-time intervals [s] where the planned joint speed |Phi'| sqrt(x*) (at the grid times (M,), the
    departure times; ``arrivals`` (M,) the arrival times where the plan waits, default the same) is below
    ``min_speed``, widened by ``window`` on each side, merged and sorted. Zones less than ``min_gap`` [s] apart
    are merged too: a sampled controller cannot take one whole sample on the orbit between them."""
    arrivals = times if arrivals is None else arrivals
    slow = joint_speed < min_speed
    edges = np.diff(np.concatenate([[0], slow.astype(int), [0]]))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0] - 1
    zones: list[list[float]] = []
    for a, b in zip(starts, stops):
        z0, z1 = max(0.0, arrivals[a] - window), min(duration, times[b] + window)
        if zones and z0 <= zones[-1][1] + min_gap:
            zones[-1][1] = max(zones[-1][1], z1)
        else:
            zones.append([z0, z1])
    return tuple((float(a), float(b)) for a, b in zones)


def orbital_segments(times: np.ndarray, zones: tuple, duration: float, shortest: float):
    """(zones, in_zone (M,) bool, segments): the grid runs [i0, i1) of ``times`` (M,) [s] outside the clock
    ``zones``, where the orbital law runs. A run shorter than ``shortest`` [s] (a sampled design needs two samples on the orbit) joins
    the zones around it; without any run left the whole plan [0, ``duration``] is one zone (a short move)."""
    zones = [list(z) for z in zones]
    while True:
        in_zone = np.zeros(len(times), bool)
        for z0, z1 in zones:
            in_zone |= (times >= z0) & (times <= z1)
        segments = _runs(~in_zone)
        short = next(((i0, i1) for i0, i1 in segments if times[i1 - 1] - times[i0] < shortest), None)
        if short is None or not zones:
            break
        before = [k for k, (_, z1) in enumerate(zones) if z1 <= times[short[0]]]
        after = [k for k, (z0, _) in enumerate(zones) if z0 >= times[short[1] - 1]]
        lo = zones[before[-1]][0] if before else 0.0
        hi = zones[after[0]][1] if after else duration
        zones = [z for k, z in enumerate(zones) if k not in before[-1:] + after[:1]] + [[lo, hi]]
        zones.sort()
    if not segments:
        zones, in_zone = [[0.0, duration]], np.ones(len(times), bool)
    return tuple((float(a), float(b)) for a, b in zones), in_zone, segments


@dataclass(frozen=True, eq=False)
class RiccatiKnots:
    """P(theta) of one orbital segment: the design grid's points start..stop-1 take P linear in theta between
    ``knots`` (K,) with values ``values`` (K, d, d) (held beyond the first and last knot)."""

    start: int
    stop: int
    knots: np.ndarray
    values: np.ndarray


@dataclass(frozen=True, eq=False)
class OrbitalDesign:
    """Everything the orbital controller precomputes: path table, profile, basis and gain schedule.

    theta (M,) gain grid (the table grid); gain (M, n, 2n-1) K(theta) (outside the orbital segments
    the nearest segment's end value); riccati_knots: P(theta) per orbital segment at its Riccati knots (the
controller reads K only; :attr:`riccati` puts P on the grid when asked);
    zones: planned-time intervals [s] where the planned joint speed is below ``min_speed`` (rest points,
    path ends, clamped spline ends where Phi' = 0), widened by ``terminal_time_to_go``: there the transverse
    coordinates degenerate and the plan is played on the clock.
    """

    table: PathTable
    profile: ProfileLookup
    basis: TransverseBasis
    gains: OrbitalGains
    theta: np.ndarray
    gain: np.ndarray
    riccati_knots: tuple[RiccatiKnots, ...]
    zones: tuple[tuple[float, float], ...]

    @cached_property
    def riccati(self) -> np.ndarray:
        """P(theta) (M, d, d) on the grid, zero outside the orbital segments: interpolated from the knots on first
        use (an 8.5 MB stack at 4 ms with one sample of delay that the controller never reads)."""
        d = self.gain.shape[2]
        out = np.zeros((len(self.theta), d, d))
        for seg in self.riccati_knots:
            out[seg.start:seg.stop] = _interpolate(seg.knots, self.theta[seg.start:seg.stop], seg.values)
        return out

    @classmethod
    @blas_single_threaded
    def build(cls, table: PathTable, profile: Profile, gains: OrbitalGains = OrbitalGains(),
              sample_time: float | None = None, delay: int = 0) -> "OrbitalDesign":
        """The design on ``table`` for ``profile``: continuous-time LQR gains (``sample_time`` None), or gains
        of the sampled system at ``sample_time`` [s] with the command applied ``delay`` samples late (the gain
        then also acts on the ``delay`` commands in flight: state (xi, z, z_dot, I, dv_{k-delay}, ..., dv_{k-1}))."""
        lookup = ProfileLookup(profile, closed=table.closed)
        lo, hi = table.domain
        if abs(profile.grid[0] - lo) > DOMAIN_MATCH * table.length or abs(profile.grid[-1] - hi) > DOMAIN_MATCH * table.length:
            raise SimulationError(
                f"the profile covers theta in [{profile.grid[0]:.6g}, {profile.grid[-1]:.6g}] but the path's domain is "
                f"[{lo:.6g}, {hi:.6g}]; plan the profile on this path"
            )
        if table.closed:
            if abs(profile.x[0] - profile.x[-1]) > DOMAIN_MATCH * max(profile.x.max(), SPEED2_FLOOR):
                raise SimulationError(
                    f"closed path: the profile must be periodic, x*(start) = {profile.x[0]:.6g} but "
                    f"x*(end) = {profile.x[-1]:.6g} (theta_dot^2)"
                )
            if np.any(profile.x <= 0):
                i = int(np.argmax(profile.x <= 0))
                raise SimulationError(
                    f"closed path: the periodic profile stops at theta = {profile.grid[i]:.6g}; the orbital controller "
                    "needs a periodic motion that never stops (blend the corner or open the path there)"
                )
        theta = table.grid
        times = lookup.times(theta)
        if table.closed:
            times[-1] = lookup.duration
        _, dphi_grid, _ = table.evaluate(theta)
        x_grid = lookup.states(theta)[:, 0]
        joint_speed = np.linalg.norm(dphi_grid, axis=1) * np.sqrt(x_grid)
        zones = () if table.closed else clock_zones(times, joint_speed, gains.min_speed, gains.terminal_time_to_go,
                                                    lookup.duration, times - profile.holds_at(theta),
                                                    sample_time or 0.0)
        zones, in_zone, segments = orbital_segments(times, zones, float(lookup.duration), 2.0 * (sample_time or 0.0))
        if not segments:
            log.info("orbital design: every point is within %g s of a stop; the whole motion is played on the clock",
                     gains.terminal_time_to_go)
        m = table.n - 1
        ni = integral_size(gains, table.n)
        d = ni + 2 * m + 1 + (delay * table.n if sample_time is not None else 0)
        gain = np.zeros((len(theta), table.n, d))
        riccati = []
        active = (np.concatenate([np.arange(i0, i1) for i0, i1 in segments]) if segments
                  else np.nonzero(np.linalg.norm(dphi_grid, axis=1) > ZERO_SPEED)[0])
        basis = TransverseBasis.for_table(table, theta[active])
        for i0, i1 in segments:
            sl = slice(i0, i1)
            if sample_time is not None:
                gain[sl], p = discrete_segment(table, basis, lookup, gains, theta[sl], times[sl], sample_time, delay)
            else:
                gain[sl], p = continuous_segment(table, basis, lookup, gains, theta[sl], times[sl])
            riccati.append(RiccatiKnots(i0, i1, *p))
        # outside the segments: hold the nearest segment-end gain (used only at zone edges)
        idx = np.where(~in_zone, np.arange(len(theta)), -1)
        fwd = np.maximum.accumulate(idx)
        first = active[0]
        fwd[fwd < 0] = first
        gain = gain[fwd]
        require_finite(gain.reshape(len(theta), -1), "orbital feedback gain K(theta)", "lower simulate.gains "
                       "(bandwidth, speed_rate, integral_rate) or check the plan's speed profile", SimulationError)
        return cls(table, lookup, basis, gains, theta, gain, tuple(riccati), zones)

    def zone_at(self, planned_time: float, first: int = 0) -> int | None:
        """Index (>= first) of the clock zone containing ``planned_time`` [s], or None."""
        for i in range(first, len(self.zones)):
            z0, z1 = self.zones[i]
            if z0 <= planned_time <= z1:
                return i
        return None


def design_knots(times: np.ndarray, spacing: float) -> np.ndarray:
    """Indices into ``times`` (M,) [s] of the Riccati knots: the first and last point and the points where
    t // spacing changes, so consecutive knots are about ``spacing`` [s] apart (all points when denser)."""
    cell = np.floor((times - times[0]) / spacing)
    keep = np.concatenate([[True], cell[1:] != cell[:-1]])
    keep[-1] = True
    return np.nonzero(keep)[0]


def continuous_segment(table, basis, lookup, gains, theta, times):
    """Gains K = R^-1 B^T P (M, n, d) of the continuous-time design on one orbital segment at its grid points
    ``theta`` (M,) with planned ``times`` (M,) [s], and (knots (K,), P (K, d, d)): the Riccati equation is
    integrated on knots ``defaults.RICCATI_KNOT_TIME`` apart (:func:`design_knots`), K and P linear in theta in
    between."""
    ni = integral_size(gains, table.n)
    knots = design_knots(times, defaults.RICCATI_KNOT_TIME)
    th = theta[knots]
    a, b = with_integral(*transverse_linearization(table, basis, lookup, th), ni)
    _, dphi, _ = table.evaluate(th)
    q, r = lqr_weights(gains, dphi, lookup.states(th)[:, 0])
    d = a.shape[1]
    # the stationary solution at the end (closed paths: a start the periodic iteration is attracted from)
    p_end = _stationary(lambda keep: solve_continuous_are(a[-1][keep], b[-1][keep[0][:, 0]], q[-1][keep], r),
                        d, _end_states(gains, table.n, d))
    p = solve_riccati(times[knots], a, b, q, r, p_end, periodic=table.closed)
    k = np.linalg.solve(r, np.transpose(b, (0, 2, 1))) @ p  # R^-1 B^T P
    return _interpolate(th, theta, k), (th, p)


def _interpolate(knots: np.ndarray, theta: np.ndarray, values: np.ndarray) -> np.ndarray:
    """values (K, ...) given at increasing ``knots`` (K,), linear in theta at ``theta`` (M,) (clipped)."""
    if len(knots) == 1:
        return np.repeat(values, len(theta), axis=0)
    i = np.clip(np.searchsorted(knots, theta, side="right") - 1, 0, len(knots) - 2)
    w = np.clip((theta - knots[i]) / (knots[i + 1] - knots[i]), 0.0, 1.0).reshape(-1, *([1] * (values.ndim - 1)))
    out, step = values[i], np.diff(values, axis=0)[i]  # two gathers, then in place (the P stack is ~10 MB)
    step *= w
    out += step
    return out


def sample_grid(times: np.ndarray, sample_time: float, periodic: bool) -> np.ndarray:
    """Planned times (N+1,) [s] of the samples over [times[0], times[-1]]: ``sample_time`` apart, the last
    interval shorter (open; merged into the one before when shorter than ``SAMPLE_MERGE`` samples, unless it
    is the only one), or N equal intervals nearest ``sample_time`` (one period of a closed path). N >= 1."""
    t0, t1 = float(times[0]), float(times[-1])
    if not t1 > t0:
        raise SimulationError(f"an orbital segment at planned time {t0:.6g} s has no duration (it ends at "
                              f"{t1:.6g} s): the plan's speed profile is at rest over it")
    if periodic:
        return np.linspace(t0, t1, max(1, int(round((t1 - t0) / sample_time))) + 1)
    grid = np.arange(t0, t1, sample_time)
    merge = len(grid) > 1 and t1 - grid[-1] <= SAMPLE_MERGE * sample_time
    return np.append(grid[:-1] if merge else grid, t1)


def _strictly_increasing(theta: np.ndarray, length: float) -> np.ndarray:
    """theta (N,) pushed apart by SAMPLE_SEPARATION x ``length`` per index (at rest the profile gives equal thetas)."""
    return np.maximum.accumulate(theta + SAMPLE_SEPARATION * np.arange(len(theta)) * length)


def sampled_system(table: PathTable, basis: TransverseBasis, lookup: ProfileLookup, gains: OrbitalGains,
                   t: np.ndarray, delay: int):
    """The transverse linearization (with its integral states) sampled at planned times t (N+1,) [s] with a
    zero-order hold, the command ``delay`` samples late, and the continuous cost int x^T Q x + dv^T R dv dt
    (:func:`lqr_weights`) integrated exactly over each hold (:func:`.riccati.sampled_cost`); sample k spans
    [t_k, t_k+1], its matrices frozen at its middle. Returns (theta_k (N,) at the sample starts, Phi (N, D, D),
    Gamma (N, D, n), Q (N, D, D), R (N, n, n), S (N, D, n)), D = d + delay n. Without a delay the held command
    is the new one: Q = W_xx, S = W_xu, R = R Ts + W_uu. With one, the held command is the oldest in flight: W
    weighs (x, dv_k-delay), S = 0, and the new command carries R Ts (every command is held exactly once), so the
    sampled cost is the continuous one and the gains tend to the continuous design's as Ts -> 0."""
    steps = np.diff(t)
    mid = _strictly_increasing(np.asarray(lookup.profile.state_at_time(0.5 * (t[:-1] + t[1:]))[0], float),
                               table.length)
    start = _strictly_increasing(np.asarray(lookup.profile.state_at_time(t[:-1])[0], float), table.length)
    ni = integral_size(gains, table.n)
    a, b = with_integral(*transverse_linearization(table, basis, lookup, mid), ni)
    _, dphi, _ = table.evaluate(mid)
    q, r = lqr_weights(gains, dphi, lookup.states(mid)[:, 0])
    big, d, n = b.shape
    phi, gamma, w = sampled_cost(a, b, q, steps)  # each sample its own hold (an open segment's last is shorter)
    r_k = r[None] * steps[:, None, None]
    phi, gamma = with_delay(phi, gamma, delay)
    size = phi.shape[1]
    q_k, s_k = np.zeros((big, size, size)), np.zeros((big, size, n))
    if delay == 0:
        q_k[:], s_k[:] = w[:, :d, :d], w[:, :d, d:]
        r_k = r_k + w[:, d:, d:]
    else:
        q_k[:, :d + n, :d + n] = w
    return start, phi, gamma, q_k, r_k, s_k


def discrete_segment(table, basis, lookup, gains, theta, times, sample_time, delay):
    """Gains (M, n, d) of the sampled design on one orbital segment at its grid points ``theta`` (M,) with planned
    ``times`` (M,) [s], linear in theta between the sample starts (where the controller applies them), and
    (sample starts (K,), Riccati matrices (K, d, d) there)."""
    periodic = table.closed
    t = sample_grid(times, sample_time, periodic)
    th, phi, gamma, q, r, s = sampled_system(table, basis, lookup, gains, t, delay)
    dim = phi.shape[1]
    if periodic:  # any start: the periodic recursion is attracted to the periodic solution
        p_end = q[-1]
    else:  # the stationary solution at the end
        p_end = _stationary(lambda keep: solve_discrete_are(phi[-1][keep], gamma[-1][keep[0][:, 0]], q[-1][keep],
                                                            r[-1], s=s[-1][keep[0][:, 0]]),
                            dim, _end_states(gains, table.n, dim))
    p, k = solve_discrete_riccati(phi, gamma, q, r, p_end, periodic=periodic, cross=s)
    if len(th) == 1:
        return np.repeat(k, len(theta), axis=0), (th, p[:1])
    return _interpolate(th, theta, k), (th, p[:-1])


def _end_states(gains: OrbitalGains, n: int, dim: int) -> list[np.ndarray]:
    """Candidate state sets for the stationary Riccati solution at the end of an open segment, preferred first:
    the whole state; then without I and xi_I (where the frozen end is not stabilizable through the speed)."""
    m = n - 1
    ni = integral_size(gains, n)
    core = ni + 2 * m + 1
    partial = np.concatenate([np.arange(min(ni, m)), ni + np.arange(2 * m), np.arange(core, dim)])
    return [np.arange(dim), partial]


def _stationary(solve, dim: int, candidates: list[np.ndarray]) -> np.ndarray:
    """P_end (dim, dim): ``solve(np.ix_(keep, keep))`` -- an algebraic Riccati solution of the frozen end on the
    states ``keep`` -- for the first candidate that has a finite one, zero elsewhere; zero if none has.

    Why the whole state: with P_end zero on I and xi_I the speed feedback fades out over the last 1/speed_rate of
    the segment, and a robot slowed by friction stopped just short of the clock play near the end
    (circle_zero with 2 N m Coulomb friction stalls at 95 % of the path without it)."""
    p_end = np.zeros((dim, dim))
    for keep in candidates:
        sub = np.ix_(keep, keep)
        try:
            value = solve(sub)
        except (np.linalg.LinAlgError, ValueError):
            continue
        if np.all(np.isfinite(value)):
            p_end[sub] = 0.5 * (value + value.T)
            return p_end
    return p_end


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges of the runs of True in mask that have at least 3 points."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    return [(int(a), int(b)) for a, b in zip(starts, stops) if b - a >= 3]


class OrbitalController:
    """Running orbital controller (stateful: theta, the integral states and the clock zone it is in).

    Build a new one for every run. ``__call__(t, q, qd) -> tau`` with q, qd (n,) measured, tau (n,) [N m].
    """

    name = "orbital"

    def __init__(self, design: OrbitalDesign, robot: Robot, sample_time: float = defaults.SAMPLE_TIME,
                 delay: int | None = None, sampled: bool = True,
                 identify_payload: bool = defaults.PAYLOAD_IDENTIFICATION):
        d = design
        self.design = design
        self.model = robot.model
        self.data = robot.model.createData()
        self.sample_time = float(sample_time)
        self.theta = d.table.domain[0]
        self.theta_dot = float(np.sqrt(d.profile.state(self.theta)[0]))
        n = d.table.n
        self.xi = np.zeros(integral_size(d.gains, n))  # (int z dt, int I dt) in orbital mode
        self.xi_q = np.zeros(n)  # integral of q - q_ref (clock play)
        self.x_perp = np.zeros(d.gain.shape[2])
        self.torque_limit = np.asarray(robot.limits.torque, dtype=float)
        self.v = np.zeros(n)
        self._offset: np.ndarray | None = None  # the friction compensated in the last command (identification)
        core = integral_size(d.gains, n) + 2 * n - 1
        self.delay = (d.gain.shape[2] - core) // n if delay is None else int(delay)
        self.payload = (PayloadEstimator.for_robot(robot, self.sample_time, d.gains.payload_memory,
                                                   d.gains.payload_noise, d.gains.payload_speed_noise)
                        if identify_payload else None)
        self.observer = DisturbanceObserver(self.model, self.sample_time,
                                            observer_gain(d.gains, self.sample_time, self.delay, sampled), self.delay,
                                            self.torque_limit, self.payload)
        p = d.profile.profile
        self._path, self._plan, self._basis = d.table.arrays, d.profile.arrays, d.basis.arrays
        self._projection = d.table.projection()
        self._clock_gains = d.gains.clock_gains
        # zones are entered by theta: t*(theta) is increasing, so zone i starts at theta*(start of zone i)
        self._zone_theta = np.asarray(p.state_at_time(np.asarray([z0 for z0, _ in d.zones], float))[0], float)
        zone = design.zone_at(0.0)
        # clock play: (zone index, clock time at entry, planned time at entry); zones are passed in order
        # and never re-entered, so measurement noise near a stop cannot restart the clock
        self.clock: tuple | None = None if zone is None else (zone, 0.0, 0.0)
        self.next_zone = 0 if zone is None else zone + 1

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        q = np.ascontiguousarray(q, dtype=float)
        qd = np.ascontiguousarray(qd, dtype=float)
        self.observer.measure(q, qd)
        tau = self._law(t, q, qd)
        return self.observer.command(tau, self._offset)

    def _law(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        d = self.design
        if self.clock is not None:
            zone, t0, plan0 = self.clock
            z1 = d.zones[zone][1]
            t_ref = plan0 + (t - t0)
            if t_ref <= z1 or z1 >= d.profile.duration:
                return self._play(t_ref, q, qd)
            th, thd, _ = d.profile.profile.state_at_time(np.array([t_ref]))  # leave the zone: back to orbital
            self.theta, self.theta_dot, self.clock = float(th[0]), float(thd[0]), None
            self._integral_to_transverse()
        table = d.table
        guess = table.next_guess(self.theta, self.theta_dot, self.sample_time)
        if self.next_zone < len(d.zones) and guess + self._projection.max_step >= self._zone_theta[self.next_zone]:
            theta, _ = table.project(q, guess, *self._projection)
            plan = d.profile.time(theta)
            zone = d.zone_at(plan, self.next_zone)
            if zone is not None:
                self.theta = theta
                self.clock, self.next_zone = (zone, t, plan), zone + 1
                self._integral_to_joints(theta)
                return self._play(plan, q, qd)
        self.theta, self.theta_dot = orbital_command(self._path, self._plan, self._basis, self._projection, d.gain,
                                                     q, qd, guess, self.sample_time, self.xi, self.x_perp, self.v)
        tau = self._model_torque(q, qd, self.v, self.theta, None)
        if len(self.xi) and np.any(np.abs(tau + self.observer.estimate) > self.torque_limit):
            self._hold_integral()
        return tau

    def _hold_integral(self) -> None:
        """Anti-windup by conditional integration: the command saturates, so this sample's integration of
        (z, I) is taken back (the integral would only wind up against the limit)."""
        m, ni = len(self.xi) - 1, len(self.xi)
        self.xi[:m] -= self.sample_time * self.x_perp[ni:ni + m]
        self.xi[m] -= self.sample_time * self.x_perp[ni + 2 * m]
        self.x_perp[:ni] = self.xi

    def _play(self, t_ref: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Tracking of the plan at planned time t_ref (after its end: hold Phi(theta_end)) with the orbital
        law's closed-loop poles and integral action on the joint error."""
        kp, kd, ki = self._clock_gains
        clock_command(self._path, self._plan, t_ref, self.sample_time, q, qd, kp, kd, ki, self.xi_q, self.v)
        return self._model_torque(q, qd, self.v, None, t_ref)

    def _model_torque(self, q: np.ndarray, qd: np.ndarray, v: np.ndarray, theta: float | None,
                      t_ref: float | None) -> np.ndarray:
        """Computed torque on the controller's model: the nominal RNEA plus, with the identification on, the
        identified payload's torque and the identified friction at the PLANNED joint velocity Phi'(theta) theta_dot*
        (at ``theta`` in orbital mode, at the planned time ``t_ref`` [s] in the clock play). Friction compensated at
        the measured velocity would be a negative damping F_c / v_s (40 N m s/rad for 2 N m at 0.05 rad/s) acting
        a sample late, which makes a light joint chatter where its speed crosses zero."""
        tau = computed_torque(self.model, self.data, q, qd, v)
        if self.payload is not None:
            if theta is None:
                th, thd, _ = self.design.profile.profile.state_at_time(np.array([t_ref]))
                theta, theta_dot = float(th[0]), float(thd[0])
            else:
                theta_dot = math.sqrt(self.design.profile.state(theta)[0])
            qd_ref = self.design.table.evaluate_scalar(theta)[1] * theta_dot
            self._offset = self.payload.torque(q, qd, v, qd_ref, tau)
        return tau

    def _frame(self, theta: float) -> np.ndarray:
        """E(theta) (n, n-1)."""
        _, dphi, ddphi = self.design.table.evaluate_scalar(theta)
        return self.design.basis.frames(dphi[None], ddphi[None])[0][0]

    def _integral_to_joints(self, theta: float) -> None:
        """Entering the clock play: the transverse integral as a joint-space one, xi_q = E xi_z."""
        if len(self.xi):
            self.xi_q[:] = self._frame(theta) @ self.xi[:-1]

    def _integral_to_transverse(self) -> None:
        """Back to orbital mode: xi_z = E^T xi_q; the speed integral restarts (the clock play held the
        along-path error itself)."""
        if len(self.xi):
            self.xi[:-1] = self._frame(self.theta).T @ self.xi_q
            self.xi[-1] = 0.0
        self.x_perp[len(self.xi) + 2 * (self.design.table.n - 1) + 1:] = 0.0  # no orbital command in flight

