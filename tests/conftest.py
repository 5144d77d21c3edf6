import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def irb140():
    from pathmotion.robot import load_robot

    return load_robot("irb140")
