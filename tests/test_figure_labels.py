"""What a figure says about its own axes agrees with the report: the stretch of the run shown,
the lags and rates of the whiteness finding, the share inside a band, and labels that do not sit on
one another."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import dynval
from dynval import plot
from dynval.simulate import simulate


@pytest.fixture(scope="module")
def friction():
    d = simulate("friction", seed=0)
    est, val = d.estimation, d.validation
    rigid = dynval.identify(est.full_regressor[:, :, :6], est.tau_meas)
    full = dynval.identify(est.full_regressor, est.tau_meas)
    pred = rigid.predict(val.full_regressor[:, :, :6])
    report = dynval.validate(val.tau_meas, pred, n_params=rigid.rank, sample_rate=d.sample_rate,
                             joint_names=list(d.joint_names))
    return d, pred, report, full.prediction_interval(val.full_regressor), full.predict(val.full_regressor)


def test_a_zoomed_prediction_says_which_stretch_of_the_run_it_shows(friction):
    d, pred, report, _band, _ = friction
    n = d.validation.tau_meas.shape[0]
    total = n / d.sample_rate
    fig = plot.prediction(d.validation.tau_meas, pred, report=report, window=(0.0, total / 2))
    assert f"0–{total / 2:.3g} s of {total:.3g} s shown" in fig.get_suptitle()
    whole = plot.prediction(d.validation.tau_meas, pred, report=report)
    assert "shown" not in whole.get_suptitle()  # nothing to say when the whole run is drawn


def test_the_prediction_legend_stands_outside_the_data_and_the_band_share_is_the_whole_runs(friction):
    d, _pred, report, band, full_pred = friction
    meas = d.validation.tau_meas
    fig = plot.prediction(meas, full_pred, report=report, window=(0.0, 5.0), interval=band)
    assert all(ax.get_legend() is None for ax in fig.axes) and len(fig.legends) == 1
    inside = ((meas >= band.lower) & (meas <= band.upper)).mean(axis=0)  # over every sample
    for j, ax in enumerate(fig.axes):
        assert f"{100 * inside[j]:.1f} % of the measured torque inside the band (whole run)" in ax.get_title(
            loc="right")


def test_the_autocorrelation_figure_explains_the_whiteness_findings_lags(friction):
    _d, _pred, report, _band, _ = friction
    wh = report.whiteness
    assert wh.decimation > 1  # the rigid model's residual is slow: tested at the information rate
    fig = plot.autocorrelation(report)
    lmax = report.autocorrelation["rho"].shape[0] - 1
    assert fig.axes[0].get_xlim()[1] == pytest.approx(lmax + 0.5)
    title = fig.get_suptitle()
    assert f"every {wh.decimation}th sample" in title
    assert f"up to its lag {wh.lag_decimated} = {wh.lag_decimated * wh.decimation} samples here" in title
    assert f"{report.provenance.sample_rate / wh.decimation:.3g} Hz" in title


def test_the_autocorrelation_figure_names_the_findings_own_largest_lag_when_it_differs():
    rng = np.random.default_rng(1)
    tau = rng.normal(size=(3000, 2))
    pred = tau + 0.1 * rng.normal(size=tau.shape)
    # lags from the motion's band (3 here), while the whiteness finding's Ljung–Box runs to its own lag
    report = dynval.validate(tau, pred, n_params=2, sample_rate=100.0)
    lmax, lag = report.autocorrelation["rho"].shape[0] - 1, report.whiteness.lag
    assert (report.whiteness.decimation, lag != lmax) == (1, True)
    assert f"runs to lag {lag} ({lag / 100.0:.3g} s), this figure to lag {lmax}" in plot.autocorrelation(
        report).get_suptitle()
    same = dynval.validate(tau, pred, n_params=2, max_lag=12, sample_rate=100.0)
    assert same.whiteness.lag == 12 and "\n" not in plot.autocorrelation(same).get_suptitle()


def _bbox(fig, artist):
    return artist.get_window_extent(renderer=fig.canvas.get_renderer())


def test_the_perfect_label_and_the_note_on_cut_bars_stand_apart(friction):
    d, _pred, report, _band, _ = friction
    meas = d.validation.tau_meas
    bad = dynval.validate(meas, np.zeros_like(meas) + meas.mean(axis=0) + 5 * meas.std(axis=0), n_params=0,
                          joint_names=list(d.joint_names))
    fig = plot.metrics({"rigid": report, "bad": bad})
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()
    for ax in fig.axes:
        perfect = [t for t in ax.texts if t.get_text() == "perfect"]
        note = ax._right_title  # matplotlib's artist of the right-hand title: the note on cut bars
        if not perfect or not note.get_text():
            continue
        # stacked one above the other, the two read as one sentence ("… printed on them perfect"):
        # they must not share a horizontal stretch
        a, b = _bbox(fig, perfect[0]), _bbox(fig, note)
        assert a.x1 < b.x0 or b.x1 < a.x0, ax.get_ylabel()
