"""Family streaming: the metrics of a mergeable accumulator fed the rows in blocks (contract §4.1).

Every expected value is the in-memory one on the whole series, computed by the other families'
builders: how the port splits, feeds and merges (the ``chunks`` and ``merge`` conventions) must
not change any number beyond the tolerance. The family is optional for ports and holds its own
invalid vectors.
"""

from __future__ import annotations

from ._config import RTOL
from ._exact import css, f64, mmean, resid_cols
from ._family import Family
from ._inputs import Stream, predict, q, scale_comment, scaled, trajectory
from ._json import arr, mat, num
from .autocorrelation import acf_expected
from .cross_correlation import regressor, xcorr_expected
from .information_criteria import criteria_values
from .normalized_fit import aggregate
from .norms import norm_metric

MERGES = ("none", "left", "right", "tree")


def accumulate_expected(meas, pred, n_params: int, max_lag: int, segments, noise_model: str, Y=None):
    """Expected outputs and tolerances of ``accumulate``: the in-memory operations on the whole series."""
    n = len(meas)
    ec = resid_cols(meas, pred)
    m = len(ec)
    exp: dict = {}
    tol: dict = {}
    for op in ("sse", "rmse", "max_abs_error"):
        value, t = norm_metric(op, meas, pred, "raw_values", None)
        exp[op], tol[op] = arr(value, [m]), t
    for kind in ("vaf", "fit_percent", "r2"):
        value, t = aggregate(kind, meas, pred, "raw_values")
        exp[kind], tol[kind] = arr(value, [m]), t
    big = f64(max(abs(x) for c in ec for x in c))
    exp["residual_mean"], tol["residual_mean"] = arr([mmean(c) for c in ec], [m]), RTOL * big
    var = [css(c) / (n - 1) for c in ec]
    exp["residual_variance"] = arr(var, [m])
    tol["residual_variance"] = RTOL * f64(max(var)) + (1e-12 * big) ** 2
    values, acf_tol = acf_expected(ec, max_lag, True, segments)
    exp["autocorrelation"], tol["autocorrelation"] = arr(values, [max_lag + 1, m]), acf_tol
    if Y is not None:
        x_exp, x_tol = xcorr_expected(ec, Y, max_lag, True, segments, 0.95)
        exp["rho"], tol["rho"] = x_exp["rho"], x_tol["rho"]
    vals, ic_tol, _ = criteria_values(meas, pred, n_params, noise_model)
    for name in ("aic", "bic", "aicc", "fpe", "naic"):
        exp[name], tol[name] = num(vals[name]), ic_tol[name]
    return exp, tol


