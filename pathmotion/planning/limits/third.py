"""Shared parts of the third-order limits (jerk, torque rate): a per-joint value the user may give
in ``[limits]``, or the robot's, switched on by ``use_<name>`` (default: on exactly when a value is
given), and the check of that value."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import ScenarioError
from .base import Limit, LimitChoice


class PerJointThirdOrder(Limit):
    """Base of a third-order per-joint limit; subclasses set ``robot_key`` (the JointLimits field of the
    robot's own values) and ``keys``."""

    order = 3
    robot_key: str = ""

    def __init__(self, values: np.ndarray):
        self.values = np.asarray(values, float)  # (n,) in the limit's unit

    def enforced(self) -> list[float]:
        """The per-joint values in the limit's unit (``unit``), scale applied."""
        return self.values.tolist()

    @classmethod
    def from_robot(cls, robot, choice):
        value = cls.values_for(robot, choice)
        return None if value is None else cls(value)

    @classmethod
    def default_choice(cls) -> LimitChoice:
        return LimitChoice(on=None, value=None)

    @classmethod
    def check_choice(cls, choice: LimitChoice) -> LimitChoice:
        key = f"limits.{cls.key_for('value')}"
        value = choice.value
        if isinstance(value, (bool, np.bool_)):
            raise ScenarioError(f"{key} holds the limits ({cls.unit}, one per joint), got {value!r}; the switch is "
                                f"limits.{cls.key_for('on')}")
        if value is not None:
            arr = np.atleast_1d(np.asarray(value, dtype=object))
            ok = arr.ndim == 1 and arr.size > 0 and all(
                isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) and np.isfinite(v) and v > 0
                for v in arr)
            if not ok:
                raise ScenarioError(f"{key} must be a list of numbers > 0 {cls.unit}, one per joint, got {value!r}")
            value = tuple(float(v) for v in arr)
        on = choice.on
        if on is None:
            on = value is not None
        if not isinstance(on, (bool, np.bool_)):
            raise ScenarioError(f"limits.{cls.key_for('on')} must be true or false, got {on!r}")
        if not (np.isfinite(choice.scale) and choice.scale > 0):
            raise ScenarioError(f"limits.{cls.key_for('scale')} must be > 0, got {choice.scale}")
        return replace(choice, on=bool(on), value=value)

    @classmethod
    def values_for(cls, robot, choice: LimitChoice) -> np.ndarray | None:
        """The effective per-joint values (n,) (user's or robot's, times the scale), None when off."""
        if not choice.on:
            return None
        key = f"limits.{cls.key_for('value')}"
        if choice.value is not None:
            value = np.asarray(choice.value, float)
            if value.shape != (robot.n,):
                raise ScenarioError(f"{key} has {value.size} values; {robot.name} has {robot.n} joints "
                                    f"{list(robot.joint_names)}")
        else:
            value = getattr(robot.limits, cls.robot_key, None)
            if value is None:
                raise ScenarioError(f"limits.{cls.key_for('on')} is on but robot {robot.name} has no "
                                    f"{cls.robot_key} limits: give {key} = [...] ({cls.unit}, one per joint)")
        return np.asarray(value, float) * choice.scale
