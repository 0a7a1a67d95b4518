"""Every rule's record: which joints and columns a finding names, its severity, and the numbers it
carries (statistic, p-value, Holm-adjusted p-value, effect, its unit and threshold, details).

The rules are those of docs/conventions.md §5 and contract §4 (finding kinds and their details).
Each test builds an :class:`~dynval.report._findings.Evidence` by hand and states the expected record from
the evidence: raw p-values as given, adjusted ones by statsmodels' Holm over the report's tests,
effects and thresholds by the documented definitions, boundaries on both sides (an effect *at* its
threshold is practical). The message and action must be the wording of exactly the facts the rule
decided on (``dynval.report._finding_words``, whose own wording is tested in test_text/test_findings).
Fast (milliseconds each): ``scripts/mutation.sh`` runs these for every mutant of ``_findings.py``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from statsmodels.stats.multitest import multipletests

from dynval.checks._validation import InvalidParameter
from dynval.report._findings import Evidence, Finding, Thresholds, compute_findings, holm_family, resolve_thresholds
from dynval.report.kinds import bias as bias_kind
from dynval.report.kinds import constant_target as constant_target_kind
from dynval.report.kinds import delay as delay_kind
from dynval.report.kinds import excitation as excitation_kind
from dynval.report.kinds import low_information as low_information_kind
from dynval.report.kinds import missing_physics as physics_kind
from dynval.report.kinds import omitted_rows as omitted_rows_kind
from dynval.report.kinds import oscillation as oscillation_kind
from dynval.report.kinds import periodic_error as periodic_error_kind
from dynval.report.kinds import pooling as pooling_kind
from dynval.report.kinds import predictive_failure as predictive_failure_kind
from dynval.report.kinds import processing_band as processing_band_kind
from dynval.report.kinds import regressor_correlation as rc_kind
from dynval.report.kinds import repeat_trajectory as repeat_trajectory_kind
from dynval.report.kinds import sampling_colour as sampling_colour_kind
from dynval.report.kinds import time_stamps as time_stamps_kind
from dynval.report.kinds import whiteness as whiteness_kind
from dynval.report.kinds import worse_than_constant as worse_than_constant_kind
from dynval.statistics._physics import LABELS
from dynval.statistics._stats import correlation_pvalue

NAMES = ["shoulder", "elbow", "wrist"]


def _ev(m: int = 2, level: float = 0.95, **kw) -> Evidence:
    base = dict(n_samples=1000, level=level, joint_names=NAMES[:m], r2=np.full(m, 0.9), pooled_r2=0.9,
                constant_target=np.zeros(m, bool))
    base.update(kw)
    return Evidence(**base)


def _holm(p: np.ndarray) -> np.ndarray:
    """statsmodels' Holm over the non-NaN entries, NaN kept (the report's one family)."""
    p = np.asarray(p, dtype=float)
    out = np.full(p.shape, np.nan)
    ok = ~np.isnan(p)
    out[ok] = multipletests(p[ok], method="holm")[1]
    return out


def _of(found: list[Finding], kind: str) -> list[Finding]:
    return [f for f in found if f.kind == kind]


def _record(f: Finding) -> dict:
    d = dataclasses.asdict(f)
    del d["message"], d["action"]
    return d


def _worded(f: Finding, words: tuple[str, str]) -> None:
    assert (f.message, f.action) == words


def _blank(**kw) -> dict:
    """A record with every field at its default, overridden by ``kw``."""
    out = {"joints": (), "columns": (), "statistic": None, "pvalue": None, "pvalue_adjusted": None, "effect": None,
           "effect_unit": "", "threshold": None, "details": {}}
    out.update(kw)
    return out


# ---------------------------------------------------------------------------------------- the data

@pytest.mark.parametrize("force", [False, True])
def test_data_notes_omitted_rows_and_constant_joints(force):
    ev = _ev(3, omitted_rows=7, constant_target=np.array([False, True, False]), force_finite=force,
             r2=np.array([0.9, np.nan, 0.9]))
    found = compute_findings(ev)
    (om,) = _of(found, "omitted_rows")
    assert _record(om) == _blank(kind="omitted_rows", severity="note", effect=7.0, effect_unit="rows")
    _worded(om, omitted_rows_kind.words(7))
    (ct,) = _of(found, "constant_target")
    assert _record(ct) == _blank(kind="constant_target", severity="note", joints=(1,))
    _worded(ct, constant_target_kind.words("elbow", force))
    assert not _of(compute_findings(_ev(3)), "omitted_rows") and not _of(compute_findings(_ev(3)), "constant_target")


# ----------------------------------------------------------------------------------------- the fit

def test_worse_than_constant_and_pooling_records_and_their_boundaries():
    # joint 0 worse than a constant; joint 1 exactly 0 (not worse); joint 2 at pooled − 0.05 (no note);
    # joint 3 just below it (a pooling note); joint 4 constant (never judged)
    r2 = np.array([-0.5, 0.0, 0.55, 0.5499, -2.0])
    names = ["a", "b", "c", "d", "e"]
    ev = _ev(5, r2=r2, pooled_r2=0.6, joint_names=names, constant_target=np.array([0, 0, 0, 0, 1], bool))
    found = compute_findings(ev)
    (wc,) = _of(found, "worse_than_constant")
    assert _record(wc) == _blank(kind="worse_than_constant", severity="deficiency", joints=(0,), statistic=-0.5,
                                 effect=0.5, effect_unit="1 − R² beyond 1 (fraction of TSS)", threshold=0.0)
    _worded(wc, worse_than_constant_kind.words("a", -0.5, 0.6))
    pooling = _of(found, "pooling")
    assert [f.joints for f in pooling] == [(1,), (3,)]
    assert _record(pooling[1]) == _blank(kind="pooling", severity="note", joints=(3,), statistic=0.5499,
                                         effect=pytest.approx(0.6 - 0.5499), effect_unit="R² below pooled",
                                         threshold=0.05)
    _worded(pooling[1], pooling_kind.words("d", 0.5499, 0.6))
    # whiteness is a deficiency on a joint worse than a constant: it was found deficient
    ev_w = _ev(2, r2=np.array([-0.5, 0.9]), pooled_r2=0.6, whiteness_lag=5,
               whiteness_pvalue_raw=np.array([1e-6, 1e-6]), whiteness_log_pvalue_raw=np.log([1e-6, 1e-6]))
    assert [f.severity for f in _of(compute_findings(ev_w), "whiteness")] == ["deficiency", "note"]


@pytest.mark.parametrize("pooled, m, hidden", [(0.6, 2, 0.6), (0.0, 2, None), (np.nan, 2, None), (0.6, 1, None)])
def test_worse_than_constant_names_the_pooled_value_only_when_it_looks_good(pooled, m, hidden):
    r2 = np.array([-0.5, 0.9])[:m]
    (wc,) = _of(compute_findings(_ev(m, r2=r2, pooled_r2=pooled)), "worse_than_constant")
    _worded(wc, worse_than_constant_kind.words("shoulder", -0.5, hidden))
    assert not _of(compute_findings(_ev(1, r2=np.array([0.1]), pooled_r2=0.9)), "pooling")  # one joint: no pooling


def test_bias_records_deficiency_at_the_threshold_and_note_below():
    p = np.array([1e-6, 1e-5, 0.5])
    mean, rmse = np.array([0.25, -0.2, 3.0]), np.array([1.0, 1.0, 1.0])
    ev = _ev(3, mean=mean, rmse=rmse, bias_statistic=np.array([5.0, -4.0, 0.1]), bias_pvalue=p,
             n_eff=np.array([400.0, 300.0, 200.0]))
    padj = _holm(p)
    found = _of(compute_findings(ev), "bias")
    assert [f.joints for f in found] == [(0,), (1,)]  # joint 2: not significant
    at, below = found
    assert _record(at) == _blank(kind="bias", severity="deficiency", joints=(0,), statistic=5.0, pvalue=1e-6,
                                 pvalue_adjusted=pytest.approx(padj[0]), effect=0.25, effect_unit="|mean| / RMSE",
                                 threshold=0.25, details={"mean": 0.25, "n_eff": 400.0})
    _worded(at, bias_kind.words("shoulder", 0.25, 0.25, 0.25, 400.0, 1000, padj[0], True, None))
    assert _record(below)["severity"] == "note" and below.statistic == -4.0 and below.effect == pytest.approx(0.2)
    _worded(below, bias_kind.words("elbow", -0.2, 0.2, 0.25, 300.0, 1000, padj[1], False, None))


def test_bias_culprit_named_in_columns_and_words():
    ev = _ev(1, mean=np.array([0.5]), rmse=np.array([1.0]), bias_statistic=np.array([5.0]),
             bias_pvalue=np.array([1e-6]), n_eff=np.array([400.0]), column_names=["a", "b", "c"],
             missing_columns=[1, 2], missing_share=np.array([[0.02, 0.04]]),
             missing_explains_bias=np.array([[True, True]]), missing_statistic=np.array([[0.1, 0.1]]),
             missing_pvalue=np.array([[0.9, 0.9]]))
    (b,) = _of(compute_findings(ev), "bias")
    assert b.columns == (2,)  # the larger share of the two that account for the mean
    _worded(b, bias_kind.words("shoulder", 0.5, 0.5, 0.25, 400.0, 1000, b.pvalue_adjusted, True, ("c", 0.04)))


# ----------------------------------------------------------------------------- the missing terms

def test_missing_term_added_variable_record_orders_columns_by_share():
    p = np.array([[1e-8, 1e-9, 0.5], [0.4, 0.5, 0.6]])
    share = np.array([[0.05, 0.01, 0.2], [0.3, 0.3, 0.3]])
    stat = np.array([[0.2, 0.1, 0.0], [0.0, 0.0, 0.0]])
    ev = _ev(2, column_names=["a", "b", "c", "d"], missing_columns=[1, 2, 3], missing_statistic=stat,
             missing_pvalue=p, missing_share=share, missing_explains_bias=np.zeros((2, 3), bool))
    found = _of(compute_findings(ev), "regressor_correlation")
    (f,) = found  # joint 1: nothing significant
    padj = _holm(p)
    assert _record(f) == _blank(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(1, 2),
                                statistic=0.2, pvalue=1e-8, pvalue_adjusted=pytest.approx(padj[0, 0]), effect=0.05,
                                effect_unit="share of the residual's mean square the term would remove",
                                threshold=0.01, details={"lag": 0, "ρ": 0.2, "added_variable": True,
                                                         "method": "added_variable", "indirect": {}})
    _worded(f, rc_kind.missing_term_words("shoulder", [("b", 0.2, 0.05), ("c", 0.1, 0.01)], False, padj[0, 0], True))


def test_missing_term_below_its_share_is_a_note_naming_every_significant_column():
    p = np.array([[1e-8, 1e-9]])
    ev = _ev(1, column_names=["a", "b", "c"], missing_columns=[1, 2], missing_statistic=np.array([[0.05, 0.04]]),
             missing_pvalue=p, missing_share=np.array([[0.002, 0.009]]),
             missing_explains_bias=np.zeros((1, 2), bool))
    (f,) = _of(compute_findings(ev), "regressor_correlation")
    assert (f.severity, f.columns, f.effect, f.statistic) == ("note", (2, 1), 0.009, 0.04)
    _worded(f, rc_kind.missing_term_words("shoulder", [("c", 0.04, 0.009), ("b", 0.05, 0.002)], False,
                                          f.pvalue_adjusted, False))


def test_missing_term_refit_tests_per_column_and_skips_joints_it_does_not_matter_on():
    p = np.array([1e-8, 0.9])
    share = np.array([[0.2, 0.0], [0.005, 0.0]])
    ev = _ev(2, column_names=["a", "b", "c"], missing_columns=[1, 2], missing_method="estimation_refit",
             missing_statistic=np.array([6.0, 0.1]), missing_pvalue=p, missing_share=share,
             missing_explains_bias=np.zeros((2, 2), bool))
    found = _of(compute_findings(ev), "regressor_correlation")
    assert [f.joints for f in found] == [(0,)]  # joint 1: the column removes too little there
    (f,) = found
    assert f.details == {"lag": 0, "t": 6.0, "added_variable": True, "method": "estimation_refit", "indirect": {}}
    assert (f.statistic, f.pvalue, f.effect, f.columns) == (6.0, 1e-8, 0.2, (1,))
    _worded(f, rc_kind.missing_term_words("shoulder", [("b", 6.0, 0.2)], True, f.pvalue_adjusted, True))


def test_a_joint_whose_missing_term_is_named_is_not_reported_again_for_correlation():
    ev = _ev(1, column_names=["a", "b"], missing_columns=[1], missing_statistic=np.array([[0.3]]),
             missing_pvalue=np.array([[1e-9]]), missing_share=np.array([[0.1]]),
             missing_explains_bias=np.zeros((1, 1), bool),
             xcorr_rho=np.full((1, 2, 1), 0.5), xcorr_sd=np.full((1, 2, 1), 0.03))
    found = _of(compute_findings(ev), "regressor_correlation")
    assert len(found) == 1 and found[0].details["added_variable"] is True
    # below its share the term is a note, and the correlations are reported
    ev.missing_share = np.array([[0.001]])
    assert len(_of(compute_findings(ev), "regressor_correlation")) == 2


# ------------------------------------------------------------------------------ the correlations

def test_regressor_correlation_record_names_the_earliest_lag_near_the_strongest():
    rho = np.zeros((1, 3, 6))
    rho[0, 0] = [0.0, 0.10, 0.30, 0.28, 0.31, 0.0]  # strongest 0.31 at lag 4; 0.30 ≥ 0.9·0.31 at lag 2
    rho[0, 1] = [0.0, 0.0, 0.16, 0.0, 0.0, 0.0]
    rho[0, 2] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.01]
    sd = np.full(rho.shape, 0.02)
    ev = _ev(1, xcorr_rho=rho, xcorr_sd=sd, column_names=["a", "b", "c"], sample_rate=100.0)
    padj = _holm(correlation_pvalue(rho, sd))
    (f,) = _of(compute_findings(ev), "regressor_correlation")
    assert _record(f) == _blank(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(0, 1),
                                statistic=pytest.approx(0.30 / 0.02),
                                pvalue=pytest.approx(float(correlation_pvalue(0.30, 0.02))),
                                pvalue_adjusted=pytest.approx(padj[0, 0, 2]), effect=0.30, effect_unit="|ρ|",
                                threshold=0.15, details={"lag": 2, "rho": 0.30, "n_significant_columns": 2,
                                                                  "in_model": None})
    _worded(f, rc_kind.correlation_words("shoulder", [("a", "lag 2 (20 ms)", 0.30), ("b", "lag 2 (20 ms)", 0.16)],
                                       0.15, 0.30, padj[0, 0, 2], True))


def test_regressor_correlation_below_its_threshold_is_a_note_and_at_it_a_deficiency():
    for size, severity in ((0.15, "deficiency"), (0.1499, "note")):
        rho = np.full((1, 1, 1), size)
        (f,) = _of(compute_findings(_ev(1, xcorr_rho=rho, xcorr_sd=np.full((1, 1, 1), 0.01))),
                   "regressor_correlation")
        assert (f.severity, f.effect, f.details["lag"]) == (severity, size, 0)
        _worded(f, rc_kind.correlation_words("shoulder", [("column 1", "lag 0", size)], 0.15, size,
                                           f.pvalue_adjusted, severity == "deficiency"))
    # negative correlations count by their size; ties between columns go to the lower index
    rho = np.full((1, 2, 1), -0.2)
    (f,) = _of(compute_findings(_ev(1, xcorr_rho=rho, xcorr_sd=np.full((1, 2, 1), 0.01))), "regressor_correlation")
    assert f.columns == (0, 1) and f.effect == 0.2 and f.details["rho"] == -0.2


# ------------------------------------------------------------------------------------ the spectrum

def _spectrum(shares, pvalue=1e-9, bins=21, peak=10, m=1):
    freq = np.arange(bins) * 0.5
    p = np.full((bins, m), np.nan)
    p[peak] = pvalue
    share = np.zeros((bins, m))
    share[peak] = shares
    is_peak = np.zeros((bins, m), bool)
    is_peak[peak] = True
    return dict(spectrum_frequency=freq, spectrum_pvalue=p, spectrum_ratio=np.full((bins, m), 12.0),
                spectrum_share=share, spectrum_is_peak=is_peak, frequency_unit="Hz")


def test_oscillation_record_at_and_below_the_threshold():
    ev = _ev(2, **_spectrum([0.05, 0.0499], m=2))
    found = _of(compute_findings(ev), "oscillation")
    padj = _holm(ev.spectrum_pvalue)
    assert _record(found[0]) == _blank(kind="oscillation", severity="deficiency", joints=(0,), statistic=12.0,
                                       pvalue=1e-9, pvalue_adjusted=pytest.approx(padj[10, 0]), effect=0.05,
                                       effect_unit="share of residual variance", threshold=0.05,
                                       details={"frequency": 5.0, "frequency_unit": "Hz", "n_peaks": 1})
    _worded(found[0], oscillation_kind.words("shoulder", 5.0, "Hz", 0.05, 12.0, padj[10, 0], True))
    assert found[1].severity == "note"
    _worded(found[1], oscillation_kind.words("elbow", 5.0, "Hz", 0.0499, 12.0, padj[10, 1], False))


def test_oscillation_needs_a_local_maximum_and_names_the_largest_share():
    ev = _ev(1, **_spectrum([0.3]))
    ev.spectrum_is_peak = np.zeros_like(ev.spectrum_is_peak)
    assert not _of(compute_findings(ev), "oscillation")
    ev = _ev(1, **_spectrum([0.3]))
    ev.spectrum_pvalue[4, 0], ev.spectrum_share[4, 0], ev.spectrum_is_peak[4, 0] = 1e-9, 0.6, True
    (f,) = _of(compute_findings(ev), "oscillation")
    assert (f.details["frequency"], f.effect, f.details["n_peaks"]) == (2.0, 0.6, 2)


def test_a_peak_above_the_bandwidth_is_a_processing_note():
    ev = _ev(1, bandwidth=4.0, **_spectrum([0.3]))
    found = compute_findings(ev)
    assert not _of(found, "oscillation")
    (f,) = _of(found, "processing_band")
    padj = _holm(ev.spectrum_pvalue)[10, 0]
    assert _record(f) == _blank(kind="processing_band", severity="note", joints=(0,), pvalue=1e-9,
                                pvalue_adjusted=pytest.approx(padj), effect=0.3,
                                effect_unit="share of residual variance", threshold=4.0,
                                details={"evidence": "oscillation", "bandwidth": 4.0, "frequency": 5.0})
    _worded(f, processing_band_kind.words("shoulder", 5.0, 4.0, padj))
    ev.bandwidth = 5.0  # at the bandwidth: still the model's
    assert _of(compute_findings(ev), "oscillation")


# ---------------------------------------------------------------------------------- the whiteness

def _white(raw, dec=None, **kw):
    raw = np.asarray(raw, dtype=float)
    out = dict(whiteness_lag=20, whiteness_pvalue_raw=raw, whiteness_log_pvalue_raw=np.log(raw),
               max_abs_acf=np.linspace(0.3, 0.4, raw.size))
    if dec is not None:
        out.update(whiteness_pvalue_decimated=np.asarray(dec, dtype=float), decimation=4, information_band=0.1)
    out.update(kw)
    return out


def test_whiteness_record_at_the_logged_rate():
    ev = _ev(2, **_white([1e-6, 0.5]))
    (f,) = _of(compute_findings(ev), "whiteness")
    padj = _holm(ev.whiteness_pvalue_raw)
    assert _record(f) == _blank(kind="whiteness", severity="note", joints=(0,), pvalue=1e-6,
                                pvalue_adjusted=pytest.approx(padj[0]), effect=0.3, effect_unit="max |ρ̂(ℓ)|",
                                details={"lag": 20, "decimation": 1})
    _worded(f, whiteness_kind.words("shoulder", False, 20, padj[0], False))
    ev.max_abs_acf = None
    assert _of(compute_findings(ev), "whiteness")[0].effect is None


def test_whiteness_at_the_information_rate_and_sampling_colour():
    # joint 0 coloured at both rates; joint 1 coloured only at the logged rate (sampling colour);
    # joint 2 the same but found deficient (a bias): no sampling note, and no whiteness finding
    ev = _ev(3, **_white([1e-6, 1e-6, 1e-6], [1e-7, 0.5, 0.5]), mean=np.array([0.0, 0.0, 0.9]),
             rmse=np.ones(3), bias_statistic=np.array([0.0, 0.0, 9.0]), bias_pvalue=np.array([0.9, 0.9, 1e-9]),
             n_eff=np.full(3, 500.0))
    found = compute_findings(ev)
    (wh,) = _of(found, "whiteness")
    fam = holm_family(ev)
    padj = fam["whiteness"][1]
    assert (wh.joints, wh.pvalue, wh.severity) == ((0,), 1e-7, "note")
    assert wh.details == {"lag": 20, "decimation": 4}
    _worded(wh, whiteness_kind.words("shoulder", True, 20, padj[0], False))
    (sc,) = _of(found, "sampling_colour")
    assert _record(sc) == _blank(kind="sampling_colour", severity="note", joints=(1,), pvalue=0.5,
                                 pvalue_adjusted=pytest.approx(padj[1]), effect=4.0,
                                 effect_unit="decimation factor",
                                 details={"information_band": 0.1, "frequency_unit": "cycles/sample"})
    _worded(sc, sampling_colour_kind.words("elbow", 0.1, "cycles/sample", 4))
    # the whiteness family is the decimated test when there is one
    np.testing.assert_array_equal(fam["whiteness"][0], [1e-7, 0.5, 0.5])


def test_whiteness_above_the_bandwidth_is_a_processing_note_unless_the_joint_is_deficient():
    ev = _ev(2, whiteness_above_bandwidth=True, bandwidth=10.0, r2=np.array([0.9, -0.5]), pooled_r2=0.5,
             **_white([1e-6, 1e-6]))
    found = compute_findings(ev)
    (pb,) = _of(found, "processing_band")
    padj = _holm(ev.whiteness_pvalue_raw)
    assert _record(pb) == _blank(kind="processing_band", severity="note", joints=(0,), pvalue=1e-6,
                                 pvalue_adjusted=pytest.approx(padj[0]), threshold=10.0, effect_unit=None,
                                 details={"evidence": "whiteness", "bandwidth": 10.0, "frequency": None})
    _worded(pb, processing_band_kind.words("shoulder", None, 10.0, padj[0]))
    (wh,) = _of(found, "whiteness")
    assert (wh.joints, wh.severity) == ((1,), "deficiency")
    _worded(wh, whiteness_kind.words("elbow", False, 20, padj[1], True))


# -------------------------------------------------------------------------------------- the motion

def _library(pvalues, shares, terms, term_shares=None, delay=None, others=None):
    tests = []
    for j, (share, term) in enumerate(zip(shares, terms)):
        ts = share if term_shares is None else term_shares[j]
        group = {term: ts} if term else {}
        group.update((others or {}).get(j, {}))
        tests.append({"statistic": 4.0 + j, "share": share, "term": term, "term_share": ts,
                      "selected": [term] if term else [], "selected_share": share, "shares": group,
                      "n_eff": 300.0 + j})
    out = {"pvalue": np.asarray(pvalues, dtype=float), "tests": tests, "method": "library", "derivatives": "given"}
    if delay is not None:
        out["delay"] = delay
    return out


def _advice(effect: float) -> dict:
    """The advice a library test without a refit or the model's columns gives the words."""
    return {"refit_run": None, "effect": effect, "relation": None, "column_names": None,
            "derivatives": "Savitzky–Golay derivatives of q on both runs (0.1 s window, degree 4)"}


