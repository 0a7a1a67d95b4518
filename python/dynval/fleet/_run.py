"""Validating many logs: tasks of a few logs each, reading and computing where the task runs.

A task receives consecutive :class:`~dynval.fleet._logs.LogSpec` (file names, never arrays; about
four tasks per worker thread, so that the scheduler's cost per task stays small beside the logs'),
reads each log's arrays
with the command line's readers (``dynval.io``), validates them with :func:`dynval.compare` on the
one candidate (its verdict is the log's decision) and returns a :class:`LogSummary` of a few
numbers. Without a dask client the tasks run one after the other in this process.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ..checks._errors import InputError
from ._logs import as_spec

__all__ = ["LogSummary", "summarise_log", "run_logs", "is_bag"]


@dataclass(frozen=True)
class LogSummary:
    """One log's row of the fleet table.

    ``rmse`` is the pooled RMSE per element (√(SSE/(N·m))) and ``vaf`` the pooled VAF in %;
    ``decision`` is the verdict of :func:`dynval.compare` on the one model (accept, refine,
    redesign), or ``error`` when the log could not be validated (``error`` then holds the message);
    ``kinds`` are the kinds of its deficiency and design findings, strongest first.
    """

    robot: str
    time: str
    log: str
    n_samples: int = 0
    n_joints: int = 0
    rmse: float = float("nan")
    vaf: float = float("nan")
    rmse_per_joint: tuple[float, ...] = ()
    decision: str = "error"
    n_findings: int = 0
    kinds: tuple[str, ...] = ()
    error: str | None = None
    seconds: float = 0.0


def summarise_log(item: Any, n_params: int | None = None, keywords: dict | None = None) -> LogSummary:
    """Read one log where this runs, validate it and summarise it (the task of every log).

    Input errors (a file refused, an error of the contract) become the row's ``error``: one bad
    log does not stop a fleet.
    """
    from ..comparison._compare import compare
    from ..io._files import load_array
    from ..io._shapes import check_declared

    spec = as_spec(item, n_params)
    start = time.perf_counter()
    try:
        if all(isinstance(x, str) for x in (spec.tau_meas, spec.tau_pred)):
            # the files' shapes, from their headers, before any array is decoded (contract §7)
            check_declared(spec.tau_meas, {"tau_pred": spec.tau_pred},
                           regressor=spec.regressor if isinstance(spec.regressor, str) else None)
        meas, pred = load_array(spec.tau_meas), load_array(spec.tau_pred)
        reg = None if spec.regressor is None else load_array(spec.regressor)
        cmp = compare(meas, {spec.name: (pred, spec.n_params, reg)}, **(keywords or {}))
    except InputError as exc:
        return LogSummary(spec.robot, spec.time, spec.name, error=f"{type(exc).__name__}: {exc}",
                          seconds=time.perf_counter() - start)
    report = cmp.reports[spec.name]
    shown = [f for f in report.findings if f.severity in ("deficiency", "design")]
    return LogSummary(
        robot=spec.robot, time=spec.time, log=spec.name, n_samples=int(meas.shape[0]),
        n_joints=1 if meas.ndim == 1 else int(meas.shape[1]), rmse=float(report.pooled["rmse_per_element"]),
        vaf=float(report.pooled["vaf"]), rmse_per_joint=tuple(float(x) for x in report.per_joint["rmse"]),
        decision=str(cmp.verdict.decision), n_findings=len(shown), kinds=tuple(dict.fromkeys(f.kind for f in shown)),
        seconds=time.perf_counter() - start)


def _summarise_partition(items: Sequence[Any], n_params: int | None, keywords: dict) -> list[LogSummary]:
    return [summarise_log(item, n_params, keywords) for item in items]


def is_bag(logs: Any) -> bool:
    """Whether ``logs`` is a dask bag (without importing dask when it is not installed)."""
    return type(logs).__module__.startswith("dask.bag")


def _progress_bar(total: int, progress: bool | None, unit: str) -> Any:
    from tqdm import tqdm  # type: ignore[import-untyped]

    # By default: on a terminal, once the run has lasted 2 s (as dynval validate --stream does).
    return tqdm(total=total, unit=unit, file=sys.stderr, disable=None if progress is None else not progress,
                delay=2.0 if progress is None else 0.0, desc="dynval fleet")


def run_logs(logs: Any, client: Any, n_params: int | None, keywords: dict,
             progress: bool | None) -> list[LogSummary]:
    """Every log's summary, in the order of ``logs`` (a list of items, or a dask bag)."""
    if is_bag(logs):
        return _run_bag(logs, client, n_params, keywords, progress)
    items = list(logs)
    if client is None:
        with _progress_bar(len(items), progress, "log") as bar:
            out = []
            for item in items:
                out.append(summarise_log(item, n_params, keywords))
                bar.update(1)
            return out
    batches = _batches(items, client)
    futures = client.map(_summarise_partition, batches, n_params=n_params, keywords=keywords, pure=False)
    return _gathered(client, futures, progress, "log", lambda parts: [row for part in parts for row in part],
                     sizes=[len(b) for b in batches])


#: Tasks per worker thread: enough to balance logs of unequal cost, few enough that the scheduler's
#: per-task cost (milliseconds, on the cores the workers use) stays small beside a log's.
TASKS_PER_THREAD = 10


def _batches(items: list, client: Any) -> list[list]:
    """The logs in consecutive batches, one task each: about TASKS_PER_THREAD per worker thread."""
    workers = (client.scheduler_info() or {}).get("workers", {})
    threads = sum(int(w.get("nthreads", 1)) for w in workers.values()) or 1
    size = max(1, math.ceil(len(items) / (TASKS_PER_THREAD * threads)))
    return [items[i:i + size] for i in range(0, len(items), size)]


def _run_bag(bag: Any, client: Any, n_params: int | None, keywords: dict, progress: bool | None) -> list[LogSummary]:
    parts = bag.map_partitions(_summarise_partition, n_params, keywords).to_delayed()
    if client is None:
        from dask.base import compute

        return [row for part in compute(*parts, scheduler="sync") for row in part]
    return _gathered(client, client.compute(parts), progress, "partition",
                     lambda parts: [row for part in parts for row in part])


def _gathered(client: Any, futures: list, progress: bool | None, unit: str, flatten: Callable,
              sizes: list[int] | None = None) -> list:
    from distributed import as_completed

    weight = dict(zip(map(id, futures), sizes or [1] * len(futures)))
    with _progress_bar(sum(weight.values()), progress, unit) as bar:
        for done in as_completed(futures):
            bar.update(weight.get(id(done), 1))
    return list(flatten(client.gather(futures)))
