"""Exact arithmetic (mpmath at 50 digits, contract §3): the formulas every expected value comes from,
rounded once to float64 at the end, and the tolerance helpers that go with them."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

import mpmath
from mpmath import mpf
from mpmath.libmp import to_float

from ._config import RTOL


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


def columns(rows: Sequence[Sequence[float]]) -> list[list[float]]:
    return [list(c) for c in zip(*rows)]


def rows_of(cols: Sequence[Sequence[float]]) -> list[list[float]]:
    return [list(r) for r in zip(*cols)]


def resid_cols(meas: Sequence[Sequence[float]], pred: Sequence[Sequence[float]]) -> list[list[mpf]]:
    return [[M(a) - M(b) for a, b in zip(ca, cb)] for ca, cb in zip(columns(meas), columns(pred))]


def ieee_mean(values: Sequence[mpf]) -> mpf:
    if any(mpmath.isnan(v) for v in values):
        return NAN
    if any(mpmath.isinf(v) for v in values):
        return -INF if any(v == -INF for v in values) and not any(v == INF for v in values) else NAN
    return msum(values) / len(values)


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


def pspread(fn: Callable, x: mpf, dx: mpf, y: mpf, dy: mpf) -> float:
    """Absolute tolerance of fn(x, y) when x, y carry the absolute errors dx, dy."""
    base = fn(x, y)
    worst = mpf(0)
    for sx in (-1, 1):
        for sy in (-1, 1):
            worst = max(worst, abs(fn(x + sx * dx, y + sy * dy) - base))
    return f64(1e-12 * abs(base) + worst) + 1e-15
