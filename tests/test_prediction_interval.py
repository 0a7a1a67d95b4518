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
    # one legend below the panels names the band; each panel's title gives its joint's share
    assert "90 % prediction interval" in [t.get_text() for t in fig.legends[0].get_texts()]
    for j, ax in enumerate(fig.axes):
        want = f"{100 * shares[j]:.1f} % of the measured torque inside the band (whole run)"
        assert ax.get_title(loc="right") == want
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


# ---------------------------------------------------------------------------- the coverage test

def _demo_band(candidate, seed=0):
    from dynval.simulate import simulate

    d = simulate("friction", seed=seed)
    fit = identify(d.estimation.regressors[candidate], d.estimation.tau_meas)
    return fit.prediction_interval(d.validation.regressors[candidate]), d.validation


def test_the_friction_less_demo_model_fails_the_coverage_test_though_its_share_is_above_the_level():
    band, val = _demo_band("rigid")
    share = band.share_inside(val.tau_meas)
    assert np.all(share > 0.95)  # the overall share cannot show the missing friction
    test = band.coverage_test(val.tau_meas, q=val.q, dq=val.dq)
    assert test.decision == "fail" and not test.passed
    assert np.all(test.rejected) and np.all(test.adjusted < 1e-6), test.adjusted
    assert test.component == ("velocity_sign", "velocity_sign")
    np.testing.assert_array_equal(test.share_inside, share)
    # q alone: the velocity's sign from q's differences
    assert np.all(band.coverage_test(val.tau_meas, q=val.q).adjusted < 1e-6)
    words = str(test)
    assert words.startswith("The 95 % band fails its coverage test (Holm over 2 joint(s) at alpha = 0.05) on joint 0")
    assert "directions of motion" in words and "the share inside cannot show" in words


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_right_demo_model_passes_the_coverage_test_with_a_margin(seed):
    band, val = _demo_band("friction", seed)
    test = band.coverage_test(val.tau_meas, q=val.q, dq=val.dq)
    assert test.passed and test.decision == "pass"
    assert np.all(test.adjusted > 0.4), test.adjusted  # alpha 0.05; the friction-less model's are below 1e-8
    assert str(test) == ("The 95 % band passes its coverage test (Holm over 2 joint(s) at alpha = 0.05): its misses "
                         "do not depend on the state or cluster in time.")


def test_a_kuka_joint_worse_than_a_constant_fails_the_coverage_test():
    pytest.importorskip("pinocchio")
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    runs = {k: load_kuka_lwr4(k) for k in (1, 2)}
    cad = URDFModel(runs[1].urdf)
    rigid = list(range(70))  # the inertial columns only: no friction
    y1 = cad.regressor(runs[1].q, runs[1].dq, runs[1].ddq)[:, :, rigid]
    y2 = cad.regressor(runs[2].q, runs[2].dq, runs[2].ddq)[:, :, rigid]
    band = identify(y1, runs[1].tau).prediction_interval(y2)
    tau = runs[2].tau
    r2 = 1 - ((tau - band.prediction) ** 2).sum(axis=0) / ((tau - tau.mean(axis=0)) ** 2).sum(axis=0)
    share = band.share_inside(tau)
    assert r2[0] < 0 and share[0] > 0.99  # worse than a constant, and nearly all of it inside the band
    test = band.coverage_test(tau, q=runs[2].q, dq=runs[2].dq)
    assert test.rejected[0] and test.decision == "fail", test.adjusted


