"""Normalised fit metrics: vaf (percent), fit_percent (percent), r2 (fraction).

Degenerate values follow contract §3.2 exactly and are produced without numpy warnings:
a constant target gives -inf, or nan when the fit is exact.
"""

from __future__ import annotations

import numpy as np

from ...checks._validation import MULTIOUTPUT_OPTIONS, check_multioutput
from ._common import finite_pair
from .norms import joint_major, moments_scaled, pooled, scaled_ratio, sumsq_scaled

# The error-side sums each metric needs: r2 and fit use the SSE, vaf the centred residual.
_ERROR_TERMS = {"vaf": ("ssc_e",), "fit_percent": ("sse",), "r2": ("sse",)}


def fit_parts(meas_rows: np.ndarray, e_rows: np.ndarray, error_terms=("sse", "ssc_e")) -> dict:
    """Per-row ingredients of the fit metrics for one view of the data (rows: see ``norms``).

    ``error_terms`` limits the residual side to what the caller uses. ``e_rows`` must be a
    temporary of the same shape as ``meas_rows``: it then holds the target's deviations.
    Sums of squares are scaled (``*_exp``: the value is sum·4^exp), so ratios of tiny data keep
    their digits.
    """
    parts = {}
    if "sse" in error_terms:
        parts["sse"], parts["sse_exp"] = sumsq_scaled(e_rows)
    if "ssc_e" in error_terms:
        _, parts["ssc_e"], parts["e_constant"], parts["ssc_e_exp"] = moments_scaled(e_rows)
    _, parts["tss"], parts["constant"], parts["tss_exp"] = moments_scaled(meas_rows, out=e_rows)
    return parts


def _degenerate(values, constant, exact):
    values = np.where(constant & exact, np.nan, values)
    return np.where(constant & ~exact, -np.inf, values)


def r2_values(parts: dict) -> np.ndarray:
    values = 1.0 - scaled_ratio(parts["sse"], parts["sse_exp"], parts["tss"], parts["tss_exp"])
    return _degenerate(values, parts["constant"], parts["sse"] == 0)


def fit_values(parts: dict) -> np.ndarray:
    ratio = scaled_ratio(parts["sse"], parts["sse_exp"], parts["tss"], parts["tss_exp"])
    with np.errstate(invalid="ignore"):
        values = 100.0 * (1.0 - np.sqrt(ratio))
    return _degenerate(values, parts["constant"], parts["sse"] == 0)


def vaf_values(parts: dict) -> np.ndarray:
    # A ratio of two centred variances with the same ddof: N cancels, so use the sums.
    values = 100.0 * (1.0 - scaled_ratio(parts["ssc_e"], parts["ssc_e_exp"], parts["tss"], parts["tss_exp"]))
    return _degenerate(values, parts["constant"], parts["e_constant"])


def uniform_average(values: np.ndarray) -> float:
    """IEEE mean over joints: -inf and nan propagate."""
    with np.errstate(invalid="ignore"):
        return float(np.mean(values))


def variance_weighted(values: np.ndarray, parts: dict) -> float:
    """TSS-weighted mean; constant joints get weight 0 and are left out (contract §3.2)."""
    live = ~parts["constant"]
    if not live.any():
        return uniform_average(values)
    # The TSS at the largest joint's scale: tiny joints do not all underflow to weight 0.
    exps = parts["tss_exp"][live]
    weights = np.ldexp(parts["tss"][live], 2 * (exps - exps.max()))
    total = np.sum(weights)
    if total == 0.0:
        return uniform_average(values)
    with np.errstate(invalid="ignore"):
        return float(np.sum(weights * values[live]) / total)


def _metric(meas, pred, multioutput, function, per_row):
    meas, pred = finite_pair(meas, pred)
    check_multioutput(multioutput, MULTIOUTPUT_OPTIONS, function)
    terms = _ERROR_TERMS[function]
    if multioutput == "pooled":
        return float(per_row(fit_parts(pooled(meas), pooled(meas - pred), terms))[0])
    parts = fit_parts(joint_major(meas), joint_major(meas, minus=pred), terms)
    values = per_row(parts)
    if multioutput == "raw_values":
        return values
    if multioutput == "uniform_average":
        return uniform_average(values)
    return variance_weighted(values, parts)


def vaf(meas, pred, multioutput):
    """Variance accounted for, percent: 100(1 − var(e)/var(τ))."""
    return _metric(meas, pred, multioutput, "vaf", vaf_values)


def fit_percent(meas, pred, multioutput):
    """Normalised fit, percent: 100(1 − √(SSE/TSS))."""
    return _metric(meas, pred, multioutput, "fit_percent", fit_values)


def r2(meas, pred, multioutput):
    """Coefficient of determination: 1 − SSE/TSS."""
    return _metric(meas, pred, multioutput, "r2", r2_values)