def test_missing_physics_record_needs_both_shares_at_the_threshold():
    lib = _library([1e-9, 1e-9, 1e-9, 0.9], [0.05, 0.2, 0.0499, 0.5], ["coulomb", "viscous", "offset", "drift"],
                   term_shares=[0.05, 0.04, 0.0499, 0.5], others={0: {"viscous": 0.02, "offset": 0.005}})
    found = _of(compute_findings(_ev(4, joint_names=["a", "b", "c", "d"], physics=lib,
                                     r2=np.full(4, 0.9))), "missing_physics")
    assert [(f.joints, f.severity) for f in found] == [((0,), "deficiency"), ((1,), "note"), ((2,), "note")]
    padj = _holm(lib["pvalue"])
    assert _record(found[0]) == _blank(
        kind="missing_physics", severity="deficiency", joints=(0,), statistic=4.0, pvalue=1e-9,
        pvalue_adjusted=pytest.approx(padj[0]), effect=0.05,
        effect_unit="share of the joint's mean square the physical terms remove", threshold=0.05,
        details={"term": "coulomb", "label": LABELS["coulomb"], "term_share": 0.05, "selected_share": 0.05,
                 "selected": ["coulomb"], "shares": {"coulomb": 0.05, "viscous": 0.02, "offset": 0.005},
                 "n_eff": 300.0, "method": "library", "derivatives": "given",
                 # issue 34: how the share was measured and the term relative to the model's columns
                 # (unknown here: the evidence has no relation)
                 "refit_run": None, "effect_out_of_sample": 0.05, "heldout_share": None, "carried_share": None,
                 "relation": None, "model_terms": None, "derivative_source": None})
    # the other groups that remove at least 1 % are named with it, largest first
    _worded(found[0], physics_kind.words("a", LABELS["coulomb"], [LABELS["viscous"]], 0.05, 0.05, 0.05, padj[0],
                                         True, _advice(0.05)))
    _worded(found[1], physics_kind.words("b", LABELS["viscous"], [], 0.2, 0.04, 0.2, padj[1], False,
                                         _advice(0.04)))


