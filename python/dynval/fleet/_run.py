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
import os
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..checks._errors import InputError, InvalidParameter
from ._logs import LogSpec, as_spec, check_unique, is_manifest, manifest_logs, parse_name

__all__ = ["LogSummary", "summarise_log", "run_logs", "is_bag", "fleet_items", "error_row", "sees"]


@dataclass(frozen=True)
class LogSummary:
    """One log's row of the fleet table.

    ``rmse`` is the pooled RMSE per element (√(SSE/(N·m))) and ``vaf`` the pooled VAF in %;
    ``decision`` is the verdict of :func:`dynval.compare` on the one model (accept, refine,
    redesign), or ``error`` when the log could not be validated (``error`` then holds the message);
    ``kinds`` are the kinds of its deficiency and design findings, strongest first; ``sees`` says
    what the decision could test (``residual only: no q, no regressor`` when the log gave neither:
    then a change that leaves the residual zero-mean and no more coloured, such as a grown friction,
    does not show within the log).
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
    sees: str = ""


def summarise_log(item: Any, n_params: int | None = None, keywords: dict | None = None) -> LogSummary:
    """Read one log where this runs, validate it and summarise it (the task of every log).

    Input errors (a file refused, an error of the contract) become the row's ``error``: one bad
    log does not stop a fleet.
    """
    from ..comparison._compare import compare
    from ..io._files import load_array
    from ..io._shapes import check_declared

    start = time.perf_counter()
    if isinstance(item, LogSummary):  # a log refused before the run (fleet_items)
        return item
    try:
        spec = as_spec(item, n_params)
    except InputError as exc:  # a log of a dask bag, named on the worker
        return error_row(item, exc)
    try:
        if all(isinstance(x, str) for x in (spec.tau_meas, spec.tau_pred)):
            # the files' shapes, from their headers, before any array is decoded (contract §7)
            check_declared(spec.tau_meas, {"tau_pred": spec.tau_pred},
                           regressor=spec.regressor if isinstance(spec.regressor, str) else None)
        meas, pred = load_array(spec.tau_meas), load_array(spec.tau_pred)
        arrays = {name: load_array(file) for name, file in spec.data.items()}
        reg = arrays.pop("regressor", None)
        cmp = compare(meas, {spec.name: (pred, spec.n_params, reg)}, **_log_keywords(arrays, keywords or {}))
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
        seconds=time.perf_counter() - start, sees=sees(spec.data))


def _log_keywords(arrays: dict[str, Any], keywords: dict) -> dict:
    """validate's keywords of one log: the fleet's, and the log's own q, dq, ddq, time and estimation run."""
    out = dict(keywords)
    out.update({name: arrays[name] for name in ("q", "dq", "ddq") if name in arrays})
    if "timestamps" in arrays:
        out["time"] = arrays["timestamps"]
    run = {key: arrays[f"estimation_{key}"] for key in ("tau", "regressor", "q") if f"estimation_{key}" in arrays}
    if run:
        out["estimation"] = run
    return out


def sees(data: dict[str, Any]) -> str:
    """What a log's decision could test, in words (contract §10): the residual alone unless q or the
    regressor came with it, and the estimation run when it did."""
    if "q" not in data and "regressor" not in data:
        return "residual only: no q, no regressor"
    given = ["q" if "q" in data else "", "regressor" if "regressor" in data else "",
             "estimation run" if "estimation_tau" in data or "estimation_q" in data else ""]
    lacking = [name for name in ("q", "regressor") if name not in data]
    if "estimation_tau" not in data and "estimation_q" not in data:
        lacking.append("estimation run")
    return "residual, " + ", ".join(g for g in given if g) + ("; no " + ", no ".join(lacking) if lacking else "")


def error_row(item: Any, exc: InputError, seconds: float = 0.0) -> LogSummary:
    """The row of a log that could not be named or read: its robot and time as far as its name gives them."""
    message = f"{type(exc).__name__}: {exc}"
    if isinstance(item, Mapping):
        return LogSummary(str(item.get("robot") or "?"), str(item.get("time") or ""),
                          str(item.get("log") or item.get("time") or item.get("tau_meas") or "?"),
                          error=message, seconds=seconds)
    path = os.fspath(item) if isinstance(item, (str, os.PathLike)) else repr(item)
    named = parse_name(path)
    if named is None:  # no robot to give it: the path stands for one, so that the row is seen
        return LogSummary(path, "", os.path.basename(path.rstrip("/\\")) or path, error=message, seconds=seconds)
    robot, stamp, stem, _ = named
    return LogSummary(robot, stamp, stem, error=message, seconds=seconds)


def fleet_items(logs: Iterable[Any], n_params: int | None) -> list[LogSpec | LogSummary]:
    """The fleet's logs before any runs: manifests read (a bad manifest is refused whole, naming its row),
    logs named by a path, mapping or LogSpec resolved, and a log that cannot be (a missing directory,
    a name without ``ROBOT__TIME``) its error row, so that one broken log does not stop the fleet."""
    out: list[LogSpec | LogSummary] = []
    named: list[tuple[str, LogSpec]] = []
    for index, item in enumerate(logs):
        if is_manifest(item):
            rows = manifest_logs(os.fspath(item), n_params)
            named.extend(rows)
            out.extend(spec for _, spec in rows)
            continue
        if not isinstance(item, (str, os.PathLike, Mapping, LogSpec)):
            raise InvalidParameter(f"a log must be a path, a manifest, a mapping or a LogSpec, got "
                                   f"{type(item).__name__}")
        if n_params is None and isinstance(item, (str, os.PathLike)):
            raise InvalidParameter(f"{os.fspath(item)}: n_params is needed: give it to validate_many (--n-params) "
                                   "or list the log in a manifest with an n_params column")
        try:
            spec = as_spec(item, n_params)
        except InputError as exc:
            out.append(error_row(item, exc))
            continue
        named.append((os.fspath(item) if isinstance(item, (str, os.PathLike)) else f"logs[{index}]", spec))
        out.append(spec)
    check_unique(named)
    return out


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
