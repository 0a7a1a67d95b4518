"""dynval.statistics._periodic: the period of a trajectory and Pintelon & Schoukens' periodic noise test.

Each test names, in a comment, the mutation of python/dynval/statistics/_periodic.py it catches. The size and
power tests run the seeds as columns of one residual (joints are tested independently, so one call
tests 200 seeds at once); the whole file takes a few seconds on one core.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.signal
import scipy.stats

from dynval import InputError
from dynval.checks._errors import InvalidParameter, NonFiniteInput, TooFewSamples
from dynval.statistics._periodic import Period, PeriodicTest, detect_period, periodic_noise_test

FS = 200.0
SEEDS = 200


def fourier_trajectory(rng, period, n, joints=3, harmonics=5):
    """Finite Fourier series q_j(t) = Σ_l a_l/(ωl) sin(ωlt) − b_l/(ωl) cos(ωlt), period in samples."""
    t = np.arange(n, dtype=np.float64)
    w = 2.0 * np.pi / period
    q = np.zeros((n, joints))
    for j in range(joints):
        a, b = rng.normal(size=harmonics), rng.normal(size=harmonics)
        for k in range(1, harmonics + 1):
            q[:, j] += a[k - 1] / (w * k) * np.sin(w * k * t) - b[k - 1] / (w * k) * np.cos(w * k * t)
    return q


def rms(q):
    """Per-sample RMS of q − q̄ over all joints together (the normalisation of the mismatch)."""
    return float(np.sqrt(((q - q.mean(axis=0)) ** 2).sum(axis=1).mean() / q.shape[1]))


def ar1(rng, rho, n, columns):
    """Stationary AR(1) noise of unit variance, one independent series per column."""
    w = rng.standard_normal((n, columns))
    if rho == 0.0:
        return w
    x0 = rng.standard_normal(columns) / math.sqrt(1.0 - rho**2)
    x = scipy.signal.lfilter([1.0], [1.0, -rho], w, axis=0, zi=rho * x0[None, :])[0]
    return x * math.sqrt(1.0 - rho**2)


def periodic_error(rng, period, n, columns, rms, harmonics=(1, 2, 3, 4, 5)):
    """A periodic model error: random amplitudes and phases at the given harmonics, scaled to ``rms``."""
    t = np.arange(n, dtype=np.float64)[:, None]
    err = np.zeros((n, columns))
    for k in harmonics:
        amp = rng.uniform(0.5, 1.5, columns)
        phase = rng.uniform(0.0, 2.0 * np.pi, columns)
        err += amp * np.sin(2.0 * np.pi * k * t / period + phase)
    whole = int(n // period * period)
    return err * (rms / err[: max(whole, 1)].std(axis=0))


def binomial_upper(count_share, n=SEEDS, p=0.05):
    """P(X ≥ observed) for X ~ Binomial(n, p): how surprising the share is for a size-p test."""
    return float(scipy.stats.binom.sf(round(count_share * n) - 1, n, p))


# --------------------------------------------------------------------------------------------------
# detect_period


def test_detects_the_period_of_a_fourier_trajectory_within_half_a_sample():
    # Mutations caught: n_periods rounded up (ceil: 5 of 4.5 periods); the start taken at the
    # beginning instead of leaving the partial period there; seconds not divided by the rate; the
    # deepest valley taken instead of the first (a multiple of T).
    period = 1.37 * FS  # 274 samples
    n = int(4.5 * period)
    for seed in range(5):
        rng = np.random.default_rng(seed)
        q = fourier_trajectory(rng, period, n) + 1e-4 * rng.standard_normal((n, 3))
        p = detect_period(q, sample_rate=FS)
        assert p is not None
        assert abs(p.samples - period) < 0.5
        assert p.n_periods == 4
        assert p.start == math.floor(n - 4 * p.samples)
        assert p.seconds == pytest.approx(p.samples / FS)
        assert abs(p.seconds - 1.37) < 0.5 / FS
        assert p.mismatch < 0.02


def test_non_integer_period_to_sub_sample_precision():
    # Mutation caught: the mismatch taken at the nearest integer lag instead of the refined T (a
    # half-sample shift leaves a mismatch of about 1e-2, not 1e-4).
    for period in (274.5, 101.3):
        rng = np.random.default_rng(7)
        n = int(4.5 * period)
        q = fourier_trajectory(rng, period, n) + 1e-4 * rng.standard_normal((n, 3))
        p = detect_period(q)
        assert p is not None
        assert abs(p.samples - period) < 0.02
        assert p.mismatch < 1e-3
        assert p.seconds is None


def test_the_shortest_period_is_returned_not_a_multiple():
    # q repeats exactly after 2T, and within 1 % after T (a small component at half the fundamental
    # frequency): T is the shortest period under the tolerance 0.02. Mutation caught: the deepest
    # valley (the global minimum of the mismatch) chosen instead of the first one, which gives 2T.
    period, n = 200.0, 2000
    rng = np.random.default_rng(3)
    q = fourier_trajectory(rng, period, n, joints=2)
    t = np.arange(n)
    sub = np.sin(2.0 * np.pi * t / (2.0 * period))[:, None] * np.ones((1, 2))
    sub *= 0.01 * q.std() / (2.0 * sub.std())  # mismatch at T: 2·rms(sub)/rms(q) = 0.01
    p = detect_period(q + sub)
    assert p is not None and abs(p.samples - period) < 0.05
    assert 0.005 < p.mismatch < 0.02
    # Without the sub-harmonic the same trajectory holds 10 periods, and T is found, not 2T or 3T.
    p = detect_period(q)
    assert p is not None and abs(p.samples - period) < 0.05 and p.n_periods == 10


def test_a_trajectory_that_does_not_repeat_has_no_period():
    # Mutation caught: every local minimum of the mismatch accepted as a period (no valley screen,
    # no tolerance).
    n = 3000
    t = np.arange(n) / FS
    incommensurate = np.column_stack([
        np.sin(2 * np.pi * 0.7 * t) + 0.7 * np.sin(2 * np.pi * 0.7 * np.sqrt(2) * t + 1.0),
        0.5 * np.sin(2 * np.pi * 0.7 * np.sqrt(3) * t + 2.0) + np.cos(2 * np.pi * 0.7 * np.pi * t)])
    chirp = np.sin(2 * np.pi * (0.2 * t + 0.05 * t**2))
    assert detect_period(incommensurate, sample_rate=FS) is None
    assert detect_period(chirp, sample_rate=FS) is None


def test_noise_in_q_counts_against_the_tolerance():
    # White noise of 2.5 % of q's RMS makes q(t+T) − q(t) at least √2·2.5 % = 3.5 % of it: not
    # periodic within 2 %, periodic within 5 %. Mutation caught: the tolerance not applied to the
    # refined mismatch (the candidate valleys' looser screen, 2·tolerance + √(d(1)/2), lets it by).
    period, n = 274.0, 1233
    rng = np.random.default_rng(21)
    q = fourier_trajectory(rng, period, n)
    q = q + 0.025 * rms(q) * rng.standard_normal(q.shape)
    assert detect_period(q) is None
    p = detect_period(q, tolerance=0.05)
    assert p is not None and abs(p.samples - period) < 0.5 and 0.03 < p.mismatch < 0.04


@pytest.mark.parametrize("n", [1233, 20000])
def test_a_random_walk_and_noise_have_no_period(n):
    # Mutations caught: every local minimum of the mismatch accepted, or the valley screen and the
    # tolerance both removed (a short lag, where a random walk is close to itself, accepted).
    for seed in range(3):
        rng = np.random.default_rng(seed)
        assert detect_period(np.cumsum(rng.standard_normal((n, 3)), axis=0)) is None
        assert detect_period(rng.standard_normal((n, 2))) is None


def test_a_drift_with_a_fast_vibration_is_not_periodic():
    # A ramp with a small vibration of 20 samples comes within 1.4 % of itself after 20 samples
    # (the ramp moves little relative to its whole range) without ever having moved away: the
    # period must follow lags where the trajectory left itself (mean squared mismatch ≥ 1).
    # Mutation caught: that rule removed (_MIN_MEAN_DIP = 0 returns T ≈ 19.9).
    n = 5000
    t = np.arange(n, dtype=np.float64)
    q = np.column_stack([t + 50.0 * np.sin(2 * np.pi * t / 20), 0.5 * t + 50.0 * np.cos(2 * np.pi * t / 20)])
    assert detect_period(q) is None


def test_detect_period_degenerate_inputs():
    # Checks: a constant q is not periodic (no division by its zero variance: warnings are errors
    # here); parameters are checked. Mutation caught: min_periods not enforced (2 periods asked
    # for whatever min_periods says).
    assert detect_period(np.zeros(500)) is None
    assert detect_period(np.full((500, 2), 3.0)) is None
    rng = np.random.default_rng(0)
    q = fourier_trajectory(rng, 274.0, 700)  # 2.55 periods
    assert detect_period(q) is not None
    assert detect_period(q, min_periods=3) is None
    assert detect_period(q[:10]) is None
    with pytest.raises(InvalidParameter):
        detect_period(q, min_periods=1)
    with pytest.raises(InvalidParameter):
        detect_period(q, tolerance=0.0)
    with pytest.raises(InvalidParameter):
        detect_period(q, sample_rate=-1.0)
    bad = q.copy()
    bad[3, 1] = np.nan
    with pytest.raises(NonFiniteInput):
        detect_period(bad)
    with pytest.raises(InputError):
        detect_period(np.zeros((5, 2, 2)))


def test_period_is_a_frozen_record():
    rng = np.random.default_rng(1)
    p = detect_period(fourier_trajectory(rng, 150.0, 600), sample_rate=100.0)
    assert isinstance(p, Period)
    with pytest.raises(AttributeError):
        p.samples = 1.0  # type: ignore[misc]
    d = p.to_dict()
    assert set(d) == {"samples", "seconds", "n_periods", "start", "mismatch", "method"}
    json.dumps(d)


# --------------------------------------------------------------------------------------------------
# periodic_noise_test: size


@pytest.mark.parametrize(("rho", "n_periods"), [(0.0, 5), (0.9, 5), (0.99, 5), (0.0, 2), (0.99, 2), (0.999, 5)])
def test_size_under_white_and_coloured_noise(rho, n_periods):
    # Residual = noise only, independent of the period, P periods of 400 samples, every harmonic
    # below Nyquist tested (K = 199), 1000 seeds (one call: the seeds are the columns). With a true
    # size of 0.05 the number of p ≤ 0.05 is Binomial(1000, 0.05): 95 % of runs fall in
    # [37, 64] (3.7 %–6.4 %) and a share above 0.08 has probability 2e-5 (with 200 seeds it would
    # be 2.4 %: the first seed set tried gave 17/200 = 8.5 % for AR(1) 0.9, P = 5, whose size
    # measured on 20,000 seeds is 4.9 %). These seeds give 5.1, 5.6, 4.9, 5.2, 5.3 and 3.8 % (in
    # the order of the parameters). Measured on 20,000 seeds, p ≤ 0.05 / 0.01 / 0.001:
    # white P = 2: 5.05 / 1.04 / 0.11 %, P = 5: 5.05 / 1.12 / 0.13 %; AR(1) 0.9 P = 2: 5.07 / 1.01 /
    # 0.10 %, P = 5: 4.91 / 0.95 / 0.09 %; AR(1) 0.99 P = 2: 5.07 / 0.97 / 0.12 %, P = 5: 5.28 /
    # 1.06 / 0.11 %.
    # Mutations caught: σ̂²_k divided by P instead of P − 1, or F(2, 2P) instead of F(2, 2(P − 1))
    # (white, P = 2 and 5); a pooled statistic Σ P|Ē|²/Σ σ̂² against F(2K, 2K(P − 1)) (AR(1));
    # no AR(1) prewhitening (P = 2 with ρ = 0.99: 10 %; ρ = 0.999: 15 %, the leakage of slow noise
    # ties the bins together and Fisher's sum becomes liberal).
    rng = np.random.default_rng(1000 + int(rho * 1000) + n_periods)
    seeds = 1000
    e = ar1(rng, rho, n_periods * 400, seeds)
    r = periodic_noise_test(e, 400.0)
    assert r.n_periods == n_periods and r.samples_per_period == 400 and r.n_harmonics == 199
    share = float(np.mean(r.pvalue <= 0.05))
    assert share <= 0.08, (share, binomial_upper(share, seeds))
    # The harmonics one by one keep their size too (199,000 bin tests, ±0.003 is 4.5 sd).
    assert abs(float(np.mean(r.harmonic_pvalue <= 0.05)) - 0.05) < 0.003


def test_size_with_a_band():
    # Mutation caught: band converted with the wrong unit (K would not be 10).
    rng = np.random.default_rng(77)
    e = ar1(rng, 0.99, 5 * 400, SEEDS)
    r = periodic_noise_test(e, 400.0, sample_rate=FS, band=5.0)
    assert r.n_harmonics == 10 and r.dof == 20
    np.testing.assert_allclose(r.frequency, 0.5 * np.arange(1, 11))
    assert float(np.mean(r.pvalue <= 0.05)) <= 0.08


# --------------------------------------------------------------------------------------------------
# periodic_noise_test: power and effect


def test_power_and_effect_with_a_periodic_model_error():
    # White noise σ = 1 plus a periodic error of RMS 0.5σ at harmonics 1..5 of a 2 s period
    # (400 samples at 200 Hz), P = 5, the band of the trajectory (5 Hz, K = 10). True share of the
    # variance within the periods: 0.25/(0.25 + 399/400) = 0.2004. Measured with 2000 seeds:
    # p ≤ 0.001 in 100 %, effect 0.147–0.256 (mean 0.2003).
    # Mutations caught: the χ² tail taken the wrong way (cdf for sf: no power); the effect's
    # denominator taken over the tested band only, or the mirrored bins (k and L − k) counted once
    # in its numerator (effect off by more than 0.1).
    rng = np.random.default_rng(2024)
    n = 5 * 400
    e = ar1(rng, 0.0, n, SEEDS) + periodic_error(rng, 400.0, n, SEEDS, 0.5)
    r = periodic_noise_test(e, 400.0, sample_rate=FS, band=5.0)
    assert float(np.mean(r.pvalue <= 0.001)) >= 0.95
    true_share = 0.25 / (0.25 + 399 / 400)
    assert np.all(np.abs(r.effect - true_share) <= 0.1), (r.effect.min(), r.effect.max())
    # The error sits at harmonics 1..5: the estimated error power is there, not at 6..10.
    assert np.all(r.error_power[:5].sum(axis=0) > 10 * np.abs(r.error_power[5:]).sum(axis=0) / 5 - 1e-3)


def test_more_periods_give_more_power_and_two_periods_work():
    # P = 2 is the minimum (F(2, 2)): it runs and has some power; P = 5 has more.
    # Mutations caught: F(2, 2P) instead of F(2, 2(P − 1)) (the method names the distribution);
    # the χ² tail taken the wrong way; band converted with the wrong unit (dof ≠ 20).
    rng = np.random.default_rng(99)
    powers = {}
    for n_periods in (2, 5):
        n = n_periods * 400
        e = ar1(rng, 0.0, n, SEEDS) + periodic_error(rng, 400.0, n, SEEDS, 0.5)
        r = periodic_noise_test(e, 400.0, sample_rate=FS, band=5.0)
        assert r.dof == 20 and np.all(np.isfinite(r.pvalue))
        assert f"F(2, {2 * (n_periods - 1)})" in r.method
        powers[n_periods] = float(np.mean(r.pvalue <= 0.001))
    assert 0.2 < powers[2] < powers[5]


def test_effect_is_unbiased_when_every_harmonic_is_tested():
    # Noise only, P = 2, K = 199: the effect must stay near 0. Mutation caught: each harmonic's
    # excess clipped at 0 before the sum (Σ_k max(|Ē_k|² − σ̂²_k/P, 0)), which adds the positive
    # part of every noise-only harmonic: a mean effect of about 0.19 here.
    rng = np.random.default_rng(5)
    e = ar1(rng, 0.0, 2 * 400, SEEDS)
    r = periodic_noise_test(e, 400.0)
    assert float(np.mean(r.effect)) < 0.05
    assert np.all((r.effect >= 0.0) & (r.effect <= 1.0))


def test_noise_level_and_colour_are_measured():
    # The noise spectrum at the harmonics follows the noise's own PSD, colour included, and the
    # noise variance is σ²(L − 1)/L. Mutations caught: the spectrum of the prewhitened residual
    # reported (flat for AR(1) noise) instead of dividing by the filter gain; a one-sided PSD
    # without the factor 2 or without the sampling interval.
    rho = 0.9
    rng = np.random.default_rng(11)
    e = ar1(rng, rho, 10 * 400, SEEDS) + periodic_error(rng, 400.0, 10 * 400, SEEDS, 0.3)
    r = periodic_noise_test(e, 400.0, sample_rate=FS)
    f = r.frequency
    sigma_u2 = 1.0 - rho**2
    psd = 2.0 * sigma_u2 / FS / np.abs(1.0 - rho * np.exp(-2j * np.pi * f / FS)) ** 2
    ratio = r.noise_spectrum.mean(axis=1) / psd  # averaged over 200 seeds: ±3 % at each harmonic
    assert np.all(np.abs(ratio[:150] - 1.0) < 0.12), (ratio.min(), ratio.max())
    white = periodic_noise_test(ar1(rng, 0.0, 5 * 400, SEEDS), 400.0, sample_rate=FS)
    assert float(np.mean(white.noise_spectrum)) == pytest.approx(2.0 / FS, rel=0.02)
    assert float(np.mean(white.noise_variance)) == pytest.approx(399 / 400, rel=0.02)
    np.testing.assert_allclose(white.phi, 0.0, atol=0.1)
    assert float(np.mean(r.phi)) == pytest.approx(rho, abs=0.03)


# --------------------------------------------------------------------------------------------------
# periodic_noise_test: non-integer periods, the Period record, degenerate input


def test_non_integer_period_is_resampled():
    # T = 100.5 samples, 10 periods, an error at harmonics 1..10: resampling each period onto
    # L = 100 points by Fourier interpolation keeps the error in phase from period to period.
    # Mutation caught: the periods cut at round(T) samples without resampling (the error drifts
    # by half a sample per period, up to 1.4 rad over 10 periods at harmonic 10: the common part
    # shrinks and the effect falls far below the truth). Size is kept (white noise, no error).
    period, n_periods = 100.5, 10
    n = int(math.floor(n_periods * period))
    rng = np.random.default_rng(8)
    harmonics = tuple(range(1, 11))
    e = ar1(rng, 0.0, n, SEEDS) + periodic_error(rng, period, n, SEEDS, 0.5, harmonics)
    r = periodic_noise_test(e, period)
    assert r.samples_per_period == 100 and r.n_periods == n_periods and r.period_samples == period
    assert "Fourier interpolation" in r.method
    true_share = 0.25 / 1.25
    assert np.all(np.abs(r.effect - true_share) <= 0.1), (r.effect.min(), r.effect.max())
    assert float(np.mean(r.pvalue <= 0.001)) >= 0.95
    null = periodic_noise_test(ar1(rng, 0.0, n, SEEDS), period)
    assert float(np.mean(null.pvalue <= 0.05)) <= 0.08


def test_a_detected_period_drives_the_test():
    # detect_period on q, periodic_noise_test on the residual of the same run: the last whole
    # periods (from Period.start) are used, so a start-up transient in the first 100 samples stays
    # out. Mutation caught: Period.start ignored (the periods taken from sample 0: the transient
    # enters the first period and the noise variance grows several times).
    period = 274.6
    n = int(4.5 * period)
    rng = np.random.default_rng(4)
    q = fourier_trajectory(rng, period, n) + 1e-4 * rng.standard_normal((n, 3))
    p = detect_period(q, sample_rate=FS)
    assert p is not None and p.n_periods == 4 and p.start > 100
    error = 0.1 * (q - q.mean(axis=0)) / q.std(axis=0)  # RMS 0.1 against noise of SD 0.2
    transient = np.exp(-np.arange(n) / 20.0)[:, None] * np.array([3.0, -2.0, 4.0])
    e = 0.2 * rng.standard_normal((n, 3)) + error + transient
    r = periodic_noise_test(e, p, sample_rate=FS, band=10.0)
    assert r.start == p.start and r.n_periods == 4
    assert np.all(r.pvalue < 1e-3)
    assert np.all(np.abs(r.effect - 0.25 / 1.25) < 0.1)
    np.testing.assert_allclose(r.noise_variance, 0.04, rtol=0.2)


def test_degenerate_residuals():
    # Mutations caught: P < 2 accepted (σ̂² divides by P − 1 = 0); a constant residual giving nan
    # or p < 1 (F = 0/0 from rounding); an exactly periodic residual (no noise) not rejected; the
    # rounding floor removed (empty harmonics of an exact residual get F = rounding/rounding).
    with pytest.raises(TooFewSamples):
        periodic_noise_test(np.zeros(700), 400.0)
    with pytest.raises(ValueError):
        periodic_noise_test(np.zeros(700), Period(400.0, None, 1, 300, 0.0, "given"))
    with pytest.raises(InvalidParameter):
        periodic_noise_test(np.zeros(1000), 1.0)
    with pytest.raises(InvalidParameter):
        periodic_noise_test(np.zeros(1000), 200.0, sample_rate=100.0, band=0.1)  # below 0.5 Hz
    with pytest.raises(NonFiniteInput):
        periodic_noise_test(np.full(1000, np.inf), 200.0)
    r = periodic_noise_test(np.column_stack([np.full(1000, 3.0), np.zeros(1000)]), 200.0)
    assert r.pvalue.tolist() == [1.0, 1.0]
    assert r.effect.tolist() == [0.0, 0.0] and r.noise_variance.tolist() == [0.0, 0.0]
    assert np.all(r.harmonic_pvalue == 1.0)
    t = np.arange(1000)
    exact = np.sin(2 * np.pi * 3 * t / 200) + 0.3 * np.cos(2 * np.pi * 7 * t / 200)
    r = periodic_noise_test(exact, 200.0)
    assert r.pvalue.tolist() == [0.0] and r.effect[0] == pytest.approx(1.0)
    # Harmonics without content and without noise are not tested (p = 1), not F = rounding/rounding.
    empty = np.ones(r.n_harmonics, dtype=bool)
    empty[[2, 6]] = False
    assert np.all(r.harmonic_pvalue[empty] == 1.0) and np.all(r.harmonic_pvalue[~empty] == 0.0)
    # Two periods exactly: F(2, 2) and p-values in (0, 1].
    r = periodic_noise_test(np.random.default_rng(0).standard_normal((400, 2)), 200.0)
    assert r.n_periods == 2 and np.all((r.pvalue > 0) & (r.pvalue <= 1))


def test_scale_free_and_json():
    # Mutations caught: the power-of-two scaling not undone (noise_variance in scaled units), or
    # not done (squared DFT sums overflow at 1e155 and lose their digits to underflow at 1e-165).
    rng = np.random.default_rng(12)
    e = rng.standard_normal((1000, 2))
    base = periodic_noise_test(e, 200.0, sample_rate=50.0)
    for scale in (1e-165, 1e-150, 1e100, 1e155):  # squared DFT sums leave float64 at both ends
        r = periodic_noise_test(e * scale, 200.0, sample_rate=50.0)
        np.testing.assert_allclose(r.pvalue, base.pvalue, rtol=1e-9)
        np.testing.assert_allclose(r.effect, base.effect, rtol=1e-9, atol=1e-15)
        if 1e-150 <= scale <= 1e100:
            np.testing.assert_allclose(r.noise_variance, base.noise_variance * scale**2, rtol=1e-9)
    assert isinstance(base, PeriodicTest)
    d = base.to_dict()
    assert np.asarray(d["noise_spectrum"]).shape == (base.n_harmonics, 2)
    json.dumps(d)
