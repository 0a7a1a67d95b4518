"""The checked call: one mechanism for the parameter step of every entry point.

The metric functions (``_api``), ``validate`` (``_report``), the accumulator's chunks
(``stream``) and the corpus drivers (``golden._ops``) check their data's type, shape and size
first (``_validation``), then hand the data to a :class:`CheckedCall`, which holds them for what
comes after, in the contract's order (§2.1):

* the **deferred** parameter checks: a parameter is checked where its place in the order says,
  but when it fails, the data are searched first, so that a non-finite value still wins over a
  bad parameter (finiteness comes before parameters; the kernels find non-finite values in
  their own pass, so the data are read once when every parameter is good);
* ``nan_policy``, and the omission of the rows holding a non-finite value (``"omit"``), after
  which nothing is searched (the data are finite) and sizes are checked again;
* the backend: its name and its kernels.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

import numpy as np

from ._errors import InputError, NonFiniteInput
from ._segments import longest_segment, omit_nonfinite, parse_segments
from ._typing import BackendName, FloatArray, IntArray, Kernels
from ._validation import check_min_samples, check_nan_policy, first_nonfinite, nonfinite_error

__all__ = ["CheckedCall"]

_T = TypeVar("_T")

#: ``(name, 2-D array, n_columns)``: ``n_columns`` is p for a regressor viewed ``(N, m*p)``.
Array = tuple[str, FloatArray, "int | None"]


class CheckedCall:
    """The data of one call, checked for type, shape and size, and the steps after.

    Parameters
    ----------
    function : str
        Public function name (for TooFewSamples after omission).
    arrays : list of (name, 2-D array, n_columns)
        The data in argument order.
    scan : callable, optional
        The search for the first non-finite value of an array (``(row, col, value)`` or None):
        :func:`dynval.checks._validation.first_nonfinite`, or a backend's own.
    first_row : int, optional
        The data's first row in the stream they are a chunk of: NonFiniteInput then also names
        the row in the stream.
    """

    def __init__(self, function: str, arrays: list[Array],
                 scan: Callable[[FloatArray], tuple[int, int, float] | None] = first_nonfinite,
                 first_row: int | None = None) -> None:
        self.function = function
        self.arrays = arrays
        self._scan = scan
        self._first_row = first_row
        self.omitting = False  # rows with a non-finite value are deleted (the data are then finite)
        self.omitted = 0
        self.kept_rows: IntArray | None = None  # the rows kept by the omission, when asked for
        self.starts: IntArray = np.zeros(1, dtype=np.int64)
        self.backend: BackendName = "python"
        self._kernel: Kernels | None = None

    # ----------------------------------------------------------------------- the data

    @property
    def data(self) -> list[FloatArray]:
        """The arrays, after omission."""
        return [a for _, a, _ in self.arrays]

    @property
    def n(self) -> int:
        return int(self.arrays[0][1].shape[0])

    @property
    def pair(self) -> tuple[FloatArray, FloatArray]:
        """``(tau_meas, tau_pred)`` of a two-signal call, after omission."""
        return self.arrays[0][1], self.arrays[1][1]

    @property
    def kernel(self) -> Kernels:
        """The backend's kernels (:meth:`resolve_backend` first)."""
        assert self._kernel is not None, "resolve_backend() comes first"
        return self._kernel

    @property
    def limit(self) -> int:
        """Longest segment: the bound on lags."""
        return longest_segment(self.starts, self.n)

    # ----------------------------------------------------------------------- finiteness

    def first_nonfinite(self) -> NonFiniteInput | None:
        """The error of the first non-finite value, in argument order, then row-major."""
        for name, a, n_columns in self.arrays:
            found = self._scan(a)
            if found is not None:
                error = nonfinite_error(name, *found, n_columns=n_columns)
                if self._first_row is None:
                    return error
                return type(error)(f"{error} (row {self._first_row + found[0]} of the stream)")
        return None

    def require_finite(self) -> None:
        """The finiteness step now (where no kernel pass follows to find a non-finite value)."""
        error = self.first_nonfinite()
        if error is not None:
            raise error

    # ----------------------------------------------------------------------- parameters

    @contextmanager
    def deferred(self) -> Iterator[None]:
        """Parameter checks: an InputError raised inside gives way to a non-finite value in the
        data (unless rows are omitted: the data are finite then)."""
        try:
            yield
        except InputError:
            error = None if self.omitting else self.first_nonfinite()
            if error is not None:
                raise error from None
            raise

    def check(self, check: Callable[..., _T], *args: Any) -> _T:
        """Run one parameter check, deferred (:meth:`deferred`)."""
        with self.deferred():
            return check(*args)

    def nan_policy(self, value: object) -> str:
        """Check ``nan_policy`` (deferred); after "omit" nothing is deferred (:meth:`omit` follows)."""
        policy = self.check(check_nan_policy, value)
        self.omitting = policy == "omit"
        return policy

    def resolve_backend(self, value: object, resolve: Callable[[object], tuple[BackendName, Kernels]]) -> Kernels:
        """Check ``backend`` (deferred) with ``resolve`` (:func:`dynval.kernels._backend.resolve`,
        given by the caller: the kernels are a layer above the checks) and keep its name and kernels."""
        self.backend, self._kernel = self.check(resolve, value)
        return self._kernel

    def segments(self, value: object) -> IntArray:
        """Check ``segments`` (deferred) against the rows as given."""
        self.starts = self.check(parse_segments, value, self.n)
        return self.starts

    def omit(self, starts: IntArray | None = None, *, rows: bool = False) -> None:
        """``nan_policy="omit"``: delete the rows holding a non-finite value in any array, with a
        segment break where rows were deleted (``starts``: the caller's segments, else those
        checked before), then check the size again. ``rows``: keep the numbers of the rows kept
        (``kept_rows``, None when none was deleted)."""
        self.omitting = True
        if starts is not None:
            self.starts = starts
        data = self.data
        if rows:  # the row numbers ride along
            data.append(np.arange(self.n, dtype=np.float64)[:, None])
        kept, self.starts, self.omitted = omit_nonfinite(data, self.starts)
        if rows:
            numbers = kept.pop()
            self.kept_rows = numbers[:, 0].astype(np.int64) if self.omitted else None
        self.arrays = [(name, a, n_columns) for (name, _, n_columns), a in zip(self.arrays, kept)]
        check_min_samples(self.function, self.n)
