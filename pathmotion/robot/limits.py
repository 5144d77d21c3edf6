"""Joint limits of an arm and their loading from a TOML limits file or a URDF."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RobotModelError
from ..io.files import parse_toml, read_input

_KEYS = ("lower", "upper", "velocity", "acceleration", "torque")
#: Keys a limits file may leave out (all joints or none); None in JointLimits when absent.
_OPTIONAL = ("acceleration", "jerk", "torque_rate", "armature")
#: Every per-joint key of a limits file, required first (acceleration is in both).
_ALL_KEYS = tuple(dict.fromkeys((*_KEYS, *_OPTIONAL)))


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits, arrays of shape (n,), SI units.

    lower, upper [rad]; velocity [rad/s] (> 0); acceleration [rad/s^2] (> 0) or None when
    not given; torque [N m] (> 0); jerk [rad/s^3] and torque_rate [N m/s] (> 0) or None when not given
    (used by the third-order limits when ``use_jerk`` / ``use_torque_rate`` is on); armature [kg m^2] (>= 0) or None: the reflected rotor inertia
    J_motor N^2 of each drive, added to the diagonal of the mass matrix (the torques are joint-side,
    so they include the torque that accelerates the rotors). ``sources`` maps each quantity to
    "official"/"estimate"/...
    """

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    torque: np.ndarray
    acceleration: np.ndarray | None = None
    sources: dict = field(default_factory=dict)
    armature: np.ndarray | None = None
    jerk: np.ndarray | None = None
    torque_rate: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.names)
        for key in _ALL_KEYS:
            v = getattr(self, key)
            if v is None:
                continue
            arr = np.asarray(v, dtype=float)
            if arr.shape != (n,):
                raise RobotModelError(f"limits: '{key}' has {arr.size} values for {n} joints {list(self.names)}")
            if not np.all(np.isfinite(arr)):
                raise RobotModelError(f"limits: '{key}' contains NaN or inf: {arr.tolist()}")
            object.__setattr__(self, key, arr)
        for key in ("velocity", "torque", "acceleration", "jerk", "torque_rate"):
            v = getattr(self, key)
            if v is not None and np.any(v <= 0):
                j = int(np.argmax(v <= 0))
                raise RobotModelError(
                    f"limits: {key} of {self.names[j]} is {v[j]:g}; limits are magnitudes and must be > 0"
                )
        if self.armature is not None and np.any(self.armature < 0):
            j = int(np.argmax(self.armature < 0))
            raise RobotModelError(f"limits: armature of {self.names[j]} is {self.armature[j]:g} kg m^2; it must be >= 0")
        bad = np.nonzero(self.lower >= self.upper)[0]
        if bad.size:
            j = int(bad[0])
            raise RobotModelError(
                f"limits: joint {self.names[j]} has lower {self.lower[j]:g} >= upper {self.upper[j]:g} rad"
            )

    @property
    def n(self) -> int:
        return len(self.names)


def limits_from_toml(path: str | Path, joint_names: tuple[str, ...], ignore: tuple[str, ...] = ()) -> JointLimits:
    """Read a limits file (``[[joints]]`` tables with name, lower, upper, velocity, torque and
    optional acceleration, jerk, torque_rate and armature) and order it as ``joint_names``; entries named in
    ``ignore`` (locked joints) are dropped."""
    path = Path(path)
    doc = parse_toml(read_input(path, "limits"), f"limits file {path}", RobotModelError)
    if ignore and isinstance(doc.get("joints"), list):
        doc["joints"] = [j for j in doc["joints"] if not (isinstance(j, dict) and j.get("name") in ignore)]
    return limits_from_dict(doc, joint_names, where=str(path))


def limits_from_dict(doc: dict, joint_names: tuple[str, ...], where: str = "limits") -> JointLimits:
    """Limits from the parsed form of a limits file (see :func:`limits_from_toml`)."""
    joints = doc.get("joints")
    if not isinstance(joints, list) or not all(isinstance(j, dict) for j in joints):
        raise RobotModelError(f"{where}: expected a [[joints]] table per joint ({len(joint_names)} joints)")
    if len(joints) != len(joint_names):
        raise RobotModelError(
            f"{where}: {len(joints)} [[joints]] entries, but the robot has {len(joint_names)} joints "
            f"{list(joint_names)}; give one entry per joint"
        )
    by_name = {}
    for k, j in enumerate(joints):
        name = j.get("name", joint_names[k])
        if name not in joint_names:
            raise RobotModelError(f"{where}: joints[{k}] names '{name}', not a joint of the robot {list(joint_names)}")
        by_name[name] = j
    values: dict[str, list] = {key: [] for key in _ALL_KEYS}
    sources = {}
    for name in joint_names:
        if name not in by_name:
            raise RobotModelError(f"{where}: no [[joints]] entry for joint '{name}'")
        j = by_name[name]
        for key in _ALL_KEYS:
            v = j.get(key)
            if v is None and key not in _OPTIONAL:
                raise RobotModelError(f"{where}: joint '{name}' has no '{key}' limit; add it")
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise RobotModelError(f"{where}: joint '{name}' {key} = {v!r} is not a number")
            values[key].append(v)
        src = j.get("sources", {})
        if not isinstance(src, dict) or not all(isinstance(v, str) for v in src.values()):
            raise RobotModelError(f"{where}: joint '{name}' sources = {src!r:.60}: give a table of quantity = "
                                  "\"where it comes from\", e.g. sources = { velocity = \"datasheet\" }")
        sources[name] = dict(src)
    for key in _OPTIONAL:
        given = values[key]
        if any(a is None for a in given) and not all(a is None for a in given):
            missing = [n for n, a in zip(joint_names, given) if a is None]
            raise RobotModelError(f"{where}: {key} given for some joints but not for {missing}; give all or none")
    optional = {key: None if values[key][0] is None else values[key] for key in _OPTIONAL}
    return JointLimits(
        names=tuple(joint_names),
        lower=values["lower"],
        upper=values["upper"],
        velocity=values["velocity"],
        torque=values["torque"],
        sources=sources,
        **optional,
    )


def limits_from_model(model, where: str) -> JointLimits:
    """Limits carried by a Pinocchio model built from a URDF (lower/upper, velocity, effort).

    Raises RobotModelError naming every joint whose limit is missing (0 or infinite in the URDF).
    """
    names = tuple(model.names[1:])
    lower = np.asarray(model.lowerPositionLimit, dtype=float)
    upper = np.asarray(model.upperPositionLimit, dtype=float)
    vel = np.asarray(model.velocityLimit, dtype=float)
    eff = np.asarray(model.effortLimit, dtype=float)
    missing = []
    for j, name in enumerate(names):
        if not np.isfinite(lower[j]) or not np.isfinite(upper[j]):
            missing.append(f"{name}: range")
        elif lower[j] >= upper[j]:
            missing.append(f"{name}: range (lower {lower[j]:g} >= upper {upper[j]:g} rad)")
        if not np.isfinite(vel[j]) or vel[j] <= 0:
            missing.append(f"{name}: velocity")
        if not np.isfinite(eff[j]) or eff[j] <= 0:
            missing.append(f"{name}: effort (torque)")
    if missing:
        raise RobotModelError(
            f"{where}: limits missing for {', '.join(missing)}; add <limit> values to the URDF or give a limits file"
        )
    return JointLimits(names=names, lower=lower, upper=upper, velocity=vel, torque=eff,
                       sources={n: {"all": "urdf"} for n in names})
