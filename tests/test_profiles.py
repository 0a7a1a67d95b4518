"""Each convention profile against its tool: scikit-learn and statsmodels themselves, the
documented MATLAB example, and the lesson's own numbers and code."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpmath import log as mlog
from mpmath import mp, mpf

import dynval
from dynval.metrics._profiles import PROFILE_NAMES, PROFILES, get_profile

mp.dps = 30


def _data(n=300, seed=0, scales=(30.0, 3.0, 0.4)):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 40.0
    tau = np.column_stack([s * np.sin((j + 1.3) * t + j) + 0.2 * s for j, s in enumerate(scales)])
    # Joint-dependent error levels and a bias, so uniform, weighted and pooled all differ.
    pred = tau + rng.normal(0.0, 1.0, size=tau.shape) * np.array([2.0, 1.5, 0.3]) + [0.5, -0.2, 0.05]
    return tau, pred


# ---------------------------------------------------------------- profile data


def test_profile_table_is_complete():
    assert PROFILE_NAMES == ("lesson", "matlab", "statsmodels", "sklearn")
    expected = {  # contract §4
        "lesson": ("pooled", "percent", "ieee", 1, True, 50, "white", 0.95, "pooled", "dropped"),
        "matlab": ("raw_values", "percent", "ieee", 0, False, 25, "white", 0.99, "full", "included"),
        "statsmodels": ("pooled", "percent", "ieee", 0, False, None, "bartlett", 0.95, "pooled", "included"),
        "sklearn": ("uniform_average", "fraction", "force_finite", 1, True, 50, "white", 0.95, "pooled", "dropped"),
    }
    for name, row in expected.items():
        p = PROFILES[name]
        assert (p.multioutput, p.units, p.constant_target, p.ddof, p.adjusted, p.max_lag_cap, p.band,
                p.level, p.noise_model, p.ic_constant) == row
        assert p.checked_against
    assert PROFILES["matlab"].unverified  # cases with no published number are marked


def test_get_profile_rejects_unknown_names():
    with pytest.raises(dynval.InvalidParameter,
                       match=r"^profile must be one of 'lesson', 'matlab', 'statsmodels', 'sklearn', got 'R'$"):
        get_profile("R")


@pytest.mark.parametrize("n, longest, expected", [(1000, 1000, 30), (1000, 10, 9), (5, 5, 4), (2, 2, 1)])
def test_statsmodels_default_lags(n, longest, expected):
    # statsmodels acf: nlags = min(int(10 * log10(nobs)), nobs - 1)
    assert PROFILES["statsmodels"].default_max_lag(n, longest) == expected


def test_max_lag_defaults_and_ljung_box_lags():
    assert PROFILES["lesson"].default_max_lag(1000, 1000) == 50
    assert PROFILES["matlab"].default_max_lag(1000, 1000) == 25
    assert PROFILES["lesson"].default_max_lag(1000, 1) == 0
    assert PROFILES["statsmodels"].ljung_box_lags(30, 14, 30) == [6]
    assert PROFILES["statsmodels"].ljung_box_lags(1000, 30, 1000) == [10]
    assert PROFILES["lesson"].ljung_box_lags(1000, 0, 1000) == []


# ---------------------------------------------------------------- scikit-learn


def test_sklearn_profile_matches_scikit_learn(backend):
    from sklearn.metrics import explained_variance_score, r2_score, root_mean_squared_error

    tau, pred = _data()
    r = dynval.validate(tau, pred, n_params=3, profile="sklearn", backend=backend)
    tol = dict(rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.per_joint["r2"], r2_score(tau, pred, multioutput="raw_values"), **tol)
    np.testing.assert_allclose(r.per_joint["vaf"],
                               explained_variance_score(tau, pred, multioutput="raw_values"), **tol)
    np.testing.assert_allclose(r.per_joint["rmse"],
                               root_mean_squared_error(tau, pred, multioutput="raw_values"), **tol)
    agg = r.aggregates
    assert agg["uniform_average"]["r2"] == pytest.approx(r2_score(tau, pred), rel=1e-10)
    assert agg["variance_weighted"]["r2"] == pytest.approx(
        r2_score(tau, pred, multioutput="variance_weighted"), rel=1e-10)
    assert agg["uniform_average"]["vaf"] == pytest.approx(explained_variance_score(tau, pred), rel=1e-10)
    assert agg["variance_weighted"]["vaf"] == pytest.approx(
        explained_variance_score(tau, pred, multioutput="variance_weighted"), rel=1e-10)
    assert agg["rmse_uniform_average"] == pytest.approx(root_mean_squared_error(tau, pred), rel=1e-10)
    # fit as a fraction: 1 − √(1 − R²) per joint
    np.testing.assert_allclose(r.per_joint["fit_percent"], 1 - np.sqrt(1 - r.per_joint["r2"]), rtol=1e-9)
    assert r.provenance["units"]["vaf"] == "fraction"
    assert r.provenance["conventions"]["multioutput"] == "uniform_average"


@pytest.mark.parametrize("case", ["one_constant", "all_constant"])
def test_sklearn_force_finite(case, backend):
    from sklearn.metrics import explained_variance_score, r2_score

    tau, pred = _data(n=50)
    tau[:, 1] = 4.0
    pred[:, 1] = 3.0        # constant residual: exact for VAF (1.0), not for R² (0.0)
    tau[:, 2] = 2.0
    pred[:, 2] = 2.0        # exact: 1.0
    if case == "all_constant":
        tau[:, 0] = -1.0
        pred[:, 0] = np.linspace(-2.0, 0.0, 50)  # not exact: 0.0
    r = dynval.validate(tau, pred, n_params=1, profile="sklearn", backend=backend)
    for mo, got_r2, got_vaf in (
            ("raw_values", r.per_joint["r2"], r.per_joint["vaf"]),
            ("uniform_average", r.aggregates["uniform_average"]["r2"], r.aggregates["uniform_average"]["vaf"]),
            ("variance_weighted", r.aggregates["variance_weighted"]["r2"],
             r.aggregates["variance_weighted"]["vaf"])):
        np.testing.assert_allclose(got_r2, r2_score(tau, pred, multioutput=mo, force_finite=True), rtol=1e-10)
        np.testing.assert_allclose(got_vaf, explained_variance_score(tau, pred, multioutput=mo, force_finite=True),
                                   rtol=1e-10)
    assert np.all(np.isfinite(r.per_joint["fit_percent"]))
    # The same data in the IEEE profiles: −inf / nan.
    lesson = dynval.validate(tau, pred, n_params=1, backend=backend)
    assert lesson.per_joint["r2"][1] == -np.inf and np.isnan(lesson.per_joint["r2"][2])


# ---------------------------------------------------------------- statsmodels


def _stacked_ols(seed=2, n=200, m=2):
    """A stacked least-squares robot-like fit: tau (N, m), X (N*m, k) sample-major."""
    import statsmodels.api as sm

    rng = np.random.default_rng(seed)
    k = 4
    X = rng.normal(size=(n * m, k))
    X[:, 0] = np.sin(np.arange(n * m) / 7.0)
    y = X @ np.array([1.5, -2.0, 0.7, 3.0]) + rng.normal(0.0, 0.5, n * m) * np.tile([1.0, 0.4], n)
    res = sm.OLS(y, X).fit()
    return y.reshape(n, m), res.fittedvalues.reshape(n, m), res, k


def test_statsmodels_profile_information_criteria_match_ols(backend):
    tau, pred, res, k = _stacked_ols()
    assert res.k_constant == 0 and res.df_model + res.k_constant == k
    r = dynval.validate(tau, pred, n_params=k, profile="statsmodels", backend=backend)
    ic = r.information_criteria
    assert ic["n_obs"] == tau.size and ic["constant"] == "included"
    assert ic["aic"] == pytest.approx(res.aic, rel=1e-12)
    assert ic["bic"] == pytest.approx(res.bic, rel=1e-12)
    assert ic["aicc"] == pytest.approx(res.info_criteria("aicc"), rel=1e-12)


def test_statsmodels_profile_acf_bartlett_ljung_box_variance(backend):
    from statsmodels.stats.diagnostic import acorr_ljungbox
    from statsmodels.tools.eval_measures import vare
    from statsmodels.tsa.stattools import acf

    tau, pred = _data(n=300)
    r = dynval.validate(tau, pred, n_params=2, profile="statsmodels", backend=backend)
    e = tau - pred
    nlags = min(int(10 * np.log10(300)), 299)
    assert r.autocorrelation["max_lag"] == nlags and r.autocorrelation["adjusted"] is False
    np.testing.assert_allclose(r.residuals["variance"], vare(tau, pred), rtol=1e-12)
    for j in range(3):
        rho, confint = acf(e[:, j], nlags=nlags, alpha=0.05, fft=False, result_object=False)
        np.testing.assert_allclose(r.autocorrelation["rho"][:, j], rho, rtol=1e-9, atol=1e-12)
        # statsmodels centres its Bartlett interval on the estimate: compare half-widths.
        np.testing.assert_allclose(r.autocorrelation["band"][1:, j], (confint[:, 1] - rho)[1:], rtol=1e-9)
        lb = acorr_ljungbox(e[:, j])  # lags 1..min(10, N // 5); the report keeps the last
        assert r.ljung_box["lags"].tolist() == [lb.index[-1]] == [10]
        assert r.ljung_box["statistic"][0, j] == pytest.approx(lb["lb_stat"].iloc[-1], rel=1e-9)
        assert r.ljung_box["pvalue"][0, j] == pytest.approx(lb["lb_pvalue"].iloc[-1], rel=1e-8)


# ---------------------------------------------------------------- MATLAB

# Documented tfest(iddata1, 2) example (shared/docs/anchors.md §b1): N = 300, np = 6,
# MSE = 1.6575 printed to five digits; published AIC 1.0150e3, AICc 1.0153e3, nAIC 0.5453,
# BIC 1.0372e3, FPE 1.7252.
MATLAB_DOC = {"aic": (1.0150e3, 0.1), "aicc": (1.0153e3, 0.1), "naic": (0.5453, 1e-4),
              "bic": (1.0372e3, 0.1), "fpe": (1.7252, 1e-4)}


def _matlab_report(mse, backend):
    n = 300
    e = math.sqrt(mse) * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)  # Σe²/N = MSE
    tau = np.sin(np.arange(n) / 10.0) * 5.0
    return dynval.validate(tau, tau - e, n_params=6, profile="matlab", backend=backend)


def test_matlab_profile_reproduces_documented_example(backend):
    lo = _matlab_report(1.65745, backend).information_criteria
    hi = _matlab_report(1.65755, backend).information_criteria
    for key, (published, unit) in MATLAB_DOC.items():
        # Every MSE that prints as 1.6575 must bracket a value that prints as the published one.
        a, b = sorted((lo[key], hi[key]))
        assert a - unit / 2 <= published <= b + unit / 2, (key, a, b, published)
    # And one MSE inside that interval reproduces all five printed values at once.
    ic = _matlab_report(1.65754, backend).information_criteria
    assert float(f"{ic['aic']:.4e}") == 1.0150e3
    assert float(f"{ic['aicc']:.4e}") == 1.0153e3
    assert round(ic["naic"], 4) == 0.5453
    assert float(f"{ic['bic']:.4e}") == 1.0372e3
    assert round(ic["fpe"], 4) == 1.7252


def test_matlab_profile_multi_output_formulas(backend):
    # ny > 1 has no published MATLAB number (marked unverified): check the documented formula.
    tau, pred = _data(n=200)
    r = dynval.validate(tau, pred, n_params=5, profile="matlab", backend=backend)
    E = tau - pred
    sign, logdet = np.linalg.slogdet(E.T @ E / 200)
    assert sign > 0
    ic = r.information_criteria
    assert ic["noise_model"] == "full" and ic["n_obs"] == 200
    assert ic["aic"] == pytest.approx(200 * logdet + 10 + 200 * 3 * (math.log(2 * math.pi) + 1), rel=1e-12)
    assert ic["naic"] == pytest.approx(logdet + 10 / 200, rel=1e-12)
    assert ic["fpe"] == pytest.approx(math.exp(logdet) * (1 + 5 / 200) / (1 - 5 / 200), rel=1e-10)
    # compare/goodnessOfFit: fit = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖) per output, NRMSE the cost.
    nrmse = np.linalg.norm(E, axis=0) / np.linalg.norm(tau - tau.mean(axis=0), axis=0)
    np.testing.assert_allclose(r.per_joint["fit_percent"], 100 * (1 - nrmse), rtol=1e-12)
    np.testing.assert_allclose(r.per_joint["nrmse"], nrmse, rtol=1e-12)
    np.testing.assert_allclose(r.residuals["variance"], np.var(E, axis=0), rtol=1e-12)
    assert r.autocorrelation["max_lag"] == 25
    np.testing.assert_allclose(r.autocorrelation["band"][1:], 2.5758293035489004 / math.sqrt(200), rtol=1e-13)


# ---------------------------------------------------------------- the lesson


def _problem4_report(rss, p, backend):
    n = 1000
    e = math.sqrt(rss / n) * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    tau = np.cos(np.arange(n) / 13.0)
    return dynval.validate(tau, tau - e, n_params=p, profile="lesson", backend=backend)


@pytest.mark.parametrize("rss, p", [(10, 6), (mpf("8.5"), 10)])
def test_lesson_problem_4_full_precision(rss, p, backend):
    n = 1000
    aic = 2 * p + n * mlog(mpf(rss) / n)
    bic = p * mlog(n) + n * mlog(mpf(rss) / n)
    ic = _problem4_report(float(rss), p, backend).information_criteria
    assert ic["aic"] == pytest.approx(float(aic), abs=1e-9)
    assert ic["bic"] == pytest.approx(float(bic), abs=1e-9)


def test_lesson_problem_4_rounded_values_in_the_docs():
    # docs/conventions.md quotes these to three decimals; the lesson's −4.7690 was a slip.
    assert float(mlog(mpf("0.0085"))) == pytest.approx(-4.767689, abs=5e-7)
    assert round(float(12 + 1000 * mlog(mpf("0.01"))), 3) == -4593.170
    assert round(float(6 * mlog(1000) + 1000 * mlog(mpf("0.01"))), 3) == -4563.724
    assert round(float(20 + 1000 * mlog(mpf("0.0085"))), 3) == -4747.689
    assert round(float(10 * mlog(1000) + 1000 * mlog(mpf("0.0085"))), 3) == -4698.612


def _lesson_compute_basic_metrics(tau_meas, tau_pred, p):
    """The lesson's compute_basic_metrics, verbatim except that p is an argument."""
    N, m = tau_meas.shape
    e = tau_meas - tau_pred
    rmse = np.sqrt(np.mean(np.sum(e**2, axis=1)))
    y = tau_meas.reshape(-1)
    y_hat = tau_pred.reshape(-1)
    e_flat = e.reshape(-1)
    y_mean = np.mean(y)
    var_y = np.var(y, ddof=1)
    var_e = np.var(e_flat, ddof=1)
    vaf = 100.0 * (1.0 - var_e / var_y)
    fit_percent = 100.0 * (1.0 - np.linalg.norm(y - y_hat) / np.linalg.norm(y - y_mean))
    r2 = 1.0 - np.sum((y - y_hat) ** 2) / np.sum((y - y_mean) ** 2)
    sigma2_hat = np.mean(e_flat**2)
    Nm = N * m
    aic = 2.0 * p + Nm * np.log(sigma2_hat)
    bic = p * np.log(Nm) + Nm * np.log(sigma2_hat)
    return rmse, vaf, fit_percent, r2, aic, bic


