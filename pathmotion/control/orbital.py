"""Orbital stabilization of a planned motion (Shiriaev, Perram, Canudas-de-Wit 2005; Shiriaev,
Freidovich, Gusev 2010), for a fully actuated arm with a computed-torque inner loop.

Per sample (docs/control.md has the equations):

1. project the measured q onto the path near the previous theta -> theta, theta_dot, x_perp = (z, z_dot, I);
2. v = v*(theta_m) - K(theta) x_perp, v* = Phi' u* + Phi'' x*, evaluated at theta_m = theta + theta_dot Ts/2
   (the middle of the coming hold interval), K from the Riccati equation of the transverse linearization;
3. tau = M(q) v + C(q, qd) qd + G(q) with the nominal model.

The clock never enters steps 1-3. On an open path, once the planned time-to-go from the projected theta is
below ``OrbitalGains.terminal_time_to_go``, the rest of the plan is played on the clock (computed torque
with the same bandwidth) and the final configuration is then held.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_continuous_are

from .. import defaults
from ..errors import SimulationError
from ..planning.profile import Profile
from ..robot import Robot
from .gains import OrbitalGains
from .laws import computed_torque
from .path_table import PathTable
from .profile_lookup import ProfileLookup
from .riccati import solve_riccati
from .transverse import TransverseBasis, TransverseState, transverse_linearization, transverse_state


def lqr_weights(gains: OrbitalGains, dphi: np.ndarray, x_star: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q (N, 2n-1, 2n-1) and R (n, n) along the path from Phi' (N, n) and x* (N,).

    Q = diag(w^4 I, 2 w^2 (2 zeta^2 - 1) I, q_I),  q_I = lambda^2 |Phi'|^4 / (4 max(|Phi'|^2 x*, v_min^2)),
    R = I: I weighted as the joint speed error along the path it means, |Phi'|^2 I / (2 |q_dot*|).
    """
    big, n = dphi.shape
    m = n - 1
    w, zeta = gains.bandwidth, gains.damping
    speed2 = np.sum(dphi * dphi, axis=1)
    q_i = gains.speed_rate**2 * speed2**2 / (4.0 * np.maximum(speed2 * x_star, gains.min_speed**2))
    diag = np.concatenate([np.full((big, m), w**4), np.full((big, m), 2.0 * w**2 * (2.0 * zeta**2 - 1.0)),
                           q_i[:, None]], axis=1)
    q = np.zeros((big, 2 * m + 1, 2 * m + 1))
    idx = np.arange(2 * m + 1)
    q[:, idx, idx] = diag
    return q, np.eye(n)


def clock_zones(times: np.ndarray, joint_speed: np.ndarray, min_speed: float,
                window: float, duration: float) -> tuple[tuple[float, float], ...]:
    """Planned-time intervals [s] where the planned joint speed |Phi'| sqrt(x*) (at the grid times (M,))
    is below ``min_speed``, widened by ``window`` on each side, merged and sorted."""
    slow = joint_speed < min_speed
    edges = np.diff(np.concatenate([[0], slow.astype(int), [0]]))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0] - 1
    zones: list[list[float]] = []
    for a, b in zip(starts, stops):
        z0, z1 = max(0.0, times[a] - window), min(duration, times[b] + window)
        if zones and z0 <= zones[-1][1]:
            zones[-1][1] = max(zones[-1][1], z1)
        else:
            zones.append([z0, z1])
    return tuple((float(a), float(b)) for a, b in zones)


