"""dynval.validate and the ValidationReport: sections, values against closed forms and
independent code, JSON, summary text, errors and degenerate input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval.report._text import pvalue_text

# The hand-checkable example of docs/conventions.md §3.2.
MEAS = np.array([[10.0, 1.0], [20.0, 2.0], [30.0, 1.0], [40.0, 2.0]])
PRED = np.array([[11.0, 2.0], [19.0, 1.0], [31.0, 2.0], [39.0, 1.0]])

SECTIONS = {"provenance", "per_joint", "pooled", "aggregates", "residuals", "autocorrelation",
            "ljung_box", "cross_correlation", "information_criteria", "warnings_text",
            "findings", "bias", "whiteness", "spectrum", "design", "segment_metrics", "physics", "periodic",
            "predictive", "timing"}


def _signals(n=400, seed=0, scales=(20.0, 2.0, 0.5)):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 50.0
    tau = np.column_stack([s * np.sin((j + 1) * t + j) for j, s in enumerate(scales)])
    pred = tau + rng.normal(0.0, 0.1, size=tau.shape)
    return tau, pred


def test_sections_and_provenance(backend):
    tau, pred = _signals()
    report = dynval.validate(tau, pred, n_params=5, backend=backend)
    d = report.to_dict()
    # the sections, and the deciding findings ranked with the first step and why (contract §4)
    assert set(d) == SECTIONS | {"deciding", "first_step", "first_reason"}
    prov = d["provenance"]
    for key in ("profile", "conventions", "units", "n_samples", "n_joints", "n_params", "segments",
                "omitted_rows", "backend", "dynval_version", "contract_version", "report_schema_version"):
        assert key in prov
    assert prov["backend"] == backend
    assert prov["n_samples"] == 400 and prov["n_joints"] == 3 and prov["n_params"] == 5
    assert prov["segments"] == [400]
    assert prov["contract_version"] == dynval.CONTRACT_VERSION
    assert prov["report_schema_version"] == 1
    for key in ("multioutput", "units", "constant_target", "ddof", "adjusted", "max_lag", "band",
                "level", "ljung_box_lags", "noise_model", "ic_constant", "nan_policy"):
        assert key in prov["conventions"]
    # Both RMSE conventions, never a bare rmse in the pooled section.
    assert "rmse" not in d["pooled"]
    assert {"rmse_per_element", "rmse_per_sample"} <= set(d["pooled"])
    assert set(d["per_joint"]) >= {"sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2"}
    assert set(d["information_criteria"]) == {"noise_model", "constant", "n_obs", "n_params", "aic",
                                              "bic", "aicc", "fpe", "naic", "n_eff", "aic_neff",
                                              "bic_neff", "aicc_neff"}
    assert d["cross_correlation"] is None
    json.dumps(d, allow_nan=False)


def test_hand_example_closed_forms(backend):
    r = dynval.validate(MEAS, PRED, n_params=1, max_lag=1, backend=backend)
    np.testing.assert_allclose(r.per_joint["r2"], [0.992, -3.0], rtol=1e-14)
    np.testing.assert_allclose(r.per_joint["fit_percent"], [100 * (1 - math.sqrt(4 / 500)), -100.0],
                               rtol=1e-14)
    np.testing.assert_allclose(r.per_joint["sse"], [4.0, 4.0])
    assert r.pooled["r2"] == pytest.approx(1 - 8 / 1605.5, rel=1e-14)
    assert r.pooled["rmse_per_element"] == pytest.approx(1.0, rel=1e-15)
    assert r.pooled["rmse_per_sample"] == pytest.approx(math.sqrt(2.0), rel=1e-15)
    assert r.aggregates["uniform_average"]["r2"] == pytest.approx(-1.004, rel=1e-13)
    assert r.aggregates["variance_weighted"]["r2"] == pytest.approx(1 - 8 / 501, rel=1e-13)
    # Pooled AIC, the lesson's form: n = N·m = 8, σ̂² = 8/8.
    assert r.information_criteria["aic"] == pytest.approx(2 * 1 + 8 * math.log(1.0), abs=1e-12)
    assert r.information_criteria["bic"] == pytest.approx(1 * math.log(8), rel=1e-14)


def test_summary_leads_with_joints_and_flags_hidden_negative_r2():
    r = dynval.validate(MEAS, PRED, n_params=1, max_lag=1)
    text = r.summary()
    assert text.index("Per joint") < text.index("Pooled")
    hidden = [w for w in r.warnings_text if "joint 2 does worse than a constant" in w]
    assert hidden and "pooled R² is 0.995" in hidden[0]
    worse = [f for f in r.findings if f.kind == "worse_than_constant"]
    assert [(f.joints, f.severity) for f in worse] == [((1,), "deficiency")]
    assert worse[0].effect == pytest.approx(3.0)
    assert hidden[0] in text
    assert str(r) == text


def test_one_dimensional_input_equals_one_column(backend):
    tau, pred = _signals(scales=(3.0,))
    a = dynval.validate(tau[:, 0], pred[:, 0], n_params=2, backend=backend).to_dict()
    b = dynval.validate(tau, pred, n_params=2, backend=backend).to_dict()
    assert a == b


def test_lists_and_float32_accepted(backend):
    tau, pred = _signals(n=50, scales=(3.0, 1.0))
    ref = dynval.validate(tau, pred, n_params=2, backend=backend).to_dict()
    assert dynval.validate(tau.tolist(), pred.tolist(), n_params=2, backend=backend).to_dict() == ref
    r32 = dynval.validate(tau.astype(np.float32), pred.astype(np.float32), n_params=2, backend=backend)
    assert r32.per_joint["r2"].dtype == np.float64


def test_zero_mean_section_matches_scipy_ttest(backend):
    tau, pred = _signals()
    r = dynval.validate(tau, pred, n_params=2, backend=backend)
    zmt = r.residuals["zero_mean_test"]
    t, p = scipy.stats.ttest_1samp(tau - pred, 0.0)
    np.testing.assert_allclose(zmt["statistic_iid"], t, rtol=1e-10)
    np.testing.assert_allclose(zmt["pvalue_iid"], p, rtol=1e-9)
    np.testing.assert_allclose(r.residuals["variance"], np.var(tau - pred, axis=0, ddof=1), rtol=1e-12)
    assert r.residuals["ddof"] == 1


def _lesson_acf(e, L):
    """The lesson's residual_autocorrelation, verbatim (single joint)."""
    e = np.asarray(e).reshape(-1)
    N = e.size
    e0 = e - np.mean(e)
    R0 = np.dot(e0, e0) / N
    rho = np.zeros(L + 1)
    rho[0] = 1.0
    for ell in range(1, L + 1):
        rho[ell] = np.dot(e0[ell:], e0[:-ell]) / (N - ell) / R0
    return rho


