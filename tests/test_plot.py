"""dynval.plot: each figure's structure (axes, labels, lines, cells), built from real reports of
the simulated arm, and that every figure renders to PNG."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import dynval
from dynval import plot
from dynval.identify import identify
from dynval.simulate import simulate


def _validate(d, name):
    est, val = d.estimation, d.validation
    res = identify(est.regressors[name], est.tau_meas)
    pred = res.predict(val.regressors[name])
    rep = dynval.validate(val.tau_meas, pred, n_params=res.rank, regressor=val.full_regressor,
                          sample_rate=d.sample_rate, joint_names=list(d.joint_names),
                          column_names=list(d.full_column_names))
    return pred, rep


@pytest.fixture(scope="module")
def flexible():
    d = simulate("flexible", n_samples=1500)
    reports, preds = {}, {}
    for name in d.candidates:
        preds[name], reports[name] = _validate(d, name)
    return d, preds, reports


def _texts(fig):
    out = [fig.get_suptitle()] if hasattr(fig, "get_suptitle") else []
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_title(loc="left"), ax.get_xlabel(), ax.get_ylabel()]
        out += [t.get_text() for t in ax.texts]
        out += [t.get_text() for t in ax.get_xticklabels() + ax.get_yticklabels()]
        leg = ax.get_legend()
        if leg is not None:
            out += [t.get_text() for t in leg.get_texts()]
    for leg in fig.legends:
        out += [t.get_text() for t in leg.get_texts()]
    return "\n".join(out)


def _renders(fig, tmp_path, name):
    path = tmp_path / f"{name}.png"
    plot.save(fig, path)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_residuals_figure(flexible, tmp_path):
    d, preds, _reports = flexible
    fig = plot.residuals(d.validation.tau_meas, preds["friction"], sample_rate=100.0, segments=[500, 1000],
                         joint_names=d.joint_names)
    assert len(fig.axes) == 2
    for j, ax in enumerate(fig.axes):
        assert d.joint_names[j] in ax.get_ylabel() and "N·m" in ax.get_ylabel()
        lines = ax.get_lines()
        assert len(lines[0].get_xdata()) == 1500
        np.testing.assert_allclose(lines[0].get_ydata(), d.validation.tau_meas[:, j] - preds["friction"][:, j])
        # zero line + one boundary at 5 s
        vlines = [ln for ln in lines if np.ptp(ln.get_xdata()) == 0 and ln.get_xdata()[0] == 5.0]
        assert len(vlines) == 1
    assert fig.axes[-1].get_xlabel() == "time (s)"
    assert "segment boundary" in _texts(fig) and "RMS" in _texts(fig)
    _renders(fig, tmp_path, "residuals")


def test_residuals_without_rate_use_samples_and_default_names():
    fig = plot.residuals(np.zeros((50, 3)), np.ones((50, 3)))
    assert fig.axes[-1].get_xlabel() == "sample"
    assert "joint 3" in fig.axes[2].get_ylabel()


def test_autocorrelation_figure(flexible, tmp_path):
    d, _preds, reports = flexible
    rep = reports["friction"]
    fig = plot.autocorrelation(rep)
    main_axes = [ax for ax in fig.axes if ax.get_ylabel()]
    assert len(main_axes) == 2
    lmax = rep.autocorrelation["max_lag"]
    for j, ax in enumerate(main_axes):
        assert d.joint_names[j] in ax.get_ylabel()
        # band drawn as two dashed lines over lags 1..max_lag
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert len(dashed) == 2 and len(dashed[0].get_xdata()) == lmax
        np.testing.assert_allclose(dashed[0].get_ydata(), rep.autocorrelation["band"][1:, j])
        # one stem per lag, split between inside and outside the band
        n_stems = sum(len(c.get_segments()) for c in ax.collections)
        assert n_stems == lmax + 1
    assert main_axes[-1].get_xlabel() == "lag ℓ (samples)"
    text = _texts(fig)
    assert "Ljung–Box" in text and "outside the band" in text
    _renders(fig, tmp_path, "acf")


def test_autocorrelation_seconds_axis_only_with_rate(flexible):
    _d, _preds, reports = flexible
    fig = plot.autocorrelation(reports["friction"])
    top = [c for ax in fig.axes for c in ax.child_axes]
    assert len(top) == 1 and top[0].get_xlabel() == "lag (s)"
    fig2 = plot.autocorrelation(reports["friction"].autocorrelation)  # a bare section: no rate known
    assert not [c for ax in fig2.axes for c in ax.child_axes]


def test_spectrum_marks_the_found_oscillation(flexible, tmp_path):
    d, _preds, reports = flexible
    rep = reports["friction"]
    fig = plot.spectrum(rep, reference=d.mode_frequency, reference_label="simulated mode")
    assert len(fig.axes) == 2
    assert fig.axes[-1].get_xlabel() == "frequency (Hz)"
    for ax in fig.axes:
        markers = [ln for ln in ax.get_lines() if ln.get_marker() == "v"]
        if rep.spectrum is not None and any(f.kind == "oscillation" for f in rep.findings):
            assert markers, "the oscillation finding is not marked"
            for mk in markers:
                assert mk.get_xdata()[0] == pytest.approx(d.mode_frequency, rel=0.1)
        assert "PSD" in ax.get_ylabel()
    assert "simulated mode" in _texts(fig)
    _renders(fig, tmp_path, "spectrum")


def test_spectrum_from_residuals_and_explicit_peaks():
    rng = np.random.default_rng(0)
    t = np.arange(4000) / 100.0
    e = np.column_stack([np.sin(2 * np.pi * 12.0 * t), np.zeros_like(t)]) + rng.normal(0, 0.1, (4000, 2))
    fig = plot.spectrum(residuals=e, sample_rate=100.0, peaks=[(0, 12.0)], joint_names=["a", "b"])
    first = fig.axes[0]
    psd = first.get_lines()[0]
    assert psd.get_xdata()[np.argmax(psd.get_ydata())] == pytest.approx(12.0, abs=0.5)
    assert len([ln for ln in first.get_lines() if ln.get_marker() == "v"]) == 1
    assert not [ln for ln in fig.axes[1].get_lines() if ln.get_marker() == "v"]
    assert "12 Hz" in _texts(fig)


def test_cross_correlation_heatmap(flexible, tmp_path):
    d, _preds, reports = flexible
    rep = reports["rigid"]
    fig = plot.cross_correlation(rep)
    ax = fig.axes[0]
    img = ax.get_images()[0]
    arr = img.get_array()
    assert arr.shape == (2, 12)
    xc = rep.cross_correlation
    # the colour-aware band of the findings: max over lags of |ρ|/sd(ℓ), over the band's z
    from dynval.statistics._stats import z_two_sided

    expected = np.where(np.asarray(xc["constant_mask"]), np.nan, np.asarray(xc["z_max"]) / z_two_sided(xc["level"]))
    np.testing.assert_allclose(np.ma.filled(arr.astype(float), np.nan), expected, equal_nan=True)
    assert [t.get_text() for t in ax.get_xticklabels()] == list(d.full_column_names)
    assert [t.get_text() for t in ax.get_yticklabels()] == list(d.joint_names)
    # every significant cell carries its value
    labelled = sum(1 for t in ax.texts if t.get_text() not in ("–",))
    assert labelled == int(np.sum(expected > 1.0))
    assert "band" in fig.axes[1].get_ylabel()  # colour bar
    # the rigid model misses friction: a Coulomb column stands out on each joint
    assert np.nanargmax(expected[0]) in (6, 7) and np.nanargmax(expected[1]) in (8, 9)
    _renders(fig, tmp_path, "xcorr")


def test_metrics_bars(flexible, tmp_path):
    d, _preds, reports = flexible
    fig = plot.metrics(reports, chosen="friction")
    assert len(fig.axes) == 3
    assert [ax.get_ylabel() for ax in fig.axes] == ["VAF (%)", "fit (%)", "R² (fraction)"]
    for ax, metric in zip(fig.axes, ("vaf", "fit_percent", "r2")):
        bars = ax.patches
        assert len(bars) == 3 * 2  # candidates × joints
        heights = np.array([b.get_height() for b in bars]).reshape(3, 2)
        floor = -100.0 if metric != "r2" else -1.0
        for i, name in enumerate(d.candidates):
            np.testing.assert_allclose(heights[i], np.maximum(reports[name].per_joint[metric], floor))
    assert [t.get_text() for t in fig.axes[-1].get_xticklabels()] == list(d.joint_names)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["rigid", "friction (chosen)", "friction+offset"]
    _renders(fig, tmp_path, "metrics")


def test_metrics_cut_very_negative_bars_and_print_their_value(flexible):
    d, _preds, reports = flexible
    # A candidate predicting zero torque has R² far below -1 on a joint with a large mean.
    meas = d.validation.tau_meas
    bad = dynval.validate(meas, np.zeros_like(meas) + meas.mean(axis=0) + 5 * meas.std(axis=0), n_params=0,
                          joint_names=list(d.joint_names))
    fig = plot.metrics({"good": reports["friction"], "bad": bad})
    r2_ax = fig.axes[2]
    heights = [b.get_height() for b in r2_ax.patches]
    assert min(heights) == -1.0
    printed = [t.get_text() for t in r2_ax.texts]
    assert f"{bad.per_joint['r2'][0]:.3g}" in printed
    assert "cut" in r2_ax.get_title(loc="right")  # the printed values are explained
    assert "perfect" in printed  # and so is the dotted line at the top


def test_prediction_figure(flexible, tmp_path):
    d, preds, reports = flexible
    fig = plot.prediction(d.validation.tau_meas, preds["friction"], report=reports["friction"],
                          model_name="friction", window=(0.0, 5.0))
    assert len(fig.axes) == 2
    for j, ax in enumerate(fig.axes):
        meas, pred = ax.get_lines()[:2]
        assert len(meas.get_xdata()) == 501 and meas.get_xdata()[-1] == pytest.approx(5.0)
        np.testing.assert_allclose(pred.get_ydata(), preds["friction"][:501, j])
        assert "torque (N·m)" in ax.get_ylabel()
    assert "predicted (friction)" in _texts(fig) and "measured" in _texts(fig)
    _renders(fig, tmp_path, "prediction")


def test_wrong_number_of_names_is_an_error():
    with pytest.raises(ValueError, match="joint_names"):
        plot.residuals(np.zeros((10, 2)), np.zeros((10, 2)), joint_names=["only one"])


def test_autocorrelation_by_model(flexible, tmp_path):
    d, _preds, reports = flexible
    fig = plot.autocorrelation_by_model(reports, joint=1, chosen="friction")
    axes = [ax for ax in fig.axes if ax.get_xlabel()]
    assert len(axes) == 3
    assert [ax.get_title().split("\n")[0] for ax in axes] == ["rigid", "friction (chosen)", "friction+offset"]
    assert axes[0].get_ylabel().startswith("elbow")
    assert "10 ms" in axes[0].get_xlabel()
    for ax, name in zip(axes, d.candidates):
        lmax = reports[name].autocorrelation["max_lag"]
        assert sum(len(c.get_segments()) for c in ax.collections) == lmax + 1
        band = next(ln for ln in ax.get_lines() if ln.get_linestyle() == "--")
        np.testing.assert_allclose(band.get_ydata(), reports[name].autocorrelation["band"][1:, 1])
    _renders(fig, tmp_path, "acf_models")


def _colour_aware_beyond(xc):
    """The cells beyond the colour-aware band, from the report's fields alone: |ρ| above z·sd(ℓ)
    at the strongest lag, sd(ℓ) Bartlett's for two coloured series (the findings' rule)."""
    from dynval.statistics._stats import z_two_sided

    z = z_two_sided(float(xc["level"]))
    mask = np.asarray(xc["constant_mask"], dtype=bool)
    with np.errstate(invalid="ignore"):
        return ~mask & (np.asarray(xc["z_max"], dtype=float) > z)


def _white_beyond(xc):
    mask = np.asarray(xc["constant_mask"], dtype=bool)
    return ~mask & (np.asarray(xc["max_abs_rho"], dtype=float) > float(xc["band"]))


def test_spectrum_frequency_axis_is_logarithmic_without_the_zero_bin(flexible):
    _d, _preds, reports = flexible
    rep = reports["friction"]
    fig = plot.spectrum(rep)
    for ax in fig.axes:
        assert ax.get_xscale() == "log"
        psd = ax.get_lines()[0]
        assert np.all(np.asarray(psd.get_xdata()) > 0)
    assert fig.axes[-1].get_xlim()[0] > 0
    # the report's information band is marked
    band = rep.whiteness["information_band"]
    assert band is not None
    assert "information band" in _texts(fig)
    # without a rate: cycles/sample, still logarithmic
    rng = np.random.default_rng(1)
    fig2 = plot.spectrum(residuals=rng.normal(size=(2000, 1)))
    assert fig2.axes[0].get_xscale() == "log" and "cycles/sample" in fig2.axes[0].get_xlabel()


def test_cross_correlation_beyond_cells_are_the_colour_aware_ones(flexible):
    d, _preds, reports = flexible
    # a residual that is coloured (a smooth error) against smooth regressor columns: the white
    # band flags far more cells than the colour-aware one
    val = d.validation
    rng = np.random.default_rng(3)
    smooth = np.cumsum(rng.normal(size=val.tau_meas.shape), axis=0) * 0.02
    rep = dynval.validate(val.tau_meas, val.tau_meas + smooth, n_params=0, regressor=val.full_regressor,
                          sample_rate=d.sample_rate, joint_names=list(d.joint_names),
                          column_names=list(d.full_column_names))
    xc = rep.cross_correlation
    aware, white = _colour_aware_beyond(xc), _white_beyond(xc)
    assert (aware != white).any(), "the example does not tell the two bands apart"
    for r in (rep, reports["rigid"]):
        x = r.cross_correlation
        fig = plot.cross_correlation(r)
        arr = np.ma.filled(fig.axes[0].get_images()[0].get_array().astype(float), np.nan)
        with np.errstate(invalid="ignore"):
            shown = np.isfinite(arr) & (arr > 1.0)
        np.testing.assert_array_equal(shown, _colour_aware_beyond(x))
        # the printed values are exactly on those cells
        printed = {(round(t.get_position()[1]), round(t.get_position()[0])) for t in fig.axes[0].texts
                   if t.get_text() != "–"}
        assert printed == {tuple(int(i) for i in c) for c in np.argwhere(_colour_aware_beyond(x))}
        assert "colour-aware" in _texts(fig)


def test_cross_correlation_without_colour_fields_falls_back_to_white_and_says_so(flexible):
    _d, _preds, reports = flexible
    xc = dict(reports["rigid"].cross_correlation.items())
    for key in ("z_max", "colour_factor"):
        xc.pop(key)
    fig = plot.cross_correlation(xc)
    arr = np.ma.filled(fig.axes[0].get_images()[0].get_array().astype(float), np.nan)
    expected = np.where(np.asarray(xc["constant_mask"]), np.nan, np.asarray(xc["max_abs_rho"]) / xc["band"])
    np.testing.assert_allclose(arr, expected, equal_nan=True)
    assert "white" in fig.legends[0].get_title().get_text()


def test_cross_correlation_legend_explains_every_mark(flexible):
    _d, _preds, reports = flexible
    rep = reports["rigid"]
    fig = plot.cross_correlation(rep)
    assert fig.legends, "the heatmap has no legend"
    text = "\n".join(t.get_text() for t in fig.legends[0].get_texts())
    assert "beyond the per-cell band" in text and "grey" in text and "constant" in text and "finding" in text
    assert "Holm" in text and "significant" in text
    # many columns: the cells significant over the whole report are dots, and the legend says what a dot is
    xc = dict(rep.cross_correlation.items())
    reps = 3
    for key in ("constant_mask", "max_abs_rho", "z_max", "colour_factor", "lag_of_max", "pvalue_adjusted"):
        xc[key] = np.tile(np.asarray(xc[key]), (1, reps))
    fig2 = plot.cross_correlation(xc)
    dots = [ln for ln in fig2.axes[0].get_lines() if ln.get_marker() == "o"]
    significant = np.asarray(xc["pvalue_adjusted"], dtype=float) <= 1 - xc["level"]
    assert len(dots) == int(significant.sum()) > 0
    assert int(significant.sum()) < int(_colour_aware_beyond(xc).sum())  # Holm is stricter than each cell's band
    assert "dot" in "\n".join(t.get_text() for t in fig2.legends[0].get_texts())


def test_cross_correlation_marks_the_cells_the_findings_call_significant(flexible):
    # The report's pvalue_adjusted is each cell's smallest Holm-adjusted p over its lags: a
    # regressor_correlation finding's cell is among the significant ones, at most at its p.
    _d, _preds, reports = flexible
    rep = reports["rigid"]
    padj = np.asarray(rep.cross_correlation["pvalue_adjusted"], dtype=float)
    alpha = 1 - rep.cross_correlation["level"]
    assert padj.shape == np.asarray(rep.cross_correlation["max_abs_rho"]).shape
    assert np.array_equal(np.isnan(padj), np.asarray(rep.cross_correlation["constant_mask"], dtype=bool))
    found = [f for f in rep.findings if f.kind == "regressor_correlation"]
    assert found
    for f in found:
        j, c = f.joints[0], f.columns[0]
        assert padj[j, c] <= f.pvalue_adjusted <= alpha
    fig = plot.cross_correlation(rep)
    starred = {(round(t.get_position()[1]), round(t.get_position()[0])) for t in fig.axes[0].texts
               if t.get_text().endswith("*")}
    beyond = np.asarray(plot.cross_correlation_ratio(rep.cross_correlation)[0]) > 1
    assert starred == {tuple(int(i) for i in c) for c in np.argwhere((padj <= alpha) & beyond)}


def test_every_axes_with_marks_has_a_legend_or_text(flexible):
    d, preds, reports = flexible
    rep = reports["friction"]
    figs = [plot.residuals(d.validation.tau_meas, preds["friction"], sample_rate=100.0, segments=[500, 1000]),
            plot.autocorrelation(rep), plot.autocorrelation_by_model(reports, chosen="friction"),
            plot.spectrum(rep, reference=d.mode_frequency), plot.cross_correlation(reports["rigid"]),
            plot.metrics(reports, chosen="friction"),
            plot.prediction(d.validation.tau_meas, preds["friction"], report=rep)]
    for fig in figs:
        colourbars = {id(ax) for ax in fig.axes if ax.get_label() == "<colorbar>"}
        for ax in fig.axes:
            if id(ax) in colourbars:
                continue
            marks = ax.get_lines() or ax.collections or ax.get_images() or ax.patches
            if not marks:
                continue
            explained = ax.get_legend() is not None or bool(fig.legends)
            assert explained, f"{fig.get_suptitle()!r}: an axes with marks has no legend"


# --------------------------------------------------------------------------- degenerate input, no warning


def _degenerate_reports():
    """An exactly zero residual (an all-nan autocorrelation), a constant regressor column (a nan
    cross-correlation row) and a joint whose metrics are nan."""
    rng = np.random.default_rng(3)
    tau = rng.normal(size=(400, 2))
    y = rng.normal(size=(400, 2, 3))
    y[:, :, 1] = 2.0
    zero = dynval.validate(tau, tau, n_params=1, regressor=y)
    const = np.c_[np.full(400, 1.5), tau[:, 1]]
    flat = dynval.validate(const, const, n_params=1, regressor=y)
    return tau, {"zero": zero, "flat": flat}


def test_figures_of_degenerate_reports_raise_no_warning(tmp_path):
    """An exactly zero residual printed numpy's 'All-NaN slice encountered' from plot.py on standard
    error during dynval validate --html. Every warning is an error here, whatever pytest's setting."""
    from dynval.html import write_report

    tau, reports = _degenerate_reports()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name, report in reports.items():
            figs = [plot.autocorrelation(report), plot.cross_correlation(report), plot.spectrum(report),
                    plot.residuals(tau, tau, report=report), plot.metrics(reports)]
            for i, fig in enumerate(figs):
                _renders(fig, tmp_path, f"{name}{i}")
            write_report(report, tmp_path / f"{name}.html", tau_meas=tau, tau_pred=tau)


def test_the_command_line_writes_nothing_on_standard_error_for_a_zero_residual(tmp_path):
    """The same path through a subprocess, where pytest's filter does not reach: stderr stays empty."""
    np.save(tmp_path / "z.npy", np.zeros(600))
    env = {**os.environ, "PYTHONPATH": str(Path(dynval.__file__).parents[1])}
    p = subprocess.run([sys.executable, "-m", "dynval", "validate", "z.npy", "z.npy", "--n-params", "1",
                        "--html", "r.html"], cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode in (0, 1) and p.stderr == ""
    assert (tmp_path / "r.html").stat().st_size > 0
