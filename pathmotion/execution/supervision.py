"""execute's path supervision: does the arm the controller reports stay on the plan's path?

Each robot message's motor-side joints, less the gear deflection the shaping planned at that moment, estimate
the link side q_hat (as the orbital loop does, :mod:`.orbital`). It is projected onto the plan's joint path
near the previous projection by simulate's own monitor (:func:`pathmotion.simulation.monitor.monitor_state`:
the controller's local projection, kinks included), which gives theta_hat and the joint deviation
max_j |q_hat - Phi(theta_hat)| [rad], the quantity simulate's ``joint_tolerance`` rule judges; the TCP
distance [m] is that of FK(q_hat) from FK(Phi(theta_hat)), the planned TCP at the projection (an upper bound
of the distance to the planned TCP path, equal to it to first order). Both peaks are kept for summary.json. The
TCP distance is computed (two forward kinematics) only where it can matter: at a new peak deviation, a trip, or
where its bound sum_j r_j |q_hat_j - Phi_j| (r_j: the most joint j's axis can be away from the TCP, the sum of
the link offsets after it) reaches the peak distance so far; elsewhere the peak cannot change.
A deviation above the tolerance trips the supervision; the streamer then stops along the path, and the
supervision is armed again when the motion resumes from that stop (the first trip is what summary.json reports).

While the stop runs, a deviation that keeps growing (:data:`GROWTH`, :data:`GROWTH_CYCLES`) means a loop
that pushes the arm away: the streamer then switches the orbital correction off and streams the shaped stop
alone (:class:`.streamer.Streamer`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import pinocchio as pin

from ..control.kernels import PathArrays, Projection, evaluate_at
from ..control.path_table import PathTable
from ..simulation.monitor import monitor_state

#: During a stop, the deviation counts as growing when it is above this multiple of its value when the stop
#: began [-] ...
GROWTH = 1.5
#: ... and has grown in this many consecutive messages (not a single noisy sample) [-].
GROWTH_CYCLES = 5
#: Slack on the bound of the TCP distance (the round-off of two forward kinematics is ~1e-16 m) [m].
TCP_BOUND_SLACK = 1e-9


@dataclass
class Excursion:
    """Where the supervision saw the arm: time t [s, robot clock from the first message], theta (the
    projection), joint deviation [rad], TCP distance [m]."""

    t: float = 0.0
    theta: float = 0.0
    deviation: float = 0.0
    tcp: float = 0.0


@numba.njit(cache=True)
def _project(grid, coeffs, closed, kinks, iterations, tol, max_step, reported, deflection, guess, qd, speed_limit,
             speed_eps, reach):
    """(theta, deviation, tcp_bound, q_hat, Phi(theta)) of one message: q_hat = reported - deflection projected
    by :func:`pathmotion.simulation.monitor.monitor_state` near ``guess``, on the path PathArrays(grid, coeffs,
    closed, kinks) with the Projection(iterations, tol, max_step); tcp_bound = sum_j reach_j |q_hat_j - Phi_j|
    (joints where they agree add nothing, also with an infinite reach). One compiled call per EGM cycle, its
    arguments arrays and numbers (a named tuple argument costs microseconds to type at every call)."""
    path = PathArrays(grid, coeffs, closed, kinks)
    q_hat = reported - deflection
    theta, _, deviation, _, _, _ = monitor_state(path, q_hat, qd, guess, Projection(iterations, tol, max_step),
                                                 speed_limit, speed_eps)
    phi = evaluate_at(path, theta)[0]
    bound = 0.0
    for j in range(q_hat.shape[0]):
        gap = abs(q_hat[j] - phi[j])
        if gap > 0.0:
            bound += reach[j] * gap
    return theta, deviation, bound, q_hat, phi


def tcp_reach(model, frame: int) -> np.ndarray:
    """r_j (nv,) [m]: a bound of |dTCP/dq_j| for a chain of revolute joints, the sum of the link offsets from
    joint j to the TCP frame (0 for joints off its chain); infinite for every joint when the chain has another
    kind of joint (no bound then)."""
    f = model.frames[frame]
    chain, j = [], f.parentJoint
    while j > 0:
        chain.append(j)
        j = model.parents[j]
    chain.reverse()
    names = [model.joints[j].shortname() for j in chain]
    if model.nq != model.nv or not all(n.startswith("JointModelR") and not n.startswith("JointModelRUB")
                                       for n in names):
        return np.full(model.nv, np.inf)
    reach = np.zeros(model.nv)
    offset = float(np.linalg.norm(f.placement.translation))
    for i in range(len(chain) - 1, -1, -1):
        reach[model.joints[chain[i]].idx_v] = offset
        offset += float(np.linalg.norm(model.jointPlacements[chain[i]].translation))
    return reach


class PathSupervision:
    """The reported arm against the path of ``path`` (a JointPath) for ``robot``; ``tolerance`` [rad]: the
    largest joint deviation max_j |q_hat - Phi(theta)| before the supervision trips."""

    def __init__(self, robot, path, tolerance: float):
        table = PathTable.from_path(path)
        self.arrays, self.projection = table.arrays, table.projection()
        self.speed2_eps = 0.0
        self.tolerance = float(tolerance)
        self.model, self.data, self.frame = robot.model, robot.model.createData(), robot.tcp_frame_id
        self.theta = float(path.domain[0])
        self._zero, self._unbounded = np.zeros(path.n), np.full(path.n, np.inf)
        self.deviation = 0.0  # of the last message [rad]
        self._reach = tcp_reach(self.model, self.frame)
        self.peak = Excursion(theta=self.theta)
        self.peak_tcp = 0.0
        self.tripped: Excursion | None = None  # the first trip
        self.trip: Excursion | None = None  # the latest
        self.armed = True
        self._growing, self._baseline, self._previous = 0, None, 0.0
        self._path = (*self.arrays, *self.projection)  # _project's first arguments
        # the compiled kernel loads (or compiles) now, not at the first robot message
        _project(*self._path, self._zero, self._zero, self.theta, self._zero, self._unbounded, self.speed2_eps,
                 self._reach)

    def rearm(self) -> None:
        """Supervise again (the motion resumes after a stop)."""
        self.armed = True
        self._growing, self._baseline = 0, None

    def _tcp(self, q: np.ndarray) -> np.ndarray:
        """The TCP position (3,) [m] at q (a view into the model data: the next call overwrites it)."""
        pin.forwardKinematics(self.model, self.data, q)
        return pin.updateFramePlacement(self.model, self.data, self.frame).translation

    def check(self, reported: np.ndarray, deflection: np.ndarray, t: float) -> bool:
        """One robot message at robot time t [s]: reported (n,) motor-side joints [rad], deflection (n,) the
        planned gear deflection [rad]. True when the deviation is above the tolerance while armed (which
        disarms it)."""
        theta, deviation, bound, q_hat, phi = _project(*self._path, reported, deflection, self.theta, self._zero,
                                                       self._unbounded, self.speed2_eps, self._reach)
        self.theta, self.deviation = theta, deviation
        peak = deviation > self.peak.deviation
        trip = self.armed and deviation > self.tolerance
        if not (peak or trip or bound + TCP_BOUND_SLACK > self.peak_tcp):
            return False  # the TCP distance is at most the peak so far: nothing to record
        gap = self._tcp(q_hat).copy()
        gap -= self._tcp(phi)
        tcp = math.sqrt(gap @ gap)
        if peak:
            self.peak = Excursion(t, theta, deviation, tcp)
        if tcp > self.peak_tcp:
            self.peak_tcp = tcp
        if trip:
            self.armed = False
            self.trip = Excursion(t, theta, deviation, tcp)
            self.tripped = self.tripped or self.trip
            return True
        return False

    def diverging(self) -> bool:
        """Called once per message while a stop runs: the deviation has kept growing since the first call
        (see :data:`GROWTH`)."""
        dev = self.deviation
        if self._baseline is None:
            self._baseline, self._previous = dev, dev
            return False
        self._growing = self._growing + 1 if dev > self._previous else 0
        self._previous = dev
        return dev > GROWTH * self._baseline and self._growing >= GROWTH_CYCLES

    def reason(self, e: Excursion | None = None) -> str:
        """A stop's reason: how far, where (``e``, default the first trip), the tolerance."""
        e = e or self.tripped
        return (f"the arm left the path: joint deviation {e.deviation:.4g} rad (TCP {e.tcp * 1e3:.4g} mm from the "
                f"path) at theta = {e.theta:.6g}, t = {e.t:.4g} s; tolerance {self.tolerance:.4g} rad "
                "(simulate.joint_tolerance)")

    def figures(self) -> dict:
        """summary.json's supervision figures (SI units)."""
        p = self.peak
        return {"path_deviation_tolerance_rad": self.tolerance, "peak_path_deviation_rad": p.deviation,
                "peak_path_deviation_t_s": p.t, "peak_path_deviation_theta": p.theta,
                "peak_path_deviation_tcp_m": self.peak_tcp}
