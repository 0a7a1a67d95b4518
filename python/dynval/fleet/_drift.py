"""Drift: a robot whose model fits worse from some log on than in that robot's earlier logs.

The unit is the log: within a log the residual of a real robot is coloured, so its samples are not
independent, but the logs of one robot, each a separate run on its own trajectory, give log RMSEs
that are exchangeable while nothing changes. The test is a one-sided change point in the mean of
log(RMSE) over the robot's logs in time order: for every split with at least ``min_baseline`` logs
before it, the two-sample t statistic of the later logs against the earlier ones; the largest one
is the statistic and its split the change. Its p-value is a permutation p-value (the logs' order
shuffled, ``(1 + #{T* ≥ T}) / (B + 1)``), exact under exchangeability whatever the distribution of
the log RMSEs, so the size holds with few logs and heavy tails. Holm's method over the fleet's
robots holds the family-wise error rate, as the findings of a report do (docs/conventions.md §5).

A significant drift is a ``deficiency`` when the later logs' RMSE is at least ``ratio_threshold``
times the earlier logs' (geometric means), else a ``note``; ``benchmarks/calibrate_fleet.py``
measures its size and power on simulated fleets.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..report._findings import Finding
from ..report._text import p_clause
from ..statistics._stats import holm
from ._run import LogSummary

__all__ = ["Drift", "change_point", "drift_per_robot", "DEFAULT_PERMUTATIONS", "RATIO_THRESHOLD",
           "MIN_BASELINE", "MAX_PERMUTATIONS"]

DEFAULT_PERMUTATIONS = 1999
"""Shuffles of a robot's logs for the permutation p-value (its smallest value is 1/2000)."""
MAX_PERMUTATIONS = 1_000_000
"""Most shuffles a run accepts: a p-value resolution of 1e-6, far below any level, in seconds per robot."""
# Shuffles drawn and reduced at a time, so that memory stays bounded whatever n_permutations is
# (the draws are those of one call: permuted consumes the generator row after row).
_SHUFFLE_BLOCK = 10_000
RATIO_THRESHOLD = 1.10
"""A drift is a deficiency when the RMSE grew by at least 10 % (geometric means after / before)."""
MIN_BASELINE = 3
"""Earlier logs a change needs before it (so a robot needs at least 4 logs to be tested)."""


@dataclass(frozen=True)
class Drift:
    """The drift test of one robot.

    ``tested`` is False (with the ``reason``) when the robot has too few valid logs. ``change``
    is the 0-based index, in the robot's time order, of the first log after the change, with that
    log's id and time; ``ratio`` the geometric-mean RMSE of the logs from it on over that of the
    logs before it; ``finding`` the drift finding when the Holm-adjusted p-value is at most α.
    """

    robot: str
    n_logs: int
    tested: bool
    reason: str = ""
    change: int | None = None
    change_log: str | None = None
    change_time: str | None = None
    statistic: float = float("nan")
    pvalue: float = float("nan")
    pvalue_adjusted: float = float("nan")
    ratio: float = float("nan")
    finding: Finding | None = None


def _split_statistics(x: np.ndarray, min_baseline: int) -> np.ndarray:
    """t statistics of every split k ≥ min_baseline (later mean − earlier mean, pooled variance);
    rows of ``x`` are series, the result has one column per split."""
    n = x.shape[1]
    k = np.arange(min_baseline, n)
    # t does not depend on a shift: centred first, equal logs give sums of exact zeros (0/0, no
    # change) instead of a rounding residue over a rounding spread
    x = x - x.mean(axis=1, keepdims=True)
    s1, s2 = np.cumsum(x, axis=1), np.cumsum(x * x, axis=1)
    before, before2 = s1[:, k - 1], s2[:, k - 1]
    after, after2 = s1[:, -1:] - before, s2[:, -1:] - before2
    mean_b, mean_a = before / k, after / (n - k)
    ss = (before2 - k * mean_b**2) + (after2 - (n - k) * mean_a**2)
    scale = np.sqrt(np.maximum(ss, 0.0) / (n - 2) * (1.0 / k + 1.0 / (n - k)))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (mean_a - mean_b) / scale
    # identical logs: no change (0/0); a jump without spread stays ±inf (nan_to_num's default would
    # make it ±1.8e308, and the permutation count's tolerance would overflow on it)
    return np.nan_to_num(t, nan=0.0, posinf=np.inf, neginf=-np.inf)


