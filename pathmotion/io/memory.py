"""The memory a run may use: an estimate is checked against the machine's available memory before a large
array is built, so a too-large input ends in a one-line error naming the figure and the largest size that
fits instead of a MemoryError or a machine driven into swap."""

from __future__ import annotations

from collections.abc import Callable

from .. import defaults
from ..errors import ScenarioError


def available_bytes() -> int | None:
    """MemAvailable of /proc/meminfo [bytes], None where the system does not say."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def memory_budget() -> int | None:
    """What one run may plan to use [bytes]: defaults.MEMORY_FRACTION of the available memory (None: unknown)."""
    free = available_bytes()
    return None if free is None else int(free * defaults.MEMORY_FRACTION)


def _size(n: float) -> str:
    return f"{n / 2**30:.3g} GiB" if n >= 2**30 else f"{n / 2**20:.3g} MiB"


def largest_count(bytes_each: float, base: float = 0.0) -> int | None:
    """The most items of ``bytes_each`` [bytes] that fit :func:`memory_budget` beside ``base`` [bytes] (None:
    the budget is unknown)."""
    budget = memory_budget()
    return None if budget is None else max(int((budget - base) // bytes_each), 0)


def check_memory(count: int, bytes_each: float, what: str, fix: Callable[[int], str], base: float = 0.0) -> None:
    """ScenarioError when ``base`` + ``count`` items of ``bytes_each`` [bytes] exceed :func:`memory_budget`: the
    message names ``what`` ("plan.grid_points = 1,000,000"), the estimate, the budget and ``fix(largest)``, what
    to change given the largest count that fits (e.g. "give plan.grid_points <= 208,000")."""
    budget = memory_budget()
    need = base + count * bytes_each
    if budget is None or need <= budget:
        return
    largest = max(int((budget - base) // bytes_each), 0)
    raise ScenarioError(f"{what} needs about {_size(need)} of memory, more than the {_size(budget)} this run may "
                        f"use ({defaults.MEMORY_FRACTION:g} of the available memory); {fix(largest)}")
