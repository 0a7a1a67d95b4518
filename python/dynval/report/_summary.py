"""The plain-language side of a :class:`~dynval.ValidationReport`: findings and the summary table.

Kept apart from the numbers so that the report's contents (contract §4) and their wording can
change independently.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..checks._typing import ReportSections
from ._ranking import Ranked, deciding, first_reason, share_text, torque_text
from ._text import counted, pvalue_text
from .kinds._base import Finding


def _num(x: float, fmt: str = ".4g") -> str:
    """Format a number; nan and infinities as words a reader recognises."""
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, fmt)


def format_summary(report: ReportSections) -> str:
    """The text of :meth:`ValidationReport.summary`."""
    prov = report.provenance
    names = _joint_names(prov)
    alpha = 1.0 - float(prov["conventions"]["level"])
    lines = _heading_lines(prov)
    lines += _per_joint_lines(report, names)
    lines += _pooled_lines(report)
    lines += _criteria_lines(report.information_criteria)
    lines += [""] + _analysis_lines(report, names)
    lines += ["", f"Findings (family-wise error rate α = {alpha:g} over every test of the report, Holm):"]
    lines += format_findings(report.findings, prov.get("not_tested"))
    lines += format_deciding(deciding(report.findings, report.per_joint["r2"]), _joint_names(prov))
    return "\n".join(lines)


def format_deciding(ranked: Sequence[Ranked], names: Sequence[str] | None) -> list[str]:
    """The deficiencies strongest first, each with the share of the residual it explains, and the
    first step with why it is first (nothing without a deficiency)."""
    if not ranked:
        return []
    lines = ["", "Deciding findings, strongest first (share of the joint's residual mean square each explains, and "
             "of its measured torque's variance, which ranks them; the number of findings is not the measure):"]
    for i, r in enumerate(ranked, 1):
        f = r.finding
        where = ", ".join(str(names[j]) if names and j < len(names) else f"joint {j + 1}" for j in f.joints)
        basis = "" if r.share is None else (" carried from the estimation run" if r.basis == "held_out"
                                            else " on the validation run")
        torque = "" if r.torque_share is None else f" ({torque_text(r.torque_share)} the torque's variance)"
        lines.append(f"  {i}. {f.kind}{' on ' + where if where else ''}: {share_text(r.share)}{basis}{torque}")
    lines.append(f"Do first: {ranked[0].finding.action}")
    lines.append(f"  ({first_reason(ranked, names)})")
    return lines


def _joint_names(prov: Mapping[str, Any]) -> list[str]:
    """The joints' names as given, else "joint 1", "joint 2", ..."""
    return prov.get("joint_names") or [f"joint {j + 1}" for j in range(prov["n_joints"])]


def _fraction_style(prov: Mapping[str, Any]) -> tuple[str, str]:
    """The unit suffix and the number format of VAF and fit: per cent or a fraction of 1."""
    percent = prov["conventions"]["units"] == "percent"
    return (" %" if percent else ""), (".2f" if percent else ".4f")


def _heading_lines(prov: Mapping[str, Any]) -> list[str]:
    """The title and the run's size: samples, joints, parameters, segments, omitted rows, backend."""
    seg = prov["segments"]
    return [
        f"dynval validation report — profile '{prov['profile']}'",
        f"N = {prov['n_samples']} samples, m = {prov['n_joints']} joints, p = {prov['n_params']} parameters, "
        f"{len(seg)} segment{'s' if len(seg) != 1 else ''}"
        + (f", {counted(prov['omitted_rows'], 'row')} omitted" if prov["omitted_rows"] else "")
        + f"; backend {prov['backend']}, dynval {prov['dynval_version']}",
        "",
    ]


