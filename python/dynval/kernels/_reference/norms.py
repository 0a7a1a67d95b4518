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

from ...checks._validation import check_convention, check_multioutput
from ._common import finite_pair

# Below this, a sum of squares may hold terms that left float64's normal range (|x| < 2^-511
# squares to a subnormal or to 0); at or above it, the terms lost cost less than 2^-270 of the
# sum. Rows whose sum falls below it are summed again scaled by a power of two (contract §1.3).
TINY_SUM = 2.0**-800

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


def scale_exponents(rows: np.ndarray, sums: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
    """Per row: k with max|row|·2^-k in [0.5, 1) where the row's sum of squares is below
    TINY_SUM (and the row is ``live`` and not all zero), else 0. Scaling by 2^-k is exact."""
    k = np.zeros(rows.shape[0], dtype=np.int64)
    low = sums < TINY_SUM
    if live is not None:
        low &= live
    for i in np.flatnonzero(low):
        largest = float(np.max(np.abs(rows[i])))
        if largest > 0.0:
            k[i] = np.frexp(largest)[1]
    return k


def sumsq_scaled(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, k) per row with Σx² = s·4^k: rows whose squares leave the normal range are summed
    scaled by 2^-k, so s keeps full precision however small the data are."""
    s = sumsq(rows)
    k = scale_exponents(rows, s)
    for i in np.flatnonzero(k):
        s[i] = sumsq(np.ldexp(rows[i : i + 1], -k[i]), overwrite=True)[0]
    return s, k


def scaled_ratio(a, ka, b, kb):
    """(a·4^ka)/(b·4^kb) without forming either value (which may underflow); IEEE for b = 0."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # IEEE ±inf and nan are the result
        return np.ldexp(a / b, 2 * (np.asarray(ka) - np.asarray(kb)))


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
    """:func:`moments_scaled` with the centred sum of squares in the data's units (it may
    underflow: the variance of data near 1e-170 is below float64's range)."""
    mean, ss, constant, k = moments_scaled(rows, out)
    return mean, np.ldexp(ss, 2 * k), constant


def moments_scaled(rows: np.ndarray, out: np.ndarray | None = None):
    """Per row: the mean, Σ(x − x̄)²·4^-k, constancy and k, from two passes over the data.

    k is 0 unless the centred sum of squares left the normal range (data near 1e-160); the row
    is then summed again scaled by 2^-k (exact), see :func:`scale_exponents`.

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
    # A tiny row is summed again from the data, which must therefore survive as scratch.
    if out is not None and np.may_share_memory(out, rows):
        out = None
    d = np.subtract(rows, first[:, None], out=out)
    shift = rowsum(d)
    squares = sumsq(d, overwrite=True)
    # Σd² ≥ (Σd)²/n holds exactly; the clamp only absorbs rounding of near-equal terms.
    ss = np.maximum(squares - shift * shift / n, 0.0)
    ss[constant] = 0.0
    k = scale_exponents(rows, ss, ~constant)
    for i in np.flatnonzero(k):
        _, ss[i : i + 1], _, _ = moments_scaled(np.ldexp(rows[i : i + 1], -k[i]))
    return first + shift / n, ss, constant, k


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
        s, k = sumsq_scaled(pooled(meas - pred))
        return float(np.ldexp(s, 2 * k)[0])
    s, k = sumsq_scaled(joint_major(meas, minus=pred))
    return np.ldexp(s, 2 * k)


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
    # The root is taken in scaled units and scaled back: it does not underflow with the squares.
    if multioutput == "pooled":
        s, k = sumsq_scaled(pooled(meas - pred))
        root = math.sqrt(s[0] / n if convention == "per_sample" else s[0] / (n * m))
        return float(np.ldexp(root, k[0]))
    s, k = sumsq_scaled(joint_major(meas, minus=pred))
    per_joint = np.ldexp(np.sqrt(s / n), k)
    if multioutput == "raw_values":
        return per_joint
    return float(np.mean(per_joint))
