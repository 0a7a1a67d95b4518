"""Periodic excitation measures its own noise: Pintelon & Schoukens' nonparametric noise model.

Robot excitation trajectories are usually periodic (finite Fourier series). When a validation run
holds P ≥ 2 whole periods, the residual of each period can be set beside the others: what all
periods share is the model's error (a periodic trajectory makes a periodic model error), what
changes from one period to the next is noise. At each harmonic k of the period the spread of the
P discrete Fourier coefficients estimates the noise level at that frequency, whatever its colour,
and the mean over periods is tested against it (Pintelon & Schoukens, *System Identification: A
Frequency Domain Approach*, 2nd ed. 2012, §2.5 and §6.4; Schoukens, Pintelon & Rolain 2012).

Two pure functions, and the report's section built on them:

* :func:`detect_period` finds the fundamental period of the joint positions q (sub-sample
  precision) and how many whole periods the run holds, or says the trajectory is not periodic;
* :func:`periodic_noise_test` splits the residual into those periods and returns, per joint, a
  p-value of "no periodic model error", the share of the residual's variance that is periodic model
  error beyond the noise, and the noise variance and spectrum the periods measure.

:func:`periodic_error_test` is the report's periodic section: the period, the residual cleared of
what the model's own columns represent, and the test (or why none runs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.fft
    import scipy.optimize
    import scipy.signal
    import scipy.stats
else:
    from .._lazy import scipy

from ..checks._errors import InvalidParameter, InvalidShape, NonFiniteInput, TooFewSamples
from ..checks._typing import ArrayLike, FloatArray
from ..checks._validation import format_value, is_real_number
from ._columns import unit_norm_columns

__all__ = ["Period", "PeriodicTest", "detect_period", "periodic_noise_test", "periodic_error_test"]

# A periodic signal's squared mismatch d(ℓ) = ‖q(t+ℓ) − q(t)‖²/‖q − q̄‖² averages 2 over the lags
# of one period (the autocorrelation of a zero-mean periodic signal averages 0 over a period). A
# period must follow lags where the trajectory has moved away from itself: the mean of d over the
# lags before it must reach this much. A random walk or a slow drift is close to itself at short
# lags (d ≈ 6ℓ/N for a random walk) without ever coming back, and fails here.
_MIN_MEAN_DIP = 1.0

# Candidate valleys refined before giving up (each refinement costs a few dozen passes over q).
_MAX_CANDIDATES = 25

# Rounding level of a sum of squares relative to its size (64 ulps, squared), and the smallest
# normal number, which keeps a zero sum from dividing by zero.
_EPS2 = (64.0 * np.finfo(np.float64).eps) ** 2
_TINY = np.finfo(np.float64).tiny


def _to_list(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


@dataclass(frozen=True)
class Period:
    """The fundamental period of a trajectory, from :func:`detect_period`.

    Attributes
    ----------
    samples : float
        The period T in samples (not necessarily an integer).
    seconds : float or None
        T / sample_rate, None without a sample rate.
    n_periods : int
        Whole periods in the run (≥ ``min_periods``).
    start : int
        First sample of the whole periods: they are the *last* ``n_periods`` periods of the run,
        so a start-up transient falls in the part left out. ``start = ⌊N − n_periods·T⌋``.
    mismatch : float
        Relative RMS mismatch ‖q(t+T) − q(t)‖ / ‖q − q̄‖ over the whole run (per-sample RMS,
        all joints together); below the ``tolerance`` it was detected with.
    method : str
        How T was found.
    """

    samples: float
    seconds: float | None
    n_periods: int
    start: int
    mismatch: float
    method: str

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain Python values (JSON-ready)."""
        return {f.name: _to_list(getattr(self, f.name)) for f in fields(self)}


