"""A Dask distributed cluster as the studies and the searches use it: connect to a scheduler by its address
(io/scheduler.py) with one clear error when it cannot be reached, and run calls on its workers."""

from __future__ import annotations

import logging
from contextlib import contextmanager
from typing import Callable, Iterator, Sequence

from ..errors import PathmotionError
from ..io.scheduler import bad_address, check_scheduler_address

log = logging.getLogger(__name__)


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
