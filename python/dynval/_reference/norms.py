"""Sums, means and the norm-based metrics: residuals, sse, rmse, max_abs_error.

Column sums are pairwise over contiguous columns (numpy's ``sum(axis=0)`` over a C-ordered
``(N, m)`` array is not pairwise: ~1e-14 relative error at N = 2e6 with offsets), and centred sums
use the corrected two-pass mean, so the reference stays accurate on data with a large offset
(NIST StRD NumAcc4) at numpy speed.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_convention, check_multioutput
from ._common import finite_pair


def colsum(x: np.ndarray) -> np.ndarray:
    """Pairwise sum of each column (error O(log N·ε) of the sum of absolute values).

    Exact enough where there is no cancellation to protect (sums of squares); where there is
    (means), :func:`colmean` and :func:`centred` add a second, corrective pass.
    """
    return np.add.reduce(np.ascontiguousarray(np.asarray(x).T), axis=1)


def colmean(x: np.ndarray) -> np.ndarray:
    """Mean of each column, refined by the mean of the first deviations."""
    first = colsum(x) / x.shape[0]
    return first + colsum(x - first) / x.shape[0]


def centred(x: np.ndarray) -> np.ndarray:
    """x − x̄ per column, with the rounding of the mean itself removed.

    ``x − fl(x̄)`` is exact for data with an offset, but ``fl(x̄)`` can be off by half an ulp of
    the offset (1e-9 at 1e7), which lag products do not cancel. A second pass subtracts the
    mean of the first deviations, which is small and therefore representable to full precision
    (the corrected two-pass algorithm).
    """
    d = x - colsum(x) / x.shape[0]
    return d - colsum(d) / x.shape[0]


def is_constant(x: np.ndarray) -> np.ndarray:
    """Per column: min equals max, decided on the data (contract §3.2)."""
    return x.min(axis=0) == x.max(axis=0)


def centred_and_ss(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`centred` deviations and their per-column Σ(x − x̄)², exactly 0 for a constant column.

    The mean of a constant column may differ from its value by an ulp after division, so
    constancy is decided on min == max rather than on the rounded sum.
    """
    d = centred(x)
    ss = colsum(d * d)
    ss[is_constant(x)] = 0.0
    return d, ss


def centred_ss(x: np.ndarray) -> np.ndarray:
    """Per column Σ(x − x̄)², exactly 0 for a constant column."""
    return centred_and_ss(x)[1]


def pooled(x: np.ndarray) -> np.ndarray:
    """All N·m values as one column: the lesson's flattened view with one global mean."""
    return x.reshape(-1, 1)


def residuals(meas, pred) -> np.ndarray:
    """``e = tau_meas - tau_pred`` as ``(N, m)``."""
    meas, pred = finite_pair(meas, pred)
    return meas - pred


def sse(meas, pred, multioutput):
    """Sum of squared errors: pooled float or per-joint ``(m,)``."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values"), "sse")
    e = meas - pred
    if multioutput == "pooled":
        return float(colsum(pooled(e * e))[0])
    return colsum(e * e)


def max_abs_error(meas, pred, multioutput):
    """Largest absolute residual: pooled float or per-joint ``(m,)``."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values"), "max_abs_error")
    a = np.abs(meas - pred)
    if multioutput == "pooled":
        return float(a.max())
    return a.max(axis=0)


def rmse(meas, pred, multioutput, convention=""):
    """Root mean squared error; ``convention`` applies to ``pooled`` only (``""`` = per_element)."""
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, ("pooled", "raw_values", "uniform_average"), "rmse")
    convention = check_convention(convention, multioutput)
    e = meas - pred
    n, m = e.shape
    if multioutput == "pooled":
        total = colsum(pooled(e * e))[0]
        return float(math.sqrt(total / n if convention == "per_sample" else total / (n * m)))
    per_joint = np.sqrt(colsum(e * e) / n)
    if multioutput == "raw_values":
        return per_joint
    return float(np.mean(per_joint))
