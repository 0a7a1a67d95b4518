"""Family normalized_fit: VAF, fit percent and R^2 (contract §3.1, degenerate values §3.2)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._exact import INF, NAN, M, columns, css, f64, ieee_mean, is_const, msum, resid_cols
from ._family import Family, out
from ._inputs import EXTREME_SCALES, Stream, enc_signal, metric_datasets, predict, q, scale_comment, scaled, trajectory
from ._json import mat


def ratio_metric(kind: str, t: Sequence, e: Sequence) -> tuple[mpf, mpf]:
    """Per-joint (or pooled, on flattened lists) r2 / fit_percent / vaf, and its error ratio (for tolerance)."""
    tm = [M(x) for x in t]
    if kind == "vaf":
        num_, exact = css(e), is_const(e)
    else:
        num_ = msum(x * x for x in e)
        exact = num_ == 0
    if is_const(t):
        return (NAN if exact else -INF), mpf(0)
    den = css(tm)
    r = num_ / den
    if kind == "r2":
        return 1 - r, r
    if kind == "fit_percent":
        return 100 * (1 - mpmath.sqrt(r)), mpmath.sqrt(r)
    return 100 * (1 - r), r


def aggregate(kind: str, meas, pred, multioutput: str) -> tuple[Any, float]:
    """Value (mpf or list) and absolute tolerance of r2 / fit_percent / vaf."""
    tc = columns(meas)
    ec = resid_cols(meas, pred)
    unit = 1 if kind == "r2" else 100
    if multioutput == "pooled":
        t = [x for c in tc for x in c]
        e = [x for c in ec for x in c]
        v, r = ratio_metric(kind, t, e)
        return v, RTOL * unit * max(1.0, f64(r))
    per = [ratio_metric(kind, t, e) for t, e in zip(tc, ec)]
    vals = [p[0] for p in per]
    tol = RTOL * unit * max(1.0, max(f64(p[1]) for p in per))
    if multioutput == "raw_values":
        return vals, tol
    if multioutput == "uniform_average":
        return ieee_mean(vals), tol
    weights = [(mpf(0) if is_const(t) else css([M(x) for x in t])) for t in tc]
    if all(w == 0 for w in weights):
        return ieee_mean(vals), tol
    return msum(w * v for w, v in zip(weights, vals) if w != 0) / msum(weights), tol


def build() -> Family:
    fam = Family("normalized_fit", [
        "VAF (percent), fit percent (percent) and R^2 (fraction), contract §3.1 and degenerate values §3.2.",
        "Tolerance: RTOL * unit * max(1, SSE/TSS) (VAF: centred residual SS / TSS; fit: its square root); "
        "unit = 100 for percent.",
    ])
    for d in metric_datasets():
        meas, pred = d["meas"], d["pred"]
        inputs = {"tau_meas": enc_signal(d, "meas"), "tau_pred": enc_signal(d, "pred")}
        for op in ("vaf", "fit_percent", "r2"):
            for mo in ("pooled", "raw_values", "uniform_average", "variance_weighted"):
                v, tol = aggregate(op, meas, pred, mo)
                fam.add(op, {"multioutput": mo, "nan_policy": "raise"}, d["comment"], list(d["flags"]), inputs,
                        {"value": out(v)}, {"value": tol})
    # VAF does not depend on the mean of the residual; r2/fit do (bias in the prediction).
    s = Stream(120)
    meas = trajectory(s, 30, 2, [3.0, -1.0], [2.0, 1.0])
    pred = [[q(r[0] - 0.5 - 0.1 * s.normal()), q(r[1] + 0.3 - 0.05 * s.normal())] for r in meas]
    for op in ("vaf", "r2", "fit_percent"):
        v, tol = aggregate(op, meas, pred, "raw_values")
        fam.add(op, {"multioutput": "raw_values", "nan_policy": "raise"},
                "biased prediction (residual mean 0.5 and -0.3): VAF ignores the bias, r2 and fit do not",
                ["Basic"], {"tau_meas": mat(meas), "tau_pred": mat(pred)}, {"value": out(v)}, {"value": tol})
    # nan_policy = "omit": rows with a NaN anywhere are deleted.
    s = Stream(121)
    meas = trajectory(s, 16, 2, [1.0, 2.0], [1.0, 3.0])
    pred = predict(s, meas, [0.2, 0.3])
    kept = [k for k in range(16) if k not in (3, 10)]
    meas_in = [list(r) for r in meas]
    pred_in = [list(r) for r in pred]
    meas_in[3][1] = float("nan")
    pred_in[10][0] = float("inf")
    for op in ("r2", "vaf", "fit_percent"):
        for mo in ("pooled", "raw_values"):
            v, tol = aggregate(op, [meas[k] for k in kept], [pred[k] for k in kept], mo)
            fam.add(op, {"multioutput": mo, "nan_policy": "omit"},
                    "rows 3 (NaN in tau_meas) and 10 (Infinity in tau_pred) are omitted", ["NanOmit"],
                    {"tau_meas": mat(meas_in), "tau_pred": mat(pred_in)}, {"value": out(v)}, {"value": tol})
    # A constant target whose float mean is inexact: constancy is decided on min = max, not on a
    # rounded TSS (the lesson's ports return -1e31 here instead of -inf).
    meas = [[0.1]] * 10
    pred = [[0.1 + (0.01 if k % 2 else -0.01)] for k in range(10)]
    for op in ("r2", "vaf", "fit_percent"):
        for mo in ("pooled", "raw_values"):
            v, tol = aggregate(op, meas, pred, mo)
            fam.add(op, {"multioutput": mo, "nan_policy": "raise"},
                    "constant target 0.1 (ten samples; its float mean is not exact): -Infinity by min = max",
                    ["ConstantTarget", "InexactConstantMean"], {"tau_meas": mat(meas), "tau_pred": mat(pred)},
                    {"value": out(v)}, {"value": tol})
    # ExtremeScale: ratios of sums of squares that underflow (1e-162) or of data near the bound.
    s = Stream(152)
    base_meas = trajectory(s, 30, 2, [1.0, -2.0], [2.0, 1.0])
    base_pred = predict(s, base_meas, [0.3, 0.2])
    for factor in EXTREME_SCALES:
        meas, pred = scaled(base_meas, factor), scaled(base_pred, factor)
        for op in ("vaf", "fit_percent", "r2"):
            for mo in ("pooled", "raw_values", "variance_weighted"):
                v, tol = aggregate(op, meas, pred, mo)
                fam.add(op, {"multioutput": mo, "nan_policy": "raise"}, scale_comment(factor), ["ExtremeScale"],
                        {"tau_meas": mat(meas), "tau_pred": mat(pred)}, {"value": out(v)}, {"value": tol})
    return fam
