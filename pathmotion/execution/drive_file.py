"""The drive file: the parameters of a robot's drives behind EGM (robot/data/<robot>_drives.toml).

Every value is a table ``{ value, status, source }``; status is "official" or "estimate". Per-axis values
are in ``[[axes]]`` (one table per joint, in joint order). SI units, link side.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RobotModelError
from ..io.files import parse_toml, read_input

_STATUS = ("official", "estimate")
_EGM = ("cycle", "lowpass_bandwidth", "position_correction_gain", "max_speed_deviation", "transport_delay")
_SERVO = ("rate", "position_gain", "speed_bandwidth", "speed_integration_time", "speed_feedforward",
          "torque_feedforward", "torque_speed_knee", "torque_at_max_speed")
_AXIS = ("stiffness", "damping")


@dataclass(frozen=True)
class DriveParameters:
    """EGM filtering: cycle [s], lowpass_bandwidth [Hz], position_correction_gain [-], max_speed_deviation
    [rad/s], transport_delay [s]. Servo: rate [s], position_gain Kp [1/s], speed_bandwidth [rad/s] (Kv =
    bandwidth x rotor inertia), speed_integration_time Ti [s], speed_feedforward and torque_feedforward [-],
    torque_speed_knee and torque_at_max_speed (fractions of the top speed and of the torque limit).
    Gearbox per axis: stiffness (n,) [N m/rad] and damping (n,) [N m s/rad]; stiffness 0 = rigid.
    ``sources``: "section.key" -> (status, source)."""

    cycle: float
    lowpass_bandwidth: float
    position_correction_gain: float
    max_speed_deviation: float
    transport_delay: float
    rate: float
    position_gain: float
    speed_bandwidth: float
    speed_integration_time: float
    speed_feedforward: float
    torque_feedforward: float
    torque_speed_knee: float
    torque_at_max_speed: float
    stiffness: np.ndarray
    damping: np.ndarray
    sources: dict = field(default_factory=dict, compare=False)

    @property
    def elastic(self) -> np.ndarray:
        """(n,) bool: axes with an elastic gearbox."""
        return self.stiffness > 0

    def rigid(self) -> "DriveParameters":
        """The same drives with every gearbox rigid."""
        from dataclasses import replace

        return replace(self, stiffness=np.zeros_like(self.stiffness), damping=np.zeros_like(self.damping))

    def substeps(self) -> int:
        """Servo periods per EGM cycle (>= 1)."""
        return max(1, int(round(self.cycle / self.rate)))


def _value(entry, where: str, sources: dict) -> float:
    if not isinstance(entry, dict) or "value" not in entry:
        raise RobotModelError(f"{where}: expected {{ value = ..., status = ..., source = ... }}, got {entry!r}")
    status = entry.get("status")
    if status not in _STATUS:
        raise RobotModelError(f"{where}.status is {status!r}; write one of {', '.join(_STATUS)}")
    if not isinstance(entry.get("source"), str) or not entry["source"].strip():
        raise RobotModelError(f"{where}.source is missing; say where the value comes from or why it is estimated")
    v = entry["value"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
        raise RobotModelError(f"{where}.value is {v!r}; give a finite number >= 0")
    sources[where] = (status, entry["source"])
    return float(v)


def _section(data: dict, name: str, keys: tuple, where: str, sources: dict) -> dict:
    table = data.get(name)
    if not isinstance(table, dict):
        raise RobotModelError(f"{where}: missing the [{name}] table with {', '.join(keys)}")
    missing = [k for k in keys if k not in table]
    unknown = sorted(set(table) - set(keys))
    if missing or unknown:
        raise RobotModelError(f"{where} [{name}]: missing {missing}, unknown {unknown}; expected {list(keys)}")
    return {k: _value(table[k], f"{name}.{k}", sources) for k in keys}


def parse_drives(text: str, n: int, where: str = "drive file") -> DriveParameters:
    """DriveParameters from the TOML ``text`` for an arm of ``n`` joints."""
    data = parse_toml(text, where, RobotModelError)
    sources: dict = {}
    values = _section(data, "egm", _EGM, where, sources)
    values.update(_section(data, "servo", _SERVO, where, sources))
    axes = data.get("axes")
    if not isinstance(axes, list) or len(axes) != n:
        got = len(axes) if isinstance(axes, list) else 0
        raise RobotModelError(f"{where}: {got} [[axes]] tables for a {n}-joint arm; give one per joint")
    per = {k: np.array([_value(a.get(k) if isinstance(a, dict) else None, f"axes[{j}].{k}", sources)
                        for j, a in enumerate(axes)]) for k in _AXIS}
    for key in ("cycle", "rate", "lowpass_bandwidth", "speed_bandwidth", "speed_integration_time"):
        if values[key] <= 0:
            raise RobotModelError(f"{where}: {key} must be > 0, got {values[key]:g}")
    if values["rate"] > values["cycle"]:
        raise RobotModelError(f"{where}: servo.rate {values['rate']:g} s is longer than the EGM cycle "
                              f"{values['cycle']:g} s; the servo runs at least once per cycle")
    if not 0 < values["torque_speed_knee"] < 1 or not 0 < values["torque_at_max_speed"] <= 1:
        raise RobotModelError(f"{where}: servo.torque_speed_knee must lie in (0, 1) and torque_at_max_speed in (0, 1]")
    return DriveParameters(**values, **per, sources=sources)


def drive_file_for(robot_name: str) -> Path:
    """The shipped drive file of a built-in robot (an error naming the robots that have one)."""
    folder = Path(__file__).resolve().parent.parent / "robot" / "data"
    path = folder / f"{robot_name.lower()}_drives.toml"
    if not path.is_file():
        have = sorted(p.name.removesuffix("_drives.toml") for p in folder.glob("*_drives.toml"))
        raise RobotModelError(f"no drive file for robot {robot_name!r}; built-in drive files: {have}; "
                              f"give one with --drives FILE")
    return path


def load_drives(path: str | Path, n: int) -> DriveParameters:
    return parse_drives(read_input(path, "robot"), n, where=str(path))
