"""The statistics of ``dynval.statistics._stats`` pinned to their documented definitions.

Every expected value here is computed independently of the code under test: by the library that
defines the same quantity (scipy.signal.welch / periodogram / decimate, scipy.stats,
statsmodels' HAC and Holm code) or by a brute-force transcription of the formula in the docstring
and docs/conventions.md §5.4 (explicit loops over lags, segments and median windows). Small
hand-made inputs pin each rule; edge cases (several segments, too-short segments, constant or zero
series, powers-of-two scaling, float32 or whole-float inputs, no warnings where the code silences
them) pin the special paths. Tolerances are exact or 1e-12 where the arithmetic is the same, and
looser only where the reference computes differently (FFT against direct sums, beta against t
distribution), as said at each place.
"""

from __future__ import annotations

import math
import warnings
from fractions import Fraction

import numpy as np
import pytest
import scipy.signal
import scipy.stats

from dynval.statistics import _stats

RTOL = 1e-12


# ---------------------------------------------------------------------------------------------
# Independent references (transcriptions of the documented formulas)
# ---------------------------------------------------------------------------------------------

def _segments(starts, n):
    bounds = [int(s) for s in starts] + [n]
    return list(zip(bounds[:-1], bounds[1:]))


def ref_acov(col, starts, lag):
    """Σ x_t x_{t−lag} over pairs inside one segment (a direct sum per segment and lag)."""
    total = 0.0
    for a, b in _segments(starts, len(col)):
        if b - a > lag:
            total += float(np.dot(col[a + lag:b], col[a:b - lag]))
    return total


def ref_acf(x, starts, max_lag, centre=True):
    x = np.asarray(x, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    out = np.empty((max_lag + 1, x.shape[1]))
    for j in range(x.shape[1]):
        col = x[:, j] - x[:, j].mean() if centre else x[:, j]
        c0 = ref_acov(col, starts, 0)
        for lag in range(max_lag + 1):
            out[lag, j] = ref_acov(col, starts, lag) / c0 if c0 > 0 else np.nan
    return out


def ref_andrews(phi, n):
    """Andrews (1991) AR(1) plug-in for the Bartlett kernel, as in conventions §5.4."""
    phi = min(max(float(phi), -0.999), 0.999)
    alpha = 4.0 * phi**2 / ((1.0 - phi) ** 2 * (1.0 + phi) ** 2)
    s = 1.1447 * (alpha * n) ** (1.0 / 3.0)
    return int(math.floor(s)) if math.isfinite(s) else 0


def ref_long_run_variance(e, starts):
    """Andrews & Monahan (1992) prewhitened Bartlett LRV, loop by loop (conventions §5.4)."""
    x = np.asarray(e, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    n, m = x.shape
    segs = _segments(starts, n)
    res = {k: np.empty(m) for k in ("variance", "lrv", "n_eff", "phi")}
    res["bandwidth"] = np.zeros(m, dtype=np.int64)
    for j in range(m):
        xc = x[:, j] - x[:, j].mean()
        var = float(np.sum(xc**2)) / n
        c0 = ref_acov(xc, starts, 0)
        rho1 = ref_acov(xc, starts, 1) / c0 if c0 > 0 else 0.0
        phi = min(max(rho1, -0.999), 0.999)
        useg = [[xc[t] - phi * xc[t - 1] for t in range(a + 1, b)] for a, b in segs]
        useg = [s for s in useg if s]
        nu = sum(len(s) for s in useg)
        bw = 0
        if nu >= 2:
            u = np.concatenate(useg)
            uc = u - u.mean()
            ustarts = np.cumsum([0] + [len(s) for s in useg[:-1]])
            d0 = ref_acov(uc, ustarts, 0)
            rho_u1 = ref_acov(uc, ustarts, 1) / d0 if d0 > 0 else 0.0
            bw = max(min(ref_andrews(rho_u1, nu), max(len(s) for s in useg) - 1), 0)
            lrv_u = d0 / nu
            for lag in range(1, bw + 1):
                lrv_u += 2.0 * (1.0 - lag / (bw + 1.0)) * ref_acov(uc, ustarts, lag) / nu
        else:
            lrv_u = np.nan
        lrv = lrv_u / (1.0 - phi) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            n_eff = n * var / np.float64(lrv)
        n_eff = min(max(n_eff, 2.0), float(n)) if (np.isfinite(n_eff) and var > 0) else float(n)
        res["variance"][j], res["lrv"][j], res["n_eff"][j], res["phi"][j] = var, lrv, n_eff, phi
        res["bandwidth"][j] = bw
    return res


def ref_welch(x, starts, fs, nperseg):
    """Welch by hand: every Hann window (50 % overlap) of every long-enough segment, its
    periodogram (scipy.signal.periodogram), and the plain mean over all windows — which is the
    documented average of the segments' Welch spectra weighted by their window counts."""
    x = np.asarray(x, dtype=np.float64)
    step = nperseg - nperseg // 2  # noverlap = nperseg // 2 (rounded down), as scipy.signal.welch
    pers, freq = [], None
    for a, b in _segments(starts, x.shape[0]):
        for w0 in range(a, b - nperseg + 1, step):
            freq, p = scipy.signal.periodogram(x[w0:w0 + nperseg], fs=fs, window="hann",
                                               detrend="constant", axis=0)
            pers.append(p)
    return freq, np.mean(pers, axis=0), len(pers)


def ref_default_nperseg(starts, n):
    longest = max(b - a for a, b in _segments(starts, n))
    p = 16
    while p * 2 <= longest // 8:  # the largest power of two ≤ N/8, within 16..1024
        p *= 2
    return min(p, 1024, longest)


def ref_dof(k):
    return 2.0 if k <= 1 else 2.0 * k / (1.0 + 2.0 * (1.0 - 1.0 / k) * 0.1667**2)


def ref_side_medians(logp, inner, outer):
    f = len(logp)
    left, right = np.full(f, np.nan), np.full(f, np.nan)
    for b in range(f):
        lo = [i for i in range(b - outer, b - inner + 1) if 0 <= i < f]
        hi = [i for i in range(b + inner, b + outer + 1) if 0 <= i < f]
        if len(lo) >= 3:
            left[b] = np.median(logp[lo])
        if len(hi) >= 3:
            right[b] = np.median(logp[hi])
    return left, right


def ref_spectrum(e, starts, fs, nperseg, inner=3, outer=10):
    x = np.asarray(e, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    freq, power, k = ref_welch(x, starts, fs, nperseg)
    dof = ref_dof(k)
    med = scipy.stats.chi2.median(dof) / dof
    f, m = power.shape
    ratio, pvalue, share = (np.full((f, m), np.nan) for _ in range(3))
    is_peak = np.zeros((f, m), dtype=bool)
    df = freq[1] - freq[0]
    for j in range(m):
        pj = power[:, j]
        if pj.max() <= 0 or x[:, j].var() <= 0:
            continue
        left, right = ref_side_medians(np.log(pj), inner, outer)
        excess = np.zeros(f)
        for b in range(f):
            if not (np.isfinite(left[b]) and np.isfinite(right[b])):
                continue
            bg = math.exp(max(left[b], right[b])) / med
            ratio[b, j] = pj[b] / bg
            pvalue[b, j] = scipy.stats.chi2.sf(dof * ratio[b, j], dof)
            excess[b] = max(pj[b] - bg, 0.0) * df
            is_peak[b, j] = (b == 0 or pj[b] >= pj[b - 1]) and (b == f - 1 or pj[b] >= pj[b + 1])
        for b in range(f):
            if np.isfinite(ratio[b, j]):
                share[b, j] = excess[max(b - 2, 0):b + 3].sum() / x[:, j].var()
    return freq, power, dof, ratio, pvalue, share, is_peak


def _no_warnings():
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("error")
    return ctx


# ---------------------------------------------------------------------------------------------
# z, t test, Holm
# ---------------------------------------------------------------------------------------------

def test_z_two_sided_is_the_normal_quantile_of_half_the_tails():
    """z = Φ⁻¹((1 + level)/2)."""
    for level in (0.5, 0.9, 0.95, 0.99):
        assert _stats.z_two_sided(level) == scipy.stats.norm.ppf((1.0 + level) / 2.0)
    assert _stats.z_two_sided(0.95) == pytest.approx(1.959963984540054, rel=1e-15)


def test_iid_t_test_equals_scipy_ttest_1samp():
    """t = mean·√n/std with std the ddof=1 deviation, p two-sided with n − 1 degrees of freedom."""
    rng = np.random.default_rng(1)
    samples = [rng.normal(0.3, 1.0, size=n) for n in (3, 5, 12, 40)]
    mean = [s.mean() for s in samples]
    std = [s.std(ddof=1) for s in samples]
    n = [s.size for s in samples]
    t, p = _stats.iid_t_test(mean, std, n)
    for i, s in enumerate(samples):
        ref = scipy.stats.ttest_1samp(s, 0.0)
        assert t[i] == pytest.approx(ref.statistic, rel=1e-12)
        assert p[i] == pytest.approx(ref.pvalue, rel=1e-10)  # sf vs scipy's own tail: same t law


def test_iid_t_test_float32_sample_sizes_are_computed_in_double():
    """An effective sample size given as float32 is converted to float64 before √n and n − 1."""
    n32 = np.array([7.3, 123.7], dtype=np.float32)
    t, p = _stats.iid_t_test([0.2, 0.05], [1.0, 1.0], n32)
    n64 = n32.astype(np.float64)
    t_ref = np.array([0.2, 0.05]) * np.sqrt(n64)
    np.testing.assert_allclose(t, t_ref, rtol=RTOL)
    np.testing.assert_allclose(p, 2.0 * scipy.stats.t.sf(t_ref, n64 - 1.0), rtol=RTOL)


def test_iid_t_test_zero_std_gives_inf_or_nan_silently():
    """Zero std: t = ±inf, p = 0 for a non-zero mean; nan for a zero mean; no warning."""
    ctx = _no_warnings()
    try:
        t, p = _stats.iid_t_test([1.0, -2.0, 0.0], [0.0, 0.0, 0.0], [10, 10, 10])
    finally:
        ctx.__exit__(None, None, None)
    assert t[0] == np.inf and t[1] == -np.inf and np.isnan(t[2])
    assert p[0] == 0.0 and p[1] == 0.0 and np.isnan(p[2])


def test_holm_matches_statsmodels_and_keeps_shape_and_nan():
    """Holm step-down adjusted p-values (statsmodels multipletests 'holm'); NaN stays NaN and is
    not counted in the family; the shape of the input is kept; capped at 1."""
    from statsmodels.stats.multitest import multipletests

    p = np.array([[0.01, 0.04, np.nan], [0.03, 0.2, 0.6]])
    got = _stats.holm(p)
    assert got.shape == (2, 3)
    valid = ~np.isnan(p)
    ref = multipletests(p[valid], method="holm")[1]
    np.testing.assert_allclose(got[valid], ref, rtol=RTOL)
    assert np.isnan(got[0, 2])
    assert _stats.holm([0.01, 0.04, 0.03]).tolist() == [0.03, 0.06, 0.06]
    np.testing.assert_array_equal(_stats.holm([0.6, 0.7, 0.9]), [1.0, 1.0, 1.0])


def test_holm_integer_input_gives_float_pvalues():
    """Integer p-values (0 and 1) are p-values: the result is float64."""
    got = _stats.holm([0, 1, 0])
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, [0.0, 1.0, 0.0])


# ---------------------------------------------------------------------------------------------
# Newey–West window of the zero-mean test
# ---------------------------------------------------------------------------------------------

def test_newey_west_bandwidth_formula():
    """K = ⌊4(N/100)^(2/9)⌋, at most N − 1 (contract §3.3), over a range of N."""
    assert _stats.newey_west_bandwidth(1) == 0
    assert _stats.newey_west_bandwidth(2) == 1
    assert _stats.newey_west_bandwidth(100) == 4
    assert _stats.newey_west_bandwidth(1000) == 6
    for n in list(range(1, 3000)) + [10**4, 10**5, 10**6, 2 * 10**6]:
        ref = min(math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0)), n - 1)
        assert _stats.newey_west_bandwidth(n) == ref, n


