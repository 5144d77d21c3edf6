"""``--correction orbital``: the transverse loop closed around the drives.

The shaped reference (reference.py) is the feed-forward. Each robot message's motor-side joints, less the
gear deflection the shaping planned at that moment, estimate the link side q_hat; its projection on the
plan's joint path (control/PathTable, the orbital controller's own projection) gives theta_hat and the
transverse error y = q_hat - Phi(theta_hat), orthogonal to the path's tangent. An integral loop adds
c <- c - g y to every reference: what the model does not know (a payload, a friction, a drive's offset)
is pulled back onto the path, while the motion along the path keeps its timing.

The correction reaches the reported joints only through the drives' lag (:func:`loop_lag`). The gain per cycle
puts the loop's crossover where that lag takes ``defaults.EGM_ORBITAL_CROSSOVER_PHASE`` (:func:`loop_gain`): the
loop then follows only what changes slowly against the lag (a payload's pull, a friction), not the transients
of corners it cannot catch up with; a faster loop adds those back late, and 0.3 per cycle diverges on the
IRB 140's drive file.
"""

from __future__ import annotations

import numpy as np

from .. import defaults
from ..control.path_table import PathTable
from .drive_file import DriveParameters


def loop_lag(drives: DriveParameters) -> float:
    """The mean lag [s] from a change of the sent reference to the reported joints: EGM's transport delay and
    its low-pass time constant (the position correction turns a reference change into a speed the servo feeds
    forward, so the position loop adds little: the drive model's step response lags 18 ms on the IRB 140's
    drive file, against 20 ms of this sum)."""
    return drives.transport_delay + 1.0 / (2.0 * np.pi * drives.lowpass_bandwidth)


def loop_gain(drives: DriveParameters, phase: float = defaults.EGM_ORBITAL_CROSSOVER_PHASE) -> float:
    """The integral gain per cycle [-] whose crossover omega = g / cycle meets the lag at ``phase`` [rad]."""
    return float(phase * drives.cycle / loop_lag(drives))


class TransverseLoop:
    """The integral transverse correction (n,) [rad] for a joint path; :meth:`update` per robot message."""

    def __init__(self, path, gain: float):
        self.table = PathTable.from_path(path)
        self.projection = self.table.projection()
        self.gain = float(gain)
        self.correction = np.zeros(path.n)

    def update(self, reported: np.ndarray, deflection: np.ndarray, theta_guess: float) -> np.ndarray:
        """The correction after one message: reported (n,) motor-side joints [rad], deflection (n,) the planned
        gear deflection [rad], theta_guess the reference's theta."""
        q_hat = np.asarray(reported, float) - deflection
        p = self.projection
        _, (phi, _, _) = self.table.project(q_hat, theta_guess, p.iterations, p.tol, p.max_step)
        self.correction = self.correction - self.gain * (q_hat - phi)
        return self.correction
