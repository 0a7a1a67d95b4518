"""Mergeable sums behind :class:`dynval.stream.ValidationAccumulator` (contract §4.1).

A :class:`State` summarises a run of consecutive rows (one or more segments) with sums whose
size does not depend on the number of rows:

* per joint, about a centre K (kept at the running mean): Σ(x − K), Σ(x − K)² of the target,
  and for the residual, at every lag ℓ = 0..L, the lagged products P_ℓ = Σ (e_t − K)(e_{t−ℓ} − K)
  together with the sums of the current elements H_ℓ = Σ (e_t − K) and of the lagged elements
  T_ℓ = Σ (e_{t−ℓ} − K) over the same pairs, and the pair count n_ℓ; the same for the residual
  against each regressor column (lagged sums of the column instead of T);
* minima and maxima (constancy is decided on the data, contract §3.2);
* the first rows of the first segment and the last rows of the last segment (at most L each),
  so that a later merge can form the lagged products that cross the junction.

Moving a centre from K to K' = K + δ needs only these sums:
Σ(x_t − K')(y_{t−ℓ} − K'') = P_ℓ − δ_y H_ℓ − δ_x T_ℓ + n_ℓ δ_x δ_y. Every merge moves both operands
to their combined mean before adding them (Chan's pairwise update of centred moments, extended to
lagged products), so the sums stay centred and nothing cancels however large the offset of the
data. Running sums are compensated (a second array holds what each addition rounded away), so a
stream of many small chunks is as accurate as one pass.

Every sum is held in units of a power of two per column (contract §4.1, scale): ``exp_e`` (m,),
``exp_t`` (m,) and ``exp_y`` (m, p) are the exponents k of the largest |x| seen in each column
(``np.frexp``; 0 for a column of zeros), and the centres and sums are those of x·2^-k, so that no
square or product underflows or overflows whatever the data's magnitude. A block takes the
exponents of its own rows; a merge moves both operands to the larger exponent of each column,
which multiplies every sum by a power of two (exact, but for parts that fall below 2^-1022 of the
largest: they are below the rounding of the sums they join). After any merge tree the exponents
are those of the whole stream's largest |x|, the ones ``validate`` scales by. The boundary rows,
minima and maxima stay raw.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.fft

from ..checks import _timing
from ..kernels._reference.correlation import DIRECT_MAX_LAGS, row_lagged_products
from ..kernels._reference.norms import joint_major

_ONE_SEGMENT = np.zeros(1, dtype=np.int64)
# Values gathered at a time for the products across a junction (lags × head rows × m).
_JUNCTION_VALUES = 1 << 20


class Compensated:
    """An array sum carried as ``hi + lo`` (Kahan–Babuška/Neumaier): ``lo`` keeps the rounding errors."""

    __slots__ = ("hi", "lo")

    def __init__(self, value):
        self.hi = np.array(value, dtype=np.float64)
        self.lo = np.zeros_like(self.hi)

    def add(self, x) -> None:
        s = self.hi + x
        b = s - self.hi
        self.lo += (self.hi - (s - b)) + (x - b)
        self.hi = s

    def add_sum(self, other: Compensated) -> None:
        self.add(other.hi)
        self.lo += other.lo

    def value(self) -> np.ndarray:
        return self.hi + self.lo

    def scale(self, k) -> None:
        """Multiply the sum by 2^k (``k`` broadcast against it), exactly unless a part underflows."""
        self.hi = np.ldexp(self.hi, k)
        self.lo = np.ldexp(self.lo, k)


@dataclass(frozen=True)
class Layout:
    """What a state holds: m joints, p regressor columns (0: none), lags of the residual's
    autocorrelation (``acf_lags``) and of the cross-correlation (``xcorr_lags`` ≤ ``acf_lags``),
    and whether the residuals' m × m product matrix is needed (the ``full`` noise model)."""

    m: int
    p: int
    acf_lags: int
    xcorr_lags: int
    gram: bool


MAX_STATE_CELLS = 1 << 27
"""Most numbers a streamed state may hold (1 GiB of float64; contract §4.1): a larger layout is
refused before anything is allocated. A merge holds about three states at once."""


def state_cells(layout: Layout) -> int:
    """Numbers a state of ``layout`` holds at most (contract §4.1): the compensated lag sums and
    boundary rows of the residual, 8(L+1)m, the pair counts L+1, the regressor's compensated lag
    sums and last rows 5(Lx+1)mp, the m × m products 2m² (``gram``), and per joint and column
    their centres, extremes and exponents, 12m + 6mp."""
    m, p, le, lx = layout.m, layout.p, layout.acf_lags, layout.xcorr_lags
    return (le + 1) * (8 * m + 1) + 5 * (lx + 1) * m * p + (2 * m * m if layout.gram else 0) + 12 * m + 6 * m * p