def build() -> Family:
    fam = Family("streaming", [
        "accumulate: a port's mergeable accumulator fed tau_meas and tau_pred (and the regressor) in the blocks "
        "of `chunks`, combined as `merge` says, gives the in-memory per-joint metrics, residual statistics, "
        "autocorrelation, cross-correlation and criteria of the whole series (contract §4.1).",
        "Expected values and tolerances are those of the in-memory families on the same data; the family is "
        "optional for ports and holds its own invalid vectors.",
    ])

    def add(comment, flags, meas, pred, chunks, merge, max_lag, segments=None, noise_model="pooled", n_params=4,
            Y=None):
        exp, tol = accumulate_expected(meas, pred, n_params, max_lag, segments, noise_model, Y)
        inputs = {"tau_meas": mat(meas), "tau_pred": mat(pred)}
        if Y is not None:
            inputs["regressor"] = arr([x for row in Y for joint in row for x in joint], [len(Y), len(Y[0]),
                                                                                        len(Y[0][0])])
        inputs.update({"n_params": n_params, "max_lag": max_lag})
        conventions = {"chunks": chunks, "merge": merge, "segments": segments, "noise_model": noise_model,
                       "nan_policy": "raise"}
        fam.add("accumulate", conventions, comment, flags, inputs, exp, tol)

    s = Stream(901)
    meas = trajectory(s, 40, 2, [1.5, -4.0], [2.0, 6.0])
    pred = predict(s, meas, [0.05, 0.3], ar=0.6)
    add("two joints, N = 40, one block: the in-memory values", ["Streaming", "Basic"], meas, pred, [40], "none", 5)
    for merge in MERGES:
        add(f"two joints, N = 40, blocks 7, 1, 13, 19, merge {merge}", ["Streaming", "MergeOrder"], meas, pred,
            [7, 1, 13, 19], merge, 5)
    add("two joints, N = 40, forty one-row blocks merged pairwise", ["Streaming", "ShortBlocks", "MergeOrder"],
        meas, pred, [1] * 40, "tree", 5)
    short = [3, 2, 4, 1, 6, 2, 3, 5, 7, 7]
    for merge in ("none", "tree", "right"):
        add(f"blocks of 1 to 7 rows, shorter than max_lag = 8, merge {merge}", ["Streaming", "ShortBlocks"], meas,
            pred, short, merge, 8)
    for merge in ("none", "left", "tree"):
        add(f"records of 15 and 25 rows, a block starting at the record boundary, merge {merge}",
            ["Streaming", "Segments", "BlockAtRecordBoundary"], meas, pred, [10, 5, 12, 13], merge, 6, [15, 25])
    for merge in ("none", "right"):
        add(f"records of 15 and 25 rows, the boundary inside a block, merge {merge}", ["Streaming", "Segments"],
            meas, pred, [9, 22, 9], merge, 6, [15, 25])
    add("records given by their starts 0 and 20, merge tree", ["Streaming", "SegmentStarts"], meas, pred,
        [6, 6, 6, 6, 6, 10], "tree", 4, [0, 20])

    # Three joints with a regressor: the streaming form of the cross-correlation.
    s = Stream(902)
    meas3 = trajectory(s, 36, 3, [0.0, 2.0, -1.0], [1.0, 3.0, 0.5])
    pred3 = predict(s, meas3, [0.1, 0.2, 0.05], ar=0.4)
    Y = regressor(s, 36, 3, 2)
    for noise_model, merge in (("pooled", "none"), ("per_joint", "left"), ("full", "tree")):
        add(f"three joints and a regressor of 2 columns, blocks 5, 11, 20, noise model {noise_model}, merge {merge}",
            ["Streaming", "MergeOrder"], meas3, pred3, [5, 11, 20], merge, 4, None, noise_model, 6, Y)
    add("three joints and a regressor, records of 12 and 24, blocks 4, 8, 3, 21, merge right",
        ["Streaming", "Segments", "BlockAtRecordBoundary"], meas3, pred3, [4, 8, 3, 21], "right", 3, [12, 24],
        "per_joint", 6, Y)

    # A large common offset: sums about the first rows lose everything unless they are centred.
    s = Stream(903)
    base = trajectory(s, 40, 1, [0.0], [1.0])
    big = [[q(1e7 + r[0])] for r in base]
    big_pred = [[q(v[0] - 0.01 * x, 12)] for v, x in zip(big, s.noise(40, 1.0))]
    for merge in ("none", "right"):
        add(f"torques 1e7 + O(1) with residuals of 0.01, blocks 17 and 23, merge {merge}",
            ["Streaming", "LargeOffset"], big, big_pred, [17, 23], merge, 3)

    # Invalid vectors: the driver's own parameters, then the rules shared with the in-memory operations.
    conv = {"chunks": [7, 1, 13, 19], "merge": "left", "segments": None, "noise_model": "pooled",
            "nan_policy": "raise"}
    good = {"tau_meas": mat(meas), "tau_pred": mat(pred), "n_params": 4, "max_lag": 5}

    def err(comment, changes, inputs, kind):
        fam.add("accumulate", {**conv, **changes}, comment, ["Streaming", kind], inputs, {"error": kind},
                result="invalid")

    err("blocks summing to 39 for N = 40", {"chunks": [7, 1, 13, 18]}, good, "InvalidParameter")
    err("a block of length 0", {"chunks": [7, 0, 14, 19]}, good, "InvalidParameter")
    err("chunks not a list", {"chunks": None}, good, "InvalidParameter")
    err("merge \"sideways\"", {"merge": "sideways"}, good, "InvalidParameter")
    err("max_lag = 25 with records of 15 and 25 rows (it must be below the longest, 25)", {"segments": [15, 25]},
        {**good, "max_lag": 25}, "InvalidParameter")
    err("tau_pred with one joint fewer", {}, {**good, "tau_pred": mat([r[:1] for r in pred])}, "ShapeMismatch")
    err("a NaN in the last block", {}, {**good, "tau_meas": mat(meas[:-1] + [[meas[-1][0], float("nan")]])},
        "NonFiniteInput")
    err("one sample", {"chunks": [1]}, {**good, "tau_meas": mat(meas[:1]), "tau_pred": mat(pred[:1])},
        "TooFewSamples")
    err("a regressor with 39 rows", {}, {**good, "regressor": arr([0.5] * 39 * 2 * 2, [39, 2, 2])}, "ShapeMismatch")
    # operations.json lists only "raise": "omit" is refused, after the data checks (a NaN is still
    # NonFiniteInput), so that every port's accumulator is held to the same policy.
    err("nan_policy \"omit\", which accumulate does not take", {"nan_policy": "omit"}, good, "InvalidParameter")
    err("nan_policy \"omit\" with a NaN in the data: the data checks come first", {"nan_policy": "omit"},
        {**good, "tau_pred": mat(pred[:3] + [[float("nan"), pred[3][1]]] + pred[4:])}, "NonFiniteInput")

    # StreamedScale (appended last so that the tcIds above stay): the three joints and their regressor
    # scaled, the residual far from the regressor (1e90 against 1e70: R_e(0)·R_Y(0) overflows) or both
    # tiny (1e-90, 1e-100: it underflows; 1e-200: the residual's squares do). Streamed sums must be
    # scaled by a power of two per column, with merges exact (contract §4.1).
    for factor, y_factor, merge in ((1e90, 1e70, "tree"), (1e-90, 1e-90, "left"), (1e-100, 1e-100, "right"),
                                    (1e-200, 1.0, "none")):
        add(f"three joints {scale_comment(factor)}, the regressor by {y_factor:g}, blocks 5, 11, 20, merge {merge}",
            ["Streaming", "StreamedScale", "MergeOrder"], scaled(meas3, factor), scaled(pred3, factor),
            [5, 11, 20], merge, 4, None, "per_joint", 6, scaled(Y, y_factor))
    return fam
