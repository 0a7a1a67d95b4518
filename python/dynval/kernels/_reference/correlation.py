"""Autocorrelation of residuals and cross-correlation with regressor columns.

Lagged products never cross a segment boundary; means are overall (one per joint over all
N samples). Joints are reduced as contiguous joint-major rows. Short lag ranges use direct
pairwise sums, long ones scipy.fft (one transform per segment, summed); both paths give the same
sums to rounding.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import scipy.fft
else:
    from ..._lazy import scipy

from ...checks._validation import check_adjusted, check_finite, check_max_lag, check_n_columns, is_integer
from ._common import as_2d, check_starts, finite_residual, segment_limit
from .norms import centred, is_constant, joint_major, scale_exponents, sumsq

# Up to this many lags per segment the O(n·L) direct sums are cheaper than an FFT (measured:
# about even at 16 lags for 7 × 2e6 samples; shorter segments favour the FFT earlier).
DIRECT_MAX_LAGS = 16


def lagged_products(x: np.ndarray, y: np.ndarray, max_lag: int, starts: np.ndarray, method: str | None = None):
    """S[ℓ, j] = Σ over segments of Σ_k x[k, j]·y[k − ℓ, j], for ℓ = 0..max_lag; x, y ``(N, m)``.

    Only pairs inside one segment contribute. ``method`` forces ``"direct"`` or ``"fft"``.
    """
    xr = joint_major(x)
    yr = xr if y is x else joint_major(y)
    return row_lagged_products(xr, yr, max_lag, starts, method)


def row_lagged_products(xr: np.ndarray, yr: np.ndarray, max_lag: int, starts: np.ndarray, method: str | None = None):
    """:func:`lagged_products` of joint-major rows ``(m, N)``; the result is ``(max_lag+1, m)``.

    Passing the same array as ``xr`` and ``yr`` (autocorrelation) saves one transform.
    """
    m, n = xr.shape
    out = np.zeros((max_lag + 1, m))
    bounds = np.append(np.asarray(starts, dtype=np.int64), n)
    for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist()):
        length = b - a
        top = min(max_lag, length - 1)
        xs, ys = xr[:, a:b], yr[:, a:b]
        use_direct = method == "direct" or (method is None and top + 1 <= DIRECT_MAX_LAGS)
        if use_direct:
            # Contiguous row slices: numpy sums each product row pairwise.
            for lag in range(top + 1):
                out[lag] += np.add.reduce(xs[:, lag:] * ys[:, : length - lag], axis=1)
        else:
            # A transform of length >= n + L keeps the circular wrap-around out of lags 0..L.
            # One row at a time keeps the transforms' temporaries small.
            nfft = scipy.fft.next_fast_len(length + top, real=True)
            for j in range(m):
                fx = scipy.fft.rfft(xs[j], nfft)
                fy = fx if yr is xr else scipy.fft.rfft(ys[j], nfft)
                fx *= np.conj(fy)
                out[: top + 1, j] += scipy.fft.irfft(fx, nfft)[: top + 1]
    return out


def product_counts(starts: np.ndarray, n: int, max_lag: int) -> np.ndarray:
    """n_ℓ = Σ_s max(n_s − ℓ, 0) for ℓ = 0..max_lag."""
    lengths = np.diff(np.append(np.asarray(starts, dtype=np.int64), n))
    lags = np.arange(max_lag + 1)
    return np.maximum(lengths[None, :] - lags[:, None], 0).sum(axis=1).astype(np.float64)


def denominators(starts: np.ndarray, n: int, max_lag: int, adjusted: bool) -> np.ndarray:
    """D_ℓ: n_ℓ when adjusted (D_0 = N either way), else N at every lag."""
    if adjusted:
        return product_counts(starts, n, max_lag)
    return np.full(max_lag + 1, float(n))


def biased_rho(d: np.ndarray, ss: np.ndarray, max_lag: int, starts: np.ndarray) -> np.ndarray:
    """ρ̂_ℓ = S_ℓ / S_0 for centred joint-major rows ``d`` with Σd² = ``ss``; nan where ss == 0."""
    s = row_lagged_products(d, d, max_lag, starts)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = s / ss
    rho[0] = 1.0
    rho[:, ss == 0] = np.nan
    return rho


def centred_and_ss(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint-major centred rows of ``x`` ``(N, m)``, their Σd² (0 when constant) and constancy.

    A row whose Σd² leaves the normal range (data near 1e-160) is scaled by a power of two
    and centred again: correlations do not depend on the scale, and its mean and squares then
    keep their digits.
    """
    rows = joint_major(x)
    constant = is_constant(rows)
    d = centred(rows)
    ss = sumsq(d)
    k = scale_exponents(rows, ss, ~constant)
    for i in np.flatnonzero(k):
        # Scaled before centring, so that the mean is not rounded to the subnormal grid.
        d[i] = centred(np.ldexp(rows[i : i + 1], -k[i]))[0]
        ss[i] = sumsq(d[i : i + 1])[0]
    ss[constant] = 0.0
    return d, ss, constant