def test_missing_physics_without_a_term_names_nothing():
    lib = _library([1e-9], [0.3], [None])
    assert not _of(compute_findings(_ev(1, physics=lib)), "missing_physics")


def test_delay_record_and_when_it_explains_the_structure():
    delay = {"share": np.array([0.3, 0.04, 0.3]), "pvalue": np.array([1e-9, 1e-9, 1e-9]), "shift_samples": 3.0}
    # joint 0: realigning removes more than the library → a delay, not a missing term; joint 1:
    # realigning removes more too, but below the delay threshold → neither; joint 2: the library
    # removes more → a missing term
    lib = _library([1e-9, 1e-9, 1e-9], [0.2, 0.01, 0.5], ["viscous", "viscous", "coulomb"], delay=delay)
    found = compute_findings(_ev(3, physics=lib, sample_rate=200.0, r2=np.full(3, 0.9)))
    (d,) = _of(found, "delay")
    fam = holm_family(_ev(3, physics=lib))
    padj = fam["delay"][1]
    assert _record(d) == _blank(kind="delay", severity="deficiency", joints=(0,), statistic=3.0, pvalue=1e-9,
                                pvalue_adjusted=pytest.approx(padj[0]), effect=0.3,
                                effect_unit="share of the joint's mean square realigning removes", threshold=0.05,
                                details={"delay_s": 0.015, "delay_samples": 3.0, "share": [0.3, 0.04, 0.3],
                                         "phase_deg": None, "band_edge": None, "band_unit": "Hz",
                                         "significant": [0, 1, 2], "explains": [0, 1]})
    _worded(d, delay_kind.words(3.0, 200.0, [("shoulder", 0.3)], padj[0]))
    assert [f.joints for f in _of(found, "missing_physics")] == [(2,)]
    assert not _of(compute_findings(_ev(3, physics=lib)), "delay")[0].details["delay_s"]  # no rate: None


