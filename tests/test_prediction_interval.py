"""Prediction intervals: the estimation run's noise and Cov(π̂) give each predicted torque a band,
which holds ``level`` of new measurements when the model and its white noise are right."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval.identify import identify

SIGMA = np.array([0.5, 0.05])  # two joints with very different noise


def _run(rng, n, theta):
    y = rng.standard_normal((n, 2, 3)) * [2.0, 1.0, 0.5]
    return y, y @ theta + SIGMA * rng.standard_normal((n, 2))


@pytest.mark.parametrize("weights", [None, "per_joint"])
def test_the_band_holds_its_level_on_a_new_run_for_each_joint(weights):
    rng = np.random.default_rng(11)
    theta = np.array([1.0, -2.0, 0.5])
    y_e, tau_e = _run(rng, 4000, theta)
    fit = identify(y_e, tau_e, weights=weights)
    np.testing.assert_allclose(fit.noise_std, SIGMA, rtol=0.05)  # per joint, not pooled
    y_v, tau_v = _run(rng, 5000, theta)
    for level in (0.8, 0.95):
        share = fit.prediction_interval(y_v, level=level).share_inside(tau_v)
        # 5000 samples per joint: 4 binomial standard errors, and 0.01 for the noise level's own
        # estimation error (about 1 % of σ with 4000 samples)
        assert np.all(np.abs(share - level) < 4 * np.sqrt(level * (1 - level) / 5000) + 0.01), (level, share)
    if weights is None:  # a pooled noise level would be far off on both joints
        pooled = np.sqrt(fit.sigma2)
        assert pooled > 2 * SIGMA[1] and pooled < 0.9 * SIGMA[0]


def test_each_samples_variance_is_noise_plus_parameter_uncertainty():
    rng = np.random.default_rng(3)
    y_e, tau_e = _run(rng, 30, np.array([1.0, 2.0, 3.0]))
    fit = identify(y_e, tau_e)
    y_v = rng.standard_normal((5, 2, 3))
    band = fit.prediction_interval(y_v, level=0.9)
    cov = fit.covariance
    for k in range(5):
        for j in range(2):
            row = y_v[k, j, list(fit.base_columns)]
            want = np.sqrt(fit.noise_std[j] ** 2 + row @ cov @ row)
            assert band.std[k, j] == pytest.approx(want, rel=1e-12)
    q = scipy.stats.t.ppf(0.95, fit.rows - fit.rank)
    assert band.quantile == pytest.approx(q, rel=1e-12)
    np.testing.assert_allclose(band.upper - band.prediction, q * band.std, rtol=1e-12)
    np.testing.assert_allclose(band.prediction, fit.predict(y_v), rtol=0, atol=0)


def test_a_model_that_misses_a_term_shows_it_as_a_low_share_inside():
    rng = np.random.default_rng(5)
    y_e, tau_e = _run(rng, 400, np.array([1.0, -2.0, 0.5]))
    fit = identify(y_e[:, :, :2], tau_e)  # the third term left out
    y_v, tau_v = _run(rng, 2000, np.array([1.0, -2.0, 0.5]))
    assert np.all(fit.prediction_interval(y_v[:, :, :2]).share_inside(tau_v) < 0.95)


def test_bad_levels_and_shapes_are_refused_with_their_value():
    rng = np.random.default_rng(0)
    y, tau = _run(rng, 50, np.array([1.0, 1.0, 1.0]))
    fit = identify(y, tau)
    for bad in (0.0, 1.0, 1.5, float("nan"), "0.9"):
        with pytest.raises(dynval.InvalidParameter, match="level must be a number with 0 < level < 1, got"):
            fit.prediction_interval(y, level=bad)
    with pytest.raises(dynval.ShapeMismatch, match=r"tau_meas must have the prediction's shape \(50, 2\), got"):
        fit.prediction_interval(y).share_inside(tau[:10])
    bad = tau.copy()
    bad[7, 1] = np.nan  # not counted as outside: refused, with its place
    with pytest.raises(dynval.NonFiniteInput, match=r"^tau_meas has a non-finite value \(nan\) at row 7, column 1$"):
        fit.prediction_interval(y).share_inside(bad)


def test_the_prediction_figure_draws_the_band_with_its_share():
    pytest.importorskip("matplotlib")
    from dynval import plot

    rng = np.random.default_rng(1)
    y, tau = _run(rng, 200, np.array([1.0, -2.0, 0.5]))
    fit = identify(y, tau)
    band = fit.prediction_interval(y, level=0.9)
    fig = plot.prediction(tau, band.prediction, interval=band)
    shares = band.share_inside(tau)
    for j, ax in enumerate(fig.axes):
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert f"90 % prediction interval ({100 * shares[j]:.1f} % of the measured inside)" in labels
        assert ax.collections, "no band drawn"


def test_the_html_report_draws_the_band_and_gives_the_share_in_the_caption(tmp_path):
    pytest.importorskip("matplotlib")
    from dynval.html import render_report

    rng = np.random.default_rng(2)
    y, tau = _run(rng, 300, np.array([1.0, -2.0, 0.5]))
    fit = identify(y, tau)
    band = fit.prediction_interval(y, level=0.9)
    rep = dynval.validate(tau, band.prediction, n_params=3)
    page = render_report(rep, tau_meas=tau, tau_pred=band.prediction, interval=band)
    shares = ", ".join(f"{100 * s:.1f} %" for s in band.share_inside(tau))
    assert "Shaded: the 90 % prediction interval" in page and f"per joint: {shares}." in page
    assert "prediction interval" not in render_report(rep, tau_meas=tau, tau_pred=band.prediction)
    # a comparison takes one band per model name, drawn for the chosen one
    cmp = dynval.compare(tau, {"fit": (band.prediction, 3), "zero": (np.zeros_like(tau), 0)})
    page = render_report(cmp, tau_meas=tau, tau_pred={"fit": band.prediction, "zero": np.zeros_like(tau)},
                         interval={"fit": band})
    assert f"per joint: {shares}." in page


def test_the_html_report_refuses_a_band_it_cannot_draw():
    from dynval.html import render_report

    rng = np.random.default_rng(3)
    y, tau = _run(rng, 300, np.array([1.0, -2.0, 0.5]))
    band = identify(y, tau).prediction_interval(y)
    rep = dynval.validate(tau, band.prediction, n_params=3)
    with pytest.raises(TypeError, match=r"interval must be a PredictionInterval .* got ndarray"):
        render_report(rep, tau_meas=tau, tau_pred=band.prediction, interval=band.lower)
    with pytest.raises(ValueError, match="interval needs tau_meas"):
        render_report(rep, interval=band)
    with pytest.raises(ValueError, match=r"interval has shape \(300, 2\), tau_meas \(299, 2\)"):
        render_report(rep, tau_meas=tau[:-1], tau_pred=band.prediction[:-1], interval=band)
