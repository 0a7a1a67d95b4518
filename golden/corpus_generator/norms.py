"""Family norms: residuals, SSE, RMSE and maximum absolute error (contract §3.1)."""

from __future__ import annotations

from typing import Any

import mpmath

from ._config import RTOL
from ._exact import f64, msum, resid_cols, rows_of
from ._family import Family, out
from ._inputs import EXTREME_SCALES, Stream, enc_signal, metric_datasets, predict, scale_comment, scaled, trajectory
from ._json import arr, mat


def norm_metric(op: str, meas, pred, multioutput: str, convention: str | None) -> tuple[Any, float]:
    ec = resid_cols(meas, pred)
    n, m = len(meas), len(ec)
    sse = [msum(x * x for x in c) for c in ec]
    mx = [max(abs(x) for x in c) for c in ec]
    big = f64(max(mx))
    if op == "sse":
        v = msum(sse) if multioutput == "pooled" else sse
        return v, RTOL * f64(msum(sse))
    if op == "max_abs_error":
        return (max(mx) if multioutput == "pooled" else mx), RTOL * big
    if op == "rmse":
        per = [mpmath.sqrt(s / n) for s in sse]
        if multioutput == "pooled":
            d = n * m if convention in (None, "per_element") else n
            v = mpmath.sqrt(msum(sse) / d)
            return v, RTOL * f64(v)
        if multioutput == "raw_values":
            return per, RTOL * f64(max(per))
        return msum(per) / m, RTOL * f64(max(per))
    raise ValueError(op)


def build() -> Family:
    fam = Family("norms", [
        "Residuals, SSE, RMSE and maximum absolute error (contract §3.1).",
        "Inputs tau_meas, tau_pred: arrays (N, m) or (N,), row-major; e = tau_meas - tau_pred.",
        "Tolerance: RTOL * natural size (SSE for sse, the value for rmse, max |e| for max_abs_error and residuals).",
    ])
    for d in metric_datasets():
        meas, pred = d["meas"], d["pred"]
        n = len(meas)
        inputs = {"tau_meas": enc_signal(d, "meas"), "tau_pred": enc_signal(d, "pred")}
        ec = resid_cols(meas, pred)
        e_rows = rows_of(ec)
        shape = [n] if d["one_d"] else [n, len(ec)]
        big = max(abs(x) for c in ec for x in c)
        fam.add("residuals", {"nan_policy": "raise"}, d["comment"], d["flags"], inputs,
                {"value": arr([v for r in e_rows for v in r], shape)}, {"value": RTOL * f64(big)})
        for op, mos in (("sse", ["pooled", "raw_values"]), ("max_abs_error", ["pooled", "raw_values"]),
                        ("rmse", ["pooled", "raw_values", "uniform_average"])):
            for mo in mos:
                convs = [None] if (op != "rmse" or mo != "pooled") else ["per_element", "per_sample"]
                for conv in convs:
                    conventions = {"multioutput": mo}
                    if op == "rmse":
                        conventions["convention"] = conv
                    conventions["nan_policy"] = "raise"
                    v, tol = norm_metric(op, meas, pred, mo, conv)
                    flags = list(d["flags"])
                    if op == "rmse" and mo == "pooled":
                        flags.append("RmsePerElement" if conv == "per_element" else "RmsePerSample")
                    fam.add(op, conventions, d["comment"], flags, inputs, {"value": out(v)}, {"value": tol})
    # N = 1 is allowed for sums and norms.
    for op in ("sse", "max_abs_error", "rmse"):
        conventions = {"multioutput": "pooled", **({"convention": "per_element"} if op == "rmse" else {}),
                       "nan_policy": "raise"}
        meas, pred = [[3.0, -1.0]], [[2.5, 1.0]]
        v, tol = norm_metric(op, meas, pred, "pooled", "per_element")
        fam.add(op, conventions, "one sample, two joints (minimum N = 1)", ["MinimumSamples"],
                {"tau_meas": mat(meas), "tau_pred": mat(pred)}, {"value": out(v)}, {"value": tol})
    # ExtremeScale: SSE only where it is itself a normal float64 (it underflows near 1e-162).
    s = Stream(151)
    base_meas = trajectory(s, 30, 2, [1.0, -2.0], [2.0, 1.0])
    base_pred = predict(s, base_meas, [0.3, 0.2])
    for factor in EXTREME_SCALES:
        meas, pred = scaled(base_meas, factor), scaled(base_pred, factor)
        inputs = {"tau_meas": mat(meas), "tau_pred": mat(pred)}
        ops = [("rmse", "pooled", "per_element"), ("rmse", "pooled", "per_sample"), ("rmse", "raw_values", None),
               ("max_abs_error", "raw_values", None)]
        if 1e-150 <= factor <= 1e140:
            ops.append(("sse", "raw_values", None))
        for op, mo, conv in ops:
            conventions = {"multioutput": mo, **({"convention": conv} if op == "rmse" else {}), "nan_policy": "raise"}
            v, tol = norm_metric(op, meas, pred, mo, conv)
            fam.add(op, conventions, scale_comment(factor), ["ExtremeScale"], inputs, {"value": out(v)}, {"value": tol})
    return fam
