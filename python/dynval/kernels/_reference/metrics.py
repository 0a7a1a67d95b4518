"""compute_metrics: every point metric, residual statistic and criterion in one call.

This is the reference for the C++ ``ValidationMetrics`` struct (one fused pass there). Here the
residual and the target are each copied joint-major once, and every sum is a row sum of a copy
(per joint) or of its flat view (pooled).
"""

from __future__ import annotations

import math

import numpy as np

from ...checks._typing import FusedMetrics
from ...checks._validation import check_ddof, check_n_params, check_noise_model
from ._common import finite_pair
from .fit import fit_values, r2_values, uniform_average, vaf_values, variance_weighted
from .information import assemble, fit_term, pooled_sum
from .norms import joint_major, moments_scaled, pooled, sumsq


def compute_metrics(meas, pred, n_params, ddof, noise_model) -> FusedMetrics:
    """All report metrics for ``tau_meas``/``tau_pred``; see contract §5.1 for the fields.

    Unlike :func:`information_criteria`, ``n_params >= n − 1`` does not raise: aicc and fpe
    are nan there.
    """
    meas, pred = finite_pair(meas, pred)
    n, m = meas.shape
    p = check_n_params(n_params)
    ddof = check_ddof(ddof, n)
    noise_model = check_noise_model(noise_model)

    # The residual first, so that its joint-major copy can then serve as scratch space for the
    # target's deviations: at most two arrays of the data's size are alive at a time.
    error = joint_major(meas, minus=pred)
    mean_e, ssc_e, e_constant, e_exp = moments_scaled(error)
    # max|e| from the extremes: two reads, no temporary |e|.
    max_abs = np.maximum(np.abs(error.min(axis=1)), np.abs(error.max(axis=1)))
    # Σe² = Σ(e − ē)² + N·ē²: both terms are non-negative, so nothing cancels. Scaled sums
    # (value s·4^k) keep their digits where the squares of tiny data underflow.
    scaled_mean = np.ldexp(mean_e, -e_exp)
    sse_s = ssc_e + n * scaled_mean * scaled_mean
    for i in np.flatnonzero(e_exp):  # a tiny joint: Σe² of the scaled data, not of its rounded mean
        sse_s[i] = sumsq(np.ldexp(error[i : i + 1], -e_exp[i]))[0]
    total_s, total_exp = pooled_sum(sse_s, e_exp)
    sse = np.ldexp(sse_s, 2 * e_exp)
    sse_total = float(np.ldexp(total_s, 2 * total_exp))
    f, n_ic, n_vec, size = fit_term(error.T, noise_model, (sse_s, e_exp))
    # Pooled sums do not depend on the order of the values: the flat view of the copy serves.
    _, ssc_e_pooled, e_constant_pooled, ssc_e_pooled_exp = moments_scaled(pooled(error))
    target = joint_major(meas)
    _, tss, constant, tss_exp = moments_scaled(target, out=error)
    _, tss_pooled, constant_pooled, tss_pooled_exp = moments_scaled(pooled(target), out=pooled(error))

    parts = {"sse": sse_s, "sse_exp": e_exp, "tss": tss, "tss_exp": tss_exp, "ssc_e": ssc_e,
             "ssc_e_exp": e_exp, "constant": constant, "e_constant": e_constant}
    flat = {"sse": np.array([total_s]), "sse_exp": np.array([total_exp]), "tss": tss_pooled,
            "tss_exp": tss_pooled_exp, "ssc_e": ssc_e_pooled, "ssc_e_exp": ssc_e_pooled_exp,
            "constant": constant_pooled, "e_constant": e_constant_pooled}
    rmse = np.ldexp(np.sqrt(sse_s / n), e_exp)
    vaf, fit, r2 = vaf_values(parts), fit_values(parts), r2_values(parts)

    out = {
        "n_samples": int(n),
        "n_joints": int(m),
        "n_params": p,
        "sse": sse,
        "rmse": rmse,
        "max_abs_error": max_abs,
        "vaf": vaf,
        "fit_percent": fit,
        "r2": r2,
        "residual_mean": mean_e,
        "residual_variance": np.ldexp(ssc_e / (n - ddof), 2 * e_exp),
        "constant_target": constant.copy(),
        "sse_total": sse_total,
        "rmse_per_element": float(np.ldexp(math.sqrt(total_s / (n * m)), total_exp)),
        "rmse_per_sample": float(np.ldexp(math.sqrt(total_s / n), total_exp)),
        "max_abs_error_pooled": float(max_abs.max()),
        "vaf_pooled": float(vaf_values(flat)[0]),
        "fit_percent_pooled": float(fit_values(flat)[0]),
        "r2_pooled": float(r2_values(flat)[0]),
        "constant_target_pooled": bool(flat["constant"][0]),
        "rmse_uniform_average": float(np.mean(rmse)),
        "vaf_uniform_average": uniform_average(vaf),
        "fit_percent_uniform_average": uniform_average(fit),
        "r2_uniform_average": uniform_average(r2),
        "vaf_variance_weighted": variance_weighted(vaf, parts),
        "fit_percent_variance_weighted": variance_weighted(fit, parts),
        "r2_variance_weighted": variance_weighted(r2, parts),
    }
    out.update(assemble(f, n_ic, n_vec, size, p))
    return out
