"""How many threads dynval's own parallel work may use, as the compiled core decides it.

The core (``cpp/include/dynval/parallel.hpp``) runs on the machine's hardware threads, or on
``DYNVAL_NUM_THREADS`` when that is a positive integer (a fleet worker, a benchmark per core);
the transforms scipy.fft runs for dynval and the physics test's joints (:func:`thread_map`) follow
the same setting. Its threads are joined, never
spun, like the core's (unlike a BLAS's, which ``_blas`` limits).
"""

from __future__ import annotations

import contextvars
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")

#: Below this many values a transform is not worth a thread (starting one costs tens of µs; the
#: transforms of 2^18 values take milliseconds).
MIN_PARALLEL_VALUES = 1 << 18


def worker_count(values: int | None = None) -> int:
    """DYNVAL_NUM_THREADS when set to a positive integer, else the CPUs this process may use; one
    for work on fewer than :data:`MIN_PARALLEL_VALUES` values (``values`` given)."""
    if values is not None and values < MIN_PARALLEL_VALUES:
        return 1
    value = os.environ.get("DYNVAL_NUM_THREADS", "").strip()
    if value.isdigit() and int(value) > 0:
        return int(value)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def thread_map(fn: Callable[[int], T], count: int, values: int | None = None) -> list[T]:
    """``[fn(i) for i in range(count)]``, on up to :func:`worker_count` ``(values)`` threads (one per
    item at most): independent pieces of work such as a joint's test each, whose numpy and LAPACK calls
    release the interpreter's lock. Each call runs in a copy of the caller's context, so that a
    ``numpy.errstate`` the caller set holds in the threads too; the results come back in order, and the
    first exception is raised once the calls that started have ended (the rest are cancelled)."""
    workers = min(worker_count(values), count)
    if workers < 2:
        return [fn(i) for i in range(count)]
    context = contextvars.copy_context()
    pool = ThreadPoolExecutor(workers, thread_name_prefix="dynval")
    try:
        return list(pool.map(lambda i: context.copy().run(fn, i), range(count)))
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
