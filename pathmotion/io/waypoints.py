"""Reading waypoints from a CSV file: positions x, y, z [m] and, optionally, one orientation per row.

Format: a header row naming the columns, then one row per waypoint. Columns (any order, names
case-insensitive, surrounding spaces ignored):

* ``x, y, z`` [m], required;
* either ``qw, qx, qy, qz`` (a unit quaternion; normalized when its norm is within
  ``defaults.QUATERNION_NORM_TOLERANCE`` of 1) or ``roll, pitch, yaw``
  [rad] (R = Rz(yaw) Ry(pitch) Rx(roll), as the scenario's tool rotation_rpy), optional.

Empty lines and lines starting with ``#`` are skipped. The file is read by the one input rule
(:func:`pathmotion.io.files.read_input`: a regular file of at most ``defaults.MAX_WAYPOINT_FILE_BYTES``,
UTF-8; a byte-order mark is ignored). Every error is a ScenarioError naming the
file, the line (1-based, as an editor shows it) and the column.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .. import defaults
from ..errors import ScenarioError
from .files import read_input

_POSITION = ("x", "y", "z")
_QUATERNION = ("qw", "qx", "qy", "qz")
_RPY = ("roll", "pitch", "yaw")


def _columns(header: list[str], where: str) -> tuple[dict[str, int], tuple[str, ...]]:
    names = [h.strip().lower() for h in header]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ScenarioError(f"{where}: column(s) {dup} appear twice in the header")
    known = set(_POSITION + _QUATERNION + _RPY)
    unknown = [h for h in names if h not in known]
    if unknown:
        raise ScenarioError(f"{where}: unknown column(s) {unknown}; the columns are x, y, z [m] and optionally "
                            "qw, qx, qy, qz or roll, pitch, yaw [rad]")
    missing = [c for c in _POSITION if c not in names]
    if missing:
        raise ScenarioError(f"{where}: the header has no column(s) {missing}; the first line must name the "
                            "columns, e.g. x,y,z")
    kinds = [group for group in (_QUATERNION, _RPY) if any(c in names for c in group)]
    if len(kinds) > 1:
        raise ScenarioError(f"{where}: give either quaternion columns qw, qx, qy, qz or roll, pitch, yaw, not both")
    orient = kinds[0] if kinds else ()
    absent = [c for c in orient if c not in names]
    if absent:
        raise ScenarioError(f"{where}: orientation column(s) {absent} missing; give all of {list(orient)}")
    return {n: i for i, n in enumerate(names)}, orient


def parse_waypoints_csv(text: str, where: str = "waypoints") -> tuple[np.ndarray, np.ndarray | None]:
    """(points (K, 3) [m], rotations (K, 3, 3) or None) from CSV text; ScenarioError naming line and column."""
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(io.StringIO(text.removeprefix("\ufeff"))))]
    rows = [(line, r) for line, r in rows if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise ScenarioError(f"{where}: no header and no waypoints; the first line names the columns (x,y,z)")
    (_, header), body = rows[0], rows[1:]
    index, orient = _columns(header, where)
    wanted = _POSITION + orient
    values = np.empty((len(body), len(wanted)))
    for k, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise ScenarioError(f"{where}: line {line} has {len(row)} values, the header names {len(header)} columns")
        for j, col in enumerate(wanted):
            cell = row[index[col]].strip()
            try:
                v = float(cell)
            except ValueError:
                raise ScenarioError(f"{where}: line {line}, column {col}: {cell!r} is not a number") from None
            if not math.isfinite(v):
                raise ScenarioError(f"{where}: line {line}, column {col}: {cell!r} is not a finite number")
            values[k, j] = v
    if len(body) < 2:
        raise ScenarioError(f"{where}: {len(body)} waypoint(s); a path needs at least 2")
    points = values[:, :3]
    if not orient:
        return points, None
    if orient == _RPY:
        _check_turns(values[:, 3:6], body, where)
        return points, Rotation.from_euler("ZYX", values[:, [5, 4, 3]]).as_matrix()
    quat = values[:, 3:7]
    norm = np.linalg.norm(quat, axis=1)
    off = np.abs(norm - 1.0) > defaults.QUATERNION_NORM_TOLERANCE
    if off.any():
        k = int(np.argmax(off))
        raise ScenarioError(f"{where}: line {body[k][0]}, columns qw, qx, qy, qz: the quaternion has norm "
                            f"{norm[k]:.6g}, not 1; give a unit quaternion")
    return points, quat / norm[:, None]


def _check_turns(rpy: np.ndarray, body: list, where: str) -> None:
    """ScenarioError at the first roll, pitch or yaw [rad] beyond a full turn: degrees typed as radians."""
    beyond = np.abs(rpy) > 2 * math.pi + 1e-9
    if beyond.any():
        k, j = np.argwhere(beyond)[0]
        v = float(rpy[k, j])
        raise ScenarioError(f"{where}: line {body[k][0]}, column {_RPY[j]}: {v:g} rad is more than a full turn "
                            f"(2 pi = 6.283 rad): degrees? the unit is rad (e.g. {v:g} deg = {math.radians(v):.6g} rad)")


def load_waypoints_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Read a waypoint CSV file (see the module docstring): (points (K, 3) [m], orientations or None).

    Orientations are (K, 3, 3) rotation matrices (roll, pitch, yaw columns) or (K, 4) quaternions
    (w, x, y, z), normalized."""
    path = Path(path)
    return parse_waypoints_csv(read_input(path, "waypoints"), f"waypoint file {path}")
