"""Validation of dask arrays chunked along time, on any dask scheduler: threads, or a cluster.

Each time block becomes a :class:`dynval.stream.ValidationAccumulator` (its lagged sums and its
first and last rows), and dask's own tree reduction (:func:`dask.array.reduction`) merges them in
time order; lags join across block boundaries, so the report equals :func:`dynval.validate` on the
same data within the backends' agreement tolerance, with the sections of contract §4.1
(``dynval.stream``). Only the merged accumulator, O(L·m·p) numbers, travels to the caller.

Install the extra: ``pip install "dynval[dask]"`` (``dask[distributed]``).

Running on a cluster
--------------------
The computation runs on whatever dask scheduler is active. On this machine::

    from dask.distributed import Client, LocalCluster
    import dask.array as da, dynval.dask

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))
    tau = da.from_zarr("run.zarr/tau_meas")          # (N, m), chunked along time
    pred = da.from_zarr("run.zarr/tau_pred")
    report = dynval.dask.validate(tau, pred, n_params=12, max_lag=50)

On a real cluster the only change is where the client connects, the scheduler's address::

    client = Client("tcp://scheduler.example.org:8786")

(the workers need dynval installed, and the arrays must be readable where the workers run, e.g.
zarr or HDF5 files on shared storage or an object store). Each block's task allocates temporaries of
the block's size; dask's nanny starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``, under which
glibc maps and zeroes each of them afresh (``benchmarks/README.md`` has the measurements).
"""

from __future__ import annotations

import math
from typing import Any

import dask.array as da
import numpy as np

from .checks import _timing
from .checks import _validation as v
from .checks._errors import InvalidShape, InvalidType
from .checks._segments import parse_segments
from .checks._typing import ArrayLike, Integer, SegmentsLike
from .report._report import ValidationReport
from .stream import ValidationAccumulator

__all__ = ["validate", "accumulate", "validate_many"]


def validate(tau_meas: da.Array | ArrayLike, tau_pred: da.Array | ArrayLike, *, n_params: Integer,
             regressor: da.Array | ArrayLike | None = None, n_joints: Integer | None = None,
             segments: SegmentsLike = None, time: da.Array | ArrayLike | None = None,
             split_every: int | dict[int, int] | None = None, **keywords: Any) -> ValidationReport:
    """:func:`dynval.validate` of dask arrays chunked along time (rows), as a
    :class:`~dynval.ValidationReport` with the sections of ``dynval.stream`` (contract §4.1).

    Parameters
    ----------
    tau_meas, tau_pred : dask or numpy array, (N,) or (N, m)
        Chunked along time; columns are gathered into one chunk per block.
    n_params : int
        Number of identified parameters p.
    regressor : dask or numpy array, (N, m, p) or (N·m, p) with ``n_joints``, optional
        Rechunked along time to the torques' blocks.
    n_joints : int, optional
        Number of joints m, needed for a stacked ``(N·m, p)`` regressor.
    segments : lengths or starts, optional
        Independent records (contract §1.1): N is known here, so segments are given as to
        ``validate``; each block gets the breaks that fall in it.
    time : dask or numpy array, (N,), optional
        The rows' time stamps in seconds, as for ``validate``: read whole (one number per row) and
        checked with ``validate``'s messages, then each block gets its stamps, as
        ``ValidationAccumulator.update(..., time=...)`` does.
    split_every : int, optional
        How many partial accumulators dask merges per step of its tree (dask's default otherwise).
    **keywords
        The other keywords of :class:`~dynval.stream.ValidationAccumulator` (``max_lag``,
        ``profile``, ``level``, ``noise_model``, ``nan_policy``, names, ...).

    Returns
    -------
    ValidationReport
        Equal to ``dynval.validate`` on the whole arrays within 1e-14 for the streamed sections.

    Examples
    --------
    >>> import dask.array as da, numpy as np, dynval, dynval.dask
    >>> rng = np.random.default_rng(0)
    >>> tau = rng.normal(size=(4000, 2)); pred = tau + 0.1 * rng.normal(size=(4000, 2))
    >>> report = dynval.dask.validate(da.from_array(tau, chunks=(500, 2)), da.from_array(pred, chunks=(500, 2)),
    ...                               n_params=3, max_lag=20)
    >>> want = dynval.validate(tau, pred, n_params=3, max_lag=20)
    >>> float(np.max(np.abs(report.autocorrelation["rho"] - want.autocorrelation["rho"]))) < 1e-14
    True
    """
    acc = accumulate(tau_meas, tau_pred, n_params=n_params, regressor=regressor, n_joints=n_joints,
                     segments=segments, time=time, split_every=split_every, **keywords)
    acc._entry = "dask"  # the tests it leaves out are dask's (dynval.coverage)
    return acc.result()


