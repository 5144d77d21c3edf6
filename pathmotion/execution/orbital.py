"""``--correction orbital``: the transverse loop closed around the drives.

The shaped reference (reference.py) is the feed-forward. Each robot message's motor-side joints, less the
gear deflection the shaping planned at that moment, estimate the link side q_hat; its projection on the
plan's joint path (control/PathTable, the orbital controller's own projection) gives theta_hat and the
transverse error y = q_hat - Phi(theta_hat), orthogonal to the path's tangent. An integral loop adds
c <- c - g y to every reference: what the model does not know (a payload, a friction, a drive's offset)
is pulled back onto the path, while the motion along the path keeps its timing.
"""

from __future__ import annotations

import numpy as np

from .. import defaults
from ..control.path_table import PathTable


class TransverseLoop:
    """The integral transverse correction (n,) [rad] for a joint path; :meth:`update` per robot message."""

    def __init__(self, path, gain: float = defaults.EGM_ORBITAL_GAIN):
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