def _per_joint_lines(report: ReportSections, names: list[str]) -> list[str]:
    """The per-joint table: error sizes, VAF, fit, R², mean residual and the Ljung–Box p-value."""
    unit, vfmt = _fraction_style(report.provenance)
    pj = report.per_joint
    zmt = report.residuals["zero_mean_test"]
    lb = report.ljung_box
    lb_head = f"LB p(h={int(lb['lags'][0])})" if lb is not None else "LB p"
    width = max(5, max(len(x) for x in names))
    lines = ["Per joint:",
             f"  {'joint':>{width}} {'RMSE':>11} {'max|e|':>11} {'VAF' + unit:>9} {'fit' + unit:>9} "
             f"{'R²':>9} {'mean e':>11} {lb_head:>12}"]
    for j in range(report.provenance["n_joints"]):
        lbp = pvalue_text(lb["pvalue"][0][j], lb["log_pvalue"][0][j]) if lb is not None else "—"
        lines.append(
            f"  {names[j]:>{width}} {_num(pj['rmse'][j]):>11} {_num(pj['max_abs_error'][j]):>11} "
            f"{_num(pj['vaf'][j], vfmt):>9} {_num(pj['fit_percent'][j], vfmt):>9} "
            f"{_num(pj['r2'][j], '.4f'):>9} {_num(zmt['mean'][j], '+.4g'):>11} {lbp:>12}")
    return lines


def _pooled_lines(report: ReportSections) -> list[str]:
    """The pooled metrics, then the uniform and the variance-weighted averages over joints."""
    unit, vfmt = _fraction_style(report.provenance)
    pooled, agg = report.pooled, report.aggregates
    uniform, weighted = agg["uniform_average"], agg["variance_weighted"]
    return [
        "",
        "Pooled (all joints flattened, one mean — the lesson's form):",
        f"  RMSE per element {_num(pooled['rmse_per_element'])} (√(SSE/(N·m))), per sample "
        f"{_num(pooled['rmse_per_sample'])} (√(SSE/N)); max|e| {_num(pooled['max_abs_error'])}",
        f"  VAF {_num(pooled['vaf'], vfmt)}{unit}, fit {_num(pooled['fit_percent'], vfmt)}{unit}, "
        f"R² {_num(pooled['r2'], '.4f')}",
        "Averages over joints:",
        f"  uniform: VAF {_num(uniform['vaf'], vfmt)}{unit}, fit "
        f"{_num(uniform['fit_percent'], vfmt)}{unit}, R² {_num(uniform['r2'], '.4f')}, "
        f"RMSE {_num(agg['rmse_uniform_average'])}",
        f"  variance-weighted: VAF {_num(weighted['vaf'], vfmt)}{unit}, fit "
        f"{_num(weighted['fit_percent'], vfmt)}{unit}, R² {_num(weighted['r2'], '.4f')}",
        f"  headline aggregation of this profile: {report.provenance['conventions']['multioutput']}",
    ]


def _criteria_lines(ic: Mapping[str, Any]) -> list[str]:
    """AIC, BIC, AICc, FPE and nAIC, and their N_eff-based variants when the report has them."""
    lines = [
        "",
        f"Information criteria ({ic['noise_model']} noise model, Gaussian constant {ic['constant']}, "
        f"n = {ic['n_obs']}, p = {ic['n_params']}):",
        f"  AIC {_num(ic['aic'], '.2f')}   BIC {_num(ic['bic'], '.2f')}   AICc {_num(ic['aicc'], '.2f')}   "
        f"FPE {_num(ic['fpe'], '.5g')}   normalised AIC (nAIC) {_num(ic['naic'], '.6f')}",
    ]
    if ic["n_params"] >= ic["n_obs"] - 1:
        lines.append(f"  AICc and FPE are undefined (nan): they need p < n − 1, and p = {ic['n_params']} with "
                     f"n = {ic['n_obs']} observations; the model has as many parameters as the data have values.")
    if "aic_neff" in ic:
        lines.append(f"  N_eff-based (coloured residuals, N_eff = {ic['n_eff']:.0f} of {ic['n_obs']}): "
                     f"AIC {_num(ic['aic_neff'], '.2f')}   BIC {_num(ic['bic_neff'], '.2f')}   "
                     f"AICc {_num(ic['aicc_neff'], '.2f')}")
    return lines


def _analysis_lines(report: ReportSections, names: list[str]) -> list[str]:
    """One line per analysis beyond the metrics, for those the report holds."""
    return (_whiteness_lines(report, names) + _cross_correlation_lines(report) + _information_rate_lines(report)
            + _physics_lines(report) + _design_lines(report) + _periodic_lines(report) + _bias_lines(report))


