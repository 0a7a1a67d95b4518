"""The plain-language side of a :class:`~dynval.ValidationReport`: findings and the summary table.

Kept apart from the numbers so that the report's contents (contract §4) and their wording can
change independently.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.stats

if TYPE_CHECKING:
    from ._report import ValidationReport


def _num(x, fmt=".4g") -> str:
    """Format a number; nan and infinities as words a reader recognises."""
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, fmt)


def _pvalue(p, log_p) -> str:
    """A p-value, written from its logarithm when it underflows."""
    p, log_p = float(p), float(log_p)
    if math.isnan(p):
        return "nan"
    if p >= 1e-4:
        return f"{p:.3f}" if p >= 0.001 else f"{p:.1e}"
    if p > 1e-300:
        return f"{p:.1e}"
    if not math.isfinite(log_p):
        return "0"  # an exact zero, e.g. a constant non-zero residual
    exponent = log_p / math.log(10.0)  # p < 1e-300: only the log is representable
    whole = math.floor(exponent)
    return f"{10.0 ** (exponent - whole):.1f}e{whole}"


def _binomial_excess(k: int, trials: int, alpha: float) -> float:
    """P(X >= k) for X ~ Binomial(trials, alpha): how surprising k exceedances are by chance."""
    if trials <= 0 or k <= 0:
        return 1.0
    return float(scipy.stats.binom.sf(k - 1, trials, alpha))


def findings(report: ValidationReport) -> list:
    """The plain-language findings of a report (its ``warnings_text``)."""
    out = []
    prov = report.provenance
    level = prov["conventions"]["level"]
    alpha = 1.0 - level
    pct = f"{100 * level:g} %"
    m = prov["n_joints"]
    # Per-joint tests are Bonferroni-corrected over the m joints, so a report on many joints
    # does not raise a finding by chance.
    alpha_joint = alpha / m
    pj = report.per_joint
    r2 = np.asarray(pj["r2"])
    constant = ~np.isfinite(np.asarray(pj["nrmse"]))

    if prov["omitted_rows"]:
        out.append(f"{prov['omitted_rows']} rows with non-finite values were omitted; segment breaks "
                   "were inserted so no lag joins samples that were not adjacent.")
    for j in np.flatnonzero(constant):
        out.append(f"Joint {j + 1}: the measured torque is constant, so R², fit and VAF compare against "
                   "nothing (reported as " + ("0 or 1 by scikit-learn's force_finite rule)."
                                              if prov["conventions"]["constant_target"] == "force_finite"
                                              else "-inf, or nan for an exact prediction)."))
    pooled_r2 = float(report.pooled["r2"])
    negative = [j for j in range(m) if not constant[j] and r2[j] < 0]
    for j in negative:
        if m > 1 and pooled_r2 > 0:
            out.append(
                f"Joint {j + 1} does worse than a constant: R² = {_num(r2[j], '.3f')} (predicting its mean "
                f"torque would be better), yet the pooled R² is {_num(pooled_r2, '.3f')}. Pooling flattens "
                "all joints with one mean, so the high-torque joints dominate it; read the per-joint values.")
        else:
            out.append(f"Joint {j + 1} does worse than a constant: R² = {_num(r2[j], '.3f')} (predicting "
                       "its mean torque would be better).")
    if m > 1 and np.isfinite(pooled_r2):
        for j in range(m):
            if not constant[j] and 0 <= r2[j] < pooled_r2 - 0.05:
                out.append(f"Joint {j + 1}: R² = {_num(r2[j], '.3f')}, well below the pooled "
                           f"{_num(pooled_r2, '.3f')}, which the larger torques of other joints dominate.")

    acf = report.autocorrelation
    if acf is not None:
        rho = np.asarray(acf["rho"])
        band = np.asarray(acf["band"])
        lags = acf["max_lag"]
        for j in range(m):
            if np.isnan(rho[0, j]):
                out.append(f"Joint {j + 1}: the residual is constant; its autocorrelation is undefined (nan).")
                continue
            out_j = [lag for (jj, lag, _) in acf["outside"] if jj == j]
            k = len(out_j)
            if _binomial_excess(k, lags, alpha) < alpha_joint:
                ratio = np.abs(rho[1:, j]) / band[1:, j]
                worst = int(np.argmax(ratio)) + 1
                out.append(
                    f"Joint {j + 1}: {k} of {lags} autocorrelation lags lie outside the {pct} "
                    f"{acf['band_type']} band ({alpha * lags:.1f} expected for white residuals); "
                    f"strongest ρ = {rho[worst, j]:+.3f} at lag {worst}.")

    lb = report.ljung_box
    if lb is not None:
        for i, h in enumerate(np.asarray(lb["lags"]).tolist()):
            for j in range(m):
                p, logp = lb["pvalue"][i][j], lb["log_pvalue"][i][j]
                if (np.isfinite(logp) and logp < math.log(alpha_joint)) or p == 0.0:
                    out.append(
                        f"Joint {j + 1}: the residuals are not white (Ljung–Box Q({h}) = "
                        f"{_num(lb['statistic'][i][j], '.1f')}, df {int(lb['df'][i])}, "
                        f"p = {_pvalue(p, logp)}): structure is left in them (unmodelled dynamics).")

    zmt = report.residuals["zero_mean_test"]
    corrected = zmt["pvalue_eff"] is not None
    for j in range(m):
        if not corrected:
            p_iid = float(np.asarray(zmt["pvalue_iid"])[j])
            if p_iid < alpha_joint:
                out.append(
                    f"Joint {j + 1}: the residual mean {float(np.asarray(zmt['mean'])[j]):+.4g} is "
                    f"significant under the i.i.d. t-test (p = "
                    f"{_pvalue(p_iid, math.log(p_iid) if p_iid > 0 else -math.inf)}); with max_lag=0 "
                    "it is not corrected for autocorrelation, which makes it overconfident.")
            continue
        p_eff = float(np.asarray(zmt["pvalue_eff"])[j])
        p_iid = float(np.asarray(zmt["pvalue_iid"])[j])
        mean = float(np.asarray(zmt["mean"])[j])
        n_eff = float(np.asarray(zmt["n_eff"])[j])
        if p_eff < alpha_joint:
            out.append(
                f"Joint {j + 1}: the residual mean {mean:+.4g} is significantly non-zero "
                f"(autocorrelation-corrected t-test, N_eff = {n_eff:.0f} of {prov['n_samples']}, "
                f"p = {_pvalue(p_eff, math.log(p_eff) if p_eff > 0 else -math.inf)}): a systematic bias, "
                "e.g. a missing offset or friction term.")
        elif p_iid < alpha_joint and not math.isnan(p_eff):
            out.append(
                f"Joint {j + 1}: the residual mean {mean:+.4g} looks significant under the i.i.d. t-test "
                f"(p = {_pvalue(p_iid, math.log(p_iid) if p_iid > 0 else -math.inf)}) but not once the "
                f"autocorrelation is accounted for (N_eff = {n_eff:.0f}, p = {p_eff:.3f}).")

    xc = report.cross_correlation
    if xc is not None:
        rho = np.asarray(xc["rho"])
        mask = np.asarray(xc["constant_mask"])
        cells = int((~mask).sum()) * rho.shape[2]
        # Neighbouring lags of a smooth regressor column are strongly correlated, so counting
        # exceedances overstates the evidence; a cell must instead pass the Bonferroni bound
        # over all cells, z(1 − α/(2·cells)) standard deviations of that cell.
        z_cell = float(scipy.stats.norm.isf(alpha / (2.0 * max(cells, 1))))
        # Under independence a cell's standard deviation is √n_ℓ / D_ℓ (n_ℓ lag-ℓ products,
        # D_ℓ the denominator): 1/√N for small lags, larger for adjusted estimates at large lags.
        lengths = np.asarray(prov["segments"])
        lags = np.arange(rho.shape[2])
        n_l = np.maximum(lengths[None, :] - lags[:, None], 0).sum(axis=1).astype(float)
        d_l = n_l if xc["adjusted"] else np.full_like(n_l, float(prov["n_samples"]))
        sd = np.sqrt(n_l) / d_l
        strong = sorted(((j, c, lag, r, abs(r) / sd[lag]) for j, c, lag, r, _ in xc["outside"]
                         if abs(r) > z_cell * sd[lag]), key=lambda t: (-t[4], t[0], t[1], t[2]))
        if strong:
            best, seen = [], set()
            for j, c, lag, r, score in strong:
                if (j, c) not in seen:
                    seen.add((j, c))
                    best.append(f"joint {j + 1} × column {c + 1} (lag {lag}, ρ = {r:+.3f}, "
                                f"{score:.1f} standard deviations)")
            out.append(
                f"{len(strong)} residual–regressor correlations exceed the Bonferroni bound over "
                f"{cells} cells ({z_cell:.2f} standard deviations); strongest per column: "
                + "; ".join(best[:3]) + ". The model does not use the information in these columns "
                "(a missing or mis-weighted term).")
    return out


def format_summary(report: ValidationReport) -> str:
    """The text of :meth:`ValidationReport.summary`."""
    prov = report.provenance
    conv = prov["conventions"]
    m = prov["n_joints"]
    percent = conv["units"] == "percent"
    unit = " %" if percent else ""
    pj, pooled, agg = report.per_joint, report.pooled, report.aggregates
    zmt = report.residuals["zero_mean_test"]
    lb = report.ljung_box
    seg = prov["segments"]
    lines = [
        f"dynval validation report — profile '{prov['profile']}'",
        f"N = {prov['n_samples']} samples, m = {m} joints, p = {prov['n_params']} parameters, "
        f"{len(seg)} segment{'s' if len(seg) != 1 else ''}"
        + (f", {prov['omitted_rows']} rows omitted" if prov["omitted_rows"] else "")
        + f"; backend {prov['backend']}, dynval {prov['dynval_version']}",
        "",
        "Per joint (joints numbered from 1):",
    ]
    lb_head = f"LB p(h={int(lb['lags'][0])})" if lb is not None else "LB p"
    header = (f"  {'joint':>5} {'RMSE':>11} {'max|e|':>11} {'VAF' + unit:>9} {'fit' + unit:>9} "
              f"{'R²':>9} {'mean e':>11} {lb_head:>12}")
    lines.append(header)
    vfmt = ".2f" if percent else ".4f"
    for j in range(m):
        lbp = _pvalue(lb["pvalue"][0][j], lb["log_pvalue"][0][j]) if lb is not None else "—"
        lines.append(
            f"  {j + 1:>5} {_num(pj['rmse'][j]):>11} {_num(pj['max_abs_error'][j]):>11} "
            f"{_num(pj['vaf'][j], vfmt):>9} {_num(pj['fit_percent'][j], vfmt):>9} "
            f"{_num(pj['r2'][j], '.4f'):>9} {_num(zmt['mean'][j], '+.4g'):>11} {lbp:>12}")
    lines += [
        "",
        "Pooled (all joints flattened, one mean — the lesson's form):",
        f"  RMSE per element {_num(pooled['rmse_per_element'])} (√(SSE/(N·m))), per sample "
        f"{_num(pooled['rmse_per_sample'])} (√(SSE/N)); max|e| {_num(pooled['max_abs_error'])}",
        f"  VAF {_num(pooled['vaf'], vfmt)}{unit}, fit {_num(pooled['fit_percent'], vfmt)}{unit}, "
        f"R² {_num(pooled['r2'], '.4f')}",
        "Averages over joints:",
        f"  uniform: VAF {_num(agg['uniform_average']['vaf'], vfmt)}{unit}, fit "
        f"{_num(agg['uniform_average']['fit_percent'], vfmt)}{unit}, R² {_num(agg['uniform_average']['r2'], '.4f')}, "
        f"RMSE {_num(agg['rmse_uniform_average'])}",
        f"  variance-weighted: VAF {_num(agg['variance_weighted']['vaf'], vfmt)}{unit}, fit "
        f"{_num(agg['variance_weighted']['fit_percent'], vfmt)}{unit}, R² "
        f"{_num(agg['variance_weighted']['r2'], '.4f')}",
        f"  headline aggregation of this profile: {conv['multioutput']}",
    ]
    ic = report.information_criteria
    lines += [
        "",
        f"Information criteria ({ic['noise_model']} noise model, Gaussian constant {ic['constant']}, "
        f"n = {ic['n_obs']}, p = {ic['n_params']}):",
        f"  AIC {_num(ic['aic'], '.6g')}   BIC {_num(ic['bic'], '.6g')}   AICc {_num(ic['aicc'], '.6g')}   "
        f"FPE {_num(ic['fpe'], '.5g')}   nAIC {_num(ic['naic'], '.5g')}",
    ]
    acf = report.autocorrelation
    lines.append("")
    if acf is None:
        lines.append("Residual whiteness: not analysed (max_lag = 0).")
    else:
        frac = ", ".join(f"joint {j + 1}: {_num(100 * f, '.0f')} %" for j, f in enumerate(acf["fraction_outside"]))
        lines.append(
            f"Residual whiteness: lags 1..{acf['max_lag']}, {'adjusted' if acf['adjusted'] else 'biased'} "
            f"autocorrelation, {acf['band_type']} band at {100 * acf['level']:g} %; lags outside: {frac}")
    if report.cross_correlation is not None:
        xc = report.cross_correlation
        lines.append(f"Cross-correlation with {prov['n_regressor_columns']} regressor columns, lags "
                     f"0..{xc['max_lag']}, band ±{xc['band']:.4f}: {len(xc['outside'])} cells outside.")
    lines += ["", "Findings:"]
    if report.warnings_text:
        lines += [f"  - {w}" for w in report.warnings_text]
    else:
        lines.append("  - none: no joint worse than a constant, residuals consistent with white "
                     "zero-mean noise at this level.")
    return "\n".join(lines)
