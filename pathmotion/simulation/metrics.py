"""Closed-loop metrics, failure records and the result value object.

Deviations are measured from the path, not from a clock-indexed point:

* joint deviation e = q - Phi(theta), theta the projection of the true q onto the path (the
  controller's own projection uses the measured, possibly noisy q); max over samples and joints of
  |e|, RMS over samples and joints;
* TCP path deviation: distance of the TCP to the desired TCP path (the lift's task path when the
  joint path carries ``task_path``, else FK(Phi(theta))), minimized over the path near the current
  theta: a polyline through 4x the controller table's points, so the figure is exact to the chord
  sag (segment length)^2 * curvature / 8, below a micrometre for the paths here;
* path accuracy (ISO 9283's path accuracy): the largest TCP path deviation over the run [m];
* sharp deviation: distance to the original sharp task path (``original_task_path``, when a blend
  replaced a corner), the exact closest point over all its segments (:func:`sharp_path_deviation`);
  None without one;
* cornering deviation: per sharp corner of the sharp path (the original task path, else the task path
  itself), the largest TCP distance from that path among the samples whose nearest corner point it is;
* torque ratios: max over samples and joints of |tau| / tau_limit, applied (saturated, <= 1) and commanded;
* saturation time: number of samples in which any joint was clipped, times the sample time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .. import defaults
from ..control.kernels import ZERO_SPEED2
from ..lift.joint_path import JointPath
from ..robot import Robot, fk

#: Corner points closer than this to a TCP sample count as equally near (split by theta) [m].
CORNER_TIE = 1e-6
#: A first Newton step of :func:`polish_projection` below this fraction of the path's length is finished on
#: Phi's Taylor series about the start (error |Phi'''| step^3 / 6: ~1e-24 rad for a 1 m path).
POLISH_TAYLOR_STEP = 1e-8
#: Failure reasons, in the order they are checked each sample.
FAILURE_REASONS = ("diverged", "left_path_range", "path_tolerance", "orientation_tolerance", "joint_tolerance",
                   "saturation", "timeout")


@dataclass(frozen=True)
class Failure:
    """Why, when [s] and where (theta, unwrapped on closed paths) tracking failed; how far: ``value`` against
    ``limit``, both in ``unit`` (the TCP's largest distance [m], the joint deviation [rad], the saturated
    stretch [s], the fraction of the path reached), None where it does not apply."""

    reason: str
    t: float
    theta: float
    message: str
    value: float | None = None
    limit: float | None = None
    unit: str = ""

    def as_dict(self) -> dict:
        return {"reason": self.reason, "t": float(self.t), "theta": float(self.theta), "message": self.message,
                "value": None if self.value is None else float(self.value),
                "limit": None if self.limit is None else float(self.limit), "unit": self.unit}


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """One closed-loop run. Signals at the controller samples t (K,) [s]:

    theta (K,) projection of the true q on the path; q, qd (K, n); tau (K, n) applied (saturated) and
    tau_command (K, n) as commanded [N m]; q_desired (K, n) = Phi(theta); tcp, tcp_desired (K, 3) [m];
    joint_deviation (K,) = max_j |q - Phi(theta)|; path_deviation (K,) [m]; corner_deviation (K,) [m]
    or None; cornering_deviation (C,) [m] per sharp corner or None. planned_duration [s]: the profile's
    duration (one period on a closed path); cycle_time [s]: when the TCP first reached the end of the path
    within the path tolerance (open; the plan's own time inside that ball credited) or the mean period
    (closed), None if not reached or tracking failed; settle_time [s]: when it entered that ball for good
    (open paths ending at rest). path_tolerance [m]: the tolerance the verdict used. identified: what the
    controller's payload identification held at the end (:meth:`.PayloadEstimator.identified`), or None. events:
    one dict per re-timing event (simulation/events.py: kind, time, reaction time, stop distance).
    """

    controller: str
    sample_time: float
    closed: bool
    t: np.ndarray
    theta: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    tau_command: np.ndarray
    q_desired: np.ndarray
    tcp: np.ndarray
    tcp_desired: np.ndarray
    joint_deviation: np.ndarray
    path_deviation: np.ndarray
    corner_deviation: np.ndarray | None
    torque_limit: np.ndarray
    planned_duration: float
    cycle_time: float | None
    saturation_time: float
    failure: Failure | None = None
    settle_time: float | None = None
    path_tolerance: float | None = None
    cornering_deviation: np.ndarray | None = None
    identified: dict | None = None
    events: tuple = ()
    substeps: int | None = None
    substeps_note: str | None = None
    stopped_at_failure: bool = False
    path_end_index: int | None = None
    orientation_deviation: np.ndarray | None = None
    path_tolerance_deg: float | None = None

    @property
    def tracking_ok(self) -> bool:
        return self.failure is None

    def on_path(self) -> slice:
        """The samples on the path (ISO 9283's path accuracy is over the path): all of them, except after an open
        path's arrival (``path_end_index``: the sample of the cycle time), where the arm only settles at the end
        (settle_time_s judges that)."""
        return slice(None) if self.path_end_index is None else slice(0, self.path_end_index + 1)

    def path_accuracy(self) -> float:
        """The largest TCP distance [m] from the planned path on the path (:meth:`on_path`); 0 without samples."""
        dev = self.path_deviation[self.on_path()]
        return float(np.max(dev)) if dev.size else 0.0

    def path_accuracy_deg(self) -> float | None:
        """ISO 9283's orientation path accuracy (ATo): the largest angle [deg] between the tool's orientation and
        the planned one on the path (:meth:`on_path`); None when not computed."""
        if self.orientation_deviation is None:
            return None
        ang = self.orientation_deviation[self.on_path()]
        return float(np.degrees(np.max(ang))) if ang.size else 0.0

    def summary(self) -> dict:
        """Headline figures (SI units), JSON-serializable."""
        e = self.q - self.q_desired
        corner = self.cornering_deviation
        return {
            "controller": self.controller,
            "sample_time_s": self.sample_time,
            "substeps": self.substeps,
            "substeps_note": self.substeps_note,
            "planned_duration_s": self.planned_duration,
            "cycle_time_s": self.cycle_time,
            "settle_time_s": self.settle_time,
            "path_tolerance_m": self.path_tolerance,
            "path_accuracy_m": self.path_accuracy(),
            "path_tolerance_deg": self.path_tolerance_deg,
            "path_accuracy_deg": self.path_accuracy_deg(),
            "max_sharp_deviation_m": (None if self.corner_deviation is None or not self.corner_deviation.size
                                      else float(np.max(self.corner_deviation))),
            "cornering_deviation_m": None if corner is None else [float(c) for c in corner],
            "max_joint_deviation_rad": float(np.max(np.abs(e))) if e.size else 0.0,
            "rms_joint_deviation_rad": float(np.sqrt(np.mean(e**2))) if e.size else 0.0,
            "max_torque_ratio": float(np.max(np.abs(self.tau) / self.torque_limit)) if e.size else 0.0,
            "max_commanded_torque_ratio": float(np.max(np.abs(self.tau_command) / self.torque_limit)) if e.size
            else 0.0,
            "saturation_time_s": self.saturation_time,
            "tracking_ok": self.tracking_ok,
            "figures_cover_t_s": [0.0, float(self.t[-1])] if self.t.size else [0.0, 0.0],
            "coverage_note": (f"the run stopped at its first failure: every figure covers t in [0, {self.t[-1]:.4g}] s "
                              "only (simulate --full runs to the end)") if self.stopped_at_failure and self.t.size
            else None,
            "failure": None if self.failure is None else self.failure.as_dict(),
            **_identified_payload(self.identified),
            "identified_viscous_friction": None if self.identified is None else self.identified["viscous_friction"],
            "identified_coulomb_friction": None if self.identified is None else self.identified["coulomb_friction"],
            "events": [dict(e) for e in self.events] or None,
        }


def _identified_payload(identified: dict | None) -> dict:
    """The summary's payload keys: the identified mass [kg] and centre of mass [m] when significant (else None,
    with a note saying what the figure is), and the mass's standard error [kg]."""
    if identified is None:
        return {"identified_payload_kg": None, "identified_payload_com_m": None, "identified_payload_std_kg": None,
                "identified_payload_note": None}
    m, std, significant = identified["mass_kg"], identified.get("mass_std_kg"), identified.get("significant", True)
    note = None if significant else (
        f"{m:.3g} kg +- {std:.3g} kg at the flange is within {defaults.IDENTIFIED_SIGNIFICANCE:g} standard errors of "
        "0: no payload identified (what the model lacks there, e.g. link inertia errors, not a payload)")
    return {"identified_payload_kg": m if significant else None, "identified_payload_com_m": identified["com_m"],
            "identified_payload_std_kg": std, "identified_payload_note": note}


def _wrap(path: JointPath, theta: np.ndarray) -> np.ndarray:
    lo, hi = path.domain
    return lo + (theta - lo) % (hi - lo) if path.closed else np.clip(theta, lo, hi)


def _newton_step(path: JointPath, q, theta, phi, dphi, ddphi) -> np.ndarray:
    """theta (K,) after one Newton step on Phi'^T (q - Phi) = 0 from the path values at theta (each (K, n))."""
    y = q - phi
    d2 = np.sum(dphi * dphi, axis=1)
    curv = d2 - np.sum(ddphi * y, axis=1)
    den = np.where(curv > 0.5 * d2, curv, d2)
    step = np.divide(np.sum(dphi * y, axis=1), den, out=np.zeros_like(den), where=d2 > ZERO_SPEED2)
    theta = theta + step
    return np.clip(theta, *path.domain) if not path.closed else theta


def _polish_exact(path: JointPath, q: np.ndarray, theta: np.ndarray, iterations: int):
    """``iterations`` Newton steps, the exact path evaluated at every step: (theta, Phi(theta))."""
    for _ in range(iterations):
        theta = _newton_step(path, q, theta, *path.evaluate(_wrap(path, theta)))
    return theta, path.evaluate(_wrap(path, theta))[0]


def _taylor(phi, dphi, ddphi, d):
    """(Phi, Phi', Phi'') at theta0 + d (K,) from their values at theta0 (each (K, n)), to second order."""
    d = d[:, None]
    return phi + d * (dphi + 0.5 * d * ddphi), dphi + d * ddphi, ddphi


def _smooth_step(path: JointPath, start: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(K,) bool: |step| <= POLISH_TAYLOR_STEP of the length and no break, kink or domain end between the wrapped
    start (K,) and start + step (either included), so that Phi there is its Taylor series at the start."""
    lo, hi = path.domain
    end = start + step
    ok = (np.abs(step) <= POLISH_TAYLOR_STEP * (hi - lo)) & (end >= lo) & (end <= hi)
    a, b = np.minimum(start, end), np.maximum(start, end)
    for x in (*path.breaks, *path.kinks):
        ok &= ~((a <= x) & (x <= b))
    return ok


def polish_projection(path: JointPath, q: np.ndarray, theta: np.ndarray, iterations: int = 2):
    """Newton steps on Phi'(theta)^T (q - Phi(theta)) = 0 with the exact path, vectorized.

    theta (K,) start values (unwrapped on closed paths, kept unwrapped); returns (theta, Phi(theta)).
    The path is evaluated exactly once, at the start values. The controller's own projection leaves theta
    within ~1e-10 of the answer: for the samples whose first step is below POLISH_TAYLOR_STEP of the length,
    inside one smooth piece, the later steps and the final Phi use the second-order Taylor series of Phi
    about the start (error |Phi'''| step^3 / 6, below the round-off of Phi); the others (a larger step, a
    break in reach) evaluate the path at every step (:func:`_polish_exact`).
    """
    theta = np.asarray(theta, dtype=float).copy()
    if iterations < 1 or not len(theta):
        return theta, path.evaluate(_wrap(path, theta))[0]
    start = _wrap(path, theta)
    anchor = theta if path.closed else start  # Phi's Taylor series at start is in theta - anchor
    values = path.evaluate(start)
    first = _newton_step(path, q, theta, *values)
    local = _smooth_step(path, start, first - anchor)
    out_theta, out_phi = first.copy(), np.empty(np.shape(q), dtype=float)
    if local.any():
        base = [v[local] for v in values]
        th0, ql, th = anchor[local], q[local], first[local]
        for _ in range(iterations - 1):
            th = _newton_step(path, ql, th, *_taylor(*base, th - th0))
        out_theta[local], out_phi[local] = th, _taylor(*base, th - th0)[0]
    rest = ~local
    if rest.any():
        out_theta[rest], out_phi[rest] = _polish_exact(path, q[rest], first[rest], iterations - 1)
    return out_theta, out_phi


@numba.njit(cache=True)
def polyline_distance_local(points, line, centre, window, closed):
    """Distance (K,) and nearest point (K, 3) of points (K, 3) to the polyline line (S+1, 3), over
    segments centre-window .. centre+window (wrapped on closed polylines). Compiled: K x (2 window + 1)
    point-segment distances without (K, 2 window + 1, 3) temporaries."""
    segs = len(line) - 1
    k_count = points.shape[0]
    dist = np.empty(k_count)
    near = np.empty((k_count, 3))
    for k in range(k_count):
        best = np.inf
        for off in range(-window, window + 1):
            i = centre[k] + off
            i = i % segs if closed else min(max(i, 0), segs - 1)
            ab0 = line[i + 1, 0] - line[i, 0]
            ab1 = line[i + 1, 1] - line[i, 1]
            ab2 = line[i + 1, 2] - line[i, 2]
            den = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
            t = 0.0
            if den > 0:
                t = ((points[k, 0] - line[i, 0]) * ab0 + (points[k, 1] - line[i, 1]) * ab1
                     + (points[k, 2] - line[i, 2]) * ab2) / den
                t = min(max(t, 0.0), 1.0)
            n0, n1, n2 = line[i, 0] + t * ab0, line[i, 1] + t * ab1, line[i, 2] + t * ab2
            d = np.sqrt((points[k, 0] - n0) ** 2 + (points[k, 1] - n1) ** 2 + (points[k, 2] - n2) ** 2)
            if d < best:
                best = d
                near[k, 0], near[k, 1], near[k, 2] = n0, n1, n2
        dist[k] = best
    return dist, near


def planned_tcp_line(robot: Robot, path: JointPath, grid: np.ndarray) -> np.ndarray:
    """The planned TCP path (M, 3) [m] at theta = grid (M,): the lift's task path when the joint path carries
    ``task_path``, else FK(Phi(theta))."""
    task = getattr(path, "task_path", None)
    if task is not None:
        return np.ascontiguousarray(task.evaluate(grid)[0], dtype=float)
    return np.ascontiguousarray(fk(robot, path.evaluate(grid)[0])[0], dtype=float)


def line_window(points: int) -> int:
    """Segments searched on either side of the current theta's segment of a TCP polyline of ``points``."""
    return max(2, points // 50)


def tcp_path_deviation(robot: Robot, path: JointPath, q: np.ndarray, theta: np.ndarray, grid: np.ndarray,
                       line: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tcp (K, 3), nearest desired TCP point (K, 3), distance (K,) [m]) for joint states q (K, n) near theta
    (K,), the planned TCP path being the polyline ``line`` (M, 3) at ``grid`` (M,) (:func:`planned_tcp_line`)."""
    tcp = fk(robot, q)[0] if len(q) else np.zeros((0, 3))
    if not len(q):
        return tcp, tcp.copy(), np.zeros(0)
    th = _wrap(path, theta)
    centre = np.clip(np.searchsorted(grid, th) - 1, 0, len(grid) - 2)
    dist, near = polyline_distance_local(np.ascontiguousarray(tcp), line, centre.astype(np.int64),
                                          line_window(len(grid)), bool(path.closed))
    return tcp, near, dist


def orientation_deviation(robot: Robot, q: np.ndarray, q_desired: np.ndarray) -> np.ndarray:
    """(K,) [rad]: the angle of the rotation between the tool's orientation at q (K, n) and at q_desired (K, n)
    (the planned orientation at the projection), |log(R_d^T R)|."""
    if not len(q):
        return np.zeros(0)
    rot, rot_d = fk(robot, q)[1], fk(robot, q_desired)[1]
    rel = np.einsum("kji,kjl->kil", rot_d, rot)
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    sin = np.linalg.norm(np.stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0],
                                   rel[:, 1, 0] - rel[:, 0, 1]], axis=1), axis=1) / 2.0
    return np.arctan2(sin, cos)  # accurate for small and large angles alike


def sharp_path_deviation(task_path, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance (K,) [m], nearest point (K, 3) [m]) of ``points`` (K, 3) to ``task_path``: the exact
    closest point over all its segments (each segment's own ``closest``)."""
    points = np.asarray(points, float)
    best_d = np.full(len(points), np.inf)
    best_p = np.zeros_like(points)
    if not len(points):
        return best_d, best_p
    for seg in task_path.segments:
        s, d = seg.closest(points)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        best_p[better] = seg.evaluate(s)[0][better]
    return best_d, best_p


def sharp_task_path(path: JointPath):
    """The sharp task path the corners are measured against: ``original_task_path`` (before blends), else the
    task path itself; None for a joint path."""
    original = getattr(path, "original_task_path", None)
    return original if original is not None else getattr(path, "task_path", None)


def cornering_deviation(path: JointPath, tcp: np.ndarray, theta: np.ndarray) -> np.ndarray | None:
    """Per sharp corner of :func:`sharp_task_path` (C,) [m]: the largest distance of the TCP (K, 3) from the
    sharp path (exact, :func:`sharp_path_deviation`) among the samples whose nearest corner point it is
    (corners at the same point, a path passing twice, split by theta (K,) mapped onto the sharp path in
    proportion to its length); None without corners."""
    sharp = sharp_task_path(path)
    kinks = np.asarray(getattr(sharp, "kinks", ()), dtype=float)
    if sharp is None or not len(kinks):
        return None
    points = np.atleast_2d(sharp.evaluate(kinks)[0])
    out = np.zeros(len(kinks))
    if len(tcp):
        (lo, hi), (slo, shi) = path.domain, sharp.domain
        mapped = slo + (np.asarray(theta) - lo) * (shi - slo) / (hi - lo)
        distance = np.linalg.norm(tcp[:, None, :] - points[None], axis=2)
        key = np.round(distance / CORNER_TIE) + np.abs(mapped[:, None] - kinks[None]) / (1.0 + shi - slo)
        np.maximum.at(out, np.argmin(key, axis=1), sharp_path_deviation(sharp, tcp)[0])
    return out


def original_path_deviation(path: JointPath, tcp: np.ndarray) -> np.ndarray | None:
    """Distance (K,) [m] of the TCP to the original sharp task path, or None when there is none."""
    original = getattr(path, "original_task_path", None)
    if original is None:
        return None
    return sharp_path_deviation(original, tcp)[0]
