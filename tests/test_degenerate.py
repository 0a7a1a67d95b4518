"""Contract §3.2: degenerate input gives the tabled values, without warnings, in every backend.

(pytest turns warnings into errors, so each test also proves that no RuntimeWarning is emitted.)
The ``sklearn`` profile row (force_finite) belongs to ``validate`` and is tested with the report.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dynval

NORMALISED = ("r2", "fit_percent", "vaf")
INF = math.inf


def metric(name, *args, **kwargs):
    return getattr(dynval, name)(*args, **kwargs)


@pytest.mark.parametrize("name", NORMALISED)
def test_constant_target_not_exact_is_minus_inf(backend, name):
    tau = np.full(6, 0.1)  # the mean of 0.1s is not exactly 0.1: constancy is min == max
    pred = tau + np.array([0.5, -0.5, 0.2, 0.0, 0.1, -0.3])
    assert metric(name, tau, pred, backend=backend) == -INF
    assert metric(name, tau, pred, multioutput="raw_values", backend=backend).tolist() == [-INF]


@pytest.mark.parametrize("name", NORMALISED)
def test_constant_target_exact_is_nan(backend, name):
    tau = np.full(5, 3.7)
    assert math.isnan(metric(name, tau, tau, backend=backend))
    assert np.isnan(metric(name, tau, tau, multioutput="raw_values", backend=backend)).all()


def test_vaf_exact_means_constant_residual(backend):
    # A constant offset: SSE > 0 (r2, fit -inf) but the residual is constant (vaf nan).
    tau = np.full(5, 2.0)
    pred = tau - 0.25
    assert math.isnan(dynval.vaf(tau, pred, backend=backend))
    assert dynval.r2(tau, pred, backend=backend) == -INF
    assert dynval.fit_percent(tau, pred, backend=backend) == -INF


def test_pooled_constant_is_decided_on_all_values(backend):
    # Every joint constant, but different constants: the flattened target is not constant.
    tau = np.column_stack([np.full(4, 1.0), np.full(4, 2.0)])
    pred = tau + 0.1
    assert math.isfinite(dynval.r2(tau, pred, backend=backend))
    assert dynval.r2(tau, pred, multioutput="raw_values", backend=backend).tolist() == [-INF, -INF]


def test_near_constant_target_is_not_constant(backend):
    tau = np.array([1e8, np.nextafter(1e8, 2e8), 1e8])
    value = dynval.r2(tau, np.full(3, 1e8), backend=backend)
    assert math.isfinite(value)


@pytest.mark.parametrize("name", NORMALISED)
def test_uniform_average_is_ieee_mean(backend, name):
    rng = np.random.default_rng(1)
    good = rng.standard_normal(8)
    const = np.full(8, 1.5)
    # joints: ordinary, constant not exact -> -inf
    tau = np.column_stack([good, const])
    pred = np.column_stack([good + 0.1 * rng.standard_normal(8), const + np.linspace(-1, 1, 8)])
    assert metric(name, tau, pred, multioutput="uniform_average", backend=backend) == -INF
    # add a constant exact joint -> nan wins
    tau3 = np.column_stack([tau, const])
    pred3 = np.column_stack([pred, const])
    assert math.isnan(metric(name, tau3, pred3, multioutput="uniform_average", backend=backend))


@pytest.mark.parametrize("name", NORMALISED)
def test_variance_weighted_leaves_out_constant_joints(backend, name):
    rng = np.random.default_rng(2)
    a, b = rng.standard_normal(10), 3.0 * rng.standard_normal(10)
    pa, pb = a + 0.2 * rng.standard_normal(10), b + 0.5 * rng.standard_normal(10)
    const = np.full(10, -4.0)
    with_const = metric(
        name,
        np.column_stack([a, const, b]),
        np.column_stack([pa, const + np.linspace(0, 1, 10), pb]),
        multioutput="variance_weighted",
        backend=backend,
    )
    without = metric(name, np.column_stack([a, b]), np.column_stack([pa, pb]), multioutput="variance_weighted",
                     backend=backend)
    assert with_const == pytest.approx(without, rel=1e-14)
    assert math.isfinite(with_const)


@pytest.mark.parametrize("name", NORMALISED)
def test_variance_weighted_all_constant_is_uniform_average(backend, name):
    const = np.column_stack([np.full(4, 1.0), np.full(4, 2.0)])
    pred = const + np.array([[0.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    # joint 0 exact (nan), joint 1 not exact (-inf): IEEE mean is nan
    assert math.isnan(metric(name, const, pred, multioutput="variance_weighted", backend=backend))
    pred2 = const + np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    assert metric(name, const, pred2, multioutput="variance_weighted", backend=backend) == -INF


def test_zero_sse(backend):
    tau = np.column_stack([np.linspace(0, 1, 7), np.linspace(2, -1, 7)])
    assert dynval.rmse(tau, tau, backend=backend) == 0.0
    assert dynval.rmse(tau, tau, convention="per_sample", backend=backend) == 0.0
    assert dynval.fit_percent(tau, tau, backend=backend) == 100.0
    assert dynval.r2(tau, tau, backend=backend) == 1.0
    assert dynval.vaf(tau, tau, backend=backend) == 100.0
    assert dynval.r2(tau, tau, multioutput="raw_values", backend=backend).tolist() == [1.0, 1.0]
    assert dynval.fit_percent(tau, tau, multioutput="raw_values", backend=backend).tolist() == [100.0, 100.0]


def _assert_degenerate_criteria(ic):
    assert ic.aic == -INF and ic.bic == -INF and ic.aicc == -INF and ic.naic == -INF
    assert ic.fpe == 0.0


def test_criteria_zero_sse_pooled(backend):
    tau = np.linspace(0, 1, 9)
    _assert_degenerate_criteria(dynval.criteria(tau, tau, n_params=2, backend=backend))
    assert dynval.aic(tau, tau, n_params=2, backend=backend) == -INF
    assert dynval.bic(tau, tau, n_params=2, backend=backend) == -INF
    _assert_degenerate_criteria(dynval.information_criteria(0.0, 9, 2, backend=backend))


def test_criteria_one_joint_exact_per_joint(backend):
    tau = np.column_stack([np.linspace(0, 1, 9), np.linspace(1, 0, 9)])
    pred = tau.copy()
    pred[:, 1] += np.linspace(-0.1, 0.1, 9)
    _assert_degenerate_criteria(dynval.criteria(tau, pred, n_params=2, noise_model="per_joint", backend=backend))
    assert math.isfinite(dynval.criteria(tau, pred, n_params=2, noise_model="pooled", backend=backend).aic)


def test_criteria_singular_covariance_full(backend):
    tau = np.zeros((9, 2))
    e = np.linspace(-1, 1, 9) ** 3
    pred = tau - np.column_stack([e, 2.0 * e])  # residual columns linearly dependent: det Σ̂ = 0
    _assert_degenerate_criteria(dynval.criteria(tau, pred, n_params=1, noise_model="full", backend=backend))
    assert math.isfinite(dynval.criteria(tau, pred, n_params=1, noise_model="per_joint", backend=backend).aic)


def test_constant_residual_autocorrelation(backend):
    e = np.column_stack([np.full(12, 0.3), np.sin(np.arange(12.0))])
    rho = dynval.autocorrelation(e, 4, backend=backend)
    assert np.isnan(rho[:, 0]).all()
    assert rho[0, 1] == 1.0 and np.isfinite(rho[:, 1]).all()
    assert np.isnan(dynval.autocorrelation(e, 4, adjusted=False, backend=backend)[:, 0]).all()


@pytest.mark.parametrize("name", ["ljung_box", "box_pierce"])
def test_constant_residual_portmanteau(backend, name):
    e = np.column_stack([np.sin(np.arange(12.0)), np.full(12, -2.0)])
    res = getattr(dynval, name)(e, [2, 3], backend=backend)
    assert np.isnan(res.statistic[:, 1]).all() and np.isnan(res.pvalue[:, 1]).all()
    assert np.isnan(res.log_pvalue[:, 1]).all()
    assert np.isfinite(res.statistic[:, 0]).all()


def test_constant_residual_cross_correlation(backend):
    rng = np.random.default_rng(3)
    e = np.column_stack([rng.standard_normal(20), np.full(20, 1.0)])
    y = rng.standard_normal((20, 2, 3))
    cc = dynval.cross_correlation(e, y, 3, backend=backend)
    assert np.isnan(cc.rho[1]).all()
    assert np.isfinite(cc.rho[0]).all()
    assert not cc.constant_mask.any()


def test_constant_regressor_column(backend):
    rng = np.random.default_rng(4)
    e = rng.standard_normal((20, 2))
    y = rng.standard_normal((20, 2, 3))
    y[:, 1, 2] = 7.0
    cc = dynval.cross_correlation(e, y, 3, backend=backend)
    assert cc.constant_mask.tolist() == [[False, False, False], [False, False, True]]
    assert np.isnan(cc.rho[1, 2]).all()
    assert np.isfinite(np.delete(cc.rho.reshape(6, -1), 5, axis=0)).all()


def test_zero_mean_test_zero_variance(backend):
    e = np.column_stack([np.full(10, 0.5), np.full(10, -0.5), np.zeros(10)])
    res = dynval.zero_mean_test(e, backend=backend)
    assert res.std.tolist() == [0.0, 0.0, 0.0]
    assert res.statistic_iid[:2].tolist() == [INF, -INF]
    assert res.statistic_eff[:2].tolist() == [INF, -INF]
    assert res.pvalue_iid[:2].tolist() == [0.0, 0.0]
    assert res.pvalue_eff[:2].tolist() == [0.0, 0.0]
    assert math.isnan(res.statistic_iid[2]) and math.isnan(res.pvalue_iid[2])
    assert math.isnan(res.statistic_eff[2]) and math.isnan(res.pvalue_eff[2])


def test_full_noise_model_numerically_singular_covariance_agrees_across_backends(backend):
    # Joint 3's residual is joints 1 + 2 up to 1e-10 relative: Σ̂ has λ_min/λ_max ~ 1e-20, far below
    # the m·ε rank tolerance, so the contract calls it singular (AIC = −inf) whatever the backend's
    # rounding. Without the rule numpy's slogdet and Eigen's LDLT disagreed on exactly such data.
    rng = np.random.default_rng(7)
    e = rng.normal(size=(400, 2))
    e = np.column_stack([e, e[:, 0] + e[:, 1] + 1e-10 * rng.normal(size=400)])
    meas = rng.normal(size=e.shape)
    crit = dynval.criteria(meas, meas - e, n_params=3, noise_model="full", backend=backend)
    assert crit.aic == -np.inf and crit.bic == -np.inf and crit.fpe == 0.0
    # Well away from the tolerance, the same data with an independent third column is regular.
    e[:, 2] = rng.normal(size=400)
    crit = dynval.criteria(meas, meas - e, n_params=3, noise_model="full", backend=backend)
    sigma = e.T @ e / 400
    assert crit.aic == pytest.approx(400 * np.linalg.slogdet(sigma)[1] + 6, rel=1e-12)


@pytest.mark.parametrize("noise_model", ["full", "per_joint"])
def test_fpe_is_inf_when_the_noise_size_overflows(backend, noise_model):
    # In-range data (|x| <= 1e144) whose det Σ̂ or Π SSE_j/N exceeds float64: the criteria stay
    # finite (they use logarithms) and fpe is +inf, not an exception (python) or nan.
    rng = np.random.default_rng(0)
    meas = rng.normal(size=(20, 2)) * 1e140
    crit = dynval.criteria(meas, 0.5 * meas, n_params=1, noise_model=noise_model, backend=backend)
    assert crit.fpe == np.inf
    e = 0.5 * meas
    sigma = e.T @ e / 20
    expected_f = 20 * (np.linalg.slogdet(sigma)[1] if noise_model == "full" else np.sum(np.log(np.diag(sigma))))
    assert crit.aic == pytest.approx(expected_f + 2, rel=1e-12)
