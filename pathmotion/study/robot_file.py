"""A study's robot given as a file (``pathmotion corners --robot FILE``): a scenario's ``[robot]`` table (built-in
name or URDF, limits file, payload, tool, flange frame, locked joints) and its ``[limits]`` overrides of the arm's
joint limits (``velocity``, ``acceleration``, ``torque``), read and built as a scenario's robot is
(io/scenario.py's RobotSpec and LimitsSpec, api.build_robot). Relative paths in it are relative to the file.

Example, the IRB140 with its rated 6 kg and drives at 35 % of the shipped torque limits::

    [robot]
    name = "irb140"
    payload = { mass = 6.0, com = [0.0, 0.0, 0.1], inertia = [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]] }

    [limits]
    torque = [87.5, 122.5, 42.0, 7.0, 7.0, 3.5]  # N m

The other ``[limits]`` keys of a scenario are planning settings, not the arm (the plant of a closed loop saturates
at the robot's torque limits, not at ``torque_scale`` times them): a robot file refuses them and names what to give.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from ..errors import RobotModelError, ScenarioError

#: The ``[limits]`` keys a robot file takes: the arm's own joint limits.
ROBOT_LIMIT_KEYS = ("velocity", "acceleration", "torque")
#: The tables a robot file takes.
ROBOT_FILE_TABLES = ("robot", "limits")


def _check_keys(doc: dict, where: str) -> None:
    """ScenarioError for a table or ``[limits]`` key that is not the arm's (a planning setting, or a whole scenario)."""
    other = [k for k in doc if k not in ROBOT_FILE_TABLES]
    if other:
        raise ScenarioError(f"{where}: {', '.join(map(repr, other))} is not part of a robot file; it holds a "
                            "scenario's [robot] table and the arm's joint limits in [limits] (velocity, acceleration, "
                            "torque) only: copy those two tables out of the scenario")
    limits = doc.get("limits", {})
    if not isinstance(limits, dict):
        raise ScenarioError(f"{where}: limits must be a table ([limits]) of velocity, acceleration, torque")
    planning = [k for k in limits if k not in ROBOT_LIMIT_KEYS]
    if planning:
        raise ScenarioError(f"{where}: limits.{planning[0]} is not the arm's joint limit; a robot file takes "
                            f"limits.{', limits.'.join(ROBOT_LIMIT_KEYS)} [rad/s, rad/s^2, N m] per joint (give weak "
                            "drives as limits.torque = [...]); the atlas' torque limits and reserve are its options "
                            "--torque and --torque-reserve")


def _validated(doc: dict, where: str):
    """A Scenario-typed holder of the file's RobotSpec and LimitsSpec, validated as a scenario's (strict types,
    unknown keys named with the closest allowed one)."""
    from pydantic import ValidationError

    from ..io.scenario import LimitsSpec, RobotSpec, Scenario, validation_error

    specs, errors = {}, []
    for table, model in (("robot", RobotSpec), ("limits", LimitsSpec)):
        try:
            specs[table] = model.model_validate_json(json.dumps(doc.get(table, {}), default=str), strict=True)
        except ValidationError as exc:
            errors += [{**e, "loc": (table, *e["loc"])} for e in exc.errors()]
    if errors:
        raise validation_error(errors, doc, where)
    return Scenario.model_construct(**specs)


def load_robot_file(path: str | Path):
    """The Robot a robot file describes (see the module docstring); a PathmotionError naming the file and what to
    change when it cannot be read, is not valid TOML, holds other keys, or the robot cannot be built."""
    from ..api import build_robot
    from ..io.files import parse_toml, read_input

    path = Path(path)
    where = f"robot file {path}"
    doc = parse_toml(read_input(path, "robot"), where)
    _check_keys(doc, where)
    spec = _validated(doc, where)
    try:
        return build_robot(spec, path.parent)
    except (RobotModelError, ScenarioError) as exc:
        raise exc.in_context(where) from exc


def robot_digest(robot) -> str:
    """A digest of everything a study's results depend on in ``robot``: name, URDF text, joint limits, payload, tool,
    flange frame, locked joints, gravity (a changed file gives another digest)."""
    lim = robot.limits
    arrays = {k: None if getattr(lim, k) is None else np.asarray(getattr(lim, k), float).tolist()
              for k in ("lower", "upper", "velocity", "acceleration", "torque", "armature", "jerk", "torque_rate")}
    p, t = robot.payload, robot.tool
    fields = {"name": robot.name, "urdf": hashlib.sha256(robot.urdf_text.encode()).hexdigest(), "limits": arrays,
              "joints": list(lim.names), "payload": [float(p.mass), np.asarray(p.com, float).tolist(),
                                                     np.asarray(p.inertia, float).tolist()],
              "tool": [np.asarray(t.translation, float).tolist(), np.asarray(t.rotation, float).tolist()],
              "flange": robot.flange_frame, "locked": [list(j) for j in robot.locked_joints],
              "gravity": list(map(float, robot.gravity))}
    return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:20]


__all__ = ["ROBOT_LIMIT_KEYS", "load_robot_file", "robot_digest"]