def accumulate(tau_meas: da.Array | ArrayLike, tau_pred: da.Array | ArrayLike, *, n_params: Integer,
               regressor: da.Array | ArrayLike | None = None, n_joints: Integer | None = None,
               segments: SegmentsLike = None, time: da.Array | ArrayLike | None = None,
               split_every: int | dict[int, int] | None = None, **keywords: Any) -> ValidationAccumulator:
    """The merged :class:`~dynval.stream.ValidationAccumulator` of :func:`validate` (merge it with
    accumulators of later data, or call ``.result()``).

    Parameters
    ----------
    tau_meas, tau_pred, n_params, regressor, n_joints, segments, time, split_every, **keywords
        As for :func:`validate`.

    Returns
    -------
    ValidationAccumulator

    Examples
    --------
    >>> import dask.array as da, numpy as np, dynval.dask
    >>> tau = np.sin(np.arange(300.0)); pred = tau + 0.01 * np.cos(np.arange(300.0))
    >>> acc = dynval.dask.accumulate(da.from_array(tau, chunks=100), da.from_array(pred, chunks=100),
    ...                              n_params=1, max_lag=3)
    >>> acc.n_samples
    300

    A single block needs no merge and gives the same accumulator:

    >>> dynval.dask.accumulate(da.from_array(tau, chunks=300), da.from_array(pred, chunks=300),
    ...                        n_params=1, max_lag=3).n_samples
    300
    """
    keywords = dict(keywords, n_params=n_params, n_joints=n_joints)
    ValidationAccumulator(**keywords)  # the settings are checked here, once, before any work
    meas, pred, reg = _aligned(tau_meas, tau_pred, regressor, n_joints)
    n = meas.shape[0]
    starts = parse_segments(segments, n)
    stamps = None
    if time is not None:
        stamps = _timing.stamps(time.compute() if isinstance(time, da.Array) else time, n)
        meas, pred, reg = _blocks_at_steps(stamps, meas, pred, reg)
    rows = da.arange(n, chunks=(meas.chunks[0],))
    arrays = [rows, "i", meas, "ij", pred, "ij"] + ([] if reg is None else [reg, "ijk"])
    if stamps is not None:
        arrays += [da.from_array(stamps, chunks=(meas.chunks[0],)), "i"]
    block_starts = np.cumsum((0,) + meas.chunks[0][:-1])
    blocks = da.blockwise(_block, "i", *arrays, starts=starts, block_starts=block_starts, keywords=keywords,
                          has_reg=reg is not None, timed=time is not None, dtype=object, adjust_chunks={"i": 1},
                          concatenate=True, meta=np.empty((0,), dtype=object))
    merged = da.reduction(blocks, _keep, _merge_blocks, combine=_merge_blocks, axis=0, keepdims=True,
                          concatenate=False, split_every=split_every, dtype=object,
                          meta=np.empty((0,), dtype=object))
    acc = merged.compute()[0]
    acc._chunks, acc._rows_seen = int(meas.numblocks[0]), int(n)  # the messages count blocks and rows
    return acc


