#!/usr/bin/env python3
"""Generate the dynval golden corpus (``golden/vectors/<family>.json``).

Every expected value is computed here at 50 significant digits with mpmath,
directly from the formulas of ``docs/contract.md`` — this script never imports
dynval. Inputs come from ``random.Random(seed)`` (only ``random()``, whose
sequence Python guarantees across versions, combined with IEEE arithmetic and
correctly rounded decimal formatting), from exact dyadic rationals, or from the
NIST StRD files committed in ``golden/data/``. Inputs are float64 values written
with ``repr``; expected values are rounded once to float64. The JSON layout is
fixed, so running the script again reproduces the files byte for byte.

Usage::

    python golden/generate.py            # rewrite golden/vectors/*.json
    python golden/generate.py --check    # exit 1 if the files differ from a fresh run

Only the standard library and mpmath (pinned, see ``MPMATH_VERSION``) are used.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import random
import sys
from typing import Any, Callable, Iterable, Sequence

import mpmath
from mpmath import mp, mpf
from mpmath.libmp import to_float

CORPUS_VERSION = "1.0.0"
SCHEMA_NAME = "corpus_v1.schema.json"
MPMATH_VERSION = "1.3.0"
DPS = 50
HERE = pathlib.Path(__file__).resolve().parent
GENERATOR = "golden/generate.py"

FAMILIES = (
    "norms",
    "normalized_fit",
    "residual_statistics",
    "autocorrelation",
    "portmanteau",
    "cross_correlation",
    "information_criteria",
    "errors",
)

# Relative size of every tolerance: absolute tolerance = RTOL * natural size of the
# quantity (see golden/README.md). Two-pass float64 formulas stay far below it.
RTOL = 1e-11

mp.dps = DPS

# ---------------------------------------------------------------------------------------------
# Flags legend (bugType vocabulary of golden/README.md). Each file carries the notes it uses.
# ---------------------------------------------------------------------------------------------

NOTES: dict[str, dict[str, Any]] = {
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

# ---------------------------------------------------------------------------------------------
# Numbers and JSON
# ---------------------------------------------------------------------------------------------


def f64(x: Any) -> float:
    """Round an mpf once to the nearest float64 (overflow gives +/-inf)."""
    if isinstance(x, float):
        return x
    if isinstance(x, int):
        return float(x)
    x = mpf(x)
    if mpmath.isnan(x):
        return float("nan")
    if mpmath.isinf(x):
        return float("inf") if x > 0 else float("-inf")
    return to_float(x._mpf_, rnd="n")


def num(x: Any) -> Any:
    """Corpus encoding of one number (floats shortest round-trip, non-finite as strings)."""
    if isinstance(x, bool) or isinstance(x, int):
        return x
    v = f64(x)
    if v != v:
        return "NaN"
    if v == float("inf"):
        return "Infinity"
    if v == float("-inf"):
        return "-Infinity"
    return v


def arr(values: Sequence, shape: Sequence[int]) -> dict:
    return {"shape": list(shape), "values": [num(v) for v in values]}


def mat(rows: Sequence[Sequence]) -> dict:
    """(N, m) matrix given as rows."""
    n = len(rows)
    m = len(rows[0]) if n else 0
    return arr([v for r in rows for v in r], [n, m])


def _dump(value: Any, indent: int, level: int) -> str:
    pad = " " * (indent * (level + 1))
    end = " " * (indent * level)
    if isinstance(value, dict):
        if not value:
            return "{}"
        if set(value) == {"shape", "values"}:  # arrays on one line
            return json.dumps(value, allow_nan=False, separators=(", ", ": "))
        items = [f"{pad}{json.dumps(k)}: {_dump(v, indent, level + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + end + "}"
    if isinstance(value, list):
        if all(not isinstance(v, (dict, list)) for v in value):
            return json.dumps(value, allow_nan=False, separators=(", ", ": "))
        items = [pad + _dump(v, indent, level + 1) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + end + "]"
    return json.dumps(value, allow_nan=False)


def dumps(doc: dict) -> str:
    """The fixed JSON layout of corpus files (2-space indent, arrays and lists on one line)."""
    return _dump(doc, 2, 0) + "\n"


# ---------------------------------------------------------------------------------------------
# Deterministic inputs
# ---------------------------------------------------------------------------------------------


def q(x: float, digits: int = 9) -> float:
    """Round to `digits` significant decimal digits (correctly rounded, platform independent)."""
    return float(format(x, f".{digits}g"))


class Stream:
    """Deterministic pseudo-random numbers built only on ``random.Random(seed).random()``."""

    def __init__(self, seed: int):
        self._rng = random.Random(seed)

    def uniform(self, lo: float = 0.0, hi: float = 1.0) -> float:
        return lo + (hi - lo) * self._rng.random()

    def normal(self) -> float:
        # Irwin-Hall: sum of 12 uniforms minus 6 (mean 0, variance 1); only + and - involved.
        s = 0.0
        for _ in range(12):
            s += self._rng.random()
        return s - 6.0

    def noise(self, n: int, scale: float = 1.0, digits: int = 9) -> list[float]:
        return [q(scale * self.normal(), digits) for _ in range(n)]

    def ar1(self, n: int, a: float, scale: float = 1.0) -> list[float]:
        out, prev = [], 0.0
        for _ in range(n):
            prev = a * prev + self.normal()
            out.append(q(scale * prev))
        return out

    def ar2(self, n: int, a1: float, a2: float, scale: float = 1.0) -> list[float]:
        out, p1, p2 = [], 0.0, 0.0
        for _ in range(n):
            x = a1 * p1 + a2 * p2 + self.normal()
            p2, p1 = p1, x
            out.append(q(scale * x))
        return out


def columns(rows: Sequence[Sequence[float]]) -> list[list[float]]:
    return [list(c) for c in zip(*rows)]


def rows_of(cols: Sequence[Sequence[float]]) -> list[list[float]]:
    return [list(r) for r in zip(*cols)]


def trajectory(s: Stream, n: int, m: int, means: Sequence[float], scales: Sequence[float]) -> list[list[float]]:
    """Smooth joint torques: mean + scale * (random-phase polynomial-free AR(2) motion)."""
    cols = []
    for j in range(m):
        base = s.ar2(n, 1.6, -0.7, 1.0)
        cols.append([q(means[j] + scales[j] * 0.2 * b) for b in base])
    return rows_of(cols)


def predict(s: Stream, meas: Sequence[Sequence[float]], rel: Sequence[float], ar: float = 0.0) -> list[list[float]]:
    """A prediction = measurement - residual, residual of size rel[j] (optionally AR(1) coloured)."""
    cols = columns(meas)
    out = []
    for j, col in enumerate(cols):
        res = s.ar1(len(col), ar, rel[j]) if ar else s.noise(len(col), rel[j])
        out.append([q(v - r, 12) for v, r in zip(col, res)])
    return rows_of(out)


# ---------------------------------------------------------------------------------------------
# Formulas (mpmath, contract §3)
# ---------------------------------------------------------------------------------------------

NAN = mpf("nan")
INF = mpf("inf")


def M(x: float) -> mpf:
    return mpf(x)  # exact: every float64 is an mpf at 50 digits


def msum(xs: Iterable) -> mpf:
    return mpmath.fsum(xs)


def mmean(xs: Sequence) -> mpf:
    return msum(xs) / len(xs)


def css(xs: Sequence) -> mpf:
    """Centred sum of squares."""
    mu = mmean(xs)
    return msum((x - mu) ** 2 for x in xs)


def is_const(xs: Sequence) -> bool:
    return min(xs) == max(xs)


def resid_cols(meas: Sequence[Sequence[float]], pred: Sequence[Sequence[float]]) -> list[list[mpf]]:
    return [[M(a) - M(b) for a, b in zip(ca, cb)] for ca, cb in zip(columns(meas), columns(pred))]


def ieee_mean(values: Sequence[mpf]) -> mpf:
    if any(mpmath.isnan(v) for v in values):
        return NAN
    if any(mpmath.isinf(v) for v in values):
        return -INF if any(v == -INF for v in values) and not any(v == INF for v in values) else NAN
    return msum(values) / len(values)


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


def seg_bounds(n: int, segments: Sequence[int] | None) -> list[tuple[int, int]]:
    """Segment (start, stop) pairs from lengths or starts (contract §1.1)."""
    if segments is None:
        return [(0, n)]
    segs = list(segments)
    if segs[0] == 0:  # starts
        stops = segs[1:] + [n]
        return list(zip(segs, stops))
    out, k = [], 0
    for length in segs:
        out.append((k, k + length))
        k += length
    return out


def lag_products(n: int, bounds, lag: int) -> list[tuple[int, int]]:
    """Index pairs (k, k - lag) inside one segment."""
    return [(k, k - lag) for a, b in bounds for k in range(a + lag, b)]


EPS = 2.0 ** -52


def mean_error(e: Sequence, n: int) -> mpf:
    """Error a float64 implementation may make in a mean: the sum's rounding plus the final rounding.

    (2 + sqrt(N)) ulps of the largest value; only matters for data on a large offset.
    """
    return (2 + mpmath.sqrt(n)) * EPS * max(abs(x) for x in e)


def acf(e: Sequence[mpf], max_lag: int, adjusted: bool, bounds) -> list[mpf]:
    """Autocorrelation rho(0..max_lag) of one joint (contract §3.4), NaN for a constant residual."""
    return acf_tol(e, max_lag, adjusted, bounds)[0]


def acf_tol(e: Sequence[mpf], max_lag: int, adjusted: bool, bounds) -> tuple[list[mpf], list[mpf]]:
    """rho(0..max_lag) and, per lag, the absolute error a correct float64 two-pass implementation can make.

    Besides RTOL * D_0/D_l (rounding in the sums), the mean can only be held to about delta = mean_error:
    R(l) then moves by delta * (sum of d_k + sum of d_(k-l) over the lag-l products) / D_l to first order
    (those partial sums do not vanish for l > 0), which matters for data on a large offset.
    """
    n = len(e)
    if is_const(e):
        return [NAN] * (max_lag + 1), [mpf(0)] * (max_lag + 1)
    mu = mmean(e)
    d = [x - mu for x in e]
    r0 = msum(x * x for x in d) / n
    delta = mean_error(e, n)
    out, tol = [mpf(1)], [mpf(0)]
    for lag in range(1, max_lag + 1):
        pairs = lag_products(n, bounds, lag)
        denom = len(pairs) if adjusted else n
        out.append(msum(d[k] * d[i] for k, i in pairs) / denom / r0)
        shift = abs(msum(d[k] + d[i] for k, i in pairs)) * delta + len(pairs) * delta ** 2
        tol.append(RTOL * mpf(n) / max(denom, 1) + shift / denom / r0)
    return out, tol


def n_products(n: int, bounds, lag: int) -> int:
    return sum(max(b - a - lag, 0) for a, b in bounds)


def chi2_sf(x: mpf, df: int) -> mpf:
    if mpmath.isnan(x):
        return NAN
    if x <= 0:
        return mpf(1)
    return mpmath.gammainc(mpf(df) / 2, x / 2, mpmath.inf, regularized=True)


def t_sf2(t: mpf, df: mpf) -> mpf:
    """Two-sided Student t p-value, 2 P(T > |t|) = I_{df/(df+t^2)}(df/2, 1/2)."""
    if mpmath.isnan(t) or mpmath.isnan(df):
        return NAN
    if mpmath.isinf(t):
        return mpf(0)
    x = df / (df + t * t)
    return mpmath.betainc(df / 2, mpf(1) / 2, 0, x, regularized=True)


def norm_ppf_two_sided(level: float) -> mpf:
    return mpmath.sqrt(2) * mpmath.erfinv(M(level))


# ---------------------------------------------------------------------------------------------
# Corpus assembly helpers
# ---------------------------------------------------------------------------------------------


class Family:
    def __init__(self, name: str, header: list[str]):
        self.name = name
        self.header = header
        self.groups: list[dict] = []
        self.next_id = 1

    def group(self, operation: str, conventions: dict, method: str = "high-precision", note: str = "") -> dict:
        key = (operation, json.dumps(conventions, sort_keys=True))
        for g in self.groups:
            if g["_key"] == key:
                return g
        src = {"name": "dynval-golden", "version": CORPUS_VERSION, "generator": GENERATOR, "method": method,
               "mpmath": MPMATH_VERSION, "digits": DPS}
        if note:
            src["description"] = note
        g = {"_key": key, "operation": operation, "conventions": conventions, "source": src, "tests": []}
        self.groups.append(g)
        return g

    def add(self, operation: str, conventions: dict, comment: str, flags: list[str], inputs: dict,
            expected: dict, tolerance: dict | None = None, result: str = "valid", method: str = "high-precision",
            note: str = "") -> None:
        for f in flags:
            if f not in NOTES:
                raise KeyError(f)
        g = self.group(operation, conventions, method, note)
        inputs = {k: (num(v) if isinstance(v, float) else v) for k, v in inputs.items()}
        test = {"tcId": self.next_id, "comment": comment, "flags": flags, "inputs": inputs,
                "expected": expected}
        if result != "invalid":
            test["tolerance"] = {k: num(v) if not isinstance(v, dict) else v for k, v in (tolerance or {}).items()}
        test["result"] = result
        g["tests"].append(test)
        self.next_id += 1

    def document(self) -> dict:
        used: list[str] = []
        for g in self.groups:
            for t in g["tests"]:
                for f in t["flags"]:
                    if f not in used:
                        used.append(f)
        groups = [{k: v for k, v in g.items() if k != "_key"} for g in self.groups]
        return {
            "family": self.name,
            "schema": SCHEMA_NAME,
            "numberOfTests": sum(len(g["tests"]) for g in groups),
            "header": self.header,
            "notes": {f: NOTES[f] for f in sorted(used)},
            "testGroups": groups,
        }


def out(v: Any) -> Any:
    """Expected value: list -> (m,) array, mpf -> scalar."""
    if isinstance(v, list):
        return arr(v, [len(v)])
    return num(v)


# ---------------------------------------------------------------------------------------------
# Datasets for the point metrics (tau_meas, tau_pred pairs)
# ---------------------------------------------------------------------------------------------


def metric_datasets() -> list[dict]:
    """Named (tau_meas, tau_pred) pairs used by the norms and normalized_fit families."""
    ds = []

    def add(name, comment, flags, meas, pred, one_d=False, mixed=False):
        ds.append({"name": name, "comment": comment, "flags": flags, "meas": meas, "pred": pred,
                   "one_d": one_d, "mixed": mixed})

    s = Stream(101)
    meas = trajectory(s, 12, 1, [2.0], [3.0])
    add("basic1", "single joint, 12 samples", ["Basic"], meas, predict(s, meas, [0.3]))
    s = Stream(102)
    meas = trajectory(s, 40, 3, [5.0, -2.0, 0.5], [4.0, 2.0, 1.0])
    add("basic3", "three joints, 40 samples", ["Basic"], meas, predict(s, meas, [0.5, 0.4, 0.2]))
    s = Stream(103)
    meas = trajectory(s, 200, 6, [10.0, -25.0, 8.0, 1.5, -0.8, 0.3], [20.0, 30.0, 12.0, 3.0, 2.0, 0.6])
    add("lesson6", "the lesson's layout: (N, m) = (200, 6), coloured residuals", ["LessonShape", "Autocorrelated"],
        meas, predict(s, meas, [1.0, 1.5, 0.8, 0.2, 0.15, 0.05], ar=0.8))
    s = Stream(104)
    meas = trajectory(s, 30, 7, [1.0] * 7, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    add("seven", "seven joints", ["ManyJoints"], meas, predict(s, meas, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]))
    s = Stream(105)
    meas = trajectory(s, 15, 1, [0.0], [1.0])
    add("oned", "1-D inputs (N,)", ["OneDimensional"], meas, predict(s, meas, [0.2]), one_d=True)
    s = Stream(106)
    meas = trajectory(s, 15, 1, [1.0], [1.0])
    add("mixed", "tau_meas (N,) and tau_pred (N, 1)", ["MixedPromotion"], meas, predict(s, meas, [0.2]), mixed=True)
    s = Stream(107)
    meas = trajectory(s, 50, 3, [1000.0, 0.0, -3.0], [500.0, 0.001, 2.0])
    add("scales", "joints with means 1000, 0, -3 and scales 500, 1e-3, 2", ["MixedScales"], meas,
        predict(s, meas, [400.0, 0.0004, 0.1]))
    s = Stream(108)
    meas = [[q(1e7 + 0.1 * s.normal())] for _ in range(100)]
    add("offset", "tau = 1e7 + noise of std 0.1, residual std 0.03", ["LargeOffset"], meas, predict(s, meas, [0.03]))
    s = Stream(109)
    meas = [[q(1e7 + 0.1 * s.normal()), q(-1e7 + 0.5 * s.normal())] for _ in range(60)]
    add("offset2", "two joints at +1e7 and -1e7 with small variance", ["LargeOffset"], meas,
        predict(s, meas, [0.05, 0.2]))
    s = Stream(110)
    meas = trajectory(s, 25, 2, [0.0, 1e-6], [1e-6, 3e-6])
    add("tiny", "values of order 1e-6", ["TinyScale"], meas, predict(s, meas, [1e-7, 5e-7]))
    s = Stream(111)
    meas = trajectory(s, 25, 2, [3e6, -1e6], [1e6, 2e6])
    add("huge", "values of order 1e6", ["HugeScale"], meas, predict(s, meas, [2e5, 1e5]))
    add("n2", "two samples, two joints", ["MinimumSamples"], [[1.0, -2.0], [3.0, 0.5]], [[1.5, -1.0], [2.0, 0.25]])
    add("n3", "three samples", ["SmallN"], [[0.5], [1.5], [-1.0]], [[0.25], [1.0], [-0.5]])
    s = Stream(112)
    meas = trajectory(s, 20, 2, [1.0, 2.0], [1.0, 1.0])
    add("exact", "prediction equals measurement", ["ExactFit"], meas, [list(r) for r in meas])
    add("const", "constant target, imperfect prediction", ["ConstantTarget"],
        [[2.5]] * 6, [[2.5], [2.0], [3.0], [2.5], [2.25], [2.75]])
    add("const_exact", "constant target, exact prediction", ["ConstantTarget", "ExactFit"], [[2.5]] * 6, [[2.5]] * 6)
    add("const_shift", "constant target, prediction off by a constant (residual constant: VAF exact)",
        ["ConstantTarget", "ConstantResidual"], [[4.0]] * 5, [[3.5]] * 5)
    s = Stream(113)
    base = trajectory(s, 20, 2, [1.0, -1.0], [2.0, 1.0])
    meas = [[r[0], 7.0, r[1]] for r in base]
    pred0 = predict(s, base, [0.2, 0.1])
    pred = [[p[0], 7.0 + (0.5 if k % 3 == 0 else -0.25), p[1]] for k, p in enumerate(pred0)]
    add("constjoint", "joint 1 constant (7.0) among two normal joints", ["ConstantJoint"], meas, pred)
    add("allconst", "every joint constant, one predicted exactly", ["AllJointsConstant", "ConstantTarget"],
        [[1.0, 2.0]] * 4, [[1.0, 2.5], [1.0, 1.5], [1.0, 2.0], [1.0, 2.25]])
    return ds


def enc_signal(d: dict, which: str) -> dict:
    rows = d["meas"] if which == "meas" else d["pred"]
    if d["one_d"] or (d["mixed"] and which == "meas"):
        return arr([r[0] for r in rows], [len(rows)])
    return mat(rows)


# ---------------------------------------------------------------------------------------------
# Families
# ---------------------------------------------------------------------------------------------


def build_norms() -> Family:
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
    return fam


def build_normalized_fit() -> Family:
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
    return fam


# ---- residual statistics ---------------------------------------------------------------------


def residual_sets() -> list[dict]:
    sets = []

    def add(name, comment, flags, cols, segs=None):
        sets.append({"name": name, "comment": comment, "flags": flags, "cols": cols})

    s = Stream(201)
    add("white", "white residuals, two joints, N = 80", ["Basic"], [s.noise(80, 0.5), s.noise(80, 2.0)])
    s = Stream(202)
    add("ar", "AR(1) residuals (a = 0.9), N = 150", ["Autocorrelated"], [s.ar1(150, 0.9, 0.1), s.ar1(150, 0.5, 1.0)])
    s = Stream(203)
    add("bias", "residuals with a mean of 0.3, N = 60", ["Basic"], [[q(0.3 + x) for x in s.noise(60, 0.4)]])
    s = Stream(204)
    add("offset", "residuals 1e7 + noise of std 0.1", ["LargeOffset"], [[q(1e7 + x) for x in s.noise(50, 0.1)]])
    add("n2", "N = 2", ["MinimumSamples"], [[0.5, -1.5], [2.0, 2.25]])
    add("n3", "N = 3", ["SmallN"], [[1.0, -0.5, 0.25]])
    s = Stream(205)
    add("lesson6", "six joints, N = 120, coloured", ["LessonShape", "Autocorrelated"],
        [s.ar1(120, 0.7, sc) for sc in (1.0, 0.5, 2.0, 0.1, 0.05, 0.3)])
    s = Stream(206)
    add("tiny", "residuals of order 1e-6", ["TinyScale"], [s.noise(40, 1e-6), s.ar1(40, 0.6, 3e-6)])
    return sets


NIST_UNIVARIATE = ("Lew", "Lottery", "Mavro", "Michelso", "NumAcc1", "NumAcc2", "NumAcc3", "NumAcc4")


def nist_univariate(name: str) -> list[float]:
    text = (HERE / "data" / "nist_strd" / f"{name}.dat").read_text(encoding="ascii")
    # NIST header lines are prefixed with '#'; one decimal value per data line, parsed correctly rounded.
    return [float(ln.split()[0]) for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def nist_certified() -> dict:
    return json.loads((HERE / "data" / "nist_strd" / "certified.json").read_text(encoding="utf-8"))


def zero_mean(e: list[mpf], bounds) -> dict:
    n = len(e)
    mu = mmean(e)
    var = css(e) / (n - 1)
    sd = mpmath.sqrt(var)
    k = int(mpmath.floor(4 * (mpf(n) / 100) ** (mpf(2) / 9)))
    k = min(k, n - 1)
    if sd == 0:
        t = NAN if mu == 0 else (INF if mu > 0 else -INF)
        return {"mean": mu, "std": sd, "statistic_iid": t, "pvalue_iid": NAN if mu == 0 else mpf(0),
                "statistic_eff": t, "pvalue_eff": NAN if mu == 0 else mpf(0), "bandwidth": k,
                "tol_t": mpf(0), "tol_n": mpf(0)}
    t = mu * mpmath.sqrt(n) / sd
    rho, rtol_ = acf_tol(e, k, False, bounds)
    ssum = msum((1 - mpf(j) / (k + 1)) * rho[j] for j in range(1, k + 1))
    dsum = msum((1 - mpf(j) / (k + 1)) * rtol_[j] for j in range(1, k + 1))
    if ssum <= 0:
        neff = mpf(n)
    else:
        neff = min(max(n / (1 + 2 * ssum), mpf(2)), mpf(n))
    te = mu * mpmath.sqrt(neff) / sd
    big = max(abs(x) for x in e)
    tol_t = RTOL * (abs(t) + mpmath.sqrt(n) * big / sd)
    # N_eff = N / (1 + 2 S): an error dS in S moves it by 2 N dS / (1 + 2 S)^2 (unless clipped).
    tol_n = RTOL * n * (k + 1) + (0 if ssum <= 0 else 2 * n * dsum / (1 + 2 * ssum) ** 2)
    tol_te = RTOL * (abs(te) + mpmath.sqrt(n) * big / sd) + abs(te) * tol_n / (2 * neff)
    return {"mean": mu, "std": sd, "statistic_iid": t, "pvalue_iid": t_sf2(t, mpf(n - 1)), "statistic_eff": te,
            "pvalue_eff": t_sf2(te, neff - 1), "df_eff": neff - 1, "n_eff": neff, "bandwidth": k,
            "tol_t": tol_t, "tol_te": tol_te, "tol_n": tol_n,
            "tol_p": pspread(lambda a, b: t_sf2(a, b), t, tol_t, mpf(n - 1), mpf(0)),
            "tol_pe": pspread(lambda a, b: t_sf2(a, b), te, tol_te, neff - 1, tol_n)}


def pspread(fn: Callable, x: mpf, dx: mpf, y: mpf, dy: mpf) -> float:
    """Absolute tolerance of fn(x, y) when x, y carry the absolute errors dx, dy."""
    base = fn(x, y)
    worst = mpf(0)
    for sx in (-1, 1):
        for sy in (-1, 1):
            worst = max(worst, abs(fn(x + sx * dx, y + sy * dy) - base))
    return f64(1e-12 * abs(base) + worst) + 1e-15


def zero_mean_expected(cols: list[list[float]], segments) -> tuple[dict, dict]:
    n = len(cols[0])
    bounds = seg_bounds(n, segments)
    res = [zero_mean([M(x) for x in c], bounds) for c in cols]
    m = len(cols)
    big = max(abs(x) for c in cols for x in c)
    exp: dict[str, Any] = {
        "mean": arr([r["mean"] for r in res], [m]),
        "std": arr([r["std"] for r in res], [m]),
        "n_samples": n,
        "statistic_iid": arr([r["statistic_iid"] for r in res], [m]),
        "pvalue_iid": arr([r["pvalue_iid"] for r in res], [m]),
        "df_iid": n - 1,
        "statistic_eff": arr([r["statistic_eff"] for r in res], [m]),
        "pvalue_eff": arr([r["pvalue_eff"] for r in res], [m]),
    }
    tol: dict[str, Any] = {
        "mean": RTOL * big,
        "std": RTOL * big,
        "n_samples": 0,
        "statistic_iid": arr([r["tol_t"] for r in res], [m]),
        "pvalue_iid": arr([r.get("tol_p", 0.0) for r in res], [m]),
        "df_iid": 0,
        "statistic_eff": arr([r.get("tol_te", 0.0) for r in res], [m]),
        "pvalue_eff": arr([r.get("tol_pe", 0.0) for r in res], [m]),
    }
    if all("n_eff" in r for r in res):
        exp["df_eff"] = arr([r["df_eff"] for r in res], [m])
        exp["n_eff"] = arr([r["n_eff"] for r in res], [m])
        exp["bandwidth"] = res[0]["bandwidth"]
        tol["df_eff"] = arr([r["tol_n"] for r in res], [m])
        tol["n_eff"] = arr([r["tol_n"] for r in res], [m])
        tol["bandwidth"] = 0
    return exp, tol


def build_residual_statistics() -> Family:
    fam = Family("residual_statistics", [
        "Residual mean, residual variance (ddof) and the zero-mean test (i.i.d. and Newey-West corrected), "
        "contract §3.3.",
        "Input e: residuals (N, m) or (N,). Tolerances: RTOL * max|e| for means and standard deviations, "
        "RTOL * variance + (1e-12 max|e|)^2 for variances, t statistics RTOL * (|t| + sqrt(N) max|e|/s), "
        "p-values propagated from the statistic's tolerance.",
    ])
    for d in residual_sets():
        cols = d["cols"]
        n, m = len(cols[0]), len(cols)
        e_in = mat(rows_of(cols))
        ec = [[M(x) for x in c] for c in cols]
        big = max(abs(x) for c in cols for x in c)
        means = [mmean(c) for c in ec]
        fam.add("residual_mean", {"nan_policy": "raise"}, d["comment"], list(d["flags"]), {"e": e_in},
                {"value": arr(means, [m])}, {"value": RTOL * big})
        for ddof in (0, 1):
            var = [css(c) / (n - ddof) for c in ec]
            fam.add("residual_variance", {"ddof": ddof, "nan_policy": "raise"}, d["comment"],
                    d["flags"] + ["DdofConvention"], {"e": e_in}, {"value": arr(var, [m])},
                    {"value": RTOL * f64(max(var)) + (1e-12 * big) ** 2})
        exp, tol = zero_mean_expected(cols, None)
        fam.add("zero_mean_test", {"segments": None, "nan_policy": "raise"}, d["comment"],
                d["flags"] + ["Bandwidth"], {"e": e_in}, exp, tol)
    # ddof = N - 1 (largest allowed) and ddof = 2.
    s = Stream(210)
    cols = [s.noise(6, 1.0)]
    ec = [M(x) for x in cols[0]]
    for ddof in (2, 5):
        var = css(ec) / (6 - ddof)
        fam.add("residual_variance", {"ddof": ddof, "nan_policy": "raise"}, f"N = 6, ddof = {ddof}",
                ["DdofConvention", "SmallN"] if ddof == 5 else ["DdofConvention"], {"e": mat(rows_of(cols))},
                {"value": arr([var], [1])}, {"value": RTOL * f64(var) + 1e-24})
    # Constant residual: variance exactly 0, zero-mean test degenerate.
    for c, comment in ((0.25, "constant residual 0.25"), (0.0, "residual identically zero")):
        cols = [[c] * 8]
        exp, tol = zero_mean_expected(cols, None)
        fam.add("zero_mean_test", {"segments": None, "nan_policy": "raise"}, comment,
                ["ZeroVariance", "ConstantResidual"], {"e": mat(rows_of(cols))}, exp, tol)
        fam.add("residual_variance", {"ddof": 1, "nan_policy": "raise"}, comment, ["ConstantResidual"],
                {"e": mat(rows_of(cols))}, {"value": arr([0.0], [1])}, {"value": (1e-12 * abs(c)) ** 2})
    # Segments change the corrected test only through the autocorrelation.
    s = Stream(211)
    cols = [s.ar1(90, 0.8, 1.0), s.ar1(90, -0.4, 0.5)]
    for segs, flag in (([30, 60], "Segments"), ([0, 30], "SegmentStarts")):
        exp, tol = zero_mean_expected(cols, segs)
        fam.add("zero_mean_test", {"segments": segs, "nan_policy": "raise"},
                "AR(1) residuals in two records of 30 and 60 samples", [flag, "Autocorrelated", "Bandwidth"],
                {"e": mat(rows_of(cols))}, exp, tol)
    # Bandwidth boundary N = 100 (K = 4 exactly) and a long record.
    for n, seed in ((100, 212), (400, 213)):
        s = Stream(seed)
        cols = [s.ar1(n, 0.5, 1.0)]
        exp, tol = zero_mean_expected(cols, None)
        fam.add("zero_mean_test", {"segments": None, "nan_policy": "raise"},
                f"N = {n}: bandwidth K = {exp['bandwidth']}", ["Bandwidth", "Autocorrelated"],
                {"e": mat(rows_of(cols))}, exp, tol)
    # NIST StRD univariate: mean and standard deviation (ddof 1) against certified values.
    cert = nist_certified()
    for name in NIST_UNIVARIATE:
        y = nist_univariate(name)
        ym = [M(x) for x in y]
        mu = mmean(ym)
        var = css(ym) / (len(y) - 1)
        c = cert["univariate"][name]
        _check_certified(name, "mean", mu, c["mean"], 14)
        _check_certified(name, "sd", mpmath.sqrt(var), c["sd"], 8)
        big = max(abs(x) for x in y)
        comment = f"NIST StRD {name} (N = {len(y)}), certified mean {c['mean']}, sd {c['sd']}"
        e_in = arr(y, [len(y), 1])
        flags = ["NistStrd"] + (["LargeOffset"] if name in ("NumAcc2", "NumAcc3", "NumAcc4") else [])
        fam.add("residual_mean", {"nan_policy": "raise"}, comment, flags, {"e": e_in},
                {"value": arr([mu], [1])}, {"value": RTOL * big}, method="high-precision",
                note="cross-checked against NIST certified values")
        fam.add("residual_variance", {"ddof": 1, "nan_policy": "raise"}, comment, flags, {"e": e_in},
                {"value": arr([var], [1])}, {"value": RTOL * f64(var) + (1e-12 * big) ** 2})
    # nan_policy = "omit" in the residual mean.
    e_rows = [[1.0, 2.0], [float("nan"), 1.0], [3.0, -1.0], [0.5, 0.5]]
    fam.add("residual_mean", {"nan_policy": "omit"}, "row 1 holds a NaN and is omitted for every joint",
            ["NanOmit"], {"e": mat(e_rows)}, {"value": arr([mpf(4.5) / 3, mpf(1.5) / 3], [2])},
            {"value": RTOL * 3})
    return fam


def _check_certified(name: str, what: str, value: mpf, certified: Any, digits: int) -> None:
    ref = mpf(certified if isinstance(certified, str) else str(certified))
    if ref == 0:
        ok = abs(value) < mpf(10) ** -digits
    else:
        ok = abs(value - ref) <= abs(ref) * mpf(10) ** (-digits)
    if not ok:
        raise AssertionError(f"NIST {name} {what}: computed {value}, certified {certified}")


# ---- autocorrelation -------------------------------------------------------------------------


def acf_expected(cols, max_lag, adjusted, segments):
    n = len(cols[0])
    bounds = seg_bounds(n, segments)
    res = [acf_tol([M(x) for x in c], max_lag, adjusted, bounds) for c in cols]
    values = [res[j][0][lag] for lag in range(max_lag + 1) for j in range(len(cols))]
    tols = [res[j][1][lag] for lag in range(max_lag + 1) for j in range(len(cols))]
    return values, arr(tols, [max_lag + 1, len(cols)])


def build_autocorrelation() -> Family:
    fam = Family("autocorrelation", [
        "Residual autocorrelation rho(0..max_lag) per joint (contract §3.4) and the white-noise band "
        "confidence_band(n, level).",
        "Output value: (max_lag + 1, m) for 2-D e, (max_lag + 1,) for 1-D e. Tolerance on rho: "
        "RTOL * max over lags of D_0/D_l (rho is R(l)/R(0), errors scale with R(0)).",
    ])
    seg_n = 60
    s = Stream(301)
    seg_sets = [
        ("white residuals, two joints", ["Basic"], [s.noise(seg_n, 1.0), s.noise(seg_n, 0.01)]),
        ("AR(1) residuals", ["Autocorrelated"], [s.ar1(seg_n, 0.85, 1.0)]),
        ("AR(2) oscillating residuals", ["Autocorrelated"], [s.ar2(seg_n, 1.2, -0.6, 0.5), s.ar1(seg_n, -0.5)]),
        ("residuals 1e7 + AR(1) noise of std 0.1", ["LargeOffset"],
         [[q(1e7 + x) for x in s.ar1(seg_n, 0.6, 0.1)]]),
    ]
    variants = [
        (None, [], [0, 1, 5, 12]),
        ([25, 35], ["Segments"], [1, 5, 12, 34]),
        ([0, 25], ["SegmentStarts"], [1, 5, 34]),
        ([10, 20, 30], ["Segments"], [3, 29]),
    ]
    for adjusted in (True, False):
        base_flag = "AdjustedAcf" if adjusted else "BiasedAcf"
        for segs, seg_flags, lags in variants:
            for comment, flags, cols in seg_sets:
                for L in lags:
                    longest = max(b - a for a, b in seg_bounds(seg_n, segs))
                    extra = ["LagZero"] if L == 0 else (["MaxLagLimit"] if L == longest - 1 else [])
                    values, tol = acf_expected(cols, L, adjusted, segs)
                    fam.add("autocorrelation", {"adjusted": adjusted, "segments": segs, "nan_policy": "raise"},
                            f"{comment}, N = {seg_n}, max_lag = {L}", flags + [base_flag] + seg_flags + extra,
                            {"e": mat(rows_of(cols)), "max_lag": L},
                            {"value": arr(values, [L + 1, len(cols)])}, {"value": tol})
    # The lesson's single-joint signature: 1-D e, L = 50, adjusted.
    s = Stream(302)
    e = s.ar1(400, 0.7, 0.2)
    values, tol = acf_expected([e], 50, True, None)
    fam.add("autocorrelation", {"adjusted": True, "segments": None, "nan_policy": "raise"},
            "the lesson's residual_autocorrelation(e, L=50) on a 1-D residual of 400 samples",
            ["LessonShape", "OneDimensional", "AdjustedAcf", "Autocorrelated"], {"e": arr(e, [400]), "max_lag": 50},
            {"value": arr(values, [51])}, {"value": {"shape": [51], "values": tol["values"]}})
    # Lesson layout with 6 joints.
    s = Stream(303)
    cols = [s.ar1(150, a, sc) for a, sc in ((0.9, 1.0), (0.5, 2.0), (0.0, 0.3), (-0.3, 0.1), (0.7, 0.05),
                                            (0.95, 4.0))]
    for adjusted in (True, False):
        values, tol = acf_expected(cols, 20, adjusted, None)
        fam.add("autocorrelation", {"adjusted": adjusted, "segments": None, "nan_policy": "raise"},
                "six joints, N = 150, max_lag = 20",
                ["LessonShape", "AdjustedAcf" if adjusted else "BiasedAcf", "Autocorrelated"],
                {"e": mat(rows_of(cols)), "max_lag": 20}, {"value": arr(values, [21, 6])}, {"value": tol})
    # N = 2 and small N.
    for cols, comment, flags in (([[1.0, 3.0]], "N = 2, max_lag = 1", ["MinimumSamples", "MaxLagLimit"]),
                                 ([[0.5, -1.0, 2.0], [1.0, 1.0, 0.0]], "N = 3, max_lag = 2, two joints",
                                  ["SmallN", "MaxLagLimit"])):
        n = len(cols[0])
        for adjusted in (True, False):
            values, tol = acf_expected(cols, n - 1, adjusted, None)
            fam.add("autocorrelation", {"adjusted": adjusted, "segments": None, "nan_policy": "raise"}, comment,
                    flags + ["AdjustedAcf" if adjusted else "BiasedAcf"],
                    {"e": mat(rows_of(cols)), "max_lag": n - 1},
                    {"value": arr(values, [n, len(cols)])}, {"value": tol})
    # Constant residual joint next to a normal one.
    s = Stream(304)
    cols = [s.noise(20, 1.0), [0.75] * 20]
    for adjusted in (True, False):
        values, tol = acf_expected(cols, 4, adjusted, None)
        fam.add("autocorrelation", {"adjusted": adjusted, "segments": None, "nan_policy": "raise"},
                "joint 1 has a constant residual: its column is NaN, lag 0 included", ["ConstantResidual",
                                                                                      "AdjustedAcf" if adjusted
                                                                                      else "BiasedAcf"],
                {"e": mat(rows_of(cols)), "max_lag": 4}, {"value": arr(values, [5, 2])}, {"value": tol})
    # NIST StRD: certified lag-1 autocorrelation is the biased estimator.
    cert = nist_certified()
    for name in NIST_UNIVARIATE:
        y = nist_univariate(name)
        values, tol = acf_expected([y], 1, False, None)
        c = cert["univariate"][name]
        if name not in ("NumAcc3", "NumAcc4"):  # their doubles differ from the decimal data (SOURCES.md)
            _check_certified(name, "lag1", values[1], c["lag1_autocorr"], 12)
        flags = ["NistStrd", "BiasedAcf"] + (["LargeOffset"] if name in ("NumAcc2", "NumAcc3", "NumAcc4") else [])
        fam.add("autocorrelation", {"adjusted": False, "segments": None, "nan_policy": "raise"},
                f"NIST StRD {name} (N = {len(y)}), certified r(1) = {c['lag1_autocorr']}", flags,
                {"e": arr(y, [len(y), 1]), "max_lag": 1}, {"value": arr(values, [2, 1])}, {"value": tol})
    # nan_policy = "omit": a NaN row is deleted and a segment break inserted there.
    s = Stream(305)
    e = s.ar1(30, 0.8, 1.0)
    e_in = list(e)
    e_in[12] = float("nan")
    kept = e[:12] + e[13:]
    for adjusted in (True, False):
        values, tol = acf_expected([kept], 5, adjusted, [12, 17])
        fam.add("autocorrelation", {"adjusted": adjusted, "segments": None, "nan_policy": "omit"},
                "sample 12 is NaN: omitted, and no lagged product joins samples 11 and 13",
                ["NanOmit", "AdjustedAcf" if adjusted else "BiasedAcf"],
                {"e": arr(e_in, [30, 1]), "max_lag": 5}, {"value": arr(values, [6, 1])}, {"value": tol})
    # confidence_band(n, level)
    for n in (2, 10, 100, 1000, 123456):
        for level in (0.9, 0.95, 0.99):
            z = norm_ppf_two_sided(level)
            v = z / mpmath.sqrt(n)
            fam.add("confidence_band", {"level": level}, f"n = {n}, level = {level}", ["ConfidenceBand"],
                    {"n": n}, {"value": num(v)}, {"value": RTOL * f64(v)})
    return fam


# ---- portmanteau -----------------------------------------------------------------------------


def portmanteau_expected(cols, lags, model_df, segments, test):
    n = len(cols[0])
    bounds = seg_bounds(n, segments)
    hmax = max(lags)
    res = [acf_tol([M(x) for x in c], hmax, False, bounds) for c in cols]
    rhos = [r[0] for r in res]
    m = len(cols)
    stat, pv, lp, tq, tp, tl = [], [], [], [], [], []
    for h in lags:
        df = h - model_df
        for j in range(m):
            rho = rhos[j]
            if mpmath.isnan(rho[0]):
                qv = NAN
            elif test == "ljung_box":
                qv = mpf(n) * (n + 2) * msum(rho[k] ** 2 / n_products(n, bounds, k) for k in range(1, h + 1))
            else:
                qv = mpf(n) * msum(rho[k] ** 2 for k in range(1, h + 1))
            stat.append(qv)
            if mpmath.isnan(qv):
                pv.append(NAN), lp.append(NAN), tq.append(0.0), tp.append(0.0), tl.append(0.0)
                continue
            p = chi2_sf(qv, df)
            pv.append(p)
            lp.append(mpmath.log(p))
            drho = res[j][1]
            if test == "ljung_box":
                weights = [mpf(n) * (n + 2) / n_products(n, bounds, k) for k in range(1, h + 1)]
            else:
                weights = [mpf(n)] * h
            dq = RTOL * max(f64(qv), n) + f64(msum(w * (2 * abs(rho[k]) * drho[k] + drho[k] ** 2)
                                                   for w, k in zip(weights, range(1, h + 1))))
            tq.append(dq)
            tp.append(pspread(lambda a, b: chi2_sf(a, df), qv, mpf(dq), mpf(0), mpf(0)))
            tl.append(pspread(lambda a, b: mpmath.log(chi2_sf(a, df)), qv, mpf(dq), mpf(0), mpf(0)))
    k = len(lags)
    exp = {"statistic": arr(stat, [k, m]), "pvalue": arr(pv, [k, m]), "log_pvalue": arr(lp, [k, m]),
           "df": arr([h - model_df for h in lags], [k])}
    tol = {"statistic": arr(tq, [k, m]), "pvalue": arr(tp, [k, m]), "log_pvalue": arr(tl, [k, m]), "df": 0}
    return exp, tol


def build_portmanteau() -> Family:
    fam = Family("portmanteau", [
        "Ljung-Box and Box-Pierce statistics with the biased autocorrelation, df = h - model_df, "
        "pvalue = chi2.sf(Q, df), log_pvalue = chi2.logsf(Q, df) (contract §3.5).",
        "Outputs statistic, pvalue, log_pvalue: (n_lags, m); df: (n_lags,). Tolerance on Q: RTOL * max(Q, N); "
        "p-values: the spread of the exact p-value over Q +/- that tolerance, plus 1e-12 relative.",
    ])
    n = 80
    s = Stream(401)
    sets = [
        ("white residuals, two joints", ["Basic"], [s.noise(n, 1.0), s.noise(n, 3.0)]),
        ("AR(1) residuals", ["Autocorrelated"], [s.ar1(n, 0.6, 1.0)]),
        ("1e7 + white noise of std 0.1", ["LargeOffset"], [[q(1e7 + x) for x in s.noise(n, 0.1)]]),
    ]
    for test in ("ljung_box", "box_pierce"):
        for model_df in (0, 2):
            for segs, seg_flags in ((None, []), ([30, 50], ["Segments"]), ([0, 30], ["SegmentStarts"])):
                for comment, flags, cols in sets:
                    for lags in ([10], [5, 10, 20], [20, 3]):
                        if min(lags) <= model_df:
                            continue
                        exp, tol = portmanteau_expected(cols, lags, model_df, segs, test)
                        extra = (["ModelDf"] if model_df else []) + (["SeveralLags"] if len(lags) > 1 else [])
                        lag_in: Any = lags[0] if len(lags) == 1 else lags
                        fam.add(test, {"model_df": model_df, "segments": segs, "nan_policy": "raise"},
                                f"{comment}, N = {n}, lags = {lag_in}", flags + seg_flags + extra,
                                {"e": mat(rows_of(cols)), "lags": lag_in}, exp, tol)
    # Strongly coloured residuals: p-value far below 1e-300.
    s = Stream(402)
    cols = [s.ar1(2000, 0.95, 1.0)]
    for test in ("ljung_box", "box_pierce"):
        exp, tol = portmanteau_expected(cols, [50], 0, None, test)
        fam.add(test, {"model_df": 0, "segments": None, "nan_policy": "raise"},
                "AR(1) a = 0.95, N = 2000, lags = 50: p < 1e-300", ["TinyPValue", "Autocorrelated"],
                {"e": mat(rows_of(cols)), "lags": 50}, exp, tol)
    # Lesson layout, six joints, lags = [max_lag] with max_lag = 50.
    s = Stream(403)
    cols = [s.ar1(300, a, 1.0) for a in (0.0, 0.2, 0.4, 0.6, 0.8, -0.5)]
    for test in ("ljung_box", "box_pierce"):
        exp, tol = portmanteau_expected(cols, [50], 6, None, test)
        fam.add(test, {"model_df": 6, "segments": None, "nan_policy": "raise"},
                "six joints, N = 300, lags = 50, model_df = 6", ["LessonShape", "ModelDf", "Autocorrelated"],
                {"e": mat(rows_of(cols)), "lags": 50}, exp, tol)
    # Small N and the largest lag; a constant residual.
    for test in ("ljung_box", "box_pierce"):
        cols = [[1.0, -2.0, 0.5, 3.0], [0.25, 0.25, 0.25, 0.25]]
        exp, tol = portmanteau_expected(cols, [1, 3], 0, None, test)
        fam.add(test, {"model_df": 0, "segments": None, "nan_policy": "raise"},
                "N = 4, lags [1, 3]; joint 1 has a constant residual (NaN)",
                ["SmallN", "ConstantResidual", "MaxLagLimit", "SeveralLags"],
                {"e": mat(rows_of(cols)), "lags": [1, 3]}, exp, tol)
        cols = [[2.0, -1.0]]
        exp, tol = portmanteau_expected(cols, [1], 0, None, test)
        fam.add(test, {"model_df": 0, "segments": None, "nan_policy": "raise"}, "N = 2, lags = 1",
                ["MinimumSamples"], {"e": mat(rows_of(cols)), "lags": 1}, exp, tol)
    return fam


# ---- cross-correlation ----------------------------------------------------------------------


def xcorr_expected(ecols, Y, max_lag, adjusted, segments, level):
    """Y[k][j][c]; returns rho (m, p, L+1), constant_mask (m, p), band."""
    n, m, p = len(ecols[0]), len(ecols), len(Y[0][0])
    bounds = seg_bounds(n, segments)
    rho, mask, tol = [], [], []
    for j in range(m):
        e = [M(x) for x in ecols[j]]
        const_e = is_const(e)
        mu = mmean(e)
        de = [x - mu for x in e]
        re0 = msum(x * x for x in de) / n
        delta_e = mean_error(e, n)
        for c in range(p):
            ycol = [Y[k][j][c] for k in range(n)]
            cst = is_const(ycol)
            mask.append(cst)
            if cst or const_e:
                rho.extend([NAN] * (max_lag + 1))
                tol.extend([0.0] * (max_lag + 1))
                continue
            ym = [M(x) for x in ycol]
            muy = mmean(ym)
            dy = [x - muy for x in ym]
            ry0 = msum(x * x for x in dy) / n
            delta_y = mean_error(ym, n)
            scale = mpmath.sqrt(re0 * ry0)
            for lag in range(max_lag + 1):
                pairs = lag_products(n, bounds, lag)
                den = len(pairs) if adjusted else n
                rho.append(msum(de[k] * dy[i] for k, i in pairs) / den / scale)
                # first-order effect of the float means (see acf_tol), plus rounding in the sums
                shift = (delta_e * abs(msum(dy[i] for _, i in pairs)) + delta_y * abs(msum(de[k] for k, _ in pairs))
                         + len(pairs) * delta_e * delta_y)
                tol.append(RTOL * mpf(n) / den + shift / den / scale)
    band = norm_ppf_two_sided(level) / mpmath.sqrt(n)
    return ({"rho": arr(rho, [m, p, max_lag + 1]), "constant_mask": arr(mask, [m, p]), "band": num(band)},
            {"rho": arr(tol, [m, p, max_lag + 1]), "constant_mask": 0, "band": RTOL * f64(band)})


def regressor(s: Stream, n: int, m: int, p: int, const: Sequence[tuple[int, int]] = ()) -> list:
    """Y[k][j][c]: smooth columns (positions, velocities, sign-like friction, constants)."""
    Y = [[[0.0] * p for _ in range(m)] for _ in range(n)]
    for j in range(m):
        for c in range(p):
            if (j, c) in const:
                col = [1.0] * n
            else:
                col = s.ar2(n, 1.5, -0.6, 0.3 * (c + 1))
            for k in range(n):
                Y[k][j][c] = col[k]
    return Y


def enc_regressor(Y: list, stacked: bool) -> dict:
    n, m, p = len(Y), len(Y[0]), len(Y[0][0])
    flat = [Y[k][j][c] for k in range(n) for j in range(m) for c in range(p)]
    return arr(flat, [n * m, p] if stacked else [n, m, p])


def build_cross_correlation() -> Family:
    fam = Family("cross_correlation", [
        "Cross-correlation of residual joint j with regressor column c of that joint, rho (m, p, max_lag + 1), "
        "constant_mask (m, p) and band z/sqrt(N) (contract §3.6).",
        "regressor: (N, m, p), or (N*m, p) stacked sample-major with n_joints = m. Tolerance on rho: "
        "RTOL * max over lags of D_0/D_l.",
    ])
    n = 50
    s = Stream(501)
    e2 = [s.ar1(n, 0.5, 1.0), s.noise(n, 0.2)]
    Y2 = regressor(s, n, 2, 3, const=[(0, 2), (1, 2)])
    e1 = [[q(1e7 + x) for x in s.noise(n, 0.1)]]
    Y1 = regressor(s, n, 1, 2)
    Y1 = [[[q(1e7 + Y1[k][0][0]), Y1[k][0][1]]] for k in range(n)]
    # residual correlated with a lagged regressor column: a missing term in the model.
    Y3 = regressor(s, n, 1, 2)
    e3 = [[q(0.8 * (Y3[k - 2][0][0] if k >= 2 else 0.0) + 0.1 * s.normal()) for k in range(n)]]
    sets = [
        ("two joints, three columns, column 2 constant (friction offset) on both joints",
         ["ConstantColumn"], e2, Y2),
        ("residual 1e7 + noise, regressor column 0 at 1e7 + AR(2)", ["LargeOffset"], e1, Y1),
        ("residual driven by regressor column 0 two samples earlier (peak at lag 2)", ["Basic"], e3, Y3),
    ]
    for adjusted in (True, False):
        acf_flag = "AdjustedAcf" if adjusted else "BiasedAcf"
        for segs, seg_flags in ((None, []), ([20, 30], ["Segments"]), ([0, 20], ["SegmentStarts"])):
            for level in (0.95,) if segs else (0.95, 0.99):
                for comment, flags, ecols, Y in sets:
                    for L, stacked in ((5, False), (0, False), (5, True)):
                        if stacked and len(ecols) == 1:
                            continue
                        exp, tol = xcorr_expected(ecols, Y, L, adjusted, segs, level)
                        inputs = {"e": mat(rows_of(ecols)), "regressor": enc_regressor(Y, stacked), "max_lag": L}
                        if stacked:
                            inputs["n_joints"] = len(ecols)
                        extra = (["StackedRegressor"] if stacked else []) + (["LagZero"] if L == 0 else [])
                        fam.add("cross_correlation",
                                {"adjusted": adjusted, "level": level, "segments": segs, "nan_policy": "raise"},
                                f"{comment}, N = {n}, max_lag = {L}", flags + [acf_flag] + seg_flags + extra,
                                inputs, exp, tol)
    # Lesson layout: six joints, four columns, N = 100.
    s = Stream(502)
    ecols = [s.ar1(100, 0.5, 1.0) for _ in range(6)]
    Y = regressor(s, 100, 6, 4, const=[(5, 3)])
    exp, tol = xcorr_expected(ecols, Y, 10, True, None, 0.95)
    fam.add("cross_correlation", {"adjusted": True, "level": 0.95, "segments": None, "nan_policy": "raise"},
            "six joints, four columns, N = 100, max_lag = 10; column 3 constant on joint 5",
            ["LessonShape", "ConstantColumn", "AdjustedAcf"],
            {"e": mat(rows_of(ecols)), "regressor": enc_regressor(Y, False), "max_lag": 10}, exp, tol)
    # N = 2 and a constant residual.
    ecols = [[1.0, -1.0], [0.5, 0.5]]
    Y = [[[1.0, 2.0], [3.0, 3.0]], [[2.0, 2.0], [4.0, 1.0]]]
    exp, tol = xcorr_expected(ecols, Y, 1, True, None, 0.95)
    fam.add("cross_correlation", {"adjusted": True, "level": 0.95, "segments": None, "nan_policy": "raise"},
            "N = 2: joint 1 residual constant (row NaN, mask false); column 1 of joint 0 constant (mask true)",
            ["MinimumSamples", "ConstantResidual", "ConstantColumn", "AdjustedAcf"],
            {"e": mat(rows_of(ecols)), "regressor": enc_regressor(Y, False), "max_lag": 1}, exp, tol)
    return fam


# ---- information criteria --------------------------------------------------------------------


def ic_terms(fit: mpf, n: int, nvec: int, size: mpf, p: int, raise_near: bool) -> tuple[dict, dict]:
    """aic, bic, aicc, fpe, naic from the fit term F, n, N_vec, S and p (contract §3.7)."""
    if mpmath.isinf(fit):
        vals = {"aic": -INF, "bic": -INF, "aicc": -INF, "fpe": mpf(0), "naic": -INF}
        if p >= n - 1:
            vals["aicc"], vals["fpe"] = NAN, NAN
        return vals, {k: 0.0 for k in vals}
    aic = fit + 2 * p
    bic = fit + p * mpmath.log(n)
    if p >= n - 1:
        aicc = fpe = NAN
    else:
        aicc = aic + mpf(2 * p * (p + 1)) / (n - p - 1)
        fpe = size * (1 + mpf(p) / n) / (1 - mpf(p) / n)
    naic = fit / nvec + mpf(2 * p) / n
    base = abs(fit) + n
    tol = {"aic": RTOL * f64(base + 2 * p), "bic": RTOL * f64(base + abs(p * mpmath.log(n))),
           "aicc": RTOL * f64(base + 2 * p + (0 if p >= n - 1 else abs(aicc - aic))),
           "fpe": 0.0 if mpmath.isnan(fpe) else RTOL * f64(abs(fpe)),
           "naic": RTOL * f64(abs(fit) / nvec + 1 + mpf(2 * p) / n)}
    return {"aic": aic, "bic": bic, "aicc": aicc, "fpe": fpe, "naic": naic}, tol


def criteria_values(meas, pred, p: int, noise_model: str) -> tuple[dict, dict, int]:
    ec = resid_cols(meas, pred)
    n, m = len(meas), len(ec)
    sse = [msum(x * x for x in c) for c in ec]
    if noise_model == "pooled":
        total = msum(sse)
        nn = n * m
        fit = -INF if total == 0 else nn * mpmath.log(total / nn)
        return (*ic_terms(fit, nn, nn, total / nn, p, False), nn)
    if noise_model == "per_joint":
        fit = -INF if any(s_ == 0 for s_ in sse) else n * msum(mpmath.log(s_ / n) for s_ in sse)
        size = mpf(1)
        for s_ in sse:
            size *= s_ / n
        return (*ic_terms(fit, n, n, size, p, False), n)
    sigma = mpmath.matrix(m, m)
    for a in range(m):
        for b in range(m):
            sigma[a, b] = msum(x * y for x, y in zip(ec[a], ec[b])) / n
    det = mpmath.det(sigma)
    fit = -INF if det == 0 else n * mpmath.log(det)
    return (*ic_terms(fit, n, n, det, p, False), n)


def dyadic_residual(n_big: int, n_small: int, big: float, small: float) -> list[float]:
    """Residuals of alternating sign with exactly known sum of squares (dyadic values)."""
    vals = [big] * n_big + [small] * n_small
    return [v if k % 2 == 0 else -v for k, v in enumerate(vals)]


def build_information_criteria() -> Family:
    fam = Family("information_criteria", [
        "AIC, BIC, AICc, FPE and nAIC without the Gaussian constant (contract §3.7): information_criteria(rss, "
        "n_obs, n_params), and criteria/aic/bic on tau_meas, tau_pred under a noise model.",
        "Tolerance: RTOL * (|F| + n + |penalty|) for aic/bic/aicc (F = n ln sigma^2 carries an absolute error of "
        "order n * eps), RTOL * fpe, RTOL * (|F|/N_vec + 1 + 2p/n) for naic.",
    ])
    # The lesson's Problem 4 from (rss, n_obs, n_params).
    for rss, p, model in ((10, 6, 1), (8.5, 10, 2)):
        vals, tol = ic_terms(1000 * mpmath.log(mpf(rss) / 1000), 1000, 1000, mpf(rss) / 1000, p, True)
        flags = ["LessonProblem4"] + (["LessonSlip"] if model == 2 else [])
        note = ("lesson: AIC2 ~ 20 + 1000(-4.7690), BIC2 ~ 69.078 + 1000(-4.7690); exact log 0.0085 = "
                f"{mpmath.nstr(mpmath.log(mpf('0.0085')), 12)}") if model == 2 else "lesson: AIC1 ~ 12 + 1000(-4.6052)"
        fam.add("information_criteria", {}, f"Problem 4, model {model}: RSS = {rss}, p = {p}, N = 1000; {note}",
                flags, {"rss": rss, "n_obs": 1000, "n_params": p}, {k: num(v) for k, v in vals.items()}, tol,
                method="analytic")
    for rss, nobs, p, comment, flags in (
        (2.5, 10, 3, "small n", ["Basic"]),
        (1e-8, 500, 20, "tiny rss", ["TinyScale"]),
        (3.5e9, 1200, 84, "huge rss, 84 parameters (a 7-DOF arm, 12 per joint)", ["HugeScale"]),
        (0, 50, 4, "rss = 0: -Infinity, fpe 0", ["ExactFit"]),
        (4.0, 20, 0, "no parameters", ["Basic"]),
        (4.0, 20, 18, "p = n - 2: largest p with aicc and fpe defined", ["ParamsNearN"]),
    ):
        fit = -INF if rss == 0 else nobs * mpmath.log(mpf(rss) / nobs)
        vals, tol = ic_terms(fit, nobs, nobs, mpf(rss) / nobs, p, True)
        fam.add("information_criteria", {}, comment, flags, {"rss": rss, "n_obs": nobs, "n_params": p},
                {k: num(v) for k, v in vals.items()}, tol)
    # Problem 4 from data: dyadic residuals with SSE exactly 10 and 8.5 over N = 1000.
    e1 = dyadic_residual(520, 480, 0.125, 0.0625)   # 520/64 + 480/256 = 10
    e2 = dyadic_residual(392, 608, 0.125, 0.0625)   # 392/64 + 608/256 = 8.5
    s = Stream(601)
    # Dyadic measurements (multiples of 1/1024) so that tau_pred = tau_meas - e is exact.
    meas = [round((5.0 + 2.0 * s.normal()) * 1024) / 1024 for _ in range(1000)]
    for e, p, model in ((e1, 6, 1), (e2, 10, 2)):
        pred = [mv - ev for mv, ev in zip(meas, e)]
        assert all(mv - pv == ev for mv, pv, ev in zip(meas, pred, e))  # exact subtraction
        mrows, prows = [[v] for v in meas], [[v] for v in pred]
        vals, tol, nn = criteria_values(mrows, prows, p, "pooled")
        flags = ["LessonProblem4"] + (["LessonSlip"] if model == 2 else [])
        inputs = {"tau_meas": arr(meas, [1000]), "tau_pred": arr(pred, [1000]), "n_params": p}
        fam.add("criteria", {"noise_model": "pooled", "nan_policy": "raise"},
                f"Problem 4, model {model} from data: 1000 dyadic residuals with SSE exactly {'10' if model == 1 else '8.5'}",
                flags + ["OneDimensional"], inputs, {**{k: num(v) for k, v in vals.items()}, "n_obs": nn},
                {**tol, "n_obs": 0})
        for op in ("aic", "bic"):
            fam.add(op, {"noise_model": "pooled", "nan_policy": "raise"},
                    f"Problem 4, model {model} from data ({op})", flags + ["OneDimensional"], inputs,
                    {"value": num(vals[op])}, {"value": tol[op]})
    # Noise models on multi-joint data.
    sets = []
    s = Stream(602)
    meas = trajectory(s, 60, 3, [1.0, 5.0, -2.0], [1.0, 10.0, 0.5])
    sets.append(("three joints with noise levels 0.05, 2, 0.01 (pooled and per-joint rank differently)",
                 ["NoiseModel", "MixedScales"], meas, predict(s, meas, [0.05, 2.0, 0.01])))
    s = Stream(603)
    meas = trajectory(s, 200, 6, [0.0] * 6, [5.0, 8.0, 3.0, 1.0, 0.5, 0.2])
    sets.append(("the lesson's layout (200, 6), coloured residuals", ["NoiseModel", "LessonShape"], meas,
                 predict(s, meas, [0.5, 0.8, 0.3, 0.1, 0.05, 0.02], ar=0.6)))
    s = Stream(604)
    meas = trajectory(s, 40, 2, [1e7, -1e7], [1.0, 1.0])
    sets.append(("offset 1e7 joints", ["NoiseModel", "LargeOffset"], meas, predict(s, meas, [0.01, 0.02])))
    s = Stream(605)
    meas = trajectory(s, 30, 1, [0.0], [1.0])
    sets.append(("single joint: the three noise models agree", ["NoiseModel"], meas, predict(s, meas, [0.1])))
    s = Stream(606)
    meas = trajectory(s, 25, 2, [1.0, 1.0], [1.0, 1.0])
    pred = [[r[0], q(r[1] - 0.1 * s.normal())] for r in meas]
    sets.append(("joint 0 predicted exactly: per_joint and full give -Infinity, pooled stays finite",
                 ["NoiseModel", "ExactFit"], meas, pred))
    sets.append(("N = 2, m = 2", ["NoiseModel", "MinimumSamples"], [[1.0, 2.0], [3.0, 5.0]],
                 [[0.5, 2.5], [3.25, 4.0]]))
    for comment, flags, meas, pred in sets:
        n = len(meas)
        for nm in ("pooled", "per_joint", "full"):
            for p in sorted({2, min(10, n - 3) if n > 4 else 1}):
                vals, tol, nn = criteria_values(meas, pred, p, nm)
                inputs = {"tau_meas": mat(meas), "tau_pred": mat(pred), "n_params": p}
                fam.add("criteria", {"noise_model": nm, "nan_policy": "raise"}, f"{comment}; p = {p}", flags,
                        inputs, {**{k: num(v) for k, v in vals.items()}, "n_obs": nn}, {**tol, "n_obs": 0})
            p = 2
            vals, tol, _ = criteria_values(meas, pred, p, nm)
            for op in ("aic", "bic"):
                fam.add(op, {"noise_model": nm, "nan_policy": "raise"}, f"{comment}; p = {p} ({op})", flags,
                        {"tau_meas": mat(meas), "tau_pred": mat(pred), "n_params": p},
                        {"value": num(vals[op])}, {"value": tol[op]})
    # p >= n - 1 in criteria: aicc and fpe are NaN, no error.
    meas, pred = [[1.0], [2.0], [4.0], [3.0]], [[1.5], [2.0], [3.0], [3.5]]
    for p in (3, 5):
        vals, tol, nn = criteria_values(meas, pred, p, "pooled")
        fam.add("criteria", {"noise_model": "pooled", "nan_policy": "raise"},
                f"N = 4, p = {p} >= n - 1: aicc and fpe NaN", ["ParamsNearN"],
                {"tau_meas": mat(meas), "tau_pred": mat(pred), "n_params": p},
                {**{k: num(v) for k, v in vals.items()}, "n_obs": nn}, {**tol, "n_obs": 0})
    return fam


# ---- errors ----------------------------------------------------------------------------------

NAN_F = float("nan")


def build_errors() -> Family:
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


BUILDERS: dict[str, Callable[[], Family]] = {
    "norms": build_norms,
    "normalized_fit": build_normalized_fit,
    "residual_statistics": build_residual_statistics,
    "autocorrelation": build_autocorrelation,
    "portmanteau": build_portmanteau,
    "cross_correlation": build_cross_correlation,
    "information_criteria": build_information_criteria,
    "errors": build_errors,
}


def build(families: Sequence[str] = FAMILIES) -> dict[str, str]:
    """Family -> file text, computed in memory."""
    if mpmath.__version__ != MPMATH_VERSION:
        msg = f"mpmath {MPMATH_VERSION} is required for byte-for-byte regeneration, found {mpmath.__version__}"
        raise RuntimeError(msg)
    mp.dps = DPS
    return {name: dumps(BUILDERS[name]().document()) for name in families}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=HERE / "vectors", help="output directory")
    parser.add_argument("--check", action="store_true", help="compare with the files instead of writing")
    parser.add_argument("--families", default=",".join(FAMILIES), help="comma-separated families")
    args = parser.parse_args(argv)
    texts = build([f for f in args.families.split(",") if f])
    stale = []
    for name, text in texts.items():
        path = args.out / f"{name}.json"
        if args.check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                stale.append(str(path))
        else:
            args.out.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8", newline="\n")
    if stale:
        print("out of date:\n  " + "\n  ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
