"""Family portmanteau: Ljung-Box and Box-Pierce (contract §3.5)."""

from __future__ import annotations

from typing import Any

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._exact import NAN, M, acf_tol, chi2_sf, f64, msum, n_products, pspread, rows_of, seg_bounds
from ._family import Family
from ._inputs import EXTREME_SCALES, Stream, q, scale_comment, scaled
from ._json import arr, mat


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
            tp.append(pspread(lambda a, b, df=df: chi2_sf(a, df), qv, mpf(dq), mpf(0), mpf(0)))
            tl.append(pspread(lambda a, b, df=df: mpmath.log(chi2_sf(a, df)), qv, mpf(dq), mpf(0), mpf(0)))
    k = len(lags)
    exp = {"statistic": arr(stat, [k, m]), "pvalue": arr(pv, [k, m]), "log_pvalue": arr(lp, [k, m]),
           "df": arr([h - model_df for h in lags], [k])}
    tol = {"statistic": arr(tq, [k, m]), "pvalue": arr(tp, [k, m]), "log_pvalue": arr(tl, [k, m]), "df": 0}
    return exp, tol


def build() -> Family:
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
    # ExtremeScale: at 1e-162 every square underflows and a naive Q is N·h.
    s = Stream(452)
    base_cols = [s.ar1(60, 0.5, 1.0), s.noise(60, 2.0)]
    for factor in EXTREME_SCALES:
        cols = scaled(base_cols, factor)
        for test in ("ljung_box", "box_pierce"):
            exp, tol = portmanteau_expected(cols, [5, 10], 0, None, test)
            fam.add(test, {"model_df": 0, "segments": None, "nan_policy": "raise"},
                    f"{scale_comment(factor)}, N = 60, lags = [5, 10]", ["ExtremeScale", "SeveralLags"],
                    {"e": mat(rows_of(cols)), "lags": [5, 10]}, exp, tol)
    return fam
