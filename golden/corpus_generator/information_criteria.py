"""Family information_criteria: AIC, BIC, AICc, FPE, nAIC (contract §3.7)."""

from __future__ import annotations

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._exact import INF, NAN, f64, msum, resid_cols
from ._family import Family
from ._inputs import EXTREME_SCALES, Stream, predict, q, scale_comment, scaled, trajectory
from ._json import arr, mat, num


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
           # an fpe beyond float64's range is +inf exactly: compared for equality, not within inf
           "fpe": 0.0 if mpmath.isnan(fpe) or mpmath.isinf(f64(fpe)) else RTOL * f64(abs(fpe)),
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


def build() -> Family:
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
                f"Problem 4, model {model} from data: 1000 dyadic residuals with SSE exactly "
                f"{'10' if model == 1 else '8.5'}",
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
    # The lesson's own route to an exact fit: 1-D data predicted exactly, pooled. Its Wolfram code
    # gives 2p + N·Log[0.] = 4. + Indeterminate under Mathics instead of -Infinity.
    one = [1.0, 2.5, 3.2, 4.1, 4.8, 6.1]
    rows = [[v] for v in one]
    vals, tol, nn = criteria_values(rows, rows, 2, "pooled")
    inputs = {"tau_meas": arr(one, [6]), "tau_pred": arr(one, [6]), "n_params": 2}
    flags = ["ExactFit", "OneDimensional", "LessonLogZero"]
    fam.add("criteria", {"noise_model": "pooled", "nan_policy": "raise"},
            "1-D data predicted exactly (the lesson's route): -Infinity, fpe 0", flags, inputs,
            {**{k: num(v) for k, v in vals.items()}, "n_obs": nn}, {**tol, "n_obs": 0})
    for op in ("aic", "bic"):
        fam.add(op, {"noise_model": "pooled", "nan_policy": "raise"},
                f"1-D data predicted exactly ({op}): -Infinity", flags, inputs,
                {"value": num(vals[op])}, {"value": tol[op]})
    # ExtremeScale: F = n·ln σ² stays finite when σ² itself underflows; fpe is IEEE (0 or subnormal).
    s = Stream(652)
    base_meas = trajectory(s, 30, 2, [1.0, -2.0], [2.0, 1.0])
    base_pred = predict(s, base_meas, [0.3, 0.2])
    for factor in EXTREME_SCALES:
        meas, pred = scaled(base_meas, factor), scaled(base_pred, factor)
        for nm in ("pooled", "per_joint", "full"):
            vals, tol, nn = criteria_values(meas, pred, 2, nm)
            # An fpe below the normal range is rounded twice by a float64 implementation (σ² scaled
            # back, then the factor): a few units of the smallest subnormal are allowed there.
            tol = {**tol, "fpe": max(tol["fpe"], 2.0**-1070)}
            fam.add("criteria", {"noise_model": nm, "nan_policy": "raise"}, f"{scale_comment(factor)}; p = 2",
                    ["ExtremeScale", "NoiseModel"], {"tau_meas": mat(meas), "tau_pred": mat(pred), "n_params": 2},
                    {**{k: num(v) for k, v in vals.items()}, "n_obs": nn}, {**tol, "n_obs": 0})
    return fam
