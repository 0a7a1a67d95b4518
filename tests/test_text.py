"""dynval.report._text: every p-value is written one way in every text, and an effect printed next to its
threshold reads on the side of it that the rule found (contract §4)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import dynval
from dynval.comparison._reasons import finding_reason
from dynval.report import _text
from dynval.report._findings import Finding
from dynval.report._text import P_FLOOR, p_clause, pvalue_text, versus

TINY = 5e-310  # subnormal: below the smallest normal double (2.2e-308)


# ---- the p-value formatter ------------------------------------------------------------------

@pytest.mark.parametrize(("p", "text"), [
    (0.012345, "0.0123"), (0.05, "0.05"), (0.5, "0.5"), (0.98765, "0.988"), (1.0, "1"),
    (0.00012345, "0.000123"), (4.5678e-7, "4.57e-7"), (1.5e-45, "1.5e-45"), (2.7e-299, "2.7e-299"),
    (1e-300, "1e-300"), (np.float64(0.012345), "0.0123"), (np.float32(0.25), "0.25"),
])
def test_float_range_three_significant_digits(p, text):
    assert pvalue_text(p) == text
    assert p_clause(p) == "= " + text


@pytest.mark.parametrize("p", [9.99e-301, 1e-305, TINY, 5e-324, 0.0, np.float64(0.0)])
def test_below_the_floor_and_underflow_read_less_than_1e_300(p):
    assert pvalue_text(p) == "< 1e-300"
    assert p_clause(p) == "< 1e-300"


def test_subnormal_with_its_log_reads_less_than_1e_300():
    assert pvalue_text(TINY, math.log(TINY)) == "< 1e-300"


def test_exact_zero_with_a_finite_log_is_written_from_the_log():
    # the report's Ljung–Box p of a strongly coloured residual: 0 with log p ≈ −1.0e5
    assert pvalue_text(0.0, -101463.46) == "< 1e-300"
    # a log above the floor gives the value (exp(−600) = 2.65e-261): the log is read, not ignored
    assert pvalue_text(0.0, -600.0) == "2.65e-261"
    assert p_clause(0.0, -600.0) == "= 2.65e-261"
    # just below the floor by its log
    assert pvalue_text(0.0, math.log(10.0) * -300.5) == "< 1e-300"
    assert pvalue_text(0.0, -math.inf) == "< 1e-300"


def test_a_p_known_only_by_its_log():
    assert pvalue_text(None, math.log(0.0123)) == "0.0123"
    assert pvalue_text(math.nan, math.log(4.56e-7)) == "4.56e-7"
    assert pvalue_text(None, -1e6) == "< 1e-300"


def test_a_p_in_the_float_range_wins_over_its_log():
    assert pvalue_text(0.5, -1000.0) == "0.5"
    assert pvalue_text(1e-300, -1000.0) == "1e-300"


@pytest.mark.parametrize(("p", "log_p"), [(math.nan, None), (None, None), (math.nan, math.nan),
                                          (None, math.nan), (np.float64("nan"), None), (math.inf, None),
                                          (-0.5, None)])
def test_nan_and_nonsense_read_n_a(p, log_p):
    assert pvalue_text(p, log_p) == "n/a"
    assert p_clause(p, log_p) == "= n/a"


def test_p_and_its_log_give_the_same_text_over_the_whole_range():
    for p in np.logspace(-320, 0, 997):
        p = float(p)
        lp = math.log(p) if p > 0 else -math.inf
        assert pvalue_text(p) == pvalue_text(p, lp), p
        if p >= 1e-299:
            assert pvalue_text(None, lp) == pvalue_text(p), p
        text = pvalue_text(p)
        if text.startswith("<"):
            assert p < P_FLOOR
        else:
            assert float(text) == pytest.approx(p, rel=5e-3)
            assert "e-0" not in text and "e+" not in text  # 1.23e-5, never 1.23e-05


def test_plot_annotation_uses_the_same_wording():
    from dynval import plot

    assert plot._p_text(0.0, -101463.46) == "p < 1e-300"
    assert plot._p_text(0.0123, math.log(0.0123)) == "p = 0.0123"
    assert plot._p_text(math.nan, math.nan) == "p = n/a"  # was "p = 1"


def test_findings_p_text_words():
    from dynval.report._finding_words import p_text as _p_text

    # three significant digits, exponents without padding, the float64 floor said as a bound, and a
    # missing p-value said as such (never "p = 0" or "p = nan")
    expected = {0.0123: "= 0.0123", 4.56e-7: "= 4.56e-7", 1e-301: "< 1e-300", 0.0: "< 1e-300",
                math.nan: "= n/a", None: "= n/a", 0.98765: "= 0.988"}
    for p, words in expected.items():
        assert _p_text(p) == words, p


# ---- effect against threshold ----------------------------------------------------------------

def _order(a: float, b: float) -> int:
    return (a > b) - (a < b)


def test_an_effect_that_rounds_to_its_threshold_still_reads_below_it():
    assert versus(0.2496, 0.25, ".0f", scale=100.0) == ("24.96", "25")
    assert versus(0.24999996, 0.25, ".0f", scale=100.0) == ("24.999996", "25")


def test_an_effect_that_rounds_to_its_threshold_still_reads_above_it():
    assert versus(0.2504, 0.25, ".0f", scale=100.0) == ("25.04", "25")
    assert versus(1000.4, 1000.0) == ("1000.4", "1000")


def test_digits_are_added_only_when_needed():
    assert versus(0.31, 0.25, ".0f", scale=100.0) == ("31", "25")
    assert versus(0.0123, 0.1, ".3f") == ("0.012", "0.1")
    assert versus(0.25, 0.25, ".0f", scale=100.0) == ("25", "25")  # equal reads equal


def test_threshold_is_written_as_briefly_as_it_reads_back():
    # 100 * 0.07 = 7.000000000000001 in floating point
    assert versus(0.2, 0.07, ".0f", scale=100.0)[1] == "7"
    assert versus(0.2, 0.125, ".0f", scale=100.0)[1] == "12.5"  # not "12" (the old :.0f)
    assert versus(0.2, 0.123456789)[1] == "0.123456789"
    assert versus(2.0, 1e-5)[1] == "1e-5"


def test_signed_effect_compared_by_its_size():
    assert versus(-0.09996, 0.1, "+.3f", absolute=True) == ("-0.09996", "0.1")
    assert versus(0.09996, 0.1, "+.3f", absolute=True) == ("+0.09996", "0.1")
    assert versus(-0.2, 0.1, "+.3f", absolute=True) == ("-0.200", "0.1")


def test_negative_r2_never_reads_as_zero():
    assert versus(-0.0001, 0.0, ".3f")[0] == "-0.0001"
    assert versus(-0.4, 0.0, ".3f")[0] == "-0.400"


def test_missing_values():
    assert versus(None, 0.1) == ("n/a", "0.1")
    assert versus(math.nan, 0.1) == ("nan", "0.1")
    assert versus(0.3, None) == ("0.3", "n/a")
    with pytest.raises(ValueError):
        versus(0.3, 0.1, "%d")


@pytest.mark.parametrize("spec", [".0f", ".1f", ".3f", ".2g", ".3g"])
@pytest.mark.parametrize("scale", [1.0, 100.0])
def test_printed_order_is_the_true_order(spec, scale):
    rng = np.random.default_rng(7)
    for threshold in (0.25, 0.1, 0.05, 0.07, 0.01, 0.9, 3.0, 1000.0):
        for k in range(1, 8):
            for side in (-1.0, 1.0):
                effect = threshold * (1.0 + side * 10.0 ** -k * rng.uniform(0.5, 1.0))
                e, t = versus(effect, threshold, spec, scale=scale)
                assert _order(float(e), float(t)) == _order(effect, threshold), (effect, threshold, spec, e, t)
                assert float(t) == pytest.approx(threshold * scale, rel=1e-12)


# ---- the messages that print both ------------------------------------------------------------

def test_bias_message_below_its_threshold_reads_below_it():
    # |mean|/RMSE = 0.2496 against the default 0.25: the old ":.0f" wording read
    # "25 % of the RMSE ... significant but negligible (below 25 % of the RMSE)"
    rng = np.random.default_rng(3)
    n = 4000
    z = rng.standard_normal(n)
    z -= z.mean()
    ratio = 0.2496  # |mean| / RMS of z + c is c / sqrt(mean(z²) + c²) for a zero-mean z
    c = ratio * math.sqrt(float(np.mean(z * z)) / (1.0 - ratio * ratio))
    meas = 10.0 * rng.standard_normal(n)
    rep = dynval.validate(meas, meas - (z + c), n_params=1, max_lag=5)
    (f,) = [f for f in rep.findings if f.kind == "bias"]
    assert f.effect == pytest.approx(ratio, rel=1e-9)
    assert f.severity == "note" and f.threshold == 0.25
    assert "(24.96 % of the RMSE;" in f.message
    assert "significant but negligible (below 25 % of the RMSE)." in f.message


def test_comparison_reason_reads_on_the_rule_side():
    rep = dynval.validate(np.arange(10.0), np.arange(10.0) + 0.1, n_params=1, max_lag=0)
    f = Finding(kind="excitation", severity="design", joints=(0,), effect=0.09996,
                effect_unit="joint motion (RMS) relative to the estimation run", threshold=0.1)
    assert "hardly moves (9.996 % of its estimation-run motion < 10 %)" in finding_reason(f, rep)
    f = Finding(kind="bias", severity="deficiency", joints=(0,), effect=0.25004, effect_unit="|mean| / RMSE",
                threshold=0.25)
    assert "|mean| = 25.004 % of the RMSE ≥ 25 %" in finding_reason(f, rep)
    f = Finding(kind="worse_than_constant", severity="deficiency", joints=(0,), statistic=-0.0002,
                effect=0.0002, threshold=0.0)
    assert "R² = -0.0002 < 0" in finding_reason(f, rep)


# ---- one p, one text: summary, HTML and finding ----------------------------------------------

@pytest.fixture(scope="module")
def underflow():
    rng = np.random.default_rng(0)
    n = 20000
    w = rng.standard_normal(n)
    e = np.empty(n)
    e[0] = w[0]
    for k in range(1, n):
        e[k] = 0.95 * e[k - 1] + w[k]
    meas = 10.0 * rng.standard_normal(n) + e
    return dynval.validate(meas, meas - e, n_params=1, decimate=None)


def _lb_cell(summary: str) -> str:
    lines = summary.splitlines()
    i = next(k for k, s in enumerate(lines) if "LB p(h=" in s)
    return re.split(r"\s{2,}", lines[i + 1].strip())[-1]


def test_underflowing_ljung_box_p_reads_the_same_everywhere(underflow):
    from dynval.html import render_report

    rep = underflow
    lb = rep.ljung_box
    assert lb["pvalue"][0][0] == 0.0 and math.isfinite(lb["log_pvalue"][0][0])
    assert lb["log_pvalue"][0][0] / math.log(10.0) < -1000
    text = pvalue_text(lb["pvalue"][0][0], lb["log_pvalue"][0][0])
    assert text == "< 1e-300"
    summary = str(rep)
    assert summary == rep.summary()
    assert _lb_cell(summary) == text
    (f,) = [f for f in rep.findings if f.kind == "whiteness"]
    assert f.pvalue_adjusted == 0.0
    assert f"Holm-adjusted p {text}" in f.message
    assert f"Holm-adjusted p {text}" in summary
    page = render_report(rep)
    assert "<td>&lt; <span class=\"num\">1e-300</span></td>" in page  # the per-joint Ljung–Box cell, kept whole
    assert "Holm-adjusted p &lt; 1e-300" in page
    # no exponent outside the double range anywhere a person reads
    for where in (summary, page.split("<details>")[0]):
        assert not re.search(r"\de-\d{4,}", where), where


def test_float_range_p_reads_the_same_in_summary_and_html():
    from dynval.html import _per_joint_table

    rng = np.random.default_rng(11)
    n = 3000
    e = rng.standard_normal(n)
    e[1:] += 0.06 * e[:-1]  # mildly coloured: a p in the float range
    meas = 5.0 * rng.standard_normal(n)
    rep = dynval.validate(meas, meas - e, n_params=1, max_lag=10, decimate=None)
    p = float(rep.ljung_box["pvalue"][0][0])
    assert 1e-12 < p < 1.0
    text = pvalue_text(p, rep.ljung_box["log_pvalue"][0][0])
    assert _lb_cell(rep.summary()) == text
    assert f"<td>{text}</td>" in _per_joint_table(rep)


def test_module_lists_its_helpers():
    assert set(_text.__all__) >= {"pvalue_text", "p_clause", "versus", "number_text", "P_FLOOR"}


def test_a_count_of_one_takes_the_singular():
    import numpy as np

    import dynval
    from dynval.report._text import counted

    assert (counted(1, "row"), counted(0, "row"), counted(3, "log"), counted(2, "entry", "entries")) == (
        "1 row", "0 rows", "3 logs", "2 entries")
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(300, 2))
    pred = tau + 0.1 * rng.normal(size=tau.shape)
    pred[5, 0] = np.nan
    report = dynval.validate(tau, pred, n_params=2, nan_policy="omit")
    assert "1 row omitted" in report.summary() and "1 rows" not in report.summary()
    assert any("1 row with non-finite values was omitted" in f.message for f in report.findings)
    cmp = dynval.compare(tau[1:], {"only": {"prediction": pred[1:], "n_params": 2}}, nan_policy="omit")
    assert "— 1 candidate," in cmp.summary()


@pytest.mark.parametrize("in_model, reason", [(True, "a mis-weighted term (the model has it)"),
                                              (False, "a missing term"), (None, "a missing or mis-weighted term")])
def test_comparison_reason_tells_a_correlated_column_from_the_record_not_the_words(in_model, reason):
    """Rewording a finding's action once changed compare's reason silently. Kills: the reason read
    from the action's words (each action here says the opposite of the record)."""
    rep = dynval.validate(np.arange(10.0), np.arange(10.0) + 0.1, n_params=1, max_lag=0)
    contrary = {True: "add the term c on j: the model lacks it", False: "re-identify the term of c on j",
                None: "re-identify the term of c on j"}
    f = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(0,), effect=0.4,
                effect_unit="correlation |ρ|", threshold=0.1, action=contrary[in_model],
                details={"lag": 0, "rho": 0.4, "n_significant_columns": 1, "in_model": in_model})
    assert finding_reason(f, rep).endswith("): " + reason)
