"""The findings' rules, tested directly on evidence records, and the statistics under them.

Each rule test asks: which mutation of the rule would this catch? Dropping the Holm correction,
changing an effect threshold's direction, letting colour alone count as a deficiency, losing a
design warning. The estimators are checked against independent code (statsmodels) and against
simulated processes whose answer is known.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval.report._findings import Evidence, Thresholds, compute_findings, holm_family
from dynval.statistics import _stats


def _ar1(n, rho, rng, m=1):
    w = rng.normal(size=(n, m))
    x = np.empty((n, m))
    x[0] = w[0] / math.sqrt(1.0 - rho * rho)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + w[k]
    return x


# ----------------------------------------------------------------- statistics


def test_holm_matches_statsmodels():
    from statsmodels.stats.multitest import multipletests

    rng = np.random.default_rng(3)
    for size in (1, 2, 7, 50):
        p = rng.uniform(0, 0.2, size=size) ** 2
        np.testing.assert_allclose(_stats.holm(p), multipletests(p, method="holm")[1], rtol=1e-15)
    # nan entries are not tests: they neither count nor change the others
    p = np.array([0.01, np.nan, 0.02])
    np.testing.assert_allclose(_stats.holm(p), [0.02, np.nan, 0.02])


def test_bartlett_long_run_variance_matches_statsmodels_hac():
    from statsmodels.stats.sandwich_covariance import S_hac_simple

    rng = np.random.default_rng(4)
    x = _ar1(3000, 0.6, rng, m=2)
    x -= x.mean(axis=0)
    for lags in (0, 1, 7, 40):
        ours = _stats.bartlett_long_run_variance(x, np.array([0]), lags)
        ref = np.diag(S_hac_simple(x, nlags=lags)) / x.shape[0]  # statsmodels leaves out the 1/N
        np.testing.assert_allclose(ours, ref, rtol=1e-12)


@pytest.mark.parametrize("rho, n", [(0.0, 5000), (0.9, 5000), (0.99, 20000)])
def test_effective_sample_size_of_ar1_within_25_percent(rho, n):
    # N_eff of an AR(1) mean is N(1 − ρ)/(1 + ρ); the prewhitened estimator must find it on every
    # seeded replicate within ±25 % (a fixed 9-lag Newey–West window gives ≈ N/10 at ρ = 0.99).
    rng = np.random.default_rng(int(rho * 100) + 7)
    truth = n * (1 - rho) / (1 + rho)
    for _ in range(8):
        est = _stats.long_run_variance(_ar1(n, rho, rng), np.array([0])).n_eff[0]
        assert abs(est / truth - 1.0) <= 0.25, (est, truth)


def test_effective_sample_size_respects_segments():
    # Two independent AR(1) records concatenated: no lag joins them, so N_eff is the sum.
    rng = np.random.default_rng(8)
    a, b = _ar1(8000, 0.9, rng), _ar1(8000, 0.9, rng)
    both = _stats.long_run_variance(np.vstack([a, b]), np.array([0, 8000])).n_eff[0]
    assert abs(both / (16000 * 0.1 / 1.9) - 1) < 0.2


def test_correlation_pvalue_is_the_t_test_of_a_correlation_for_white_series():
    # sd = 1/√N gives ν = N: the classical t test of a Pearson correlation with N − 2 df.
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=(2, 200))
    r = np.corrcoef(x, y)[0, 1]
    expected = scipy.stats.pearsonr(x, y).pvalue
    assert _stats.correlation_pvalue(r, 1 / math.sqrt(200)) == pytest.approx(expected, rel=1e-10)


def test_cross_correlation_sd_grows_with_both_colours():
    # Two AR(1) series with coefficients a, b: var ρ̂ ≈ (1/N)(1 + ab)/(1 − ab) (Bartlett).
    n, a, b, lags = 10_000, 0.8, 0.9, 200
    j = np.arange(lags + 1)
    sd = _stats.cross_correlation_sd((a ** j)[:, None], (b ** j)[:, None, None], np.array([n]), np.array([n]), n)
    expected = math.sqrt((1 + a * b) / (1 - a * b) / n)
    assert sd[0, 0, 0] == pytest.approx(expected, rel=0.02)
    white = _stats.cross_correlation_sd(np.eye(lags + 1, 1), np.eye(lags + 1, 1)[:, :, None], np.array([n]),
                                        np.array([n]), n)
    assert white[0, 0, 0] == pytest.approx(1 / math.sqrt(n), rel=1e-12)


def test_spectrum_finds_a_mode_and_not_a_coloured_background():
    rng = np.random.default_rng(2)
    n, fs = 4000, 100.0
    t = np.arange(n) / fs
    coloured = _ar1(n, 0.95, rng)
    spec = _stats.residual_spectrum(coloured, np.array([0]), sample_rate=fs)
    assert np.nanmin(spec.pvalue) * np.sum(~np.isnan(spec.pvalue)) > 0.001  # nothing after Bonferroni
    with_mode = coloured + 0.5 * np.sin(2 * np.pi * 12.3 * t)[:, None]
    spec = _stats.residual_spectrum(with_mode, np.array([0]), sample_rate=fs)
    best = int(np.nanargmin(spec.pvalue[:, 0]))
    assert abs(spec.frequency[best] - 12.3) < 2 * (spec.frequency[1] - spec.frequency[0])
    assert spec.pvalue[best, 0] * np.sum(~np.isnan(spec.pvalue)) < 1e-4 and spec.is_peak[best, 0]


def test_information_bandwidth_and_decimation():
    fs = 200.0
    t = np.arange(20000) / fs
    tau = np.sin(2 * np.pi * 0.5 * t) + 0.3 * np.sin(2 * np.pi * 2.0 * t)
    band = _stats.information_bandwidth(tau[:, None], np.array([0]), sample_rate=fs)
    assert 1.5 < band < 3.5
    d, starts = _stats.decimate_segments(np.column_stack([tau, tau]), np.array([0, 10000]), 10)
    assert d.shape == (2000, 2) and starts.tolist() == [0, 1000]


# ----------------------------------------------------------------- the rules, on evidence


def _evidence(m=2, **kw):
    base = dict(n_samples=1000, level=0.95, joint_names=[f"j{k}" for k in range(m)], r2=np.full(m, 0.9),
                pooled_r2=0.9, constant_target=np.zeros(m, bool))
    base.update(kw)
    return Evidence(**base)


def _bias(p, mean, rmse=1.0, m=2):
    return dict(mean=np.asarray(mean, float), rmse=np.full(m, rmse), bias_statistic=np.full(m, 5.0),
                bias_pvalue=np.asarray(p, float), n_eff=np.full(m, 500.0))


def kinds(found, severity=None):
    return [(f.kind, f.joints) for f in found if severity is None or f.severity == severity]


def test_bias_needs_significance_and_size():
    th = Thresholds()
    found = compute_findings(_evidence(**_bias([1e-6, 1e-6], [0.5, 0.05])), th)
    assert kinds(found, "deficiency") == [("bias", (0,))]
    assert kinds(found, "note") == [("bias", (1,))]  # significant but negligible
    assert "negligible" in found[1].message
    assert compute_findings(_evidence(**_bias([0.2, 0.2], [0.9, 0.9])), th) == []
    # the threshold is configurable, and at equality the effect counts
    found = compute_findings(_evidence(**_bias([1e-6, 1e-6], [0.05, 0.0])), Thresholds(bias=0.05))
    assert kinds(found, "deficiency") == [("bias", (0,))]


def test_holm_covers_every_test_of_the_report():
    # One bias p-value of 0.004 among 100 null regressor cells: significant alone (0.004·2 ≤ 0.05),
    # not once corrected over all 102 tests (0.004·102 > 0.05). A per-family correction would flag it.
    ev = _evidence(**_bias([0.004, 0.9], [0.9, 0.0]))
    assert kinds(compute_findings(ev)) == [("bias", (0,))]
    ev.xcorr_rho = np.zeros((2, 5, 10))
    ev.xcorr_sd = np.full((2, 5, 10), 0.03)
    fam = holm_family(ev)
    assert fam["_count"] == 102
    assert fam["bias"][1][0] == pytest.approx(0.004 * 102)
    assert compute_findings(ev) == []
    # ... while a strong effect survives the correction
    ev.bias_pvalue = np.array([1e-6, 0.9])
    assert kinds(compute_findings(ev), "deficiency") == [("bias", (0,))]


def test_colour_alone_is_a_note_and_corroborated_whiteness_a_deficiency():
    white = dict(whiteness_lag=20, whiteness_pvalue_raw=np.array([1e-30, 1e-30]),
                 whiteness_log_pvalue_raw=np.array([-69.0, -69.0]))
    found = compute_findings(_evidence(**white))
    assert kinds(found) == [("whiteness", (0,)), ("whiteness", (1,))]
    assert all(f.severity == "note" for f in found)
    assert "not evidence against the model" in found[0].message
    # joint 1 also has a large, significant bias: its whiteness rejection now counts against the model
    found = compute_findings(_evidence(**white, **_bias([0.5, 1e-9], [0.0, 0.8])))
    assert kinds(found, "deficiency") == [("bias", (1,)), ("whiteness", (1,))]
    assert kinds(found, "note") == [("whiteness", (0,))]


def test_sampling_colour_when_white_at_the_information_rate():
    ev = _evidence(whiteness_lag=20, whiteness_pvalue_raw=np.array([1e-30, 1e-30]),
                   whiteness_log_pvalue_raw=np.array([-69.0, -69.0]),
                   whiteness_pvalue_decimated=np.array([0.4, 1e-12]), decimation=8, information_band=3.0,
                   frequency_unit="Hz")
    found = compute_findings(ev)
    assert kinds(found) == [("sampling_colour", (0,)), ("whiteness", (1,))]
    assert found[0].severity == "note" and "below 3 Hz" in found[0].message


def test_regressor_correlation_names_the_strongest_significant_column():
    rho = np.zeros((2, 3, 4))
    rho[1, 2, 1] = 0.4   # strong
    rho[1, 0, 0] = 0.2   # significant, weaker
    rho[0, 1, 3] = 0.06  # significant but negligible (sd 0.01)
    ev = _evidence(xcorr_rho=rho, xcorr_sd=np.full(rho.shape, 0.01), column_names=["a", "b", "c"])
    found = compute_findings(ev)
    defi = [f for f in found if f.severity == "deficiency"]
    assert [(f.kind, f.joints, f.columns) for f in defi] == [("regressor_correlation", (1,), (2, 0))]
    assert defi[0].details["lag"] == 1 and defi[0].effect == pytest.approx(0.4)
    assert "c (lag 1" in defi[0].message
    notes = [f for f in found if f.severity == "note"]
    assert [(f.kind, f.joints) for f in notes] == [("regressor_correlation", (0,))]


def test_missing_term_is_named_before_compensating_columns():
    ev = _evidence(xcorr_rho=np.full((2, 3, 2), 0.3), xcorr_sd=np.full((2, 3, 2), 0.01),
                   column_names=["a", "b", "Fc"], missing_columns=[2],
                   missing_statistic=np.array([[0.25], [0.01]]), missing_pvalue=np.array([[1e-12], [0.3]]),
                   missing_share=np.array([[0.07], [0.0001]]))
    found = compute_findings(ev)
    first = [f for f in found if f.joints == (0,) and f.kind == "regressor_correlation"]
    assert len(first) == 1 and first[0].columns == (2,) and first[0].details["added_variable"]
    assert "add the term Fc" in first[0].action
    # joint 1: the missing term explains nothing; the marginal correlations remain
    assert [f.columns[0] for f in found if f.joints == (1,) and f.kind == "regressor_correlation"] == [0]


def test_oscillation_needs_a_significant_large_peak():
    f_count = 50
    p = np.full((f_count, 1), 0.5)
    share = np.zeros((f_count, 1))
    peak = np.zeros((f_count, 1), bool)
    p[20, 0], share[20, 0], peak[20, 0] = 1e-20, 0.3, True
    p[30, 0], share[30, 0], peak[30, 0] = 1e-20, 0.01, True
    ev = _evidence(m=1, spectrum_frequency=np.arange(f_count) * 0.5, spectrum_pvalue=p,
                   spectrum_ratio=np.full((f_count, 1), 9.0), spectrum_share=share, spectrum_is_peak=peak,
                   frequency_unit="Hz")
    found = compute_findings(ev)
    assert [(f.kind, f.severity, f.details["frequency"]) for f in found] == [("oscillation", "deficiency", 10.0)]
    peak[20, 0] = False  # not a local maximum: an edge, not a line
    found = compute_findings(ev)
    assert [(f.kind, f.severity) for f in found] == [("oscillation", "note")]


def test_worse_than_constant_and_design_findings():
    ev = _evidence(r2=np.array([0.95, -0.4]), pooled_r2=0.9,
                   repeat={"measure": "regressor", "distance": 0.004, "is_repeat": True},
                   excitation={"condition_raw": 1e9, "condition_scaled": 12.0, "unexcited": [3]},
                   column_names=["a", "b", "c", "off"])
    found = compute_findings(ev)
    assert [(f.kind, f.severity) for f in found] == [
        ("worse_than_constant", "deficiency"), ("repeat_trajectory", "design"), ("excitation", "design")]
    assert "off" in found[2].message
    ev.repeat["is_repeat"] = False
    ev.excitation["unexcited"] = []
    assert [f.kind for f in compute_findings(ev)] == ["worse_than_constant"]
    ev.excitation["condition_scaled"] = 5e3
    assert [f.kind for f in compute_findings(ev)] == ["worse_than_constant", "excitation"]


def test_thresholds_are_checked():
    with pytest.raises(dynval.InvalidParameter, match="thresholds"):
        dynval.validate([1.0, 2.0, 3.0], [1.0, 2.0, 3.5], n_params=1, thresholds={"nope": 1})
    with pytest.raises(dynval.InvalidParameter, match=r"thresholds\['bias'\] must be a finite number >= 0"):
        dynval.validate([1.0, 2.0, 3.0], [1.0, 2.0, 3.5], n_params=1, thresholds={"bias": -1})


def test_finding_records_serialise():
    found = compute_findings(_evidence(**_bias([1e-6, 0.5], [0.5, 0.0])))
    d = found[0].to_dict()
    assert set(d) >= {"kind", "severity", "joints", "columns", "statistic", "pvalue", "pvalue_adjusted",
                      "effect", "effect_unit", "threshold", "action", "message"}
    assert d["kind"] in dynval.FINDING_KINDS


# ----------------------------------------------------------------- the report end to end


def test_fraction_outside_counts_lags_over_max_lag():
    # A strongly coloured residual has every lag outside the white band: the fraction is exactly 1.
    rng = np.random.default_rng(0)
    e = _ar1(3000, 0.95, rng, m=2)
    r = dynval.validate(e, np.zeros_like(e), n_params=1, max_lag=15)
    np.testing.assert_array_equal(r.autocorrelation["fraction_outside"], [1.0, 1.0])


def test_readme_example_raises_no_finding(backend):
    rng = np.random.default_rng(0)
    tau_meas = rng.normal(size=(1000, 2)) * [30.0, 2.0]
    tau_pred = tau_meas + rng.normal(scale=0.5, size=tau_meas.shape)
    report = dynval.validate(tau_meas, tau_pred, n_params=12, backend=backend)
    assert report.deficiencies == []
    assert "whiteness" not in [f.kind for f in report.findings]


def test_report_carries_names_and_segments():
    rng = np.random.default_rng(5)
    n = 1200
    tau = np.column_stack([np.sin(np.arange(n) / 30.0), np.cos(np.arange(n) / 17.0)]) * 10
    pred = tau + rng.normal(0, 0.1, size=tau.shape)
    pred[:200] += 0.5  # a start-up transient
    r = dynval.validate(tau, pred, n_params=3, joint_names=["hip", "knee"],
                        segments={"transient": 200, "steady": 1000})
    assert r.provenance["joint_names"] == ["hip", "knee"] and r.provenance["segments"] == [200, 1000]
    seg = r.segment_metrics
    assert list(seg) == ["transient", "steady"]
    assert seg["transient"]["per_joint"]["rmse"][0] > 4 * seg["steady"]["per_joint"]["rmse"][0]
    np.testing.assert_allclose(seg["steady"]["per_joint"]["r2"],
                               dynval.r2(tau[200:], pred[200:], multioutput="raw_values"), rtol=1e-12)
    assert "hip" in r.summary() and "knee" in r.summary()
    assert all(f.message.startswith(("hip", "knee")) for f in r.findings if f.joints)


def test_noise_model_keyword_and_n_eff_criteria(backend):
    rng = np.random.default_rng(6)
    tau = rng.normal(size=(500, 2))
    pred = tau + _ar1(500, 0.9, rng, m=2) * 0.1
    pooled = dynval.validate(tau, pred, n_params=3, backend=backend)
    per = dynval.validate(tau, pred, n_params=3, noise_model="per_joint", backend=backend)
    assert pooled.information_criteria["noise_model"] == "pooled"
    assert per.information_criteria["aic"] == pytest.approx(
        dynval.aic(tau, pred, n_params=3, noise_model="per_joint"), rel=1e-12)
    ic = pooled.information_criteria
    ratio = ic["n_eff"] / ic["n_obs"]
    assert 0.02 < ratio < 0.2  # AR(0.9): N_eff/N ≈ 0.05
    assert ic["aic_neff"] == pytest.approx((ic["aic"] - 6) * ratio + 6, rel=1e-12)
    assert ic["bic_neff"] == pytest.approx((ic["aic"] - 6) * ratio + 3 * math.log(ic["n_eff"]), rel=1e-12)


def test_repeat_trajectory_is_detected_through_estimation():
    from dynval import calibration as C
    from dynval import simulate as sim

    rng = np.random.default_rng(9)
    t = np.arange(2000) / 100.0
    q, dq, ddq = C._trajectory(rng, t)
    q2, dq2, ddq2 = C._trajectory(rng, t)
    pi = sim.base_parameters()
    y1 = sim.regressor(q, dq, ddq)
    y_rep = sim.regressor(q + rng.normal(0, 0.003, q.shape), dq, ddq)  # a repeat within a few mrad
    y_new = sim.regressor(q2, dq2, ddq2)
    est = {"q": q, "regressor": y1, "tau": y1 @ pi}
    for y_val, q_val, is_repeat in ((y_rep, q, True), (y_new, q2, False)):
        tau = y_val @ pi + rng.normal(0, 0.2, (2000, 2))
        r = dynval.validate(tau, y_val @ pi, n_params=10, regressor=y_val, q=q_val, estimation=est,
                            sample_rate=100.0)
        rep = r.design["repeat"]
        assert rep["is_repeat"] is is_repeat
        # A repeat within a few mrad is far below the 0.1 threshold; two independent trajectories of
        # this arm share their gravity columns' offsets, so they stand at about 0.6, not above 1.
        assert (rep["regressor"] < 0.01) if is_repeat else (rep["regressor"] > 0.3)
        assert ("repeat_trajectory" in [f.kind for f in r.findings]) is is_repeat


def test_unexcited_column_is_a_design_finding():
    rng = np.random.default_rng(10)
    Y = rng.normal(size=(800, 2, 3))
    Y[:, :, 2] = 0.0
    tau = rng.normal(size=(800, 2))
    r = dynval.validate(tau, tau + rng.normal(0, 0.1, tau.shape), n_params=3, regressor=Y,
                        column_names=["a", "b", "Fc"])
    f = [f for f in r.findings if f.kind == "excitation"]
    assert len(f) == 1 and f[0].severity == "design" and f[0].columns == (2,) and "Fc" in f[0].message


KUKA = "../shared/data/robots/kuka_lwr4_flobaroid/data"


@pytest.mark.skipif(not __import__("os").path.isdir(KUKA), reason="../shared/data/robots is not beside the repo")
def test_real_kuka_repeat_is_a_design_warning_and_colour_is_not_blamed_alone():
    # Run 2 of the KUKA LWR4+ data repeats run 1's trajectory; replaying run 1's measured torques as
    # the "prediction" of run 2 must not blame a model for the oversampled, filtered colour. The
    # replayed torques belong to run 1's states, not run 2's: the physics library (q given) finds
    # structure that follows the motion, and a whiteness deficiency is allowed only on a joint where
    # that structure is shown (colour alone never makes a deficiency).
    m = {k: np.load(f"{KUKA}/measurements_{k}.npz") for k in (1, 2)}
    n = min(len(m[1]["torques"]), len(m[2]["torques"]))
    r = dynval.validate(m[2]["torques"][:n], m[1]["torques"][:n], n_params=0, sample_rate=200.0,
                        q=m[2]["positions"][:n], estimation={"q": m[1]["positions"], "tau": m[1]["torques"]})
    assert r.design["repeat"]["is_repeat"] and r.design["repeat"]["q_rms"] < 0.006
    assert {f.kind for f in r.deficiencies} <= {"missing_physics", "whiteness"}
    physics = {f.joints for f in r.deficiencies if f.kind == "missing_physics"}
    assert all(f.joints in physics for f in r.deficiencies if f.kind == "whiteness")
    assert next(f.kind for f in r.findings if f.severity == "design") == "repeat_trajectory"
    assert r.whiteness["decimation"] > 1  # 200 Hz carries motion below a few Hz


def test_estimation_regressor_must_match_the_regressor_columns():
    rng = np.random.default_rng(11)
    tau = rng.normal(size=(300, 2))
    with pytest.raises(dynval.ShapeMismatch, match=r"estimation\['regressor'\] must have the p=3 columns"):
        dynval.validate(tau, tau + 0.1, n_params=2, regressor=rng.normal(size=(300, 2, 3)),
                        estimation={"regressor": rng.normal(size=(300, 2, 4))})


# ---- the estimation run: the parameters' coloured-noise covariance and the refit of a missing term

def test_score_covariance_equals_its_explicit_matrix_form():
    # X̃ᵀ Γ_u X̃ with X̃ = Bᵀ X (B the AR(1) recolouring matrix, φ^{t−s} below the diagonal) and Γ_u
    # the Bartlett-tapered Toeplitz autocovariance of u = e − φe₋₁: the FFT convolution and the
    # backward filter must give the same matrix as the dense algebra.
    import scipy.linalg

    rng = np.random.default_rng(11)
    n, p = 80, 3
    x = rng.normal(size=(n, 1, p)).cumsum(axis=0)
    e = _ar1(n, 0.8, rng)
    ours = _stats.score_covariance(x, e)
    lr = _stats.long_run_variance(e, np.array([0]))
    phi = lr.phi[0] + (1 + 3 * lr.phi[0]) / n
    u = e[1:, 0] - phi * e[:-1, 0]
    lag = max(int(lr.bandwidth[0]), 1)
    gamma = np.array([u[k:] @ u[:u.size - k] for k in range(lag + 1)]) / u.size
    gamma *= 1 - np.arange(lag + 1) / (lag + 1)
    gamma_u = scipy.linalg.toeplitz(np.concatenate([gamma, np.zeros(u.size - lag - 1)]))
    k = np.arange(u.size)
    b = np.tril(phi ** (k[:, None] - k[None, :]).clip(0))
    xt = b.T @ x[1:, 0, :]
    np.testing.assert_allclose(ours, xt.T @ gamma_u @ xt, rtol=1e-9)


def test_parameter_covariance_matches_the_spread_of_estimates_under_coloured_noise():
    # Least squares with AR(1) noise (ρ = 0.9) and smooth columns: the sandwich variance of π̂
    # must match the variance of the estimates over replicates within ±25 % (OLS's σ²(XᵀX)⁻¹ is
    # about (1 + ρ)/(1 − ρ) = 19 times too small here).
    from dynval.statistics import _estimation

    rng = np.random.default_rng(12)
    n = 3000
    t = np.arange(n) / 100.0
    reg = np.stack([np.sin(0.7 * t), np.cos(0.3 * t), np.ones(n)], axis=1)[:, None, :]
    estimates, variances = [], []
    for _ in range(150):
        tau = reg @ np.array([1.0, -2.0, 0.5]) + _ar1(n, 0.9, rng)
        fit = _estimation.fit_columns(reg, tau, [0, 1, 2])
        estimates.append(fit.coefficients)
        variances.append(np.diag(fit.covariance))
    ratio = np.mean(variances, axis=0) / np.var(estimates, axis=0)
    assert np.all(np.abs(ratio - 1.0) <= 0.25), ratio


def test_missing_term_refit_names_the_column_and_stays_quiet_without_one():
    from dynval.statistics import _estimation

    rng = np.random.default_rng(13)
    n = 2000
    def run(shift):
        t = np.arange(n) / 100.0 + shift
        return np.stack([np.sin(t), np.sin(2.3 * t), np.cos(0.4 * t)], axis=1)[:, None, :]
    est, val = run(0.0), run(7.0)
    for coef_c, expect in ((0.8, True), (0.0, False)):
        truth = np.array([1.0, 0.5, coef_c])
        out = _estimation.missing_terms(est, est @ truth + rng.normal(0, 0.3, (n, 1)),
                                        val, val @ truth + rng.normal(0, 0.3, (n, 1)), [0, 1])
        assert out["columns"] == [2]
        if expect:
            assert out["pvalue"][0] < 1e-10 and out["share"][0, 0] > 0.3
        else:
            assert out["pvalue"][0] > 1e-3 and out["share"][0, 0] < 0.01


def test_estimation_regressor_and_torque_must_have_the_same_length():
    rng = np.random.default_rng(14)
    y = rng.normal(size=(300, 1, 2))
    tau = y @ np.array([1.0, 2.0]) + rng.normal(size=(300, 1))
    with pytest.raises(dynval.ShapeMismatch, match="same N"):
        dynval.validate(tau, y @ np.array([1.0, 2.0]), n_params=2, regressor=y,
                        estimation={"regressor": y, "tau": tau[:200]})


def test_the_estimation_run_widens_the_bias_test_by_the_parameter_error():
    # Coloured noise, parameters estimated on a short run: with the estimation run the bias test
    # allows for π̂'s error (its standard error grows), without it the same mean looks significant.
    rng = np.random.default_rng(15)
    n = 1500
    t = np.arange(n) / 100.0
    y_est = np.stack([np.sin(0.5 * t) + 1.5, np.cos(0.2 * t)], axis=1)[:, None, :]
    y_val = np.stack([np.sin(0.5 * t + 2) + 1.5, np.cos(0.2 * t + 1)], axis=1)[:, None, :]
    pi = np.array([1.0, -1.0])
    tau_est = y_est @ pi + _ar1(n, 0.95, rng)
    tau_val = y_val @ pi + _ar1(n, 0.95, rng)
    pi_hat = np.linalg.lstsq(y_est[:, 0], tau_est[:, 0], rcond=None)[0]
    pred = y_val @ pi_hat
    without = dynval.validate(tau_val, pred, n_params=2, regressor=y_val, max_lag=20)
    with_est = dynval.validate(tau_val, pred, n_params=2, regressor=y_val, max_lag=20,
                               estimation={"regressor": y_est, "tau": tau_est})
    assert with_est.bias["method"] == "student_t_n_eff_with_parameter_error"
    assert with_est.bias["standard_error"][0] > 1.2 * without.bias["standard_error"][0]
    assert with_est.bias["pvalue"][0] > without.bias["pvalue"][0]


def test_refit_missing_term_is_one_test_per_column_named_on_the_joints_it_matters_for():
    # The estimation refit tests a column once (its coefficient); the effect is per joint, so the
    # deficiency appears only where the term removes ≥ the threshold share of the mean square, and
    # a joint's bias is attributed to it only when the refit accounts for that joint's mean.
    ev = _evidence(column_names=["a", "b", "MY1"], missing_columns=[2], missing_method="estimation_refit",
                   missing_statistic=np.array([14.0]), missing_pvalue=np.array([1e-20]),
                   missing_share=np.array([[0.4], [0.002]]), missing_explains_bias=np.array([[True], [False]]),
                   mean=np.array([0.3, 0.05]), rmse=np.array([0.5, 0.5]), bias_statistic=np.array([8.0, 1.0]),
                   bias_pvalue=np.array([1e-9, 0.3]), n_eff=np.array([300.0, 300.0]))
    found = compute_findings(ev)
    missing = [f for f in found if f.kind == "regressor_correlation"]
    assert [(f.joints, f.columns, f.severity) for f in missing] == [((0,), (2,), "deficiency")]
    assert "t = +14" in missing[0].message and missing[0].details["method"] == "estimation_refit"
    bias = [f for f in found if f.kind == "bias"]
    assert [(f.joints, f.columns) for f in bias] == [((0,), (2,))]
    assert "MY1" in bias[0].message
    # The same column significant but not accounting for the mean: the bias is not attributed.
    ev.missing_explains_bias = np.array([[False], [False]])
    assert [f.columns for f in compute_findings(ev) if f.kind == "bias"] == [()]


def test_each_kinds_description_is_the_contracts():
    # The words a reader sees for each kind (the site's findings page, the HTML report) are the
    # contract's, both ways: no kind without its row, no row without its kind, the same words.
    import pathlib
    import re

    text = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "contract.md").read_text(encoding="utf-8")
    block = text[text.index("| kind | what it detects |"):]
    rows = dict(re.findall(r"^\| `([a-z_]+)` \| (.+) \|$", block.split("\n\n")[0], flags=re.M))
    assert rows == {k: v.replace("|", "/") for k, v in dynval.FINDING_KINDS.items()}


def test_the_named_lag_is_the_earliest_within_nine_tenths_of_the_strongest():
    from dynval.report.kinds.regressor_correlation import strongest_lag as _strongest_lag

    rho = np.array([1.0, 0.05, 0.30, 0.86, 0.20, 0.95, 0.40])
    sig = np.array([2, 3, 5, 6])
    # lag 3 holds 0.86 / 0.95 = 0.905 of the strongest: it is named; at 0.85 of it, lag 5 would be
    assert _strongest_lag(rho, sig) == 3
    rho[3] = 0.85
    assert _strongest_lag(rho, sig) == 5
    assert _strongest_lag(-rho, sig) == 5  # by size, whatever the sign


# --------------------------------------------------------------------------- n_params and the criteria


def _seventy_observations():
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(10, 7))
    return tau, tau + 0.1 * rng.normal(size=tau.shape)


@pytest.mark.parametrize("n_params, noted", [(0, False), (68, False), (69, True), (500, True)])
def test_n_params_that_leave_the_criteria_no_freedom_are_noted(n_params, noted):
    """validate(tau[:10], pred[:10], n_params=500) (70 observations) gave AIC and BIC without a word."""
    tau, pred = _seventy_observations()
    report = dynval.validate(tau, pred, n_params=n_params)
    notes = [f for f in report.findings if f.kind == "information_criteria"]
    assert bool(notes) == noted
    assert math.isnan(report.information_criteria.aicc) == noted  # the note says what the nan means
    if noted:
        (f,) = notes
        assert f.severity == "note" and f.effect == n_params and f.threshold == 69
        assert "AICc and FPE are nan" in f.message and "n = 70" in f.message
        assert f.kind in dynval.FINDING_KINDS


def test_the_criteria_note_counts_samples_for_a_per_joint_noise_model():
    """With one σ² per joint the criteria count N = 10 samples: p = 9 is already too many."""
    tau, pred = _seventy_observations()
    report = dynval.validate(tau, pred, n_params=9, profile="matlab")
    assert report.information_criteria.n_obs == 10
    (f,) = [f for f in report.findings if f.kind == "information_criteria"]
    assert f.threshold == 9 and "N samples" in f.message


def test_the_criteria_note_changes_no_decision():
    """The note is information: the verdict reads the residual's tests, which do not use n_params."""
    tau, pred = _seventy_observations()
    few = dynval.compare(tau, {"a": (pred, 3)})
    many = dynval.compare(tau, {"a": (pred, 500)})
    assert few.verdict.decision == many.verdict.decision
    assert any(f.kind == "information_criteria" for f in many.reports["a"].findings)


