"""Why a result must not be run, as typed values: a kind, the message a user reads, and where (the place on
the path or the scenario key). summary.json's ``failures`` holds their records; the command's verdict and the
torque reserve search read the values, never their text."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class FailureKind(StrEnum):
    """What failed."""

    SPEED_JUMP = "speed_jump"  # the path speed jumps at a 'max' connection
    LIMIT_EXCEEDED = "limit_exceeded"  # a limit is exceeded beyond its tolerance on the verification
    NO_RESERVE = "no_reserve"  # torque_reserve = "auto" found no reserve with which the closed loop tracks
    TRACKING = "tracking"  # the closed loop failed (its summary's failure names the reason)


@dataclass(frozen=True)
class ResultFailure:
    """One reason a result failed: ``kind``, ``message`` (one line for the user) and ``where`` (e.g.
    "theta = 0.52 .. 0.55", the worst limit's place, "limits.torque_reserve", "t = 0.31 s")."""

    kind: FailureKind
    message: str
    where: str = ""

    def __str__(self) -> str:
        return self.message

    def record(self) -> dict:
        """JSON-serializable, for summary.json's ``failures``."""
        return {"kind": self.kind.value, "message": self.message, "where": self.where}