def _whiteness_lines(report: ReportSections, names: list[str]) -> list[str]:
    """The autocorrelation's lags, band and the share of lags outside it per joint."""
    acf = report.autocorrelation
    if acf is None:
        return ["Residual whiteness: not analysed (max_lag = 0)."]
    conv = report.provenance["conventions"]
    frac = ", ".join(f"{names[j]}: {_num(100 * f, '.0f')} %" for j, f in enumerate(acf["fraction_outside"]))
    span = (f" ({_num(conv['max_lag_seconds'], '.3g')} s, {conv['max_lag_source']})"
            if conv.get("max_lag_seconds") is not None else "")
    return [f"Residual whiteness: lags 1..{acf['max_lag']}{span}, {'adjusted' if acf['adjusted'] else 'biased'} "
            f"autocorrelation, {acf['band_type']} band at {100 * acf['level']:g} % per lag (uncorrected; the "
            f"findings correct over the whole report); lags outside: {frac}"]


def _cross_correlation_lines(report: ReportSections) -> list[str]:
    """The cells of the residual × regressor cross-correlation outside the white band."""
    xc = report.cross_correlation
    if xc is None:
        return []
    # A streamed report has no colour-aware band (it needs the whole series, contract §4.1).
    colour = (f"the findings use a colour-aware band over {xc['colour_lags']} lags." if "colour_lags" in xc
              else "no colour-aware band (streamed), so the findings do not use it.")
    return [f"Cross-correlation with {report.provenance['n_regressor_columns']} regressor columns, lags "
            f"0..{xc['max_lag']}: {xc['n_outside_white_band']} cells outside the white band "
            f"±{xc['band']:.4f} ({100 * xc['level']:g} % per cell, uncorrected); {colour}"]


def _information_rate_lines(report: ReportSections) -> list[str]:
    """The decimation to the information rate and the information band, when there are any."""
    white = report.whiteness
    if white is None:
        return []
    units = report.provenance["units"]
    lines = []
    if white["decimation"] > 1:
        band = white.get("information_band")
        source = (f"band {_num(band)} {units['frequency']}" if band is not None
                  else "the factor given, no information band")
        lines.append(f"Whiteness at the information rate: decimated by {white['decimation']} ({source}), "
                     f"Ljung–Box up to lag {white['lag_decimated']}.")
    if white.get("information_band") is not None:
        lines.append(f"Information band (from the prediction, the noise-free side): "
                     f"{_num(white['information_band'])} {units['frequency']}.")
    return lines


def _physics_lines(report: ReportSections) -> list[str]:
    """How the physical terms were tested, when q was given."""
    phys = getattr(report, "physics", None)
    if phys is None:
        return []
    lines = [f"Physical terms tested against each joint's residual (q given; derivatives: "
             f"{phys['derivatives']}; the model's own columns: {phys['model_columns']})."]
    if "decimation" in phys:  # only a decimated log says it (conventions §5.2)
        lines.append(f"Physical terms tested on the log {phys['decimation']['rule']}.")
    return lines


def _design_lines(report: ReportSections) -> list[str]:
    """The smallest term the data could detect, per joint."""
    design = report.design or {}
    if design.get("detectable_share") is None:
        return []
    shares = ", ".join(f"{100 * x:.0f} %" for x in design["detectable_share"])
    return [f"Smallest detectable term (90 % power, per joint): {shares} of the mean square "
            f"(N_eff of the noise {', '.join(f'{x:.0f}' for x in design['noise_n_eff'])})."]


def _periodic_lines(report: ReportSections) -> list[str]:
    """The whole periods of a periodic trajectory and the noise they measure."""
    per = getattr(report, "periodic", None)
    if per is None:
        return []
    if not per["used"]:
        return [f"Periodic trajectory: {per['note']}."]
    sec = per["period"]["seconds"]
    noise = ", ".join(_num(math.sqrt(max(v, 0.0))) for v in per["noise_variance"])
    return [f"Periodic trajectory: {per['n_periods']} whole periods of "
            + (f"{sec:.4g} s" if sec else f"{per['period']['samples']:.4g} samples")
            + f"; noise measured from the period-to-period variation (no whiteness assumed): "
            f"standard deviation {noise} per joint."]


