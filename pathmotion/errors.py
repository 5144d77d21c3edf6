"""One error hierarchy for the whole package.

Every message says what went wrong, where (file, key, segment, theta, joint) and what the
user can change. The CLI prints ``str(error)`` on one or two lines and exits non-zero.
"""

from __future__ import annotations

from typing import Self


class PathmotionError(Exception):
    """Base class of every error pathmotion raises on purpose.

    ``where``: the place the message starts with (a scenario key such as ``path.blends[0] (corner 2)``),
    None when the message names none; :meth:`in_context` sets it."""

    where: str | None = None

    def in_context(self, where: str) -> Self:
        """A copy of this error (same type, same attributes) whose message starts with ``where``: the way to
        add the caller's context without losing what the error carries."""
        new = type(self).__new__(type(self), *self.args)  # not copy.copy: a copy that shares nothing with self
        new.__dict__.update(self.__dict__)
        new.args = (f"{where}: {self}",)
        new.where = where
        return new


class ScenarioError(PathmotionError):
    """A scenario or limits file is malformed, wrongly typed or inconsistent."""


class RobotModelError(PathmotionError):
    """A robot description (URDF, limits file, payload) cannot be used."""


class UnreachableError(PathmotionError):
    """A pose or path point cannot be reached: out of reach, outside a joint range, or singular.

    ``index``: index of the first bad point of a batch (None for a single pose); ``reason``:
    "reach", "joint_range", "singular" or "not_converged" (None when not given); ``position``: the TCP
    position (x, y, z) [m] of the path point that failed (None when not known).
    """

    def __init__(self, message: str, *, index: int | None = None, reason: str | None = None,
                 position: tuple[float, float, float] | None = None):
        super().__init__(message)
        self.index = index
        self.reason = reason
        self.position = None if position is None else tuple(float(x) for x in position)


class PathError(PathmotionError):
    """A path is geometrically invalid: zero-length or degenerate segment, gap, blend that does not fit."""


class InfeasibleError(PathmotionError):
    """Limits cannot be met: gravity torque above a limit, impossible boundary velocity, ..."""


class StateInfeasibleError(InfeasibleError):
    """A moving state that no motion within the limits can bring to where it must go (planning/retime.py).

    ``limit_factor``: the factor on every limit's dynamic part (acceleration, torque; velocity by its square
    root) that would just save it; ``end_speed``: theta_dot still left at the path's end (or the next kink)
    when braking within the limits (nan when unknown); ``overshoot``: how far past it (unit theta) that
    braking would stop; ``stop``: the Profile of the stop that ends there with the limits times
    ``limit_factor`` (None when that could not be computed)."""

    def __init__(self, message: str, *, limit_factor: float = float("nan"), end_speed: float = float("nan"),
                 overshoot: float = float("nan"), stop=None):
        super().__init__(message)
        self.limit_factor, self.end_speed, self.overshoot, self.stop = limit_factor, end_speed, overshoot, stop

    def __reduce__(self):
        return (_rebuild_state_infeasible, (str(self), self.limit_factor, self.end_speed, self.overshoot, self.stop))


def _rebuild_state_infeasible(message, limit_factor, end_speed, overshoot, stop):
    return StateInfeasibleError(message, limit_factor=limit_factor, end_speed=end_speed, overshoot=overshoot,
                                stop=stop)


class SimulationError(PathmotionError):
    """A closed-loop simulation could not be set up (not a tracking failure, which is a result)."""


class OutputError(PathmotionError):
    """An output folder or file cannot be written: not a folder, read-only, disk full, locked by another run."""


def printable(text) -> str:
    """``text`` (str() of it) with every non-printable character (a newline in a file name, a user's control bytes,
    \\x1e, \\u2028: a terminal or ``splitlines`` would break the line there) written as its Python escape."""
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in str(text))


#: Most characters of the user's input one error message quotes (a key, a value, a list of names); the rest
#: is counted, never echoed.
MAX_QUOTED_CHARS = 200


def clipped(text, limit: int = MAX_QUOTED_CHARS) -> str:
    """``text`` (str() of it) cut to ``limit`` characters, the rest counted: 'kkk... (3,800 more characters)'."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit:,} more characters)"


def listed(items, limit: int = MAX_QUOTED_CHARS) -> str:
    """The repr of each of ``items``, comma-separated, as many as fit in about ``limit`` characters, the rest
    counted: "'g0', 'g1', ... (99,990 more)"."""
    items = list(items)
    shown, size = [], 0
    for item in items:
        text = clipped(repr(item), limit)
        if shown and size + len(text) > limit:
            break
        shown.append(text)
        size += len(text) + 2
    rest = len(items) - len(shown)
    return ", ".join(shown) + (f", ... ({rest:,} more)" if rest else "")


def check_finite(name: str, value, where: str = "") -> None:
    """Raise a PathmotionError naming ``name`` (and ``where``) if ``value`` holds NaN or inf."""
    import numpy as np

    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        loc = f" in {where}" if where else ""
        raise PathmotionError(f"{name}{loc} contains NaN or inf ({arr.tolist()}); give finite numbers")


def require_finite(values, what: str, change: str, error: type = PathmotionError, columns=None) -> None:
    """Raise ``error`` in one line if ``values`` (any shape) holds NaN or inf.

    The message names ``what``, the first bad entry (row index, and column name from ``columns``
    when given) and ``change``: what the user can change. Cheap when all is finite.
    """
    import numpy as np

    arr = np.asarray(values, dtype=float)
    if np.isfinite(arr).all():
        return
    idx = np.unravel_index(int(np.argmax(~np.isfinite(arr))), arr.shape) if arr.ndim else ()
    where = ""
    if arr.ndim == 1:
        where = f" at index {idx[0]}"
    elif arr.ndim >= 2:
        col = columns[idx[-1]] if columns is not None and idx[-1] < len(columns) else f"column {idx[-1]}"
        where = f" at point {idx[0]} ({col})"
    raise error(f"{what} is not finite{where} (value {arr[idx]!r}); {change}")


class ExecutionError(PathmotionError):
    """Streaming to a controller cannot go on: a malformed or foreign EGM message, a robot that does not match
    the plan or is not at its start, a silent controller (a stop along the path follows where one is possible)."""
