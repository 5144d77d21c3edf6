"""A Dask distributed scheduler as the studies and the searches use it: its address, as ``--scheduler`` and
``plan.scheduler`` take it ([PROTOCOL://]HOST:PORT, checked before any work: distributed itself may assert on a
malformed one), a client of it with one clear error when it cannot be reached, and calls run as its tasks."""

from __future__ import annotations

import logging
import re
from contextlib import contextmanager
from typing import Callable, Iterator, Sequence

from ..errors import PathmotionError, ScenarioError

log = logging.getLogger(__name__)

#: [PROTOCOL://]HOST:PORT of a Dask scheduler.
_DASK_ADDRESS = re.compile(r"^((tcp|tls|ws|wss|ucx)://)?([A-Za-z0-9_.\-]+|\[[0-9a-fA-F:]+\]):(\d{1,5})/?$")


def bad_address(address, detail: str = "", what: str = "scheduler address") -> ScenarioError:
    """The error for a scheduler address that is not [PROTOCOL://]HOST:PORT (``detail``: Dask's reason; ``what``:
    the option or key that gave it)."""
    return ScenarioError(f"{what} {str(address)[:80]!r} is not a Dask scheduler address{detail}; give "
                         "tcp://HOST:PORT, e.g. tcp://127.0.0.1:8786")


def check_scheduler_address(address, what: str = "scheduler address") -> str:
    """``address`` when it has the form [PROTOCOL://]HOST:PORT of a Dask scheduler (PORT 1..65535), else a
    ScenarioError naming ``what``."""
    match = _DASK_ADDRESS.match(address) if isinstance(address, str) else None
    if match is None or not 0 < int(match.group(4)) < 65536:
        raise bad_address(address, what=what)
    return address


@contextmanager
def dask_client(address: str, what: str = "scheduler address") -> Iterator:
    """A distributed.Client of the scheduler at ``address`` (checked first; ``what`` names where it was given),
    closed after use; PathmotionError when distributed is missing or the scheduler cannot be reached."""
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - dask is a runtime dependency
        raise PathmotionError("a Dask scheduler needs dask distributed: pip install 'dask[distributed]'") from None
    check_scheduler_address(address, what)
    try:
        client = Client(address, timeout="10s")
    except (ValueError, TypeError) as exc:  # malformed: no port, unknown scheme
        raise bad_address(address, f" ({exc})", what) from None
    except (OSError, TimeoutError) as exc:
        raise PathmotionError(f"cannot reach the Dask scheduler at {address}: {exc}; is it running "
                              "(dask scheduler) with workers (dask worker ADDRESS)?") from None
    try:
        yield client
    finally:
        client.close()


def run_on_cluster(address: str, fn: Callable, calls: Sequence[tuple], label: str, what: str = "plan.scheduler"
                   ) -> list:
    """``[fn(*args) for args in calls]`` with each call a task on the Dask cluster at ``address``, the results in
    the calls' order; an exception a call raises is raised here (the first in order). ``label`` names the tasks."""
    with dask_client(address, what) as client:
        log.info("%s: %d task(s) on the Dask cluster at %s", label, len(calls), address)
        futures = [client.submit(fn, *args, key=f"pathmotion-{label}-{k}", pure=False) for k, args in enumerate(calls)]
        return client.gather(futures)
