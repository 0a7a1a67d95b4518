"""Inputs found to break the contract, each pinned: scale, degenerate values, masked arrays,
huge segment sequences, integers beyond float64. Every test runs on both backends."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import dynval


def _data(n=200, m=2, seed=1):
    rng = np.random.default_rng(seed)
    tau = rng.normal(size=(n, m))
    pred = tau + 0.5 * rng.normal(size=(n, m))
    y = rng.normal(size=(n, m, 3))
    y[:, :, 0] += 0.8 * (tau - pred)
    return tau, pred, y


# --------------------------------------------------------------------------- scale (§1.3)

# Inside the accepted range: 1e±80 (products of two sums of squares overflow or underflow),
# 1e-150 and 1e-162 (squares underflow), and subnormal data.
SCALES = [1e80, 1e-80, 1e140, 1e-150, 1e-162, 2.0**-1030]


def _scale_free(tau, pred, y, backend):
    e = tau - pred
    return {
        "r2": dynval.r2(tau, pred, backend=backend),
        "r2_joints": dynval.r2(tau, pred, multioutput="raw_values", backend=backend),
        "r2_weighted": dynval.r2(tau, pred, multioutput="variance_weighted", backend=backend),
        "vaf": dynval.vaf(tau, pred, backend=backend),
        "fit": dynval.fit_percent(tau, pred, backend=backend),
        "acf": dynval.autocorrelation(e, 5, backend=backend),
        "ljung_box": dynval.ljung_box(e, [2, 5], backend=backend).statistic,
        "box_pierce": dynval.box_pierce(e, 5, backend=backend).statistic,
        "xcorr": dynval.cross_correlation(e, y, 3, backend=backend).rho,
        "xcorr_e_only": dynval.cross_correlation(e, y / np.max(np.abs(y)), 3, backend=backend).rho,
        "t": dynval.zero_mean_test(e, backend=backend).statistic_eff,
    }


def _with_units(tau, pred, backend):
    e = tau - pred
    return {
        "rmse": dynval.rmse(tau, pred, backend=backend),
        "rmse_joints": dynval.rmse(tau, pred, multioutput="raw_values", backend=backend),
        "max_abs_error": dynval.max_abs_error(tau, pred, backend=backend),
        "mean": dynval.residual_mean(e, backend=backend),
        "std": dynval.zero_mean_test(e, backend=backend).std,
    }


@pytest.mark.parametrize("scale", SCALES, ids=lambda s: f"{s:.0e}")
def test_scale_free_results_do_not_depend_on_the_data_scale(scale, backend):
    tau, pred, y = _data()
    if scale < 1e-300:  # subnormal data hold fewer digits: compare with the data as represented
        tau, pred, y = (np.ldexp(np.ldexp(a, -1030), 1030) for a in (tau, pred, y))
        tau, pred, y = (np.round(a * 2.0**20) / 2.0**20 for a in (tau, pred, y))
    expected = _scale_free(tau, pred, y, backend)
    got = _scale_free(tau * scale, pred * scale, y * scale, backend)
    for key in expected:
        np.testing.assert_allclose(got[key], expected[key], rtol=1e-12, atol=1e-13, err_msg=key)


@pytest.mark.parametrize("scale", [1e-150, 1e-162, 2.0**-1000], ids=lambda s: f"{s:.0e}")
def test_results_with_units_scale_back_exactly(scale, backend):
    tau, pred, _ = _data()
    expected = _with_units(tau, pred, backend)
    got = _with_units(tau * scale, pred * scale, backend)
    for key in expected:
        np.testing.assert_allclose(np.asarray(got[key]) / scale, expected[key], rtol=1e-13, err_msg=key)


def test_brief_examples_at_1e_minus_162(backend):
    # The cases that were wrong: r2 gave 1.0, rmse 0, Box–Pierce Q 60.
    tau, pred, _ = _data()
    e = tau - pred
    s = 1e-162
    assert dynval.r2(tau * s, pred * s, backend=backend) == pytest.approx(dynval.r2(tau, pred), rel=1e-13)
    assert dynval.rmse(tau * s, pred * s, backend=backend) / s == pytest.approx(dynval.rmse(tau, pred), rel=1e-13)
    q = dynval.box_pierce(e * s, 5, backend=backend).statistic
    np.testing.assert_allclose(q, dynval.box_pierce(e, 5).statistic, rtol=1e-12)


@pytest.mark.parametrize("noise_model", ["pooled", "per_joint", "full"])
@pytest.mark.parametrize("scale", [1e-80, 1e-162, 1e120], ids=lambda s: f"{s:.0e}")
def test_information_criteria_shift_by_the_log_of_the_scale(noise_model, scale, backend):
    tau, pred, _ = _data()
    n, m = tau.shape
    base = dynval.criteria(tau, pred, n_params=3, noise_model=noise_model, backend=backend)
    got = dynval.criteria(tau * scale, pred * scale, n_params=3, noise_model=noise_model, backend=backend)
    # F = n_vec·ln σ² (pooled) or N·Σ ln σ_j² / N·ln det Σ̂: each gains N·m·2·ln(scale).
    shift = n * m * 2 * math.log(scale)
    assert got.aic == pytest.approx(base.aic + shift, abs=1e-9 * (abs(base.aic) + abs(shift)))
    assert got.bic == pytest.approx(base.bic + shift, abs=1e-9 * (abs(base.bic) + abs(shift)))


# --------------------------------------------------------------------------- degenerate values (§3.2)


def test_variance_weighted_with_tiny_tss_agrees_and_is_finite(backend):
    tau = np.array([[1e-170, 1.0], [2e-170, 2.0], [4e-170, 3.0]])
    pred = np.array([[1.5e-170, 1.0], [2e-170, 2.5], [3e-170, 3.0]])
    got = dynval.r2(tau, pred, multioutput="variance_weighted", backend=backend)
    per_joint = dynval.r2(tau, pred, multioutput="raw_values", backend=backend)
    assert np.all(np.isfinite(per_joint))
    assert math.isfinite(got)


def test_cross_correlation_of_tiny_signals_is_finite(backend):
    e = np.array([1.0, -2.0, 0.5, 3.0, -1.0]) * 1e-170
    y = (np.array([2.0, -1.0, 0.0, 1.5, -0.5]) * 1e-170)[:, None, None]
    rho = dynval.cross_correlation(e, y, 1, backend=backend).rho
    expected = dynval.cross_correlation(e * 1e170, y * 1e170, 1, backend=backend).rho
    np.testing.assert_allclose(rho, expected, rtol=1e-14)


def test_per_joint_fpe_does_not_depend_on_the_joint_order(backend):
    rng = np.random.default_rng(3)
    e = rng.normal(size=(50, 4)) * np.array([1e140, 1e140, 1e-140, 1e-140])
    tau = e.copy()
    pred = np.zeros_like(e)
    a = dynval.criteria(tau, pred, n_params=2, noise_model="per_joint", backend=backend)
    order = [2, 0, 3, 1]
    b = dynval.criteria(tau[:, order], pred[:, order], n_params=2, noise_model="per_joint", backend=backend)
    assert a.fpe == pytest.approx(b.fpe, rel=1e-12)
    assert a.aic == pytest.approx(b.aic, rel=1e-12)


def test_both_backends_agree_on_degenerate_values():
    if not dynval.backends()["cpp"]["available"]:
        pytest.skip("needs the compiled backend")
    tiny = np.array([[1e-200, 1.0], [1e-200, 2.0], [3e-200, 2.0], [2e-200, 5.0]])
    pred = tiny * 0.5
    for f in (dynval.r2, dynval.vaf, dynval.fit_percent):
        for how in ("pooled", "raw_values", "uniform_average", "variance_weighted"):
            np.testing.assert_allclose(f(tiny, pred, multioutput=how, backend="python"),
                                       f(tiny, pred, multioutput=how, backend="cpp"), rtol=1e-13)
    np.testing.assert_allclose(dynval.cross_correlation(tiny, tiny[:, :, None], 1, backend="python").rho,
                               dynval.cross_correlation(tiny, tiny[:, :, None], 1, backend="cpp").rho, rtol=1e-13)


# --------------------------------------------------------------------------- parameters and types


@pytest.mark.parametrize("rss", [10**400, 2**1030, -(10**400)])
def test_rss_beyond_float64_is_an_invalid_parameter(rss, backend):
    # the integer's first 80 characters and its length: 401 digits would make a long message
    with pytest.raises(dynval.InvalidParameter,
                       match=r"^rss must be a finite number >= 0, got -?\d{79,80}\.\.\. \(\d+ characters\)$"):
        dynval.information_criteria(rss, 100, 2, backend=backend)


def test_core_rss_beyond_float64_is_an_invalid_parameter():
    if not dynval.backends()["cpp"]["available"]:
        pytest.skip("needs the compiled backend")
    from dynval import _core

    with pytest.raises(dynval.InvalidParameter, match=r"^rss must be a finite number >= 0"):
        _core.information_criteria(10**400, 100, 2)


MASKED_CALLS = {
    "r2": lambda a, b: dynval.r2(a, np.asarray(a), backend=b),
    "r2 (pred)": lambda a, b: dynval.r2(np.asarray(a), a, backend=b),
    "sse": lambda a, b: dynval.sse(a, np.asarray(a), backend=b),
    "residual_mean": lambda a, b: dynval.residual_mean(a, backend=b),
    "autocorrelation": lambda a, b: dynval.autocorrelation(a, 2, backend=b),
    "ljung_box": lambda a, b: dynval.ljung_box(a, 2, backend=b),
    "cross_correlation": lambda a, b: dynval.cross_correlation(np.asarray(a), a[:, :, None], 1, backend=b),
    "validate": lambda a, b: dynval.validate(a, np.asarray(a) * 0.9, n_params=1, backend=b),
}


@pytest.mark.parametrize("call", sorted(MASKED_CALLS))
def test_masked_arrays_are_refused(call, backend):
    data = np.ma.masked_array(np.arange(20.0).reshape(10, 2) ** 1.5, mask=np.zeros((10, 2), dtype=bool))
    data.mask[3, 1] = True
    with pytest.raises(dynval.InvalidType, match=r"masked array \(numpy\.ma\)"):
        MASKED_CALLS[call](data, backend)


@pytest.mark.parametrize("segments", [range(10**12), range(10**20), np.arange(10**6)])
def test_huge_segment_sequences_are_refused_promptly(segments, backend):
    e = np.sin(np.arange(50.0))
    start = time.perf_counter()
    with pytest.raises(dynval.InvalidParameter, match=r"^segments must be"):
        dynval.autocorrelation(e, 2, segments=segments, backend=backend)
    assert time.perf_counter() - start < 1.0


# --------------------------------------------------------------------------- tiny levels, unknown dask chunks


def test_a_tiny_level_gives_the_exact_band_without_a_warning(backend):
    # (1 + 1e-300)/2 rounds to 0.5: the quantile was 0 and |rho| / band divided by zero
    tau, pred, y = _data()
    xc = dynval.cross_correlation(tau - pred, y, 3, level=1e-300, backend=backend)
    assert xc.band == pytest.approx(math.sqrt(math.pi / 2) * 1e-300 / math.sqrt(200), rel=1e-13)
    assert all(math.isfinite(ratio) and ratio > 1e290 for *_, ratio in xc.outside)


def test_the_band_quantile_is_unchanged_at_usual_levels():
    import scipy.stats

    from dynval.statistics._stats import z_two_sided

    for level in (0.5, 0.9, 0.95, 0.99, 0.999):
        assert z_two_sided(level) == float(scipy.stats.norm.ppf(0.5 * (1.0 + level)))
    assert z_two_sided(0.3) == pytest.approx(0.38532046640756773, rel=1e-14)


def test_dask_arrays_with_unknown_chunk_sizes_are_an_input_error():
    da = pytest.importorskip("dask.array")
    import dynval.dask

    rng = np.random.default_rng(2)
    tau = da.from_array(rng.standard_normal((300, 2)), chunks=100)
    kept = tau[tau[:, 0] > -10]  # boolean indexing: the chunk sizes are nan until computed
    with pytest.raises(dynval.InvalidShape, match=r"tau_meas has unknown chunk sizes .*compute_chunk_sizes\(\)"):
        dynval.dask.validate(kept, tau, n_params=1)
    with pytest.raises(dynval.InvalidShape, match=r"tau_pred has unknown chunk sizes"):
        dynval.dask.validate(tau, kept, n_params=1)
    kept.compute_chunk_sizes()
    report = dynval.dask.validate(kept, tau, n_params=1)
    assert report.pooled["rmse_per_element"] == 0.0


@pytest.mark.parametrize("rate", [1e-308, 200.0 * 2.0 ** -1000, 1e300])
def test_an_extreme_sample_rate_gives_the_spectrum_without_a_warning(rate):
    # The Welch density per Hz overflows at 1e-308 Hz: it is computed at a power-of-two multiple of
    # the rate and scaled back, so the tests on it (ratios, shares, peaks) are those of a usual rate.
    import warnings

    from dynval.statistics._stats import information_bandwidth, residual_spectrum

    rng = np.random.default_rng(0)
    tau = rng.standard_normal((500, 2))
    e = 0.1 * rng.standard_normal((500, 2))
    usual = residual_spectrum(e, [0], sample_rate=200.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        extreme = residual_spectrum(e, [0], sample_rate=rate)
        band = information_bandwidth(tau, [0], sample_rate=rate)
        dynval.validate(tau, tau + e, n_params=1, sample_rate=rate)
    np.testing.assert_allclose(extreme.ratio, usual.ratio, rtol=1e-12)
    np.testing.assert_allclose(extreme.share, usual.share, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(extreme.is_peak, usual.is_peak)
    # atol: the frequencies at 1e-308 Hz are subnormal
    np.testing.assert_allclose(extreme.frequency, usual.frequency * (rate / 200.0), rtol=1e-15, atol=1e-320)
    assert band == pytest.approx(information_bandwidth(tau, [0], sample_rate=200.0) * rate / 200.0, rel=1e-15)
