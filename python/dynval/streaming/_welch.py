"""The residual's Welch spectrum of a stream, window by window (contract §4.1).

``validate`` takes the Welch spectrum of each segment (Hann windows of nperseg rows, 50 % overlap,
the mean removed from each window) and averages the segments' spectra weighted by their window
counts: that is the sum of every window's periodogram over the number of windows, and a sum of
windows is mergeable. nperseg is a power of two near the longest segment / 8 (16..1024), which a
stream knows only at its end, so :class:`WelchSums` keeps the sums for each size it may still be:
those at least the size of the longest segment so far (the longest only grows), so from 8,192 rows
of one segment on, 1024 alone.

A window never crosses a segment break; the rows of the current segment after the earliest next
window start (fewer than 1024 plus a chunk) wait for the rows that complete it. Two accumulators
merge exactly when a break separates them (the later one's windows then start on its own first
row, as ``validate``'s do); joined without a break, the windows across the junction were never
formed and the later one's are off the grid: the spectrum is then left out, and said so.

Sums are held in units of 4^k per joint, k the exponent of the largest |e| seen so far (as the
stream's other sums, contract §4.1 scale): a larger one multiplies the sums by a power of two.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import scipy.signal

OFF_GRID = ("accumulators merged without a break_segment between them: the Welch windows across the junction "
            "are not kept")
"""Why a merged stream has no spectrum (its report's ``not_tested``; ``dynval.coverage``)."""

_NO_ROWS = -1100
SIZES = tuple(2**i for i in range(4, 11))
"""The window lengths ``validate`` may choose (``_stats._default_nperseg``): 16..1024."""

class WelchSums:
    """Sums of the window periodograms of a residual stream for every size of :data:`SIZES`."""

    def __init__(self, m: int) -> None:
        self.m = m
        # below any frexp exponent (−1073): the first rows set the units, however small
        self.exps = np.full(m, _NO_ROWS, dtype=np.int64)
        self.sums = {size: np.zeros((size // 2 + 1, m)) for size in SIZES}
        self.windows = dict.fromkeys(SIZES, 0)
        self.rows = np.zeros((0, m))  # the current segment's rows from ``offset`` on, raw
        self.offset = 0
        self.next = dict.fromkeys(SIZES, 0)  # each size's next window start, in the current segment's rows
        self.any_rows = False
        self.longest = 0  # the longest segment so far, the current one included
        self.start_break = False  # the first rows start a segment of their own (a break before them)
        self.off_grid: str | None = None  # why the sums are not validate's, once they are not

    def copy(self) -> WelchSums:
        return copy.deepcopy(self)

    def add(self, e: np.ndarray) -> None:
        """Rows (c, m) that continue the current segment."""
        if e.shape[0] == 0:
            return
        self.any_rows = True
        self._rescale(_exponents(e))
        self.rows = np.concatenate((self.rows, e)) if self.rows.size else e.copy()
        end = self.offset + self.rows.shape[0]
        self._prune(end)
        for size in self.sizes:
            step = size - size // 2
            start = self.next[size]
            if end - start < size:
                continue
            k = 1 + (end - start - size) // step
            a = start - self.offset
            piece = np.ldexp(self.rows[a:a + size + (k - 1) * step], -self.exps[None])
            _, pxx = scipy.signal.welch(piece, fs=1.0, window="hann", nperseg=size, noverlap=size // 2,
                                        detrend="constant", axis=0)
            self.sums[size] += pxx * k
            self.windows[size] += k
            self.next[size] = start + k * step
        keep = min(self.next.values(), default=end) - self.offset
        if keep > 0:
            self.rows = self.rows[keep:]
            self.offset += keep

    @property
    def sizes(self) -> list[int]:
        """The window lengths still kept."""
        return list(self.sums)

    def _prune(self, length: int) -> None:
        """Drop the sizes a longest segment of at least ``length`` rows rules out (``_default_nperseg``)."""
        self.longest = max(self.longest, length)
        smallest = min(SIZES[-1], max(SIZES[0], 2 ** int(math.floor(math.log2(max(self.longest // 8, 16))))))
        for size in [size for size in self.sums if size < smallest]:
            del self.sums[size], self.windows[size], self.next[size]

    def end_segment(self) -> None:
        """A break: no window joins the rows before and after it."""
        if not self.any_rows:
            self.start_break = True
        self.rows = np.zeros((0, self.m))
        self.offset = 0
        self.next = dict.fromkeys(self.sums, 0)

    def merge(self, later: WelchSums) -> None:
        """Add ``later``'s windows (its rows come after these)."""
        if not later.any_rows:
            if later.start_break:
                self.end_segment()
            return
        if not self.any_rows:
            start_break = self.start_break
            self.__dict__.update(later.copy().__dict__)
            self.start_break = self.start_break or start_break
            return
        joined = self.offset + self.rows.shape[0] > 0 and not later.start_break
        if joined:
            self.off_grid = OFF_GRID
        self.off_grid = self.off_grid or later.off_grid
        b = later.copy()
        top = np.maximum(self.exps, b.exps)
        self._rescale(top)
        b._rescale(top)
        sizes = [size for size in self.sizes if size in b.sums]  # each dropped those the data cannot choose
        self.sums = {size: self.sums[size] + b.sums[size] for size in sizes}
        self.windows = {size: self.windows[size] + b.windows[size] for size in sizes}
        self.rows, self.offset, self.next = b.rows, b.offset, {size: b.next[size] for size in sizes}
        self._prune(b.longest)

    def power(self, nperseg: int, exps: np.ndarray) -> tuple[np.ndarray | None, int]:
        """The mean window periodogram of size ``nperseg`` (F, m) at rate 1, in units 4^exps (the
        stream's final exponents), and the window count; (None, 0) without a window."""
        windows = self.windows.get(nperseg, 0)
        if not windows:
            return None, 0
        return np.ldexp(self.sums[nperseg] / windows, 2 * (self.exps - exps)[None]), windows

    def _rescale(self, exps: np.ndarray) -> None:
        """Hold the sums in units 4^max(exps, the current ones)."""
        top = np.maximum(self.exps, exps)
        shift = top - self.exps
        if shift.any():
            for size in self.sums:
                self.sums[size] = np.ldexp(self.sums[size], -2 * shift[None])
            self.exps = top


def _exponents(e: np.ndarray) -> np.ndarray:
    largest = np.max(np.abs(e), axis=0)
    return np.where(largest > 0, np.frexp(largest)[1], 0).astype(np.int64)
