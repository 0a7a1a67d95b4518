"""One BLAS thread while dynval's own Python sections run.

The report's linear algebra (Gram matrices, small eigenproblems, least squares) is a small share
of its time, but a multi-threaded BLAS whose threads spin at a barrier turns it into most of it
when the machine is busy: on two cores with one taken by another process, one Gram matrix of a
1.4M × 70 regressor took 30 s with OpenBLAS's two threads and 0.27 s with one (benchmarks/
README.md). The core's own threads (parallel.hpp) are joined, never spun, and are not limited.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

from .._lazy import scipy

P = ParamSpec("P")
R = TypeVar("R")

_controller: ThreadpoolController | None = None
_modules_seen = -1


def _blas_controller() -> ThreadpoolController:
    """The loaded BLAS libraries, found once and again only after an import (a search of every
    loaded shared library took 50 ms a call on a busy machine: a ``compare`` pays it per candidate).
    scipy's own BLAS is loaded first, so that the limit covers it although scipy is imported on
    first use (dynval._lazy)."""
    global _controller, _modules_seen
    if _controller is None or len(sys.modules) != _modules_seen:
        scipy.linalg  # noqa: B018  (the import is the point)
        _controller = ThreadpoolController()
        _modules_seen = len(sys.modules)
    return _controller


def one_blas_thread(func: Callable[P, R]) -> Callable[P, R]:
    """``func`` with the BLAS libraries limited to one thread for the length of the call (the
    caller's limits come back afterwards)."""

    @functools.wraps(func)
    def limited(*args: P.args, **kwargs: P.kwargs) -> R:
        with _blas_controller().limit(limits=1, user_api="blas"):
            return func(*args, **kwargs)

    return limited
