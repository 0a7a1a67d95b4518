"""Sums, means and the norm-based metrics: residuals, sse, rmse, max_abs_error.

The reference reduces *rows*: a 2-D array whose rows are the series to reduce. Per joint that is
the joint-major copy ``x.T`` ``(m, N)``, made contiguous once per array; pooled it is the view
``x.reshape(1, -1)`` of the C-ordered ``(N, m)`` data, which costs nothing. numpy sums a
contiguous row pairwise (error O(log n·ε) of the sum of absolute values) at the speed of reading
it, whereas its column sums of an ``(N, m)`` array are neither pairwise nor fast. Centred sums use
the corrected two-pass algorithm, so the reference stays accurate on data with a large offset
(NIST StRD NumAcc4) at numpy speed.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_convention, check_multioutput
from ._common import finite_pair

# Values compared before a full min/max scan: data that vary show it within the first few.
_CONSTANT_PROBE = 64
# Rows transposed at a time: a block of this many rows of (N, m) data stays in cache.
_TRANSPOSE_BLOCK = 8192


def joint_major(x: np.ndarray, minus: np.ndarray | None = None) -> np.ndarray:
    """The ``(m, N)`` rows of an ``(N, m)`` array ``x`` (or of ``x − minus``), one contiguous row per joint.

    The copy goes block by block: a whole-array strided copy would read the data from memory
    once per joint. Without ``minus``, data that are already joint-major are returned as they are.
    """
    if minus is None and x.T.flags.c_contiguous:
        return x.T
    out = np.empty(x.shape[::-1])
    for i in range(0, x.shape[0], _TRANSPOSE_BLOCK):
        block = slice(i, i + _TRANSPOSE_BLOCK)
        if minus is None:
            out[:, block] = x[block].T
        else:
            np.subtract(x[block].T, minus[block].T, out=out[:, block])
    return out


def pooled(x: np.ndarray) -> np.ndarray:
    """All N·m values in one row, in the lesson's flattening order (row-major)."""
    return x.reshape(1, -1)


def rowsum(rows: np.ndarray) -> np.ndarray:
    """Pairwise sum of each row.

    Exact enough where there is no cancellation to protect (sums of squares); where there is
    (means, centred sums), :func:`moments` and :func:`centred` add a second, corrective pass.
    """
    return np.add.reduce(rows, axis=1)


def sumsq(rows: np.ndarray, overwrite: bool = False) -> np.ndarray:
    """Σx² of each row; ``overwrite=True`` squares in place (for a temporary the caller owns)."""
    return rowsum(np.square(rows, out=rows if overwrite else None))


def is_constant(rows: np.ndarray) -> np.ndarray:
    """Per row: min equals max, decided on the data (contract §3.2).

    A row whose first values already differ is not constant, so only rows that start flat
    are scanned in full.
    """
    head = rows[:, :_CONSTANT_PROBE]
    constant = np.all(head == head[:, :1], axis=1)
    for i in np.flatnonzero(constant):
        constant[i] = rows[i].min() == rows[i].max()
    return constant


def moments(rows: np.ndarray, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row: the mean, Σ(x − x̄)² and constancy, from two passes over the data.

    ``out``, an array shaped like ``rows`` that the caller no longer needs (``rows`` itself
    included), receives the deviations instead of a new temporary.

    With d = x − fl(x̄), the corrected two-pass algorithm gives the mean as fl(x̄) + Σd/n and the
    centred sum of squares as Σd² − (Σd)²/n. ``x − fl(x̄)`` is exact for data with an offset, but
    ``fl(x̄)`` can be off by half an ulp of the offset (1e-9 at 1e7); Σd measures that error to
    full precision and the correction removes it. A constant row gets exactly 0: its rounded
    mean may differ from its value by an ulp, so constancy is decided on min == max.
    """
    n = rows.shape[1]
    constant = is_constant(rows)
    first = rowsum(rows) / n
    d = np.subtract(rows, first[:, None], out=out)
    shift = rowsum(d)
    squares = sumsq(d, overwrite=True)
    # Σd² ≥ (Σd)²/n holds exactly; the clamp only absorbs rounding of near-equal terms.
    ss = np.maximum(squares - shift * shift / n, 0.0)
    ss[constant] = 0.0
    return first + shift / n, ss, constant


def centred(rows: np.ndarray) -> np.ndarray:
    """x − x̄ per row, with the rounding of the mean itself removed.

    Lag products of the deviations do not cancel an error in the mean, so the second pass
    subtracts the mean of the first deviations, which is small and therefore representable to
    full precision (the corrected two-pass algorithm, as in :func:`moments`).
    """
    n = rows.shape[1]
    d = rows - (rowsum(rows) / n)[:, None]
    d -= (rowsum(d) / n)[:, None]
    return d


def residuals(meas, pred) -> np.ndarray:
    """``e = tau_meas - tau_pred`` as ``(N, m)``."""
    meas, pred = finite_pair(meas, pred)
    return meas - pred


def sse(meas, pred, multioutput):
    """Sum of squared errors: pooled float or per-joint ``(m,)``."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values"), "sse")
    if multioutput == "pooled":
        return float(sumsq(pooled(meas - pred), overwrite=True)[0])
    return sumsq(joint_major(meas, minus=pred), overwrite=True)


def max_abs_error(meas, pred, multioutput):
    """Largest absolute residual: pooled float or per-joint ``(m,)``."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values"), "max_abs_error")
    # max|e| from the extremes: two reads, no temporary |e|.
    if multioutput == "pooled":
        e = meas - pred
        return float(max(abs(e.min()), abs(e.max())))
    rows = joint_major(meas, minus=pred)
    return np.maximum(np.abs(rows.min(axis=1)), np.abs(rows.max(axis=1)))


def rmse(meas, pred, multioutput, convention=""):
    """Root mean squared error; ``convention`` applies to ``pooled`` only (``""`` = per_element)."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values", "uniform_average"), "rmse")
    convention = check_convention(convention, multioutput)
    n, m = meas.shape
    if multioutput == "pooled":
        total = sumsq(pooled(meas - pred), overwrite=True)[0]
        return float(math.sqrt(total / n if convention == "per_sample" else total / (n * m)))
    per_joint = np.sqrt(sumsq(joint_major(meas, minus=pred), overwrite=True) / n)
    if multioutput == "raw_values":
        return per_joint
    return float(np.mean(per_joint))