def _bias_lines(report: ReportSections) -> list[str]:
    """Why the findings do not use the residual mean, when the coloured-noise bias test is missing."""
    if report.bias is not None:
        return []
    if report.provenance.get("streaming"):
        return ["Residual mean: zero-mean test only (the coloured-noise bias test was not run: see \"not tested\" "
                "under the findings), so the findings do not use it."]
    return ["Residual mean: i.i.d. t-test only (max_lag = 0), not corrected for autocorrelation, "
            "so the findings do not use it."]


_SEVERITY_LABEL = {"deficiency": "DEFICIENCY", "design": "DESIGN", "note": "note"}


def format_findings(findings: Sequence[Finding], not_tested: Sequence[Mapping[str, Any]] | None = None) -> list[str]:
    """One line per finding, deficiencies first, each with its action; then one line per test the
    report left out (``not_tested``: a streamed report's, :func:`dynval.coverage.not_tested`), so
    that a report which tested less never reads as a clean bill."""
    lines = []
    for f in findings:
        lines.append(f"  - [{_SEVERITY_LABEL[f.severity]}] {f.message}")
        if f.severity != "note" and f.action:
            lines.append(f"      → {f.action}")
    if not not_tested:
        return lines or ["  - none: no deficiency, no design problem, nothing to note at this level."]
    if not lines:
        lines.append("  - none from the tests this report ran: no deficiency, no design problem at this level.")
    lines.append(f"  - not tested ({len(not_tested)}; a finding of these kinds cannot show here):")
    lines += [f"      {t['test']} ({', '.join(t['kinds'])}): {t['why']}" for t in not_tested]
    return lines


def format_comparison(cmp: Any) -> str:
    """The text of :meth:`ComparisonReport.summary`: decision table, per-joint table, verdict."""
    crit = cmp.criterion
    first = cmp.reports[cmp.names[0]]
    prov = first.provenance
    m = prov["n_joints"]
    names = prov.get("joint_names") or [f"joint {j + 1}" for j in range(m)]
    percent = prov["conventions"]["units"] == "percent"
    unit = " %" if percent else ""
    vfmt = ".2f" if percent else ".4f"
    w = max(9, max(len(n) for n in cmp.names))
    lines = [f"dynval model comparison — {counted(len(cmp.names), 'candidate')}, N = {prov['n_samples']} samples, "
             f"m = {m} joints, profile '{prov['profile']}', ranked by {crit}", "",
             "Decision table (pooled over joints; Δ to the best; weight = Akaike weight of " + crit + "):"]
    extra = [] if crit in ("aic", "bic", "aicc") else [crit]
    head = (f"  {'rank':>4} {'model':<{w}} {'p':>4} {'RMSE':>10} {'VAF' + unit:>8} {'R²':>8} {'AIC':>12} {'ΔAIC':>9} "
            f"{'BIC':>12} {'ΔBIC':>9}" + "".join(f" {'Δ' + c:>12}" for c in extra)
            + f" {'weight':>7} {'whiteness':>10} {'bias':>10} {'deficient (strongest share)'}")
    lines.append(head)
    for i, n in enumerate(cmp.ranking):
        row = cmp.table["pooled"][n]
        lines.append(
            f"  {i + 1:>4} {n:<{w}} {row['n_params']:>4} {_num(row['rmse']):>10} {_num(row['vaf'], vfmt):>8} "
            f"{_num(row['r2'], '.4f'):>8} {_num(row['aic'], '.1f'):>12} {_num(row['delta_aic'], '.1f'):>9} "
            f"{_num(row['bic'], '.1f'):>12} {_num(row['delta_bic'], '.1f'):>9}"
            + "".join(f" {_num(row['delta_' + c], '.1f'):>12}" for c in extra)
            + f" {_num(row['akaike_weight'], '.3f'):>7} {row['whiteness']:>10} {row['bias']:>10} "
            f"{_deficient_cell(row):>9}")
    lines += _format_candidate_reasons(cmp)
    lines += ["", "Per joint (RMSE / R²):"]
    jw = max(len(x) for x in names)
    lines.append(f"  {'model':<{w}} " + " ".join(f"{x:>{max(jw, 18)}}" for x in names))
    for n in cmp.ranking:
        pj = cmp.table["per_joint"][n]
        cells = [f"{_num(pj['rmse'][j])} / {_num(pj['r2'][j], '.4f')}" for j in range(m)]
        lines.append(f"  {n:<{w}} " + " ".join(f"{c:>{max(jw, 18)}}" for c in cells))
    best = cmp.verdict.model
    alpha = 1.0 - float(cmp.reports[best].provenance["conventions"]["level"])
    lines += ["", f"Findings of {best} (α = {alpha:g} over every test of its report, Holm):"]
    lines += format_findings(cmp.reports[best].findings)
    for f in cmp.findings:
        lines.append(f"  - [{_SEVERITY_LABEL[f.severity]}] {f.message}")
    shown = [f.message for f in cmp.reports[best].findings] + [f.message for f in cmp.findings]
    lines += [""] + format_verdict(cmp.verdict, criterion=crit, shown=shown)
    return "\n".join(lines)