def test_autocorrelation_section_and_white_band(backend):
    tau, pred = _signals()
    r = dynval.validate(tau, pred, n_params=2, max_lag=20, backend=backend)
    acf = r.autocorrelation
    e = tau - pred
    for j in range(3):
        np.testing.assert_allclose(acf["rho"][:, j], _lesson_acf(e[:, j], 20), rtol=1e-10, atol=1e-13)
    assert acf["rho"].shape == (21, 3) and acf["band"].shape == (21, 3)
    assert np.all(np.isnan(acf["band"][0]))
    np.testing.assert_allclose(acf["band"][1:], 1.959963984540054 / math.sqrt(400), rtol=1e-14)
    expected = [(j, lag, acf["rho"][lag, j]) for j in range(3) for lag in range(1, 21)
                if abs(acf["rho"][lag, j]) > acf["band"][lag, j]]
    assert acf["outside"] == expected
    np.testing.assert_allclose(acf["fraction_outside"],
                               [sum(1 for o in expected if o[0] == j) / 20 for j in range(3)])


def test_ljung_box_section_matches_statsmodels(backend):
    from statsmodels.stats.diagnostic import acorr_ljungbox

    tau, pred = _signals()
    r = dynval.validate(tau, pred, n_params=2, max_lag=15, backend=backend)
    lb = r.ljung_box
    assert lb["lags"].tolist() == [15] and lb["df"].tolist() == [15]
    for j in range(3):
        ref = acorr_ljungbox((tau - pred)[:, j], lags=[15])
        assert lb["statistic"][0, j] == pytest.approx(ref["lb_stat"].iloc[0], rel=1e-9)
        assert lb["pvalue"][0, j] == pytest.approx(ref["lb_pvalue"].iloc[0], rel=1e-8)


