"""The controller set-up's BLAS thread limit: one thread inside the block, the previous limits restored after it,
and simulate() runs under it."""

import numpy as np
import pytest

from pathmotion.control import threads

threadpoolctl = pytest.importorskip("threadpoolctl")


def blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpoolctl.threadpool_info() if lib["user_api"] == "blas"]


def test_one_blas_thread_inside_the_block_and_the_limits_restored_after_it():
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):  # a known start, whatever the machine's default
        before = blas_threads()
        with threads.single_blas_thread():
            assert blas_threads() and all(n == 1 for n in blas_threads())
        assert blas_threads() == before


def test_the_decorator_limits_the_call_and_returns_its_value():
    seen = []

    @threads.blas_single_threaded
    def work(x):
        seen.append(blas_threads())
        return np.linalg.solve(np.eye(3) * x, np.ones(3))

    assert np.allclose(work(2.0), 0.5) and all(n == 1 for n in seen[0])