def test_delay_equal_to_the_library_share_is_the_delay():
    delay = {"share": np.array([0.2]), "pvalue": np.array([1e-9]), "shift_samples": -2.0}
    lib = _library([1e-9], [0.2], ["viscous"], delay=delay)
    found = compute_findings(_ev(1, physics=lib))
    assert _of(found, "delay") and not _of(found, "missing_physics")
    (dl,) = _of(found, "delay")
    _worded(dl, delay_kind.words(-2.0, None, [("shoulder", 0.2)], dl.pvalue_adjusted))
    lib["tests"][0]["share"] = math.nan  # no library share: realigning alone decides
    assert _of(compute_findings(_ev(1, physics=lib)), "delay")


def test_predictive_failure_record_at_the_ratio():
    pred = {"ratio": np.array([2.0, 1.99, 5.0]), "pvalue": np.array([1e-9, 1e-9, 0.9]),
            "expected_mse": np.array([1.0, 1.0, 1.0]), "validation_mse": np.array([2.0, 1.99, 5.0])}
    found = _of(compute_findings(_ev(3, predictive=pred)), "predictive_failure")
    padj = _holm(pred["pvalue"])
    (f,) = found
    assert _record(f) == _blank(kind="predictive_failure", severity="deficiency", joints=(0,), statistic=2.0,
                                pvalue=1e-9, pvalue_adjusted=pytest.approx(padj[0]), effect=2.0,
                                effect_unit="validation mean square / what the estimation run allows",
                                threshold=2.0, details={"expected_mse": 1.0, "validation_mse": 2.0})
    _worded(f, predictive_failure_kind.words("shoulder", 2.0, padj[0]))


def test_periodic_error_record_at_and_below_the_threshold():
    per = {"pvalue": np.array([1e-9, 1e-9, 0.9]), "effect_net": np.array([0.05, 0.0499, 0.9]),
           "statistic": np.array([7.0, 6.0, 1.0]), "n_periods": 5, "period": {"seconds": 2.0, "samples": 200},
           "noise_variance": np.array([0.1, 0.2, 0.3]), "model_columns_removed": True}
    found = _of(compute_findings(_ev(3, periodic=per)), "periodic_error")
    padj = _holm(per["pvalue"])
    assert [f.severity for f in found] == ["deficiency", "note"]
    assert _record(found[0]) == _blank(kind="periodic_error", severity="deficiency", joints=(0,), statistic=7.0,
                                       pvalue=1e-9, pvalue_adjusted=pytest.approx(padj[0]), effect=0.05,
                                       effect_unit="share of the residual's variance common to every period",
                                       threshold=0.05, details={"n_periods": 5, "period": per["period"],
                                                                "noise_variance": 0.1,
                                                                "model_columns_removed": True})
    _worded(found[0], periodic_error_kind.words("shoulder", 0.05, 5, per["period"], padj[0], True))
    _worded(found[1], periodic_error_kind.words("elbow", 0.0499, 5, per["period"], padj[1], False))
    del per["model_columns_removed"]
    assert _of(compute_findings(_ev(3, periodic=per)), "periodic_error")[0].details["model_columns_removed"] is False


def test_motion_deficiencies_make_whiteness_a_deficiency():
    per = {"pvalue": np.array([1e-9, 0.9]), "effect_net": np.array([0.5, 0.5]), "statistic": np.array([7.0, 1.0]),
           "n_periods": 5, "period": {"seconds": None, "samples": 200}, "noise_variance": np.array([0.1, 0.1])}
    ev = _ev(2, periodic=per, **_white([1e-6, 1e-6]))
    assert [(f.joints, f.severity) for f in _of(compute_findings(ev), "whiteness")] == [
        ((0,), "deficiency"), ((1,), "note")]


# --------------------------------------------------------------------------- the Holm family