def test_lesson_profile_reproduces_the_lesson_code(backend):
    tau, pred = _data()
    r = dynval.validate(tau, pred, n_params=30, backend=backend)
    rmse, vaf, fit, r2, aic, bic = _lesson_compute_basic_metrics(tau, pred, 30)
    assert r.pooled["rmse_per_sample"] == pytest.approx(rmse, rel=1e-12)  # the code's RMSE
    assert r.pooled["rmse_per_element"] == pytest.approx(rmse / math.sqrt(3), rel=1e-12)  # the formula's
    assert r.pooled["vaf"] == pytest.approx(vaf, rel=1e-12)
    assert r.pooled["fit_percent"] == pytest.approx(fit, rel=1e-12)
    assert r.pooled["r2"] == pytest.approx(r2, rel=1e-12)
    assert r.information_criteria["aic"] == pytest.approx(aic, rel=1e-12)
    assert r.information_criteria["bic"] == pytest.approx(bic, rel=1e-12)


# ---------------------------------------------------------------- identities


def test_identities_fit_r2_vaf_ddof_scale(backend):
    tau, pred = _data(seed=4)
    r = dynval.validate(tau, pred, n_params=1, backend=backend)
    # Fit = 100 (1 − √(1 − R²)), not 100 √R²
    np.testing.assert_allclose(r.per_joint["fit_percent"], 100 * (1 - np.sqrt(1 - r.per_joint["r2"])), rtol=1e-10)
    # a residual one tenth of a zero-mean torque: R² = 0.99, so fit is 90 %, where the lesson's "100 √R²"
    # would say 99.5 %
    t = np.array([3.0, -1.0, 2.0, -4.0, 1.0, -1.0] * 20)[:, None]
    exact = dynval.validate(t, t - 0.1 * t, n_params=1, backend=backend)
    assert exact.per_joint["r2"][0] == pytest.approx(0.99, abs=1e-12)
    assert exact.per_joint["fit_percent"][0] == pytest.approx(90.0, abs=1e-9)
    # VAF does not depend on ddof: the lesson (ddof 1) and matlab (ddof 0) profiles agree.
    m = dynval.validate(tau, pred, n_params=1, profile="matlab", backend=backend)
    np.testing.assert_allclose(m.per_joint["vaf"], r.per_joint["vaf"], rtol=1e-12)
    e = tau - pred
    np.testing.assert_allclose(
        r.per_joint["vaf"], 100 * (1 - np.var(e, axis=0, ddof=0) / np.var(tau, axis=0, ddof=0)), rtol=1e-10)
    # scale invariance of VAF, fit, R²
    s = dynval.validate(tau * 1e3, pred * 1e3, n_params=1, backend=backend)
    for key in ("vaf", "fit_percent", "r2"):
        np.testing.assert_allclose(s.per_joint[key], r.per_joint[key], rtol=1e-9)
        assert s.pooled[key] == pytest.approx(r.pooled[key], rel=1e-9)


