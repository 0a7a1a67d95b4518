"""Flags legend (bugType vocabulary of golden/README.md). Each file carries the notes it uses."""

from __future__ import annotations

from typing import Any

NOTES: dict[str, dict[str, Any]] = {
    "ExtremeScale": {
        "bugType": "NUMERICAL",
        "description": "Ordinary data multiplied by 1e80, 1e-80, 1e140, 1e-150, 1e-162 or 1e-310 (subnormal): "
        "inside the accepted range, where squares or products of sums of squares leave float64 (contract §1.3).",
        "effect": "An implementation that squares before scaling gives R² = 1, RMSE = 0, ρ = 0 or ±inf, or a "
        "Box–Pierce Q of N·h instead of the value at scale 1.",
    },
    "StreamedScale": {
        "bugType": "NUMERICAL",
        "description": "A streamed accumulator fed data at 1e90 with a regressor at 1e70, or at 1e-90, 1e-100 or "
        "1e-200: products of sums of squares (or the squares themselves) leave float64 (contract §1.3, §4.1).",
        "effect": "Streamed sums not held in power-of-two units per column, or a cross-correlation normalised by "
        "the root of the product of the two variances, give ρ = 0, ±inf or NaN, R² = 1 or RMSE = 0.",
    },
    "Basic": {"bugType": "BASIC", "description": "Ordinary, well-conditioned data; every port must pass."},
    "LessonShape": {
        "bugType": "BASIC",
        "description": "The lesson's layout: tau of shape (N, m) with m = 6 joints (or a single joint (N,) for the "
        "autocorrelation with L = 50).",
    },
    "OneDimensional": {
        "bugType": "EDGE_CASE",
        "description": "Inputs of shape (N,): promoted to (N, 1); values identical to the 2-D form, per-joint "
        "results still have shape (1,).",
        "effect": "Ports that squeeze or reject 1-D input give the wrong shape.",
    },
    "MixedPromotion": {
        "bugType": "EDGE_CASE",
        "description": "tau_meas (N,) with tau_pred (N, 1): both are (N, 1) after promotion and must be accepted.",
    },
    "ManyJoints": {"bugType": "EDGE_CASE", "description": "m = 7 joints (a 7-DOF arm)."},
    "MinimumSamples": {
        "bugType": "EDGE_CASE",
        "description": "N is the function's minimum (1 for sums and norms, 2 for normalised and statistical "
        "quantities).",
    },
    "SmallN": {"bugType": "EDGE_CASE", "description": "Very few samples (N = 3 to 5)."},
    "ExactFit": {
        "bugType": "DEGENERATE",
        "description": "tau_pred equals tau_meas: SSE = 0, so rmse = 0, fit = 100, r2 = 1, VAF = 100 and the "
        "criteria are -Infinity (fpe 0).",
    },
    "ConstantTarget": {
        "bugType": "DEGENERATE",
        "description": "The target (a joint, or the whole flattened target for pooled) is constant (min = max): "
        "r2/fit/VAF are -Infinity, or NaN when the prediction is exact (contract §3.2); no sklearn-style clamping.",
        "effect": "Ports that divide by a zero TSS without the rule give +/-inf or NaN at random, or raise.",
    },
    "LessonLogZero": {
        "bugType": "KNOWN_DISCREPANCY",
        "description": "An exact fit reached from data (SSE = 0), as the lesson's code computes it: the criteria "
        "are -Infinity (fpe 0). The lesson's Wolfram code gives 2p + N Log[0.], which Mathics evaluates to "
        "4. + Indeterminate.",
    },
    "InexactConstantMean": {
        "bugType": "KNOWN_DISCREPANCY",
        "description": "A constant target whose float64 mean is not exact (ten values of 0.1): the centred sum of "
        "squares is a few ulps, not 0. The rule decides constancy on min = max, so r2/fit/VAF are -Infinity.",
        "effect": "The lesson's code (TSS == 0 tests, or none) gives r2 near -1e31, VAF near -1e33 and fit near "
        "-4e17 here; every other constant-target vector has an exact mean and cannot show it.",
    },
    "ConstantJoint": {
        "bugType": "DEGENERATE",
        "description": "One joint has a constant target among normal joints: its value is -Infinity, the uniform "
        "average is -Infinity, the variance-weighted average leaves it out (weight 0).",
    },
    "AllJointsConstant": {
        "bugType": "DEGENERATE",
        "description": "Every joint is constant: variance_weighted falls back to the uniform average of the "
        "per-joint values.",
    },
    "ConstantResidual": {
        "bugType": "DEGENERATE",
        "description": "The residual of a joint is constant: VAF counts it as exact; its autocorrelation, "
        "portmanteau statistics and cross-correlation row are NaN.",
    },
    "LargeOffset": {
        "bugType": "NUMERICAL",
        "description": "Signal riding on a large offset (tau = 1e7 + noise) with a small variance.",
        "effect": "One-pass formulas (E[x^2] - E[x]^2, sum of squares minus N mean^2) lose every digit and fail; "
        "two-pass (centred) sums pass.",
    },
    "TinyScale": {"bugType": "NUMERICAL", "description": "Values of order 1e-6 (no absolute thresholds allowed)."},
    "HugeScale": {"bugType": "NUMERICAL", "description": "Values of order 1e6."},
    "MixedScales": {
        "bugType": "CONVENTION",
        "description": "Joints with very different means and scales: pooled values (one global mean over all N*m "
        "values) differ strongly from per-joint and averaged values.",
        "effect": "Ports that pool when they should not (or the reverse) fail by a wide margin.",
    },
    "RmsePerElement": {
        "bugType": "CONVENTION",
        "description": "Pooled RMSE per element, sqrt(SSE/(N*m)): the lesson's formula and the default.",
    },
    "RmsePerSample": {
        "bugType": "CONVENTION",
        "description": "Pooled RMSE per sample, sqrt(SSE/N): what the lesson's code computes "
        "(sqrt(mean(sum(e**2, axis=1)))); larger by sqrt(m).",
    },
    "DdofConvention": {
        "bugType": "CONVENTION",
        "description": "Residual variance with ddof 0 (divide by N) or 1 (divide by N - 1); VAF does not depend "
        "on ddof, the criteria use sigma^2 = SSE/(N*m) (no ddof).",
    },
    "AdjustedAcf": {
        "bugType": "CONVENTION",
        "description": "Adjusted autocorrelation (the lesson): R(l) divided by the number of lag-l products, "
        "R(0) by N; values can exceed the biased ones by N/(N - l).",
    },
    "BiasedAcf": {
        "bugType": "CONVENTION",
        "description": "Biased autocorrelation (NIST StRD, R, statsmodels, Ljung-Box): every R(l) divided by N.",
    },
    "Segments": {
        "bugType": "CONVENTION",
        "description": "Concatenated records given as segment lengths: no lagged product joins two segments, "
        "means stay overall, n_l = sum_s max(n_s - l, 0).",
        "effect": "Ports that ignore segments include products across the joint and fail.",
    },
    "Streaming": {
        "bugType": "CONVENTION",
        "description": "accumulate: the rows reach the port's accumulator in the blocks of `chunks`, combined as "
        "`merge` says; every output equals the in-memory operation on the whole series.",
        "effect": "An accumulator that drops the lagged products across a block junction, restarts its means per "
        "block or merges in the wrong order gives autocorrelations, cross-correlations or variances that "
        "depend on the blocks.",
    },
    "MergeOrder": {
        "bugType": "CONVENTION",
        "description": "The same blocks combined one after another, left to right, right to left or pairwise: "
        "merging must be associative.",
    },
    "ShortBlocks": {
        "bugType": "EDGE_CASE",
        "description": "Blocks shorter than max_lag (down to one row): lagged products span several blocks.",
        "effect": "Ports that keep only the previous block's tail of its own length lose products.",
    },
    "BlockAtRecordBoundary": {
        "bugType": "EDGE_CASE",
        "description": "A record of `segments` starts exactly where a block starts: the break belongs to the "
        "junction of two accumulators.",
        "effect": "Ports that join lags across every junction, or break at every junction, fail.",
    },
    "SegmentStarts": {
        "bugType": "CONVENTION",
        "description": "The same segments given as starts (first element 0); identical values to the lengths form.",
    },
    "MaxLagLimit": {
        "bugType": "EDGE_CASE",
        "description": "max_lag = longest segment - 1 (one lagged product left at the last lag, or none in the "
        "shorter segments).",
    },
    "LagZero": {"bugType": "EDGE_CASE", "description": "max_lag = 0: only rho(0) = 1."},
    "Autocorrelated": {
        "bugType": "BASIC",
        "description": "Coloured residuals (an AR(1) or AR(2) recursion), as robot residuals usually are: large "
        "autocorrelations, small p-values.",
    },
    "ModelDf": {
        "bugType": "CONVENTION",
        "description": "Portmanteau degrees of freedom reduced by model_df: df = h - model_df.",
    },
    "SeveralLags": {
        "bugType": "BASIC",
        "description": "Several lags in one call: one statistic per entry, in the given order (not sorted).",
    },
    "TinyPValue": {
        "bugType": "NUMERICAL",
        "description": "Strongly coloured residuals: the p-value is below 1e-300 (or underflows); log_pvalue "
        "keeps the information.",
        "effect": "log(sf(Q)) gives -Infinity; a proper log survival function gives the finite value.",
    },
    "ConstantColumn": {
        "bugType": "DEGENERATE",
        "description": "A regressor column is constant on a joint: its cross-correlation is NaN and "
        "constant_mask is true there.",
    },
    "StackedRegressor": {
        "bugType": "EDGE_CASE",
        "description": "Regressor stacked sample-major as (N*m, p) with n_joints = m (row k*m + j is sample k, "
        "joint j); same values as the (N, m, p) form.",
    },
    "NoiseModel": {
        "bugType": "CONVENTION",
        "description": "Information criteria under an explicit noise model: pooled (one sigma^2, the lesson), "
        "per_joint (one sigma^2 per joint) or full (MATLAB multi-output, ln det of E'E/N).",
        "effect": "Pooled and per-joint criteria differ by far more than any tolerance when joints have "
        "different noise levels.",
    },
    "LessonProblem4": {
        "bugType": "BASIC",
        "description": "The lesson's Problem 4: N = 1000, RSS1 = 10 with p1 = 6, RSS2 = 8.5 with p2 = 10; at full "
        "precision AIC1 = -4593.170..., AIC2 = -4747.689..., BIC1 = -4563.724..., BIC2 = -4698.612....",
    },
    "LessonSlip": {
        "bugType": "KNOWN_DISCREPANCY",
        "description": "The lesson's approximate values carry a slip: it writes log 0.0085 = -4.7690, the true "
        "value is -4.76769..., so its AIC2/BIC2 are off by about 1.3; the corpus holds the exact values.",
        "links": ["golden/README.md#lesson-problem-4"],
    },
    "ParamsNearN": {
        "bugType": "EDGE_CASE",
        "description": "n_params >= n - 1: aicc and fpe are undefined, criteria() gives NaN for them "
        "(information_criteria raises InvalidParameter instead).",
    },
    "NistStrd": {
        "bugType": "BASIC",
        "description": "NIST StRD univariate data (public domain); the generator cross-checks its values against "
        "the certified mean, standard deviation and lag-1 autocorrelation.",
        "links": ["https://www.itl.nist.gov/div898/strd/"],
    },
    "NanOmit": {
        "bugType": "CONVENTION",
        "description": "nan_policy = 'omit': rows holding a non-finite value are deleted and a segment break is "
        "inserted where rows were removed.",
        "effect": "Ports that only delete rows (no break) join samples that were not adjacent.",
    },
    "ZeroVariance": {
        "bugType": "DEGENERATE",
        "description": "Zero residual variance in the zero-mean test: statistic +/-Infinity with p-value 0, or "
        "NaN when the mean is 0 too.",
    },
    "Bandwidth": {
        "bugType": "CONVENTION",
        "description": "Newey-West bandwidth K = floor(4 (N/100)^(2/9)) at most N - 1; N_eff clipped to [2, N].",
    },
    "ConfidenceBand": {"bugType": "BASIC", "description": "White-noise band z/sqrt(n), z = Phi^-1((1 + level)/2)."},
    "InvalidType": {"bugType": "INVALID_INPUT", "description": "An array argument is missing (null)."},
    "InvalidShape": {
        "bugType": "INVALID_INPUT",
        "description": "Wrong number of dimensions, or zero columns.",
    },
    "ShapeMismatch": {"bugType": "INVALID_INPUT", "description": "Arrays that must agree in shape do not."},
    "TooFewSamples": {"bugType": "INVALID_INPUT", "description": "Fewer samples than the function's minimum."},
    "NonFiniteInput": {
        "bugType": "INVALID_INPUT",
        "description": "NaN or +/-Infinity in the data with nan_policy = 'raise'.",
    },
    "InvalidParameter": {
        "bugType": "INVALID_INPUT",
        "description": "A keyword out of range, of the wrong kind, or an unknown option.",
    },
    "CheckOrder": {
        "bugType": "INVALID_INPUT",
        "description": "Several things are wrong at once: the first failure in the order type -> shape -> size -> "
        "finiteness -> parameters wins.",
        "effect": "Ports that check in another order report another error kind.",
    },
    "IntegerParameter": {
        "bugType": "CONVENTION",
        "description": "A boolean or an integral float where an integer is required: InvalidParameter in the "
        "Python and C++ APIs. Ports whose language cannot tell them apart (MATLAB, Wolfram) may return the value.",
    },
    "OutOfRange": {
        "bugType": "INVALID_INPUT",
        "description": "A finite data value with |x| > 1e144 (contract §1.2): NonFiniteInput, like NaN and ±inf, "
        "and deleted by nan_policy omit. |x| = 1e144 itself is accepted.",
        "effect": "Without the bound, sums of squares overflow and implementations disagree (inf in one, nan in "
        "another): a silently wrong number.",
    },
    "Int64Parameter": {
        "bugType": "INVALID_INPUT",
        "description": "An integer parameter that does not fit in a signed 64-bit integer: InvalidParameter, so "
        "that every language accepts exactly the same values.",
    },
}