@dataclass(frozen=True)
class PeriodicTest:
    """Pintelon & Schoukens' test of a periodic model error, from :func:`periodic_noise_test`.

    Ē_k and σ̂²_k below are the mean and the sample variance over the P periods of the DFT
    coefficient of harmonic k (each period on L points), taken from the prewhitened residual and
    divided by the filter's gain at that harmonic: in the data's units, without the leakage of
    noise slower than the period.

    Attributes
    ----------
    pvalue : ndarray (m,)
        Per joint, the p-value of "no periodic model error at the tested harmonics" (Fisher's
        combination of the harmonics' F tests); 1 for a joint without variation within the periods.
    statistic : ndarray (m,)
        Fisher's statistic −2 Σ_k log p_k, χ²(``dof``) under the null.
    dof : int
        2K, the degrees of freedom of ``statistic``.
    phi : ndarray (m,)
        The AR(1) prewhitening coefficient fitted to the deviations between periods.
    effect : ndarray (m,)
        Share of the residual's variance within the periods (its power at k ≥ 1) that is periodic
        model error beyond what the noise explains: Σ_{k≤K} ``error_power`` / ``total_variance``,
        clipped to [0, 1]. The sum is clipped, not each harmonic: Σ_k max(|Ē_k|² − σ̂²_k/P, 0)
        would add the positive part of every noise-only harmonic, a bias that grows with K (pure
        white noise, P = 5, K = 199: about 0.06; P = 2: about 0.19).
    error_power : ndarray (K, m)
        Variance carried by harmonic k of the periodic model error, 2(|Ē_k|² − σ̂²_k/P)/L² (data
        units²): unbiased (E|Ē_k|² = |μ_k|² + σ²_k/P), so negative where there is only noise.
    noise_variance : ndarray (m,)
        The noise variance (data units²) at the harmonics k = 1..L−1, every one of them, not only
        the tested: Σ_{k=1}^{L−1} σ̂²_k/L² (Parseval; for white noise of variance σ², about
        σ²(L − 1)/L). Noise slower than the period (power below the fundamental) is not in it.
    total_variance : ndarray (m,)
        The residual's variance within the periods (period means removed), averaged over periods:
        the denominator of ``effect``.
    noise_spectrum : ndarray (K, m)
        One-sided power spectral density of the noise at each tested harmonic, 2σ̂²_k·Δ/L with Δ
        the (resampled) sampling interval: units²/Hz with a sample rate, units²·samples without.
        For white noise of variance σ² it is about 2σ²/f_s at every harmonic.
    harmonic_statistic, harmonic_pvalue : ndarray (K, m)
        F_k = P|Ē_k|²/σ̂²_k and its p-value under F(2, 2(P−1)).
    frequency : ndarray (K,)
        The tested harmonics k/T: Hz with a sample rate, cycles per sample without.
    n_periods : int
        P, the whole periods used.
    samples_per_period : int
        L = round(T), the points of each period's DFT.
    n_harmonics : int
        K, the harmonics tested (k = 1..K, all below L/2).
    period_samples : float
        T in samples.
    start : int
        The first sample of the first period used.
    method : str
        What was computed, including whether the periods were resampled.
    """

    pvalue: FloatArray
    statistic: FloatArray
    dof: int
    phi: FloatArray
    effect: FloatArray
    error_power: FloatArray
    noise_variance: FloatArray
    total_variance: FloatArray
    noise_spectrum: FloatArray
    harmonic_statistic: FloatArray
    harmonic_pvalue: FloatArray
    frequency: FloatArray
    n_periods: int
    samples_per_period: int
    n_harmonics: int
    period_samples: float
    start: int
    method: str

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain Python values (arrays as nested lists; JSON-ready except nan)."""
        return {f.name: _to_list(getattr(self, f.name)) for f in fields(self)}


def _as_2d(x: ArrayLike, name: str) -> FloatArray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] == 0:
        raise InvalidShape(f"{name} must be (N,) or (N, m) with m ≥ 1, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteInput(f"{name} holds NaN or inf")
    return a


def _positive_rate(sample_rate: float | None) -> float | None:
    if sample_rate is None:
        return None
    rate = float(sample_rate) if is_real_number(sample_rate) else math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise InvalidParameter(f"sample_rate must be a positive finite number, got {format_value(sample_rate)}")
    return rate


def _difference_function(x: FloatArray, max_lag: int) -> FloatArray:
    """d(ℓ) = mean_t ‖x(t+ℓ) − x(t)‖² over the N − ℓ pairs, ℓ = 0..max_lag, from one FFT.

    Σ_t ‖x(t+ℓ) − x(t)‖² = Σ_{t≥ℓ} ‖x_t‖² + Σ_{t<N−ℓ} ‖x_t‖² − 2 r(ℓ), r the autocorrelation summed
    over joints (zero-padded FFT, no circular wrap-around in the lags kept).
    """
    n = x.shape[0]
    size = scipy.fft.next_fast_len(n + max_lag, real=True)
    spec = scipy.fft.rfft(x, n=size, axis=0)
    r = scipy.fft.irfft((spec.real**2 + spec.imag**2).sum(axis=1), n=size)[: max_lag + 1]
    cum = np.concatenate([[0.0], np.cumsum((x**2).sum(axis=1))])
    lags = np.arange(max_lag + 1)
    total = (cum[n] - cum[lags]) + cum[n - lags] - 2.0 * r
    return np.asarray(np.maximum(total, 0.0) / (n - lags), dtype=np.float64)


def _valleys(d: FloatArray, threshold: float) -> list[int]:
    """The lag of the lowest point of each run of lags ≥ 1 where d ≤ threshold, in increasing order."""
    below = d <= threshold
    below[0] = False
    # each run's first lag and the lag after its last, from the steps of the padded indicator (one
    # pass over the lags, not a Python step per lag: 10,000 lags on a 20,000-row log)
    steps = np.diff(np.concatenate([[0], below.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(steps == 1), np.flatnonzero(steps == -1)
    return [int(lo + np.argmin(d[lo:hi])) for lo, hi in zip(starts, stops)]


def _parabolic(d: FloatArray, lag: int) -> float:
    """Vertex of the parabola through d at lag − 1, lag, lag + 1 (the lag itself at an edge)."""
    if lag <= 0 or lag + 1 >= d.shape[0]:
        return float(lag)
    a, b, c = float(d[lag - 1]), float(d[lag]), float(d[lag + 1])
    curvature = a - 2.0 * b + c
    if curvature <= 0:
        return float(lag)
    return lag + 0.5 * (a - c) / curvature


def detect_period(
    q: ArrayLike,
    *,
    sample_rate: float | None = None,
    min_periods: int = 2,
    tolerance: float = 0.02,
) -> Period | None:
    """Fundamental period of a (periodic) trajectory, to sub-sample precision, or None.

    The squared mismatch d(ℓ) = mean_t ‖q(t+ℓ) − q(t)‖² / mean_t ‖q(t) − q̄‖² is computed for every
    integer lag ℓ ≤ N/``min_periods`` from the autocorrelation of the centred q summed over joints
    (one zero-padded FFT). Candidate periods are the valleys of d (runs of lags where
    √d ≤ 2·tolerance + √(d(1)/2): an integer lag is at most half a sample from the period, which
    adds at most √(d(1)/2)) that follow lags where the trajectory moved away from itself (the mean
    of d over the shorter lags at least 1; it is 2 over a period of a periodic signal, and stays
    near 0 for a random walk or a drift at short lags). Taking them in increasing order, each
    valley's minimum is refined by a parabola through d, then by minimising the mismatch of q
    shifted by a non-integer T (4-point cubic Lagrange interpolation between samples; Brent's
    method within ±1.5 samples); the first T whose relative RMS mismatch is below ``tolerance``
    and that leaves ``min_periods`` whole periods is returned: the shortest period, not a multiple
    of it.

    Parameters
    ----------
    q : array_like, shape (N,) or (N, m)
        Joint positions (any consistent unit; joints with a larger range weigh more).
    sample_rate : float, optional
        Samples per second; gives ``Period.seconds``.
    min_periods : int, default 2
        Whole periods the run must hold (≥ 2: one period has nothing to be compared with).
    tolerance : float, default 0.02
        Largest relative RMS mismatch ‖q(t+T) − q(t)‖/‖q − q̄‖ of a period. Noise in q counts:
        white noise of standard deviation s gives a mismatch of at least s·√2/RMS(q − q̄).

    Returns
    -------
    Period or None
        None when no such period exists (a non-periodic trajectory, a random walk, noise, a
        constant q, or fewer than ``min_periods`` periods in the run).

    Raises
    ------
    InvalidShape, NonFiniteInput, InvalidParameter
        (All ``ValueError``.) q not 1-D/2-D, holding NaN/inf; a parameter out of range.

    Examples
    --------
    A two-joint Fourier trajectory with a period of 137.5 samples, 3.6 periods long:

    >>> import numpy as np
    >>> from dynval.statistics._periodic import detect_period
    >>> t = np.arange(500) / 100.0                      # 100 Hz, 5 s
    >>> w = 2 * np.pi / 1.375                           # period 1.375 s
    >>> q = np.column_stack([np.sin(w * t) + 0.3 * np.cos(3 * w * t), 0.5 * np.sin(2 * w * t + 1)])
    >>> p = detect_period(q, sample_rate=100.0)
    >>> round(p.samples, 2), round(p.seconds, 4), p.n_periods, p.start, p.mismatch < 1e-3
    (137.5, 1.375, 3, 87, True)

    A trajectory that never repeats (incommensurate frequencies) has no period, and a constant one
    neither:

    >>> print(detect_period(np.sin(w * t) + np.sin(np.sqrt(2) * w * t)))
    None
    >>> print(detect_period(np.zeros(500)))
    None
    """
    x = _as_2d(q, "q")
    rate = _positive_rate(sample_rate)
    if isinstance(min_periods, bool) or not isinstance(min_periods, (int, np.integer)) or min_periods < 2:
        raise InvalidParameter(f"min_periods must be an integer ≥ 2, got {format_value(min_periods)}")
    tol = float(tolerance) if is_real_number(tolerance) else math.nan
    if not (math.isfinite(tol) and tol > 0):
        raise InvalidParameter(f"tolerance must be a positive finite number, got {format_value(tolerance)}")
    n = x.shape[0]
    max_lag = n // int(min_periods)
    if max_lag < 2:
        return None
    xc = x - x.mean(axis=0)
    # Scale by a power of two (exact): squares of data near 1e±160 leave float64 otherwise.
    largest = float(np.max(np.abs(xc)))
    if largest == 0.0:
        return None
    xc = np.ldexp(xc, -int(np.frexp(largest)[1]))
    power = float((xc**2).sum(axis=1).mean())
    d = _difference_function(xc, max_lag) / power
    threshold = (2.0 * tol + math.sqrt(0.5 * float(d[1]))) ** 2
    prefix = np.cumsum(d)  # prefix[ℓ] − d[0]: Σ d over lags 1..ℓ
    tried = 0
    for lag in _valleys(d, threshold):
        if lag < 2 or (prefix[lag - 1] - d[0]) / (lag - 1) < _MIN_MEAN_DIP:
            continue
        if tried >= _MAX_CANDIDATES:
            break
        tried += 1
        guess = _parabolic(d, lag)
        lo, hi = max(guess - 1.5, 1.0), guess + 1.5
        rows = n - math.floor(hi) - 2  # x(t + T) needs the samples up to t + ⌊T⌋ + 2
        if rows < 2:
            continue
        period, mismatch = _refine(xc, rows, power, lo, hi)
        n_periods = int(math.floor(n / period + 1e-9))
        if mismatch < tol and n_periods >= min_periods:
            start = max(int(math.floor(n - n_periods * period + 1e-9)), 0)
            return Period(
                samples=period,
                seconds=None if rate is None else period / rate,
                n_periods=n_periods,
                start=start,
                mismatch=mismatch,
                method=("difference function d(l) = |q(t+l) - q(t)|^2 from the FFT autocorrelation summed "
                        "over joints; shortest valley below tolerance; parabolic interpolation; "
                        "refinement (Brent) of the mismatch with cubic Lagrange interpolation"),
            )
    return None


def _fourier_resample(x: FloatArray, t0: float, step: float, count: int) -> FloatArray:
    """x (N, m) at the times t0 + j·step, j < count, by trigonometric (Fourier) interpolation.

    The line joining the first and the last sample is removed first (so the record's periodic
    extension is continuous and rings little at its ends) and added back exactly. The interpolant
    Σ_f X_f e^{2πifτ/N}/N over f = −N/2..N/2−1 is evaluated on the uniform grid by one chirp-z
    transform (Bluestein; ``scipy.signal.czt``), O((N + count) log). Band-limited interpolation
    is all-pass: white noise keeps its variance at every fractional position, which linear
    interpolation would lower by up to half (at half a sample) and by a different amount in each
    period.
    """
    n = x.shape[0]
    t = np.arange(n, dtype=np.float64)
    slope = (x[-1] - x[0]) / (n - 1)
    y = x - x[0] - slope * t[:, None]
    half = n // 2
    freqs = np.arange(n, dtype=np.float64) - half  # f = −N/2..N/2−1 (the Nyquist bin's real part is its cos)
    g = np.roll(scipy.fft.fft(y, axis=0), half, axis=0) * np.exp(2j * np.pi * freqs * t0 / n)[:, None]
    z = scipy.signal.czt(g, m=count, w=np.exp(2j * np.pi * step / n), axis=0)
    j = np.arange(count, dtype=np.float64)
    values = np.real(z * np.exp(-2j * np.pi * half * j * step / n)[:, None]) / n
    return np.asarray(values + x[0] + slope * (t0 + j * step)[:, None], dtype=np.float64)


def _shifted(x: FloatArray, shift: float, rows: int) -> FloatArray:
    """x(t + shift) for t = 0..rows−1 by 4-point (cubic) Lagrange interpolation between samples.

    Local, so it needs no stored spline (O(rows·m) memory); exact at integer shifts, error
    O(ω⁴) for a component of ω rad/sample.
    """
    lag = int(math.floor(shift))
    f = shift - lag
    w = (-f * (f - 1.0) * (f - 2.0) / 6.0, (f + 1.0) * (f - 1.0) * (f - 2.0) / 2.0,
         -(f + 1.0) * f * (f - 2.0) / 2.0, (f + 1.0) * f * (f - 1.0) / 6.0)
    out = w[0] * x[lag - 1 : lag - 1 + rows]
    for i in (1, 2, 3):
        out = out + w[i] * x[lag - 1 + i : lag - 1 + i + rows]
    return np.asarray(out, dtype=np.float64)


def _refine(x: FloatArray, rows: int, power: float, lo: float, hi: float) -> tuple[float, float]:
    """T in [lo, hi] minimising mean_t ‖x(t+T) − x(t)‖² over t < rows (x(t+T) interpolated), by
    Brent's bounded method; returns T and the relative RMS mismatch there."""
    base = x[:rows]

    def mismatch2(period: float) -> float:
        diff = _shifted(x, period, rows) - base
        return float((diff**2).sum(axis=1).mean()) / power

    fit = scipy.optimize.minimize_scalar(mismatch2, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
    return float(fit.x), math.sqrt(max(float(fit.fun), 0.0))


def _period_blocks(e: FloatArray, period: float, start: int, n_periods: int) -> tuple[FloatArray, int, bool]:
    """The residual of each period on L = round(T) points: (P, L, m), L, whether resampled.

    An integer T takes the samples as they are; otherwise the P periods are sampled at
    start + j·T/L, j = 0..P·L − 1, by Fourier interpolation of the whole record.
    """
    length = int(round(period))
    m = e.shape[1]
    if abs(period - length) <= 1e-9 * period:
        stop = start + n_periods * length
        return e[start:stop].reshape(n_periods, length, m), length, False
    # One column at a time: the chirp-z transform holds several complex copies of its input.
    values = np.empty((n_periods * length, m))
    for j in range(m):
        values[:, j] = _fourier_resample(e[:, j : j + 1], float(start), period / length, n_periods * length)[:, 0]
    return values.reshape(n_periods, length, m), length, True


def periodic_noise_test(
    e: ArrayLike,
    period: Period | float,
    *,
    sample_rate: float | None = None,
    band: float | None = None,
) -> PeriodicTest:
    """Test each joint's residual for a periodic model error against the noise the periods measure.

    The P whole periods of the residual (those of ``period``; with a plain T, the last ⌊N/T⌋
    periods of the run) are taken on L = round(T) points each (when T is not an integer, resampled
    by Fourier interpolation of the whole record, which keeps the noise's variance) and transformed
    (DFT, E_pk for period p and harmonic k). At each harmonic k = 1..K and for each joint, the mean
    over periods Ē_k is what every period shares (the model's error: a periodic trajectory makes it
    periodic), and the sample variance σ̂²_k = Σ_p |E_pk − Ē_k|²/(P − 1) is the noise at that
    frequency, whatever its colour. With noise independent between periods and E_pk complex
    Gaussian, F_k = P|Ē_k|²/σ̂²_k ~ F(2, 2(P − 1)) when there is no model error (Pintelon &
    Schoukens 2012, §2.5). The Nyquist bin (real-valued) is never tested.

    **Prewhitening.** Noise slower than the period (AR(1) with ρ near 1 against a short period)
    leaks from each period's ends into every bin with the same shape, so the bins of a period are
    no longer independent. The residual is therefore filtered by 1 − φ̂z⁻¹ first, φ̂ the AR(1)
    coefficient of the deviations e_p(t) − ē(t) between periods (noise only: the periodic error
    cancels there; first sample by Prais–Winsten). A fixed filter multiplies harmonic k of every
    period by the same gain, which cancels in F_k; it only removes the leakage. The bins are divided
    by the gain afterwards, so Ē_k, σ̂²_k and the spectra are in the data's units.

    **Combining the harmonics: Fisher's method**, −2 Σ_k log p_k ~ χ²(2K). Each p_k is exact for
    any noise colour because each bin is divided by its *own* noise estimate; Fisher needs only that
    the bins are independent, which the DFT bins of stationary (prewhitened) noise are,
    asymptotically, and exactly for white Gaussian noise. A pooled statistic Σ P|Ē_k|² / Σ σ̂²_k
    against F(2K, 2K(P − 1)) holds its size only for white noise: under colour a few bins dominate
    both sums and the effective degrees of freedom collapse (size at 5 %, L = 400, K = 199: 28 %
    for AR(1) 0.9, 28–38 % for AR(1) 0.99). Measured size of this test at 5 % / 1 % / 0.1 %
    (20,000 seeds, L = 400, K = 199): white noise 5.05 / 1.04 / 0.11 % (P = 2) and
    5.05 / 1.12 / 0.13 % (P = 5); AR(1) 0.9 5.07 / 1.01 / 0.10 % and 4.91 / 0.95 / 0.09 %;
    AR(1) 0.99 5.07 / 0.97 / 0.12 % and 5.28 / 1.06 / 0.11 %. Without the prewhitening, AR(1)
    0.99 with P = 2 gave 9.9 % and AR(1) 0.999 with P = 5 14.5 %.

    **Power** comes from the harmonics that hold the error: Fisher's sum dilutes a few strong
    harmonics among many empty ones. Give ``band`` (the trajectory's band, e.g.
    :func:`dynval.statistics._stats.information_bandwidth` of the measured torque) to test only the harmonics
    the motion occupies. White noise σ plus an error of RMS 0.5σ at harmonics 1–5 of L = 400
    (2000 seeds): p ≤ 0.001 in 43–47 % (P = 2), 99.9 % (P = 3) and 100 % (P = 5) with K = 10; in
    1 % (P = 2), 52 % (P = 5) and 100 % (P = 10) with every harmonic (K = 199). Against AR(1) 0.9
    noise of the same variance, whose power sits at the low harmonics with the error, P = 5 and
    K = 10 give 26 %.

    **Limits.** Noise whose slow part is not AR(1)-like is only partly prewhitened: white noise plus
    a random walk (steps 0.05σ) keeps a liberal size of 8–9 % at 5 % with K = 10 (5.4 % with
    K = 199; 4000 seeds, L = 400). Model error that is not periodic (a drift, a transient) counts
    as noise; model error that is periodic but sits above ``band`` is not tested.

    Parameters
    ----------
    e : array_like, shape (N,) or (N, m)
        The residual τ − Y π̂ of the run whose trajectory has the period.
    period : Period or float
        A :class:`Period` from :func:`detect_period` (its ``start`` and ``samples`` are used; the
        number of periods is the whole periods of ``e`` from ``start``), or T in samples (the last
        ⌊N/T⌋ whole periods are used).
    sample_rate : float, optional
        Samples per second: frequencies in Hz, ``band`` in Hz, spectra in units²/Hz.
    band : float, optional
        Highest frequency to test (Hz with ``sample_rate``, else cycles per sample): harmonics
        k = 1..K with k/T ≤ band. By default every harmonic below L/2 (the Nyquist bin, real-valued,
        is never tested).

    Returns
    -------
    PeriodicTest
        Per joint ``pvalue``, ``statistic``, ``effect``, ``noise_variance``, ``total_variance``; per
        harmonic and joint ``noise_spectrum``, ``error_power``, ``harmonic_statistic``,
        ``harmonic_pvalue``; ``frequency``, ``n_periods`` (P), ``samples_per_period`` (L),
        ``n_harmonics`` (K), ``dof`` (2K), ``method``.

    Raises
    ------
    TooFewSamples
        Fewer than two whole periods in ``e`` (P = 2 is the minimum: one degree of freedom pair
        for the noise, F(2, 2), low power), or L < 3 (no harmonic below Nyquist).
    InvalidShape, NonFiniteInput, InvalidParameter
        (All ``ValueError``.) ``e`` not 1-D/2-D or non-finite; T ≤ 1, a start outside ``e``, a band
        below the fundamental, a non-positive sample rate.

    Examples
    --------
    Five periods of 200 samples: joint 1 is noise only, joint 2 also carries a periodic error of
    half the noise's standard deviation at harmonics 1 to 3:

    >>> import numpy as np
    >>> from dynval.statistics._periodic import periodic_noise_test
    >>> rng = np.random.default_rng(1)
    >>> t = np.arange(1000)
    >>> error = 0.5 * sum(np.sqrt(2 / 3) * np.sin(2 * np.pi * k * t / 200 + k) for k in (1, 2, 3))
    >>> e = rng.normal(size=(1000, 2)) + np.column_stack([0 * t, error])
    >>> r = periodic_noise_test(e, 200.0, sample_rate=100.0, band=5.0)
    >>> r.n_periods, r.samples_per_period, r.n_harmonics, r.frequency[:3].tolist()
    (5, 200, 10, [0.5, 1.0, 1.5])
    >>> bool(r.pvalue[0] > 0.05), bool(r.pvalue[1] < 1e-6)
    (True, True)
    >>> np.round(r.effect, 1).tolist()                 # true shares 0 and 0.25/1.25 = 0.2
    [0.0, 0.2]
    >>> np.round(r.noise_variance, 1).tolist()         # white noise of variance 1
    [1.0, 1.0]

    A constant residual has no variation within the periods: p = 1, effect 0:

    >>> r = periodic_noise_test(np.full(600, 3.0), 200.0)
    >>> r.pvalue.tolist(), r.effect.tolist(), r.noise_variance.tolist()
    ([1.0], [0.0], [0.0])
    """
    x = _as_2d(e, "e")
    rate = _positive_rate(sample_rate)
    t_samples, start, p_count = _whole_periods(x.shape[0], period)
    fs = 1.0 if rate is None else rate
    n_harm = _harmonics_tested(t_samples, fs, band)
    # Each joint scaled by a power of two near its largest |e| (exact, contract §1.3): squared DFT
    # sums overflow near 1e140 and underflow near 1e-160. Scaled back at the end.
    largest = np.max(np.abs(x), axis=0)
    exps = np.where(largest > 0, np.frexp(largest)[1], 0).astype(np.int64)
    x = np.ldexp(x, -exps)
    blocks, length, resampled = _period_blocks(x, t_samples, start, p_count)
    # The residual's variance within the periods (period means removed), averaged over periods.
    total_variance = blocks.var(axis=1).mean(axis=0)
    phi = _ar1_between_periods(blocks)
    mean_power, noise_all = _mean_and_spread_over_periods(_prewhitened_spectra(x, phi, t_samples, start, p_count))
    tests = _harmonic_tests(mean_power, noise_all, blocks, p_count, n_harm)
    tests["noise_variance"] = _noise_variance(noise_all, length)
    effect, still = _effect_and_still(tests["error_power"], total_variance, blocks)
    tests = _without_still_joints(tests, still)
    dt = t_samples / (length * fs)  # the sampling interval of the (resampled) periods
    in_units = _to_data_units(exps, total_variance=total_variance, noise_variance=tests["noise_variance"],
                              noise_spectrum=2.0 * tests["noise_k"] * dt / length, error_power=tests["error_power"])
    return PeriodicTest(
        pvalue=tests["pvalue"],
        statistic=np.asarray(tests["statistic"], dtype=np.float64),
        dof=2 * n_harm,
        phi=np.asarray(phi, dtype=np.float64),
        effect=np.asarray(effect, dtype=np.float64),
        error_power=np.asarray(in_units["error_power"], dtype=np.float64),
        noise_variance=np.asarray(in_units["noise_variance"], dtype=np.float64),
        total_variance=np.asarray(in_units["total_variance"], dtype=np.float64),
        noise_spectrum=np.asarray(in_units["noise_spectrum"], dtype=np.float64),
        harmonic_statistic=np.asarray(tests["harmonic_statistic"], dtype=np.float64),
        harmonic_pvalue=np.asarray(tests["harmonic_pvalue"], dtype=np.float64),
        frequency=np.arange(1, n_harm + 1, dtype=np.float64) * fs / t_samples,
        n_periods=p_count,
        samples_per_period=length,
        n_harmonics=n_harm,
        period_samples=t_samples,
        start=start,
        method=_method_text(p_count, t_samples, length, resampled, n_harm),
    )


def _whole_periods(n: int, period: Period | float) -> tuple[float, int, int]:
    """T in samples, the first sample and the number P ≥ 2 of the whole periods to test."""
    if isinstance(period, Period):
        t_samples, start = float(period.samples), int(period.start)
    else:
        t_samples = float(period) if is_real_number(period) else math.nan
        start = -1
    if not (math.isfinite(t_samples) and t_samples > 1.0):
        raise InvalidParameter(f"the period must be a finite number of samples > 1, got {format_value(period)}")
    if start < 0:  # a plain T: the last whole periods of the run
        whole = int(math.floor(n / t_samples + 1e-9))
        start = max(int(math.floor(n - whole * t_samples + 1e-9)), 0)
    elif start >= n:
        raise InvalidParameter(f"the period's start {start} is beyond the residual's {n} samples")
    n_periods = int(math.floor((n - start) / t_samples + 1e-9))
    if n_periods < 2:
        raise TooFewSamples(
            f"the residual holds {n_periods} whole period(s) of {t_samples:g} samples from sample {start}; "
            "the periodic noise model needs at least 2")
    return t_samples, start, n_periods


MIN_TESTED_PERIOD = 3
"""The shortest period (samples) with a harmonic below the Nyquist frequency: q repeating every 2
samples is an encoder dithering by one count, not a trajectory the periodic test can read."""


def _harmonics_tested(t_samples: float, fs: float, band: float | None) -> int:
    """K: every harmonic below L/2, or those up to ``band``."""
    length = int(round(t_samples))
    if length < MIN_TESTED_PERIOD:
        raise TooFewSamples(f"a period of {t_samples:g} samples has no harmonic below the Nyquist frequency")
    k_max = (length - 1) // 2  # harmonics strictly below L/2
    if band is None:
        return k_max
    band_f = float(band) if is_real_number(band) else math.nan
    if not (math.isfinite(band_f) and band_f > 0):
        raise InvalidParameter(f"band must be a positive finite frequency, got {format_value(band)}")
    n_harm = min(k_max, int(math.floor(band_f * t_samples / fs + 1e-9)))
    if n_harm < 1:
        raise InvalidParameter(
            f"band {band_f:g} is below the fundamental frequency {fs / t_samples:g}: no harmonic to test")
    return n_harm


def _ar1_between_periods(blocks: FloatArray) -> FloatArray:
    """φ̂ per joint: the AR(1) coefficient of the deviations from the mean period, within ±0.999.

    The deviations are noise only: the periodic error is common to all periods and cancels there.
    Filtering the whole record by 1 − φ̂z⁻¹ multiplies harmonic k of every period by the same gain
    g_k = 1 − φ̂e^{−2πik/T}, which cancels in F_k; what it changes is the leakage of slow noise
    (power below the fundamental) into every bin, which otherwise ties the bins together and makes
    Fisher's sum liberal.
    """
    dev = blocks - blocks.mean(axis=0)
    num = (dev[:, 1:] * dev[:, :-1]).sum(axis=(0, 1))
    den = (dev[:, :-1] ** 2).sum(axis=(0, 1))
    # Deviations at rounding level (a constant or exactly periodic residual): no noise, no filter.
    noisy = den > _EPS2 * np.maximum((blocks[:, :-1] ** 2).sum(axis=(0, 1)), _TINY)
    return np.asarray(np.clip(np.where(noisy, num / np.maximum(den, _TINY), 0.0), -0.999, 0.999), dtype=np.float64)


def _prewhitened_spectra(x: FloatArray, phi: FloatArray, period: float, start: int, n_periods: int) -> Any:
    """The DFT of each period of x filtered by 1 − φ̂z⁻¹, divided by the filter's gain.

    (P, L//2 + 1, m) complex: the bins in the data's units, without the leakage of slow noise.
    """
    u = np.empty_like(x)
    u[1:] = x[1:] - phi * x[:-1]
    u[0] = np.sqrt(1.0 - phi**2) * x[0]  # Prais–Winsten: the first sample has no predecessor
    u_blocks, length, _ = _period_blocks(u, period, start, n_periods)
    freq_bins = np.arange(length // 2 + 1, dtype=np.float64)
    gain = 1.0 - phi[None, :] * np.exp(-2j * np.pi * freq_bins[:, None] / period)  # (L//2 + 1, m)
    return scipy.fft.rfft(u_blocks, axis=1) / gain


def _mean_and_spread_over_periods(spec: Any) -> tuple[FloatArray, FloatArray]:
    """|Ē_k|² and σ̂²_k = Σ_p |E_pk − Ē_k|²/(P − 1) at every bin k = 0..L//2, per joint."""
    mean = spec.mean(axis=0)
    dev_k = spec - mean
    return mean.real**2 + mean.imag**2, (dev_k.real**2 + dev_k.imag**2).sum(axis=0) / (spec.shape[0] - 1)


def _noise_variance(noise_all: FloatArray, length: int) -> FloatArray:
    """The noise variance at the harmonics k ≥ 1, from σ̂²_k of every bin (Parseval)."""
    # Mirrored bins count twice, the Nyquist bin of an even L once.
    weights = np.full(noise_all.shape[0], 2.0)
    weights[0] = 0.0
    if length % 2 == 0:
        weights[-1] = 1.0
    return np.asarray(weights @ noise_all / length**2, dtype=np.float64)


def _harmonic_tests(mean_power: FloatArray, noise_all: FloatArray, blocks: FloatArray, p_count: int,
                    n_harm: int) -> dict[str, Any]:
    """The F test of each tested harmonic, Fisher's combination of them and the error power, per joint."""
    length = blocks.shape[1]
    noise_k = noise_all[1 : n_harm + 1]
    mean_power = mean_power[1 : n_harm + 1]
    # Bins where both the common part and the spread are at rounding level (a constant residual):
    # nothing to test, F = 0, p = 1. A spread at rounding level under a real common part is an
    # exactly periodic residual: F = inf, p = 0.
    floor = _EPS2 * length * np.maximum((blocks**2).sum(axis=1).mean(axis=0), _TINY)
    quiet = (noise_k <= floor) & (mean_power <= floor)
    with np.errstate(divide="ignore", invalid="ignore"):
        f_stat = np.where(quiet, 0.0, p_count * mean_power / np.where(noise_k > floor, noise_k, 0.0))
    infinite = np.isinf(f_stat)
    log_p = np.where(infinite, -np.inf,
                     scipy.stats.f.logsf(np.where(infinite, 0.0, f_stat), 2.0, 2.0 * (p_count - 1)))
    statistic = -2.0 * log_p.sum(axis=0)
    return {
        "pvalue": np.asarray(scipy.stats.chi2.sf(statistic, 2 * n_harm), dtype=np.float64),
        "statistic": statistic,
        "harmonic_statistic": f_stat,
        "harmonic_pvalue": np.exp(log_p),
        # Unbiased per harmonic (E|Ē_k|² = |μ_k|² + σ²_k/P), so it may be negative; only the sum is clipped.
        "error_power": np.where(quiet, 0.0, 2.0 * (mean_power - noise_k / p_count) / length**2),
        "noise_k": noise_k,
    }


def _effect_and_still(error_power: FloatArray, total_variance: FloatArray,
                      blocks: FloatArray) -> tuple[FloatArray, Any]:
    """The share of the variance within the periods that is periodic model error, per joint, and
    which joints have no variation within the periods (a constant residual: effect 0)."""
    still = total_variance <= _EPS2 * (blocks**2).mean(axis=(0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        effect = np.where(still, 0.0, np.clip(error_power.sum(axis=0) / total_variance, 0.0, 1.0))
    return effect, still


# What a joint without variation within the periods reads: nothing to test, p = 1.
_STILL_VALUES = {"pvalue": 1.0, "statistic": 0.0, "harmonic_statistic": 0.0, "harmonic_pvalue": 1.0,
                 "error_power": 0.0, "noise_k": 0.0, "noise_variance": 0.0}


def _without_still_joints(tests: dict[str, Any], still: Any) -> dict[str, Any]:
    """``tests`` with the joints in ``still`` set to their values of "no variation"."""
    return {key: np.where(still if np.ndim(value) == 1 else still[None, :], _STILL_VALUES[key], value)
            for key, value in tests.items()}


def _to_data_units(exps: Any, **scaled: FloatArray) -> dict[str, FloatArray]:
    """Variances and spectra of the scaled residual times 2^(2·exps): back in the data's units²."""
    # IEEE where it leaves float64.
    with np.errstate(over="ignore"):
        scale2 = np.ldexp(np.ones(exps.shape[0]), 2 * exps)
        return {key: value * scale2 for key, value in scaled.items()}


def _method_text(p_count: int, t_samples: float, length: int, resampled: bool, n_harm: int) -> str:
    """What was computed, for ``PeriodicTest.method``."""
    return (f"Pintelon-Schoukens nonparametric noise model: {p_count} periods of T = {t_samples:g} samples"
            + (f" resampled onto L = {length} points each by Fourier interpolation" if resampled
               else f" (L = {length} samples each)")
            + "; AR(1) prewhitening fitted to the deviations between periods; DFT per period; "
            + f"harmonics k = 1..{n_harm}: F_k = P|mean|^2/var ~ F(2, {int(2.0 * (p_count - 1))}) per joint; "
            + f"Fisher's combination -2 sum log p_k ~ chi2({2 * n_harm})")


def periodic_error_test(e: FloatArray, q: FloatArray, sample_rate: float | None, band: float | None,
                        reg3: FloatArray | None = None, cols: list[int] | None = None) -> dict[str, Any] | None:
    """When the validation trajectory repeats itself (at least two whole periods of q), the residual's
    part common to every period against the noise the period-to-period variation measures
    (:func:`periodic_noise_test`, no whiteness assumed).

    A model's estimation error Y(π − π̂) repeats with the trajectory too: with a regressor, each
    joint's residual is first cleared of what the model's own columns represent (least squares on
    the validation run), so what is tested is periodic error the model cannot represent. ``cols``:
    the model's columns of ``reg3`` (N, m, p). Returns the report's periodic section, or None where
    q does not repeat (or no test can run without the band it was given).
    """
    period = detect_period(q, sample_rate=sample_rate)
    if period is None:
        return None
    if round(period.samples) < MIN_TESTED_PERIOD:
        return _untested_period(period, f"q repeats every {period.samples:.3g} samples: an encoder dithering by a "
                                        "count at standstill, not a repeated trajectory; such a period has no "
                                        "harmonic below the Nyquist frequency, so no periodic test")
    projected = False
    if reg3 is not None and cols is not None:
        e = e.copy()
        for j in range(e.shape[1]):
            y = unit_norm_columns(reg3[:, j, cols])  # the projection in any unit of the columns
            if y.size:
                e[:, j] -= y @ np.linalg.lstsq(y, e[:, j], rcond=None)[0]
        projected = True
    use_band = band if band is not None and np.isfinite(band) and band > 0 else None
    try:
        test = periodic_noise_test(e, period, sample_rate=sample_rate, band=use_band)
    except ValueError:
        if use_band is None:
            return None
        try:
            test = periodic_noise_test(e, period, sample_rate=sample_rate)
        except ValueError as exc:
            return _untested_period(period, f"no periodic test: {exc}")
    out = {"used": True, "period": period.to_dict(), **test.to_dict()}
    out["model_columns_removed"] = projected
    out["effect_net"] = np.clip(np.asarray(test.effect, dtype=float), 0.0, 1.0)
    return out


def _untested_period(period: Period, note: str) -> dict[str, Any]:
    """The periodic section of a period that cannot be tested: ``used`` False and the ``note`` why."""
    return {"used": False, "period": period.to_dict(), "note": note}