def test_every_test_of_the_report_is_in_one_holm_family():
    ev = _ev(1, bias_pvalue=np.array([0.01]), mean=np.array([0.0]), rmse=np.array([1.0]),
             bias_statistic=np.array([1.0]), n_eff=np.array([100.0]), **_white([0.02]),
             xcorr_rho=np.full((1, 1, 2), 0.1), xcorr_sd=np.full((1, 1, 2), 0.05),
             missing_columns=[0], missing_statistic=np.array([[0.1]]), missing_pvalue=np.array([[0.03]]),
             missing_share=np.array([[0.0]]), missing_explains_bias=np.zeros((1, 1), bool),
             physics=_library([0.04], [0.0], [None], delay={"share": np.array([0.0]), "pvalue": np.array([0.05]),
                                                            "shift_samples": 0.0}),
             predictive={"ratio": np.array([1.0]), "pvalue": np.array([0.06])},
             periodic={"pvalue": np.array([0.07])}, **_spectrum([0.0], pvalue=0.08))
    fam = holm_family(ev)
    families = ["bias", "whiteness", "spectrum", "xcorr", "missing", "physics", "delay", "predictive", "periodic"]
    assert [k for k in fam if k != "_count"] == families
    flat = np.concatenate([np.ravel(fam[k][0]) for k in families])
    assert fam["_count"] == int(np.sum(~np.isnan(flat))) == 10
    np.testing.assert_allclose(np.concatenate([np.ravel(fam[k][1]) for k in families]), _holm(flat))
    assert holm_family(_ev(1))["_count"] == 0


# ------------------------------------------------------------------------------- the thresholds

def test_thresholds_resolve_and_refuse_with_the_contracts_words():
    assert resolve_thresholds(None) == Thresholds()
    th = Thresholds(bias=0.5)
    assert resolve_thresholds(th) is th
    got = resolve_thresholds({"bias": 1, "delay": 0.0})
    assert got == Thresholds(bias=1.0, delay=0.0) and isinstance(got.bias, float)
    with pytest.raises(InvalidParameter) as e:
        resolve_thresholds({"bais": 0.3})
    assert str(e.value).startswith("thresholds must be a mapping with keys among 'bias', 'condition_number', ")
    assert "got {'bais': 0.3}" in str(e.value)
    for bad in (-0.1, math.nan, math.inf, True, "0.3", None):
        with pytest.raises(InvalidParameter, match=r"thresholds\['bias'\] must be a finite number >= 0, got"):
            resolve_thresholds({"bias": bad})
    with pytest.raises(InvalidParameter, match="thresholds must be None, a mapping or a Thresholds, got"):
        resolve_thresholds([("bias", 0.3)])


def test_the_default_thresholds_are_the_documented_ones():
    # the fields of Thresholds; a kind's module documents the thresholds it declares (its own tests)
    th = Thresholds()
    assert {f.name: getattr(th, f.name) for f in dataclasses.fields(th) if f.name != "declared"} == {
        "bias": 0.25, "regressor_correlation": 0.15, "missing_term": 0.01, "oscillation": 0.05,
        "missing_physics": 0.05, "delay": 0.05, "delay_phase": 10.0, "predictive_ratio": 2.0, "periodic_error": 0.05,
        "joint_motion": 0.1, "detectable_share": 0.25, "repeat_distance": 0.1, "repeat_share": 0.5,
        "repeat_tolerance": 0.1, "condition_number": 1e3}


# -------------------------------------------------------------------------------------- the design

def test_repeat_by_state_record_above_the_share_only():
    rep = {"share": 0.8, "state": "q", "tolerance": 0.2, "method": "nearest"}
    (f,) = _of(compute_findings(_ev(1, repeat=rep)), "repeat_trajectory")
    assert _record(f) == _blank(kind="repeat_trajectory", severity="design", effect=0.8,
                                effect_unit="share of the validation run near the estimation trajectory (q)",
                                threshold=0.5, details=rep)
    _worded(f, repeat_trajectory_kind.words_by_state(0.8, 0.5, "q", 0.2))
    assert not _of(compute_findings(_ev(1, repeat={**rep, "share": 0.5})), "repeat_trajectory")  # not above
    (f,) = _of(compute_findings(_ev(1, repeat={"share": 0.6, "state": "regressor"})), "repeat_trajectory")
    _worded(f, repeat_trajectory_kind.words_by_state(0.6, 0.5, "regressor", 0.1))  # the default tolerance


def test_repeat_by_distance_record_below_the_distance_or_as_decided():
    rep = {"share": None, "distance": 0.05, "measure": "tau"}
    (f,) = _of(compute_findings(_ev(1, repeat=rep)), "repeat_trajectory")
    assert _record(f) == _blank(kind="repeat_trajectory", severity="design", effect=0.05,
                                effect_unit="relative distance (tau)", threshold=0.1, details=rep)
    _worded(f, repeat_trajectory_kind.words_by_distance(0.05, 0.1, "tau"))
    assert not _of(compute_findings(_ev(1, repeat={**rep, "distance": 0.1})), "repeat_trajectory")
    assert not _of(compute_findings(_ev(1, repeat={**rep, "distance": None})), "repeat_trajectory")
    # the section's own decision wins over the threshold
    assert _of(compute_findings(_ev(1, repeat={**rep, "distance": 0.5, "is_repeat": True})), "repeat_trajectory")
    assert not _of(compute_findings(_ev(1, repeat={**rep, "is_repeat": False})), "repeat_trajectory")


def _excitation(**kw):
    out = {"column_norms": [1.0, 1.0, 1.0, 1.0], "unexcited": [], "unidentifiable": [], "condition_scaled": 10.0}
    out.update(kw)
    return out


def test_excitation_records_structural_unexcited_and_ill_conditioned():
    cols = ["a", "b", "c", "d"]
    x = _excitation(structural=[3], identifiable_rank=3, identifiable_columns=[0, 1, 2], unexcited=[1],
                    inseparable=[2])
    found = _of(compute_findings(_ev(1, excitation=x, column_names=cols)), "excitation")
    note, design = found[-1], found[0]  # design findings sort before notes
    assert _record(note) == _blank(kind="excitation", severity="note", columns=(3,), effect=1.0,
                                   effect_unit="structural columns",
                                   details={"structural": [3], "identifiable_rank": 3,
                                            "identifiable_columns": [0, 1, 2]})
    _worded(note, excitation_kind.structural_columns(cols, [3], 4, 3))
    assert _record(design) == _blank(kind="excitation", severity="design", columns=(1, 2), effect=2.0,
                                     effect_unit="columns", details=x)
    _worded(design, excitation_kind.unexcited_columns(cols, [1], [2], "estimation"))
    # without the estimation run's regressor the structure is unknown
    (f,) = _of(compute_findings(_ev(1, excitation=_excitation(unexcited=[0]))), "excitation")
    _worded(f, excitation_kind.unexcited_columns(None, [0], [], None))
    # ill-conditioned only above the threshold, and over the reduced combinations when reduced
    x = _excitation(condition_scaled=1000.5, structural=[3], identifiable_rank=3, validation_rank=3)
    found = _of(compute_findings(_ev(1, excitation=x)), "excitation")
    (ill,) = [f for f in found if f.severity == "design"]
    assert _record(ill) == _blank(kind="excitation", severity="design", effect=1000.5,
                                  effect_unit="column-scaled condition number", threshold=1000.0, details=x)
    _worded(ill, excitation_kind.ill_conditioned(1000.5, 1000.0, True, 3))
    (ill,) = _of(compute_findings(_ev(1, excitation=_excitation(condition_scaled=2e3))), "excitation")
    _worded(ill, excitation_kind.ill_conditioned(2e3, 1e3, False, None))
    assert not _of(compute_findings(_ev(1, excitation=_excitation(condition_scaled=1e3))), "excitation")


def test_joint_and_column_motion_records_below_the_threshold():
    ev = _ev(2, joint_motion_ratio=np.array([0.0999, 0.1]),
             excitation=_excitation(column_motion_ratio=[0.05, 0.5, 0.02, 0.01], unexcited=[], unidentifiable=[3],
                                    inseparable=[]))
    found = _of(compute_findings(ev), "excitation")
    joint = [f for f in found if f.joints]
    (j,) = joint
    assert _record(j) == _blank(kind="excitation", severity="design", joints=(0,), effect=0.0999,
                                effect_unit="joint motion (RMS) relative to the estimation run", threshold=0.1,
                                details={"joint_motion_ratio": 0.0999})
    _worded(j, excitation_kind.joint_motion("shoulder", 0.0999, 0.1))
    (c,) = [f for f in found if f.columns]
    assert _record(c) == _blank(kind="excitation", severity="design", columns=(0, 2), effect=0.02,
                                effect_unit="column RMS relative to the estimation run", threshold=0.1,
                                details={"column_motion_ratio": {0: 0.05, 2: 0.02}})
    _worded(c, excitation_kind.column_motion([("column 1", 0.05), ("column 3", 0.02)], 0.1))
    # columns already reported as unexcited, inseparable or structural are not repeated
    ev.excitation = _excitation(column_motion_ratio=[0.05, 0.5, 0.02, 0.01], unexcited=[0], unidentifiable=[3],
                                inseparable=[2], structural=[1])
    assert not [f for f in _of(compute_findings(ev), "excitation")
                if f.effect_unit == "column RMS relative to the estimation run"]


