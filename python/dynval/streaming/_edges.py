"""The residual's rows at the inner segment junctions of a stream, for the bias test (contract §4.1).

The bias test's prewhitened sums lose a few products at each segment's first and last rows
(``dynval.statistics._stats.long_run_variance_from_sums``). The state keeps the stream's own first
and last rows; :class:`SegmentEdges` keeps, for every other segment start and end, the sums those
products need: S_j = Σ y_{s+j}y_s, H_j = Σ y_{s+j} over the starts and E_j = Σ y_{E−1}y_{E−1−j},
T_j = Σ y_{E−1−j} over the ends, j < K (K the lags held), of segments longer than K, with y the
residual less a reference row (the accumulator's first) in units 2^k per joint. They centre on the
final mean at the end: Σ(y_a − δ)(y_b − δ) = Σ y_a y_b − δ Σ(y_a + y_b) + n δ².

A segment's start is recorded once it is not the stream's first and holds more than K rows; its end
once rows follow it in a later segment. Merges join the two sides' current segments (the later
side's first rows are kept whole while they are K or fewer), or record the junction's two edges
when a break separates them. Segments of K rows or fewer are not recorded: their products are left
out, O(K/N) of the sums.
"""

from __future__ import annotations

import copy

import numpy as np

_NO_ROWS = -1100  # below any frexp exponent: the first rows set the units


