"""The address of a Dask scheduler, as ``--scheduler`` and ``plan.scheduler`` take it: [PROTOCOL://]HOST:PORT,
checked before any work (distributed itself may assert on a malformed one)."""

from __future__ import annotations

import re

from ..errors import ScenarioError

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
