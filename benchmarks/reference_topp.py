"""Reference minimum-time motion along a fixed path, by direct transcription (CasADi + IPOPT).

An independent check for the planner: it shares only the path (Phi and its
exact derivatives, :meth:`JointPath.evaluate3`) and the reduced dynamics coefficients
(:func:`pathmotion.planning.reduced.reduced_dynamics`, three RNEA calls) with pathmotion.

Formulation: time-based, not theta-based. With jerk limits a rest start needs theta_ddot(0) = 0,
so theta = j t^3 / 6 near it and, in the theta domain, b = theta_dot^2 ~ theta^(4/3) and
a' = d theta_ddot / d theta ~ theta^(-2/3): the usual (b, a) transcription on a theta grid
(Verscheure et al. 2009 for second order; TOPP3, Pham et al. 2017, for third order) then has an
O(h^(1/3)) error in the first and last interval, about 1 % at 6400 intervals on the circle. On a
uniform time grid the same start is smooth. So, with N intervals of dt = T / N and T free (one
dt_k per interval, chained dt_{k+1} = dt_k: a single T variable would couple every dynamics row and
make IPOPT's KKT matrix dense in that column, 3x slower at N = 800):

    second order (no jerk, no torque rate): states (theta, theta_dot), control theta_ddot = u_k
        piecewise constant; theta_dot_{k+1} = theta_dot_k + u_k dt, theta_{k+1} = theta_k
        + theta_dot_k dt + u_k dt^2 / 2 (exact);
    third order: states (theta, theta_dot, theta_ddot), control theta_dddot = u_k piecewise
        constant, integrated exactly (cubic theta per interval).

Every limit is imposed at both ends of every interval with that interval's control, per joint:

    velocity      |Phi' theta_dot| <= v
    acceleration  |Phi' a + Phi'' theta_dot^2| <= A                      (a = theta_ddot)
    jerk          |Phi''' theta_dot^3 + 3 Phi'' theta_dot a + Phi' j| <= J   (j = theta_dddot)
    torque        |alpha a + beta theta_dot^2 + gamma| <= (1 - reserve) tau
    torque rate   |alpha' theta_dot a + alpha j + beta' theta_dot^3 + 2 beta theta_dot a
                   + gamma' theta_dot| <= R
    envelope      |tau_j| + k |qd_j| <= C,  k = (1 - e) tau_lim / ((1 - knee) v),
                  C = tau_lim (1 + (1 - e) knee / (1 - knee)): the line from (knee v, tau_lim)
                  to (v, e tau_lim), written exactly as the two ranges tau +- k qd in [-C, C].

Rest boundaries: theta_dot = 0, and with third-order limits theta_ddot = 0 too (a motion at rest
has zero acceleration when jerk is bounded). Given boundary speeds replace theta_dot = 0.

The path quantities (Phi', Phi'', Phi''', alpha, beta, gamma) enter through a cubic B-spline
interpolant of a dense table (``table_points``, default 4001: interpolation error ~1e-12 relative
on smooth paths; alpha', beta', gamma' are its derivatives). A path whose Phi'' or Phi''' jumps
(segment breaks, spline knots) is smoothed over one table step there, an O(1 / table_points)
effect. The optimum converges as O(dt^p) with p about 1..2 (switching times fall between nodes);
:func:`converged_duration` solves on doubling grids, warm-starting each from the last, and
extrapolates (Richardson) with the order estimated from the last three grids.

Run ``python benchmarks/reference_topp.py`` for the table of recorded converged optima on scenarios/circle_zero.toml
(about 20 minutes on a loaded 2-core machine, 2 minutes per 6400-interval solve;
``--grids 200 400 800`` for a quick look). Result (IRB140 limits file, 200..6400 intervals):

    limits                        reference [s]  order  finest [s]  recorded [s] difference
    vel + acc                          1.087412   0.99    1.087492       1.08740    +0.001 %
    + jerk 10x acc                     1.213063   1.01    1.213117       1.21310    -0.003 %
    + jerk 4x acc                      1.554302   0.98    1.554468       1.55430    +0.000 %
    vel + torque, acc off              0.466664   1.01    0.466688       0.46666    +0.001 %
    vel + torque, reserve 0.2          0.497121   1.00    0.497152       0.49712    +0.000 %

    acceleration only: toppra (4001 points) 1.087549 s (+0.013 %), pathmotion planner 1.087951 s (+0.050 %)
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field, replace

import numpy as np

try:
    import casadi as ca
except ImportError:  # pragma: no cover - casadi is in the dev extra
    ca = None

from pathmotion.planning.reduced import reduced_dynamics

GRIDS = (200, 400, 800, 1600, 3200, 6400)
TABLE_POINTS = 4001
IPOPT_TOL = 1e-10


@dataclass(frozen=True)
class ReferenceLimits:
    """Limits of the reference problem; None switches one off. Per-joint arrays (n,), SI units.

    velocity [rad/s], acceleration [rad/s^2], jerk [rad/s^3], torque [N m], torque_rate [N m/s];
    torque_speed = (knee, at_max_speed) in (0, 1] (needs velocity and torque); torque_reserve in
    [0, 0.5) scales the torque limits by (1 - reserve); start_speed, end_speed: theta_dot at the ends
    [unit theta / s] (0 = rest).
    """

    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    jerk: np.ndarray | None = None
    torque: np.ndarray | None = None
    torque_rate: np.ndarray | None = None
    torque_speed: tuple[float, float] | None = None
    torque_reserve: float = 0.0
    start_speed: float = 0.0
    end_speed: float = 0.0

    def __post_init__(self):
        if not 0.0 <= self.torque_reserve < 0.5:
            raise ValueError(f"torque_reserve must be in [0, 0.5), got {self.torque_reserve}")
        if self.torque_speed is not None:
            knee, at = self.torque_speed
            if not (0.0 < knee < 1.0 and 0.0 < at <= 1.0):
                raise ValueError(f"torque_speed (knee, at_max_speed) must be in (0, 1) x (0, 1], got {self.torque_speed}")
            if self.velocity is None or self.torque is None:
                raise ValueError("the torque-speed envelope needs both velocity and torque limits")

    @property
    def third_order(self) -> bool:
        return self.jerk is not None or self.torque_rate is not None

    @property
    def needs_dynamics(self) -> bool:
        return self.torque is not None or self.torque_rate is not None


@dataclass(frozen=True)
class ReferenceProfile:
    """Solution on N intervals: t, theta, theta_dot, theta_ddot (N + 1,) at the nodes (second
    order: theta_ddot is the interval's control, repeated at the last node); control (N,) is
    theta_ddot (second order) or theta_dddot (third order) per interval."""

    duration: float
    intervals: int
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    control: np.ndarray
    third_order: bool
    status: str
    solve_seconds: float
    x: np.ndarray = field(repr=False, default=None)


def _table(path, robot, limits: ReferenceLimits, points: int):
    """Interpolant theta -> [Phi', Phi'', Phi'''] (3 n values), then [alpha, beta, gamma] with torque limits."""
    theta = np.linspace(*path.domain, points)
    q, dq, ddq, dddq = path.evaluate3(theta)
    blocks = [dq, ddq, dddq]
    if limits.needs_dynamics:
        red = reduced_dynamics(robot, q, dq, ddq)
        blocks += [red.alpha, red.beta, red.gamma]
    values = np.concatenate(blocks, axis=1)
    return ca.interpolant("path_table", "bspline", [theta], values.ravel(order="C"))


def _rows(expr, bound):
    return [expr], [-bound], [bound]


def _node_function(table, n: int, limits: ReferenceLimits):
    """CasADi function (theta, theta_dot, a, j) -> (constraint rows,) with numeric bounds (lb, ub)."""
    th, v, a, j = (ca.MX.sym(s) for s in ("theta", "theta_dot", "a", "j"))
    vals = table(th)
    d1, d2, d3 = (vals[k * n:(k + 1) * n] for k in range(3))
    if limits.needs_dynamics:
        al, be, ga = (vals[k * n:(k + 1) * n] for k in range(3, 6))
    rows, lb, ub = [], [], []

    def add(expr, bound):
        r, lo, hi = _rows(expr, np.asarray(bound, float))
        rows.extend(r), lb.extend(lo), ub.extend(hi)

    if limits.velocity is not None:
        add(d1 * v, limits.velocity)
    if limits.acceleration is not None:
        add(d1 * a + d2 * v ** 2, limits.acceleration)
    if limits.jerk is not None:
        add(d3 * v ** 3 + 3 * d2 * v * a + d1 * j, limits.jerk)
    scale = 1.0 - limits.torque_reserve
    if limits.torque is not None:
        tau = al * a + be * v ** 2 + ga
        tau_lim = scale * np.asarray(limits.torque, float)
        add(tau, tau_lim)
        if limits.torque_speed is not None:
            knee, at = limits.torque_speed
            k = (1.0 - at) * tau_lim / ((1.0 - knee) * limits.velocity)
            c = tau_lim * (1.0 + (1.0 - at) * knee / (1.0 - knee))
            add(tau + k * (d1 * v), c)
            add(tau - k * (d1 * v), c)
    if limits.torque_rate is not None:
        dvals = ca.jacobian(vals, th)
        dal, dbe, dga = (dvals[k * n:(k + 1) * n] for k in (3, 4, 5))
        add(dal * v * a + al * j + dbe * v ** 3 + 2 * be * v * a + dga * v, limits.torque_rate)
    g = ca.vertcat(*rows)
    return ca.Function("node", [th, v, a, j], [g]), np.concatenate(lb), np.concatenate(ub)


def _initial_guess(path, limits: ReferenceLimits, N: int, third: bool) -> np.ndarray:
    """Quintic smoothstep from 0 to L, slow enough for the kinematic limits (a rough start)."""
    L = path.length
    dq = np.abs(path.evaluate3(np.linspace(*path.domain, 200))[1]).max(axis=0)
    T = 0.5
    for lim, peak, power in ((limits.velocity, 1.875, 1), (limits.acceleration, 5.78, 2), (limits.jerk, 60.0, 3)):
        if lim is not None:
            T = max(T, float(np.max((peak * L * dq / lim) ** (1.0 / power))))
    T *= 1.5
    s = np.linspace(0.0, 1.0, N + 1)
    theta = L * s ** 3 * (10 - 15 * s + 6 * s ** 2)
    v = L * 30 * s ** 2 * (1 - s) ** 2 / T
    a = L * 60 * s * (1 - s) * (1 - 2 * s) / T ** 2
    j = L * 60 * (1 - 6 * s + 6 * s ** 2) / T ** 3
    return _pack(theta, v, a, j, T, third)


def _pack(theta, v, a, j, T, third):
    u = 0.5 * (j[:-1] + j[1:]) if third else 0.5 * (a[:-1] + a[1:])
    parts = [theta, v] + ([a] if third else []) + [u, np.full(len(u), T / len(u))]
    return np.concatenate([np.asarray(p, float) for p in parts])


def _unpack(x: np.ndarray, N: int, third: bool):
    theta, v = x[:N + 1], x[N + 1:2 * N + 2]
    off = 2 * N + 2
    a = x[off:off + N + 1] if third else None
    off += N + 1 if third else 0
    return theta, v, a, x[off:off + N], float(np.sum(x[off + N:]))


def _resample(prev: ReferenceProfile, N: int) -> np.ndarray:
    """Warm start on N intervals from a solution on a coarser grid (linear in normalized time)."""
    s_old = np.linspace(0.0, 1.0, prev.intervals + 1)
    s = np.linspace(0.0, 1.0, N + 1)
    theta, v, a = (np.interp(s, s_old, y) for y in (prev.theta, prev.theta_dot, prev.theta_ddot))
    u_old = np.append(prev.control, prev.control[-1])
    u = np.interp(s, s_old, u_old)
    return _pack(theta, v, a, u if prev.third_order else a, prev.duration, prev.third_order)


def _build(node, lb_node, ub_node, N: int, third: bool, L: float, limits: ReferenceLimits):
    nx = (3 if third else 2) * (N + 1) + 2 * N
    x = ca.MX.sym("x", nx)
    theta, v = x[:N + 1], x[N + 1:2 * N + 2]
    off = 2 * N + 2
    a = x[off:off + N + 1] if third else None
    off += N + 1 if third else 0
    # one time step per interval, all equal: a single T would couple every row (a dense KKT column)
    u, dt = x[off:off + N], x[off + N:]
    if third:
        dyn = [theta[1:] - (theta[:-1] + v[:-1] * dt + a[:-1] * dt ** 2 / 2 + u * dt ** 3 / 6),
               v[1:] - (v[:-1] + a[:-1] * dt + u * dt ** 2 / 2), a[1:] - (a[:-1] + u * dt)]
        a_left, a_right, jerk = a[:-1].T, a[1:].T, u.T
    else:
        dyn = [theta[1:] - (theta[:-1] + v[:-1] * dt + u * dt ** 2 / 2), v[1:] - (v[:-1] + u * dt)]
        a_left = a_right = u.T
        jerk = ca.DM.zeros(1, N)
    fmap = node.map(N)
    g_left = fmap(theta[:-1].T, v[:-1].T, a_left, jerk)
    g_right = fmap(theta[1:].T, v[1:].T, a_right, jerk)
    g = ca.vertcat(*dyn, dt[1:] - dt[:-1], ca.vec(g_left), ca.vec(g_right))
    ndyn = (3 if third else 2) * N + N - 1
    lbg = np.concatenate([np.zeros(ndyn), np.tile(lb_node, 2 * N)])
    ubg = np.concatenate([np.zeros(ndyn), np.tile(ub_node, 2 * N)])
    lbx, ubx = np.full(nx, -np.inf), np.full(nx, np.inf)
    lbx[:N + 1], ubx[:N + 1] = 0.0, L
    lbx[0] = ubx[0] = 0.0
    lbx[N] = ubx[N] = L
    lbx[N + 1:2 * N + 2] = 0.0
    lbx[N + 1] = ubx[N + 1] = limits.start_speed
    lbx[2 * N + 1] = ubx[2 * N + 1] = limits.end_speed
    if third:
        if limits.start_speed == 0.0:
            lbx[2 * N + 2] = ubx[2 * N + 2] = 0.0
        if limits.end_speed == 0.0:
            lbx[3 * N + 2] = ubx[3 * N + 2] = 0.0
    lbx[off + N:] = 1e-3 / N
    return {"x": x, "f": ca.sum1(dt), "g": g}, lbx, ubx, lbg, ubg


def reference_duration(path, robot, limits: ReferenceLimits, intervals: int, *, warm: ReferenceProfile | None = None,
                       table=None, table_points: int = TABLE_POINTS, print_level: int = 0):
    """Minimum time [s] along ``path`` (a JointPath with ``evaluate3``) on ``intervals`` time steps.

    Returns (duration, :class:`ReferenceProfile`). ``warm``: a solution on another grid to start
    from; ``table``: a prebuilt path interpolant (reuse across grids). RuntimeError if IPOPT fails.
    """
    if ca is None:
        raise RuntimeError("the reference needs casadi (pip install -e '.[dev]')")
    n = path.n
    third = limits.third_order
    table = table if table is not None else _table(path, robot, limits, table_points)
    node, lb_node, ub_node = _node_function(table, n, limits)
    nlp, lbx, ubx, lbg, ubg = _build(node, lb_node, ub_node, intervals, third, path.length, limits)
    x0 = _resample(warm, intervals) if warm is not None else _initial_guess(path, limits, intervals, third)
    opts = {"ipopt.print_level": print_level, "print_time": False, "ipopt.tol": IPOPT_TOL,
            "ipopt.max_iter": 3000, "ipopt.mu_strategy": "adaptive"}
    solver = ca.nlpsol("reference", "ipopt", nlp, opts)
    start = time.perf_counter()
    sol = solver(x0=np.clip(x0, lbx, ubx), lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    elapsed = time.perf_counter() - start
    status = solver.stats()["return_status"]
    if status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
        raise RuntimeError(f"IPOPT did not converge on {intervals} intervals: {status}")
    x = np.asarray(sol["x"]).ravel()
    theta, v, a, u, T = _unpack(x, intervals, third)
    if a is None:
        a = np.append(u, u[-1])
    prof = ReferenceProfile(T, intervals, np.linspace(0.0, T, intervals + 1), theta, v, a, u, third, status,
                            elapsed, x)
    return T, prof


def richardson(grids, durations) -> tuple[float, float]:
    """(extrapolated duration, observed order p) from the last three of doubling grids."""
    t1, t2, t3 = durations[-3:]
    d1, d2 = t1 - t2, t2 - t3
    if d1 * d2 <= 0 or abs(d2) < 1e-14 * abs(t3):
        return t3, float("nan")  # not in the asymptotic range: take the finest value
    p = float(np.log2(d1 / d2))
    return t3 - d2 / (2.0 ** p - 1.0), p


def converged_duration(path, robot, limits: ReferenceLimits, grids=GRIDS, table_points: int = TABLE_POINTS,
                       log=None):
    """Solve on each of ``grids`` (doubling interval counts), warm-starting each from the last.

    Returns (extrapolated duration, order, list of ReferenceProfile)."""
    table = _table(path, robot, limits, table_points)
    profiles, warm = [], None
    for N in grids:
        _, warm = reference_duration(path, robot, limits, N, warm=warm, table=table)
        profiles.append(warm)
        if log:
            log(f"    N = {N:5d}: T = {warm.duration:.7f} s  ({warm.solve_seconds:.1f} s, {warm.status})")
    if len(profiles) < 3:
        return profiles[-1].duration, float("nan"), profiles
    T, p = richardson(grids, [pr.duration for pr in profiles])
    return T, p, profiles


def toppra_instance(path, velocity, acceleration, gridpoints: int):
    """toppra's acceleration-only TOPPRA problem (ParametrizeConstAccel output) on ``path`` (any object with
    evaluate(s) -> (q, q', q'', ...), n and domain), on a uniform grid of ``gridpoints``."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    class _Path(ta.interpolator.AbstractGeometricPath):
        def __call__(self, s, order=0):
            res = path.evaluate(np.atleast_1d(s))[order]
            return res[0] if np.ndim(s) == 0 else res

        @property
        def dof(self):
            return path.n

        @property
        def path_interval(self):
            return np.array(path.domain)

    cons = [constraint.JointVelocityConstraint(np.vstack([-velocity, velocity]).T),
            constraint.JointAccelerationConstraint(np.vstack([-acceleration, acceleration]).T)]
    return algo.TOPPRA(cons, _Path(), gridpoints=np.linspace(*path.domain, gridpoints),
                       parametrizer="ParametrizeConstAccel")


def toppra_duration(path, robot, velocity, acceleration, gridpoints: int = 4001) -> float:
    """toppra's acceleration-only optimum (ParametrizeConstAccel) on ``path``."""
    return float(toppra_instance(path, velocity, acceleration, gridpoints).compute_trajectory().duration)


# ------------------------------------------------------------------------------------ the table
RECORDED_OPTIMA = (  # (label, recorded converged optimum)
    ("vel + acc", 1.0874),
    ("+ jerk 10x acc", 1.2131),
    ("+ jerk 4x acc", 1.5543),
    ("vel + torque, acc off", 0.46666),
    ("vel + torque, reserve 0.2", 0.49712),
)


def circle_cases(robot) -> dict[str, ReferenceLimits]:
    lim = robot.limits
    base = ReferenceLimits(velocity=lim.velocity, acceleration=lim.acceleration)
    torque = ReferenceLimits(velocity=lim.velocity, torque=lim.torque)
    return {
        "vel + acc": base,
        "+ jerk 10x acc": replace(base, jerk=10.0 * lim.acceleration),
        "+ jerk 4x acc": replace(base, jerk=4.0 * lim.acceleration),
        "vel + torque, acc off": torque,
        "vel + torque, reserve 0.2": replace(torque, torque_reserve=0.2),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/circle_zero.toml")
    parser.add_argument("--grids", type=int, nargs="+", default=list(GRIDS))
    args = parser.parse_args(argv)
    from pathmotion.api import load, plan_scenario

    setup = load(args.scenario)
    path, robot = setup.path, setup.robot
    print(f"{args.scenario}: path length {path.length:.6f} m; grids {args.grids}")
    rows = []
    for label, recorded in RECORDED_OPTIMA:
        limits = circle_cases(robot)[label]
        print(f"  {label}:")
        T, p, profiles = converged_duration(path, robot, limits, args.grids, log=print)
        rows.append((label, T, p, profiles[-1].duration, recorded))
    lim = robot.limits
    t_toppra = toppra_duration(path, robot, lim.velocity, lim.acceleration)
    acc_only = load(args.scenario, {"limits.use_torque": False})
    t_plan = plan_scenario(acc_only).duration
    print(f"\n{'limits':28s} {'reference [s]':>14s} {'order':>6s} {'finest [s]':>11s} {'recorded [s]':>13s} "
          f"{'difference':>10s}")
    for label, T, p, finest, recorded in rows:
        print(f"{label:28s} {T:14.6f} {p:6.2f} {finest:11.6f} {recorded:13.5f} {100 * (T / recorded - 1):+9.3f} %")
    ref = rows[0][1]
    print(f"\nacceleration-only check: toppra (4001 points) {t_toppra:.6f} s ({100 * (t_toppra / ref - 1):+.4f} %), "
          f"pathmotion planner {t_plan:.6f} s ({100 * (t_plan / ref - 1):+.4f} %)")


if __name__ == "__main__":
    main()
