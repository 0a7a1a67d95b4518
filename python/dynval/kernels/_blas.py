"""One BLAS thread while dynval's own Python sections run.

The report's linear algebra (Gram matrices, small eigenproblems, least squares) is a small share
of its time, but a multi-threaded BLAS whose threads spin at a barrier turns it into most of it
when the machine is busy: on two cores with one taken by another process, one Gram matrix of a
1.4M × 70 regressor took 30 s with OpenBLAS's two threads and 0.27 s with one (benchmarks/
README.md). The core's own threads (parallel.hpp) are joined, never spun, and are not limited.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from threadpoolctl import threadpool_limits

P = ParamSpec("P")
R = TypeVar("R")


def one_blas_thread(func: Callable[P, R]) -> Callable[P, R]:
    """``func`` with the BLAS libraries limited to one thread for the length of the call (the
    caller's limits come back afterwards)."""

    @functools.wraps(func)
    def limited(*args: P.args, **kwargs: P.kwargs) -> R:
        with threadpool_limits(limits=1, user_api="blas"):
            return func(*args, **kwargs)

    return limited