def test_newey_west_n_eff_hand_values():
    """N/(1 + 2 Σ_ℓ (1 − ℓ/(K+1)) ρ̂_ℓ), clipped to [2, N]; N where the sum is ≤ 0 or nan."""
    rho = np.array([[1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
                    [0.3, -1.0, np.nan, 0.0, 0.5, 0.9],
                    [0.3, 0.0, 0.0, 0.0, 0.4, 0.9]])
    got = _stats.newey_west_n_eff(rho, 2, 100)
    # weights 1 − ℓ/3: 2/3, 1/3
    total = [0.3 * 2 / 3 + 0.3 / 3, -2 / 3, np.nan, 0.0, 0.5 * 2 / 3 + 0.4 / 3, 0.9]
    exp = [100 / (1 + 2 * total[0]), 100.0, 100.0, 100.0, 100 / (1 + 2 * total[4]),
           100 / (1 + 2 * 0.9)]
    np.testing.assert_allclose(got, exp, rtol=RTOL)
    # bandwidth larger than the lags present: weights 1 − ℓ/(K + 1) with K = 9
    np.testing.assert_allclose(_stats.newey_west_n_eff(rho[:2, :1], 9, 50),
                               [50 / (1 + 2 * 0.9 * 0.3)], rtol=RTOL)
    # one lag only (K_used = 1), total > 0
    np.testing.assert_allclose(_stats.newey_west_n_eff(rho[:2, 4:5], 1, 40),
                               [40 / (1 + 2 * 0.5 * 0.5)], rtol=RTOL)
    # clipping at 2 and a sum of exactly 1/2 … 1
    np.testing.assert_allclose(_stats.newey_west_n_eff(np.array([[1.0], [50.0]]), 1, 10),
                               [2.0], rtol=0)
    np.testing.assert_allclose(_stats.newey_west_n_eff(np.array([[1.0], [1.0]]), 1, 10),
                               [10 / 2.0], rtol=RTOL)


def test_newey_west_n_eff_no_lags_and_singular_sum():
    """No lag (ρ̂ at lag 0 only): N for every joint; a sum of −1/2 (a zero denominator) gives N
    silently."""
    np.testing.assert_array_equal(_stats.newey_west_n_eff(np.ones((1, 3)), 4, 80), [80.0] * 3)
    ctx = _no_warnings()
    try:
        got = _stats.newey_west_n_eff(np.array([[1.0], [-1.0]]), 1, 30)
    finally:
        ctx.__exit__(None, None, None)
    np.testing.assert_array_equal(got, [30.0])


# ---------------------------------------------------------------------------------------------
# Autocorrelation
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("max_lag", [3, 8, 20])
@pytest.mark.parametrize("centre", [True, False])
def test_acf_fft_matches_brute_force_over_segments(max_lag, centre):
    """Biased ρ̂ with the overall mean, products inside segments only, denominator N at all lags."""
    rng = np.random.default_rng(5)
    x = rng.standard_normal((90, 3)).cumsum(axis=0) * 0.3 + 1.5
    starts = [0, 30, 33, 70]
    got = _stats.acf_fft(x, starts, max_lag, centre=centre)
    # FFT vs explicit sums: rounding of the transforms only
    np.testing.assert_allclose(got, ref_acf(x, starts, max_lag, centre), rtol=1e-11, atol=1e-13)


def test_acf_fft_one_dimensional_float32_and_whole_float_starts():
    """A 1-D series is one column; float32 data are used in double precision; whole-float
    starts are segment indices."""
    rng = np.random.default_rng(6)
    x32 = rng.standard_normal(64).astype(np.float32)
    for lag in (4, 12):
        got = _stats.acf_fft(x32, np.array([0.0, 20.0]), lag)
        np.testing.assert_allclose(got, ref_acf(x32.astype(np.float64), [0, 20], lag),
                                   rtol=1e-12, atol=1e-14)


def test_acf_fft_exact_direct_sums_up_to_eight_lags():
    """Up to _DIRECT_LAGS = 8 lags the products are summed directly: on small integers (exact
    products and sums, no centring) ρ̂ is the exact ratio, bit for bit."""
    rng = np.random.default_rng(7)
    x = rng.integers(-5, 6, size=(60, 2)).astype(np.float64)
    starts = [0, 25]
    got = _stats.acf_fft(x, starts, 8, centre=False)
    for j in range(2):
        col = [int(v) for v in x[:, j]]
        c0 = sum(v * v for v in col)
        for lag in range(9):
            num = sum(col[t] * col[t - lag] for a, b in _segments(starts, 60)
                      for t in range(a + lag, b))
            assert got[lag, j] == float(Fraction(num, c0))


def test_acf_fft_lags_past_every_segment_are_exactly_zero():
    """No product joins two segments: lags at or beyond every segment's length are exactly 0
    (FFT path, max_lag > 8)."""
    rng = np.random.default_rng(8)
    x = rng.standard_normal((10, 2))
    got = _stats.acf_fft(x, [0, 5], 9)
    np.testing.assert_array_equal(got[5:], 0.0)
    np.testing.assert_allclose(got, ref_acf(x, [0, 5], 9), rtol=1e-11, atol=1e-13)


def test_acf_fft_constant_is_nan_and_small_amplitude_is_not():
    """A constant column gives nan at every lag; a tiny (sum of squares < 1) one is a number."""
    rng = np.random.default_rng(9)
    x = np.column_stack([np.full(40, 3.0), 1e-3 * rng.standard_normal(40)])
    for lag in (2, 12):
        got = _stats.acf_fft(x, [0], lag)
        assert np.all(np.isnan(got[:, 0]))
        np.testing.assert_allclose(got[:, 1], ref_acf(x[:, 1], [0], lag)[:, 0], rtol=1e-11,
                                   atol=1e-13)


def test_acf_fft_many_columns_in_batches():
    """Long series are processed in column batches: every column is computed (N = 300,000, 8
    columns: 4 per batch)."""
    rng = np.random.default_rng(10)
    x = rng.standard_normal((300_000, 8))
    x[:, 7] += 0.5 * np.roll(x[:, 7], 1)
    got = _stats.acf_fft(x, [0], 1)
    xc = x - x.mean(axis=0)
    ref = (xc[1:] * xc[:-1]).sum(axis=0) / (xc**2).sum(axis=0)
    np.testing.assert_allclose(got[1], ref, rtol=1e-10)  # long sums in another order
    assert got[1, 7] > 0.3


def test_segment_lag_pairs_stay_inside_segments():
    """Rows (k, k − lag) with both in the same segment (rows before the first start are a run
    of their own); whole-float starts are indices."""
    x = np.arange(12.0)[:, None] * 10
    for starts in ([0, 4, 9], np.array([0.0, 4.0, 9.0]), [2, 7]):
        for lag in (1, 2):
            cur, prev, idx = _stats._segment_lag_pairs(x, starts, lag)
            first = int(starts[0])
            segs = ([(0, first)] if first > 0 else []) + _segments(starts, 12)
            exp = [k for a, b in segs for k in range(a + lag, b)]
            np.testing.assert_array_equal(idx, exp)
            np.testing.assert_array_equal(cur[:, 0], x[exp, 0])
            np.testing.assert_array_equal(prev[:, 0], x[np.array(exp) - lag, 0])


# ---------------------------------------------------------------------------------------------
# Andrews bandwidth, Bartlett, long-run variance
# ---------------------------------------------------------------------------------------------

def test_andrews_bandwidth_formula_grid():
    """⌊1.1447·(α(1)·N)^(1/3)⌋, α(1) = 4φ²/((1 − φ)²(1 + φ)²), |φ| clipped to 0.999, int64."""
    phis = [-1.5, -1.0, -0.999, -0.9, -0.5, -0.1, 0.0, 0.05, 0.3, 0.7, 0.95, 0.999, 1.0, 2.0]
    for n in (10, 100, 1000, 123457):
        got = _stats.andrews_bandwidth(phis, n)
        assert got.dtype == np.int64
        assert got.tolist() == [ref_andrews(p, n) for p in phis]
    assert _stats.andrews_bandwidth([0.5], 1000).tolist() == [math.floor(1.1447 * (1000 / 0.5625) ** (1 / 3))]


def test_andrews_bandwidth_float32_coefficients_in_double():
    """φ given as float32 is converted to float64 first: near an integer the floor of
    1.1447·(α(1)N)^(1/3) is that of the double-precision value."""
    phi32 = np.array([0.85354817, 0.93861467, 0.94920176], dtype=np.float32)
    got = _stats.andrews_bandwidth(phi32, 1000)
    assert got.tolist() == [ref_andrews(float(p), 1000) for p in phi32] == [38, 71, 81]


def test_andrews_bandwidth_nan_is_zero_lags():
    """A nan coefficient gives 0 lags."""
    ctx = _no_warnings()
    try:
        got = _stats.andrews_bandwidth([np.nan, 0.5], 200)
    finally:
        ctx.__exit__(None, None, None)
    assert got.tolist() == [0, ref_andrews(0.5, 200)]


def test_bartlett_long_run_variance_equals_statsmodels_one_segment():
    """γ₀ + 2 Σ (1 − j/(L + 1)) γ_j, γ_j over N = statsmodels S_hac_simple(x, nlags=L) (one
    segment); per-column L; x used as given (not centred again)."""
    from statsmodels.stats.sandwich_covariance import S_hac_simple

    rng = np.random.default_rng(11)
    x = rng.standard_normal((200, 3)).cumsum(axis=0) * 0.2 + 0.7  # deliberately not centred
    bw = [0, 3, 7]
    got = _stats.bartlett_long_run_variance(x, [0], bw)
    for j in range(3):
        ref = float(np.atleast_2d(S_hac_simple(x[:, j:j + 1], nlags=bw[j]))[0, 0]) / 200
        assert got[j] == pytest.approx(ref, rel=1e-11)  # FFT-free direct vs statsmodels loops


def test_bartlett_long_run_variance_segments_float_input():
    """No lag across segments; float32 x and whole-float bandwidths are taken exactly."""
    rng = np.random.default_rng(12)
    x32 = rng.standard_normal((80, 2)).astype(np.float32)
    x = x32.astype(np.float64)
    starts = [0, 30, 35]
    got = _stats.bartlett_long_run_variance(x32, starts, np.array([2.0, 11.0]))
    for j, L in enumerate((2, 11)):
        ref = ref_acov(x[:, j], starts, 0) / 80
        for lag in range(1, L + 1):
            ref += 2 * (1 - lag / (L + 1)) * ref_acov(x[:, j], starts, lag) / 80
        assert got[j] == pytest.approx(ref, rel=1e-12)


def _check_lrv(e, starts):
    got = _stats.long_run_variance(e, starts)
    ref = ref_long_run_variance(e, starts)
    np.testing.assert_allclose(got.variance, ref["variance"], rtol=RTOL)
    np.testing.assert_allclose(got.phi, ref["phi"], rtol=1e-11, atol=1e-15)
    np.testing.assert_array_equal(got.bandwidth, ref["bandwidth"])
    assert got.bandwidth.dtype.kind == "i"
    np.testing.assert_allclose(got.long_run_variance, ref["lrv"], rtol=1e-10)
    np.testing.assert_allclose(got.n_eff, ref["n_eff"], rtol=1e-10)
    return got, ref


def test_long_run_variance_matches_transcription_with_segments():
    """Andrews–Monahan: φ̂ lag-1 biased ρ̂ inside segments, u prewhitened per segment and centred,
    Andrews' L capped at the longest u segment − 1, Bartlett, recoloured by (1 − φ̂)², N_eff
    clipped to [2, N]; columns with different means and colours."""
    rng = np.random.default_rng(13)
    n = 400
    e = np.empty((n, 3))
    w = rng.standard_normal((n, 3))
    e[0] = w[0]
    for k in range(1, n):
        e[k] = np.array([0.8, -0.4, 0.0]) * e[k - 1] + w[k]
    e += [5.0, -1.0, 0.2]
    _check_lrv(e, [0])
    _check_lrv(e, [0, 97, 150, 152, 300])
    _check_lrv(e[:, 0], [0, 200])  # one-dimensional


def test_long_run_variance_phi_clipped_both_ways():
    """|φ̂| ≤ 0.999: a ramp (φ̂ → 1) and an alternating ramp (φ̂ → −1)."""
    t = np.arange(5000.0)
    e = np.column_stack([t, t * (-1.0) ** t])
    got, _ = _check_lrv(e, [0])
    np.testing.assert_array_equal(got.phi, [0.999, -0.999])


def test_long_run_variance_one_row_segments_first():
    """Segments of a single row contribute no pair; the prewhitened series' segments start
    where the kept rows jump."""
    rng = np.random.default_rng(14)
    e = rng.standard_normal((60, 2)).cumsum(axis=0)
    _check_lrv(e, [0, 1, 2, 30])


def test_long_run_variance_bandwidth_capped_by_short_segments():
    """A smooth residual cut into short segments: L is the longest u segment's length − 1."""
    t = np.arange(200.0)
    e = np.column_stack([np.sin(2 * np.pi * t / 40), np.cos(2 * np.pi * t / 55)])
    starts = list(range(0, 200, 6))
    got, _ = _check_lrv(e, starts)
    np.testing.assert_array_equal(got.bandwidth, [4, 4])


def test_long_run_variance_zero_bandwidth_and_tiny_segments():
    """Two-row segments: u has one row per segment, so L = 0 lags."""
    rng = np.random.default_rng(15)
    e = rng.standard_normal((12, 2))
    got, _ = _check_lrv(e, [0, 2, 4, 6, 8, 10])
    np.testing.assert_array_equal(got.bandwidth, [0, 0])


def test_long_run_variance_n_eff_clipped_to_2_and_n():
    """A random-walk-like residual gives N_eff < 2 before clipping; an alternating one > N."""
    rng = np.random.default_rng(16)
    t = np.arange(30.0)
    smooth = np.sin(t / 5) + 1e-3 * rng.standard_normal(30)
    alt = t * (-1.0) ** t
    got, _ = _check_lrv(np.column_stack([smooth, alt]), [0])
    assert got.n_eff[0] == 2.0 and got.n_eff[1] == 30.0
    raw = 30 * got.variance / got.long_run_variance
    assert raw[0] < 2.0 and raw[1] > 30.0


def test_long_run_variance_short_and_constant():
    """N = 1, 2, 3 and a constant column: LRV nan where u has fewer than two rows, N_eff = N,
    φ̂ = 0 for a constant, bandwidth 0."""
    got = _stats.long_run_variance(np.array([[2.0, 3.0]]), [0])
    np.testing.assert_array_equal(got.variance, [0.0, 0.0])
    np.testing.assert_array_equal(got.phi, [0.0, 0.0])
    np.testing.assert_array_equal(got.n_eff, [1.0, 1.0])
    np.testing.assert_array_equal(got.bandwidth, [0, 0])
    assert got.bandwidth.dtype.kind == "i"
    assert np.all(np.isnan(got.long_run_variance))
    two = _stats.long_run_variance(np.array([[1.0, 4.0], [3.0, 4.0]]), [0])
    np.testing.assert_array_equal(two.phi, [-0.5, 0.0])
    np.testing.assert_array_equal(two.n_eff, [2.0, 2.0])
    assert np.all(np.isnan(two.long_run_variance))
    _check_lrv(np.array([[1.0, 2.0], [3.0, 2.0], [2.5, 2.0]]), [0])
    _check_lrv(np.array([[1.0], [3.0], [2.5], [7.0]]), [0])


def test_long_run_variance_float32_input():
    """float32 residuals are analysed in double precision."""
    rng = np.random.default_rng(17)
    e32 = rng.standard_normal((120, 2)).cumsum(axis=0).astype(np.float32)
    got = _stats.long_run_variance(e32, [0])
    ref = ref_long_run_variance(e32.astype(np.float64), [0])
    np.testing.assert_allclose(got.variance, ref["variance"], rtol=RTOL)
    np.testing.assert_allclose(got.long_run_variance, ref["lrv"], rtol=1e-10)


# ---------------------------------------------------------------------------------------------
# Score covariance
# ---------------------------------------------------------------------------------------------

def ref_score_covariance(x, e):
    x = np.asarray(x, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    n, m, p = x.shape
    if n < 3:
        out = np.zeros((p, p))
        for k in range(n):
            for j in range(m):
                out += np.outer(x[k, j], x[k, j]) * e[k, j] ** 2
        return out
    lr = ref_long_run_variance(e, [0])
    out = np.zeros((p, p))
    for j in range(m):
        phi = min(max(lr["phi"][j] + (1.0 + 3.0 * lr["phi"][j]) / n, -0.999), 0.999)
        u = e[1:, j] - phi * e[:-1, j]  # not centred
        lag = min(max(int(lr["bandwidth"][j]), 1), u.size - 1)
        c0 = ref_acov(u, [0], 0)
        g = [(ref_acov(u, [0], ell) / u.size if c0 > 0 else 0.0) * (1 - ell / (lag + 1.0))
             for ell in range(lag + 1)]
        xt = np.zeros((n, p))  # backwards through 1/(1 − φ z)
        xt[n - 1] = x[n - 1, j]
        for k in range(n - 2, -1, -1):
            xt[k] = x[k, j] + phi * xt[k + 1]
        xt = xt[1:]
        gam = np.zeros((n - 1, n - 1))
        for a in range(n - 1):
            for b in range(max(0, a - lag), min(n - 1, a + lag + 1)):
                gam[a, b] = g[abs(a - b)]
        out += xt.T @ gam @ xt
    return out


def test_score_covariance_matches_toeplitz_transcription():
    """Σ_j X̃ᵀ Γ_u X̃ with the Kendall-corrected φ̂, Γ_u the Bartlett-weighted Toeplitz of u's
    biased autocovariances (L ≥ 1) and X̃ the columns run backwards through 1/(1 − φ̂z)."""
    rng = np.random.default_rng(18)
    n, m, p = 150, 2, 3
    x = rng.standard_normal((n, m, p)) + np.linspace(0, 1, n)[:, None, None]
    e = np.empty((n, m))
    w = rng.standard_normal((n, m))
    e[0] = w[0]
    for k in range(1, n):
        e[k] = np.array([0.85, 0.3]) * e[k - 1] + w[k]
    e[:, 1] = np.cos(np.arange(n) * 2.5) + 0.2 * w[:, 1]  # still coloured after AR(1)
    got = _stats.score_covariance(x, e)
    # FFT convolution against the dense Toeplitz product: rounding of the transforms only
    np.testing.assert_allclose(got, ref_score_covariance(x, e), rtol=1e-9)
    assert max(ref_long_run_variance(e, [0])["bandwidth"]) >= 2
    got32 = _stats.score_covariance(x.astype(np.float32), e.astype(np.float32))
    np.testing.assert_allclose(got32, ref_score_covariance(x.astype(np.float32).astype(float),
                                                           e.astype(np.float32).astype(float)),
                               rtol=1e-9)


def test_score_covariance_phi_clipped_and_short_series():
    """φ̂ + (1 + 3φ̂)/N is clipped to ±0.999; N = 2 is the white sum Σ x e² xᵀ; N = 3 is the
    prewhitened estimate with one lag."""
    t = np.arange(300.0)
    x = np.stack([np.sin(t / 7), np.cos(t / 11)], axis=1)[:, :, None] * np.ones(2)
    x[:, :, 1] += 0.1 * t[:, None] / 300
    e = np.column_stack([t, t * (-1.0) ** t])
    np.testing.assert_allclose(_stats.score_covariance(x, e), ref_score_covariance(x, e),
                               rtol=1e-9)
    small = np.arange(12.0).reshape(2, 2, 3) / 7.0
    es = np.array([[1.0, -2.0], [0.5, 3.0]])
    np.testing.assert_allclose(_stats.score_covariance(small, es),
                               ref_score_covariance(small, es), rtol=RTOL)
    x3 = np.arange(18.0).reshape(3, 2, 3) / 5.0 - 1.0
    e3 = np.array([[1.0, -2.0], [0.5, 3.0], [-1.5, 0.25]])
    np.testing.assert_allclose(_stats.score_covariance(x3, e3), ref_score_covariance(x3, e3),
                               rtol=1e-10)


# ---------------------------------------------------------------------------------------------
# Cross-correlation band and its p-value
# ---------------------------------------------------------------------------------------------

def test_cross_correlation_sd_bartlett_sum():
    """sd = √max(1 + 2 Σ_{j=1..J} (1 − j/(J+1)) ρ_e(j) ρ_y(j), 1) · √n_ℓ / D_ℓ, nan as 0."""
    rng = np.random.default_rng(19)
    big, m, p = 4, 2, 3
    rho_e = np.vstack([np.ones((1, m)), rng.uniform(-0.2, 0.9, (big, m))])
    rho_y = np.vstack([np.ones((1, m, p)), rng.uniform(-0.3, 0.9, (big, m, p))])
    rho_y[2, 1, 2] = np.nan
    rho_y[1:, 0, 0] = -rho_e[1:, 0] * 0.9  # negative colour: floored at 1
    n_lag = np.array([100.0, 99.0, 98.0])
    d_lag = np.array([100.0, 100.0, 100.0])
    got = _stats.cross_correlation_sd(rho_e, rho_y, n_lag, d_lag, 100)
    assert got.shape == (m, p, 3)
    for a in range(m):
        for b in range(p):
            s = 1.0
            for j in range(1, big + 1):
                ry = 0.0 if np.isnan(rho_y[j, a, b]) else rho_y[j, a, b]
                s += 2 * (1 - j / (big + 1)) * rho_e[j, a] * ry
            for ell in range(3):
                exp = math.sqrt(max(s, 1.0)) * math.sqrt(n_lag[ell]) / d_lag[ell]
                assert got[a, b, ell] == pytest.approx(exp, rel=1e-13)
    assert np.all(got[0, 0] == np.sqrt(n_lag) / d_lag)


def test_cross_correlation_sd_float32_counts():
    """Counts given as float32 are converted before the square root."""
    n32 = np.array([97.3, 51.1], dtype=np.float32)
    got = _stats.cross_correlation_sd(np.ones((1, 1)), np.ones((1, 1, 1)), n32, [90.0, 50.0], 97)
    np.testing.assert_allclose(got[0, 0], np.sqrt(n32.astype(np.float64)) / [90.0, 50.0],
                               rtol=RTOL)


def test_correlation_pvalue_t_test_with_effective_samples():
    """ν = max(1/sd² − 2, 1); t = |ρ|√ν/√(1 − ρ²); p = 2·sf_t(t, ν). White: Pearson's p."""
    rng = np.random.default_rng(20)
    a, b = rng.standard_normal((2, 30))
    b += 0.4 * a
    r, p_ref = scipy.stats.pearsonr(a, b)
    # scipy computes Pearson's p from a beta law: the same t law, other arithmetic
    assert float(_stats.correlation_pvalue(r, 1 / math.sqrt(30))) == pytest.approx(p_ref, rel=1e-9)
    rho = np.array([0.3, -0.5, 0.1, 0.99], dtype=np.float32)
    sd = np.array([0.1, 0.2, 0.9, 0.05], dtype=np.float32)
    got = _stats.correlation_pvalue(rho, sd)
    r64, s64 = rho.astype(np.float64), sd.astype(np.float64)
    nu = np.maximum(1 / s64**2 - 2, 1.0)
    t = np.abs(r64) * np.sqrt(nu) / np.sqrt(1 - r64**2)
    np.testing.assert_allclose(got, 2 * scipy.stats.t.sf(t, nu), rtol=1e-12)


def test_correlation_pvalue_zero_sd_silent():
    """sd = 0 (infinitely many effective samples): p = 0 for ρ ≠ 0, nan for ρ = 0; no warning."""
    ctx = _no_warnings()
    try:
        got = _stats.correlation_pvalue(np.array([0.3, 0.0, 1.0]), np.array([0.0, 0.0, 0.1]))
    finally:
        ctx.__exit__(None, None, None)
    assert got[0] == 0.0 and np.isnan(got[1]) and got[2] == 0.0


# ---------------------------------------------------------------------------------------------
# Welch spectrum, peaks, information band
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("n, nperseg", [(29, 15), (30, 15), (100, 17), (64, 16), (47, 1), (40, 2)])
def test_welch_window_count_is_scipys(n, nperseg):
    """The windows a segment holds, and so its weight and the dof, are those scipy.signal.welch
    averages (an odd nperseg overlaps by nperseg // 2, a step of nperseg - nperseg // 2)."""
    x = np.random.default_rng(n).standard_normal((n, 1))
    _, _, k = _stats._welch(x, np.array([0]), 1.0, nperseg)
    _, _, zxx = scipy.signal.stft(x[:, 0], nperseg=nperseg, noverlap=nperseg // 2, boundary=None, padded=False)
    assert k == zxx.shape[-1]


def test_welch_dof_formula():
    """ν = 2K/(1 + 2(1 − 1/K)c²), c = 0.1667; 2 for one window (or none)."""
    assert _stats._welch_dof(0) == 2.0
    assert _stats._welch_dof(1) == 2.0
    for k in (2, 3, 10, 1000):
        assert _stats._welch_dof(k) == pytest.approx(ref_dof(k), rel=1e-15)


def test_default_nperseg_power_of_two_near_n_over_8():
    """A power of two ≤ N/8 of the longest segment, within 16..1024, at most that length."""
    for lengths in ([10], [100], [200], [255], [256], [4095], [4096], [4100], [9000], [16384],
                    [20000], [100, 3000], [40, 40000]):
        starts = np.cumsum([0] + lengths[:-1])
        n = int(sum(lengths))
        assert _stats._default_nperseg(starts, n, None) == ref_default_nperseg(starts, n)
    assert _stats._default_nperseg([0], 20000, None) == 1024
    assert _stats._default_nperseg([0], 200, None) == 16
    assert _stats._default_nperseg([0], 4096, None) == 512
    assert _stats._default_nperseg([0, 50], 80, 64) == 50
    assert _stats._default_nperseg([0], 80, 32) == 32


def test_welch_weighted_by_window_counts_matches_pooled_windows():
    """Segments analysed separately (Hann, 50 % overlap, constant detrend), too-short ones
    skipped, averaged weighted by window count = the mean over all windows."""
    rng = np.random.default_rng(21)
    x = rng.standard_normal((400, 2)).cumsum(axis=0) * 0.1 + rng.standard_normal((400, 2))
    for starts, nperseg in (([0, 5, 69, 133, 190, 240], 64), ([0.0, 20.0, 180.0], 32),
                            ([0, 7, 12, 400 - 13], 2), ([0, 100, 115, 130, 300], 16)):
        freq, power, k = _stats._welch(x, starts, 10.0, nperseg)
        rf, rp, rk = ref_welch(x, starts, 10.0, nperseg)
        assert k == rk
        np.testing.assert_allclose(freq, rf, rtol=RTOL)
        np.testing.assert_allclose(power, rp, rtol=1e-12)


def test_welch_no_segment_long_enough_gives_none():
    """When no segment holds nperseg samples there is no spectrum: (freq, power) = (None, None)
    and no window."""
    x = np.ones((40, 2))
    assert _stats._welch(x, [0, 20], 1.0, 32) == (None, None, 0)


def test_side_medians_windows_and_edges():
    """Medians over b−outer..b−inner and b+inner..b+outer; near the ends the existing bins if
    at least three, else nan."""
    rng = np.random.default_rng(22)
    for f in (2, 5, 8, 9, 10, 11, 12, 25, 40):
        logp = rng.standard_normal(f)
        for inner, outer in ((3, 10), (0, 4), (1, 3), (2, 6), (3, 5)):
            got = _stats._side_medians(logp, inner, outer)
            ref = ref_side_medians(logp, inner, outer)
            np.testing.assert_array_equal(got[0], ref[0])
            np.testing.assert_array_equal(got[1], ref[1])


def _signal(n=3000, m=2, seed=23):
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    e = rng.standard_normal((n, m))
    e[:, 0] += 0.8 * np.sin(2 * np.pi * 0.1 * t)
    e[:, 1] = 0.5 * e[:, 1] + np.convolve(rng.standard_normal(n), np.ones(4) / 4, mode="same")
    e[:, 1] += 0.6 * np.sin(2 * np.pi * 0.23 * t + 0.4)
    return e


def _check_spectrum(e, starts, *, sample_rate=None, nperseg=None, inner=3, outer=10):
    got = _stats.residual_spectrum(e, starts, sample_rate=sample_rate, nperseg=nperseg,
                                   inner=inner, outer=outer)
    n = np.asarray(e).shape[0]
    nps = ref_default_nperseg(starts, n) if nperseg is None else min(nperseg, max(
        b - a for a, b in _segments(starts, n)))
    fs = 1.0 if sample_rate is None else sample_rate
    freq, power, dof, ratio, pvalue, share, is_peak = ref_spectrum(e, starts, fs, nps, inner, outer)
    assert got.nperseg == nps
    assert got.dof == pytest.approx(dof, rel=1e-15)
    np.testing.assert_allclose(got.frequency, freq, rtol=RTOL)
    np.testing.assert_allclose(got.power, power, rtol=1e-12)
    assert got.is_peak.dtype == bool
    np.testing.assert_array_equal(got.is_peak, is_peak)
    np.testing.assert_array_equal(np.isnan(got.ratio), np.isnan(ratio))
    np.testing.assert_array_equal(np.isnan(got.share), np.isnan(share))
    # log/exp of the power-of-two-scaled power against the unscaled one: a few ulps
    np.testing.assert_allclose(got.ratio, ratio, rtol=1e-11)
    np.testing.assert_allclose(got.pvalue, pvalue, rtol=1e-8)  # chi2 tail amplifies ulps
    np.testing.assert_allclose(got.share, share, rtol=1e-10, atol=1e-15)
    peaks = [{"joint": int(j), "frequency": float(freq[b]), "ratio": float(ratio[b, j]),
              "pvalue": float(pvalue[b, j]), "share": float(share[b, j]), "bin": int(b)}
             for b, j in np.argwhere(is_peak)]
    assert len(got.peaks) == len(peaks)
    for g, r in zip(got.peaks, peaks):
        assert set(g) == set(r)
        assert g["joint"] == r["joint"] and g["bin"] == r["bin"]
        assert g["frequency"] == pytest.approx(r["frequency"], rel=RTOL)
        for key in ("ratio", "share"):
            assert g[key] == pytest.approx(r[key], rel=1e-10)
        assert g["pvalue"] == pytest.approx(r["pvalue"], rel=1e-8, abs=1e-300)
    return got


def test_residual_spectrum_matches_transcription():
    """Welch by segments, ν, background = larger side median of log power / median(χ²_ν/ν),
    ratio, χ² p-value, local maxima among tested bins, share = excess over ±2 bins × Δf / var;
    frequency in cycles per sample without a sample rate, Hz with one."""
    e = _signal()
    got = _check_spectrum(e, [0])
    assert got.frequency[-1] == 0.5
    assert any(p["joint"] == 0 and abs(p["frequency"] - 0.1) < 0.01 for p in got.peaks)
    _check_spectrum(e, [0, 1400, 1420, 2000], sample_rate=250.0)
    _check_spectrum(e, [0, 1000], sample_rate=4.0, nperseg=128, inner=2, outer=7)
    _check_spectrum(e[:, 1], [0], nperseg=100)


def test_residual_spectrum_float32_input():
    """float32 residuals are analysed in double precision."""
    e32 = _signal(1200).astype(np.float32)
    _check_spectrum(e32.astype(np.float64), [0])
    got = _stats.residual_spectrum(e32, [0])
    ref = ref_spectrum(e32.astype(np.float64), [0], 1.0, ref_default_nperseg([0], 1200))
    np.testing.assert_allclose(got.power, ref[1], rtol=1e-12)


def test_residual_spectrum_scaling_by_powers_of_two():
    """Each joint is scaled by a power of two: e·2^k gives exactly power·4^k and the same
    ratios, p-values and shares, even at 1e±200 and with joints of very different size;
    an overflowing power is IEEE inf without a warning."""
    e = _signal(1500)
    base = _stats.residual_spectrum(e, [0])
    for k in (-700, -40, 40, 660):
        s = np.ldexp(e, k)
        s[:, 1] = np.ldexp(e[:, 1], -k // 2)
        got = _stats.residual_spectrum(s, [0])
        with np.errstate(over="ignore", under="ignore"):
            np.testing.assert_array_equal(got.power[:, 0], np.ldexp(base.power[:, 0], 2 * k))
            np.testing.assert_array_equal(got.power[:, 1],
                                          np.ldexp(base.power[:, 1], 2 * (-k // 2)))
        np.testing.assert_array_equal(got.ratio, base.ratio)
        np.testing.assert_array_equal(got.pvalue, base.pvalue)
        np.testing.assert_array_equal(got.share, base.share)
    ctx = _no_warnings()
    try:
        huge = _stats.residual_spectrum(e * 1e200, [0])
    finally:
        ctx.__exit__(None, None, None)
    assert np.isinf(huge.power).any()
    np.testing.assert_allclose(huge.ratio, base.ratio, rtol=1e-11)


def test_residual_spectrum_zero_power_joint_is_not_tested():
    """A joint whose Welch power is zero (constant inside each segment, two levels) or which is
    constant is not tested; the next joint still is."""
    n = 1024
    e = np.empty((n, 3))
    e[:512, 0], e[512:, 0] = 1.0, 5.0
    e[:, 1] = 2.0
    e[:, 2] = _signal(n)[:, 0]
    got = _stats.residual_spectrum(e, [0, 512])
    assert np.all(np.isnan(got.ratio[:, :2])) and np.all(np.isnan(got.share[:, :2]))
    assert not got.is_peak[:, :2].any()
    assert np.isfinite(got.ratio[:, 2]).any()
    ref = ref_spectrum(e[:, 2:], [0, 512], 1.0, ref_default_nperseg([0, 512], n))
    np.testing.assert_allclose(got.ratio[:, 2], ref[3][:, 0], rtol=1e-11)


def test_residual_spectrum_one_bin_is_not_tested():
    """nperseg = 1: a single (zero) bin, nothing tested."""
    got = _stats.residual_spectrum(np.arange(20.0) ** 1.5, [0], nperseg=1)
    assert got.power.shape == (1, 1) and np.isnan(got.ratio).all() and got.peaks == []


def ref_information_bandwidth(tau, starts, fraction, fs):
    x = np.asarray(tau, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    freq, power, _ = ref_welch(x, starts, fs, ref_default_nperseg(starts, x.shape[0]))
    best = None
    for j in range(x.shape[1]):
        total = power[:, j].sum()
        if not total > 0:
            continue
        cum = np.cumsum(power[:, j]) / total
        idx = next((i for i in range(len(cum)) if cum[i] >= fraction), len(cum))
        best = idx if best is None else max(best, idx)
    return float("nan") if best is None else float(freq[min(best, len(freq) - 1)])


def test_information_bandwidth_first_bin_reaching_the_fraction():
    """The first frequency where the cumulative Welch power share reaches ``fraction``, the
    largest over joints; Nyquist if never reached; nan for zero torque; 1-D input is one joint."""
    rng = np.random.default_rng(24)
    tau = np.cumsum(rng.standard_normal((2000, 2)), axis=0) + 3.0
    tau[:, 1] = np.sin(np.arange(2000) / 3.0) + 0.01 * rng.standard_normal(2000)
    for starts, fs, fraction in (([0], None, 0.99), ([0, 700], 500.0, 0.9),
                                 ([0, 1500], None, 0.5), ([0], 8.0, 1.5)):
        got = _stats.information_bandwidth(tau, starts, fraction=fraction, sample_rate=fs)
        assert got == ref_information_bandwidth(tau, starts, fraction, 1.0 if fs is None else fs)
    assert _stats.information_bandwidth(tau, [0], fraction=1.5) == 0.5
    assert _stats.information_bandwidth(tau[:, 0], [0]) == ref_information_bandwidth(
        tau[:, 0], [0], 0.99, 1.0)
    assert math.isnan(_stats.information_bandwidth(np.zeros((300, 2)), [0]))
    both = np.column_stack([np.zeros(300), tau[:300, 1]])
    assert _stats.information_bandwidth(both, [0]) == ref_information_bandwidth(both, [0], 0.99, 1.0)


def test_information_bandwidth_scale_free_and_exact_threshold():
    """Shares of power are scale-free (joints of 1e±200 and of very different size give the
    same band) and the band edge is the first bin whose share reaches the fraction, computed
    in double precision also for float32 torque."""
    rng = np.random.default_rng(25)
    tau = np.column_stack([np.cumsum(rng.standard_normal(1500)), rng.standard_normal(1500)])
    ref = _stats.information_bandwidth(tau, [0], fraction=0.95)
    assert ref == ref_information_bandwidth(tau, [0], 0.95, 1.0)
    for scale in ((1e-200, 1e-200), (1e200, 1e200), (1e-200, 1e150), (1e150, 1e-200),
                  (0.5, 0.25)):
        assert _stats.information_bandwidth(tau * np.array(scale), [0], fraction=0.95) == ref
    # the share is of the total power: just above bin k − 1's cumulative share gives bin k
    white = rng.standard_normal(1024)
    freq, power, _ = ref_welch(white[:, None], [0], 1.0, ref_default_nperseg([0], 1024))
    cum = np.cumsum(power[:, 0]) / power[:, 0].sum()
    for k in (5, 20, 40):
        frac = cum[k - 1] + 1e-9
        assert _stats.information_bandwidth(white, [0], fraction=frac) == freq[k], k
    t32 = (np.cumsum(rng.standard_normal(1024)) + 40.0).astype(np.float32)
    t64 = t32.astype(np.float64)
    freq, power, _ = ref_welch(t64[:, None], [0], 1.0, ref_default_nperseg([0], 1024))
    cum = np.cumsum(power[:, 0]) / power[:, 0].sum()
    for k in range(2, 40):
        if cum[k] - cum[k - 1] < 1e-9:
            continue
        below, above = cum[k] * (1 - 1e-13), cum[k] * (1 + 1e-13)
        assert _stats.information_bandwidth(t32, [0], fraction=below) == freq[k], k
        if cum[k + 1] - cum[k] > 1e-9:
            assert _stats.information_bandwidth(t32, [0], fraction=above) == freq[k + 1], k


# ---------------------------------------------------------------------------------------------
# Decimation
# ---------------------------------------------------------------------------------------------

def test_decimate_segments_per_segment_scipy_decimate():
    """scipy.signal.decimate (FIR, zero phase) inside each segment; segments shorter than
    30·factor dropped; the new starts are the running lengths; nothing left gives (None, None)."""
    rng = np.random.default_rng(26)
    x = rng.standard_normal((700, 2)).cumsum(axis=0)
    starts = [0, 50, 110, 170, 230, 520]  # lengths 50, 60, 60, 60, 290, 180
    for factor in (2, 3):
        got, new = _stats.decimate_segments(x, np.asarray(starts, dtype=float), factor)
        parts, nst, pos = [], [], 0
        for a, b in _segments(starts, 700):
            if b - a < 30 * factor:
                continue
            y = scipy.signal.decimate(x[a:b], factor, ftype="fir", axis=0, zero_phase=True)
            parts.append(y)
            nst.append(pos)
            pos += y.shape[0]
        np.testing.assert_array_equal(got, np.concatenate(parts))
        np.testing.assert_array_equal(new, nst)
        assert new.dtype == np.int64
    got32, _ = _stats.decimate_segments(x.astype(np.float32), [0, 400], 2)
    exp = np.concatenate([scipy.signal.decimate(x.astype(np.float32).astype(float)[a:b], 2,
                                                ftype="fir", axis=0) for a, b in ((0, 400), (400, 700))])
    np.testing.assert_array_equal(got32, exp)
    assert _stats.decimate_segments(x[:50], [0], 2) == (None, None)


def test_iid_zero_mean_from_the_moments_is_scipys_one_sample_t_test():
    rng = np.random.default_rng(5)
    e = rng.standard_normal((200, 3)) + np.array([0.0, 0.3, -1.0])
    for ddof in (0, 1):
        z = _stats.iid_zero_mean(e.mean(axis=0), e.var(axis=0, ddof=ddof), e.shape[0], ddof)
        ref = scipy.stats.ttest_1samp(e, 0.0)
        np.testing.assert_allclose(z.statistic_iid, ref.statistic, rtol=1e-12)
        np.testing.assert_allclose(z.pvalue_iid, ref.pvalue, rtol=1e-10)
        np.testing.assert_allclose(z.std, e.std(axis=0, ddof=1), rtol=1e-12)
        assert z.df_iid == 199 and z.n_samples == 200 and z.n_eff is None and z.bandwidth is None


def test_residual_bias_test_reports_the_parameter_error_in_the_residuals_unit():
    # the test runs on each joint scaled by a power of two; the standard errors it reports are unscaled
    rng = np.random.default_rng(6)
    e = rng.standard_normal((500, 2)) + 0.1
    pv = np.array([1e-3, 4e-3])
    starts = np.array([0], dtype=np.int64)
    plain = _stats.residual_bias_test(e, starts, pv)
    tiny = _stats.residual_bias_test(np.ldexp(e, -500), starts, np.ldexp(pv, -1000))
    np.testing.assert_allclose(plain.parameter_standard_error, np.sqrt(pv), rtol=1e-15)
    np.testing.assert_array_equal(tiny.parameter_standard_error, np.ldexp(plain.parameter_standard_error, -500))
    np.testing.assert_array_equal(tiny.standard_error, np.ldexp(plain.standard_error, -500))
    np.testing.assert_array_equal(tiny.statistic, plain.statistic)
    # the parameters' variance widens the error: s²/N_eff alone is smaller
    alone = _stats.residual_bias_test(e, starts)
    assert alone.parameter_standard_error is None
    np.testing.assert_allclose(plain.standard_error**2, alone.standard_error**2 + pv, rtol=1e-12)


@pytest.mark.parametrize("decimate, band, bandwidth, factor", [
    (None, None, None, 1), (1, None, None, 1), (4, None, None, 4),
    ("auto", 5.0, None, 5),      # ⌊f_s / (4 f_I)⌋ = ⌊100 / 20⌋
    ("auto", 40.0, 10.0, 5),     # the band allows no decimation, the bandwidth asks ⌈100 / 20⌉
    ("auto", 40.0, None, 0),     # a band above a quarter of the rate: no factor (the logged rate)
])
def test_information_rate_chooses_the_decimation_factor(decimate, band, bandwidth, factor):
    rng = np.random.default_rng(7)
    e = rng.standard_normal((1200, 2))
    starts = np.array([0, 600], dtype=np.int64)
    rate = _stats.information_rate(e, None, starts, decimate, 100.0, band=band, bandwidth=bandwidth)
    assert rate.factor == factor
    assert rate.band == (band if decimate == "auto" else None)
    if factor >= 2:
        # each segment decimated on its own: ⌈600 / q⌉ rows each
        assert rate.residual is not None and rate.residual.shape == (2 * -(-600 // factor), 2)
        assert rate.starts is not None and rate.starts.tolist() == [0, -(-600 // factor)]
    else:
        assert rate.residual is None and rate.starts is None


def test_residual_spectra_put_the_measured_and_predicted_power_on_the_residuals_grid():
    rng = np.random.default_rng(8)
    meas = rng.standard_normal((2048, 2))
    pred = 0.5 * meas
    starts = np.array([0], dtype=np.int64)
    spectra = _stats.residual_spectra(meas - pred, meas, pred, starts, sample_rate=50.0)
    assert spectra.sides is not None
    p_meas, p_pred = spectra.sides
    assert p_meas.shape == spectra.residual.power.shape == p_pred.shape
    np.testing.assert_allclose(p_pred, 0.25 * p_meas, rtol=1e-12)
    np.testing.assert_allclose(spectra.residual.power, 0.25 * p_meas, rtol=1e-12)  # the residual is 0.5·meas