def test_max_lag_zero_skips_the_lag_analysis(backend):
    tau, pred = _signals()
    Y = np.random.default_rng(1).normal(size=(400, 3, 2))
    r = dynval.validate(tau, pred, n_params=2, max_lag=0, regressor=Y, backend=backend,
                        cross_correlation_detail="full")
    assert r.autocorrelation is None and r.ljung_box is None
    assert r.cross_correlation["rho"].shape == (3, 2, 1)
    assert r.bias is None and r.whiteness is None and r.spectrum is None
    assert "not analysed" in r.summary()
    assert r.provenance["conventions"]["ljung_box_lags"] == []


def test_segments_keep_lags_inside_records(backend):
    tau, pred = _signals(n=300, scales=(2.0,))
    e = (tau - pred)[:, 0]
    r = dynval.validate(tau, pred, n_params=1, max_lag=3, segments=[100, 200], backend=backend)
    assert r.provenance["segments"] == [100, 200]
    # Independent: lag products inside each record only, overall mean, adjusted denominators.
    e0 = e - e.mean()
    r0 = e0 @ e0 / 300
    for lag in range(1, 4):
        prods = e0[lag:100] @ e0[:100 - lag] + e0[100 + lag:] @ e0[100:300 - lag]
        assert r.autocorrelation["rho"][lag, 0] == pytest.approx(prods / (300 - 2 * lag) / r0, rel=1e-10)
    # starts form gives the same report
    assert dynval.validate(tau, pred, n_params=1, max_lag=3, segments=[0, 100],
                           backend=backend).to_dict() == r.to_dict()


def test_nan_policy_omit_deletes_rows_and_breaks_segments(backend):
    tau, pred = _signals(n=200, scales=(2.0, 1.0))
    tau_bad = tau.copy()
    tau_bad[50, 1] = np.nan
    r = dynval.validate(tau_bad, pred, n_params=1, nan_policy="omit", max_lag=4, backend=backend)
    assert r.provenance["omitted_rows"] == 1
    assert r.provenance["segments"] == [50, 149]
    keep = np.ones(200, bool)
    keep[50] = False
    ref = dynval.validate(tau[keep], pred[keep], n_params=1, segments=[50, 149], max_lag=4,
                          backend=backend).to_dict()
    got = r.to_dict()
    for section in ("per_joint", "pooled", "autocorrelation", "ljung_box", "information_criteria"):
        assert got[section] == ref[section]
    assert any("omitted" in w for w in r.warnings_text)


def test_cross_correlation_ranks_the_missing_column(backend):
    rng = np.random.default_rng(5)
    n = 500
    Y = rng.normal(size=(n, 2, 3))
    tau = rng.normal(size=(n, 2)) * 5
    # The residual of joint 1 contains column 2 of joint 1's regressor row.
    pred = tau.copy()
    pred[:, 1] -= 0.8 * Y[:, 1, 2] + rng.normal(0.0, 0.3, n)
    pred[:, 0] -= rng.normal(0.0, 0.3, n)
    r = dynval.validate(tau, pred, n_params=3, regressor=Y, max_lag=5, backend=backend,
                        cross_correlation_detail="full")
    xc = r.cross_correlation
    assert xc["rho"].shape == (2, 3, 6) and xc["constant_mask"].shape == (2, 3)
    assert xc["band"] == pytest.approx(1.959963984540054 / math.sqrt(n), rel=1e-14)
    j, c, lag, rho, _ratio = xc["outside"][0]
    assert (j, c, lag) == (1, 2, 0)
    e = tau[:, 1] - pred[:, 1]
    assert rho == pytest.approx(np.corrcoef(e, Y[:, 1, 2])[0, 1], rel=1e-10)
    ratios = [o[4] for o in xc["outside"]]
    assert ratios == sorted(ratios, reverse=True)
    found = [f for f in r.deficiencies if f.kind == "regressor_correlation"]
    assert [(f.joints, f.columns[0]) for f in found] == [((1,), 2)]
    assert "column 3 (lag 0" in found[0].message
    # stacked (N*m, p) with n_joints gives the same section
    r2 = dynval.validate(tau, pred, n_params=3, regressor=Y.reshape(n * 2, 3), n_joints=2, max_lag=5,
                         backend=backend, cross_correlation_detail="full")
    assert r2.to_dict()["cross_correlation"] == r.to_dict()["cross_correlation"]