def _two_joint_runs(n, shift, columns):
    """A two-joint regressor (n, 2, columns) at 100 Hz from ``shift`` s: column 0 shared by both
    joints (as a link's inertial parameter), 1 the shoulder's, 2 the elbow's; the rest zero (the
    caller's). Returns it and the times."""
    t = np.arange(n) / 100.0 + shift
    y = np.zeros((n, 2, columns))
    y[:, 0, 0], y[:, 1, 0] = np.sin(t), 0.7 * np.cos(1.3 * t)  # shared
    y[:, 0, 1] = np.sin(2.1 * t)  # shoulder only
    y[:, 1, 2] = np.cos(0.9 * t)  # elbow only
    return y, t


def test_a_missing_column_is_named_on_the_joints_whose_rows_it_enters():
    """A shoulder offset the model lacks, on a two-joint regressor whose first column is shared (it
    enters both joints' rows, as a link's inertial parameter does): refitting with the offset moves
    the shared parameter and so the elbow's validation error too. Kills: the offset named as the
    elbow's missing term ("add the term off_0 to the model" on the elbow, as the KUKA run 3 report
    said of lwr_3 and lwr_6 for lwr_0's offset); the shoulder's own finding dropped with it; what it
    does for the elbow lost (it counts in the step's rank: a planar arm's missing L1:mz bends the
    fitted L2:mz and so the elbow's error, which adding L1:mz removes)."""
    from dynval.statistics import _estimation

    rng = np.random.default_rng(21)
    n = 3000

    def run(shift):
        y, _ = _two_joint_runs(n, shift, 4)
        y[:, 0, 3] = 1.0  # the shoulder's offset
        return y

    est, val = run(0.0), run(11.0)
    truth = np.array([1.0, 0.5, 0.8, 0.6])
    noise = 0.05
    est_tau = est @ truth + noise * rng.standard_normal((n, 2))
    val_tau = val @ truth + noise * rng.standard_normal((n, 2))
    out = _estimation.missing_terms(est, est_tau, val, val_tau, [0, 1, 2])
    assert out["columns"] == [3] and out["pvalue"][0] < 1e-10
    assert out["share"][0, 0] > 0.5 and out["share"][1, 0] > 0.01 and not out["explains_bias"][1, 0]
    assert out["enters"][:, 0].tolist() == [True, False]
    model = [0, 1, 2]
    coef = np.linalg.lstsq(est[:, :, model].reshape(-1, 3), est_tau.reshape(-1), rcond=None)[0]
    r = dynval.validate(val_tau, val[:, :, model] @ coef, n_params=3, regressor=val, model_columns=model,
                        estimation={"regressor": est, "tau": est_tau}, joint_names=["shoulder", "elbow"])
    named = [f for f in r.findings if f.kind == "regressor_correlation"]
    assert [(f.joints, f.columns) for f in named] == [((0,), (3,))]
    # what the refit with it removes on the elbow is said on the shoulder's finding, and counts in its rank
    (share,) = named[0].details["indirect"].values()
    assert list(named[0].details["indirect"]) == [1] and share == pytest.approx(out["share"][1, 0], rel=1e-6)
    assert f"also removes {100 * share:.1f} % on elbow" in named[0].message
    # one absent column: its share added alone is its leave-one-out share
    assert out["alone"][:, 0] == pytest.approx(out["share"][:, 0], rel=1e-9)


