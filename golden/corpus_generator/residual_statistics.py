"""Family residual_statistics: residual mean, variance and the zero-mean test (contract §3.3)."""

from __future__ import annotations

from typing import Any

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._exact import INF, NAN, M, acf_tol, css, f64, mmean, msum, pspread, rows_of, seg_bounds, t_sf2
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
from ._json import arr, mat


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


def build() -> Family:
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
        check_certified(name, "mean", mu, c["mean"], 14)
        check_certified(name, "sd", mpmath.sqrt(var), c["sd"], 8)
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
    # ExtremeScale: the variance only where it is itself a normal float64.
    s = Stream(252)
    base_cols = [s.noise(60, 0.5), s.ar1(60, 0.7, 1.0)]
    for factor in EXTREME_SCALES:
        cols = scaled(base_cols, factor)
        ec = [[M(x) for x in c] for c in cols]
        big = max(abs(x) for c in cols for x in c)
        e_in = mat(rows_of(cols))
        fam.add("residual_mean", {"nan_policy": "raise"}, scale_comment(factor), ["ExtremeScale"], {"e": e_in},
                {"value": arr([mmean(c) for c in ec], [len(cols)])}, {"value": RTOL * big})
        if 1e-150 <= factor <= 1e140:
            var = [css(c) / (len(c) - 1) for c in ec]
            fam.add("residual_variance", {"ddof": 1, "nan_policy": "raise"}, scale_comment(factor), ["ExtremeScale"],
                    {"e": e_in}, {"value": arr(var, [len(cols)])}, {"value": RTOL * f64(max(var)) + (1e-12 * big) ** 2})
        exp, tol = zero_mean_expected(cols, None)
        fam.add("zero_mean_test", {"segments": None, "nan_policy": "raise"}, scale_comment(factor),
                ["ExtremeScale"], {"e": e_in}, exp, tol)
    return fam
