"""Tool orientation along a path as a function of the path coordinate theta.

Both classes return, vectorized over theta (N,):

    R (N, 3, 3)   tool frame in world axes (world_vector = R @ tool_vector)
    w (N, 3)      angular velocity per unit theta in world axes: dR/dtheta = [w]x R   [rad/m]
    dw (N, 3)     dw/dtheta                                                          [rad/m^2]

* :class:`FixedOrientation` -- one rotation everywhere (default
  :data:`pathmotion.defaults.TOOL_DOWN_ROTATION`, tool z pointing down).
* :class:`SlerpOrientation` -- key rotations R_k at theta_k, joined by slerp with a quintic
  smoothstep time-scaling (see its docstring for why w and dw are continuous).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from .. import defaults
from ..errors import PathError

#: A rotation matrix given by the user must satisfy max |R^T R - I| <= this [-].
ORTHONORMALITY = 1e-9
#: Consecutive key orientations must differ by less than a half turn by this margin [rad]: at a half
#: turn the rotation direction is ambiguous.
HALF_TURN_MARGIN = 1e-6


def as_rotation(name: str, value, where: str = "orientation") -> np.ndarray:
    """``value`` as a read-only proper rotation matrix (3, 3), or a PathError."""
    try:
        r = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise PathError(f"{where}: {name} must be a 3x3 rotation matrix, got {value!r}") from exc
    if r.shape != (3, 3):
        raise PathError(f"{where}: {name} must be a 3x3 rotation matrix, got shape {r.shape}")
    if not np.all(np.isfinite(r)):
        raise PathError(f"{where}: {name} contains NaN or inf; give a finite rotation matrix")
    if not np.allclose(r.T @ r, np.eye(3), atol=ORTHONORMALITY) or np.linalg.det(r) < 0:
        raise PathError(f"{where}: {name} is not a proper rotation (R^T R = I, det R = +1); "
                        "give an orthonormal right-handed matrix")
    r.flags.writeable = False
    return r


def _thetas(theta) -> np.ndarray:
    return np.atleast_1d(np.asarray(theta, dtype=float))


@dataclass(frozen=True, eq=False)
class FixedOrientation:
    """The same tool rotation (3, 3) for every theta; w = dw = 0."""

    rotation: np.ndarray = field(default_factory=lambda: np.array(defaults.TOOL_DOWN_ROTATION))

    def __post_init__(self):
        object.__setattr__(self, "rotation", as_rotation("rotation", self.rotation, "FixedOrientation"))

    def evaluate(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R (N, 3, 3), w (N, 3), dw (N, 3)) at theta (N,)."""
        th = _thetas(theta)
        z = np.zeros((len(th), 3))
        return np.broadcast_to(self.rotation, (len(th), 3, 3)).copy(), z, z.copy()

    def evaluate3(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(R, w, dw, ddw) at theta (N,); ddw = d2w/dtheta2 = 0 (N, 3)."""
        r, w, dw = self.evaluate(theta)
        return r, w, dw, np.zeros_like(w)

    def key_thetas(self) -> tuple[float, ...]:
        return ()

    def remapped(self, fn: Callable[[np.ndarray], np.ndarray]) -> "FixedOrientation":
        """The same orientation after the path coordinate is remapped by ``fn`` (unchanged)."""
        return self


def smoothstep5_third(tau: np.ndarray) -> np.ndarray:
    """sigma'''(tau) = 60 (1 - 6 tau + 6 tau^2) on [0, 1], 0 outside (where sigma is held constant).

    It does not vanish at the ends, so the third derivative of the rotation jumps at each key."""
    t = np.asarray(tau, dtype=float)
    return np.where((t >= 0.0) & (t <= 1.0), 60.0 * (1.0 - 6.0 * t + 6.0 * t ** 2), 0.0)


def smoothstep5(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic smoothstep sigma(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 and its first two derivatives.

    sigma(0) = 0, sigma(1) = 1, sigma' and sigma'' vanish at both ends."""
    t = np.clip(tau, 0.0, 1.0)
    return (t ** 3 * (10.0 - 15.0 * t + 6.0 * t ** 2),
            30.0 * t ** 2 * (1.0 - t) ** 2,
            60.0 * t * (1.0 - t) * (1.0 - 2.0 * t))


@dataclass(frozen=True, eq=False)
class SlerpOrientation:
    """Key rotations ``rotations`` (K, 3, 3) at strictly increasing ``thetas`` (K,) [m], K >= 1.

    Between keys k and k+1, with h = theta_{k+1} - theta_k, tau = (theta - theta_k) / h and the
    relative rotation vector omega_k = log(R_k^T R_{k+1}) (shortest rotation, |omega_k| < pi):

        R(theta) = R_k exp(sigma(tau) [omega_k]x)           sigma = quintic smoothstep
        w  = R_k omega_k sigma'(tau) / h                    (world axes; R_k omega_k is fixed)
        dw = R_k omega_k sigma''(tau) / h^2

    Why this scaling: a plain (linear) slerp has a constant w on each piece, so w jumps at every
    key where the rotation axis or rate changes, and Phi'' of the joint-space lift would be
    unbounded there. With sigma'(0) = sigma'(1) = sigma''(0) = sigma''(1) = 0, w = 0 and dw = 0 at
    every key from both sides, so R is C2 in theta for any keys (the tool briefly stops turning at
    a key; place keys where that is acceptable). Before the first key and after the last the
    rotation is held constant (w = dw = 0), which joins continuously for the same reason.
    """

    thetas: tuple[float, ...]
    rotations: np.ndarray
    _axes: np.ndarray = field(init=False, repr=False)
    _rotvecs: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        where = "SlerpOrientation"
        th = np.array(self.thetas, dtype=float).reshape(-1)
        if len(th) < 1:
            raise PathError(f"{where}: give at least one key orientation")
        if not np.all(np.isfinite(th)):
            raise PathError(f"{where}: key thetas {th.tolist()} contain NaN or inf")
        if np.any(np.diff(th) <= 0):
            k = int(np.argmax(np.diff(th) <= 0))
            raise PathError(f"{where}: key thetas must increase strictly, but key {k + 1} (theta = {th[k + 1]:.6g}) "
                            f"is not after key {k} (theta = {th[k]:.6g}); reorder or remove a key")
        rots = np.array(self.rotations, dtype=float)
        if rots.ndim != 3 or rots.shape[0] != len(th):
            raise PathError(f"{where}: need one 3x3 rotation per key theta ({len(th)}), got shape {rots.shape}")
        rots = np.stack([as_rotation(f"rotation of key {k}", r, where) for k, r in enumerate(rots)])
        rotvecs = np.zeros((max(len(th) - 1, 0), 3))
        for k in range(len(th) - 1):
            rotvecs[k] = Rotation.from_matrix(rots[k].T @ rots[k + 1]).as_rotvec()
            if np.linalg.norm(rotvecs[k]) > np.pi - HALF_TURN_MARGIN:
                raise PathError(f"{where}: keys {k} and {k + 1} (theta = {th[k]:.6g}, {th[k + 1]:.6g}) differ by a "
                                "half turn, so the rotation direction is ambiguous; add a key in between")
        axes = np.einsum("kij,kj->ki", rots[:-1], rotvecs)
        for arr in (rots, rotvecs, axes):
            arr.flags.writeable = False
        object.__setattr__(self, "thetas", tuple(float(x) for x in th))
        object.__setattr__(self, "rotations", rots)
        object.__setattr__(self, "_rotvecs", rotvecs)
        object.__setattr__(self, "_axes", axes)

    def key_thetas(self) -> tuple[float, ...]:
        return self.thetas

    def evaluate(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R (N, 3, 3), w (N, 3) [rad/m], dw (N, 3) [rad/m^2]) at theta (N,) [m]."""
        th = _thetas(theta)
        keys = np.asarray(self.thetas)
        if len(keys) == 1:
            z = np.zeros((len(th), 3))
            return np.broadcast_to(self.rotations[0], (len(th), 3, 3)).copy(), z, z.copy()
        k = np.clip(np.searchsorted(keys, th, side="right") - 1, 0, len(keys) - 2)
        h = keys[k + 1] - keys[k]
        sig, dsig, ddsig = smoothstep5((th - keys[k]) / h)
        rel = Rotation.from_rotvec(sig[:, None] * self._rotvecs[k]).as_matrix()
        r = np.einsum("nij,njk->nik", self.rotations[k], rel)
        return r, self._axes[k] * (dsig / h)[:, None], self._axes[k] * (ddsig / h ** 2)[:, None]

    def evaluate3(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(R, w, dw, ddw) at theta (N,): ddw = R_k omega_k sigma'''(tau) / h^3 [rad/m^3] (N, 3), exact
        inside each piece; it jumps at the keys (sigma''' = 60 at both ends of a piece, 0 outside the keys)."""
        th = _thetas(theta)
        r, w, dw = self.evaluate(th)
        keys = np.asarray(self.thetas)
        if len(keys) == 1:
            return r, w, dw, np.zeros_like(w)
        k = np.clip(np.searchsorted(keys, th, side="right") - 1, 0, len(keys) - 2)
        h = keys[k + 1] - keys[k]
        return r, w, dw, self._axes[k] * (smoothstep5_third((th - keys[k]) / h) / h ** 3)[:, None]

    def remapped(self, fn: Callable[[np.ndarray], np.ndarray]) -> "SlerpOrientation":
        """The same keys at thetas mapped by the increasing function ``fn`` (used when a blend
        changes the path length)."""
        return SlerpOrientation(tuple(fn(np.asarray(self.thetas))), self.rotations)


Orientation = FixedOrientation | SlerpOrientation


#: Largest share of the key interval on either side an orientation zone may take (below half: two zones
#: never overlap, and the keys stay strictly increasing) [-].
ORIENTATION_ZONE_SHARE = 0.49
#: An orientation zone shorter than this share of its shorter neighbouring interval is not blended: its two
#: keys would make the tool stop turning twice within a short stretch (w = 0 at every key), a large dw for
#: an orientation change of at most the zone's own small turn; the key is met exactly instead [-].
ORIENTATION_ZONE_MIN_SHARE = 0.01


def zoned_keys(thetas, rotations, zones) -> tuple[np.ndarray, np.ndarray]:
    """Key thetas (M,) and rotations (M, 3, 3) of a :class:`SlerpOrientation` whose interior keys blend.

    ``thetas`` (K,) [m] strictly increasing, ``rotations`` (K, 3, 3), ``zones`` (K,) [m]: the orientation
    zone at each key (0: the key is met exactly; the first and last keys are always met). A key with a
    zone z > 0 is replaced by two keys at theta_k - a and theta_k + b, a and b = z kept within
    ORIENTATION_ZONE_SHARE of the neighbouring intervals, carrying the rotations the slerp towards and
    away from R_k has there (the share a / h of the way along); between them the orientation turns
    straight from one to the other without passing R_k, as a controller's orientation zone does. A zone
    shorter than ORIENTATION_ZONE_MIN_SHARE of the shorter interval keeps its key exact."""
    th = np.asarray(thetas, float)
    rots = np.asarray(rotations, float)
    z = np.asarray(zones, float)
    out_t, out_r = [th[0]], [rots[0]]
    for k in range(1, len(th) - 1):
        a = min(z[k], ORIENTATION_ZONE_SHARE * (th[k] - th[k - 1]))
        b = min(z[k], ORIENTATION_ZONE_SHARE * (th[k + 1] - th[k]))
        shortest = min(th[k] - th[k - 1], th[k + 1] - th[k])
        if a <= 0.0 or b <= 0.0 or min(a, b) < ORIENTATION_ZONE_MIN_SHARE * shortest:
            out_t.append(th[k])
            out_r.append(rots[k])
            continue
        before = Rotation.from_matrix(rots[k].T @ rots[k - 1]).as_rotvec() * a / (th[k] - th[k - 1])
        after = Rotation.from_matrix(rots[k].T @ rots[k + 1]).as_rotvec() * b / (th[k + 1] - th[k])
        out_t += [th[k] - a, th[k] + b]
        out_r += [rots[k] @ Rotation.from_rotvec(before).as_matrix(), rots[k] @ Rotation.from_rotvec(after).as_matrix()]
    if len(th) > 1:
        out_t.append(th[-1])
        out_r.append(rots[-1])
    return np.array(out_t), np.array(out_r)