def change_point(x: Sequence[float] | np.ndarray, *, min_baseline: int = MIN_BASELINE,
                 n_permutations: int = DEFAULT_PERMUTATIONS, rng: np.random.Generator | None = None,
                 ) -> tuple[int, float, float]:
    """(index of the first later log, statistic, permutation p-value) of an upward change in the
    mean of ``x`` (at least ``min_baseline`` + 1 values).

    Examples
    --------
    >>> x = [0.0, 0.1, -0.1, 0.05, 1.0, 1.1, 0.9]
    >>> k, t, p = change_point(x, rng=np.random.default_rng(0))
    >>> k, p < 0.05
    (4, True)
    """
    values = np.asarray(x, dtype=np.float64)[None, :]
    observed = _split_statistics(values, min_baseline)[0]
    best = int(np.argmax(observed))
    generator = rng if rng is not None else np.random.default_rng(0)
    maxima = np.concatenate([
        _split_statistics(generator.permuted(np.repeat(values, min(_SHUFFLE_BLOCK, n_permutations - done), axis=0),
                                             axis=1), min_baseline).max(axis=1)
        for done in range(0, n_permutations, _SHUFFLE_BLOCK)])
    # shuffles that reproduce the observed order up to rounding count as at least as large
    tolerance = 1e-9 * max(1.0, abs(float(observed[best]))) if math.isfinite(observed[best]) else 0.0
    exceed = int(np.sum(maxima >= observed[best] - tolerance))
    return min_baseline + best, float(observed[best]), (1 + exceed) / (n_permutations + 1)


def _robot_rng(seed: int, robot: str) -> np.random.Generator:
    # surrogatepass: a robot named from a path with a byte that is not UTF-8 (kept as U+DCFF) has a stream
    # too; any other name encodes as plain UTF-8, so its stream is unchanged
    return np.random.default_rng([seed, zlib.crc32(robot.encode("utf-8", "surrogatepass"))])


def drift_per_robot(rows: Sequence[LogSummary], *, level: float, min_baseline: int = MIN_BASELINE,
                    ratio_threshold: float = RATIO_THRESHOLD, n_permutations: int = DEFAULT_PERMUTATIONS,
                    seed: int = 0) -> list[Drift]:
    """The drift test of every robot of ``rows`` (already in robot and time order), Holm over the
    robots tested."""
    robots = list(dict.fromkeys(r.robot for r in rows))
    partial: list[tuple[str, list[LogSummary], tuple[int, float, float] | None]] = []
    for robot in robots:
        logs = [r for r in rows if r.robot == robot and r.error is None and r.rmse > 0 and math.isfinite(r.rmse)]
        if len(logs) < min_baseline + 1:
            partial.append((robot, logs, None))
            continue
        k, t, p = change_point(np.log([r.rmse for r in logs]), min_baseline=min_baseline,
                               n_permutations=n_permutations, rng=_robot_rng(seed, robot))
        partial.append((robot, logs, (k, t, p)))
    tested = [i for i, (_, _, res) in enumerate(partial) if res is not None]
    raw = [res[2] for _, _, res in partial if res is not None]
    adjusted = dict(zip(tested, holm(raw))) if tested else {}
    return [_drift(robot, logs, res, adjusted.get(i), level, min_baseline, ratio_threshold)
            for i, (robot, logs, res) in enumerate(partial)]


def _drift(robot, logs, res, padj, level, min_baseline, ratio_threshold) -> Drift:
    if res is None:
        return Drift(robot, len(logs), False, reason=f"only {len(logs)} valid log{'s' * (len(logs) != 1)}; the drift "
                                                     f"test needs at least {min_baseline + 1}")
    k, t, p = res
    log_rmse = np.log([r.rmse for r in logs])
    ratio = float(np.exp(log_rmse[k:].mean() - log_rmse[:k].mean()))
    drift = Drift(robot, len(logs), True, change=k, change_log=logs[k].log, change_time=logs[k].time,
                  statistic=t, pvalue=p, pvalue_adjusted=float(padj), ratio=ratio)
    if padj > 1.0 - level:
        return drift
    return replace(drift, finding=_finding(drift, logs, ratio_threshold))


def _finding(d: Drift, logs: Sequence[LogSummary], ratio_threshold: float) -> Finding:
    k = int(d.change or 0)
    severity = "deficiency" if d.ratio >= ratio_threshold else "note"
    size = (f"{d.ratio:.3g}× the RMSE of its {k} earlier log{'s' * (k != 1)}" if severity == "deficiency"
            else f"{d.ratio:.3g}× the RMSE of its {k} earlier logs, below the {ratio_threshold:g}× that counts")
    message = (f"robot {d.robot}: the model fits worse from log {d.change_log} ({d.change_time}) on: {size} "
               f"(geometric means; change point in log RMSE over its {d.n_logs} logs, permutation test, "
               f"Holm-adjusted p {p_clause(d.pvalue_adjusted)} over the fleet's robots)")
    action = (f"re-identify robot {d.robot}'s model on its logs from {d.change_log} on, or find what changed then "
              "(friction wear, a new payload or tool, a sensor's calibration)") if severity == "deficiency" else ""
    return Finding(kind="drift", severity=severity, statistic=d.statistic, pvalue=d.pvalue,
                   pvalue_adjusted=d.pvalue_adjusted, effect=d.ratio, effect_unit="× RMSE", threshold=ratio_threshold,
                   action=action, message=message,
                   details={"robot": d.robot, "from_log": d.change_log, "from_time": d.change_time, "from_index": k,
                            "n_logs": d.n_logs, "rmse_before": _geometric_mean(logs[:k]),
                            "rmse_after": _geometric_mean(logs[k:])})


def _geometric_mean(logs: Sequence[LogSummary]) -> float:
    return float(np.exp(np.mean(np.log([r.rmse for r in logs]))))