def test_bias_is_reported_with_the_corrected_test(backend):
    tau, pred = _signals(n=1000)
    r = dynval.validate(tau, pred - np.array([0.0, 0.05, 0.0]), n_params=1, backend=backend)
    bias = [f for f in r.findings if f.kind == "bias"]
    assert [(f.joints, f.severity) for f in bias] == [((1,), "deficiency")]
    assert bias[0].effect == pytest.approx(abs(r.bias["mean"][1]) / r.per_joint["rmse"][1])
    assert "a systematic bias" in bias[0].message


# ---------------------------------------------------------------- degenerate input


def test_constant_target_joint_gives_ieee_values_and_json_strings(backend):
    tau, pred = _signals(n=100, scales=(2.0, 1.0))
    tau[:, 1] = 3.0
    r = dynval.validate(tau, pred, n_params=1, backend=backend)
    assert r.per_joint["r2"][1] == -np.inf and r.per_joint["fit_percent"][1] == -np.inf
    d = r.to_dict()
    assert d["per_joint"]["r2"][1] == "-Infinity"
    assert d["per_joint"]["nrmse"][1] == "Infinity"
    assert any("measured torque is constant" in w for w in r.warnings_text)
    json.loads(r.to_json())


def test_exact_prediction_of_constant_target_is_nan(backend):
    tau, pred = _signals(n=100, scales=(2.0, 1.0))
    tau[:, 1] = 3.0
    pred[:, 1] = 3.0
    r = dynval.validate(tau, pred, n_params=1, backend=backend)
    assert np.isnan(r.per_joint["r2"][1]) and np.isnan(r.per_joint["vaf"][1])
    assert r.to_dict()["per_joint"]["r2"][1] == "NaN"
    # Zero residual on joint 2: its autocorrelation is nan at every lag, no lag counts as outside.
    assert np.all(np.isnan(r.autocorrelation["rho"][:, 1]))
    assert all(o[0] != 1 for o in r.autocorrelation["outside"])
    assert np.isnan(r.ljung_box["statistic"][0, 1])


def test_exact_prediction_gives_minus_infinite_aic(backend):
    tau, _ = _signals(n=100, scales=(2.0,))
    r = dynval.validate(tau, tau, n_params=2, backend=backend)
    ic = r.information_criteria
    assert ic["aic"] == -np.inf and ic["bic"] == -np.inf and ic["aicc"] == -np.inf and ic["fpe"] == 0.0
    assert r.pooled["r2"] == 1.0 and r.pooled["fit_percent"] == 100.0
    assert r.to_dict()["information_criteria"]["aic"] == "-Infinity"


def test_too_many_parameters_give_nan_aicc_and_fpe(backend):
    tau, pred = _signals(n=5, scales=(2.0,))
    r = dynval.validate(tau, pred, n_params=4, max_lag=1, backend=backend)
    assert np.isnan(r.information_criteria["aicc"]) and np.isnan(r.information_criteria["fpe"])
    assert np.isfinite(r.information_criteria["aic"])


# ---------------------------------------------------------------- errors


def test_error_order_nonfinite_before_parameters(backend):
    tau, pred = _signals(n=50)
    tau[3, 2] = np.inf
    with pytest.raises(dynval.NonFiniteInput, match=r"^tau_meas has a non-finite value \(inf\) at row 3, column 2$"):
        dynval.validate(tau, pred, n_params=-1, profile="nope", backend=backend)


