"""Shared fixtures and the Hypothesis profiles.

Profiles (``HYPOTHESIS_PROFILE=ci|dev``; without it ``ci`` when ``CI`` is true, else ``dev``):

* ``ci``: derandomized, so every run draws the same examples (each test's seed is derived from its
  own source, printed in the pytest header as "derandomized"); no example database, so one run's
  failures do not change the next run's examples; no deadline and no ``too_slow`` health check,
  both of which measure wall-clock time and fail on a loaded machine without any code change.
* ``dev``: random examples (the seed of a failing run is printed with the failure, to replay it with
  ``--hypothesis-seed``) and the local example database, which replays earlier failures first.

Tests set their own ``max_examples``; the profile decides only how examples are drawn and timed.

The controller design cache (``PATHMOTION_CACHE_DIR``) is a temporary folder for the whole session, shared by
the xdist workers and removed at the end: the tests never read or fill the user's ~/.cache/pathmotion.
"""

import os
import shutil
import tempfile

import pytest
from hypothesis import HealthCheck, settings

os.environ.setdefault("MPLBACKEND", "Agg")

settings.register_profile(
    "ci", derandomize=True, database=None, deadline=None, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", deadline=None, print_blob=True)


def hypothesis_profile() -> str:
    """The profile chosen by the environment: HYPOTHESIS_PROFILE, else 'ci' when CI is true."""
    chosen = os.environ.get("HYPOTHESIS_PROFILE")
    if chosen:
        return chosen
    return "ci" if os.environ.get("CI", "").strip().lower() in ("1", "true", "yes") else "dev"


settings.load_profile(hypothesis_profile())

_SESSION_CACHE = []


def pytest_configure(config):
    """The session's own design cache, set before the xdist workers start (they inherit the environment)."""
    if hasattr(config, "workerinput"):
        return
    folder = tempfile.mkdtemp(prefix="pathmotion-test-cache-")
    _SESSION_CACHE.append(folder)
    os.environ["PATHMOTION_CACHE_DIR"] = folder


def pytest_unconfigure(config):
    for folder in _SESSION_CACHE:
        shutil.rmtree(folder, ignore_errors=True)


def pytest_report_header(config):
    current = settings.default
    how = "derandomized (per-test seed from the test source)" if current.derandomize else "random seed"
    return f"hypothesis profile: {hypothesis_profile()} ({how}, database={'off' if current.database is None else 'on'})"


@pytest.fixture(scope="session")
def irb140():
    from pathmotion.robot import load_robot

    return load_robot("irb140")
