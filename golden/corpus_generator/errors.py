"""Family errors: the error kind each operation must raise, and the check order (contract §2)."""

from __future__ import annotations

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._family import Family
from ._json import arr, mat, num
from .autocorrelation import acf_expected
from .information_criteria import ic_terms

NAN_F = float("nan")


def build() -> Family:
    fam = Family("errors", [
        "Invalid input: the error kind each operation must raise, and the check order type -> shape -> size -> "
        "finiteness -> parameters (contract §2). Kinds only; the message texts are a contract of the Python and "
        "C++ APIs.",
    ])
    good = mat([[1.0, 2.0], [2.0, 1.0], [0.5, 3.0]])
    good2 = mat([[1.5, 2.0], [2.5, 0.5], [0.0, 3.5]])
    e_good = mat([[0.5, 0.0], [-0.5, 0.5], [0.5, -0.5], [0.25, 0.0], [-0.25, 1.0]])

    def err(op, conventions, comment, flags, inputs, kind):
        fam.add(op, conventions, comment, flags, inputs, {"error": kind}, result="invalid")

    pooled = {"multioutput": "pooled", "nan_policy": "raise"}
    # InvalidType
    for op in ("r2", "rmse", "sse"):
        conv = {**pooled, **({"convention": None} if op == "rmse" else {})}
        err(op, conv, "tau_meas is null", ["InvalidType"], {"tau_meas": None, "tau_pred": good}, "InvalidType")
        err(op, conv, "tau_pred is null", ["InvalidType"], {"tau_meas": good, "tau_pred": None}, "InvalidType")
    err("autocorrelation", {"adjusted": True, "segments": None, "nan_policy": "raise"}, "e is null",
        ["InvalidType"], {"e": None, "max_lag": 1}, "InvalidType")
    # InvalidShape
    three_d = arr([1.0] * 8, [2, 2, 2])
    for op in ("r2", "vaf", "max_abs_error"):
        err(op, pooled, "tau_meas is 3-D (2, 2, 2)", ["InvalidShape"], {"tau_meas": three_d, "tau_pred": three_d},
            "InvalidShape")
        err(op, pooled, "zero columns (3, 0)", ["InvalidShape"],
            {"tau_meas": arr([], [3, 0]), "tau_pred": arr([], [3, 0])}, "InvalidShape")
    err("r2", pooled, "0-D input", ["InvalidShape"], {"tau_meas": arr([1.0], []), "tau_pred": arr([1.0], [])},
        "InvalidShape")
    err("residual_variance", {"ddof": 1, "nan_policy": "raise"}, "e is 3-D", ["InvalidShape"], {"e": three_d},
        "InvalidShape")
    err("cross_correlation", {"adjusted": True, "level": 0.95, "segments": None, "nan_policy": "raise"},
        "regressor 1-D", ["InvalidShape"], {"e": e_good, "regressor": arr([1.0] * 5, [5]), "max_lag": 1},
        "InvalidShape")
    # ShapeMismatch
    for op in ("r2", "rmse", "residuals", "criteria"):
        conv = dict(pooled)
        if op == "rmse":
            conv["convention"] = None
        if op == "residuals":
            conv = {"nan_policy": "raise"}
        inputs = {"tau_meas": good, "tau_pred": mat([[1.0, 2.0], [2.0, 1.0]])}
        if op == "criteria":
            conv = {"noise_model": "pooled", "nan_policy": "raise"}
            inputs["n_params"] = 1
        err(op, conv, "(3, 2) vs (2, 2)", ["ShapeMismatch"], inputs, "ShapeMismatch")
    err("r2", pooled, "(3, 2) vs (3, 1)", ["ShapeMismatch"],
        {"tau_meas": good, "tau_pred": mat([[1.0], [2.0], [3.0]])}, "ShapeMismatch")
    err("r2", pooled, "(3,) vs (3, 2): promotion gives (3, 1)", ["ShapeMismatch"],
        {"tau_meas": arr([1.0, 2.0, 3.0], [3]), "tau_pred": good}, "ShapeMismatch")
    xconv = {"adjusted": True, "level": 0.95, "segments": None, "nan_policy": "raise"}
    err("cross_correlation", xconv, "regressor (4, 2, 3) for e of 5 samples", ["ShapeMismatch"],
        {"e": e_good, "regressor": arr([1.0] * 24, [4, 2, 3]), "max_lag": 1}, "ShapeMismatch")
    err("cross_correlation", xconv, "regressor (5, 3, 2) for e with 2 joints", ["ShapeMismatch"],
        {"e": e_good, "regressor": arr([1.0] * 30, [5, 3, 2]), "max_lag": 1}, "ShapeMismatch")
    err("cross_correlation", xconv, "stacked regressor with 9 rows, N*m = 10", ["ShapeMismatch", "StackedRegressor"],
        {"e": e_good, "regressor": arr([1.0] * 18, [9, 2]), "max_lag": 1, "n_joints": 2}, "ShapeMismatch")
    # TooFewSamples
    one = mat([[1.0, 2.0]])
    for op in ("r2", "vaf", "fit_percent"):
        err(op, pooled, "N = 1 (minimum 2)", ["TooFewSamples"], {"tau_meas": one, "tau_pred": one},
            "TooFewSamples")
    for op, conv in (("residual_variance", {"ddof": 0, "nan_policy": "raise"}),
                     ("zero_mean_test", {"segments": None, "nan_policy": "raise"})):
        err(op, conv, "N = 1 (minimum 2)", ["TooFewSamples"], {"e": one}, "TooFewSamples")
    err("autocorrelation", {"adjusted": True, "segments": None, "nan_policy": "raise"}, "N = 1, max_lag = 0",
        ["TooFewSamples"], {"e": one, "max_lag": 0}, "TooFewSamples")
    for test in ("ljung_box", "box_pierce"):
        err(test, {"model_df": 0, "segments": None, "nan_policy": "raise"}, "N = 1", ["TooFewSamples"],
            {"e": one, "lags": 1}, "TooFewSamples")
    for op in ("aic", "bic"):
        err(op, {"noise_model": "pooled", "nan_policy": "raise"}, "N = 1", ["TooFewSamples"],
            {"tau_meas": one, "tau_pred": one, "n_params": 0}, "TooFewSamples")
    empty = arr([], [0, 2])
    for op in ("sse", "residuals"):
        conv = pooled if op == "sse" else {"nan_policy": "raise"}
        err(op, conv, "N = 0 (minimum 1)", ["TooFewSamples"], {"tau_meas": empty, "tau_pred": empty},
            "TooFewSamples")
    err("r2", {"multioutput": "pooled", "nan_policy": "omit"}, "nan_policy omit leaves one row (minimum 2)",
        ["TooFewSamples", "NanOmit"],
        {"tau_meas": mat([[1.0], [NAN_F], [3.0]]), "tau_pred": mat([[1.0], [2.0], [float("inf")]])},
        "TooFewSamples")
    # NonFiniteInput
    bad_nan = mat([[1.0, 2.0], [NAN_F, 1.0], [0.5, 3.0]])
    bad_inf = mat([[1.0, 2.0], [2.0, 1.0], [0.5, float("-inf")]])
    for op in ("r2", "sse", "max_abs_error", "residuals"):
        conv = pooled if op != "residuals" else {"nan_policy": "raise"}
        err(op, conv, "NaN in tau_meas", ["NonFiniteInput"], {"tau_meas": bad_nan, "tau_pred": good2},
            "NonFiniteInput")
        err(op, conv, "-Infinity in tau_pred", ["NonFiniteInput"], {"tau_meas": good, "tau_pred": bad_inf},
            "NonFiniteInput")
    err("autocorrelation", {"adjusted": True, "segments": None, "nan_policy": "raise"}, "Infinity in e",
        ["NonFiniteInput"], {"e": arr([1.0, float("inf"), 2.0, 0.0], [4, 1]), "max_lag": 1}, "NonFiniteInput")
    err("cross_correlation", xconv, "NaN in regressor", ["NonFiniteInput"],
        {"e": e_good, "regressor": arr([1.0, 2.0] * 9 + [NAN_F, 1.0], [5, 2, 2]), "max_lag": 1}, "NonFiniteInput")
    # InvalidParameter
    err("r2", {"multioutput": "mean", "nan_policy": "raise"}, "unknown multioutput", ["InvalidParameter"],
        {"tau_meas": good, "tau_pred": good2}, "InvalidParameter")
    err("sse", {"multioutput": "uniform_average", "nan_policy": "raise"}, "sse has no uniform_average",
        ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2}, "InvalidParameter")
    err("max_abs_error", {"multioutput": "variance_weighted", "nan_policy": "raise"},
        "max_abs_error has no variance_weighted", ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2},
        "InvalidParameter")
    err("rmse", {"multioutput": "variance_weighted", "convention": None, "nan_policy": "raise"},
        "rmse has no variance_weighted", ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2},
        "InvalidParameter")
    err("rmse", {"multioutput": "raw_values", "convention": "per_sample", "nan_policy": "raise"},
        "convention with raw_values", ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2},
        "InvalidParameter")
    err("rmse", {"multioutput": "pooled", "convention": "per_joint", "nan_policy": "raise"}, "unknown convention",
        ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2}, "InvalidParameter")
    err("r2", {"multioutput": "pooled", "nan_policy": "ignore"}, "unknown nan_policy", ["InvalidParameter"],
        {"tau_meas": good, "tau_pred": good2}, "InvalidParameter")
    for ddof, comment in ((-1, "ddof = -1"), (5, "ddof = N = 5"), (7, "ddof > N")):
        err("residual_variance", {"ddof": ddof, "nan_policy": "raise"}, comment, ["InvalidParameter"],
            {"e": e_good}, "InvalidParameter")
    aconv = {"adjusted": True, "segments": None, "nan_policy": "raise"}
    for L, comment in ((5, "max_lag = N = 5"), (-1, "max_lag = -1"), (9, "max_lag > N")):
        err("autocorrelation", aconv, comment, ["InvalidParameter"], {"e": e_good, "max_lag": L},
            "InvalidParameter")
    err("autocorrelation", {"adjusted": True, "segments": [2, 3], "nan_policy": "raise"},
        "max_lag = 3 not below the longest segment (3)", ["InvalidParameter", "Segments"],
        {"e": e_good, "max_lag": 3}, "InvalidParameter")
    for segs, comment in (([2, 2], "lengths summing to 4, N = 5"), ([0, 5], "start 5 not below N = 5"),
                          ([0, 3, 2], "starts not increasing"), ([3, 0, 2], "a zero length"),
                          ([1, 4, 0], "lengths with a trailing zero"), ([], "empty")):
        err("autocorrelation", {"adjusted": True, "segments": segs, "nan_policy": "raise"},
            f"invalid segments: {comment}", ["InvalidParameter", "Segments"], {"e": e_good, "max_lag": 1},
            "InvalidParameter")
    err("autocorrelation", {"adjusted": "yes", "segments": None, "nan_policy": "raise"}, "adjusted is a string",
        ["InvalidParameter"], {"e": e_good, "max_lag": 1}, "InvalidParameter")
    pconv = {"model_df": 0, "segments": None, "nan_policy": "raise"}
    for lags, comment in ((0, "lags = 0"), ([], "empty lags"), ([2, 5], "lag 5 = N"), (-1, "lags = -1")):
        err("ljung_box", pconv, comment, ["InvalidParameter"], {"e": e_good, "lags": lags}, "InvalidParameter")
    for model_df, lags, comment in ((2, 2, "model_df = lags"), (3, [4, 2], "model_df above the smallest lag"),
                                    (-1, 2, "model_df = -1")):
        err("box_pierce", {"model_df": model_df, "segments": None, "nan_policy": "raise"}, comment,
            ["InvalidParameter", "ModelDf"], {"e": e_good, "lags": lags}, "InvalidParameter")
    for level in (0.0, 1.0, 1.5, -0.5):
        err("confidence_band", {"level": level}, f"level = {level}", ["InvalidParameter"], {"n": 10},
            "InvalidParameter")
    err("confidence_band", {"level": 0.95}, "n = 0", ["InvalidParameter"], {"n": 0}, "InvalidParameter")
    err("cross_correlation", {"adjusted": True, "level": 1.0, "segments": None, "nan_policy": "raise"},
        "level = 1", ["InvalidParameter"],
        {"e": e_good, "regressor": arr([float(k % 3) for k in range(20)], [5, 2, 2]), "max_lag": 1},
        "InvalidParameter")
    cconv = {"noise_model": "pooled", "nan_policy": "raise"}
    err("criteria", {"noise_model": "diagonal", "nan_policy": "raise"}, "unknown noise model",
        ["InvalidParameter", "NoiseModel"], {"tau_meas": good, "tau_pred": good2, "n_params": 1}, "InvalidParameter")
    err("aic", cconv, "n_params = -1", ["InvalidParameter"], {"tau_meas": good, "tau_pred": good2, "n_params": -1},
        "InvalidParameter")
    for rss, nobs, p, comment in ((10.0, 1000, -1, "n_params = -1"), (10.0, 0, 0, "n_obs = 0"),
                                  (-1.0, 10, 1, "rss < 0"), (NAN_F, 10, 1, "rss NaN (a parameter: not NonFiniteInput)"),
                                  (float("inf"), 10, 1, "rss infinite"), (1.0, 10, 9, "n_params = n_obs - 1"),
                                  (1.0, 10, 12, "n_params > n_obs"), (1.0, 1, 0, "n_obs = 1: p = 0 = n - 1")):
        err("information_criteria", {}, comment, ["InvalidParameter"] + (["ParamsNearN"] if p >= nobs - 1 >= 0
                                                                          and p >= 0 else []),
            {"rss": rss, "n_obs": nobs, "n_params": p}, "InvalidParameter")
    # Integers only: booleans and integral floats.
    err("autocorrelation", aconv, "max_lag = true", ["InvalidParameter", "IntegerParameter"],
        {"e": e_good, "max_lag": True}, "InvalidParameter")
    err("residual_variance", {"ddof": True, "nan_policy": "raise"}, "ddof = true",
        ["InvalidParameter", "IntegerParameter"], {"e": e_good}, "InvalidParameter")
    rho2, tol2 = acf_expected([[0.5, -0.5, 0.5, 0.25, -0.25], [0.0, 0.5, -0.5, 0.0, 1.0]], 2, True, None)
    fam.add("autocorrelation", aconv, "max_lag = 2.0 (integral float): InvalidParameter in typed APIs",
            ["IntegerParameter"], {"e": e_good, "max_lag": 2.0},
            {"value": arr(rho2, [3, 2]), "error": "InvalidParameter"}, {"value": tol2}, result="acceptable")
    vals, tol = ic_terms(10 * mpmath.log(mpf(1) / 10), 10, 10, mpf(1) / 10, 2, True)
    fam.add("information_criteria", {}, "n_params = 2.0 (integral float): InvalidParameter in typed APIs",
            ["IntegerParameter"], {"rss": 1.0, "n_obs": 10, "n_params": 2.0},
            {**{k: num(v) for k, v in vals.items()}, "error": "InvalidParameter"}, tol, result="acceptable")
    # Check order: the first failing step wins.
    err("r2", pooled, "tau_meas 3-D and tau_pred null: type before shape", ["CheckOrder", "InvalidType"],
        {"tau_meas": three_d, "tau_pred": None}, "InvalidType")
    err("r2", pooled, "zero columns and shape mismatch: shape of tau_meas first", ["CheckOrder", "InvalidShape"],
        {"tau_meas": arr([], [3, 0]), "tau_pred": mat([[1.0], [2.0]])}, "InvalidShape")
    err("r2", pooled, "shape mismatch and NaN: shape before finiteness", ["CheckOrder", "ShapeMismatch"],
        {"tau_meas": bad_nan, "tau_pred": mat([[1.0, 2.0], [2.0, 1.0]])}, "ShapeMismatch")
    err("r2", pooled, "N = 1 with NaN: size before finiteness", ["CheckOrder", "TooFewSamples"],
        {"tau_meas": mat([[NAN_F]]), "tau_pred": mat([[1.0]])}, "TooFewSamples")
    err("r2", {"multioutput": "bogus", "nan_policy": "raise"}, "NaN and unknown multioutput: finiteness before "
        "parameters", ["CheckOrder", "NonFiniteInput"], {"tau_meas": bad_nan, "tau_pred": good2}, "NonFiniteInput")
    err("r2", {"multioutput": "bogus", "nan_policy": "raise"}, "N = 1 and unknown multioutput: size before "
        "parameters", ["CheckOrder", "TooFewSamples"], {"tau_meas": one, "tau_pred": one}, "TooFewSamples")
    err("autocorrelation", aconv, "NaN and max_lag = N: finiteness before parameters",
        ["CheckOrder", "NonFiniteInput"], {"e": arr([1.0, 2.0, NAN_F], [3, 1]), "max_lag": 3}, "NonFiniteInput")
    err("residual_variance", {"ddof": 3, "nan_policy": "raise"}, "N = 1 and ddof too large: size first",
        ["CheckOrder", "TooFewSamples"], {"e": arr([1.0], [1, 1])}, "TooFewSamples")
    err("ljung_box", {"model_df": 5, "segments": None, "nan_policy": "raise"},
        "Infinity in e and model_df too large: finiteness first", ["CheckOrder", "NonFiniteInput"],
        {"e": arr([1.0, float("inf"), 0.0, 1.0], [4, 1]), "lags": 2}, "NonFiniteInput")
    err("cross_correlation", xconv, "regressor shape mismatch and NaN in e: shape first",
        ["CheckOrder", "ShapeMismatch"],
        {"e": arr([NAN_F, 1.0, 0.0, 1.0], [4, 1]), "regressor": arr([1.0] * 10, [5, 1, 2]), "max_lag": 1},
        "ShapeMismatch")
    err("cross_correlation", xconv, "NaN in e and in regressor: e is checked first (argument order)",
        ["CheckOrder", "NonFiniteInput"],
        {"e": arr([1.0, NAN_F, 0.0, 1.0], [4, 1]), "regressor": arr([NAN_F] + [1.0] * 7, [4, 1, 2]), "max_lag": 9},
        "NonFiniteInput")
    err("sse", {"multioutput": "pooled", "nan_policy": "raise"}, "null tau_pred and N = 0: type first",
        ["CheckOrder", "InvalidType"], {"tau_meas": arr([], [0, 1]), "tau_pred": None}, "InvalidType")
    # Out-of-range values (|x| > 1e144) and integers beyond int64; appended last so tcIds stay stable.
    huge_pred = mat([[1.0, 2.0], [2.0, -3e200], [0.5, 3.0]])
    for op in ("r2", "sse", "residuals", "vaf"):
        conv = pooled if op != "residuals" else {"nan_policy": "raise"}
        err(op, conv, "-3e200 in tau_pred (|x| > 1e144)", ["NonFiniteInput", "OutOfRange"],
            {"tau_meas": good, "tau_pred": huge_pred}, "NonFiniteInput")
    err("r2", pooled, "1e145 in tau_meas", ["NonFiniteInput", "OutOfRange"],
        {"tau_meas": mat([[1.0, 2.0], [1e145, 1.0], [0.5, 3.0]]), "tau_pred": good2}, "NonFiniteInput")
    err("autocorrelation", aconv, "1e150 in e", ["NonFiniteInput", "OutOfRange"],
        {"e": arr([1.0, 1e150, 2.0, 0.0], [4, 1]), "max_lag": 1}, "NonFiniteInput")
    err("cross_correlation", xconv, "-1e300 in the regressor", ["NonFiniteInput", "OutOfRange"],
        {"e": e_good, "regressor": arr([1.0, 2.0] * 9 + [-1e300, 1.0], [5, 2, 2]), "max_lag": 1}, "NonFiniteInput")
    err("r2", {"multioutput": "bogus", "nan_policy": "raise"}, "1e200 and unknown multioutput: finiteness first",
        ["CheckOrder", "NonFiniteInput", "OutOfRange"], {"tau_meas": good, "tau_pred": huge_pred}, "NonFiniteInput")
    err("r2", {"multioutput": "pooled", "nan_policy": "omit"}, "nan_policy omit deletes the 1e200 row and the NaN "
        "row, leaving one (minimum 2)", ["TooFewSamples", "NanOmit", "OutOfRange"],
        {"tau_meas": mat([[1.0], [NAN_F], [3.0]]), "tau_pred": mat([[1.0], [2.0], [1e200]])}, "TooFewSamples")
    bound = float("1e144")
    sse_bound = 2 * mpf(bound) ** 2
    fam.add("sse", pooled, "|x| = 1e144 exactly is in range: SSE = 2·(1e144)²", ["OutOfRange"],
            {"tau_meas": mat([[bound], [-bound], [0.0]]), "tau_pred": mat([[0.0], [0.0], [0.0]])},
            {"value": num(sse_bound)}, {"value": num(RTOL * sse_bound)})
    for value in (2**63, -(2**63) - 1):
        err("aic", cconv, f"n_params = {value} does not fit in int64", ["InvalidParameter", "Int64Parameter"],
            {"tau_meas": good, "tau_pred": good2, "n_params": value}, "InvalidParameter")
    return fam
