"""Segments (independent records concatenated along the sample axis) and ``nan_policy="omit"``.

Segments are carried internally as an int64 array of *starts* whose first element is 0
(contract §1.1). Lagged products never join two segments; means stay overall.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ._validation import in_range, is_integer, parameter_error


def parse_segments(segments, n: int) -> np.ndarray:
    """Turn ``segments`` (None, lengths or starts) into int64 starts for N = ``n`` samples.

    Parameters
    ----------
    segments : None or sequence of int
        ``None`` (one segment); lengths, positive and summing to N (``[500, 300]``); or
        starts, strictly increasing, first element 0, all below N (``[0, 500]``).
    n : int
        Number of samples.

    Returns
    -------
    numpy.ndarray
        int64 starts, first element 0.

    Raises
    ------
    InvalidParameter
        For anything else. A length is never 0, so the two forms cannot be confused.

    Examples
    --------
    >>> parse_segments([500, 300], 800).tolist()
    [0, 500]
    >>> parse_segments([0, 500], 800).tolist()
    [0, 500]
    """
    if segments is None:
        return np.zeros(1, dtype=np.int64)
    error = parameter_error(
        "segments",
        f"positive lengths summing to N={n}, or increasing starts beginning at 0 and below N={n}",
        segments,
    )
    if isinstance(segments, np.ndarray):
        if segments.ndim != 1:
            raise error
    elif not isinstance(segments, Sequence) or isinstance(segments, (str, bytes)):
        raise error
    # Either form has at most N entries: refuse a longer one (range(10**12)) before it is
    # materialised. len() itself overflows past sys.maxsize (range(10**20)).
    try:
        too_long = len(segments) > n
    except OverflowError:
        too_long = True
    if too_long:
        raise error
    items = list(segments)
    if not items or not all(is_integer(v) for v in items):
        raise error
    values = [int(v) for v in items]
    if values[0] == 0:
        if any(b <= a for a, b in zip(values, values[1:])) or values[-1] >= n:
            raise error
        return np.asarray(values, dtype=np.int64)
    if any(v <= 0 for v in values) or sum(values) != n:
        raise error
    return np.concatenate(([0], np.cumsum(values[:-1]))).astype(np.int64)


def segment_lengths(starts: np.ndarray, n: int) -> np.ndarray:
    """Lengths of the segments described by ``starts`` over ``n`` samples."""
    starts = np.asarray(starts, dtype=np.int64)
    return np.diff(np.append(starts, n))


def longest_segment(starts: np.ndarray, n: int) -> int:
    """Length of the longest segment (the bound on ``max_lag``)."""
    return int(segment_lengths(starts, n).max()) if n > 0 else 0


def omit_nonfinite(arrays: Sequence[np.ndarray], starts: np.ndarray):
    """Delete the rows holding a non-finite value in any of ``arrays`` and insert breaks.

    Parameters
    ----------
    arrays : sequence of 2-D float64 arrays
        Arrays sharing the sample axis (a regressor is passed viewed as ``(N, m*p)``).
    starts : numpy.ndarray
        Segment starts of the original rows.

    Returns
    -------
    kept : list of numpy.ndarray
        The arrays without the deleted rows.
    new_starts : numpy.ndarray
        int64 starts: the caller's segments, refined wherever rows were deleted, so lags never
        join samples that were not adjacent.
    omitted : int
        Number of deleted rows.

    Examples
    --------
    >>> a = np.array([[1.0], [np.nan], [3.0], [4.0]])
    >>> kept, starts, omitted = omit_nonfinite([a], np.array([0]))
    >>> kept[0].ravel().tolist(), starts.tolist(), omitted
    ([1.0, 3.0, 4.0], [0, 1], 1)
    """
    n = arrays[0].shape[0]
    keep = np.ones(n, dtype=bool)
    for a in arrays:
        keep &= in_range(a).all(axis=1)  # non-finite or out of range (contract §1.2)
    omitted = int(n - keep.sum())
    if omitted == 0:
        return [a for a in arrays], np.asarray(starts, dtype=np.int64), 0
    is_start = np.zeros(n, dtype=bool)
    is_start[np.asarray(starts, dtype=np.int64)] = True
    # A kept row opens a segment if it opened one before, or if the row before it was deleted.
    previous_deleted = np.concatenate(([True], ~keep[:-1]))
    opens = (is_start | previous_deleted)[keep]
    new_starts = np.flatnonzero(opens).astype(np.int64)
    if new_starts.size == 0:
        new_starts = np.zeros(1, dtype=np.int64)
    return [np.ascontiguousarray(a[keep]) for a in arrays], new_starts, omitted
