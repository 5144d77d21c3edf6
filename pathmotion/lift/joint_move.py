"""Joint moves (MoveJ / MoveAbsJ) as pieces of the constraint q = Phi(theta), and the joint paths that chain
them with lifted task paths on one path coordinate.

A joint move from q0 to q1 covers theta in [a, a + L], L the arc length of its TCP trace FK(q0 + u (q1 - q0)),
u in [0, 1] (:func:`tcp_arc_length`), so theta stays in metres along the whole chain, and

    Phi(theta) = q0 + (theta - a) / L (q1 - q0),   Phi' = (q1 - q0) / L,   Phi'' = Phi''' = 0   (exact).

theta is the TCP arc length only on average there: the TCP moves at |J_v Phi'| theta_dot.

:class:`JointBlend` is the zone blend of a connection that involves a joint move: a quintic polynomial in theta
that matches Phi, Phi' and Phi'' of both neighbours at the ends of the zone, so Phi stays C2 there.
:class:`PiecewiseJointPath` is the chain: pieces (any :class:`JointPath`) over consecutive theta ranges.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import PathError
from ..robot import Robot, fk, frame_acceleration_bias, jacobian
from .joint_path import JointPath

#: Gauss-Legendre nodes per panel of the TCP arc-length integral, and the relative change between two panel
#: counts below which the integral has converged [-].
ARC_NODES = 8
ARC_RELATIVE = 1e-12
ARC_MAX_PANELS = 4096


def _scalar_out(out, scalar):
    return tuple(o[0] for o in out) if scalar else tuple(out)


def tcp_arc_length(robot: Robot, q0, q1) -> float:
    """Arc length [m] of the TCP trace of the joint line q0 -> q1 (each (n,) [rad]): the integral over u in
    [0, 1] of |J_v(q(u)) (q1 - q0)|, composite Gauss-Legendre with the panels doubled until two counts agree
    to ARC_RELATIVE."""
    q0, dq = np.asarray(q0, float), np.asarray(q1, float) - np.asarray(q0, float)
    nodes, weights = np.polynomial.legendre.leggauss(ARC_NODES)
    nodes, weights = 0.5 * (nodes + 1.0), 0.5 * weights

    def integral(panels: int) -> float:
        u = ((np.arange(panels)[:, None] + nodes[None]) / panels).ravel()
        speed = np.linalg.norm(jacobian(robot, q0 + u[:, None] * dq)[:, :3] @ dq, axis=1)
        return float(np.sum(speed * np.tile(weights, panels)) / panels)

    panels, value = 4, integral(4)
    while panels < ARC_MAX_PANELS:
        panels *= 2
        finer = integral(panels)
        if abs(finer - value) <= ARC_RELATIVE * max(finer, 1e-300):
            return finer
        value = finer
    return value


@dataclass(frozen=True, eq=False)
class LinearJointPath(JointPath):
    """Phi linear in theta from q0 (at domain[0]) to q1 (at domain[1]), each (n,) [rad]."""

    q0: np.ndarray = field(default=None, repr=False)
    q1: np.ndarray = field(default=None, repr=False)

    def evaluate3(self, theta, side: str = "right"):
        th, scalar = self._check_theta(theta)
        rate = (self.q1 - self.q0) / self.length
        q = self.q0 + (th - self.domain[0])[:, None] * rate
        d1 = np.broadcast_to(rate, q.shape).copy()
        return _scalar_out((q, d1, np.zeros_like(q), np.zeros_like(q)), scalar)

    def evaluate(self, theta, side: str = "right"):
        return self.evaluate3(theta, side)[:3]


@dataclass(frozen=True, eq=False)
class JointBlend(JointPath):
    """Quintic Phi on domain (a, b) matching (Phi, Phi', Phi'') = ``start`` at a and ``end`` at b (each three
    (n,) arrays); coeffs (6, n) in t = (theta - a) / (b - a)."""

    coeffs: np.ndarray = field(default=None, repr=False)

    @classmethod
    def between(cls, a: float, b: float, start, end, joint_names=None) -> "JointBlend":
        h = b - a
        (p0, v0, a0), (p1, v1, a1) = ([np.asarray(x, float) for x in s] for s in (start, end))
        v0, v1, a0, a1 = h * v0, h * v1, h * h * a0, h * h * a1
        d = p1 - p0
        c3 = 10 * d - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
        c4 = -15 * d + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
        c5 = 6 * d - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
        coeffs = np.stack([p0, v0, 0.5 * a0, c3, c4, c5])
        return cls(n=len(p0), domain=(float(a), float(b)), coeffs=coeffs, joint_names=joint_names)

    def evaluate3(self, theta, side: str = "right"):
        th, scalar = self._check_theta(theta)
        h = self.length
        t = ((th - self.domain[0]) / h)[:, None]
        out = []
        for d in range(4):
            acc = np.zeros((len(th), self.n))
            for k in range(5, d - 1, -1):
                factor = np.prod(np.arange(k - d + 1, k + 1)) if d else 1.0
                acc = acc * t + factor * self.coeffs[k]
            out.append(acc / h**d)
        return _scalar_out(out, scalar)

    def evaluate(self, theta, side: str = "right"):
        return self.evaluate3(theta, side)[:3]


@dataclass(frozen=True)
class Piece:
    """``path`` evaluated at theta - shift over the chain's theta in [lo, hi] [m]; ``kind``: "task", "joint" or
    "blend"; ``where``: the scenario keys it comes from."""

    path: JointPath
    lo: float
    hi: float
    shift: float
    kind: str
    where: str


@dataclass(frozen=True, eq=False)
class PiecewiseJointPath(JointPath):
    """Pieces over consecutive theta ranges; at a piece boundary ``side`` picks the piece that starts there
    ("right") or ends there ("left"). task_path: the TCP trace of the whole chain as a TaskPath (lines, arcs and
    blends of the task pieces; :class:`~pathmotion.geometry.HermiteSegment` FK traces of the joint moves and joint
    blends; its tool orientation is the task pieces', the tool's on a joint piece is FK(Phi)); original_task_path:
    the same without blends (None when nothing is blended); check: the
    :class:`~pathmotion.lift.constraint.PathCheck` of the whole chain."""

    pieces: tuple[Piece, ...] = ()
    check: object = None
    robot: Robot | None = None
    task_path: object = None
    original_task_path: object = None

    def _split(self, th: np.ndarray, side: str) -> np.ndarray:
        ends = np.array([p.hi for p in self.pieces[:-1]])
        return np.searchsorted(ends, th, side="right" if side == "right" else "left")

    def _evaluated(self, theta, side: str, third: bool):
        th, scalar = self._check_theta(theta)
        k = self._split(th, side)
        out = [np.empty((len(th), self.n)) for _ in range(4 if third else 3)]
        for j in np.unique(k):
            m = k == j
            piece = self.pieces[j]
            local = np.clip(th[m] - piece.shift, *piece.path.domain)
            values = (piece.path.evaluate3 if third else piece.path.evaluate)(local, side)
            for o, v in zip(out, values):
                o[m] = v
        return _scalar_out(out, scalar)

    def evaluate(self, theta, side: str = "right"):
        return self._evaluated(theta, side, False)

    def evaluate3(self, theta, side: str = "right"):
        return self._evaluated(theta, side, True)

    def piece_at(self, theta: float, side: str = "right") -> Piece:
        """The piece evaluated at theta [m]."""
        th, _ = self._check_theta(theta)
        return self.pieces[int(self._split(th, side)[0])]


def tcp_trace(robot: Robot, path: JointPath, lo: float, hi: float, step: float, label: str):
    """The TCP trace FK(Phi(theta)) of ``path`` for theta in [lo, hi] (its own coordinate) as a HermiteSegment
    over s = theta - lo: samples ``step`` [m] apart (at least 8 intervals) of p, p' = J_v Phi' and
    p'' = J_v Phi'' + (Jdot Phi')_v, all exact at the samples."""
    from ..geometry.sampled import HermiteSegment

    count = max(int(np.ceil((hi - lo) / step)), 8) + 1
    theta = np.linspace(lo, hi, count)
    q, dq, ddq = path.evaluate(theta)
    p = fk(robot, q)[0]
    jv = jacobian(robot, q)[:, :3]
    dp = np.einsum("kij,kj->ki", jv, dq)
    ddp = np.einsum("kij,kj->ki", jv, ddq) + frame_acceleration_bias(robot, q, dq)[:, :3]
    return HermiteSegment(theta - lo, p, dp, ddp, label=label)


def check_joint_target(robot: Robot, q, where: str) -> np.ndarray:
    """q (n,) [rad] as an array, or a PathError naming ``where`` when it has the wrong size or leaves a range
    (a joint line between two configurations in range stays in range)."""
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.n,):
        raise PathError(f"{where}: {q.size} joint values; {robot.name} has {robot.n} joints "
                        f"{list(robot.joint_names)}: give {robot.n} values [rad]")
    lim = robot.limits
    bad = (q < lim.lower) | (q > lim.upper)
    if bad.any():
        j = int(np.argmax(bad))
        raise PathError(f"{where}: joint {lim.names[j]} = {q[j]:.6g} rad is outside its range "
                        f"[{lim.lower[j]:.4f}, {lim.upper[j]:.4f}]; give a configuration inside the ranges")
    return q
