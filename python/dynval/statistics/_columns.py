"""A regressor's columns judged one against the others, in any unit: their norms without overflow
or underflow (exact power-of-two scaling), and which of them are zero (roundoff of a structurally
zero column). The one place a column's size is judged, shared by the report and the estimation refit."""

from __future__ import annotations

import numpy as np

__all__ = ["ROW_BLOCK", "ROUNDOFF_COLUMN", "largest_abs", "exponents", "pow2_exponents", "scale_pow2",
           "zero_columns", "column_norms", "unit_norm_columns", "runs"]

# Rows per block where a pass over the stacked regressor would otherwise copy it whole.
ROW_BLOCK = 1 << 16


def largest_abs(x: np.ndarray) -> np.ndarray:
    """Per column, its largest |x|, without a copy of x."""
    return np.asarray(np.maximum(np.max(x, axis=0), -np.min(x, axis=0)))


def exponents(largest: np.ndarray) -> np.ndarray:
    """The exponent k (np.frexp) of each largest |x|, 0 for a zero column."""
    return np.where(largest > 0, np.frexp(largest)[1], 0).astype(np.int64)


def pow2_exponents(x: np.ndarray) -> np.ndarray:
    """Per column, the exponent k of its largest |x| (0 for a zero column)."""
    return exponents(largest_abs(x))


def scale_pow2(x: np.ndarray, k: np.ndarray, cols: np.ndarray | None = None) -> np.ndarray:
    """x·2^-k per column, exactly (as np.ldexp); of x[:, cols] when ``cols`` are given, read run by
    run of consecutive columns (:func:`runs`) rather than gathered into a copy first, and laid out
    column-major as numpy lays out such a gather of a joint's columns (reg3[:, j, cols]), so that
    every product taken of it later is summed in the same order."""
    if cols is not None:
        out = np.empty((x.shape[0], cols.size), order="F")
        for lo, hi, a, b in runs(cols):
            out[:, lo:hi] = scale_pow2(x[:, a:b], k[lo:hi])
        return out
    if np.all(np.abs(k) < 1000):
        # 2^-k is a normal number: multiplying by it is the same exact scaling, and much faster
        return np.asarray(x * np.ldexp(1.0, -k))
    return np.asarray(np.ldexp(x, -k))


def runs(cols: np.ndarray) -> list[tuple[int, int, int, int]]:
    """The runs of consecutive indices in ``cols`` (increasing), as (lo, hi, a, b): cols[lo:hi] is
    a..b-1. A regressor's live columns come in a few runs per joint, and a slice of each is read
    in place where indexing by all of them would gather a copy."""
    cuts = (np.flatnonzero(np.diff(cols) != 1) + 1).tolist()
    return [(lo, hi, int(cols[lo]), int(cols[hi - 1]) + 1) for lo, hi in zip([0] + cuts, cuts + [cols.size]) if hi > lo]


ROUNDOFF_COLUMN = 1e-13
"""A column is zero (conventions §5.6, contract §4) when its norm is 0 or at most 1e-13 of the median
norm of the nonzero columns: roundoff of a structurally zero column (cos(π/2) = 6e-17 in a kinematic
chain; KUKA LWR4+: 1.3e-16 and 3.9e-16 of the median in runs 3 and 1). The median, not the largest:
a column in another unit (×1e9) then moves no other column's decision, and columns scaled each by
any factor in [1e-6, 1e6] keep theirs while their norms are within 10 of each other."""


def zero_columns(norms: np.ndarray, tol: float = ROUNDOFF_COLUMN) -> np.ndarray:
    """Which columns are zero (:data:`ROUNDOFF_COLUMN`): norm 0, or at most ``tol`` of the median
    norm of the nonzero columns. The only place a column's size is judged against the others'."""
    norms = np.asarray(norms, dtype=float)
    nonzero = norms[norms > 0]
    if nonzero.size == 0:
        return np.ones(norms.shape, dtype=bool)
    return norms <= tol * float(np.median(nonzero))


def column_norms(x: np.ndarray) -> np.ndarray:
    """Column norms, each column scaled by the power of two of its largest |x| (exact), so that the
    squares of 1e-170 or 1e150 data neither underflow nor overflow."""
    k = pow2_exponents(x)
    return np.asarray(np.ldexp(np.sqrt(sum(np.linalg.norm(scale_pow2(x[i:i + ROW_BLOCK], k), axis=0) ** 2
                                           for i in range(0, x.shape[0], ROW_BLOCK))), k))


def unit_norm_columns(x: np.ndarray) -> np.ndarray:
    """The columns of x (rows × k) divided by their norms, zero columns (:func:`zero_columns`) left
    out: what a least squares whose coefficients are not reported (the model's own columns as
    nuisance terms) is solved on, so that its rank decision does not depend on the columns' units."""
    norms = column_norms(x)
    keep = ~zero_columns(norms)
    return np.asarray(x[:, keep] / norms[keep])
