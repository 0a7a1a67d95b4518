"""Family autocorrelation: residual autocorrelation and the white-noise band (contract §3.4)."""

from __future__ import annotations

import mpmath

from ._config import RTOL
from ._exact import M, acf_tol, f64, norm_ppf_two_sided, rows_of, seg_bounds
from ._family import Family
from ._inputs import (
    EXTREME_SCALES,
    NIST_UNIVARIATE,
    Stream,
    check_certified,
    nist_certified,
    nist_univariate,
    q,
    scale_comment,
    scaled,
)
from ._json import arr, mat, num


def acf_expected(cols, max_lag, adjusted, segments):
    n = len(cols[0])
    bounds = seg_bounds(n, segments)
    res = [acf_tol([M(x) for x in c], max_lag, adjusted, bounds) for c in cols]
    values = [res[j][0][lag] for lag in range(max_lag + 1) for j in range(len(cols))]
    tols = [res[j][1][lag] for lag in range(max_lag + 1) for j in range(len(cols))]
    return values, arr(tols, [max_lag + 1, len(cols)])


def build() -> Family:
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
                    extra = ["LagZero"] if L == 0 else (["MaxLagLimit"] if longest - 1 == L else [])
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
            check_certified(name, "lag1", values[1], c["lag1_autocorr"], 12)
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
    # ExtremeScale: lag sums whose squares underflow (1e-162, subnormal data) or sit near the bound.
    s = Stream(352)
    base_cols = [s.ar1(80, 0.7, 1.0), s.noise(80, 0.5)]
    for factor in EXTREME_SCALES:
        cols = scaled(base_cols, factor)
        for adjusted in (True, False):
            values, tol = acf_expected(cols, 6, adjusted, None)
            fam.add("autocorrelation", {"adjusted": adjusted, "segments": None, "nan_policy": "raise"},
                    f"{scale_comment(factor)}, N = 80, max_lag = 6",
                    ["ExtremeScale", "AdjustedAcf" if adjusted else "BiasedAcf"],
                    {"e": mat(rows_of(cols)), "max_lag": 6}, {"value": arr(values, [7, 2])}, {"value": tol})
    return fam