def test_a_missing_column_s_own_effect_is_measured_added_alone():
    """Two absent columns that stand in for each other (an offset and a slow gravity column): in the
    joint refit each one's leave-one-out share is small, though adding the true one alone removes
    nearly all of the error. The share added alone is measured, said, carried to the joints the
    column does not enter and used in the ranking. Catches: the leave-one-out share used for the
    indirect effect or the rank (the planar arm without L1:mz had its elbow first, at 5 % indirect)."""
    from dynval.report._ranking import explained_share
    from dynval.statistics import _estimation

    rng = np.random.default_rng(5)
    n = 3000

    def run(shift):
        y, t = _two_joint_runs(n, shift, 5)
        y[:, 0, 3] = 1.0 + 0.05 * np.cos(0.2 * t)  # a slow posture column: nearly an offset
        y[:, 0, 4] = 1.0  # the shoulder's offset
        return y

    est, val = run(0.0), run(11.0)
    truth = np.array([1.0, 0.5, 0.8, 2.0, 0.0])
    est_tau = est @ truth + 0.02 * rng.standard_normal((n, 2))
    val_tau = val @ truth + 0.02 * rng.standard_normal((n, 2))
    out = _estimation.missing_terms(est, est_tau, val, val_tau, [0, 1, 2])
    k = out["columns"].index(3)
    # the joint refit with the offset in takes most of it: a small leave-one-out share ...
    assert out["share"][0, k] < 0.5
    # ... while adding it alone removes nearly everything, on the elbow too (the shared column's bend)
    assert out["alone"][0, k] > 0.9 and out["alone"][1, k] > 0.5
    # the share added alone, by a plain least-squares refit of the model's columns and column 3
    def mse(cols):
        coef = np.linalg.lstsq(est[:, :, cols].reshape(-1, len(cols)), est_tau.reshape(-1), rcond=None)[0]
        return np.mean((val_tau - val[:, :, cols] @ coef) ** 2, axis=0)
    np.testing.assert_allclose(out["alone"][:, k], (mse([0, 1, 2]) - mse([0, 1, 2, 3])) / mse([0, 1, 2]), rtol=1e-6)
    model = [0, 1, 2]
    coef = np.linalg.lstsq(est[:, :, model].reshape(-1, 3), est_tau.reshape(-1), rcond=None)[0]
    r = dynval.validate(val_tau, val[:, :, model] @ coef, n_params=3, regressor=val, model_columns=model,
                        estimation={"regressor": est, "tau": est_tau}, joint_names=["shoulder", "elbow"])
    f = next(f for f in r.findings if f.kind == "regressor_correlation" and 3 in f.columns)
    assert f.details["alone_share"] == pytest.approx(out["alone"][0, k], rel=1e-6)
    assert f.details["indirect"][1] == pytest.approx(out["alone"][1, k], rel=1e-6)
    assert f"{100 * out['alone'][0, k]:.1f} % added alone" in f.message
    share, basis, _ = explained_share(f)
    assert share == pytest.approx(min(out["alone"][0, k], 1.0), rel=1e-6) and basis == "held_out"
