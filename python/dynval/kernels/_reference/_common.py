"""Input handling shared by the reference kernels: 2-D float64 views, finiteness, starts."""

from __future__ import annotations

import numpy as np

from ...checks._segments import longest_segment
from ...checks._validation import check_finite, is_integer, parameter_error


def as_2d(a) -> np.ndarray:
    """The kernels take 2-D float64 arrays; a 1-D array is one joint."""
    a = np.asarray(a, dtype=np.float64)
    return a.reshape(-1, 1) if a.ndim == 1 else a


def finite_pair(meas, pred):
    """Convert and check ``tau_meas`` then ``tau_pred`` for finiteness (contract order)."""
    meas, pred = as_2d(meas), as_2d(pred)
    check_finite(meas, "tau_meas")
    check_finite(pred, "tau_pred")
    return meas, pred


def finite_residual(e) -> np.ndarray:
    e = as_2d(e)
    check_finite(e, "e")
    return e


def check_starts(starts, n: int) -> np.ndarray:
    """Kernels validate the facade's starts again (strictly increasing, first 0, below N)."""
    arr = np.asarray(starts)
    values = arr.tolist() if arr.ndim == 1 else None
    ok = (
        values is not None
        and len(values) > 0
        and all(is_integer(v) for v in arr)
        and values[0] == 0
        and values[-1] < n
        and all(b > a for a, b in zip(values, values[1:]))
    )
    if not ok:
        raise parameter_error(
            "segments",
            f"positive lengths summing to N={n}, or increasing starts beginning at 0 and below N={n}",
            starts,
        )
    return arr.astype(np.int64)


def segment_limit(starts: np.ndarray, n: int) -> int:
    return longest_segment(starts, n)