def test_tss_decomposition_least_squares_with_intercept(backend):
    # On estimation data of a least-squares fit with an intercept, TSS = SSR + RSS, R² ∈ [0, 1].
    rng = np.random.default_rng(9)
    x = rng.normal(size=(120, 2))
    X = np.column_stack([np.ones(120), x])
    y = X @ np.array([2.0, 1.0, -0.5]) + rng.normal(0.0, 1.0, 120)
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    yhat = X @ beta
    r = dynval.validate(y, yhat, n_params=3, backend=backend)
    tss, ssr, rss = np.sum((y - y.mean()) ** 2), np.sum((yhat - y.mean()) ** 2), np.sum((y - yhat) ** 2)
    assert tss == pytest.approx(ssr + rss, rel=1e-12)
    assert r.pooled["r2"] == pytest.approx(ssr / tss, rel=1e-10)
    assert 0.0 <= r.pooled["r2"] <= 1.0
    # Same model on new data without re-fitting: R² may go negative, and dynval keeps it.
    y_new = rng.normal(size=120) * 0.1
    assert dynval.validate(y_new, X @ beta, n_params=3, backend=backend).pooled["r2"] < 0


def test_numbers_quoted_in_conventions_doc(backend):
    # §1.3: e = (1, 2, 3, 4) gives ρ̂(1) = 0.25 biased and 1/3 adjusted, as statsmodels does.
    from statsmodels.tsa.stattools import acf

    e = [1.0, 2.0, 3.0, 4.0]
    assert dynval.autocorrelation(e, 1, adjusted=False, backend=backend)[1] == pytest.approx(0.25, rel=1e-14)
    assert dynval.autocorrelation(e, 1, backend=backend)[1] == pytest.approx(1 / 3, rel=1e-14)
    assert acf(e, nlags=1, adjusted=False, fft=False)[1] == pytest.approx(0.25, rel=1e-14)
    assert acf(e, nlags=1, adjusted=True, fft=False)[1] == pytest.approx(1 / 3, rel=1e-14)
    # §1.2: Newey–West bandwidth K = ⌊4 (N/100)^(2/9)⌋
    rng = np.random.default_rng(0)
    for n, k in ((100, 4), (1000, 6), (2000, 7), (10000, 11)):
        assert dynval.zero_mean_test(rng.normal(size=n), backend=backend).bandwidth == k
    # §1.3 and §1.6 constants
    assert float(mp.sqrt(2) * mp.erfinv(mpf("0.95"))) == pytest.approx(1.959964, abs=5e-7)
    assert float(mp.sqrt(2) * mp.erfinv(mpf("0.99"))) == pytest.approx(2.575829, abs=5e-7)
    assert float(mlog(2 * mp.pi) + 1) == pytest.approx(2.8378771, abs=5e-8)
    assert float(mlog(1000)) == pytest.approx(6.907755, abs=5e-7)


@pytest.mark.parametrize("profile, period, longest, expected", [
    ("lesson", 40.5, 1000, 41),          # one period of the band's edge, rounded up
    ("lesson", 500.0, 1000, 200),        # at most four times the lesson's 50 lags
    ("statsmodels", 500.0, 1000, 120),   # four times ⌊10·log10(1000)⌋ = 30
    ("lesson", 1e300, 60, 59),           # below the longest segment, and no overflow on the way
    ("lesson", float("inf"), 60, 59),
    ("lesson", 0.25, 1000, 1),           # at least one lag
])
def test_motion_max_lag_is_one_period_within_the_profile_cap_and_the_segment(profile, period, longest, expected):
    assert PROFILES[profile].motion_max_lag(period, 1000, longest) == expected
