"""compute_metrics: every point metric, residual statistic and criterion in one call.

This is the reference for the C++ ``ValidationMetrics`` struct (one fused pass there). Here the
residual and the target are each copied joint-major once and every per-joint sum is a row sum of
those copies; the pooled sums use the free flat views.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_ddof, check_n_params, check_noise_model
from ._common import finite_pair
from .fit import fit_parts, fit_values, r2_values, uniform_average, vaf_values, variance_weighted
from .information import assemble, fit_term
from .norms import joint_major, moments, pooled, sumsq


def compute_metrics(meas, pred, n_params, ddof, noise_model) -> dict:
    """All report metrics for ``tau_meas``/``tau_pred``; see contract §5.1 for the fields.

    Unlike :func:`information_criteria`, ``n_params >= n − 1`` does not raise: aicc and fpe
    are nan there.
    """
    meas, pred = finite_pair(meas, pred)
    n, m = meas.shape
    p = check_n_params(n_params)
    ddof = check_ddof(ddof, n)
    noise_model = check_noise_model(noise_model)

    e = meas - pred
    error = joint_major(e)
    mean_e, ssc_e, e_constant = moments(error)
    # max|e| from the extremes: two reads, no temporary |e|.
    max_abs = np.maximum(np.abs(error.min(axis=1)), np.abs(error.max(axis=1)))
    sse = sumsq(error)
    _, tss, constant = moments(joint_major(meas))
    parts = {"sse": sse, "tss": tss, "ssc_e": ssc_e, "constant": constant, "e_constant": e_constant}
    sse_total = float(np.sum(sse))
    flat = fit_parts(pooled(meas), pooled(e), error_terms=("ssc_e",))
    flat["sse"] = np.array([sse_total])
    rmse = np.sqrt(sse / n)
    vaf, fit, r2 = vaf_values(parts), fit_values(parts), r2_values(parts)
    f, n_ic, n_vec, size = fit_term(e, noise_model, sse)

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
        "residual_variance": parts["ssc_e"] / (n - ddof),
        "constant_target": constant.copy(),
        "sse_total": sse_total,
        "rmse_per_element": math.sqrt(sse_total / (n * m)),
        "rmse_per_sample": math.sqrt(sse_total / n),
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
    out.update(assemble(f, n_vec, n_ic, p, size))
    return out