def test_low_information_record_on_undecided_joints_only():
    design = dict(detectable_share=np.array([0.3, 0.25, 0.6]), noise_n_eff=np.array([40.0, 50.0, 8.0]))
    # joint 2 is found deficient (worse than a constant): the run did decide there
    ev = _ev(3, r2=np.array([0.9, 0.9, -0.5]), pooled_r2=0.8, **design)
    (f,) = _of(compute_findings(ev), "low_information")
    assert _record(f) == _blank(kind="low_information", severity="design", joints=(0,), effect=0.3,
                                effect_unit="smallest detectable share of the mean square (90 % power)",
                                threshold=0.25, details={"detectable_share": [0.3, 0.25, 0.6],
                                                         "noise_n_eff": [40.0, 50.0, 8.0], "unresolved": []})
    _worded(f, low_information_kind.words([("shoulder", 40.0, 0.3, None)], 0.25))
    assert not _of(compute_findings(_ev(1, detectable_share=np.array([0.25]), noise_n_eff=np.array([9.0]))),
                   "low_information")


def test_low_information_on_a_joint_whose_named_term_removes_less_than_the_run_detects():
    lib = _library([1e-9, 1e-9], [0.2, 0.7], ["coulomb", "viscous"])
    ev = _ev(2, physics=lib, detectable_share=np.array([0.5, 0.5]), noise_n_eff=np.array([20.0, 20.0]))
    found = compute_findings(ev)
    (f,) = _of(found, "low_information")
    assert f.joints == (0,) and f.effect == 0.5 and f.details["unresolved"] == [0]
    _worded(f, low_information_kind.words([("shoulder", 20.0, 0.5, [(LABELS["coulomb"], 0.2, None)])], 0.25))


def test_low_information_on_a_joint_whose_named_term_another_kind_removes_nearly_as_well():
    """A velocity-squared drag named at 35 % where viscous friction removes 29 % in the same refit and
    the run detects only 33 %: a term is missing, which one this run cannot tell. Kills: the rival
    ignored (the joint counted as decided), the named term taken as its own rival (every joint
    unresolved), the difference compared the wrong way round, the farthest rival taken for the
    closest, and a rival beyond the detectable share counted (the joint decided there)."""
    from dynval.report.kinds.low_information import rival as _rival
    from dynval.report.kinds.low_information import unresolved as _unresolved

    def ev_with(refit: dict[str, float]):
        lib = _library([1e-9], [0.6], ["velocity_squared"], term_shares=[0.35])
        lib["tests"][0].update(refit_run="estimation", refit_shares={"velocity_squared": 0.35, **refit})
        return _ev(1, physics=lib, detectable_share=np.array([0.33]), noise_n_eff=np.array([26.0]))

    close = ev_with({"viscous": 0.29, "coulomb": 0.07})
    (f,) = _of(compute_findings(close), "low_information")
    assert f.joints == (0,) and f.details["unresolved"] == [0]
    _worded(f, low_information_kind.words(
        [("shoulder", 26.0, 0.33, [(LABELS["velocity_squared"], 0.35, (LABELS["viscous"], 0.29))])], 0.25))
    far = ev_with({"viscous": 0.01, "coulomb": -0.05})
    assert not _of(compute_findings(far), "low_information")
    (phys,) = _of(compute_findings(far), "missing_physics")
    assert _rival(far, phys, 0.35, 0.33) is None
    assert _rival(close, phys, 0.35, 0.33) == (LABELS["viscous"], 0.29)
    assert _rival(close, phys, 0.35, 0.05) is None  # a run that detects 5 % tells 35 % from 29 %
    assert _rival(ev_with({}), phys, 0.35, 0.33) is None  # no other kind in the refit
    # the closest rival by share, not by name; at exactly the detectable share apart the two are told apart;
    # a term exactly at the detectable share is detected, so a close rival leaves it unresolved
    by_share = ev_with({"viscous": 0.05, "coulomb": 0.29})
    assert _rival(by_share, phys, 0.35, 0.33) == (LABELS["coulomb"], 0.29)
    assert _rival(ev_with({"viscous": 0.25}), phys, 0.5, 0.25) is None
    assert _rival(ev_with({"viscous": 0.25}), phys, 0.5, 0.2500001) == (LABELS["viscous"], 0.25)
    at_s = dataclasses.replace(phys, details={**phys.details, "term_share": 0.33})
    assert _unresolved(close, [at_s], {0}) == {0: [(LABELS["velocity_squared"], 0.33, (LABELS["viscous"], 0.29))]}
    # only a physical term of a test the report holds has rivals
    assert _rival(_ev(1, detectable_share=np.array([0.33])), phys, 0.35, 0.33) is None
    assert _rival(close, dataclasses.replace(phys, joints=()), 0.35, 0.33) is None
    small = dataclasses.replace(phys, details={**phys.details, "term_share": 0.2})
    assert _unresolved(close, [small], {0}) == {0: [(LABELS["velocity_squared"], 0.2, None)]}
    assert _unresolved(close, [phys], {0}) == {0: [(LABELS["velocity_squared"], 0.35, (LABELS["viscous"], 0.29))]}


def test_low_information_words_name_each_joints_case():
    """The message and action as a user reads them, written out by hand: an untested joint, a term
    below what the run detects and two kinds whose shares differ by less. Kills: a share printed
    off by a factor, the rival's name or share swapped, the closing sentence given where no joint
    was found deficient or left out where one was, the joints' separator or the action changed."""
    message, action = low_information_kind.words(
        [("base", 2.4, 0.884, None), ("shoulder", 23.0, 0.41, [("a drift over the run", 0.07, None)]),
         ("elbow", 9.0, 0.64, [("a posture term", 0.65, ("Coulomb friction", 0.3))])], 0.25)
    assert message == (
        "This run cannot decide: its noise leaves so few effective samples that a missing term must remove more "
        "than 25 % of the mean square to be found (base: N_eff = 2, 88 %; shoulder: N_eff = 23, 41 % — found "
        "deficient, but a drift over the run removes 7 %, less; elbow: N_eff = 9, 64 % — found deficient, but a "
        "posture term 65 % and Coulomb friction 30 % differ by less). On a joint found deficient, which term is "
        "missing this run cannot tell.")
    assert action == "validate on a longer or faster-varying run (more effective samples)"
    plain, _ = low_information_kind.words([("base", 2.4, 0.884, None)], 0.25)
    assert plain.endswith("(base: N_eff = 2, 88 %).")


def test_a_named_term_is_a_physical_term_or_a_refitted_column():
    from dynval.report.kinds.low_information import named_term as _named_term
    from dynval.report.kinds.low_information import unresolved as _unresolved

    ev = _ev(1, column_names=["a", "b"], detectable_share=np.array([0.3]), noise_n_eff=np.array([20.0]))
    phys = Finding(kind="missing_physics", severity="deficiency", joints=(0,),
                   details={"term": "offset", "label": "a torque offset", "term_share": 0.1})
    assert _named_term(ev, phys) == ("a torque offset", 0.1)
    assert _named_term(ev, dataclasses.replace(phys, details={"term": "offset", "term_share": 0.1})) == ("offset", 0.1)
    assert math.isnan(_named_term(ev, dataclasses.replace(phys, details={"term": "drift"}))[1])
    col = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(1,), effect=0.2,
                  details={"added_variable": True})
    assert _named_term(ev, col) == ("b", 0.2)
    assert _named_term(ev, dataclasses.replace(col, columns=())) == ("a column", 0.2)
    assert _named_term(ev, dataclasses.replace(col, details={"lag": 2})) is None  # a plain correlation
    assert _named_term(ev, dataclasses.replace(col, effect=None)) is None
    assert _named_term(ev, Finding(kind="bias", severity="deficiency", joints=(0,), effect=0.5)) is None
    # a note does not count, a term at the detectable share resolves, several terms are all listed
    note = dataclasses.replace(col, severity="note")
    assert _unresolved(ev, [note], {0}) == {}
    assert _unresolved(ev, [dataclasses.replace(col, effect=0.3)], {0}) == {}
    two = [col, dataclasses.replace(phys, details={"label": "drift", "term_share": 0.05})]
    assert _unresolved(ev, two, {0}) == {0: [("b", 0.2, None), ("drift", 0.05, None)]}
    assert _unresolved(_ev(1), [col], {0}) == {}  # no detectable share: nothing to compare with


