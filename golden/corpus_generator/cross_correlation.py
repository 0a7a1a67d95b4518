"""Family cross_correlation: residual against regressor columns (contract §3.6)."""

from __future__ import annotations

from collections.abc import Sequence

import mpmath
from mpmath import mpf

from ._config import RTOL
from ._exact import (
    NAN,
    M,
    f64,
    is_const,
    lag_products,
    mean_error,
    mmean,
    msum,
    norm_ppf_two_sided,
    rows_of,
    seg_bounds,
)
from ._family import Family
from ._inputs import EXTREME_SCALES, Stream, q, scale_comment, scaled
from ._json import arr, mat, num


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


def build() -> Family:
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
    # ExtremeScale: R_e(0)·R_Y(0) overflows at 1e80 and underflows at 1e-80; e and Y at the same
    # scale, and e scaled with Y left at 1 (the normalisation must not mix the two scales).
    s = Stream(552)
    base_e = [s.ar1(40, 0.5, 1.0), s.noise(40, 0.7)]
    base_y = regressor(s, 40, 2, 2)
    for k in range(40):
        for j in range(2):
            base_y[k][j][0] = q(base_y[k][j][0] + 0.8 * base_e[j][k])
    for factor in EXTREME_SCALES:
        for y_factor in (factor, 1.0):
            ecols, Y = scaled(base_e, factor), scaled(base_y, y_factor)
            exp, tol = xcorr_expected(ecols, Y, 3, True, None, 0.95)
            where = "e and regressor" if y_factor != 1.0 else "e only"
            fam.add("cross_correlation", {"adjusted": True, "level": 0.95, "segments": None, "nan_policy": "raise"},
                    f"{where} {scale_comment(factor)}, N = 40, max_lag = 3", ["ExtremeScale", "AdjustedAcf"],
                    {"e": mat(rows_of(ecols)), "regressor": enc_regressor(Y, False), "max_lag": 3}, exp, tol)
    return fam
