"""A task path through a list of waypoints: straight lines, corners blended or stopped at.

Input: K >= 2 points (K, 3) [m] and, optionally, one tool orientation per point (K, 3, 3)
rotation matrices or (K, 4) unit quaternions (w, x, y, z). The path is the chain of lines
p_k -> p_{k+1}; theta is arc length [m] as for every TaskPath.

* ``blend_tolerance`` > 0: every sharp corner where the path does not turn back is replaced by the G2 (quintic Bezier) blend of
  :mod:`pathmotion.geometry.blends` whose distance from the corner's lines is at most the tolerance
  (guaranteed there); Phi' and Phi'' are then continuous through the corner. 0: no blend, the path
  has a kink at every corner and any motion stops there. A reversal (the next line runs back along
  the last) cannot be rounded: it stays sharp, the motion stops there, and a warning says so.
* Orientation: with per-point orientations, :class:`~pathmotion.geometry.orientation.SlerpOrientation`
  with a key at each waypoint (slerp with quintic smoothstep timing in theta: w and dw vanish at
  every key, so R is C2 in theta and the lift's Phi', Phi'', Phi''' include the turning tool). A
  blend maps the key of its corner linearly onto the blend. Without them, one fixed orientation
  (``orientation``, default tool down).

Errors (PathError) name the waypoint: fewer than 2 points, NaN or inf, two consecutive points
closer than ``defaults.MIN_SEGMENT_LENGTH``, an orientation that is not a rotation, a blend that
does not fit (with the largest tolerance that does).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .. import defaults
from ..errors import PathError, PathmotionError
from .blends import blended_corners, with_g2_blends
from .chain import TaskPath
from .orientation import FixedOrientation, SlerpOrientation, as_rotation
from .segments import Line

def waypoint_points(points, where: str = "waypoints") -> np.ndarray:
    """``points`` as a checked (K, 3) float array [m]: K >= 2, finite, no repeated consecutive point."""
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise PathError(f"{where}: points must be K rows of 3 numbers x, y, z [m] ({exc})") from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise PathError(f"{where}: points must have shape (K, 3) (x, y, z in m), got {p.shape}")
    if len(p) < 2:
        raise PathError(f"{where}: a path needs at least 2 waypoints, got {len(p)}")
    bad = ~np.all(np.isfinite(p), axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise PathError(f"{where}: waypoint {k} = {p[k].tolist()} contains NaN or inf; give finite coordinates [m]")
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if np.any(step < defaults.MIN_SEGMENT_LENGTH):
        k = int(np.argmax(step < defaults.MIN_SEGMENT_LENGTH))
        raise PathError(f"{where}: waypoints {k} and {k + 1} are the same point {p[k].tolist()} "
                        f"({step[k]:.3g} m apart); remove the repeated waypoint")
    return p


def waypoint_rotations(orientations, count: int, where: str = "waypoints") -> np.ndarray:
    """Orientations (K, 3, 3) rotation matrices or (K, 4) quaternions (w, x, y, z) as (K, 3, 3)."""
    try:
        o = np.array(orientations, dtype=float)
    except (TypeError, ValueError) as exc:
        raise PathError(f"{where}: orientations must be (K, 3, 3) rotation matrices or (K, 4) quaternions "
                        f"(w, x, y, z) ({exc})") from None
    if o.ndim == 2 and o.shape[1] == 4:
        bad = ~np.all(np.isfinite(o), axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise PathError(f"{where}: quaternion of waypoint {k} = {o[k].tolist()} contains NaN or inf")
        norm = np.linalg.norm(o, axis=1)
        off = np.abs(norm - 1.0) > defaults.QUATERNION_NORM_TOLERANCE
        if off.any():
            k = int(np.argmax(off))
            raise PathError(f"{where}: quaternion of waypoint {k} = {o[k].tolist()} has norm {norm[k]:.6g}, not 1; "
                            "give a unit quaternion (w, x, y, z)")
        o = Rotation.from_quat((o / norm[:, None])[:, [1, 2, 3, 0]]).as_matrix()
    if o.ndim != 3 or o.shape[1:] != (3, 3):
        raise PathError(f"{where}: orientations must be (K, 3, 3) rotation matrices or (K, 4) quaternions "
                        f"(w, x, y, z), got shape {o.shape}")
    if len(o) != count:
        raise PathError(f"{where}: {len(o)} orientations for {count} waypoints; give one per waypoint")
    return np.stack([as_rotation(f"orientation of waypoint {k}", r, where) for k, r in enumerate(o)])


def waypoint_path(points, orientations=None, blend_tolerance: float = 0.0, orientation=None,
                  where: str = "waypoints") -> TaskPath:
    """The TaskPath of lines through ``points`` (K, 3) [m] (see the module docstring).

    orientations: None, (K, 3, 3) or (K, 4) (w, x, y, z), one per waypoint, interpolated along
    the path; orientation: the fixed tool rotation (3, 3) when ``orientations`` is None (default
    tool down). blend_tolerance [m] >= 0: largest deviation of each corner's G2 blend, 0 = stop
    at every corner. ``where`` prefixes error messages (e.g. the file name).
    """
    p = waypoint_points(points, where)
    tol = float(blend_tolerance) if np.isscalar(blend_tolerance) else np.nan
    if not (np.isfinite(tol) and tol >= 0.0):
        raise PathError(f"{where}: blend_tolerance must be a distance >= 0 m (0 = stop at each corner), "
                        f"got {blend_tolerance!r}")
    segments = tuple(Line(p[k], p[k + 1]) for k in range(len(p) - 1))
    if orientations is not None:
        if orientation is not None:
            raise PathError(f"{where}: give either one fixed orientation or one orientation per waypoint, not both")
        rots = waypoint_rotations(orientations, len(p), where)
        keys = np.concatenate([[0.0], np.cumsum([s.length for s in segments])])
        try:
            orient = SlerpOrientation(tuple(keys), rots)
        except PathError as exc:
            raise PathError(f"{where}: {exc}") from None
    else:
        orient = FixedOrientation() if orientation is None else FixedOrientation(orientation)
    path = TaskPath(segments, orient)
    if tol > 0.0 and path.kinks:
        corners = blended_corners(path, where)
        try:
            path = with_g2_blends(path, tol, corners) if corners else path
        except PathmotionError as exc:
            raise PathError(f"{where}: blend_tolerance {tol:g} m: {exc}") from None
    return path


__all__ = ["waypoint_path", "waypoint_points", "waypoint_rotations"]