class SegmentEdges:
    """Sums over the inner segment starts and ends of a residual stream (module docstring)."""

    def __init__(self, m: int, lags: int) -> None:
        self.m, self.k = m, lags
        self.exps = np.full(m, _NO_ROWS, dtype=np.int64)
        self.ref: np.ndarray | None = None
        self.ss, self.sh = np.zeros((lags, m)), np.zeros((lags, m))
        self.ee, self.et = np.zeros((lags, m)), np.zeros((lags, m))
        self.n_starts = self.n_ends = 0
        self.segments = 0  # segments with rows, the current one included
        self.first_head, self.first_len = np.zeros((0, m)), 0
        self.head, self.tail, self.length = np.zeros((0, m)), np.zeros((0, m)), 0  # the current segment
        self.start_done = False  # the current segment's start recorded
        self.ended = False  # a break after the current segment
        self.start_break = False  # a break before the first rows

    def copy(self) -> SegmentEdges:
        return copy.deepcopy(self)

    def add(self, e: np.ndarray) -> None:
        """Rows (c, m) that continue the current segment (or start one after a break)."""
        if e.shape[0] == 0 or self.k == 0:
            return
        if self.ref is None:
            self.ref = e[0].copy()
        self._rescale(_exponents(e - self.ref))
        if self.segments == 0 or self.ended:
            if self.ended:
                self._record_end(self.tail, self.length)  # rows follow: that end is inside the stream
            self.segments += 1
            self.head, self.tail, self.length = np.zeros((0, self.m)), np.zeros((0, self.m)), 0
            self.start_done, self.ended = False, False
        self.head = np.concatenate((self.head, e[: self.k - self.head.shape[0]]))
        self.tail = np.concatenate((self.tail, e))[-self.k:]
        self.length += e.shape[0]
        if self.segments == 1:
            self.first_head, self.first_len = self.head, self.length
        elif not self.start_done and self.length > self.k:
            self._record_start(self.head)
            self.start_done = True

    def end_segment(self) -> None:
        if self.segments == 0:
            self.start_break = True
        self.ended = self.segments > 0

    def merge(self, later: SegmentEdges) -> None:
        """Add ``later``'s sums and edges (its rows come after these)."""
        if later.segments == 0:
            if later.start_break:
                self.end_segment()
            return
        if self.segments == 0:
            start_break = self.start_break
            self.__dict__.update(later.copy().__dict__)
            self.start_break = self.start_break or start_break
            return
        b = later.copy()
        top = np.maximum(self.exps, b.exps)
        self._rescale(top)
        b._rescale(top)
        assert self.ref is not None and b.ref is not None
        d = np.ldexp(b.ref - self.ref, -top)  # b's y less this reference, in the common units
        self.ss += b.ss + d * (b.sh + b.sh[0]) + b.n_starts * d * d
        self.sh += b.sh + b.n_starts * d
        self.ee += b.ee + d * (b.et + b.et[0]) + b.n_ends * d * d
        self.et += b.et + b.n_ends * d
        self.n_starts += b.n_starts
        self.n_ends += b.n_ends
        if self.ended or b.start_break:
            self._record_end(self.tail, self.length)
            first_start = b.first_len > self.k
            if first_start:
                self._record_start(b.first_head)
            self._take_current(b, first_start if b.segments == 1 else b.start_done, self.segments + b.segments)
            return
        # joined: this current segment continues into b's first one
        head = np.concatenate((self.head, b.first_head))[: self.k]
        length = self.length + b.first_len
        if self.segments == 1:
            self.first_head, self.first_len = head, length
        elif not self.start_done and length > self.k:
            self._record_start(head)
            self.start_done = True
        if b.segments == 1:
            self.head, self.length = head, length
            self.tail = np.concatenate((self.tail, b.tail))[-self.k:]
            self.ended = b.ended
            return
        if b.first_len <= self.k:  # b did not record that segment's end: its first part was too short alone
            self._record_end(np.concatenate((self.tail, b.first_head))[-self.k:], length)
        self._take_current(b, b.start_done, self.segments + b.segments - 1)

    def _take_current(self, b: SegmentEdges, start_done: bool, segments: int) -> None:
        self.head, self.tail, self.length, self.ended = b.head, b.tail, b.length, b.ended
        self.start_done, self.segments = start_done, segments

    def centred(self, mean: np.ndarray, exps: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray] | None,
                                                                     tuple[np.ndarray, np.ndarray] | None]:
        """The sums (S, H) of the inner starts and (E, T) of the inner ends about the final ``mean``,
        in units 2^exps (the state's), or None where none was recorded."""
        if self.ref is None:
            return None, None
        shift = self.exps - exps
        delta = mean - np.ldexp(self.ref, -exps)

        def about(prod: np.ndarray, first: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray] | None:
            if n == 0:
                return None
            p, f = np.ldexp(prod, 2 * shift[None]), np.ldexp(first, shift[None])
            return p - delta * (f + f[0]) + n * delta * delta, f - n * delta

        return about(self.ss, self.sh, self.n_starts), about(self.ee, self.et, self.n_ends)

    def _scaled(self, rows: np.ndarray) -> np.ndarray:
        assert self.ref is not None
        scaled: np.ndarray = np.ldexp(rows - self.ref, -self.exps[None])
        return scaled

    def _record_start(self, head: np.ndarray) -> None:
        y = self._scaled(head)
        self.ss += y * y[0]
        self.sh += y
        self.n_starts += 1

    def _record_end(self, tail: np.ndarray, length: int) -> None:
        if length <= self.k:
            return
        y = self._scaled(tail)[::-1]  # y_{E−1}, y_{E−2}, ...
        self.ee += y * y[0]
        self.et += y
        self.n_ends += 1

    def _rescale(self, exps: np.ndarray) -> None:
        top = np.maximum(self.exps, exps)
        shift = top - self.exps
        if shift.any():
            self.ss, self.ee = np.ldexp(self.ss, -2 * shift[None]), np.ldexp(self.ee, -2 * shift[None])
            self.sh, self.et = np.ldexp(self.sh, -shift[None]), np.ldexp(self.et, -shift[None])
            self.exps = top


def _exponents(x: np.ndarray) -> np.ndarray:
    largest = np.max(np.abs(x), axis=0)
    return np.where((largest > 0) & np.isfinite(largest), np.frexp(largest)[1], 0).astype(np.int64)
