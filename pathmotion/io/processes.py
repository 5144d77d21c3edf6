"""Local worker processes for the sweeps and the blend searches: a pool whose workers an interrupt ends at once,
and a wait for their results that Ctrl-C and SIGTERM always interrupt.

A process-directed signal reaches whichever thread the kernel picks. A main thread blocked on a lock without a
timeout (``concurrent.futures.as_completed``, ``Future.result``) is woken only by a signal delivered to it, so a
SIGTERM that lands on the executor's manager thread or a queue feeder thread would leave it waiting for the
running calls forever; here the main thread wakes every :data:`INTERRUPT_POLL` seconds, when Python runs the
pending handler."""

from __future__ import annotations

import signal
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Callable, Iterable, Iterator, Sequence

#: Longest time [s] a signal's handler waits for the main thread blocked on worker results.
INTERRUPT_POLL = 0.1


def _worker_signals() -> None:
    """Start of a pool worker: SIGTERM ends it at once and Ctrl-C is left to the parent.

    A forked worker inherits the CLI's SIGTERM -> KeyboardInterrupt handler, and ProcessPoolExecutor's worker loop
    catches that exception as the call's result and starts the next queued call: an interrupted run then waited
    for the queued calls. Only the parent keeps results, so killing a worker loses nothing finished."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a terminal's Ctrl-C reaches the whole process group


def completed(futures: Iterable[Future]) -> Iterator[Future]:
    """``futures`` as they finish (as ``concurrent.futures.as_completed``), waiting in :data:`INTERRUPT_POLL` steps
    so that a signal's handler runs (and its KeyboardInterrupt is raised here) however the signal was delivered."""
    pending = set(futures)
    while pending:
        done, pending = wait(pending, timeout=INTERRUPT_POLL, return_when=FIRST_COMPLETED)
        yield from done


class WorkerPool:
    """At most ``workers`` forked worker processes, started at the first call. A context manager: leaving it
    normally waits for the workers to exit; leaving it by an exception (Ctrl-C, SIGTERM: a KeyboardInterrupt)
    drops the queued calls and terminates the running ones at once."""

    def __init__(self, workers: int):
        if workers < 1:
            raise ValueError(f"workers = {workers}: give at least 1")
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None

    def submit(self, fn: Callable, *args) -> Future:
        """``fn(*args)`` on a worker; its Future."""
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.workers, initializer=_worker_signals)
        return self._pool.submit(fn, *args)

    def map(self, fn: Callable, calls: Sequence[tuple]) -> list:
        """``[fn(*args) for args in calls]`` on the workers, in the calls' order; the first exception a call raised
        (in order) is raised here."""
        futures = [self.submit(fn, *args) for args in calls]
        for _ in completed(futures):
            pass
        return [f.result() for f in futures]

    def terminate(self) -> None:
        """Drop the queued calls and end the running ones now."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        processes = list((getattr(pool, "_processes", None) or {}).values())  # no public terminate before 3.14
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            proc.terminate()

    def close(self) -> None:
        """Wait for the queued calls and let the workers exit."""
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True)

    def __enter__(self) -> "WorkerPool":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.terminate()
