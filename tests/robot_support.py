"""Where the tests find the other arms: the URDFs of PyPI example-robot-data (dev extra) and the
limits files in tests/data. ROBOTS is None when example-robot-data is not installed."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

DATA = Path(__file__).parent / "data"
try:
    ROBOTS = Path(str(importlib.metadata.distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots")))
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - the dev extra installs it
    ROBOTS = None
UR5_URDF = None if ROBOTS is None else ROBOTS / "ur_description/urdf/ur5_robot.urdf"
PANDA_URDF = None if ROBOTS is None else ROBOTS / "panda_description/urdf/panda.urdf"