def autocorrelation(e, max_lag, adjusted, starts) -> np.ndarray:
    """Normalised autocorrelation ρ̂(ℓ) = R̂(ℓ)/R̂(0), ℓ = 0..max_lag, shape ``(max_lag+1, m)``.

    A constant residual (min == max) gives a column of nan.
    """
    e = finite_residual(e)
    n = e.shape[0]
    starts = check_starts(starts, n)
    max_lag = check_max_lag(max_lag, segment_limit(starts, n))
    adjusted = check_adjusted(adjusted)
    d, ss, constant = centred_and_ss(e)
    s = row_lagged_products(d, d, max_lag, starts)
    s[0] = ss
    r = s / denominators(starts, n, max_lag, adjusted)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = r / (ss / n)
    rho[0] = 1.0
    # A residual whose centred sum of squares underflows to 0 has no usable scale either.
    rho[:, constant | (ss == 0)] = np.nan
    return rho


def cross_correlation(e, y, n_columns, max_lag, adjusted, starts) -> dict:
    """ρ_{e_j Y_jc}(ℓ) for every joint j and column c; ``y`` is the ``(N, m·p)`` view.

    Returns ``rho`` ``(m·p, max_lag+1)`` (row j·p + c) and ``constant_mask`` ``(m·p,)``.
    """
    e = as_2d(e)
    y = as_2d(y)
    n, m = e.shape
    check_finite(e, "e")
    # The sample/joint/column wording needs a usable column count; otherwise row/column.
    p_ok = is_integer(n_columns) and n_columns > 0 and n_columns * m == y.shape[1]
    check_finite(y, "regressor", n_columns=int(n_columns) if p_ok else None)
    starts = check_starts(starts, n)
    p = check_n_columns(n_columns, y.shape[1], m)
    max_lag = check_max_lag(max_lag, segment_limit(starts, n))
    adjusted = check_adjusted(adjusted)

    de, ss_e, e_constant = centred_and_ss(e)
    # Row j·p + c pairs joint j's residual with its regressor column c. One joint's p columns
    # at a time: the temporaries are p rows, not a copy of the whole regressor per step.
    rho = np.empty((max_lag + 1, m * p))
    constant_mask = np.empty(m * p, dtype=bool)
    d_l = denominators(starts, n, max_lag, adjusted)[:, None]
    for j in range(m):
        cols = slice(j * p, (j + 1) * p)
        dy, ss_y, constant_mask[cols] = centred_and_ss(y[:, cols])
        # Only the varying columns are multiplied (a serial arm's regressor is zero in most joint-column
        # pairs); a constant column's correlation is nan below whatever its sums. Each row's sums do not
        # depend on the other rows, so the varying columns' are the ones all columns would give.
        live = np.flatnonzero(~constant_mask[cols])
        s = np.zeros((max_lag + 1, p))
        if live.size:
            dl = dy if live.size == p else dy[live]
            s[:, live] = row_lagged_products(np.broadcast_to(de[j], dl.shape), dl, max_lag, starts)
        with np.errstate(divide="ignore", invalid="ignore"):
            # Two roots, not the root of the product: R_e(0)·R_Y(0) overflows for data near 1e80
            # and underflows near 1e-80, both inside the accepted range.
            rho[:, cols] = s / d_l / (np.sqrt(ss_e[j] / n) * np.sqrt(ss_y / n))
        # Cauchy-Schwarz bounds |rho(l)| by N/D_l (1 at lag 0 and without `adjusted`); rounding can
        # step one ulp past it (contract §3.6). clip keeps nan.
        rho[:, cols] = np.clip(rho[:, cols], -n / d_l, n / d_l)
        if e_constant[j] or ss_e[j] == 0:
            rho[:, cols] = np.nan
        rho[:, cols][:, constant_mask[cols] | (ss_y == 0)] = np.nan
    return {"rho": np.ascontiguousarray(rho.T), "constant_mask": constant_mask}
