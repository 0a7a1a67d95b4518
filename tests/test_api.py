"""Public API values: hand-checked examples, independent libraries, segments and backends.

Expected values come from closed forms (mpmath), independent implementations (the build notes'
Octave and Java runs of the lesson's code), scikit-learn, statsmodels and scipy.stats, or
plain-Python loops written from the contract's formulas; never from dynval itself.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import scipy.stats
from sklearn.metrics import explained_variance_score, max_error, r2_score, root_mean_squared_error
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.stattools import acf

import dynval

# --------------------------------------------------------------------------- hand-checked values


def _mp_criteria(rss, n, p):
    with mpmath.workdps(50):
        s2 = mpmath.mpf(rss) / n
        aic = 2 * p + n * mpmath.log(s2)
        bic = p * mpmath.log(n) + n * mpmath.log(s2)
        aicc = aic + mpmath.mpf(2 * p * (p + 1)) / (n - p - 1)
        fpe = s2 * (1 + mpmath.mpf(p) / n) / (1 - mpmath.mpf(p) / n)
        naic = mpmath.log(s2) + mpmath.mpf(2 * p) / n
        return {k: float(v) for k, v in dict(aic=aic, bic=bic, aicc=aicc, fpe=fpe, naic=naic).items()}


@pytest.mark.parametrize(("rss", "p"), [(10.0, 6), (8.5, 10)])
def test_lesson_problem_4(backend, rss, p):
    ic = dynval.information_criteria(rss, 1000, p, backend=backend)
    want = _mp_criteria(rss, 1000, p)
    for key, value in want.items():
        assert getattr(ic, key) == pytest.approx(value, rel=1e-14, abs=0), key
    assert (ic.n_obs, ic.n_params) == (1000, p)


def test_lesson_problem_4_printed_digits_and_decision(backend):
    m1 = dynval.information_criteria(10.0, 1000, 6, backend=backend)
    m2 = dynval.information_criteria(8.5, 1000, 10, backend=backend)
    assert f"{m1.aic:.12f}" == "-4593.170185988091"[: len(f"{m1.aic:.12f}")]
    assert round(m2.aic, 3) == -4747.689
    assert round(m1.bic, 3) == -4563.724
    assert round(m2.bic, 3) == -4698.612
    # Both criteria prefer model 2 (the lesson's conclusion).
    assert m2.aic < m1.aic and m2.bic < m1.bic


# Build notes, Experiment 2 (GNU Octave running the lesson's MATLAB code); its rmse is √(SSE/N).
OCTAVE_MEAS = np.array([[1, 2], [2.5, 1.5], [3.2, 0.7], [4.1, -0.4], [4.8, -1.2], [6.1, -2.1]])
OCTAVE_PRED = np.array([[1.1, 1.9], [2.4, 1.6], [3, 0.9], [4.3, -0.5], [4.7, -1], [6, -2.3]])
OCTAVE = dict(
    rmse=0.21213203435596423,
    vaf=99.593588001409231,
    fit_percent=93.615094048676411,
    r2=0.99592329759927523,
    aic=-37.530879637261158,
    bic=-35.591253038109159,
)
# Build notes, Experiment 3 (the lesson's Java class), p = 2.
JAVA_MEAS = [1.0, 2.5, 3.2, 4.1, 4.8, 6.1]
JAVA_PRED = [1.1, 2.4, 3.0, 4.3, 4.7, 6.0]
JAVA = dict(
    rmse=0.14142135623730953,
    vaf=99.29467897521003,
    fit_percent=91.35818018681002,
    r2=0.9925318950316357,
    aic=-19.472138032568875,
    bic=-19.888619094112766,
)


@pytest.mark.parametrize(("meas", "pred", "p", "want"),
                         [(OCTAVE_MEAS, OCTAVE_PRED, 4, OCTAVE), (JAVA_MEAS, JAVA_PRED, 2, JAVA)],
                         ids=["octave", "java"])
def test_build_notes_examples(backend, meas, pred, p, want):
    got = dict(
        rmse=dynval.rmse(meas, pred, convention="per_sample", backend=backend),
        vaf=dynval.vaf(meas, pred, backend=backend),
        fit_percent=dynval.fit_percent(meas, pred, backend=backend),
        r2=dynval.r2(meas, pred, backend=backend),
        aic=dynval.aic(meas, pred, n_params=p, backend=backend),
        bic=dynval.bic(meas, pred, n_params=p, backend=backend),
    )
    for key in want:
        assert got[key] == pytest.approx(want[key], rel=1e-12, abs=0), key


def test_rmse_conventions(backend):
    e = np.array([[3.0, 4.0], [0.0, 0.0]])  # SSE = 25, N = 2, m = 2
    zero = np.zeros_like(e)
    assert dynval.rmse(e, zero, backend=backend) == math.sqrt(25 / 4)
    assert dynval.rmse(e, zero, convention="per_element", backend=backend) == math.sqrt(25 / 4)
    assert dynval.rmse(e, zero, convention="per_sample", backend=backend) == math.sqrt(25 / 2)
    assert dynval.rmse(e, zero, multioutput="raw_values", backend=backend).tolist() == [math.sqrt(9 / 2), math.sqrt(8)]
    assert dynval.rmse(e, zero, multioutput="uniform_average", backend=backend) == pytest.approx(
        (math.sqrt(4.5) + math.sqrt(8)) / 2)
    assert dynval.sse(e, zero, backend=backend) == 25.0
    assert dynval.sse(e, zero, multioutput="raw_values", backend=backend).tolist() == [9.0, 16.0]
    assert dynval.max_abs_error(e, -e, backend=backend) == 8.0
    assert dynval.max_abs_error(e, -e, multioutput="raw_values", backend=backend).tolist() == [6.0, 8.0]


def test_confidence_band(backend):
    assert dynval.confidence_band(400, backend=backend) == pytest.approx(1.959963984540054 / 20, rel=1e-15)
    assert dynval.confidence_band(1, level=0.99, backend=backend) == pytest.approx(2.5758293035489004, rel=1e-15)
    assert isinstance(dynval.confidence_band(10), float)


# --------------------------------------------------------------------------- scikit-learn


def _random_pair(seed, n=40, m=3):
    rng = np.random.default_rng(seed)
    scale = np.array([1.0, 5.0, 0.2, 30.0])[:m]
    meas = rng.standard_normal((n, m)) * scale + rng.standard_normal(m) * 3
    pred = meas + rng.standard_normal((n, m)) * 0.4 * scale + 0.1
    return meas, pred


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("multioutput", ["raw_values", "uniform_average", "variance_weighted"])
def test_sklearn_r2_and_vaf(backend, seed, multioutput):
    meas, pred = _random_pair(seed)
    np.testing.assert_allclose(dynval.r2(meas, pred, multioutput=multioutput, backend=backend),
                               r2_score(meas, pred, multioutput=multioutput), rtol=1e-12)
    np.testing.assert_allclose(
        dynval.vaf(meas, pred, multioutput=multioutput, backend=backend),
        100 * np.asarray(explained_variance_score(meas, pred, multioutput=multioutput)),
        rtol=1e-12,
    )


@pytest.mark.parametrize("seed", range(5))
def test_sklearn_rmse_and_max_error(backend, seed):
    meas, pred = _random_pair(seed)
    for mo in ("raw_values", "uniform_average"):
        np.testing.assert_allclose(dynval.rmse(meas, pred, multioutput=mo, backend=backend),
                                   root_mean_squared_error(meas, pred, multioutput=mo), rtol=1e-13)
    per_joint = dynval.max_abs_error(meas, pred, multioutput="raw_values", backend=backend)
    assert per_joint.tolist() == [max_error(meas[:, j], pred[:, j]) for j in range(meas.shape[1])]
    # Pooled r2 is sklearn's on the flattened values.
    assert dynval.r2(meas, pred, backend=backend) == pytest.approx(r2_score(meas.ravel(), pred.ravel()), rel=1e-12)


# --------------------------------------------------------------------------- statsmodels / scipy


@pytest.mark.parametrize("adjusted", [True, False])
def test_statsmodels_acf(backend, adjusted):
    rng = np.random.default_rng(5)
    x = np.convolve(rng.standard_normal(300), [1.0, 0.6, 0.3], mode="same") + 2.0
    got = dynval.autocorrelation(x, 40, adjusted=adjusted, backend=backend)
    want = acf(x, nlags=40, adjusted=adjusted, fft=False)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-14)
    two = np.column_stack([x, x[::-1]])
    got2 = dynval.autocorrelation(two, 40, adjusted=adjusted, backend=backend)
    np.testing.assert_allclose(got2[:, 1], acf(x[::-1], nlags=40, adjusted=adjusted, fft=False), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("model_df", [0, 2])
def test_statsmodels_ljung_box_and_box_pierce(backend, model_df):
    rng = np.random.default_rng(6)
    x = np.convolve(rng.standard_normal(250), [1.0, 0.4], mode="same")
    lags = [3, 7, 12]
    want = acorr_ljungbox(x, lags=lags, model_df=model_df, boxpierce=True)
    lb = dynval.ljung_box(x, lags, model_df=model_df, backend=backend)
    bp = dynval.box_pierce(x, lags, model_df=model_df, backend=backend)
    np.testing.assert_allclose(lb.statistic[:, 0], want["lb_stat"], rtol=1e-10)
    np.testing.assert_allclose(lb.pvalue[:, 0], want["lb_pvalue"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(bp.statistic[:, 0], want["bp_stat"], rtol=1e-10)
    np.testing.assert_allclose(bp.pvalue[:, 0], want["bp_pvalue"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(lb.log_pvalue[:, 0], np.log(want["lb_pvalue"]), rtol=1e-9)
    assert lb.lags.tolist() == lags and lb.df.tolist() == [h - model_df for h in lags]
    assert lb.test == "ljung_box" and bp.test == "box_pierce" and lb.model_df == model_df
    assert lb.statistic.shape == (3, 1)


def test_portmanteau_lags_keep_given_order(backend):
    x = np.sin(np.arange(60.0) * 0.7) + np.cos(np.arange(60.0) * 2.1)
    a = dynval.ljung_box(x, [9, 2, 5], backend=backend)
    b = dynval.ljung_box(x, [2, 5, 9], backend=backend)
    np.testing.assert_array_equal(a.statistic[[1, 2, 0]], b.statistic)


def test_log_pvalue_where_pvalue_underflows(backend):
    # A strongly autocorrelated residual: the chi-squared tail is far below 1e-308.
    x = np.sin(np.arange(5000) * 0.01)
    res = dynval.ljung_box(x, 20, backend=backend)
    q, df = float(res.statistic[0, 0]), int(res.df[0])
    assert res.pvalue[0, 0] == 0.0
    with mpmath.workdps(30):
        want = float(mpmath.log(mpmath.gammainc(mpmath.mpf(df) / 2, mpmath.mpf(q) / 2, regularized=True)))
    assert res.log_pvalue[0, 0] == pytest.approx(want, rel=1e-12)


def test_zero_mean_test_iid_is_ttest_1samp(backend):
    rng = np.random.default_rng(7)
    e = rng.standard_normal((80, 3)) * [1.0, 0.1, 4.0] + [0.3, 0.0, -1.0]
    res = dynval.zero_mean_test(e, backend=backend)
    want = scipy.stats.ttest_1samp(e, 0.0, axis=0)
    np.testing.assert_allclose(res.statistic_iid, want.statistic, rtol=1e-12)
    np.testing.assert_allclose(res.pvalue_iid, want.pvalue, rtol=1e-10, atol=1e-300)
    # the means are small next to the data: compare on the data's scale
    np.testing.assert_allclose(res.mean, e.mean(axis=0), rtol=0, atol=1e-15 * np.abs(e).max())
    np.testing.assert_allclose(res.std, e.std(axis=0, ddof=1), rtol=1e-14)
    assert res.df_iid == 79 and res.n_samples == 80


def test_zero_mean_test_newey_west(backend):
    rng = np.random.default_rng(8)
    e = np.convolve(rng.standard_normal(400), np.ones(5) / 5, mode="same") + 0.05
    res = dynval.zero_mean_test(e, backend=backend)
    n = e.size
    k = math.floor(4 * (n / 100) ** (2 / 9))
    rho = acf(e, nlags=k, adjusted=False, fft=False)
    total = sum((1 - j / (k + 1)) * rho[j] for j in range(1, k + 1))
    n_eff = min(max(n / (1 + 2 * total), 2.0), n)
    t = e.mean() * math.sqrt(n_eff) / e.std(ddof=1)
    assert res.bandwidth == k == 5
    assert res.n_eff[0] == pytest.approx(n_eff, rel=1e-12)
    assert res.df_eff[0] == pytest.approx(n_eff - 1, rel=1e-12)
    assert res.statistic_eff[0] == pytest.approx(t, rel=1e-12)
    assert res.pvalue_eff[0] == pytest.approx(2 * scipy.stats.t.sf(abs(t), n_eff - 1), rel=1e-10)
    # The moving average makes the residual positively correlated: fewer effective samples.
    assert n_eff < n / 2 and res.pvalue_eff[0] > res.pvalue_iid[0]


def test_zero_mean_test_negative_correlation_clips_to_n(backend):
    e = np.tile([1.0, -1.0], 50) + 0.01
    res = dynval.zero_mean_test(e, backend=backend)
    assert res.n_eff[0] == 100.0
    assert res.statistic_eff[0] == pytest.approx(res.statistic_iid[0], rel=1e-15)


# --------------------------------------------------------------------------- segments


def _manual_autocorrelation(x, max_lag, lengths, adjusted):
    """Plain loops from contract §1.1/§3.4: products within segments, overall mean."""
    n = len(x)
    mean = math.fsum(x) / n
    d = [v - mean for v in x]
    starts = [sum(lengths[:i]) for i in range(len(lengths))]
    s = []
    counts = []
    for lag in range(max_lag + 1):
        terms, count = [], 0
        for a, length in zip(starts, lengths):
            for k in range(a + lag, a + length):
                terms.append(d[k] * d[k - lag])
                count += 1
        s.append(math.fsum(terms))
        counts.append(count)
    r0 = s[0] / n
    return np.array([(s[lag] / (counts[lag] if adjusted else n)) / r0 for lag in range(max_lag + 1)])


@pytest.mark.parametrize("adjusted", [True, False])
def test_segments_no_product_crosses_a_boundary(backend, adjusted):
    rng = np.random.default_rng(9)
    x = rng.standard_normal(70) + np.repeat([0.0, 5.0, -3.0], [30, 25, 15])
    lengths = [30, 25, 15]
    got = dynval.autocorrelation(x, 20, adjusted=adjusted, segments=lengths, backend=backend)
    want = _manual_autocorrelation(x.tolist(), 20, lengths, adjusted)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    # Lags beyond a short segment still count the longer ones.
    whole = dynval.autocorrelation(x, 20, adjusted=adjusted, backend=backend)
    assert not np.allclose(got[1:], whole[1:])


def test_segments_lengths_and_starts_forms_agree(backend):
    rng = np.random.default_rng(10)
    x = rng.standard_normal((50, 2))
    a = dynval.autocorrelation(x, 9, segments=[20, 30], backend=backend)
    b = dynval.autocorrelation(x, 9, segments=[0, 20], backend=backend)
    c = dynval.autocorrelation(x, 9, segments=np.array([0, 20]), backend=backend)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    np.testing.assert_array_equal(
        dynval.ljung_box(x, 5, segments=(20, 30), backend=backend).statistic,
        dynval.ljung_box(x, 5, segments=[0, 20], backend=backend).statistic,
    )


def test_ljung_box_with_segments_uses_product_counts(backend):
    rng = np.random.default_rng(11)
    x = rng.standard_normal(40)
    lengths = [25, 15]
    rho = _manual_autocorrelation(x.tolist(), 4, lengths, adjusted=False)
    counts = [sum(max(n - lag, 0) for n in lengths) for lag in range(5)]
    q = 40 * 42 * sum(rho[lag] ** 2 / counts[lag] for lag in range(1, 5))
    res = dynval.ljung_box(x, 4, segments=lengths, backend=backend)
    assert res.statistic[0, 0] == pytest.approx(q, rel=1e-12)


def test_omit_inserts_breaks(backend):
    rng = np.random.default_rng(12)
    x = rng.standard_normal(40)
    holed = x.copy()
    holed[[10, 11, 30]] = [np.nan, np.inf, np.nan]
    kept = np.delete(x, [10, 11, 30])
    got = dynval.autocorrelation(holed, 6, nan_policy="omit", backend=backend)
    want = _manual_autocorrelation(kept.tolist(), 6, [10, 18, 9], adjusted=True)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    # Caller's segments are kept and refined.
    got2 = dynval.autocorrelation(holed, 6, segments=[20, 20], nan_policy="omit", backend=backend)
    want2 = _manual_autocorrelation(kept.tolist(), 6, [10, 8, 10, 9], adjusted=True)
    np.testing.assert_allclose(got2, want2, rtol=1e-12, atol=1e-15)


def test_omit_deletes_rows_across_all_arrays(backend):
    meas = np.array([[1.0, 2.0], [2.0, np.nan], [3.0, 1.0], [4.0, 0.0], [5.0, 2.0]])
    pred = np.array([[1.5, 2.0], [2.0, 3.0], [np.inf, 1.0], [4.0, 0.5], [5.0, 2.5]])
    got = dynval.sse(meas, pred, multioutput="raw_values", nan_policy="omit", backend=backend)
    assert got.tolist() == [0.25, 0.25 + 0.25]
    e = dynval.residuals(meas, pred, nan_policy="omit", backend=backend)
    assert e.shape == (3, 2)


def test_cross_correlation_against_loops(backend):
    rng = np.random.default_rng(13)
    n, m, p, max_lag = 30, 2, 3, 5
    e = rng.standard_normal((n, m))
    y = rng.standard_normal((n, m, p)) + e[:, :, None] * 0.5
    lengths = [18, 12]
    for adjusted in (True, False):
        cc = dynval.cross_correlation(e, y, max_lag, adjusted=adjusted, segments=lengths, backend=backend)
        assert cc.rho.shape == (m, p, max_lag + 1)
        for j in range(m):
            de = e[:, j] - e[:, j].mean()
            for c in range(p):
                dy = y[:, j, c] - y[:, j, c].mean()
                norm = math.sqrt(np.mean(de**2) * np.mean(dy**2))
                for lag in range(max_lag + 1):
                    pairs = [(k, k - lag) for a, ln in ((0, 18), (18, 12)) for k in range(a + lag, a + ln)]
                    total = math.fsum(de[k] * dy[i] for k, i in pairs)
                    want = total / (len(pairs) if adjusted else n) / norm
                    assert cc.rho[j, c, lag] == pytest.approx(want, rel=1e-10, abs=1e-14)
    band = 1.959963984540054 / math.sqrt(n)
    assert cc.band == pytest.approx(band, rel=1e-14) and cc.level == 0.95
    flagged = [(j, c, lag) for j in range(m) for c in range(p) for lag in range(max_lag + 1)
               if abs(cc.rho[j, c, lag]) > cc.band]
    assert sorted((t[0], t[1], t[2]) for t in cc.outside) == flagged
    ratios = [t[4] for t in cc.outside]
    assert ratios == sorted(ratios, reverse=True)
    for j, c, lag, rho, ratio in cc.outside:
        assert rho == cc.rho[j, c, lag] and ratio == pytest.approx(abs(rho) / cc.band)


def test_cross_correlation_stacked_regressor(backend):
    rng = np.random.default_rng(14)
    e = rng.standard_normal((25, 2))
    y = rng.standard_normal((25, 2, 4))
    stacked = y.reshape(50, 4)  # row k*m + j is sample k, joint j
    a = dynval.cross_correlation(e, y, 4, backend=backend)
    b = dynval.cross_correlation(e, stacked, 4, n_joints=2, backend=backend)
    np.testing.assert_array_equal(a.rho, b.rho)
    assert a.outside == b.outside


# --------------------------------------------------------------------------- backends


def test_backends_api():
    info = dynval.backends()
    assert set(info) == {"python", "cpp"}
    assert info["python"]["available"] is True
    for entry in info.values():
        assert isinstance(entry["available"], bool) and isinstance(entry["detail"], str) and entry["detail"]


def test_set_backend_changes_the_default(monkeypatch):
    from dynval.kernels import _backend

    try:
        dynval.set_backend("python")
        assert _backend.default_backend() == "python"
        dynval.set_backend(None)
        monkeypatch.setenv("DYNVAL_BACKEND", "python")
        assert _backend.default_backend() == "python"
        monkeypatch.setenv("DYNVAL_BACKEND", "nope")
        with pytest.raises(dynval.InvalidParameter, match=r"^DYNVAL_BACKEND \(environment variable\) must be one of"):
            dynval.rmse([1.0], [2.0])
    finally:
        dynval.set_backend(None)


def test_backends_agree():
    names = [n for n, v in dynval.backends().items() if v["available"]]
    if len(names) < 2:
        pytest.skip("only one backend available")
    meas, pred = _random_pair(3, n=200)
    for name in ("rmse", "vaf", "fit_percent", "r2"):
        values = [getattr(dynval, name)(meas, pred, multioutput="raw_values", backend=b) for b in names]
        np.testing.assert_allclose(values[0], values[1], rtol=1e-12)
    acfs = [dynval.autocorrelation(meas - pred, 30, backend=b) for b in names]
    np.testing.assert_allclose(acfs[0], acfs[1], rtol=1e-10, atol=1e-13)


def test_public_names():
    for name in ("residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean",
                 "residual_variance", "zero_mean_test", "autocorrelation", "confidence_band", "ljung_box",
                 "box_pierce", "cross_correlation", "information_criteria", "criteria", "aic", "bic",
                 "backends", "set_backend", "validate", "ValidationReport"):
        assert name in dynval.__all__ and callable(getattr(dynval, name))
    assert dynval.CONTRACT_VERSION == "1.0"
    assert isinstance(dynval.__version__, str)


# --------------------------------------------------------------------------- compute_metrics kernel

COMPUTE_METRICS_FIELDS = {
    "n_samples", "n_joints", "n_params", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2",
    "residual_mean", "residual_variance", "constant_target", "sse_total", "rmse_per_element",
    "rmse_per_sample", "max_abs_error_pooled", "vaf_pooled", "fit_percent_pooled", "r2_pooled",
    "constant_target_pooled", "rmse_uniform_average", "vaf_uniform_average", "fit_percent_uniform_average",
    "r2_uniform_average", "vaf_variance_weighted", "fit_percent_variance_weighted", "r2_variance_weighted",
    "aic", "bic", "aicc", "fpe", "naic",
}


@pytest.mark.parametrize("noise_model", ["pooled", "per_joint", "full"])
def test_compute_metrics_kernel(backend, noise_model):
    from dynval.kernels._backend import get_backend

    meas, pred = _random_pair(21, n=50, m=3)
    out = get_backend(backend).compute_metrics(meas, pred, 4, 0, noise_model)
    assert set(out) >= COMPUTE_METRICS_FIELDS
    n, m = meas.shape
    e = meas - pred
    sse = np.sum(e**2, axis=0)
    tss = np.sum((meas - meas.mean(axis=0)) ** 2, axis=0)
    flat_tss = np.sum((meas - meas.mean()) ** 2)
    assert (out["n_samples"], out["n_joints"], out["n_params"]) == (n, m, 4)
    expect = {
        "sse": sse,
        "rmse": root_mean_squared_error(meas, pred, multioutput="raw_values"),
        "max_abs_error": np.abs(e).max(axis=0),
        "vaf": 100 * explained_variance_score(meas, pred, multioutput="raw_values"),
        "fit_percent": 100 * (1 - np.sqrt(sse / tss)),
        "r2": r2_score(meas, pred, multioutput="raw_values"),
        "residual_mean": e.mean(axis=0),
        "residual_variance": e.var(axis=0),
        "sse_total": sse.sum(),
        "rmse_per_element": math.sqrt(sse.sum() / (n * m)),
        "rmse_per_sample": math.sqrt(sse.sum() / n),
        "max_abs_error_pooled": np.abs(e).max(),
        "vaf_pooled": 100 * explained_variance_score(meas.ravel(), pred.ravel()),
        "fit_percent_pooled": 100 * (1 - math.sqrt(sse.sum() / flat_tss)),
        "r2_pooled": r2_score(meas.ravel(), pred.ravel()),
        "rmse_uniform_average": root_mean_squared_error(meas, pred),
        "vaf_uniform_average": 100 * explained_variance_score(meas, pred),
        "r2_uniform_average": r2_score(meas, pred),
        "fit_percent_uniform_average": np.mean(100 * (1 - np.sqrt(sse / tss))),
        "vaf_variance_weighted": 100 * explained_variance_score(meas, pred, multioutput="variance_weighted"),
        "r2_variance_weighted": r2_score(meas, pred, multioutput="variance_weighted"),
        "fit_percent_variance_weighted": np.sum(tss * 100 * (1 - np.sqrt(sse / tss))) / tss.sum(),
    }
    for key, want in expect.items():
        np.testing.assert_allclose(out[key], want, rtol=1e-11, atol=1e-13, err_msg=key)
    assert np.asarray(out["constant_target"]).tolist() == [False] * m and out["constant_target_pooled"] is False
    if noise_model == "pooled":
        f, nn = n * m * math.log(sse.sum() / (n * m)), n * m
    elif noise_model == "per_joint":
        f, nn = n * float(np.sum(np.log(sse / n))), n
    else:
        f, nn = n * float(np.linalg.slogdet(e.T @ e / n)[1]), n
    assert out["aic"] == pytest.approx(f + 8, rel=1e-11)
    assert out["bic"] == pytest.approx(f + 4 * math.log(nn), rel=1e-11)
    assert out["aicc"] == pytest.approx(f + 8 + 2 * 4 * 5 / (nn - 5), rel=1e-11)
    assert out["naic"] == pytest.approx(f / nn + 8 / nn, rel=1e-11)


def test_compute_metrics_gives_nan_for_aicc_fpe_when_p_too_large(backend):
    from dynval.kernels._backend import get_backend

    meas, pred = _random_pair(22, n=5, m=1)
    out = get_backend(backend).compute_metrics(meas, pred, 4, 1, "pooled")
    assert math.isnan(out["aicc"]) and math.isnan(out["fpe"]) and math.isfinite(out["aic"])
    ic = dynval.criteria(meas, pred, n_params=4, backend=backend)
    assert math.isnan(ic.aicc) and math.isnan(ic.fpe)


def test_zero_mean_test_with_short_segments(backend):
    # K = ⌊4·(300/100)^(2/9)⌋ = 5, but segments of 3 samples only have lags 1 and 2.
    rng = np.random.default_rng(23)
    e = rng.standard_normal(300) + 0.2
    lengths = [3] * 100
    res = dynval.zero_mean_test(e, segments=lengths, backend=backend)
    k = 5
    rho = _manual_autocorrelation(e.tolist(), 2, lengths, adjusted=False)
    total = sum((1 - j / (k + 1)) * rho[j] for j in (1, 2))
    n_eff = 300.0 if total <= 0 else min(max(300 / (1 + 2 * total), 2.0), 300.0)
    assert res.bandwidth == k
    assert res.n_eff[0] == pytest.approx(n_eff, rel=1e-12)
    assert res.statistic_eff[0] == pytest.approx(e.mean() * math.sqrt(n_eff) / e.std(ddof=1), rel=1e-12)
