"""The plant step a stiff friction needs: one check both plants use (the built-in RK4 one and MuJoCo's)."""

from __future__ import annotations

from .. import defaults
from ..errors import SimulationError


def check_substeps(needed: tuple[int, str], dt: float, substeps: int, friction_keys: str) -> None:
    """SimulationError naming the scenario keys to change when ``substeps`` is below ``needed`` (count, why)."""
    need, why = needed
    if substeps < need:
        raise SimulationError(
            f"{why}, shorter than the plant step {dt / substeps:.3g} s (simulate.sample_time {dt:g} s / {substeps} "
            f"substeps); set simulate.substeps >= {need} (at most {defaults.MAX_PLANT_SUBSTEPS}), lower "
            f"simulate.sample_time, or lower {friction_keys}")
