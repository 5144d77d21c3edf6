"""The joint references execute streams: the plan tabulated in time, shaped for the drives, time-scaled.

``none`` streams q(t), qd(t) of the plan. ``shaping`` pre-compensates the known drive and EGM dynamics
(from the drive file), so that the arm's link side, not the reference, follows the plan:

    m(t) = q(t) + K^-1 tau_g(t)             the motor position that bends each elastic gear by its load
                                            (tau_g: the link-side torque of the plan, rotors excluded)
    p_k = (m_k - (1 - a) m_(k-1)) / a       the exact inverse of EGM's first-order low-pass (a per cycle)

and the same for the speed reference. The references are not led by EGM's transport delay L: a lead has to
be caught up from rest, and running the references ahead of a plan that leaves rest at its limits exceeds
them; the arm follows the plan L late (``ReferenceTable.delay``). A second-order plan (steps in
acceleration, which no motor passes through a spring) is first smoothed in the path coordinate over a
quarter of the lowest locked-motor gear mode's period (:func:`path_motion`). Every reference is clipped
into the joint limits (position and speed). refine.py then learns a motor-side correction (added to m before the low-pass
inverse, :func:`motor_correction`) on the nominal drive model, from the analytic table or its plain form
(m sent as it is); a re-timed segment takes the form of the one it leaves, carries its correction and
fades it out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import pinocchio as pin

from .. import defaults
from ..robot import Robot, rnea
from .drive_file import DriveParameters

MODES = ("none", "shaping", "orbital")


@dataclass(frozen=True, eq=False)
class ReferenceTable:
    """References at times t (K,) [s] of plan time: q (K, n) [rad], qd (K, n) [rad/s] (what is sent), theta (K,)
    and plan (K, n) (the plan's own joints, for the record); deflection (K, n) [rad]: the gear deflection
    the shaping planned at each time (0 without shaping); duration [s]; path: the motion's JointPath; raw:
    the :class:`RawMotion` the references follow (time 0 = its profile's first point); motion (K, 3): theta,
    theta_dot, theta_ddot of the references (the raw motion's, averaged when shaped); correction (K, n) [rad]
    or None: the motor-side correction added before the low-pass inverse (refine.py's, or its fade-out on a
    re-timed segment); delay [s]: how long after its plan time a reference reaches the servo (EGM's transport
    delay with shaping and orbital; 0 with none): the arm follows the plan that much late; plain: the shaped
    motor motion is sent without the low-pass inverse (refine.py's plain start; a re-timed segment continues
    its previous segment's form)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    theta: np.ndarray
    plan: np.ndarray
    duration: float
    deflection: np.ndarray
    path: object = None
    raw: object = None
    motion: np.ndarray | None = None
    correction: np.ndarray | None = None
    delay: float = 0.0
    plain: bool = False

    @property
    def sent(self) -> np.ndarray | None:
        """(theta, theta_dot, theta_ddot) (K, 3) of the motion the sent references follow in time: the references
        show the motion at its own plan time (no lead), so it is :attr:`motion`, on every segment."""
        return self.motion

    @cached_property
    def _lookup(self) -> tuple:
        """What :meth:`row` reads per EGM cycle, copied from the arrays at the first lookup (a table is not
        changed once streamed): the times as floats, the rows [q, qd, plan, deflection, theta] (K, 4n + 1) and
        each row's difference to the next (the same doubles as array by array)."""
        rows = np.column_stack([self.q, self.qd, self.plan, self.deflection, self.theta])
        return self.t.tolist(), rows, rows[1:] - rows[:-1]

    @property
    def end(self) -> float:
        """Plan time of the last reference [s]."""
        return float(self.t[-1])

    def state(self, tau: float) -> tuple[float, float, float]:
        """(theta, theta_dot, theta_ddot) of the raw motion at plan time tau [s]: a re-timing starts there."""
        th, thd, thdd = self.raw.state(np.array([max(tau, 0.0)]))
        return float(th[0]), max(float(thd[0]), 0.0), float(thdd[0])

    def correction_at(self, tau: np.ndarray) -> np.ndarray:
        """The motor-side correction (K', n) [rad] at plan times tau (K',) (held beyond the table's ends)."""
        if self.correction is None:
            return np.zeros((len(tau), self.q.shape[1]))
        return np.stack([np.interp(tau, self.t, c) for c in self.correction.T], axis=1)

    def row(self, tau: float) -> np.ndarray:
        """[q, qd, plan q, deflection, theta] (4n + 1,) at plan time tau (clipped to [0, end]), linearly
        interpolated: one row for the whole lookup of an EGM cycle (q and qd side by side: clipped at once)."""
        t, rows, steps = self._lookup
        if len(t) == 1:
            return rows[0].copy()
        tau = min(max(tau, 0.0), t[-1])
        k = min(int(tau / t[1]), len(t) - 2)
        row = steps[k] * ((tau - t[k]) / (t[k + 1] - t[k]))
        row += rows[k]
        return row

    def at(self, tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
        """(q, qd, plan q, theta, deflection) at plan time tau (clipped to [0, end]), linearly interpolated."""
        row, n = self.row(tau), self.q.shape[1]
        return row[:n], row[n:2 * n], row[2 * n:3 * n], float(row[4 * n]), row[3 * n:4 * n]


def gear_deflection(robot: Robot, drives: DriveParameters, q, qd, qdd) -> np.ndarray:
    """K^-1 tau_g (N, n) [rad]: each elastic gear's deflection under the plan's link-side torque (rotor inertia
    excluded: it is on the motor side of the gear); 0 on rigid axes."""
    elastic = drives.elastic
    if not elastic.any():
        return np.zeros_like(q)
    tau = rnea(robot, q, qd, qdd)
    if robot.limits.armature is not None:
        tau = tau - qdd * np.asarray(robot.limits.armature, float)  # the link side only
    return np.where(elastic, tau / np.where(elastic, drives.stiffness, 1.0), 0.0)


def lowpass_alpha(drives: DriveParameters) -> float:
    """EGM's first-order low-pass per cycle: p_f += alpha (p - p_f)."""
    return 1.0 - float(np.exp(-2.0 * np.pi * drives.lowpass_bandwidth * drives.cycle))


def lowpass(x: np.ndarray, alpha: float, per: int) -> np.ndarray:
    """EGM's low-pass of x (K, n) at the cycle (``per`` table steps per cycle), at rest at x[0] before; the
    exact inverse of :func:`_invert_lowpass`."""
    y = np.empty_like(x)
    prev = np.repeat(x[:1], per, axis=0)
    for k in range(0, len(x), per):
        y[k:k + per] = prev[:len(x[k:k + per])] + alpha * (x[k:k + per] - prev[:len(x[k:k + per])])
        prev = y[k:k + per]
    return y


def _invert_lowpass(x: np.ndarray, alpha: float, per: int) -> np.ndarray:
    """y with the low-pass y -> x undone at the EGM cycle (``per`` table steps per cycle)."""
    prev = np.concatenate([np.repeat(x[:1], per, axis=0), x[:-per]]) if len(x) > per else np.repeat(x[:1], len(x), 0)
    return (x - (1.0 - alpha) * prev) / alpha


def gear_period(robot: Robot, drives: DriveParameters, q0: np.ndarray) -> float:
    """The period [s] of the lowest locked-motor gear mode at q0, sqrt(K / J_link) (0 without elastic axes)."""
    elastic = drives.elastic
    if not elastic.any():
        return 0.0
    model = robot.model
    inertia = np.diag(pin.crba(model, model.createData(), np.asarray(q0, float))) - np.asarray(model.armature, float)
    omega = np.sqrt(drives.stiffness[elastic] / np.maximum(inertia[elastic], 1e-9))
    return float(2.0 * np.pi / omega.min())


@dataclass(frozen=True, eq=False)
class RawMotion:
    """A motion along the path in time: ``profile`` from time 0 on (at rest at its end), and before 0 the
    ``previous`` raw motion at time t + ``offset`` (the segment this one was re-timed from), or the profile's
    start at rest."""

    profile: object
    previous: "RawMotion | None" = None
    offset: float = 0.0

    @property
    def duration(self) -> float:
        return float(self.profile.duration)

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta, theta_dot, theta_ddot) (K,) at times t (K,) [s]."""
        t = np.asarray(t, float)
        out = [np.asarray(v, float) for v in self.profile.state_at_time(np.maximum(t, 0.0))]
        before = t < 0.0
        if self.previous is not None and before.any():
            for arr, v in zip(out, self.previous.state(t[before] + self.offset)):
                arr[before] = v
        elif before.any():
            out[1][before], out[2][before] = 0.0, 0.0
        return out[0], out[1], out[2]


def _box_average(raw: RawMotion, t: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, theta_dot, theta_ddot) (K,) at times t (K,) [s, evenly spaced] of the raw motion averaged over
    the last ``width`` seconds (rounded to whole table steps)."""
    step = t[1] - t[0] if len(t) > 1 else width
    m = max(1, int(round(width / step)))
    width = m * step
    fine = np.concatenate([t[0] - step * np.arange(m, 0, -1), t])
    theta, theta_dot, _ = raw.state(fine)
    mid = 0.5 * (theta[1:] + theta[:-1]) * step
    area = np.concatenate([[0.0], np.cumsum(mid)])
    averaged = (area[m:] - area[:-m]) / width
    now_dot, before_dot = theta_dot[m:], theta_dot[:-m]
    return averaged, (theta[m:] - theta[:-m]) / width, (now_dot - before_dot) / width


def shaper_support(period: float) -> float:
    """How much longer [s] the smoothed motion lasts than the raw one (0 for period 0): a quarter period."""
    return 0.25 * period if period > 0.0 else 0.0


def path_motion(raw: RawMotion, t: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, theta_dot, theta_ddot) (K,) at times t (K,) [s, evenly spaced] of the raw motion smoothed for a
    gear mode of ``period`` [s] (0: the raw motion itself): averaged over the last quarter period, so that its
    acceleration ramps over T/4 instead of stepping (a bounded jerk the motors can pass through the gears;
    the refinement on the nominal arm takes the mode's response out of the references). The weights are
    positive, so the motion stays on the path and never runs back; it lasts the raw one plus T/4 and lags it
    by T/8 on average."""
    if period <= 0.0:
        return raw.state(t)
    return _box_average(raw, t, 0.25 * period)


def _fade(t: np.ndarray, width: float) -> np.ndarray:
    """1 up to time 0, a half cosine down to 0 at ``width`` [s], 0 after (K,)."""
    return 0.5 * (1.0 + np.cos(np.pi * np.clip(t / width, 0.0, 1.0)))


def motor_correction(table: ReferenceTable, dm: np.ndarray, drives: DriveParameters, robot: Robot) -> ReferenceTable:
    """The table with the motor-side correction dm (K, n) [rad] at its rows (0 at its first row) added before
    the low-pass inverse, on position and (its derivative) speed, clipped into the joint limits."""
    step = table.t[1] - table.t[0]
    per = max(1, int(round(drives.cycle / step)))
    alpha = lowpass_alpha(drives)
    lim = robot.limits
    q = np.clip(table.q + _invert_lowpass(dm, alpha, per), lim.lower, lim.upper)
    qd = np.clip(table.qd + _invert_lowpass(np.gradient(dm, step, axis=0), alpha, per), -lim.velocity, lim.velocity)
    return replace(table, q=q, qd=qd, correction=dm)


def build_reference(robot: Robot, path, raw: RawMotion, mode: str, drives: DriveParameters | None,
                    step: float = defaults.EGM_TABLE_STEP, period: float = 0.0,
                    carried: tuple | None = None) -> ReferenceTable:
    """The table of references for the raw motion ``raw`` along ``path`` in ``mode`` (one of MODES); with
    shaping, the motion shaped in the path coordinate for a gear mode of ``period`` [s] (see
    :func:`path_motion`). The table starts one EGM cycle early (the raw motion before 0 is what ran before),
    so that the low-pass inverse at its first row continues the references already sent; ``carried``: (the
    previous table, the plan time of the switch in it): its motor-side correction continues and fades out
    over ``defaults.EGM_REFINE_FADE`` (a re-timed segment is built within a cycle, unrefined; the fade keeps
    the sent reference continuous), and the segment takes the previous table's form: plain (the motor motion
    sent as it is, the low-pass not inverted) when that one is."""
    period = period if mode != "none" else 0.0
    duration = raw.duration + shaper_support(period)
    per = 0 if mode == "none" else max(1, int(round(drives.cycle / step)))
    fading = mode != "none" and carried is not None and carried[0].correction is not None
    plain = mode != "none" and carried is not None and carried[0].plain
    end = max(duration, defaults.EGM_REFINE_FADE) if fading else duration  # the carried correction fades out
    # smoothed: one row more, the average's width is rounded to whole rows (by at most half a row)
    t = np.arange(-per, int(np.ceil(end / step)) + (2 if period > 0.0 else 1)) * step
    theta, theta_dot, theta_ddot = path_motion(raw, t, period)
    q, dq, ddq = path.evaluate(theta)
    qd = dq * theta_dot[:, None]
    deflection = np.zeros_like(q)
    sent_q, sent_qd = q, qd
    correction = None
    if mode != "none":
        qdd = dq * theta_ddot[:, None] + ddq * (theta_dot**2)[:, None]
        deflection = gear_deflection(robot, drives, q, qd, qdd)
        m = q + deflection
        md = np.gradient(m, step, axis=0) if len(t) > 2 else np.zeros_like(m)
        alpha = lowpass_alpha(drives)
        if plain:  # the motor motion as it is, the correction through the low-pass inverse (refine.py's P u)
            sent_q, sent_qd = m, md
        else:
            sent_q, sent_qd = _invert_lowpass(m, alpha, per), _invert_lowpass(md, alpha, per)
        if fading:
            correction = carried[0].correction_at(t + carried[1]) * _fade(t, defaults.EGM_REFINE_FADE)[:, None]
            sent_q = sent_q + _invert_lowpass(correction, alpha, per)
            sent_qd = sent_qd + _invert_lowpass(np.gradient(correction, step, axis=0), alpha, per)
    lim = robot.limits
    sent_q = np.clip(sent_q, lim.lower, lim.upper)[per:]
    sent_qd = np.clip(sent_qd, -lim.velocity, lim.velocity)[per:]
    cut = slice(per, None)
    return ReferenceTable(t[cut] - t[per], sent_q, sent_qd, theta[cut], q[cut], duration, deflection[cut], path, raw,
                          np.stack([theta, theta_dot, theta_ddot], axis=1)[cut],
                          None if correction is None else correction[cut],
                          0.0 if mode == "none" else drives.transport_delay, plain)
