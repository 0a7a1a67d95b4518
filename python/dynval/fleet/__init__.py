"""Fleets: many logs of many robots, validated where the data are, and drift over each robot's logs.

:func:`validate_many` validates every log (one task per log, reading its files where the task runs:
tasks receive file names, never arrays) into one row of the fleet table per log, and tests each
robot's logs for drift: a model that fits worse from some log on than it did in that robot's earlier
logs (friction wear, a changed payload). Contract §10 defines how a log names its robot and time.

Running on a cluster
--------------------
Without dask, or without a dask client, the logs are validated one after the other in this process.
With a client (``dask.distributed``) they are spread over its workers::

    from dask.distributed import Client
    import dynval.fleet

    client = Client(dynval.fleet.local_cluster(n_workers=2))  # LocalCluster, workers set for many logs
    fleet = dynval.fleet.validate_many(["fleet.csv"], n_params=40)   # the current client is used

On a real cluster the only change is the scheduler's address (``scheduler="tcp://host:8786"``, or
``Client("tcp://host:8786")`` first); the files must be readable where the workers run, and workers
started with :data:`WORKER_ENVIRON` in their environment spend less time in page faults.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable
from typing import Any

from ..checks._errors import InvalidParameter
from ..checks._validation import check_level, is_integer, is_real_number, parameter_error
from ._cluster import WORKER_ENVIRON, client_for, local_cluster
from ._drift import (
    DEFAULT_PERMUTATIONS,
    MAX_PERMUTATIONS,
    MIN_BASELINE,
    RATIO_THRESHOLD,
    Drift,
    change_point,
    drift_per_robot,
)
from ._logs import DATA_COLUMNS, MANIFEST_COLUMNS, LogSpec, log_from_path, read_manifest, time_key
from ._report import TABLE_COLUMNS, FleetReport
from ._run import LogSummary, fleet_items, is_bag, run_logs, summarise_log
from ._simulate import Degradation, EstimationRun, FleetLog, simulate_fleet, write_fleet

__all__ = ["validate_many", "FleetReport", "LogSummary", "Drift", "LogSpec", "read_manifest", "log_from_path",
           "change_point", "local_cluster", "WORKER_ENVIRON", "simulate_fleet", "write_fleet", "Degradation",
           "FleetLog", "EstimationRun", "summarise_log", "MANIFEST_COLUMNS", "TABLE_COLUMNS", "MIN_BASELINE",
           "RATIO_THRESHOLD", "DEFAULT_PERMUTATIONS", "MAX_PERMUTATIONS", "DATA_COLUMNS"]


def validate_many(logs: Any, *, n_params: int | None = None, scheduler: Any = None, progress: bool | None = None,
                  level: float = 0.95, min_baseline: int = MIN_BASELINE, ratio_threshold: float = RATIO_THRESHOLD,
                  n_permutations: int = DEFAULT_PERMUTATIONS, seed: int = 0, **keywords: Any) -> FleetReport:
    """Validate every log of a fleet, one task per log, and test each robot's logs for drift.

    Parameters
    ----------
    logs : paths, manifests, LogSpecs or mappings, or a dask bag of logs
        Manifests (``.csv``/``.json``) name their logs; other paths are logs named ``ROBOT__TIME``
        (contract §10). A dask bag of logs (not manifests) is mapped on its own partitions (names
        resolved on the workers).
    n_params : int, optional
        Parameter count of every log that does not give its own (the manifest's ``n_params``).
    scheduler : None, "single", dask Client, cluster or address, optional
        None uses the current dask client if there is one, else this process; ``"single"`` always
        this process; a cluster (``LocalCluster``) or an address (``"tcp://host:8786"``) gets a client
        of its own for the run.
    progress : bool, optional
        A progress bar on stderr; by default on a terminal once the run has lasted 2 s.
    level : float
        Confidence level of every log's findings and of the drift test (α = 1 − level).
    min_baseline : int
        Earlier logs a change needs before it (a robot needs ``min_baseline + 1`` valid logs).
    ratio_threshold : float
        RMSE ratio (later / earlier logs, geometric means) from which a drift is a deficiency.
    n_permutations : int
        Shuffles of each robot's logs for the drift test's p-value.
    seed : int
        Seed of the shuffles (each robot's stream also depends on its name): results are reproducible.
    **keywords
        Keywords of :func:`dynval.validate` for every log (``max_lag``, ``profile``, ``sample_rate``, ...).

    Returns
    -------
    FleetReport

    Examples
    --------
    >>> import tempfile, dynval.fleet as fleet
    >>> logs = fleet.simulate_fleet(n_robots=2, n_logs=8, n_samples=300,
    ...                             degradations={"r02": fleet.Degradation("friction", 4, 1.0)})
    >>> specs = fleet.write_fleet(logs, tempfile.mkdtemp())
    >>> report = fleet.validate_many(specs, scheduler="single", max_lag=10)
    >>> [(d.robot, d.change_log) for d in report.drift if d.finding]
    [('r02', 'r02__2026-01-05T08-00')]

    A robot with fewer logs than the test needs is listed as not tested:

    >>> fleet.validate_many(specs[:3], scheduler="single", max_lag=10).drift[0].reason
    'only 3 valid logs; the drift test needs at least 4'
    """
    check_level(level)
    _check_settings(min_baseline, ratio_threshold, n_permutations, seed, n_params)
    _check_validate_keywords(keywords)
    settings = dict(keywords, level=level)
    items = logs if is_bag(logs) else fleet_items([logs] if isinstance(logs, (str, os.PathLike)) else logs, n_params)
    client, owned = client_for(scheduler)
    start = time.perf_counter()
    try:
        rows = run_logs(items, client, n_params, settings, progress)
        workers = 0 if client is None else len(client.scheduler_info()["workers"])
        where = "this process" if client is None else f"{workers} dask worker{'s' * (workers != 1)}"
    finally:
        if owned:
            client.close()
    ordered = _in_fleet_order(rows)
    drift = drift_per_robot(ordered, level=level, min_baseline=min_baseline, ratio_threshold=ratio_threshold,
                            n_permutations=n_permutations, seed=seed)
    provenance = {"n_logs": len(ordered), "n_robots": len(drift), "where": where,
                  "seconds": time.perf_counter() - start, "min_baseline": min_baseline,
                  "ratio_threshold": ratio_threshold, "n_permutations": n_permutations, "seed": seed,
                  "validate_keywords": {k: v for k, v in keywords.items() if isinstance(v, (int, float, str, bool))}}
    return FleetReport(tuple(ordered), tuple(drift), float(level), provenance)


# validate's settings that do not depend on a log's data: checked once, before any task runs
def _data_free() -> set[str]:
    """validate's settings that need no data: those the stream checks before its chunks (its declared
    ``stream="supported"``), but n_params and level, the fleet's own."""
    from ..report._options import OPTIONS

    return {o.name for o in OPTIONS if o.stream == "supported"} - {"n_params", "level"}


# validate's data keywords: each log has its own, named by the manifest's columns
_PER_LOG = {"q": "q", "dq": "dq", "ddq": "ddq", "time": "timestamps",
            "estimation": "estimation_tau, estimation_regressor and estimation_q"}


def _check_validate_keywords(keywords: dict[str, Any]) -> None:
    """Unknown names (TypeError) and bad data-free settings (InvalidParameter) fail here, not in every task."""
    from ..report._options import NAMES, Keywords, check_options

    known = set(NAMES) - {"n_params", "level"}
    for name in keywords:
        if name not in known:
            raise TypeError(f"validate_many() got an unexpected keyword argument {name!r}")
        if name in _PER_LOG:
            raise InvalidParameter(f"{name}= is one log's data, not the fleet's: give each log's file in the "
                                   f"manifest's {_PER_LOG[name]} column (contract §10)")
    free = {k: v for k, v in keywords.items() if k in _data_free()}
    check_options(Keywords(n_params=0, decimate=None, cross_correlation_detail=None, **free), None)


def _check_settings(min_baseline: Any, ratio_threshold: Any, n_permutations: Any, seed: Any, n_params: Any) -> None:
    """Every setting of the run's own, before any log is read (a bad one must not cost the fleet's time)."""
    if not is_integer(min_baseline) or min_baseline < 2:
        raise parameter_error("min_baseline", "an integer >= 2", min_baseline)
    if isinstance(ratio_threshold, bool) or not is_real_number(ratio_threshold) or not ratio_threshold >= 1.0:
        raise parameter_error("ratio_threshold", "a number >= 1", ratio_threshold)
    if not is_integer(n_permutations) or not 19 <= n_permutations <= MAX_PERMUTATIONS:
        raise parameter_error("n_permutations", f"an integer with 19 <= n_permutations <= {MAX_PERMUTATIONS}",
                              n_permutations)
    if not is_integer(seed) or not 0 <= seed < 2**63:
        raise parameter_error("seed", "an integer with 0 <= seed < 2**63", seed)
    if n_params is not None and (not is_integer(n_params) or n_params < 0):
        raise parameter_error("n_params", "None or an integer >= 0", n_params)


def _in_fleet_order(rows: Iterable[LogSummary]) -> list[LogSummary]:
    """Robots in the order they first appear, each robot's logs in time order."""
    rows = list(rows)
    first = {robot: i for i, robot in reversed(list(enumerate(r.robot for r in rows)))}
    return sorted(rows, key=lambda r: (first[r.robot], time_key(r.time)))
