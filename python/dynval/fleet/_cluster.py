"""Where a fleet runs: this process, the current dask client, a cluster or a scheduler's address.

A worker runs its tasks in a thread of its own with dask's ``MALLOC_TRIM_THRESHOLD_`` in its
environment, which fixes glibc's mmap threshold at 128 KiB: every temporary of a log's validation
(a 5,000 × 7 array is 280 kB) is then mapped and zeroed afresh, five times the page faults and about
1.4 times the CPU of the same log in a plain process (``benchmarks/README.md``). Workers started with
:data:`WORKER_ENVIRON` keep freed memory for the next temporary instead.
"""

from __future__ import annotations

from typing import Any

from .._environ import restored_environ
from ..checks._errors import InvalidParameter
from ..checks._validation import format_value

__all__ = ["WORKER_ENVIRON", "local_cluster", "client_for"]

WORKER_ENVIRON = {
    "MALLOC_MMAP_THRESHOLD_": 16 << 20,  # temporaries below 16 MiB come from the heap, reused
    "MALLOC_TRIM_THRESHOLD_": 256 << 20,  # free memory returns to the system beyond 256 MiB
    "MALLOC_TOP_PAD_": 64 << 20,
    "DYNVAL_NUM_THREADS": 1,  # a worker's thread per task: no threads of its own (as dask's OMP_NUM_THREADS)
}
"""glibc malloc settings for the workers of a fleet, and one thread for dynval's own parallel work
(set them where ``dask worker`` starts, too)."""


def local_cluster(n_workers: int = 2, **kwargs: Any) -> Any:
    """A ``distributed.LocalCluster`` of ``n_workers`` processes of one thread each, started with
    :data:`WORKER_ENVIRON` (other keywords go to ``LocalCluster``); close it after use."""
    import dask
    from distributed import LocalCluster

    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ"), **WORKER_ENVIRON}
    settings = {"threads_per_worker": 1, "processes": True, "dashboard_address": ":0", **kwargs}
    # The nannies run in this process and set the variables in its own environment before they
    # spawn their workers: restore it, so that later subprocesses of the caller do not inherit them.
    with restored_environ(environ), dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        return LocalCluster(n_workers=n_workers, **settings)


def client_for(scheduler: Any) -> tuple[Any, bool]:
    """(dask client or None for this process, whether this run made it and must close it)."""
    if isinstance(scheduler, str) and scheduler == "single":
        return None, False
    if scheduler is None:
        try:
            from distributed import default_client

            return default_client(), False
        except (ImportError, ValueError):  # no dask, or no client: this process
            return None, False
    if hasattr(scheduler, "submit") and hasattr(scheduler, "gather"):
        return scheduler, False
    if isinstance(scheduler, str) or hasattr(scheduler, "scheduler_address"):
        try:
            from distributed import Client
        except ImportError:
            raise ImportError("a dask scheduler needs dask.distributed: pip install 'dynval[dask]'") from None
        return Client(scheduler), True
    raise InvalidParameter(f"scheduler must be None, 'single', a dask Client, a cluster or a scheduler address, "
                           f"got {format_value(scheduler)}")