def test_a_missing_coulomb_term_is_found_by_the_velocity_sign_alone():
    """The missing sign(q̇) term leaves the share at the level and its exceedances unclustered in
    time (the velocity's sign changes from one sample to the next, independently of the posture and
    of the modelled terms): only the residual's mean on each side of the motion shows it."""
    rng = np.random.default_rng(7)

    def run(n, coulomb_column):
        q, dq, ddq = rng.uniform(-2, 2, n), rng.standard_normal(n), rng.standard_normal(n)
        tau = 1.5 * ddq + 4.0 * np.cos(q) + 0.5 * np.sign(dq) + rng.standard_normal(n)
        cols = [ddq, np.cos(q)] + ([np.sign(dq)] if coulomb_column else [])
        return np.stack(cols, axis=1)[:, None, :], tau[:, None], q[:, None], dq[:, None]

    for coulomb_column in (False, True):
        y_e, tau_e, _, _ = run(3000, coulomb_column)
        y_v, tau_v, q_v, dq_v = run(3000, coulomb_column)
        band = identify(y_e, tau_e).prediction_interval(y_v)
        assert abs(band.share_inside(tau_v)[0] - 0.95) < 0.01
        test = band.coverage_test(tau_v, q=q_v, dq=dq_v)
        if coulomb_column:  # the term in the model: nothing left to find
            assert test.passed, test.component_pvalues
            continue
        assert test.rejected[0] and test.component == ("velocity_sign",), test.component_pvalues
        others = test.component_pvalues[0, 1:]
        assert np.all(others > 0.05), others  # posture, prediction and the runs in time see nothing


def test_a_band_built_by_hand_is_tested_without_the_refit():
    from dynval.identify import PredictionInterval

    for candidate, fails in (("rigid", True), ("friction", False)):
        band, val = _demo_band(candidate)
        by_hand = PredictionInterval(prediction=band.prediction, lower=band.lower, upper=band.upper, std=band.std,
                                     level=band.level, quantile=band.quantile, noise_std=band.noise_std)
        assert by_hand.design is None and by_hand == band  # the design is not part of the band's value
        test = by_hand.coverage_test(val.tau_meas, q=val.q, dq=val.dq)
        assert test.passed is not fails, test.component_pvalues


def test_the_coverage_test_result_is_json_ready():
    import json

    band, val = _demo_band("rigid")
    test = band.coverage_test(val.tau_meas, q=val.q, dq=val.dq)
    d = json.loads(json.dumps(test.to_dict(), allow_nan=False))
    assert d["decision"] == "fail" and d["components"] == ["velocity_sign", "posture", "prediction", "runs"]
    assert d["rejected"] == [True, True] and len(d["component_pvalues"]) == 2 and d["summary"] == str(test)
    assert d["level"] == 0.95 and d["alpha"] == 0.05 and d["n_samples"] == 2000


def test_the_coverage_test_refuses_bad_input_with_clear_errors():
    band, val = _demo_band("friction")
    tau, q, dq = val.tau_meas, val.q, val.dq
    shape = r"tau_meas must have the prediction's shape \(2000, 2\), got \(1999, 2\)"
    with pytest.raises(dynval.ShapeMismatch, match=shape):
        band.coverage_test(tau[1:])
    with pytest.raises(dynval.ShapeMismatch,
                       match=r"tau_meas and q must have the same shape, got \(2000, 2\) and \(2000, 3\)"):
        band.coverage_test(tau, q=np.zeros((2000, 3)))
    with pytest.raises(dynval.ShapeMismatch,
                       match=r"tau_meas and dq must have the same shape, got \(2000, 2\) and \(10,\)"):
        band.coverage_test(tau, dq=dq[:10, 0])
    bad = dq.copy()
    bad[3, 1] = np.inf
    with pytest.raises(dynval.NonFiniteInput, match=r"^dq has a non-finite value \(inf\) at row 3, column 1$"):
        band.coverage_test(tau, q=q, dq=bad)
    bad = tau.copy()
    bad[5, 0] = np.nan
    with pytest.raises(dynval.NonFiniteInput, match=r"^tau_meas has a non-finite value \(nan\) at row 5, column 0$"):
        band.coverage_test(bad)
    with pytest.raises(dynval.InvalidType, match="q must be an array of real numbers, got str"):
        band.coverage_test(tau, q="q.npy")
    for value in (1, 21, 4.0, True, "4"):
        with pytest.raises(dynval.InvalidParameter, match="n_bins must be an integer with 2 <= n_bins <= 20, got"):
            band.coverage_test(tau, n_bins=value)
    for value in (0, 1, -0.1, float("nan"), "0.05", None):
        with pytest.raises(dynval.InvalidParameter, match="alpha must be a number with 0 < alpha < 1, got"):
            band.coverage_test(tau, alpha=value)
    with pytest.raises(dynval.TooFewSamples, match="coverage_test needs at least 160 samples, got N=100"):
        band_short = identify(*_run(np.random.default_rng(0), 100, np.ones(3))).prediction_interval(
            np.ones((100, 2, 3)))
        band_short.coverage_test(np.zeros((100, 2)))


