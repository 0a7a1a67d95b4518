"""Statistics shared by the public functions, the report and its findings.

One home for the normal quantile, the i.i.d. t-test, the multiple-testing correction, the
effective sample size of a coloured residual, the colour-aware standard deviation of a
cross-correlation, FFT autocorrelations, the residual spectrum and the choice of a decimation
factor for oversampled data. Every estimator is named and cited in docs/conventions.md §6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    import scipy.fft
    import scipy.ndimage
    import scipy.signal
    import scipy.special
    import scipy.stats
else:
    from .._lazy import scipy

from ..checks._typing import ArrayLike, FloatArray
from ..kernels._threads import worker_count
from ._columns import runs

__all__ = [
    "z_two_sided",
    "iid_t_test",
    "ZeroMean",
    "iid_zero_mean",
    "BiasTest",
    "bias_t_test",
    "residual_bias_test",
    "holm",
    "acf_fft",
    "LongRunVariance",
    "long_run_variance",
    "long_run_variance_from_sums",
    "bartlett_long_run_variance",
    "andrews_bandwidth",
    "score_covariance",
    "cross_correlation_sd",
    "weighted_column_acf",
    "ColumnPowers",
    "column_powers",
    "colour_aware_sd",
    "correlation_pvalue",
    "Spectrum",
    "residual_spectrum",
    "spectrum_tests_per_joint",
    "spectrum_from_welch",
    "information_bandwidth",
    "decimate_segments",
    "Decimation",
    "information_rate",
    "ResidualSpectra",
    "residual_spectra",
]


def z_two_sided(level: float) -> float:
    """z = Φ⁻¹((1 + level)/2): the half-width, in standard deviations, of a two-sided band.

    Below level 0.5, ``(1 + level)/2`` rounds away the level's digits (to exactly 0.5, z = 0, for
    level 1e-300); there z = √2·erfinv(level), exact for a tiny level (z ≈ √(π/2)·level).
    """
    if level < 0.5:
        return float(math.sqrt(2.0) * scipy.special.erfinv(level))
    return float(scipy.stats.norm.ppf(0.5 * (1.0 + level)))


def iid_t_test(mean: ArrayLike, std: ArrayLike, n: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Two-sided one-sample Student t-test of zero mean; returns ``(t, pvalue)`` arrays.

    ``n`` may be an array (an effective sample size); the degrees of freedom are ``n − 1``.
    A zero standard deviation gives t = ±inf (p = 0) for a non-zero mean and nan for a zero one.
    """
    mean = np.asarray(mean, dtype=np.float64)
    std = np.asarray(std, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = mean * np.sqrt(n) / std
    return t, 2.0 * scipy.stats.t.sf(np.abs(t), n - 1.0)


def newey_west_bandwidth(n: int) -> int:
    """K = ⌊4(N/100)^(2/9)⌋, at most N − 1 (contract §3.3)."""
    return int(min(math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0)), n - 1))