@dataclass(frozen=True, eq=False)
class OrbitalDesign:
    """Everything the orbital controller precomputes: path table, profile, basis and gain schedule.

    theta (M,) gain grid (the table grid); gain (M, n, 2n-1) K(theta) (outside the orbital segments
    the nearest segment's end value); riccati (M, 2n-1, 2n-1) P(theta) (zero outside the segments);
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
    riccati: np.ndarray
    zones: tuple[tuple[float, float], ...]

    @classmethod
    def build(cls, table: PathTable, profile: Profile, gains: OrbitalGains = OrbitalGains()) -> "OrbitalDesign":
        lookup = ProfileLookup(profile, closed=table.closed)
        lo, hi = table.domain
        if abs(profile.grid[0] - lo) > 1e-9 * table.length or abs(profile.grid[-1] - hi) > 1e-9 * table.length:
            raise SimulationError(
                f"the profile covers theta in [{profile.grid[0]:.6g}, {profile.grid[-1]:.6g}] but the path's domain is "
                f"[{lo:.6g}, {hi:.6g}]; plan the profile on this path"
            )
        if table.closed:
            if abs(profile.x[0] - profile.x[-1]) > 1e-9 * max(profile.x.max(), 1e-12):
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
        x_grid = np.array([lookup.state(t)[0] for t in theta])
        joint_speed = np.linalg.norm(dphi_grid, axis=1) * np.sqrt(x_grid)
        zones = () if table.closed else clock_zones(times, joint_speed, gains.min_speed, gains.terminal_time_to_go,
                                                    lookup.duration)
        in_zone = np.zeros(len(theta), bool)
        for z0, z1 in zones:
            in_zone |= (times >= z0) & (times <= z1)
        segments = _runs(~in_zone)
        if not segments:
            raise SimulationError(
                "the planned motion is too short for orbital stabilization: every point is within "
                f"{gains.terminal_time_to_go:g} s of a stop; lower OrbitalGains.terminal_time_to_go"
            )
        m = table.n - 1
        d = 2 * m + 1
        gain = np.zeros((len(theta), table.n, d))
        riccati = np.zeros((len(theta), d, d))
        active = np.concatenate([np.arange(i0, i1) for i0, i1 in segments])
        basis = TransverseBasis.for_table(table, theta[active])
        for i0, i1 in segments:
            sl = slice(i0, i1)
            a, b = transverse_linearization(table, basis, lookup, theta[sl])
            _, dphi, _ = table.evaluate(theta[sl])
            x_star = np.array([lookup.state(t)[0] for t in theta[sl]])
            q, r = lqr_weights(gains, dphi, x_star)
            zz = slice(0, 2 * m)
            p_end = np.zeros((d, d))
            p_end[zz, zz] = solve_continuous_are(a[-1][zz, zz], b[-1][zz], q[-1][zz, zz], r)
            if table.closed:
                p_end[-1, -1] = q[-1][-1, -1] / max(gains.speed_rate, 1.0)
            riccati[sl] = solve_riccati(times[sl], a, b, q, r, p_end, periodic=table.closed)
            gain[sl] = np.linalg.solve(r, np.transpose(b, (0, 2, 1))) @ riccati[sl]  # R^-1 B^T P
        # outside the segments: hold the nearest segment-end gain (used only at zone edges)
        idx = np.where(~in_zone, np.arange(len(theta)), -1)
        fwd = np.maximum.accumulate(idx)
        first = active[0]
        fwd[fwd < 0] = first
        gain = gain[fwd]
        return cls(table, lookup, basis, gains, theta, gain, riccati, zones)

    def gain_at(self, theta: float) -> np.ndarray:
        """K(theta) (n, 2n-1), linear in theta between grid points."""
        theta = self.table.wrap(theta)
        grid = self.theta
        i = min(max(int(np.searchsorted(grid, theta, side="right")) - 1, 0), len(grid) - 2)
        w = (theta - grid[i]) / (grid[i + 1] - grid[i])
        return self.gain[i] + w * (self.gain[i + 1] - self.gain[i])

    def zone_at(self, planned_time: float, first: int = 0) -> int | None:
        """Index (>= first) of the clock zone containing ``planned_time`` [s], or None."""
        for i in range(first, len(self.zones)):
            z0, z1 = self.zones[i]
            if z0 <= planned_time <= z1:
                return i
        return None


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges of the runs of True in mask that have at least 3 points."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    return [(int(a), int(b)) for a, b in zip(starts, stops) if b - a >= 3]


class OrbitalController:
    """Running orbital controller (stateful: the previous theta and the clock zone it is in).

    Build a new one for every run. ``__call__(t, q, qd) -> tau`` with q, qd (n,) measured, tau (n,) [N m].
    """

    name = "orbital"

    def __init__(self, design: OrbitalDesign, robot: Robot, sample_time: float = defaults.SAMPLE_TIME):
        self.design = design
        self.model = robot.model
        self.data = robot.model.createData()
        self.sample_time = float(sample_time)
        self.theta = design.table.domain[0]
        self.theta_dot = float(np.sqrt(design.profile.state(self.theta)[0]))
        zone = design.zone_at(0.0)
        # clock play: (zone index, clock time at entry, planned time at entry); zones are passed in order
        # and never re-entered, so measurement noise near a stop cannot restart the clock
        self.clock: tuple | None = None if zone is None else (zone, 0.0, 0.0)
        self.next_zone = 0 if zone is None else zone + 1
        self.last: TransverseState | None = None

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        d = self.design
        if self.clock is not None:
            zone, t0, plan0 = self.clock
            z1 = d.zones[zone][1]
            t_ref = plan0 + (t - t0)
            if t_ref <= z1 or z1 >= d.profile.duration:
                return self._play(t_ref, q, qd)
            th, thd, _ = d.profile.profile.state_at_time(t_ref)  # leave the zone: back to orbital
            self.theta, self.theta_dot, self.clock = float(th), float(thd), None
        guess = d.table.next_guess(self.theta, self.theta_dot, self.sample_time)
        st = transverse_state(d.table, d.basis, d.profile, q, qd, guess)
        self.theta, self.theta_dot, self.last = st.theta, st.theta_dot, st
        if self.next_zone < len(d.zones):
            plan = d.profile.time(st.theta)
            zone = d.zone_at(plan, self.next_zone)
            if zone is not None:
                self.clock, self.next_zone = (zone, t, plan), zone + 1
                return self._play(plan, q, qd)
        theta_m = st.theta + 0.5 * self.sample_time * st.theta_dot
        if not d.table.closed:
            theta_m = min(theta_m, d.table.domain[1])
        _, dphi_m, ddphi_m = d.table.evaluate_scalar(theta_m)
        x_m, u_m = d.profile.state(theta_m)
        v = dphi_m * u_m + ddphi_m * x_m - d.gain_at(st.theta) @ st.x_perp
        return computed_torque(self.model, self.data, q, qd, v)

    def _play(self, t_ref: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Computed-torque tracking of the plan at planned time t_ref (after its end: hold Phi(theta_end))."""
        d = self.design
        half = 0.5 * self.sample_time
        th, thd, thdd = d.profile.profile.state_at_time([t_ref, t_ref + half])
        phi, dphi, _ = d.table.evaluate_scalar(float(th[0]))
        _, dphi_m, ddphi_m = d.table.evaluate_scalar(float(th[1]))
        qd_ref = dphi * thd[0]
        qdd_ff = dphi_m * thdd[1] + ddphi_m * thd[1] ** 2
        if t_ref + half >= d.profile.duration:
            qdd_ff = np.zeros_like(qdd_ff)
        g = d.gains
        v = qdd_ff + g.velocity_gain * (qd_ref - qd) + g.stiffness * (phi - q)
        return computed_torque(self.model, self.data, q, qd, v)