def test_time_stamps_note_counts_the_irregular_steps():
    t = {"regular": False, "nominal_step": 0.001, "n_steps": 999, "duplicated_stamps": 2, "repeated_rows": 1,
         "gaps": 3, "largest_gap": 0.01, "largest_gap_time": 0.5, "irregular_steps": 5, "jitter_rms": 1e-5,
         "largest_step_deviation": 2e-4, "grid": "the nominal step between gaps"}
    (f,) = _of(compute_findings(_ev(1, timing=t)), "time_stamps")
    assert _record(f) == _blank(kind="time_stamps", severity="note", effect=10.0, effect_unit="irregular steps",
                                details=t)
    _worded(f, time_stamps_kind.words(t))
    assert not _of(compute_findings(_ev(1, timing={**t, "regular": True})), "time_stamps")


# ------------------------------------------------------------------- boundaries and joint order

def _rule_evidence(rule: str, p: np.ndarray) -> dict:
    """Evidence of one rule family with the p-values ``p`` (one per joint) and effects far above
    the thresholds (every joint would be a deficiency if significant)."""
    m = p.size
    if rule == "bias":
        return dict(mean=np.full(m, 0.9), rmse=np.ones(m), bias_statistic=np.full(m, 9.0), bias_pvalue=p,
                    n_eff=np.full(m, 400.0))
    if rule == "missing_term":
        return dict(column_names=["a", "b"], missing_columns=[1], missing_statistic=np.full((m, 1), 0.3),
                    missing_pvalue=p[:, None], missing_share=np.full((m, 1), 0.3),
                    missing_explains_bias=np.zeros((m, 1), bool))
    if rule == "regressor_correlation":
        return dict(xcorr_rho=np.full((m, 1, 1), 0.5), xcorr_sd=np.full((m, 1, 1), 0.5 / 2.0))
    if rule == "oscillation":
        spec = _spectrum([0.3] * m, m=m)
        spec["spectrum_pvalue"][10] = p
        return spec
    if rule == "whiteness":
        return _white(p)
    if rule == "missing_physics":
        return dict(physics=_library(p, [0.3] * m, ["coulomb"] * m))
    if rule == "delay":
        lib = _library(np.full(m, np.nan), [0.01] * m, [None] * m,
                       delay={"share": np.full(m, 0.3), "pvalue": p, "shift_samples": 2.0})
        return dict(physics=lib)
    if rule == "predictive_failure":
        return dict(predictive={"ratio": np.full(m, 5.0), "pvalue": p, "expected_mse": np.ones(m),
                                "validation_mse": np.full(m, 5.0)})
    assert rule == "periodic_error"
    return dict(periodic={"pvalue": p, "effect_net": np.full(m, 0.5), "statistic": np.full(m, 5.0), "n_periods": 3,
                          "period": {"seconds": 1.0, "samples": 100}, "noise_variance": np.ones(m)})


_KIND = {"missing_term": "regressor_correlation"}
_RULE_NAMES = ["bias", "missing_term", "regressor_correlation", "oscillation", "whiteness", "missing_physics",
               "delay", "predictive_failure", "periodic_error"]


@pytest.mark.parametrize("rule", _RULE_NAMES)
def test_a_p_value_exactly_at_alpha_is_significant(rule):
    """p ≤ α, not p < α: one test in the report (Holm leaves it as it is) at exactly α = 1 − level."""
    level = 0.9
    alpha = 1.0 - level
    if rule == "regressor_correlation":  # the test's p comes from ρ and its sd: set the level from it
        ev = _ev(1, level=level, **_rule_evidence(rule, np.array([np.nan])))
        alpha = float(correlation_pvalue(0.5, 0.25))
        ev.level = 1.0 - alpha
        alpha = 1.0 - ev.level
        assert float(correlation_pvalue(0.5, 0.25)) <= alpha
    else:
        ev = _ev(1, level=level, **_rule_evidence(rule, np.array([alpha])))
    assert _of(compute_findings(ev), _KIND.get(rule, rule)), rule


@pytest.mark.parametrize("rule", [r for r in _RULE_NAMES if r != "regressor_correlation"])
def test_a_joint_that_is_not_significant_does_not_stop_the_next(rule):
    """Every joint is judged: the first not significant, the second found (``continue``, not ``break``)."""
    ev = _ev(2, **_rule_evidence(rule, np.array([0.9, 1e-9])))
    found = _of(compute_findings(ev), _KIND.get(rule, rule))
    assert [f.joints for f in found] == [(1,)], rule
    # and a deficient joint makes its whiteness a deficiency (the rule marks the joint it found)
    if rule not in ("whiteness",):
        ev = _ev(2, **_rule_evidence(rule, np.array([0.9, 1e-9])), **{k: v for k, v in _white([1e-6, 1e-6]).items()
                                                                        if rule != "whiteness"})
        severities = sorted((f.joints, f.severity) for f in _of(compute_findings(ev), "whiteness"))
        assert severities == [((0,), "note"), ((1,), "deficiency")], rule


def test_a_correlated_joint_after_a_clean_one_is_found_and_marked_deficient():
    rho = np.zeros((2, 1, 1))
    rho[1] = 0.5
    ev = _ev(2, xcorr_rho=rho, xcorr_sd=np.full((2, 1, 1), 0.05), **_white([1e-6, 1e-6]))
    found = compute_findings(ev)
    assert [f.joints for f in _of(found, "regressor_correlation")] == [(1,)]
    assert sorted((f.joints, f.severity) for f in _of(found, "whiteness")) == [((0,), "note"), ((1,), "deficiency")]


def test_pooling_boundary_and_two_joints():
    pooled = 0.6
    r2 = np.array([0.9, pooled - 0.05])  # exactly at pooled − 0.05: not "well below"
    assert not _of(compute_findings(_ev(2, r2=r2, pooled_r2=pooled)), "pooling")
    r2 = np.array([0.9, np.nextafter(pooled - 0.05, 0.0)])
    assert [f.joints for f in _of(compute_findings(_ev(2, r2=r2, pooled_r2=pooled)), "pooling")] == [(1,)]


def test_correlation_ties_go_to_the_lower_column_and_lags_to_the_earliest_near_the_strongest():
    rho = np.zeros((1, 2, 3))
    rho[0, 0, 2] = 0.4  # column 0 at lag 2
    rho[0, 1, 1] = 0.4  # column 1 at lag 1: the same size; the lower column comes first
    (f,) = _of(compute_findings(_ev(1, xcorr_rho=rho, xcorr_sd=np.full(rho.shape, 0.02))), "regressor_correlation")
    assert f.columns == (0, 1) and f.details["lag"] == 2
    rho = np.zeros((1, 1, 4))
    rho[0, 0, 3] = 0.4
    rho[0, 0, 1] = 0.9 * 0.4  # the same product the rule forms
    (f,) = _of(compute_findings(_ev(1, xcorr_rho=rho, xcorr_sd=np.full(rho.shape, 0.02))), "regressor_correlation")
    assert f.details["lag"] == 1  # at 0.9 of the strongest counts as near it


