"""IdentificationResult.summary(), coefficients() and to_frame(): the statistician's first table.

The white-noise columns are checked against statsmodels' OLS (an independent implementation); the
colour-robust standard errors against the spread of estimates over simulated replicates.
"""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval.identify import identify


def _ar1(rng, n, phi, sd=1.0):
    w = rng.normal(scale=sd, size=n)
    e = np.empty(n)
    e[0] = w[0] / np.sqrt(1 - phi**2)
    for k in range(1, n):
        e[k] = phi * e[k - 1] + w[k]
    return e


def _design(n):
    t = np.linspace(0.0, 20.0, n)
    return np.column_stack([np.ones(n), np.sin(t), np.cos(0.37 * t)])


def test_white_noise_columns_equal_statsmodels_ols():
    sm = pytest.importorskip("statsmodels.api")
    rng = np.random.default_rng(3)
    x = _design(400)
    y = x @ [1.0, 2.0, -0.5] + rng.normal(scale=0.3, size=400)
    fit = identify(x, y)
    c = fit.coefficients(std="white", level=0.9)
    ols = sm.OLS(y, x).fit()
    np.testing.assert_allclose(c["estimate"], ols.params, rtol=1e-10)
    np.testing.assert_allclose(c["std_err"], ols.bse, rtol=1e-10)
    np.testing.assert_allclose(c["t"], ols.tvalues, rtol=1e-10)
    np.testing.assert_allclose(c["pvalue"], ols.pvalues, rtol=1e-8, atol=1e-300)
    np.testing.assert_allclose(np.column_stack([c["lower"], c["upper"]]), ols.conf_int(alpha=0.1), rtol=1e-10)
    assert c["std_kind"] == "white"


def test_colour_robust_standard_errors_match_the_spread_of_estimates_under_ar1_noise():
    rng = np.random.default_rng(7)
    n, phi = 2000, 0.9
    x = _design(n)
    estimates, colour, white = [], [], []
    for _ in range(150):
        fit = identify(x, x @ [1.0, 2.0, -0.5] + _ar1(rng, n, phi))
        estimates.append(fit.estimate)
        colour.append(fit.colour_std)
        white.append(fit.std)
    spread = np.std(estimates, axis=0, ddof=1)
    # the white-noise errors are far too small (about √((1+φ)/(1−φ)) = 4.4 × for the mean), the
    # colour-robust ones within the Monte Carlo and bandwidth error of the truth
    assert np.all(np.mean(white, axis=0) < 0.5 * spread)
    np.testing.assert_allclose(np.mean(colour, axis=0), spread, rtol=0.3)


def test_colour_robust_errors_are_close_to_the_white_ones_under_white_noise():
    rng = np.random.default_rng(11)
    x = _design(3000)
    fit = identify(x, x @ [1.0, 2.0, -0.5] + rng.normal(size=3000))
    assert not fit.coloured()
    np.testing.assert_allclose(fit.colour_std, fit.std, rtol=0.2)
    assert fit.coefficients()["std_kind"] == "white"


def test_summary_says_which_standard_errors_it_uses():
    rng = np.random.default_rng(5)
    x = _design(3000)
    coloured = identify(x, x @ [1.0, 2.0, -0.5] + _ar1(rng, 3000, 0.95), column_names=["a", "b", "c"])
    assert coloured.coloured()
    text = coloured.summary()
    assert "The residual is coloured" in text and "Newey–West" in text
    c = coloured.coefficients()
    assert c["std_kind"] == "colour"
    np.testing.assert_allclose(c["std_err"], coloured.colour_std)
    for name, est in zip(c["name"], c["estimate"]):
        assert name in text and f"{est:.5g}" in text
    assert "assume white noise and are too small (std=\"auto\"" in coloured.summary(std="white")
    white_c = coloured.coefficients(std="white")
    np.testing.assert_allclose(white_c["std_err"], coloured.std)


def test_summary_notes_the_base_parameters():
    x = np.arange(8.0)
    fit = identify(np.column_stack([np.ones(8), x, 2 * x]), 1.0 + 3.0 * x + 0.01 * np.cos(x),
                   column_names=["a", "b", "c"])
    assert "1 of the 3 columns are zero or combinations" in fit.summary()
    assert "b + 2*c" in fit.summary()


def test_to_frame_and_reprs_show_values():
    pytest.importorskip("pandas")
    rng = np.random.default_rng(2)
    x = _design(200)
    fit = identify(x, x @ [1.0, 2.0, -0.5] + rng.normal(scale=0.1, size=200), column_names=["a", "b", "c"])
    frame = fit.to_frame()
    assert list(frame.index) == ["a", "b", "c"]
    assert list(frame.columns) == ["estimate", "std_err", "t", "pvalue", "lower", "upper"]
    np.testing.assert_allclose(frame["estimate"], fit.estimate)
    assert "rank=3 of 3" in repr(fit) and "array(" not in repr(fit)
    assert "<table>" in fit._repr_html_() and f"{fit.estimate[1]:.4g}" in fit._repr_html_()


@pytest.mark.parametrize("bad", ["colour!", None, 3])
def test_bad_std_kind_is_refused_with_its_value(bad):
    x = _design(50)
    fit = identify(x, x @ [1.0, 2.0, -0.5] + np.cos(np.arange(50.0)))
    with pytest.raises(dynval.InvalidParameter, match="std"):
        fit.coefficients(std=bad)