def _deficient_cell(row: Mapping[str, Any]) -> str:
    """The decision table's deficiency cell: the count, and the share of the residual the strongest
    leading deficiency explains (the count alone reads backwards: a weak model has few large
    findings, a good one many small ones)."""
    d = row["n_deficiencies"]
    top = row.get("strongest_share")
    return f"{d}" if not d or top is None else f"{d} ({share_text(top)})"


def _format_candidate_reasons(cmp: Any) -> list[str]:
    """The "Reasons per candidate" block: every candidate in ranking order with its reasons."""
    reasons = getattr(cmp, "reasons", None) or {}
    if not reasons:
        return []
    lines = ["", "Reasons per candidate (ranking order; one per deficiency or design finding, deficiencies strongest "
             "first):"]
    for i, n in enumerate(cmp.ranking):
        row = cmp.table["pooled"].get(n, {})
        d = row.get("n_deficiencies", 0)
        shared, top = row.get("n_shared", 0), row.get("strongest_share")
        lines.append(f"  {i + 1}. {n}" + (f" — {d} deficienc{'y' if d == 1 else 'ies'}" if d else "")
                     + (f" ({shared} shared by all candidates)" if d and shared else "")
                     + (f"; the strongest explains {share_text(top)} of a joint's residual" if d and top is not None
                        else ""))
        lines += [f"       - {r}" for r in reasons.get(n, ())]
    return lines


def format_verdict(verdict: Any, criterion: str | None = None, shown: Sequence[str] = ()) -> list[str]:
    """The verdict's lines: decision and model, what decided it, what to do first, the reasons.

    ``shown``: finding messages the text already printed; a reason that repeats one is not
    printed again, and a line counts them instead."""
    lines = [f"Verdict: {verdict.decision.upper()} — {verdict.model}"]
    decided = tuple(getattr(verdict, "decided_by", ()) or ())
    if decided:
        labels = [d.label() for d in decided]
        if len(labels) == 1:
            lines.append(f"  decided by: {labels[0]}")
        else:
            lines.append("  decided by:")
            lines += [f"    * {x}" for x in labels]
    elif verdict.decision == "accept":
        lines.append(f"  decided by: the criterion — no finding stands against {verdict.model} (no deficiency in "
                     f"its report, no design finding in any) and {criterion or 'the criterion'} ranks it first")
    first = getattr(verdict, "first_step", "")
    if first:
        lines.append(f"  do first: {first}")
        why = getattr(verdict, "first_reason", "")
        if why:
            lines.append(f"    ({why})")
    said = tuple(shown)
    repeated = [r for r in verdict.reasons if any(r.startswith(text) for text in said)]
    lines += [f"  - {r}" for r in verdict.reasons if r not in repeated]
    if repeated:
        lines.append(f"  (and the {len(repeated)} finding{'s' if len(repeated) > 1 else ''} of {verdict.model} "
                     "listed above)")
    return lines