def validate_many(logs: Any, *, scheduler: Any = None, **keywords: Any) -> Any:
    """Many logs of many robots, one task per log on the dask workers: :func:`dynval.fleet.validate_many`.

    This module spreads one long series over the workers, and its blocks travel from the caller;
    a fleet's logs are each read where their task runs, which is what pays on a cluster
    (README, "Fleets of robots").

    Parameters
    ----------
    logs : paths, manifests, LogSpecs or mappings, or a dask bag of them
        As for :func:`dynval.fleet.validate_many`.
    scheduler : dask Client, cluster or address, optional
        Default the current client (else this process).
    **keywords
        The other keywords of :func:`dynval.fleet.validate_many`.

    Returns
    -------
    dynval.fleet.FleetReport
    """
    from .fleet import validate_many as fleet_validate_many

    return fleet_validate_many(logs, scheduler=scheduler, **keywords)


def _aligned(tau_meas, tau_pred, regressor, n_joints):
    """The contract's type and shape checks on the arrays (without reading them), then one column
    chunk each and the regressor as (N, m, p) with the torques' time blocks."""
    meas, pred, reg0, _, _ = v.torque_pair(tau_meas, tau_pred, regressor, convert=_as_dask)
    n, m = meas.shape
    meas = meas.rechunk({1: -1})
    pred = pred.rechunk(meas.chunks)
    reg = None
    if reg0 is not None:
        p = v.regressor_shape(reg0, "tau_meas", n, m, n_joints)
        if reg0.ndim == 2:
            reg0 = reg0.rechunk({0: tuple(c * m for c in meas.chunks[0]), 1: -1}).reshape(n, m, p)
        reg = reg0.rechunk((meas.chunks[0], m, p))
    return meas, pred, reg


def _blocks_at_steps(stamps, meas, pred, reg):
    """The blocks moved so that none starts on a stamp equal to the one before: a merge classifies
    the step across a junction, and each block's own steps against the zero steps inside it only
    (a duplicated stamp at a block's start would make its next step look like a gap)."""
    ends = np.cumsum(meas.chunks[0])[:-1]
    moved = []
    for end in ends:
        while end < stamps.size and stamps[end] == stamps[end - 1]:
            end += 1
        if end < stamps.size and (not moved or end > moved[-1]):
            moved.append(int(end))
    chunks = tuple(int(c) for c in np.diff([0, *moved, stamps.size]))
    if chunks == tuple(meas.chunks[0]):
        return meas, pred, reg
    return (meas.rechunk({0: chunks}), pred.rechunk({0: chunks}),
            None if reg is None else reg.rechunk({0: chunks}))


def _as_dask(x, name):
    arr = x if isinstance(x, da.Array) else da.asarray(v.to_float_array(x, name))
    if any(math.isnan(size) for size in arr.shape):  # e.g. after boolean indexing: nan chunk sizes
        raise InvalidShape(f"{name} has unknown chunk sizes (shape {arr.shape}); call "
                           f"{name}.compute_chunk_sizes() first (dask must know the rows of each block)")
    if arr.dtype.kind not in "biuf":
        raise InvalidType(f"{name} must be an array of real numbers, got {arr.dtype}")
    return arr.astype(np.float64)


def _block(rows, meas, pred, *rest, starts, block_starts, keywords, has_reg, timed):
    """The accumulator of one time block (``rest``: its regressor, its stamps, as given), with the
    segment breaks that fall inside it."""
    reg = rest[0] if has_reg else None
    stamps = rest[-1] if timed else None
    acc = ValidationAccumulator(**keywords)
    if rows.size == 0:
        return _holder(acc)
    first = int(rows[0])
    # A segment start at the block's first row (other than row 0) is a break before the block.
    inside = starts[(starts >= max(first, 1)) & (starts < first + rows.size)] - first
    # Errors then name the block as the chunk and give the row in the whole array.
    acc._chunks, acc._rows_seen = int(np.searchsorted(block_starts, first)), first
    acc._update(meas, pred, reg, [int(k) for k in inside], stamps)
    return _holder(acc)


def _holder(acc):
    out = np.empty((1,), dtype=object)
    out[0] = acc
    return out


def _keep(block, axis, keepdims):
    return block


def _merge_blocks(parts, axis, keepdims):
    """Merge partial accumulators in time order (dask passes them in block order)."""
    parts = [p[0] for p in (parts if isinstance(parts, list) else [parts])]
    merged = parts[0].copy()
    for later in parts[1:]:
        merged.merge(later)
    return _holder(merged)