def test_error_messages(backend):
    tau, pred = _signals(n=50)
    with pytest.raises(dynval.InvalidParameter,
                       match=r"^profile must be one of 'lesson', 'matlab', 'statsmodels', 'sklearn', got 'nope'$"):
        dynval.validate(tau, pred, n_params=1, profile="nope", backend=backend)
    with pytest.raises(dynval.ShapeMismatch,
                       match=r"^tau_meas and tau_pred must have the same shape, got \(50, 3\) and \(50, 2\)$"):
        dynval.validate(tau, pred[:, :2], n_params=1, backend=backend)
    with pytest.raises(dynval.TooFewSamples, match=r"^validate needs at least 2 samples, got N=1$"):
        dynval.validate([1.0], [1.0], n_params=1, backend=backend)
    with pytest.raises(dynval.InvalidParameter, match=r"^max_lag must be an integer with 0 <= max_lag < 50, got 50$"):
        dynval.validate(tau, pred, n_params=1, max_lag=50, backend=backend)
    with pytest.raises(dynval.InvalidParameter, match=r"^level must be a number with 0 < level < 1, got 1.5$"):
        dynval.validate(tau, pred, n_params=1, level=1.5, backend=backend)
    with pytest.raises(dynval.InvalidParameter, match=r"^n_params must be an integer with n_params >= 0, got 2.0$"):
        dynval.validate(tau, pred, n_params=2.0, backend=backend)
    with pytest.raises(dynval.InvalidType, match=r"^tau_pred must be an array of real numbers, got complex128$"):
        dynval.validate(tau, pred.astype(complex), n_params=1, backend=backend)
    with pytest.raises(dynval.ShapeMismatch, match=r"regressor must have shape \(N, m, p\) = \(50, 3, p\)"):
        dynval.validate(tau, pred, n_params=1, regressor=np.zeros((50, 2, 4)), backend=backend)
    with pytest.raises(TypeError):
        dynval.validate(tau, pred)  # n_params has no default


def test_unknown_backend_is_invalid_parameter():
    tau, pred = _signals(n=20)
    with pytest.raises(dynval.InvalidParameter, match=r"^backend must be one of"):
        dynval.validate(tau, pred, n_params=1, backend="fortran")


# ---------------------------------------------------------------- text helpers


def test_pvalue_text_uses_the_logarithm_below_1e_300():
    # contract §4: below 1e-300 (an underflowed 0 included) a p reads "< 1e-300"; tests/test_text.py
    assert pvalue_text(0.0, -2000.0 * math.log(10.0) + math.log(3.0)) == "< 1e-300"
    assert pvalue_text(0.0, -600.0) == "2.65e-261"  # written from the log
    assert pvalue_text(0.25, math.log(0.25)) == "0.25"
    assert pvalue_text(float("nan"), float("nan")) == "n/a"


@pytest.mark.parametrize("profile", ["lesson", "matlab"])
def test_max_lag_zero_keeps_the_iid_zero_mean_test_and_drops_the_lagged_parts(backend, profile):
    # max_lag=0 is the one-pass report: no lag analysis, so only the i.i.d. half of the zero-mean
    # test (from the fused kernel's mean and variance, whatever the profile's ddof) is reported.
    rng = np.random.default_rng(11)
    meas = rng.normal(size=(300, 2)) * [5.0, 1.0]
    pred = meas + 0.05 + rng.normal(scale=0.2, size=meas.shape)
    report = dynval.validate(meas, pred, n_params=3, max_lag=0, profile=profile, backend=backend)
    zmt = report.residuals["zero_mean_test"]
    reference = scipy.stats.ttest_1samp(meas - pred, 0.0)
    np.testing.assert_allclose(zmt["statistic_iid"], reference.statistic, rtol=1e-12)
    np.testing.assert_allclose(zmt["pvalue_iid"], reference.pvalue, rtol=1e-10)
    assert zmt["pvalue_eff"] is None and zmt["n_eff"] is None
    assert report.autocorrelation is None and report.ljung_box is None
    text = report.summary()
    assert "not corrected for autocorrelation" in text
    json.loads(report.to_json())