def test_missing_terms_sort_nan_shares_last_and_every_joint_is_judged():
    p = np.array([[0.9, 0.9], [1e-9, 1e-9]])
    share = np.array([[0.3, 0.3], [np.nan, 0.2]])
    ev = _ev(2, column_names=["a", "b", "c"], missing_columns=[1, 2], missing_statistic=np.full((2, 2), 0.2),
             missing_pvalue=p, missing_share=share, missing_explains_bias=np.zeros((2, 2), bool))
    (f,) = _of(compute_findings(ev), "regressor_correlation")
    assert f.joints == (1,) and f.columns == (2,) and f.effect == 0.2
    # the refit: a column that matters on no joint is skipped there, the next joint still judged
    ev = _ev(2, column_names=["a", "b", "c"], missing_columns=[1, 2], missing_method="estimation_refit",
             missing_statistic=np.array([5.0, 5.0]), missing_pvalue=np.array([1e-9, 1e-9]),
             missing_share=np.array([[0.001, 0.001], [0.2, 0.001]]), missing_explains_bias=np.zeros((2, 2), bool))
    assert [f.joints for f in _of(compute_findings(ev), "regressor_correlation")] == [(1,)]


def test_missing_physics_names_the_other_groups_by_share_from_one_percent():
    lib = _library([1e-9], [0.3], ["coulomb"], others={0: {"offset": 0.01, "viscous": 0.05, "drift": 0.0099}})
    (f,) = _of(compute_findings(_ev(1, physics=lib)), "missing_physics")
    _worded(f, physics_kind.words("shoulder", LABELS["coulomb"], [LABELS["viscous"], LABELS["offset"]], 0.3, 0.3,
                                  0.3, f.pvalue_adjusted, True, _advice(0.3)))
    del lib["tests"][0]["selected_share"]  # without a selection, the term's own share is what it removes
    lib["tests"][0]["term_share"] = 0.2
    (f,) = _of(compute_findings(_ev(1, physics=lib)), "missing_physics")
    assert f.details["selected_share"] == 0.2


def test_a_delay_names_the_joint_it_removes_most_from_and_its_threshold_is_inclusive():
    delay = {"share": np.array([0.05, 0.3]), "pvalue": np.array([1e-9, 1e-8]), "shift_samples": 2.0}
    lib = _library([np.nan, np.nan], [0.0, 0.0], [None, None], delay=delay)
    (f,) = _of(compute_findings(_ev(2, physics=lib)), "delay")
    assert f.joints == (0, 1) and f.effect == 0.3 and f.pvalue == 1e-8  # the strongest joint's test


def test_predictive_and_motion_deficiencies_reach_the_whiteness_of_their_joints():
    pred = {"ratio": np.array([1.0, 5.0]), "pvalue": np.array([0.9, 1e-9]), "expected_mse": np.ones(2),
            "validation_mse": np.array([1.0, 5.0])}
    per = {"pvalue": np.array([1e-9, 0.9]), "effect_net": np.array([0.5, 0.5]), "statistic": np.array([5.0, 1.0]),
           "n_periods": 3, "period": {"seconds": 1.0, "samples": 100}, "noise_variance": np.ones(2)}
    ev = _ev(2, predictive=pred, periodic=per, **_white([1e-6, 1e-6]))
    assert sorted((f.joints, f.severity) for f in _of(compute_findings(ev), "whiteness")) == [
        ((0,), "deficiency"), ((1,), "deficiency")]


def test_column_motion_threshold_is_strict_and_structural_columns_are_skipped():
    x = _excitation(column_motion_ratio=[0.1, 0.05, 0.05, 0.5], unexcited=[], unidentifiable=[], inseparable=[],
                    structural=[2])
    found = [f for f in _of(compute_findings(_ev(1, excitation=x, column_names=["a", "b", "c", "d"])), "excitation")
             if f.effect_unit == "column RMS relative to the estimation run"]
    (f,) = found
    assert f.columns == (1,)
    _worded(f, excitation_kind.column_motion([("b", 0.05)], 0.1))


def test_thresholds_errors_name_the_bad_value():
    with pytest.raises(InvalidParameter, match=r"got -0\.5$"):
        resolve_thresholds({"bias": -0.5})
    with pytest.raises(InvalidParameter, match=r"got 7$"):
        resolve_thresholds(7)


def test_only_whiteness_is_set_aside_when_asking_what_a_joint_names():
    from dynval.report.kinds.low_information import unresolved as _unresolved

    ev = _ev(1, detectable_share=np.array([0.5]), noise_n_eff=np.array([9.0]))
    white = Finding(kind="whiteness", severity="deficiency", joints=(0,), effect=0.9)
    # whiteness alone names nothing: the joint is not unresolved by it (and nothing else is named)
    assert _unresolved(ev, [white], {0}) == {}
    osc = Finding(kind="oscillation", severity="deficiency", joints=(0,), effect=0.3)
    assert _unresolved(ev, [osc], {0}) == {}  # an oscillation is not a named term: resolved


def test_the_largest_peak_is_named_wherever_it_lies_and_a_processing_note_does_not_stop_the_next_joint():
    ev = _ev(1, **_spectrum([0.3]))
    ev.spectrum_pvalue[16, 0], ev.spectrum_share[16, 0], ev.spectrum_is_peak[16, 0] = 1e-9, 0.6, True
    (f,) = _of(compute_findings(ev), "oscillation")
    assert f.details["frequency"] == 8.0 and f.effect == 0.6  # the later, larger peak
    ev = _ev(2, bandwidth=4.0, **_spectrum([0.3, 0.3], m=2))
    ev.spectrum_frequency = ev.spectrum_frequency.copy()
    ev.spectrum_is_peak[10, 0] = True
    ev.spectrum_pvalue[10, 1] = np.nan  # joint 1: its peak at 3 Hz, below the bandwidth
    ev.spectrum_pvalue[6, 1], ev.spectrum_share[6, 1], ev.spectrum_is_peak[6, 1] = 1e-9, 0.3, True
    found = compute_findings(ev)
    assert [f.joints for f in _of(found, "processing_band")] == [(0,)]
    assert [f.joints for f in _of(found, "oscillation")] == [(1,)]


def test_a_joint_without_a_named_physical_term_does_not_stop_the_next():
    lib = _library([1e-9, 1e-9], [0.3, 0.3], [None, "viscous"])
    assert [f.joints for f in _of(compute_findings(_ev(2, physics=lib)), "missing_physics")] == [(1,)]


def test_a_delay_is_tested_at_the_joint_realigning_helps_most_even_if_it_comes_first():
    delay = {"share": np.array([0.3, 0.05]), "pvalue": np.array([1e-8, 1e-9]), "shift_samples": 2.0}
    lib = _library([np.nan, np.nan], [0.0, 0.0], [None, None], delay=delay)
    (f,) = _of(compute_findings(_ev(2, physics=lib)), "delay")
    assert f.effect == 0.3 and f.pvalue == 1e-8


def test_sampling_colour_at_alpha_exactly():
    level = 0.9
    alpha = 1.0 - level
    ev = _ev(1, level=level, **_white([alpha], [0.5]))
    assert _of(compute_findings(ev), "sampling_colour")  # raw p = α rejects; decimated does not


def test_whiteness_does_not_resolve_a_joint_whose_named_term_is_below_what_the_run_detects():
    from dynval.report.kinds.low_information import unresolved as _unresolved

    ev = _ev(1, column_names=["a", "b"], detectable_share=np.array([0.5]), noise_n_eff=np.array([9.0]))
    col = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(1,), effect=0.2,
                  details={"added_variable": True})
    white = Finding(kind="whiteness", severity="deficiency", joints=(0,), effect=0.9)
    assert _unresolved(ev, [col, white], {0}) == {0: [("b", 0.2, None)]}


def test_missing_terms_below_their_share_list_a_nan_share_last():
    p = np.array([[1e-9, 1e-9]])
    ev = _ev(1, column_names=["a", "b", "c"], missing_columns=[1, 2], missing_statistic=np.full((1, 2), 0.1),
             missing_pvalue=p, missing_share=np.array([[np.nan, 0.005]]), missing_explains_bias=np.zeros((1, 2), bool))
    (f,) = _of(compute_findings(ev), "regressor_correlation")
    assert f.severity == "note" and f.columns == (2, 1)