def _ar1(rng, shape, phi, sd):
    out = np.empty(shape)
    out[0] = rng.standard_normal(shape[1]) * sd
    w = rng.standard_normal(shape) * sd * np.sqrt(1 - phi**2)
    for k in range(1, shape[0]):
        out[k] = phi * out[k - 1] + w[k]
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_right_model_passes_under_coloured_noise(seed):
    """AR(1) 0.95 noise: the residual and its exceedances are slow, in every state alike; the test
    counts the residual's colour (each bin's long-run variance, the runs of a thinned series)."""
    from dynval.simulate import COLUMN_NAMES, simulate

    d = simulate("friction", seed=seed, noise=0.0)
    truth = np.array([d.true_parameters[c] for c in COLUMN_NAMES])
    cols = [COLUMN_NAMES.index(c) for c in d.column_names["friction"]]
    rng = np.random.default_rng(seed)
    est, val = d.estimation, d.validation
    tau_e = est.full_regressor @ truth + _ar1(rng, est.tau_meas.shape, 0.95, 0.2)
    tau_v = val.full_regressor @ truth + _ar1(rng, val.tau_meas.shape, 0.95, 0.2)
    band = identify(est.full_regressor[:, :, cols], tau_e).prediction_interval(val.full_regressor[:, :, cols])
    test = band.coverage_test(tau_v, q=val.q, dq=val.dq)
    assert test.passed, test.component_pvalues  # with the noise's colour counted as white: p below 1e-3
    assert np.all(test.n_eff < 0.2 * 2000)  # the colour was seen


def test_a_joint_whose_band_has_zero_width_is_not_tested_and_says_so():
    from dynval.identify import PredictionInterval

    band, val = _demo_band("rigid")
    std = band.std.copy()
    std[:, 1] = 0.0  # an exact fit's noise level on joint 1
    flat = PredictionInterval(prediction=band.prediction, lower=band.prediction - band.quantile * std,
                              upper=band.prediction + band.quantile * std, std=std, level=band.level,
                              quantile=band.quantile, noise_std=band.noise_std, design=band.design)
    test = flat.coverage_test(val.tau_meas, q=val.q, dq=val.dq)
    assert np.all(np.isnan(test.component_pvalues[1])) and np.isnan(test.adjusted[1]) and not test.rejected[1]
    assert test.component[1] == "" and test.rejected[0] and test.adjusted[0] == test.pvalue[0]  # a family of one
    assert "(Holm over 1 joint(s)" in str(test) and str(test).endswith("or a band of zero width): joint 1.")


def test_a_missing_term_that_acts_in_short_bursts_is_found_by_the_runs_in_time_alone():
    """Eight bursts of ±3σ over 12 samples each (a contact, say), in both runs: the share stays at the
    level, the residual's mean at zero in every bin of the prediction, the residual nearly white
    (N_eff stays near N, so nothing is thinned away); the exceedances come in clusters."""
    rng = np.random.default_rng(3)

    def run(n):
        y = rng.standard_normal((n, 1, 2))
        tau = y[:, 0] @ np.array([1.0, -0.5]) + rng.standard_normal(n)
        for i, start in enumerate(np.sort(rng.choice(n // 20, 8, replace=False)) * 20):
            tau[start:start + 12] += 3.0 if i % 2 else -3.0
        return y, tau[:, None]

    y_e, tau_e = run(3000)
    y_v, tau_v = run(3000)
    band = identify(y_e, tau_e).prediction_interval(y_v)
    assert abs(band.share_inside(tau_v)[0] - 0.95) < 0.01
    test = band.coverage_test(tau_v)
    assert test.rejected[0] and test.component == ("runs",) and test.adjusted[0] < 1e-10, test.component_pvalues
    assert test.component_pvalues[0, 2] > 0.5 and test.n_eff[0] > 1500  # the prediction's bins see nothing
    assert "the exceedances come in clusters in time" in str(test)