def newey_west_n_eff(rho: np.ndarray, bandwidth: int, n: int) -> np.ndarray:
    """The zero-mean test's effective sample size from ρ̂ at lags 0..K_used (rows) per joint:
    N/(1 + 2 Σ_ℓ (1 − ℓ/(K+1)) ρ̂_ℓ), clipped to [2, N]; N where the sum is ≤ 0 or not a number
    (contract §3.3). Lags past the longest segment are absent: their ρ̂ is 0 and adds nothing."""
    k_used = rho.shape[0] - 1
    weights = 1.0 - np.arange(1, k_used + 1) / (bandwidth + 1.0)
    total = weights @ rho[1:] if k_used > 0 else np.zeros(rho.shape[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        n_eff = np.clip(n / (1.0 + 2.0 * total), 2.0, float(n))
        return np.where(np.isnan(total) | (total <= 0), float(n), n_eff)


def holm(pvalues) -> np.ndarray:
    """Holm's step-down adjusted p-values (Holm 1979), same shape as the input.

    Controls the family-wise error rate at α for any dependence between the tests: reject
    every test whose adjusted p-value is ≤ α. NaN p-values are not tests: they stay NaN and do
    not count in the family size.

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03]).tolist()
    [0.03, 0.06, 0.06]
    """
    p = np.asarray(pvalues, dtype=np.float64)
    flat = p.reshape(-1)
    out = np.full_like(flat, np.nan)
    valid = np.flatnonzero(~np.isnan(flat))
    k = valid.size
    if k:
        order = valid[np.argsort(flat[valid], kind="stable")]
        scaled = flat[order] * (k - np.arange(k))
        out[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return out.reshape(p.shape)


# Memory of the transforms of one batch of columns in acf_fft.
_FFT_BATCH_BYTES = 64 * 2**20


# Up to this many lags the lagged products are summed directly (one dot product per column and
# lag, O(N·max_lag)); two transforms of length N cost more than that. The Newey–West effective
# sample size asks for lag 1 twice per report: at N = 2,000,000 × 7, 0.88 s by FFT against 0.10 s
# direct, and the whole long_run_variance 2.73 s against 0.62 s (best of 3, one run).
_DIRECT_LAGS = 8


def _lag_products(xc, bounds, max_lag: int) -> np.ndarray:
    """Σ x_t·x_{t−ℓ} of each column of ``xc`` (N, k), ℓ = 0..max_lag, no pair across two segments."""
    cols = np.ascontiguousarray(xc.T)  # one contiguous run per column for each dot product
    acov = np.zeros((max_lag + 1, cols.shape[0]))
    for a, b in zip(bounds[:-1], bounds[1:]):
        for lag in range(min(max_lag, b - a - 1) + 1):
            for j, col in enumerate(cols):
                acov[lag, j] += np.dot(col[a + lag:b], col[a:b - lag])
    return acov


def _pow2_scaled_columns(x: np.ndarray) -> np.ndarray:
    """x·2^-k per column, k the exponent (``np.frexp``) of the column's largest |x| (0 for a column
    of zeros or none): a new array, exactly ``np.ldexp``'s values."""
    largest = np.maximum(x.max(axis=0), -x.min(axis=0)) if x.shape[0] else np.zeros(x.shape[1])
    exps = np.where((largest > 0) & np.isfinite(largest), np.frexp(largest)[1], 0).astype(np.int64)
    if np.all(np.abs(exps) < 1000):
        return x * np.ldexp(1.0, -exps)  # 2^-k is a normal number: the same exact products, faster
    return np.ldexp(x, -exps)


# Above this many columns acf_fft looks for columns of zeros before transforming.
_ZERO_TEST_COLUMNS = 32


def acf_fft(x, starts, max_lag: int, *, centre: bool = True, live: np.ndarray | None = None) -> np.ndarray:
    """Biased autocorrelation ρ̂(0..max_lag) of every column of ``x`` (N, k), by FFT beyond a
    few lags.

    Means are overall (one per column), products never join two segments (contract §1.1), the
    denominator is N at every lag. A constant column gives nan. ``scipy.fft`` makes long lags
    cheap: O(N log N) per column instead of O(N·max_lag); up to ``_DIRECT_LAGS`` lags the
    products are summed directly. ``live``: the columns that are not all zeros, when the caller
    knows them (found here otherwise); the others are nan without a transform.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n, k = x.shape
    bounds = list(np.asarray(starts, dtype=np.int64)) + [n]
    live = _live_columns(x, live)
    every = live.size == k
    # the live columns' sums side by side: each batch adds to a slice of them, not to scattered
    # columns of the whole (lags, k) array (a gather, an addition and a scatter per batch)
    acov = np.zeros((max_lag + 1, live.size))
    for done, xc, workers in _scaled_batches(x, live, centre):
        if max_lag <= _DIRECT_LAGS:
            acov[:, done] = _lag_products(xc, bounds, max_lag)
            continue
        for a, b in zip(bounds[:-1], bounds[1:]):
            length = b - a
            size = _transform_size(length, max_lag)
            spec = scipy.fft.rfft(xc[a:b], n=size, axis=0, workers=workers)
            power = spec.real**2 + spec.imag**2
            del spec
            r = scipy.fft.irfft(power, n=size, axis=0, workers=workers)
            keep = min(max_lag + 1, length)
            acov[:keep, done] += r[:keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = acov / acov[0]
    rho[:, ~(acov[0] > 0)] = np.nan
    if every:
        return rho
    out = np.full((max_lag + 1, k), np.nan)
    out[:, live] = rho
    return out


def _live_columns(x: np.ndarray, live: np.ndarray | None) -> np.ndarray:
    """``live`` when given, else the columns of x that are not all zeros (looked for only where many
    may be: a regressor, not a residual)."""
    if live is not None:
        return live
    n, k = x.shape
    # A column of zeros (common in a regressor: a link's parameters do not act on the joints
    # before it) is zero once centred too: its ρ is nan without a transform.
    return (np.flatnonzero((x.max(axis=0) != 0) | (x.min(axis=0) != 0)) if n and k > _ZERO_TEST_COLUMNS
            else np.arange(k))


def _transform_size(length: int, max_lag: int) -> int:
    """Zero padding to length + max_lag keeps the circular wrap-around out of the lags kept."""
    return int(scipy.fft.next_fast_len(length + min(max_lag, length - 1), real=True))


def _scaled_batches(x: np.ndarray, live: np.ndarray, centre: bool, scale: bool = True):
    """The live columns of x in batches, each less its overall mean (``centre``) and scaled by a
    power of two (``scale``): (the batch's slice of ``live``, its columns (N, batch), the FFT's
    workers)."""
    n, k = x.shape
    every = live.size == k
    # Columns in batches: a transform holds about 6 numbers per sample and column, so the whole
    # (N, k) regressor at once would need several times its own size (tests/test_memory.py).
    batch = max(1, _FFT_BATCH_BYTES // (48 * max(n, 1)))
    means = x.mean(axis=0) if centre else None  # one pass over the rows, not one per batch
    # the columns of a batch are transformed apart, on the core's threads when they are many
    workers = min(worker_count(n * min(batch, live.size)), max(1, min(batch, live.size)))
    for c0 in range(0, live.size, batch):
        done = slice(c0, min(c0 + batch, live.size))
        xc = _centred_columns(x, slice(c0, min(c0 + batch, k)) if every else live[done], means)
        # ρ is a ratio: each column scaled by a power of two first (exact, contract §1.3), so that
        # no square underflows near 1e-160 (the compiled kernel scales, and the two must agree).
        yield done, _pow2_scaled_columns(xc) if scale else xc, workers


@dataclass(frozen=True)
class ColumnPowers:
    """The regressor's half of the colour-aware band (:func:`colour_aware_sd`) in the frequency
    domain: per segment, the power |X(f)|² of each live column's centred values (scaled by a power
    of two), zero-padded to ``sizes`` as :func:`acf_fft` pads them for ``big`` lags, and each
    column's lag-0 sum. Σ_j ρ_e(j) w_j ρ_y(j) over j = 1..J is then Σ_f Re G(f)·|X(f)|² / size
    over the transform's bins (G the transform of the residual's weighted lags), divided by the lag-0
    sum: one transform per joint and residual, where the lag domain needs every column's inverse
    transform (docs/conventions.md §6, the regressor's shared factorisation). A prepared
    regressor keeps it."""

    shape: tuple[int, int, int]  # (J + 1, m, p): the lags and the regressor's joints and columns
    live: np.ndarray  # the live columns (flattened m·p index), ascending
    lengths: tuple[int, ...]  # each segment's rows
    powers: tuple[np.ndarray, ...]  # each segment's (size/2 + 1, live) powers
    lag0: np.ndarray  # (live,): each column's Σ of squares, summed over segments

    def weighted_sums(self, rho_e: np.ndarray) -> np.ndarray:
        """Σ_{j=1..J} ρ_e(j)·w_j·ρ_y(j) per joint and column (m, p): ``rho_e`` (J + 1, m), nan
        as 0; a constant column's ρ_y (nan) as 0, as :func:`weighted_column_acf`."""
        big, m, p = self.shape[0] - 1, self.shape[1], self.shape[2]
        w = 1.0 - np.arange(1, big + 1) / (big + 1.0)
        joint = self.live // p
        total = np.zeros(self.live.size)
        for length, power in zip(self.lengths, self.powers):
            size = _transform_size(length, big)
            keep = min(big + 1, length)
            g = np.zeros((size, m))
            g[1:keep] = rho_e[1:keep] * w[:keep - 1, None]
            kernel = scipy.fft.rfft(g, axis=0).real
            kernel[1:(size + 1) // 2] *= 2.0  # the bins of the spectrum's other half
            kernel /= size
            for j in range(m):
                cols = np.flatnonzero(joint == j)
                if cols.size:
                    lo, hi = int(cols[0]), int(cols[-1]) + 1  # the live columns of a joint are consecutive
                    total[lo:hi] += kernel[:, j] @ power[:, lo:hi]
        out = np.zeros(m * p)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[self.live] = np.where(self.lag0 > 0, total / self.lag0, 0.0)
        return out.reshape(m, p)


def column_powers(x: np.ndarray, starts, big: int, m: int, live: np.ndarray | None = None,
                  largest: np.ndarray | None = None) -> ColumnPowers:
    """:class:`ColumnPowers` of the regressor's columns x (N, m·p) for ``big`` colour lags.
    ``largest``: each column's largest |x| when known; where every live column's lies within
    2^±300, no sum can underflow or overflow, and the columns are transformed unscaled: the same
    ratios, bit for bit, as scaled by powers of two (every product and sum is scaled exactly)."""
    x = np.asarray(x, dtype=np.float64)
    n, k = x.shape
    bounds = list(np.asarray(starts, dtype=np.int64)) + [n]
    live = _live_columns(x, live)
    lengths = [b - a for a, b in zip(bounds[:-1], bounds[1:])]
    powers = [np.empty((_transform_size(length, big) // 2 + 1, live.size)) for length in lengths]
    lag0 = np.zeros(live.size)
    scale = largest is None or not np.all((largest[live] >= 2.0**-300) & (largest[live] <= 2.0**300))
    for done, xc, workers in _scaled_batches(x, live, True, scale):
        for s, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
            # Each column zero-padded as a contiguous row: pocketfft transforms rows about three times
            # faster than the columns of an (N, batch) array, with the same arithmetic on each series.
            rows = np.zeros((xc.shape[1], _transform_size(b - a, big)))
            rows[:, :b - a] = xc[a:b].T
            spec = scipy.fft.rfft(rows, axis=1, workers=workers)
            power = powers[s][:, done].T
            np.multiply(spec.real, spec.real, out=power)
            power += spec.imag * spec.imag
            lag0[done] += np.einsum("ij,ij->j", xc[a:b], xc[a:b])
    return ColumnPowers((big + 1, m, k // m), live, tuple(lengths), tuple(powers), lag0)


def _centred_columns(x: np.ndarray, cols: slice | np.ndarray, means: np.ndarray | None) -> np.ndarray:
    """x[:, cols] less the columns' means (``means`` None: as they are), taking each run of
    consecutive indices of ``cols`` as a slice, so that the columns are read once, in place, rather
    than gathered into a copy that is then subtracted from (a regressor's live columns come in a
    few runs per joint). The same values as ``x[:, cols] - means[cols]``."""
    if isinstance(cols, slice):
        return x[:, cols] - means[cols] if means is not None else x[:, cols]
    out = np.empty((x.shape[0], cols.size))
    for lo, hi, a, b in runs(cols):
        if means is not None:
            np.subtract(x[:, a:b], means[a:b], out=out[:, lo:hi])
        else:
            out[:, lo:hi] = x[:, a:b]
    return out


def andrews_bandwidth(phi, n: int) -> np.ndarray:
    """Andrews (1991) AR(1) plug-in bandwidth of the Bartlett kernel, 1.1447·(α(1)·N)^(1/3).

    α(1) = 4φ²/((1 − φ)²(1 + φ)²); the result is the integer number of lags L whose weights
    1 − j/(L + 1) the Bartlett (Newey–West) estimator uses.
    """
    phi = np.clip(np.asarray(phi, dtype=np.float64), -0.999, 0.999)
    alpha = 4.0 * phi**2 / ((1.0 - phi) ** 2 * (1.0 + phi) ** 2)
    with np.errstate(invalid="ignore"):
        s = 1.1447 * (alpha * n) ** (1.0 / 3.0)
    return np.where(np.isfinite(s), np.floor(s), 0).astype(np.int64)


@dataclass(frozen=True)
class LongRunVariance:
    """Long-run variance of each joint's residual and the effective sample size it implies.

    Attributes (all ``(m,)``): ``variance`` (biased, over N), ``long_run_variance`` (2π times the
    spectral density at zero: the variance of √N·ē), ``n_eff`` = N·variance/long_run_variance,
    clipped to [2, N], ``phi`` (the AR(1) prewhitening coefficient), ``bandwidth`` (Bartlett lags
    used on the prewhitened series).
    """

    variance: np.ndarray
    long_run_variance: np.ndarray
    n_eff: np.ndarray
    phi: np.ndarray
    bandwidth: np.ndarray
    method: str = "andrews_monahan"


class ZeroMean(NamedTuple):
    """The zero-mean test's fields (contract §3.3, ``ZeroMeanTest``'s order); the
    autocorrelation-corrected half is None where it is not computed (no lag analysis)."""

    mean: FloatArray
    std: FloatArray
    n_samples: int
    statistic_iid: FloatArray
    pvalue_iid: FloatArray
    df_iid: int
    statistic_eff: FloatArray | None = None
    pvalue_eff: FloatArray | None = None
    df_eff: FloatArray | None = None
    n_eff: FloatArray | None = None
    bandwidth: int | None = None


def iid_zero_mean(mean: ArrayLike, variance: ArrayLike, n: int, ddof: int) -> ZeroMean:
    """The i.i.d. half of the zero-mean test from the residual's mean and variance (``ddof``).

    Without a lag analysis the autocorrelation-corrected half (which needs the autocorrelation up
    to the Newey–West bandwidth) is left out.
    """
    mean = np.asarray(mean, dtype=np.float64)
    std = np.sqrt(np.asarray(variance, dtype=np.float64) * ((n - ddof) / (n - 1.0)))
    t_iid, p_iid = iid_t_test(mean, std, n)
    return ZeroMean(mean, std, int(n), t_iid, p_iid, int(n - 1))


class BiasTest(NamedTuple):
    """The residual mean against its coloured-noise standard error (:func:`bias_t_test`), each
    joint's values (m,) in the residual's units."""

    mean: FloatArray
    std: FloatArray
    standard_error: FloatArray
    statistic: FloatArray
    pvalue: FloatArray
    long_run: LongRunVariance
    parameter_standard_error: FloatArray | None  # with the estimated parameters' variance only


def bias_t_test(mean: FloatArray, lr: LongRunVariance, n: int, parameter_variance: FloatArray | None = None,
                exponents: np.ndarray | None = None) -> BiasTest:
    """The bias test from each joint's mean and long-run variance ``lr``.

    Student t with N_eff − 1 degrees of freedom on the total standard error: the noise's s²/N_eff
    plus ``parameter_variance`` (m,), the variance the mean gets from the estimated parameters.
    ``exponents`` (m,): ``mean`` and ``lr`` are in units 2^k of each joint (a stream's sums,
    contract §4.1); the test does not see the unit, the returned mean and errors are unscaled.
    """
    std = np.sqrt(lr.variance * n / max(n - 1, 1))
    noise_var = std**2 / lr.n_eff
    total_var = noise_var if parameter_variance is None else noise_var + parameter_variance
    # The t statistic on the total standard error, N_eff − 1 degrees of freedom kept (conservative).
    t, p = iid_t_test(mean, np.sqrt(total_var * lr.n_eff), lr.n_eff)
    k = np.zeros(np.shape(mean), dtype=np.int64) if exponents is None else np.asarray(exponents)
    mean, std, standard_error = np.ldexp(mean, k), np.ldexp(std, k), np.ldexp(np.sqrt(total_var), k)
    parameter_se = None if parameter_variance is None else np.sqrt(parameter_variance)
    return BiasTest(mean, std, standard_error, t, p, lr, parameter_se)


def residual_bias_test(e: FloatArray, starts, parameter_variance: FloatArray | None = None) -> BiasTest:
    """:func:`bias_t_test` of a residual (N, m), its long-run variance by :func:`long_run_variance`.

    Each joint is scaled by the power of two of its largest |e| first (contract §1.3): the squares
    of a residual near 1e-200 would underflow to a zero variance and an infinite t.
    """
    largest = np.max(np.abs(e), axis=0)
    exps = np.where((largest > 0) & np.isfinite(largest), np.frexp(largest)[1], 0).astype(np.int64)
    x = np.ldexp(e, -exps[None])
    if parameter_variance is not None:
        parameter_variance = np.ldexp(parameter_variance, -2 * exps)
    out = bias_t_test(x.mean(axis=0), long_run_variance(x, starts), e.shape[0], parameter_variance, exponents=exps)
    if out.parameter_standard_error is not None:
        out = out._replace(parameter_standard_error=np.ldexp(out.parameter_standard_error, exps))
    return out


def _segment_lag_pairs(x, starts, lag: int):
    """Rows (k, k − lag) of ``x`` inside the same segment."""
    n = x.shape[0]
    keep = np.ones(n, dtype=bool)
    for s in np.asarray(starts, dtype=np.int64):
        keep[s:s + lag] = False
    keep[:lag] = False
    idx = np.flatnonzero(keep)
    return x[idx], x[idx - lag], idx


def bartlett_long_run_variance(x, starts, bandwidth) -> np.ndarray:
    """Newey–West estimate γ₀ + 2 Σ_{j≤L} (1 − j/(L + 1)) γ_j of each column of an already
    centred ``x`` (N, m), with per-column ``bandwidth`` L; γ_j over N, no lag across segments.
    With one segment it equals statsmodels' ``S_hac_simple(x, nlags=L)``.
    """
    x = np.asarray(x, dtype=np.float64)
    n, m = x.shape
    bandwidth = np.broadcast_to(np.asarray(bandwidth, dtype=np.int64), (m,))
    gamma0 = (x**2).sum(axis=0) / n
    rho = acf_fft(x, starts, int(bandwidth.max()), centre=False)
    out = np.empty(m)
    for j in range(m):
        lags = np.arange(1, bandwidth[j] + 1)
        w = 1.0 - lags / (bandwidth[j] + 1.0)
        out[j] = gamma0[j] * (1.0 + 2.0 * float(np.nansum(w * rho[1:bandwidth[j] + 1, j])))
    return out


def long_run_variance(e, starts) -> LongRunVariance:
    """Prewhitened Bartlett (Newey–West) long-run variance with an automatic bandwidth.

    The estimator of Andrews & Monahan (1992): fit an AR(1) coefficient φ̂ per joint (lag-1
    biased autocorrelation, |φ̂| ≤ 0.999), prewhiten u_k = x_k − φ̂x_{k−1} inside each segment,
    estimate the long-run variance of u with Bartlett weights 1 − j/(L + 1) and Andrews'
    (1991) AR(1) plug-in bandwidth L, and recolour: LRV_x = LRV_u/(1 − φ̂)². For an AR(1)
    residual with coefficient ρ this gives N_eff ≈ N(1 − ρ)/(1 + ρ). Means are overall; no lag
    joins two segments. A constant residual gives n_eff = N.
    """
    x = np.asarray(e, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n, m = x.shape
    xc = x - x.mean(axis=0)
    variance = (xc**2).sum(axis=0) / n
    rho1 = acf_fft(xc, starts, 1, centre=False)[1] if n > 1 else np.full(m, np.nan)
    phi = np.clip(np.nan_to_num(rho1, nan=0.0), -0.999, 0.999)
    cur, prev, idx = _segment_lag_pairs(xc, starts, 1)
    u = cur - phi * prev
    nu = u.shape[0]
    # Segment starts of u: the rows kept after removing each segment's first row.
    if nu:
        new_starts = np.flatnonzero(np.diff(idx, prepend=-2) != 1)
    else:
        new_starts = np.array([0])
    lrv_u = np.full(m, np.nan)
    bandwidth = np.zeros(m, dtype=np.int64)
    if nu >= 2:
        uc = u - u.mean(axis=0)
        rho_u1 = acf_fft(uc, new_starts, 1, centre=False)[1]
        lengths = np.diff(np.append(new_starts, nu))
        bandwidth = np.minimum(andrews_bandwidth(np.nan_to_num(rho_u1), nu), int(lengths.max()) - 1)
        bandwidth = np.maximum(bandwidth, 0)
        lrv_u = bartlett_long_run_variance(uc, new_starts, bandwidth)
    with np.errstate(divide="ignore", invalid="ignore"):
        lrv = lrv_u / (1.0 - phi) ** 2
        n_eff = n * variance / lrv
    n_eff = np.where(np.isfinite(n_eff) & (variance > 0), np.clip(n_eff, 2.0, float(n)), float(n))
    return LongRunVariance(variance=variance, long_run_variance=lrv, n_eff=n_eff, phi=phi,
                           bandwidth=bandwidth)


def long_run_variance_from_sums(cov, pairs, n: int, cur1, lag1, longest: int, starts=None,
                                ends=None) -> tuple[LongRunVariance | None, int]:
    """:func:`long_run_variance` from lagged sums, as a stream keeps them (contract §4.1).

    ``cov`` (K+1, m): Σ x_t x_{t−ℓ} over the lag-ℓ pairs inside segments, x centred on the overall
    mean, ℓ = 0..K; ``pairs`` (K+1,) their counts; ``cur1``, ``lag1`` (m,): Σ x over the current and
    over the lagged elements of the lag-1 pairs; ``longest``: the longest segment's length;
    ``starts`` = (S, H), S_j = Σ x_{s+j}x_s and H_j = Σ x_{s+j} over the segment starts s known, and
    ``ends`` = (E, T), E_j = Σ x_{E−1}x_{E−1−j} and T_j = Σ x_{E−1−j} over the segment ends known
    (each (≥ K rows, m), x centred; None: none known), of segments longer than K.

    The prewhitened u_t = x_t − φ̂x_{t−1} (t past each segment's first row) has the lagged sums
    Σ u_t u_{t−j} = (1 + φ̂²)P_j − φ̂(P_{j+1} + P_{|j−1|}) less a few products at each segment's first
    and last rows: with every start and end known the estimate is the whole series' to rounding; an
    end not known (a segment not longer than K, or one a stream did not keep) leaves its products
    out, O(j/N) of the sums (docs/conventions.md §5.4). Lag j of u
    needs lag j + 1 of x: returns ``(None, L + 1)`` when the bandwidth L that Andrews' rule picks
    needs more than the K lags held, else ``(estimate, L + 1)``.
    """
    cov = np.asarray(cov, dtype=np.float64)
    pairs = np.asarray(pairs, dtype=np.float64)
    held, m = cov.shape[0] - 1, cov.shape[1]
    variance = cov[0] / n
    with np.errstate(divide="ignore", invalid="ignore"):
        rho1 = cov[1] / cov[0] if held >= 1 and n > 1 else np.full(m, np.nan)
    phi = np.clip(np.nan_to_num(rho1, nan=0.0), -0.999, 0.999)
    nu = int(pairs[1]) if held >= 1 else 0
    bandwidth = np.zeros(m, dtype=np.int64)
    lrv_u = np.full(m, np.nan)
    needed = 2
    if nu >= 2:
        if held < 2:
            return None, needed
        edges = _EndTerms(phi, starts, ends)
        u_total = np.asarray(cur1) - phi * np.asarray(lag1)
        u_mean = u_total / nu

        def gamma_u(j: np.ndarray) -> np.ndarray:
            """Σ(u_t − ū)(u_{t−j} − ū) over u's lag-j pairs, j = 0..J (rows)."""
            raw = (1.0 + phi**2) * cov[j] - phi * (cov[j + 1] + cov[np.abs(j - 1)]) + edges.products(j)
            cur, lag = edges.sums(j, u_total)
            return raw - u_mean * (cur + lag) + pairs[j + 1][:, None] * u_mean**2

        head_sums = gamma_u(np.arange(2))
        with np.errstate(divide="ignore", invalid="ignore"):
            rho_u1 = head_sums[1] / head_sums[0]
        bandwidth = np.maximum(np.minimum(andrews_bandwidth(np.nan_to_num(rho_u1), nu), longest - 2), 0)
        needed = int(bandwidth.max()) + 1
        if needed > held:
            return None, needed
        g = gamma_u(np.arange(needed))
        lrv_u = np.empty(m)
        for j in range(m):
            lags = np.arange(1, bandwidth[j] + 1)
            w = 1.0 - lags / (bandwidth[j] + 1.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                rho = g[1:bandwidth[j] + 1, j] / g[0, j]
            lrv_u[j] = g[0, j] / nu * (1.0 + 2.0 * float(np.nansum(w * rho)))
    with np.errstate(divide="ignore", invalid="ignore"):
        lrv = lrv_u / (1.0 - phi) ** 2
        n_eff = n * variance / lrv
    n_eff = np.where(np.isfinite(n_eff) & (variance > 0), np.clip(n_eff, 2.0, float(n)), float(n))
    return LongRunVariance(variance=variance, long_run_variance=lrv, n_eff=n_eff, phi=phi, bandwidth=bandwidth), needed


class _EndTerms:
    """What the prewhitened sums of :func:`long_run_variance_from_sums` lose at segments' first rows
    x_s.. (``starts``: S_j = Σ x_{s+j}x_s, H_j = Σ x_{s+j}) and last rows ..x_{E−1} (``ends``:
    E_j = Σ x_{E−1}x_{E−1−j}, T_j = Σ x_{E−1−j}), u_t = x_t − φx_{t−1} for t > s.

    For lag j ≥ 1 the pairs of u miss x_{s+j}x_s and x_{E−1}x_{E−1−j} once and x_{s+j−1}x_s,
    x_{E−1}x_{E−j} with weight −φ; for j = 0, x_s² and φ²x_{E−1}². The sums of u over the current
    (lagged) elements of its lag-j pairs miss the first (last) j values of u at each segment."""

    def __init__(self, phi: np.ndarray, starts, ends) -> None:
        self.phi = phi
        self.starts = None if starts is None else tuple(np.asarray(a, dtype=np.float64) for a in starts)
        self.ends = None if ends is None else tuple(np.asarray(a, dtype=np.float64) for a in ends)

    def products(self, j: np.ndarray) -> np.ndarray:
        phi, out = self.phi, np.zeros((j.size, self.phi.size))
        later = j >= 1
        if self.starts is not None:
            s = self.starts[0]
            out -= s[j]
            out[later] += phi * s[j[later] - 1]
        if self.ends is not None:
            e = self.ends[0]
            out[~later] -= phi**2 * e[0]
            out[later] += phi * e[j[later] - 1] - phi**2 * e[j[later]]
        return out

    def sums(self, j: np.ndarray, total: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Σ u over the current and over the lagged elements of u's lag-j pairs."""
        cur = np.broadcast_to(total, (j.size, total.size)).copy()
        lag = cur.copy()
        top = int(j.max()) if j.size else 0
        if self.starts is not None and top:
            h = self.starts[1]
            u = h[1:top + 1] - self.phi * h[:top]  # Σ u_{s+1}, ..., Σ u_{s+top}
            cur -= np.vstack([np.zeros((1, total.size)), np.cumsum(u, axis=0)])[j]
        if self.ends is not None and top:
            t = self.ends[1]
            u = t[:top] - self.phi * t[1:top + 1]  # Σ u_{E−1}, Σ u_{E−2}, ...
            lag -= np.vstack([np.zeros((1, total.size)), np.cumsum(u, axis=0)])[j]
        return cur, lag


def score_covariance(x, e, starts=None) -> np.ndarray:
    """Var(Σ_k Σ_j x_kj e_kj) for fixed columns x (N, m, p) and a coloured noise e (N, m).

    Σ_j X_jᵀ Γ_j X_j, Γ_j the covariance matrix of joint j's noise, estimated as
    :func:`long_run_variance` does for a mean, by prewhitening (Andrews & Monahan 1992): with
    u = e − φ̂ e₋₁, Γ = (I − φ̂L)⁻¹ Γ_u (I − φ̂L)⁻ᵀ, so XᵀΓX = X̃ᵀ Γ_u X̃ with X̃ the columns run
    backwards through the AR(1) filter 1/(1 − φ̂z) (``scipy.signal.lfilter``), and Γ_u the
    Toeplitz matrix of u's biased autocovariances with Bartlett weights 1 − |ℓ|/(L + 1) and
    Andrews' (1991) bandwidth L (positive semi-definite). Γ_u X̃ is one FFT convolution per column.
    This is the "meat" of the least-squares sandwich (XᵀX)⁻¹ · this · (XᵀX)⁻¹ when the regressor
    is a known function of the trajectory and only the noise is random; joints are taken as
    uncorrelated with each other. One segment.
    """
    x = np.asarray(x, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    n, m, p = x.shape
    out = np.zeros((p, p))
    if n < 3:
        return np.einsum("nmp,nm,nmq->pq", x, e**2, x)
    lr = long_run_variance(e, np.array([0]))
    for j in range(m):
        # Kendall's (1954) first-order bias correction of the AR(1) estimate: near φ = 1 the
        # recolouring 1/(1 − φ)² is very sensitive to φ̂'s downward bias of about (1 + 3φ)/N.
        phi = float(np.clip(lr.phi[j] + (1.0 + 3.0 * lr.phi[j]) / n, -0.999, 0.999))
        u = e[1:, j] - phi * e[:-1, j]
        lag = int(min(max(int(lr.bandwidth[j]), 1), u.size - 1))
        gamma = acf_fft(u[:, None], np.array([0]), lag, centre=False)[:, 0] * (u @ u / u.size)
        g = np.nan_to_num(gamma) * (1.0 - np.arange(lag + 1) / (lag + 1.0))
        xt = scipy.signal.lfilter([1.0], [1.0, -phi], x[::-1, j, :], axis=0)[::-1][1:]
        kernel = np.concatenate([g[:0:-1], g])[:, None]
        out += xt.T @ scipy.signal.fftconvolve(xt, kernel, mode="same", axes=0)
    return 0.5 * (out + out.T)


def cross_correlation_sd(rho_e, rho_y, n_lag, d_lag, n: int) -> np.ndarray:
    """Standard deviation of ρ̂_eY(ℓ) under independence, accounting for both series' colour.

    Bartlett's formula: var ρ̂_xy(ℓ) ≈ (1/N)·Σ_j ρ_xx(j)ρ_yy(j) (Box, Jenkins & Reinsel,
    Time Series Analysis, §11.1.3), the sum over j = −J..J with Bartlett weights
    1 − |j|/(J + 1), floored at the white value 1 (a colour never makes the estimate more
    precise than white data here). ``rho_e`` is (J+1, m), ``rho_y`` (J+1, m, p); the lag factor
    √n_ℓ/D_ℓ of the white case (n_ℓ products over the denominator D_ℓ) scales it per lag.
    Returns (m, p, L+1).
    """
    return colour_aware_sd(rho_e, weighted_column_acf(rho_y), n_lag, d_lag)


def weighted_column_acf(rho_y) -> np.ndarray:
    """The regressor's half of :func:`cross_correlation_sd`'s sum: w_j·ρ_yy(j), j = 1..J, with
    Bartlett's weights w_j = 1 − j/(J + 1) and nan (a constant column) as 0; (J, m, p). It does not
    depend on the residual: a prepared regressor keeps it."""
    rho_y = np.asarray(rho_y, dtype=np.float64)
    big = rho_y.shape[0] - 1
    w = 1.0 - np.arange(1, big + 1) / (big + 1.0)
    return np.nan_to_num(rho_y[1:]) * w[:, None, None]


def colour_aware_sd(rho_e, weighted_y, n_lag, d_lag) -> np.ndarray:
    """:func:`cross_correlation_sd` from the regressor's half :func:`weighted_column_acf` (or its
    transforms, :func:`column_powers`)."""
    rho_e = np.nan_to_num(np.asarray(rho_e, dtype=np.float64))
    sums = (weighted_y.weighted_sums(rho_e) if isinstance(weighted_y, ColumnPowers)
            else np.einsum("jm,jmp->mp", rho_e[1:], weighted_y))
    colour = 1.0 + 2.0 * sums
    colour = np.maximum(colour, 1.0)
    white = np.sqrt(np.asarray(n_lag, dtype=np.float64)) / np.asarray(d_lag, dtype=np.float64)
    return np.sqrt(colour)[:, :, None] * white[None, None, :]


def correlation_pvalue(rho, sd):
    """Two-sided p-value of a sample correlation whose null standard deviation is ``sd``.

    The effective number of samples ν = 1/sd² (for white series sd = 1/√N gives ν = N) enters the
    usual t test of a correlation, t = ρ√(ν − 2)/√(1 − ρ²) with ν − 2 degrees of freedom (the
    effective-degrees-of-freedom correction of Pyper & Peterman 1998 for autocorrelated series):
    with few effective samples its tails are heavier than the normal's.
    """
    rho = np.asarray(rho, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        nu = np.maximum(1.0 / np.asarray(sd, dtype=np.float64) ** 2 - 2.0, 1.0)
        t = np.abs(rho) * np.sqrt(nu) / np.sqrt(np.maximum(1.0 - rho**2, 1e-300))
    return 2.0 * scipy.stats.t.sf(t, nu)


@dataclass(frozen=True)
class Spectrum:
    """Welch estimate of each joint's residual power spectral density, with a test per bin.

    ``frequency`` (F,) in Hz when the sample rate is known, else in cycles per sample;
    ``power`` (F, m); ``dof`` the equivalent χ² degrees of freedom of one bin. Per bin and joint
    (F, m): ``ratio`` to the local background, ``pvalue`` of that ratio (nan where not tested),
    ``share`` of the residual variance in a peak centred there above the background, and
    ``is_peak`` (a local maximum). ``peaks``: the tested local maxima as dicts.
    """

    frequency: np.ndarray
    power: np.ndarray
    dof: float
    nperseg: int
    ratio: np.ndarray
    pvalue: np.ndarray
    share: np.ndarray
    is_peak: np.ndarray
    peaks: list


def _welch_dof(n_segments: int) -> float:
    # 50 % overlapping Hann windows: neighbouring segments correlate with c = 0.1667
    # (Welch 1967; Percival & Walden 1993, eq. 292b), which lowers 2K degrees of freedom.
    if n_segments <= 1:
        return 2.0
    return 2.0 * n_segments / (1.0 + 2.0 * (1.0 - 1.0 / n_segments) * 0.1667**2)


def _side_medians(logp, inner: int, outer: int):
    """Running medians of ``logp`` (F,) or (F, m), per column, over bins b−outer..b−inner and
    b+inner..b+outer.

    Near the ends a side keeps the bins that exist; a side with fewer than three is nan. Inside,
    one sliding-window median serves both sides; only the ``outer`` bins at each end, where a side
    is cut short, take medians of their own (of every column at once).
    """
    f_count = logp.shape[0]
    width = outer - inner + 1
    left = np.full(logp.shape, np.nan)
    right = np.full(logp.shape, np.nan)
    if f_count > outer:  # then f_count ≥ width: full[i] is the median of bins i..i+width-1
        full = np.median(np.lib.stride_tricks.sliding_window_view(logp, width, axis=0), axis=-1)
        left[outer:] = full[:f_count - outer]
        right[:f_count - outer] = full[inner:f_count - outer + inner]
    for b in range(min(outer, f_count)):  # the left side reaches before bin 0
        if b - inner + 1 >= 3:
            left[b] = np.median(logp[:b - inner + 1], axis=0)
    for b in range(max(f_count - outer, 0), f_count):  # the right side reaches past the last bin
        if f_count - (b + inner) >= 3:
            right[b] = np.median(logp[b + inner:], axis=0)
    return left, right


def _rate_exponent(fs: float) -> int:
    """k with the Welch rate fs·2^-k in a range where a density per unit of rate cannot overflow.

    0 for every usual rate (results unchanged to the bit); for an extreme one (1e-308 Hz) the
    spectrum is computed at fs·2^-k and its frequencies and density scaled back exactly."""
    return 0 if 2.0 ** -500 < fs < 2.0 ** 500 else math.frexp(fs)[1]


def _welch(x, starts, fs, nperseg):
    """Welch power (F, m) averaged over segments weighted by their window counts, and the count."""
    n = x.shape[0]
    bounds = list(np.asarray(starts, dtype=np.int64)) + [n]
    total, windows, freq = None, 0, None
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a < nperseg:
            continue
        # scipy's windows: noverlap = nperseg // 2, so a step of nperseg - nperseg // 2 (8 for 15)
        k = 1 + (b - a - nperseg) // (nperseg - nperseg // 2)
        freq, pxx = scipy.signal.welch(x[a:b], fs=fs, window="hann", nperseg=nperseg,
                                       noverlap=nperseg // 2, detrend="constant", axis=0)
        total = pxx * k if total is None else total + pxx * k
        windows += k
    return freq, (None if total is None else total / windows), windows


def welch_pair(a, b, starts, *, sample_rate=None, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch power (F, m) of two series of the same shape on the residual spectrum's grid (the same
    segments, window and ``nperseg``): the measured torque and the prediction, whose powers at a
    residual's line say which of them carries it. Each joint of both is scaled by one power of two
    (exact; their ratio does not see it) and scaled back (IEEE where it leaves float64)."""
    x = np.asarray(a, dtype=np.float64).reshape(len(a), -1)
    y = np.asarray(b, dtype=np.float64).reshape(len(b), -1)
    fs = 1.0 if sample_rate is None else float(sample_rate)
    largest = np.fmax(np.max(np.abs(x), axis=0), np.max(np.abs(y), axis=0)) if x.shape[0] else np.zeros(x.shape[1])
    exps = np.where(np.isfinite(largest) & (largest > 0), np.frexp(largest)[1], 0).astype(np.int64)
    k = _rate_exponent(fs)
    _, px, _ = _welch(np.ldexp(x, -exps), starts, math.ldexp(fs, -k), nperseg)
    _, py, _ = _welch(np.ldexp(y, -exps), starts, math.ldexp(fs, -k), nperseg)
    if px is None or py is None:
        empty = np.zeros((0, x.shape[1]))
        return empty, empty
    with np.errstate(over="ignore", under="ignore"):
        return np.ldexp(px, 2 * exps - k), np.ldexp(py, 2 * exps - k)


def _default_nperseg(starts, n, nperseg):
    lengths = np.diff(list(np.asarray(starts, dtype=np.int64)) + [n])
    if nperseg is None:
        nperseg = int(min(1024, max(16, 2 ** int(math.floor(math.log2(max(lengths.max() // 8, 16)))))))
    return int(min(nperseg, lengths.max()))


def spectrum_tests_per_joint(starts, n: int, inner: int = 3, outer: int = 10) -> int:
    """How many bins :func:`residual_spectrum` tests on a joint whose residual varies, for N rows in
    segments starting at ``starts`` (0 when no segment holds a Welch window)."""
    nperseg = _default_nperseg(starts, n, None)
    f_count = nperseg // 2 + 1
    left, right = _side_medians(np.zeros(f_count), inner, outer)
    return int(np.count_nonzero(np.isfinite(left) & np.isfinite(right)))


def residual_spectrum(e, starts, *, sample_rate=None, nperseg: int | None = None,
                      inner: int = 3, outer: int = 10) -> Spectrum:
    """Welch spectrum of each joint's residual and the bins that stand above their neighbourhood.

    A lightly damped mode is a narrow line: it stands above the spectrum on **both** sides. The
    background of bin b is the larger of two running medians of the log power, over bins
    b−outer..b−inner and b+inner..b+outer (the peak's own window lobe excluded), divided by
    the median of χ²_ν/ν so that it estimates the mean level. An edge (a rise after a notch, the
    knee of a coloured spectrum) has one side at its own level and so no excess; under a smooth
    spectrum the ratio of a bin to this background is at most χ²_ν/ν-distributed, which gives each
    bin a (conservative) p-value. Bins with fewer than three neighbours on a side are not tested.
    Segments are analysed separately and their spectra averaged, weighted by their number of Welch
    windows; ``nperseg`` defaults to a power of two near N/8 (16..1024).
    """
    x = np.asarray(e, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n, m = x.shape
    fs = 1.0 if sample_rate is None else float(sample_rate)
    nperseg = _default_nperseg(starts, n, nperseg)
    # Each joint scaled by a power of two near its largest |e| (exact, contract §1.3): the
    # periodogram squares FFT sums that overflow near 1e140 and underflow near 1e-160. Ratios and
    # p-values do not see the scale; the power is scaled back (IEEE where it leaves float64).
    largest = np.max(np.abs(x), axis=0) if n else np.zeros(m)
    exps = np.where(largest > 0, np.frexp(largest)[1], 0).astype(np.int64)
    x = np.ldexp(x, -exps)
    k = _rate_exponent(fs)
    freq, power, windows = _welch(x, starts, math.ldexp(fs, -k), nperseg)
    return spectrum_from_welch(freq, power, windows, x.var(axis=0), exps, k, nperseg, inner=inner, outer=outer)


def spectrum_from_welch(freq, power, windows: int, variance, exps, k: int, nperseg: int, *, inner: int = 3,
                        outer: int = 10) -> Spectrum:
    """:func:`residual_spectrum` from the Welch power: ``freq`` (F,) at the rate fs·2^-k, ``power``
    (F, m) the mean window periodogram of x·2^-exps (None: no segment held a window), ``windows``
    their count, ``variance`` (m,) that of x·2^-exps. A stream sums the periodograms window by
    window (contract §4.1) and tests them here as ``validate`` does."""
    m = len(exps)
    if power is None:
        empty = np.zeros((0, m))
        return Spectrum(frequency=np.zeros(0), power=empty, dof=float("nan"), nperseg=nperseg, ratio=empty,
                        pvalue=empty, share=empty, is_peak=empty.astype(bool), peaks=[])
    dof = _welch_dof(windows)
    median_factor = scipy.stats.chi2.median(dof) / dof
    f_count = power.shape[0]
    ratio = np.full((f_count, m), np.nan)
    pvalue = np.full((f_count, m), np.nan)
    share = np.full((f_count, m), np.nan)
    is_peak = np.zeros((f_count, m), dtype=bool)
    df = freq[1] - freq[0] if f_count > 1 else 1.0
    # the joints with a spectrum to test (finite, not all zero, a residual that varies), together
    cols = np.flatnonzero(np.all(np.isfinite(power), axis=0) & (power.max(axis=0) > 0) & (variance > 0))
    if cols.size:
        pj = power[:, cols]
        left, right = _side_medians(np.log(np.maximum(pj, np.finfo(float).tiny)), inner, outer)
        tested = np.isfinite(left) & np.isfinite(right)
        background = np.exp(np.fmax(left, right)) / median_factor
        r = pj / background
        ratio[:, cols] = np.where(tested, r, np.nan)
        pvalue[:, cols] = np.where(tested, scipy.stats.chi2.sf(dof * np.where(tested, r, 0.0), dof), np.nan)
        before = np.vstack([np.full((1, cols.size), -np.inf), pj[:-1]])
        after = np.vstack([pj[1:], np.full((1, cols.size), -np.inf)])
        is_peak[:, cols] = tested & (pj >= before) & (pj >= after)
        excess = np.where(tested, np.maximum(pj - background, 0.0), 0.0) * df
        # A Hann-windowed line spreads over about three bins: sum the excess over ±2 bins.
        spread = 5.0 * scipy.ndimage.uniform_filter1d(excess, 5, axis=0, mode="constant") / variance[cols]
        share[:, cols] = np.where(tested, spread, np.nan)
    with np.errstate(over="ignore", under="ignore"):  # in the data's and the rate's units: IEEE where it leaves float64
        freq = np.ldexp(freq, k)
        power = np.ldexp(power, 2 * exps - k)
    bins, joints = np.nonzero(is_peak)  # row-major: by bin, then joint
    peaks = [{"joint": j, "frequency": f, "ratio": r, "pvalue": pv, "share": sh, "bin": b}
             for b, j, f, r, pv, sh in zip(bins.tolist(), joints.tolist(), freq[bins].tolist(),
                                            ratio[bins, joints].tolist(), pvalue[bins, joints].tolist(),
                                            share[bins, joints].tolist())]
    return Spectrum(frequency=freq, power=power, dof=dof, nperseg=nperseg, ratio=ratio, pvalue=pvalue,
                    share=share, is_peak=is_peak, peaks=peaks)


def information_bandwidth(tau, starts, *, fraction: float = 0.99, sample_rate=None) -> float:
    """Frequency below which ``fraction`` of the power of the (centred) measured torque lies.

    The largest over joints, in Hz when the sample rate is known, else in cycles per sample.
    It is the band that carries the robot's motion; above it, a residual's colour is what the
    sensor, its filters and the sampling make, not the model.
    """
    x = np.asarray(tau, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    fs = 1.0 if sample_rate is None else float(sample_rate)
    # Shares of power are scale-free: each joint scaled by a power of two first (contract §1.3).
    largest = np.maximum(x.max(axis=0), -x.min(axis=0)) if x.shape[0] else np.zeros(x.shape[1])
    x = np.ldexp(x, -np.where(largest > 0, np.frexp(largest)[1], 0).astype(np.int64))
    k = _rate_exponent(fs)
    freq, power, _ = _welch(x, starts, math.ldexp(fs, -k), _default_nperseg(starts, x.shape[0], None))
    if power is None:
        return float("nan")
    cum = np.cumsum(power, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        cum = cum / cum[-1]
    idx = [int(np.searchsorted(cum[:, j], fraction)) for j in range(cum.shape[1]) if np.isfinite(cum[-1, j])]
    if not idx:
        return float("nan")
    return math.ldexp(float(freq[min(max(idx), len(freq) - 1)]), k)


def decimate_segments(x, starts, factor: int):
    """Anti-alias filter and keep every ``factor``-th sample inside each segment.

    ``scipy.signal.decimate`` with its zero-phase FIR filter; segments shorter than 30·factor
    samples are dropped (the filter needs room). Returns the decimated array and its starts.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[0]
    bounds = list(np.asarray(starts, dtype=np.int64)) + [n]
    parts, new_starts, pos = [], [], 0
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a < 30 * factor:
            continue
        y = scipy.signal.decimate(x[a:b], factor, ftype="fir", axis=0, zero_phase=True)
        parts.append(y)
        new_starts.append(pos)
        pos += y.shape[0]
    if not parts:
        return None, None
    return np.concatenate(parts, axis=0), np.asarray(new_starts, dtype=np.int64)


class Decimation(NamedTuple):
    """The residual at the rate that carries information (:func:`information_rate`)."""

    factor: int  # q: every q-th sample kept (below 2: the logged rate only)
    band: float | None  # the information band f_I, with decimate="auto" (nan or 0: none found)
    residual: np.ndarray | None  # the decimated residual (None when q < 2 or every segment is too short)
    starts: np.ndarray | None  # its segments' starts


def information_rate(e, motion, starts, decimate, sample_rate=None, *, band: float | None = None,
                     bandwidth: float | None = None) -> Decimation:
    """The residual decimated to the rate that carries information, for the whiteness test there.

    ``decimate="auto"``: the information band f_I holds 99 % of the power of ``motion``, the
    noise-free side (the prediction, a function of the trajectory: the measured torque's sensor
    noise would fill the band on light joints and hide the motion's); the factor q = ⌊f_s/(4 f_I)⌋
    keeps a Nyquist frequency of at least 2 f_I (``band``: f_I when already known). ``bandwidth``
    (Hz): the inputs are trustworthy below it only, so "auto" decimates at least until the Nyquist
    frequency is at most the bandwidth. An integer is used as given; None or 1 keeps the logged rate.
    """
    fs = 1.0 if sample_rate is None else float(sample_rate)
    q = 1
    if decimate == "auto":
        if band is None:
            band = information_bandwidth(motion, starts, sample_rate=sample_rate)
        if np.isfinite(band) and band > 0:
            q = int(math.floor(min(fs / (4.0 * band), float(e.shape[0]))))
        if bandwidth is not None and fs / 2.0 > bandwidth:
            # a band far below the rate asks for more than the rows: capped before int
            q = max(q, int(math.ceil(min(fs / (2.0 * bandwidth), float(e.shape[0])))))
    else:
        band = None
        if decimate is not None:
            q = int(decimate)
    x, x_starts = decimate_segments(e, starts, q) if q >= 2 else (None, None)
    return Decimation(q, band, x, x_starts)


class ResidualSpectra(NamedTuple):
    """The residual's tested spectrum and, on its grid, the measured torque's and the prediction's
    Welch power (None without a spectrum)."""

    residual: Spectrum
    sides: tuple[np.ndarray, np.ndarray] | None


def residual_spectra(x, meas, pred, starts, *, sample_rate=None) -> ResidualSpectra:
    """:func:`residual_spectrum` of ``x`` (the residual less what the regressor explains) and
    :func:`welch_pair` of the measured torque and the prediction on its grid (conventions §5.2,
    ``prediction_artefact``: a line of the residual that the prediction holds and the measurement
    does not is the model's own)."""
    spec = residual_spectrum(x, starts, sample_rate=sample_rate)
    sides = None
    if len(spec.frequency):
        sides = welch_pair(meas, pred, starts, sample_rate=sample_rate, nperseg=int(spec.nperseg))
    return ResidualSpectra(spec, sides)