@pytest.mark.parametrize("bad", [{}, {"max_lag": -1}, {"profile": "nope"}, {"level": 2.0}])
def test_validate_reports_the_first_non_finite_value_before_any_bad_parameter(backend, bad):
    # Without a regressor the fused kernel finds non-finite values inside its one pass; a bad
    # parameter must still lose to them (contract §2.1: finiteness before parameters).
    meas = np.arange(40.0).reshape(20, 2)
    pred = meas + 0.5
    pred[7, 1] = -np.inf
    meas[12, 0] = np.nan
    with pytest.raises(dynval.NonFiniteInput, match=r"^tau_meas has a non-finite value \(nan\) at row 12, column 0$"):
        dynval.validate(meas, pred, n_params=2, backend=backend, **bad)
    meas[12, 0] = 1.0
    with pytest.raises(dynval.NonFiniteInput, match=r"^tau_pred has a non-finite value \(-inf\) at row 7, column 1$"):
        dynval.validate(meas, pred, n_params=2, backend=backend, **bad)


def test_a_given_decimation_without_a_rate_is_worded_without_a_band():
    """decimate=3 with no sample rate: no information band to name; the sampling-colour note and the
    summary say the factor was given instead of failing on the missing band."""
    n, m = 600, 2
    rng = np.random.default_rng(4)
    tau = rng.standard_normal((n, m))
    found_note = False
    for seed in range(4):  # each value held for 3 samples: coloured at the logged rate, white decimated by 3
        e2 = np.repeat(0.05 * np.random.default_rng(seed).standard_normal((n // 3, m)), 3, axis=0)
        r = dynval.validate(tau, tau + e2, n_params=1, decimate=3)
        text = r.summary()
        assert "decimated by 3 (the factor given, no information band)" in text
        for f in r.findings:
            if f.kind == "sampling_colour":
                found_note = True
                assert "decimated by 3 (the factor given)" in f.message and "None" not in f.message
    assert found_note


def test_undefined_aicc_and_fpe_are_explained_in_the_summary():
    """p ≥ n − 1 (here p = N·m): AICc and FPE are nan by definition; the summary says why."""
    rng = np.random.default_rng(2)
    tau = rng.standard_normal((30, 2))
    pred = tau + 0.1 * rng.standard_normal((30, 2))
    text = dynval.validate(tau, pred, n_params=60, max_lag=0).summary()
    assert "AICc nan" in text
    assert "AICc and FPE are undefined (nan): they need p < n − 1, and p = 60 with n = 60" in text
    assert "undefined" not in dynval.validate(tau, pred, n_params=58, max_lag=0).summary()
    assert "AICc and FPE are undefined" in dynval.validate(tau, pred, n_params=59, max_lag=0).summary()


def test_the_top_cells_are_each_joints_five_and_each_columns_two_strongest():
    # The rule written plainly: every finite cell sorted by −z, joint, column; the first five of
    # each joint's and the first two of each column's; strongest first. Ties in z (exact here)
    # go to the lower joint, then column. A changed count, order or tie rule fails.
    from dynval.report import _sections

    rng = np.random.default_rng(51)
    m, p = 4, 9
    z = np.round(rng.uniform(0, 5, size=(m, p)), 1)  # rounded: many exact ties
    z[1, 3] = np.nan
    z[2, 0] = np.inf
    lag = rng.integers(0, 12, size=(m, p))
    rho = rng.uniform(-1, 1, size=(m, p))
    cells = sorted(((j, c, int(lag[j, c]), float(rho[j, c]), float(z[j, c])) for j in range(m) for c in range(p)
                    if np.isfinite(z[j, c])), key=lambda t: (-t[4], t[0], t[1]))
    keep = set()
    for j in range(m):
        keep.update([t for t in cells if t[0] == j][:5])
    for c in range(p):
        keep.update([t for t in cells if t[1] == c][:2])
    expected = sorted(keep, key=lambda t: (-t[4], t[0], t[1]))
    assert _sections._top_cells(lag, rho, z) == expected
    assert len(expected) > 5 * m  # the columns' two strongest add cells beyond the joints' five
