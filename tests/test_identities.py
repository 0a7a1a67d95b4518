"""Mathematical identities between the metrics, checked on hypothesis-generated data."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import dynval
from dynval.kernels._reference import correlation

FINITE = st.floats(-100.0, 100.0, allow_nan=False, allow_infinity=False)


@st.composite
def pairs(draw, max_m=4):
    """(tau_meas, tau_pred) with every joint clearly non-constant."""
    n = draw(st.integers(4, 40))
    m = draw(st.integers(1, max_m))
    raw = draw(hnp.arrays(np.float64, (n, m), elements=FINITE))
    trend = draw(st.floats(1.0, 100.0))
    meas = raw + trend * np.linspace(-1.0, 1.0, n)[:, None] * np.arange(1, m + 1)
    noise = draw(hnp.arrays(np.float64, (n, m), elements=st.floats(-10.0, 10.0)))
    assume(np.all(meas.std(axis=0) > 1e-3 * (1.0 + np.abs(meas).max())))
    return meas, meas + noise


def close(a, b, rtol=1e-9, atol=1e-9):
    np.testing.assert_allclose(a, b, rtol=rtol, atol=atol)


@given(data=pairs())
def test_fit_is_a_function_of_r2(backend, data):
    meas, pred = data
    for mo in ("pooled", "raw_values"):
        r2 = np.asarray(dynval.r2(meas, pred, multioutput=mo, backend=backend))
        fit = np.asarray(dynval.fit_percent(meas, pred, multioutput=mo, backend=backend))
        close(fit, 100.0 * (1.0 - np.sqrt(1.0 - r2)), atol=1e-6)


@given(data=pairs())
def test_vaf_does_not_depend_on_ddof(backend, data):
    meas, pred = data
    vaf = dynval.vaf(meas, pred, multioutput="raw_values", backend=backend)
    e = meas - pred
    for ddof in (0, 1, 3):
        ratio = (dynval.residual_variance(e, ddof=ddof, backend=backend)
                 / dynval.residual_variance(meas, ddof=ddof, backend=backend))
        close(vaf, 100.0 * (1.0 - ratio))


@given(data=pairs(), scale=st.sampled_from([1e-3, 0.37, 2.0, -5.0, 1e3]), shift=st.floats(-50, 50))
def test_scale_invariance(backend, data, scale, shift):
    meas, pred = data
    for name in ("vaf", "fit_percent", "r2"):
        f = getattr(dynval, name)
        for mo in ("pooled", "raw_values", "variance_weighted"):
            base = f(meas, pred, multioutput=mo, backend=backend)
            close(f(scale * meas, scale * pred, multioutput=mo, backend=backend), base, atol=1e-7)
            close(f(meas + shift, pred + shift, multioutput=mo, backend=backend), base, atol=1e-7)


@given(
    n=st.integers(8, 60),
    k=st.integers(1, 4),
    seed=st.integers(0, 2**32 - 1),
)
def test_least_squares_with_intercept_decomposes_tss(backend, n, k, seed):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, k))
    y = x @ rng.standard_normal(k) + rng.standard_normal(n) + 3.0
    design = np.column_stack([np.ones(n), x])
    beta, *_ = np.linalg.lstsq(design, y, rcond=None)
    fitted = design @ beta
    tss = np.sum((y - y.mean()) ** 2)
    ssr = np.sum((fitted - y.mean()) ** 2)
    rss = np.sum((y - fitted) ** 2)
    assert tss == pytest.approx(ssr + rss, rel=1e-10)
    r2 = dynval.r2(y, fitted, backend=backend)
    assert r2 == pytest.approx(ssr / tss, rel=1e-9, abs=1e-12)
    assert -1e-12 <= r2 <= 1 + 1e-12
    # With an intercept the mean residual is zero, so VAF and R² coincide.
    assert dynval.vaf(y, fitted, backend=backend) / 100 == pytest.approx(r2, rel=1e-9, abs=1e-12)


@given(
    n=st.integers(10, 5000),
    p1=st.integers(0, 8),
    p2=st.integers(0, 8),
    rss1=st.floats(1e-6, 1e6),
    rss2=st.floats(1e-6, 1e6),
)
def test_delta_aic(backend, n, p1, p2, rss1, rss2):
    a = dynval.information_criteria(rss1, n, p1, backend=backend)
    b = dynval.information_criteria(rss2, n, p2, backend=backend)
    assert a.aic - b.aic == pytest.approx(n * math.log(rss1 / rss2) + 2 * (p1 - p2), rel=1e-9, abs=1e-9 * n)
    assert a.bic - b.bic == pytest.approx(n * math.log(rss1 / rss2) + (p1 - p2) * math.log(n), rel=1e-9, abs=1e-9 * n)


@given(data=pairs(max_m=1))
def test_vaf_minus_r2_is_the_squared_mean_residual(backend, data):
    meas, pred = data
    e = (meas - pred).ravel()
    tau = meas.ravel()
    var0 = np.mean((tau - tau.mean()) ** 2)
    lhs = dynval.vaf(meas, pred, backend=backend) / 100 - dynval.r2(meas, pred, backend=backend)
    assert lhs == pytest.approx(e.mean() ** 2 / var0, rel=1e-7, abs=1e-10)


@given(data=pairs())
def test_aggregates(backend, data):
    meas, pred = data
    e = meas - pred
    sse = np.sum(e**2, axis=0)
    tss = np.sum((meas - meas.mean(axis=0)) ** 2, axis=0)
    close(dynval.r2(meas, pred, multioutput="variance_weighted", backend=backend), 1 - sse.sum() / tss.sum())
    for name in ("vaf", "fit_percent", "r2", "rmse"):
        f = getattr(dynval, name)
        close(f(meas, pred, multioutput="uniform_average", backend=backend),
              np.mean(f(meas, pred, multioutput="raw_values", backend=backend)))
    n, m = meas.shape
    close(dynval.rmse(meas, pred, convention="per_sample", backend=backend),
          math.sqrt(m) * dynval.rmse(meas, pred, backend=backend))
    close(dynval.rmse(meas, pred, multioutput="raw_values", backend=backend) ** 2 * n,
          dynval.sse(meas, pred, multioutput="raw_values", backend=backend))
    close(dynval.sse(meas, pred, backend=backend), np.sum(e**2))


@given(data=pairs(), seed=st.integers(0, 1000))
def test_point_metrics_ignore_sample_order(backend, data, seed):
    meas, pred = data
    order = np.random.default_rng(seed).permutation(meas.shape[0])
    for name in ("rmse", "vaf", "fit_percent", "r2", "sse", "max_abs_error"):
        f = getattr(dynval, name)
        close(f(meas[order], pred[order], backend=backend), f(meas, pred, backend=backend), rtol=1e-12, atol=1e-12)


@given(data=pairs(max_m=1), p=st.integers(0, 2))
def test_noise_models_agree_for_one_joint(backend, data, p):
    meas, pred = data
    ics = [dynval.criteria(meas, pred, n_params=p, noise_model=nm, backend=backend)
           for nm in ("pooled", "per_joint", "full")]
    for ic in ics[1:]:
        for key in ("aic", "bic", "aicc", "fpe", "naic"):
            assert getattr(ic, key) == pytest.approx(getattr(ics[0], key), rel=1e-10, abs=1e-10)


@given(data=pairs(), p=st.integers(0, 3))
def test_criteria_closed_forms(backend, data, p):
    meas, pred = data
    n, m = meas.shape
    e = meas - pred
    sse = np.sum(e**2, axis=0)
    assume(np.all(sse > 0))  # an exact joint is a degenerate case (test_degenerate.py)
    pooled = dynval.criteria(meas, pred, n_params=p, backend=backend)
    nm = n * m
    assert pooled.aic == pytest.approx(nm * math.log(sse.sum() / nm) + 2 * p, rel=1e-10, abs=1e-9)
    assert pooled.n_obs == nm
    per_joint = dynval.criteria(meas, pred, n_params=p, noise_model="per_joint", backend=backend)
    assert per_joint.bic == pytest.approx(n * np.sum(np.log(sse / n)) + p * math.log(n), rel=1e-10, abs=1e-9)
    full = dynval.criteria(meas, pred, n_params=p, noise_model="full", backend=backend)
    sigma = e.T @ e / n
    # Near-singular covariances are a rounding question (the corpus owns det = 0).
    assume(np.linalg.cond(sigma) < 1e8)
    _sign, logdet = np.linalg.slogdet(sigma)
    assert full.aic == pytest.approx(n * logdet + 2 * p, rel=1e-8, abs=1e-8)
    assert full.naic == pytest.approx(logdet + 2 * p / n, rel=1e-8, abs=1e-8)
    if p < n - 1:
        assert full.aicc == pytest.approx(full.aic + 2 * p * (p + 1) / (n - p - 1), rel=1e-12, abs=1e-12)
        assert per_joint.fpe == pytest.approx(np.prod(sse / n) * (1 + p / n) / (1 - p / n), rel=1e-10)
    else:
        assert math.isnan(full.aicc) and math.isnan(full.fpe)


@given(data=pairs(), max_lag=st.integers(0, 3))
def test_autocorrelation_bounds(backend, data, max_lag):
    meas, pred = data
    e = meas - pred
    assume(np.all(e.std(axis=0) > 1e-6))  # constant or underflowing residuals: test_degenerate.py
    rho = dynval.autocorrelation(e, max_lag, adjusted=False, backend=backend)
    assert np.all(rho[0] == 1.0)
    assert np.all(np.abs(rho) <= 1 + 1e-12)
    if max_lag >= 1:
        res = dynval.ljung_box(e, max_lag, backend=backend)
        assert np.all(res.statistic >= 0)
        assert np.all((res.pvalue >= 0) & (res.pvalue <= 1))


@given(
    n=st.integers(2, 300),
    max_lag=st.integers(0, 80),
    seed=st.integers(0, 2**32 - 1),
    cut=st.floats(0.1, 0.9),
)
def test_fft_and_direct_lagged_products_agree(n, max_lag, seed, cut):
    # Reference internals: the two summation paths of the lagged products.
    rng = np.random.default_rng(seed)
    x, y = rng.standard_normal((n, 2)), rng.standard_normal((n, 2))
    starts = np.unique(np.array([0, int(cut * n)], dtype=np.int64))
    fft = correlation.lagged_products(x, y, max_lag, starts, method="fft")
    direct = correlation.lagged_products(x, y, max_lag, starts, method="direct")
    np.testing.assert_allclose(fft, direct, rtol=0, atol=1e-12 * n)
