"""One BLAS thread for the controller's small linear algebra.

The set-up solves and multiplies matrices of at most a few dozen rows (the sampled design's Riccati recursion,
scipy's algebraic Riccati solver for its end, the numba kernels' solves). OpenBLAS splits some of these calls over
its threads anyway; each then waits for a second thread, which on a loaded machine is not scheduled for a while:
scipy's discrete algebraic Riccati solver took 17 ms of CPU with two threads and 2 ms with one on the 2-core
development machine (load 6), the whole sampled design 86 ms and 46 ms. :func:`single_blas_thread` limits every
loaded BLAS to one thread inside a ``with`` block and restores the previous limits after it (``threadpoolctl``,
a dependency).
"""

from __future__ import annotations

import functools

from threadpoolctl import ThreadpoolController


@functools.lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    """threadpoolctl's view of the loaded BLAS libraries (found once per process, ~20 ms)."""
    return ThreadpoolController()


def single_blas_thread():
    """Context manager: BLAS limited to one thread inside the block."""
    return _controller().limit(limits=1, user_api="blas")


def blas_single_threaded(function):
    """Decorator: ``function`` runs inside :func:`single_blas_thread`."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with single_blas_thread():
            return function(*args, **kwargs)

    return wrapper