def state_too_large(layout: Layout) -> str | None:
    """Why a state of ``layout`` is refused (more than :data:`MAX_STATE_CELLS` numbers), or None."""
    cells = state_cells(layout)
    if cells <= MAX_STATE_CELLS:
        return None
    return (f"the streamed state of m={layout.m} joints, p={layout.p} regressor columns and {layout.acf_lags} lags "
            f"({layout.xcorr_lags} of the cross-correlation) would hold {cells} numbers ({8 * cells / 2**30:.3g} GiB), "
            f"more than the limit of {MAX_STATE_CELLS} (1 GiB, contract §4.1)")


class State:
    """Centred, mergeable sums of a run of rows (see the module docstring)."""

    def __init__(self, layout: Layout):
        too_large = state_too_large(layout)
        if too_large is not None:
            raise MemoryError(too_large)  # the accumulator refuses such a layout first, as InvalidParameter
        m, p, le, lx = layout.m, layout.p, layout.acf_lags, layout.xcorr_lags
        self.layout = layout
        self.n = 0
        self.lengths: list[int] = []  # segment lengths, in order
        self.start_break = False  # the first row must not join the rows before it
        self.end_break = False  # the next row must not join the last row
        # power-of-two exponents of each column (module docstring): every centre and sum is in their units
        self.exp_e = np.zeros(m, dtype=np.int64)
        self.exp_t = np.zeros(m, dtype=np.int64)
        self.exp_y = np.zeros((m, p), dtype=np.int64)
        # residual e: centre, lagged products and their boundary sums, pair counts, extremes
        self.k_e = np.zeros(m)
        self.prod_e = Compensated(np.zeros((le + 1, m)))
        self.cur_e = Compensated(np.zeros((le + 1, m)))  # H_ℓ; H_0 = Σ(e − K)
        self.lag_e = Compensated(np.zeros((le + 1, m)))  # T_ℓ
        self.pairs = np.zeros(le + 1, dtype=np.int64)
        self.gram = Compensated(np.zeros((m, m))) if layout.gram else None
        self.min_e = np.full(m, np.inf)
        self.max_e = np.full(m, -np.inf)
        # target tau_meas: centre, Σ(τ − K), Σ(τ − K)², extremes
        self.k_t = np.zeros(m)
        self.sum_t = Compensated(np.zeros(m))
        self.sq_t = Compensated(np.zeros(m))
        self.min_t = np.full(m, np.inf)
        self.max_t = np.full(m, -np.inf)
        # regressor Y (m, p): centre, Σ(Y − K)², lagged sums (lag 0: Σ(Y − K)), cross products
        self.k_y = np.zeros((m, p))
        self.sq_y = Compensated(np.zeros((m, p)))
        self.lag_y = Compensated(np.zeros((lx + 1, m, p)))
        self.prod_ey = Compensated(np.zeros((lx + 1, m, p)))
        self.min_y = np.full((m, p), np.inf)
        self.max_y = np.full((m, p), -np.inf)
        # boundary rows (raw values): the first segment's first rows, the last segment's last rows
        self.head_e = np.zeros((0, m))
        self.tail_e = np.zeros((0, m))
        self.tail_y = np.zeros((0, m, p))

    def copy(self) -> State:
        return copy.deepcopy(self)

    def append_measured(self, meas: np.ndarray, pred: np.ndarray, y: np.ndarray | None, rows: int) -> None:
        """Rows that continue the current segment: measured and predicted torque (c, m), ``y``
        (c, m, p) or None; summed in blocks of ``rows``, each block's residual formed on its own,
        and merged."""
        for a in range(0, meas.shape[0], rows):
            block = slice(a, a + rows)
            self.merge(State.from_block(self.layout, meas[block] - pred[block], meas[block],
                                        None if y is None else y[block]))

    def snapshot(self) -> State:
        """The sums the report reads (the state itself)."""
        return self

    # ----------------------------------------------------------------------- one block

    @classmethod
    def from_block(cls, layout: Layout, e: np.ndarray, tau: np.ndarray, y: np.ndarray | None) -> State:
        """The state of one segment of rows: ``e``, ``tau`` (c, m) and ``y`` (c, m, p) or None."""
        st = cls(layout)
        c = e.shape[0]
        st.n = c
        st.lengths = [c]
        st.k_e, xe, st.min_e, st.max_e, st.exp_e = _centred_rows(e)
        st._set_lagged_sums(xe, c)
        if st.gram is not None:
            g = np.zeros((layout.m, layout.m))
            for i in range(layout.m):
                g[i, i:] = np.add.reduce(xe[i] * xe[i:], axis=1)
            st.gram = Compensated(np.triu(g) + np.triu(g, 1).T)
        st.k_t, xt, st.min_t, st.max_t, st.exp_t = _centred_rows(tau)
        st.sum_t = Compensated(np.add.reduce(xt, axis=1))
        st.sq_t = Compensated(np.add.reduce(np.square(xt, out=xt), axis=1))
        if layout.p:
            st._set_regressor_sums(xe, y, c)
        st.head_e = e[: layout.acf_lags].copy()
        st.tail_e = _last(e, layout.acf_lags).copy()
        return st

    def _set_lagged_sums(self, xe: np.ndarray, c: int) -> None:
        le = self.layout.acf_lags
        top = min(le, c - 1)
        prod = np.zeros((le + 1, xe.shape[0]))
        prod[: top + 1] = _lagged_products(xe, xe, top)
        self.prod_e = Compensated(prod)
        cur, lag = _boundary_sums(xe, le)
        self.cur_e, self.lag_e = Compensated(cur), Compensated(lag)
        self.pairs = np.maximum(c - np.arange(le + 1), 0).astype(np.int64)

    def _set_regressor_sums(self, xe: np.ndarray, y: np.ndarray, c: int) -> None:
        m, p, lx = self.layout.m, self.layout.p, self.layout.xcorr_lags
        k_y, xy, lo, hi, exps = _centred_rows(y.reshape(c, m * p))  # row j·p + c: joint j, column c
        self.k_y, self.min_y, self.max_y = k_y.reshape(m, p), lo.reshape(m, p), hi.reshape(m, p)
        self.exp_y = exps.reshape(m, p)
        self.sq_y = Compensated(np.add.reduce(xy * xy, axis=1).reshape(m, p))
        _, lag = _boundary_sums(xy, lx)
        self.lag_y = Compensated(lag.reshape(lx + 1, m, p))
        top = min(lx, c - 1)
        prod = np.zeros((lx + 1, m * p))
        prod[: top + 1] = _lagged_products(xe, xy, top, repeat=p)
        self.prod_ey = Compensated(prod.reshape(lx + 1, m, p))
        self.tail_y = _last(y, lx).copy()

    # ----------------------------------------------------------------------- centres

    def mean_e(self) -> np.ndarray:
        return self.k_e + self.cur_e.value()[0] / self.n

    def mean_t(self) -> np.ndarray:
        return self.k_t + self.sum_t.value() / self.n

    def mean_y(self) -> np.ndarray:
        return self.k_y + self.lag_y.value()[0] / self.n

    def recentre(self, k_e: np.ndarray, k_t: np.ndarray, k_y: np.ndarray) -> None:
        """Move every sum to new centres: x − K' = (x − K) − δ (module docstring)."""
        n, lx = self.n, self.layout.xcorr_lags
        d = k_e - self.k_e
        cur, lag = self.cur_e.value(), self.lag_e.value()
        nl = self.pairs[:, None].astype(np.float64)
        # Every correction is computed from the sums before any of them moves.
        fix_prod = -d * (cur + lag) + nl * d * d
        if self.gram is not None:
            s = cur[0]
            self.gram.add(-(np.outer(d, s) + np.outer(s, d)) + n * np.outer(d, d))
        if self.layout.p:
            dy = k_y - self.k_y
            lag_y = self.lag_y.value()
            nlx = nl[: lx + 1, :, None]
            self.prod_ey.add(-dy[None] * cur[: lx + 1, :, None] - d[None, :, None] * lag_y
                             + nlx * d[None, :, None] * dy[None])
            self.sq_y.add(-2.0 * dy * lag_y[0] + n * dy * dy)
            self.lag_y.add(-nlx * dy[None])
            self.k_y = k_y
        self.prod_e.add(fix_prod)
        self.cur_e.add(-nl * d)
        self.lag_e.add(-nl * d)
        self.k_e = k_e
        dt = k_t - self.k_t
        self.sq_t.add(-2.0 * dt * self.sum_t.value() + n * dt * dt)
        self.sum_t.add(-n * dt)
        self.k_t = k_t

    def rescale(self, exp_e: np.ndarray, exp_t: np.ndarray, exp_y: np.ndarray) -> None:
        """Move every centre and sum to the exponents given (each at least the state's own): a sum
        of products of columns a and b is multiplied by 2^(da + db), a sum or centre by 2^da."""
        de, dt, dy = exp_e - self.exp_e, exp_t - self.exp_t, exp_y - self.exp_y
        if de.any():
            self.k_e = np.ldexp(self.k_e, -de)
            self.prod_e.scale(-2 * de)
            self.cur_e.scale(-de)
            self.lag_e.scale(-de)
            if self.gram is not None:
                self.gram.scale(-(de[:, None] + de[None, :]))
        if dt.any():
            self.k_t = np.ldexp(self.k_t, -dt)
            self.sum_t.scale(-dt)
            self.sq_t.scale(-2 * dt)
        if self.layout.p and (de.any() or dy.any()):
            self.k_y = np.ldexp(self.k_y, -dy)
            self.sq_y.scale(-2 * dy)
            self.lag_y.scale(-dy[None])
            self.prod_ey.scale(-(de[None, :, None] + dy[None]))
        self.exp_e, self.exp_t, self.exp_y = exp_e, exp_t, exp_y

    # ----------------------------------------------------------------------- merge

    def merge(self, later: State | CoreState) -> None:
        """Add ``later`` (rows that follow this state's rows in time) to this state, in place.

        Lags join across the junction unless this state ends with a break or ``later`` starts
        with one. ``later`` is not modified.
        """
        assert isinstance(later, State)  # accumulators of different backends do not merge
        if later.n == 0:
            self.end_break = self.end_break or later.start_break or later.end_break
            return
        if self.n == 0:
            pending = self.start_break or self.end_break
            self.__dict__.update(later.copy().__dict__)
            self.start_break = self.start_break or pending
            return
        b = later.copy()
        exps = (np.maximum(self.exp_e, b.exp_e), np.maximum(self.exp_t, b.exp_t), np.maximum(self.exp_y, b.exp_y))
        self.rescale(*exps)
        b.rescale(*exps)
        n = self.n + b.n
        w = b.n / n
        ma, mb = self.mean_e(), b.mean_e()
        ta, tb = self.mean_t(), b.mean_t()
        ya, yb = self.mean_y(), b.mean_y()
        centres = (ma + w * (mb - ma), ta + w * (tb - ta), ya + w * (yb - ya))
        self.recentre(*centres)
        b.recentre(*centres)
        join = not (self.end_break or b.start_break)
        if join:
            self._add_junction(b)
        self._add_sums(b)
        self._join_boundaries(b, join)

    def _add_sums(self, b: State) -> None:
        for name in ("prod_e", "cur_e", "lag_e", "sum_t", "sq_t", "sq_y", "lag_y", "prod_ey"):
            getattr(self, name).add_sum(getattr(b, name))
        if self.gram is not None:
            self.gram.add_sum(b.gram)
        self.pairs = self.pairs + b.pairs
        self.n += b.n
        for lo, hi in (("min_e", "max_e"), ("min_t", "max_t"), ("min_y", "max_y")):
            setattr(self, lo, np.minimum(getattr(self, lo), getattr(b, lo)))
            setattr(self, hi, np.maximum(getattr(self, hi), getattr(b, hi)))

    def _add_junction(self, b: State) -> None:
        """The lagged products whose current element is in ``b``'s first segment and whose lagged
        element is in this state's last segment (both already on the same centres)."""
        le, lx = self.layout.acf_lags, self.layout.xcorr_lags
        if le == 0:
            return
        head = _scaled(b.head_e, self.exp_e) - self.k_e  # current elements: b's first rows
        tail = _scaled(self.tail_e, self.exp_e) - self.k_e  # lagged elements: this state's last rows
        prod, cur, lag = (np.zeros((le + 1, head.shape[1])) for _ in range(3))
        pairs = np.zeros(le + 1, dtype=np.int64)
        # Lags in groups: the gathered (lags, rows, m) arrays stay small however long max_lag is.
        group = max(1, _JUNCTION_VALUES // max(1, head.size))
        for first in range(1, le + 1, group):
            lags = np.arange(first, min(le, first + group - 1) + 1)
            rows = slice(first, lags[-1] + 1)
            prod[rows], cur[rows], lag[rows], pairs[rows] = _junction_sums(head, tail, lags)
        self.prod_e.add(prod)
        self.cur_e.add(cur)
        self.lag_e.add(lag)
        self.pairs = self.pairs + pairs
        if self.layout.p and lx:
            self._add_cross_junction(head, _scaled(self.tail_y, self.exp_y) - self.k_y)

    def _add_cross_junction(self, head: np.ndarray, tail_y: np.ndarray) -> None:
        lx, m, p = self.layout.xcorr_lags, self.layout.m, self.layout.p
        n_tail = tail_y.shape[0]
        prod = np.zeros((lx + 1, m, p))
        lag_sum = np.zeros((lx + 1, m, p))
        for lag in range(1, lx + 1):
            i0, i1 = max(0, lag - n_tail), min(lag, head.shape[0])
            if i0 >= i1:
                continue
            ys = tail_y[n_tail - lag + i0: n_tail - lag + i1]  # (k, m, p)
            prod[lag] = np.einsum("km,kmp->mp", head[i0:i1], ys)
            lag_sum[lag] = ys.sum(axis=0)
        self.prod_ey.add(prod)
        self.lag_y.add(lag_sum)

    def _join_boundaries(self, b: State, join: bool) -> None:
        """Segment lengths and boundary rows of the concatenation."""
        le, lx = self.layout.acf_lags, self.layout.xcorr_lags
        single_a, single_b = len(self.lengths) == 1, len(b.lengths) == 1
        if join and single_a:
            self.head_e = np.concatenate([self.head_e, b.head_e])[:le]
        if join and single_b:
            self.tail_e = _last(np.concatenate([self.tail_e, b.tail_e]), le)
            self.tail_y = _last(np.concatenate([self.tail_y, b.tail_y]), lx)
        else:
            self.tail_e, self.tail_y = b.tail_e, b.tail_y
        if join:
            self.lengths = self.lengths[:-1] + [self.lengths[-1] + b.lengths[0]] + b.lengths[1:]
        else:
            self.lengths = self.lengths + b.lengths
        self.end_break = b.end_break


def _junction_sums(head: np.ndarray, tail: np.ndarray, lags: np.ndarray):
    """For each lag ℓ: Σ head_i·tail_{n−ℓ+i}, Σ head_i, Σ tail_{n−ℓ+i} and the count, over the head
    rows i < ℓ whose partner n − ℓ + i ≥ 0 exists (n = len(tail))."""
    n_tail = tail.shape[0]
    i = np.arange(head.shape[0])[None, :]
    idx = n_tail - lags[:, None] + i
    valid = (idx >= 0) & (i < lags[:, None])
    lagged = np.where(valid[:, :, None], tail[np.clip(idx, 0, n_tail - 1)], 0.0)  # (lags, rows, m)
    current = np.where(valid[:, :, None], head[None], 0.0)
    return (np.einsum("lim,lim->lm", current, lagged), current.sum(axis=1), lagged.sum(axis=1),
            valid.sum(axis=1))


def _lagged_products(x: np.ndarray, y: np.ndarray, top: int, repeat: int = 1) -> np.ndarray:
    """S[ℓ, r] = Σ_t x[r // repeat, t]·y[r, t − ℓ] for ℓ = 0..top, over one segment's rows (k, c).

    ``repeat = p`` pairs joint j's residual with its p regressor columns (rows j·p + c of ``y``).
    Few lags: the reference kernel's direct pairwise sums. More: one batched real FFT per array
    (length ≥ c + top, so no wrap-around), each residual row transformed once, not once per column.
    """
    if top + 1 <= DIRECT_MAX_LAGS:
        xr = x if repeat == 1 else np.repeat(x, repeat, axis=0)
        return row_lagged_products(xr, xr if y is x else y, top, _ONE_SEGMENT, "direct")
    nfft = scipy.fft.next_fast_len(x.shape[1] + top, real=True)
    fx = scipy.fft.rfft(x, nfft, axis=1)
    if y is x:
        spectrum = fx.real**2 + fx.imag**2
    else:
        spectrum = np.conj(scipy.fft.rfft(y, nfft, axis=1))
        spectrum *= fx if repeat == 1 else np.repeat(fx, repeat, axis=0)
    return scipy.fft.irfft(spectrum, nfft, axis=1)[:, : top + 1].T


def _centred_rows(x: np.ndarray):
    """(centre, rows − centre, min, max, exponents) of the columns of ``x`` (c, k), as contiguous
    rows (k, c): numpy then sums each row pairwise at the speed of reading it. Each row is scaled
    by 2^-k, k its exponent (:func:`pow2_exponents`), before it is centred on its mean; the minima
    and maxima are of the raw values."""
    rows = joint_major(x)
    if not rows.flags.owndata:
        rows = rows.copy()  # joint-major input comes back as a view: the caller's data stay untouched
    lo, hi = rows.min(axis=1), rows.max(axis=1)
    exps = pow2_exponents(lo, hi)
    if exps.any():
        rows = _scale_rows(rows, exps)
    centre = np.add.reduce(rows, axis=1) / rows.shape[1]
    rows -= centre[:, None]
    return centre, rows, lo, hi, exps


def pow2_exponents(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The exponent k (``np.frexp``) of max(|lo|, |hi|), elementwise: 0 where both are 0 (and where
    a column holds no value yet, ±inf). |x|·2^-k < 1 for every x of the column."""
    largest = np.maximum(np.abs(lo), np.abs(hi))
    return np.where((largest > 0) & np.isfinite(largest), np.frexp(largest)[1], 0).astype(np.int64)


def _scale_rows(rows: np.ndarray, exps: np.ndarray) -> np.ndarray:
    """rows·2^-k, row by row, in place where the factor is a normal number (the product is then
    exactly ``np.ldexp``'s)."""
    if np.all(np.abs(exps) < 1000):
        rows *= np.ldexp(1.0, -exps)[:, None]
        return rows
    return np.ldexp(rows, -exps[:, None])


def _scaled(rows: np.ndarray, exps: np.ndarray) -> np.ndarray:
    """Raw boundary rows (r, ...) in the units 2^exps of their columns (exps broadcast on a row)."""
    return np.ldexp(rows, -exps[None]) if rows.size else rows


def _boundary_sums(x: np.ndarray, lags: int) -> tuple[np.ndarray, np.ndarray]:
    """For rows ``x`` (k, c) of one segment: Σ x_t over the current elements (t ≥ ℓ) and over the
    lagged elements (t < c − ℓ) of the lag-ℓ pairs, ℓ = 0..lags; 0 where a lag has no pair."""
    k, c = x.shape
    total = np.add.reduce(x, axis=1)
    cur = np.zeros((lags + 1, k))
    lag = np.zeros((lags + 1, k))
    cur[0] = lag[0] = total
    top = min(lags, c - 1)
    if top >= 1:
        # The sums leave out the first (last) ℓ values: the total less a short prefix (suffix).
        cur[1: top + 1] = total - np.cumsum(x[:, :top], axis=1).T
        lag[1: top + 1] = total - np.cumsum(x[:, ::-1][:, :top], axis=1).T
    return cur, lag


def _last(rows: np.ndarray, k: int) -> np.ndarray:
    """The last ``k`` rows (none for k = 0, where ``rows[-0:]`` would give them all)."""
    return rows[rows.shape[0] - min(k, rows.shape[0]):]


class _Sum:
    """A sum already combined (``hi + lo``), read with ``value()`` like :class:`Compensated`."""

    __slots__ = ("_value",)

    def __init__(self, value: np.ndarray) -> None:
        self._value = value

    def value(self) -> np.ndarray:
        return self._value


class CoreState:
    """The same state in the C++ core (``dynval._core.StreamState``, cpp/include/dynval/stream_state.hpp),
    which follows :class:`State` step by step. ``State`` stays the reference; the report reads
    either through :meth:`snapshot`."""

    def __init__(self, layout: Layout, core: object | None = None):
        from .. import _core  # the cpp backend: imported only when it is used

        self.layout = layout
        self._core: Any = core if core is not None else _core.StreamState(
            layout.m, layout.p, layout.acf_lags, layout.xcorr_lags, layout.gram)

    @property
    def n(self) -> int:
        return int(self._core.n)

    @property
    def lengths(self) -> list[int]:
        return list(self._core.lengths)

    @property
    def end_break(self) -> bool:
        return bool(self._core.end_break)

    @end_break.setter
    def end_break(self, value: bool) -> None:
        self._core.end_break = bool(value)

    def append_measured(self, meas: np.ndarray, pred: np.ndarray, y: np.ndarray | None,
                        rows: int | None = None) -> None:
        """Rows that continue the current segment: ``meas``, ``pred`` (c, m), ``y`` (c, m, p) or None;
        the core forms the residual block by block and chooses its own block length (``rows`` is
        the reference's)."""
        c = meas.shape[0]
        self._core.append_measured(meas, pred, None if y is None else y.reshape(c, -1))

    def merge(self, later: State | CoreState) -> None:
        assert isinstance(later, CoreState)  # accumulators of different backends do not merge
        self._core.merge(later._core)

    def copy(self) -> CoreState:
        return CoreState(self.layout, self._core.copy())

    def __deepcopy__(self, memo: dict) -> CoreState:
        return self.copy()

    def snapshot(self) -> Snapshot:
        return Snapshot(self.layout, self.n, self.lengths, self._core.sums())


class Snapshot:
    """The sums of a :class:`CoreState` under the attribute names of :class:`State` (for the report)."""

    _COMPENSATED = ("prod_e", "cur_e", "lag_e", "sum_t", "sq_t", "sq_y", "lag_y", "prod_ey")
    prod_e: _Sum
    cur_e: _Sum
    lag_e: _Sum
    sum_t: _Sum
    sq_t: _Sum
    sq_y: _Sum
    lag_y: _Sum
    prod_ey: _Sum
    gram: _Sum | None
    head_e: np.ndarray  # the boundary rows, raw
    tail_e: np.ndarray
    pairs: np.ndarray
    k_e: np.ndarray
    k_t: np.ndarray
    k_y: np.ndarray
    min_e: np.ndarray
    max_e: np.ndarray
    min_t: np.ndarray
    max_t: np.ndarray
    min_y: np.ndarray
    max_y: np.ndarray
    exp_e: np.ndarray
    exp_t: np.ndarray
    exp_y: np.ndarray

    def __init__(self, layout: Layout, n: int, lengths: list[int], sums: dict) -> None:
        self.layout, self.n, self.lengths = layout, n, lengths
        for name, value in sums.items():
            setattr(self, name, _Sum(value) if name in self._COMPENSATED else value)
        self.gram = None if sums["gram"] is None else _Sum(sums["gram"])



# --------------------------------------------------------------------------- time stamps


class Stamps:
    """Streaming summary of the time stamps of the kept rows (contract §4.1): what
    :func:`dynval.checks._timing.analyse` reports of the whole array, from sums whose size does not grow
    with N (plus the row after each gap: one integer per segment, as the state keeps).

    Steps are classified as they arrive (duplicate, gap, irregular) against ``nominal``: the given
    sample rate's step, or the one ``_timing`` finds in the stream's first steps. A step after k
    duplicated stamps spans k + 1 rows (``_timing``'s rule), across chunks too. The rate is counted
    in steps of ``median`` (rint(step/median) ≥ 1) as ``_timing`` counts them in the whole run's
    median; the jitter and the largest deviation are measured against the final nominal step by
    :meth:`timing`, from sums centred on ``nominal``.
    """

    def __init__(self, nominal: float, median: float) -> None:
        self.nominal = float(nominal)
        self.median = float(median)
        self.rows = 0  # kept stamps so far
        self.first: float | None = None  # first and last kept stamps
        self.last: float | None = None
        self.first_row: np.ndarray | None = None  # first and last kept torque rows (repeats across junctions)
        self.last_row: np.ndarray | None = None
        self.zeros = 0  # zero steps right before the next step
        self.advanced = False  # a positive step seen
        self.n_steps = self.duplicated = self.repeated = self.gaps = self.irregular = 0
        self.largest = -np.inf  # the largest step, and the stamp of the row after it (the first such)
        self.largest_at: float | None = None
        self.gap_rows: list[int] = []
        # counted steps (c = rint(s/median) ≥ 1): how many, Σc, Σs, and [Σe², Σc·e, Σc²], e = s − c·median
        self.n_counted = 0
        self.counts = 0
        self.span = Compensated(0.0)
        self.rate_sums = Compensated(np.zeros(3))
        # regular steps (positive, not a gap) spanning k rows: [Σd², Σk·d, Σk²], d = s − k·nominal,
        # and the extremes of d for each k (the largest deviation against another nominal step)
        self.n_regular = 0
        self.dev_sums = Compensated(np.zeros(3))
        self.dev_range: dict[int, tuple[float, float]] = {}

    def add(self, t: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The next kept stamps ``t`` (c,), never below the last one, and their torque rows (c, m);
        returns the rows of ``t`` that follow a gap (0: the step from the stamp before ``t``)."""
        c = t.shape[0]
        if c == 0:
            return np.zeros(0, dtype=np.int64)
        flat = rows.reshape(c, -1)
        if self.last is None or self.last_row is None:
            self.first, self.first_row = float(t[0]), flat[0].copy()
            stamps, data, before = t, flat, 0
        else:
            stamps, data, before = np.concatenate(([self.last], t)), np.concatenate((self.last_row[None], flat)), 1
        assert self.first is not None
        self.repeated += int(np.count_nonzero(np.all(data[1:] == data[:-1], axis=1)))
        gap_at = self._add_steps(np.diff(stamps - self.first), stamps)  # relative to the first stamp, as _timing
        # step j ends at row j + 1 of ``stamps``: row j + 1 − before of ``t``
        at = (gap_at + 1 - before).astype(np.int64)
        self.gap_rows.extend(int(self.rows + i) for i in at)
        self.last, self.last_row = float(t[-1]), flat[-1].copy()
        self.rows += c
        return at

    def _add_steps(self, steps: np.ndarray, stamps: np.ndarray) -> np.ndarray:
        k = steps.shape[0]
        if k == 0:
            return np.zeros(0, dtype=np.int64)
        idx = np.arange(k)
        last_positive = np.maximum.accumulate(np.where(steps != 0, idx, -1))
        previous = np.concatenate(([-1], last_positive[:-1]))
        spans = (idx - previous + np.where(previous < 0, self.zeros, 0)).astype(np.float64)
        self.zeros = int(k - 1 - last_positive[-1]) if last_positive[-1] >= 0 else self.zeros + k
        positive = steps > 0
        self.advanced |= bool(positive.any())
        nominal = self.nominal
        is_gap = steps > (_timing.GAP_FACTOR + spans - 1) * nominal
        gap_at = np.flatnonzero(is_gap)
        self.n_steps += k
        self.duplicated += int(k - np.count_nonzero(positive))
        self.gaps += int(gap_at.size)
        j = int(np.argmax(steps))
        if steps[j] > self.largest:
            self.largest, self.largest_at = float(steps[j]), float(stamps[j + 1])
        counts = np.rint(steps / self.median)
        counted = counts >= 1
        if counted.any():
            cs, ss = counts[counted], steps[counted]
            e = ss - cs * self.median
            self.n_counted += int(cs.size)
            self.counts += int(cs.sum())
            self.span.add(float(ss.sum()))
            self.rate_sums.add(np.array([e @ e, cs @ e, cs @ cs]))
        regular = positive & ~is_gap
        if regular.any():
            kr = spans[regular]
            d = steps[regular] - kr * nominal
            self.n_regular += int(d.size)
            self.irregular += int(np.count_nonzero(np.abs(d) > _timing.IRREGULAR_TOLERANCE * nominal))
            self.dev_sums.add(np.array([d @ d, kr @ d, kr @ kr]))
            for span in np.unique(kr):
                ds = d[kr == span]
                lo, hi = self.dev_range.get(int(span), (math.inf, -math.inf))
                self.dev_range[int(span)] = (min(lo, float(ds.min())), max(hi, float(ds.max())))
        return gap_at

    def join(self, later: Stamps) -> bool:
        """Add the summary of the stamps that come right after these (``later.first`` ≥ ``self.last``);
        returns whether the step across the junction is a gap. The junction step is classified
        here; ``later``'s own steps keep the classification they had (against its nominal step)."""
        if later.rows == 0 or later.first_row is None:
            return False
        base = self.rows  # later's row 0
        # the step across the junction (none when this summary is empty: later's first stamp starts it)
        gap = bool(self.add(np.array([later.first]), later.first_row[None]).size)
        later = copy.deepcopy(later)
        later._recentre(self.nominal, self.median)
        self.n_steps += later.n_steps
        self.duplicated += later.duplicated
        self.repeated += later.repeated
        self.gaps += later.gaps
        self.irregular += later.irregular
        if later.largest > self.largest:
            self.largest, self.largest_at = later.largest, later.largest_at
        self.gap_rows.extend(base + r for r in later.gap_rows)
        self.n_counted += later.n_counted
        self.counts += later.counts
        self.span.add_sum(later.span)
        self.rate_sums.add_sum(later.rate_sums)
        self.n_regular += later.n_regular
        self.dev_sums.add_sum(later.dev_sums)
        for span, (lo, hi) in later.dev_range.items():
            mine = self.dev_range.get(span, (math.inf, -math.inf))
            self.dev_range[span] = (min(mine[0], lo), max(mine[1], hi))
        self.zeros = later.zeros if later.advanced else self.zeros + later.zeros
        self.advanced |= later.advanced
        self.last, self.last_row, self.rows = later.last, later.last_row, base + later.rows
        return gap

    def _recentre(self, nominal: float, median: float) -> None:
        """Move the centred sums to another nominal step and median (the counts stay)."""
        if not self.n_counted and not self.n_regular:  # duplicates only (a frozen start): no sum to move
            self.nominal, self.median = float(nominal), float(median)
            return
        dm, dn = self.median - median, self.nominal - nominal  # e' = e + c·dm, d' = d + k·dn
        e2, ce, c2 = self.rate_sums.value()
        self.rate_sums = Compensated(np.array([e2 + 2 * dm * ce + dm * dm * c2, ce + dm * c2, c2]))
        d2, kd, k2 = self.dev_sums.value()
        self.dev_sums = Compensated(np.array([d2 + 2 * dn * kd + dn * dn * k2, kd + dn * k2, k2]))
        self.dev_range = {k: (lo + k * dn, hi + k * dn) for k, (lo, hi) in self.dev_range.items()}
        self.nominal, self.median = float(nominal), float(median)

    def timing(self, sample_rate: float | None, units_checked: bool = True) -> _timing.Timing:
        """The :class:`dynval.checks._timing.Timing` of the stamps so far (at least one positive step);
        ``sample_rate`` given: checked against them as ``_timing.analyse`` does, and so are their
        units (``units_checked``)."""
        assert self.advanced and self.first is not None and self.last is not None
        span = float(self.span.value())
        _timing.check_resolvable(self.median, span)
        rate = self.counts / span
        e2, ce, c2 = self.rate_sums.value()
        dm = 1.0 / rate - self.median
        jitter = math.sqrt(max(e2 - 2 * dm * ce + dm * dm * c2, 0.0) / self.n_counted)
        uncertainty = 2.0 * float(np.spacing(max(abs(self.first), abs(self.last)))) + 3.0 * jitter
        nominal, source = _timing.rounded_step(rate, span, uncertainty), _timing.INFERRED
        if units_checked:
            _timing.check_units(nominal)
        if sample_rate is not None:
            nominal, source = _timing.given_step(sample_rate, nominal), "given"
        dn = nominal - self.nominal  # d' = d − k·dn
        d2, kd, k2 = self.dev_sums.value()
        jitter_rms = math.sqrt(max(d2 - 2 * dn * kd + dn * dn * k2, 0.0) / self.n_regular) if self.n_regular else 0.0
        largest_dev = max((max(abs(lo - k * dn), abs(hi - k * dn)) for k, (lo, hi) in self.dev_range.items()),
                          default=0.0)
        gaps = self.gaps
        return _timing.Timing(
            nominal_step=nominal, sample_rate=1.0 / nominal, sample_rate_source=source, n_steps=self.n_steps,
            duplicated_stamps=self.duplicated, repeated_rows=self.repeated, gaps=gaps,
            largest_gap=self.largest if gaps else 0.0,
            largest_gap_time=float(self.largest_at - self.first) if gaps and self.largest_at is not None else None,
            irregular_steps=self.irregular, jitter_rms=jitter_rms, largest_step_deviation=largest_dev,
            duration=float(self.last - self.first), gap_rows=tuple(self.gap_rows),
            grid=_timing.grid_text(nominal, source, len(self.gap_rows)))
