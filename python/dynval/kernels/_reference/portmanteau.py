"""Ljung–Box and Box–Pierce portmanteau statistics with chi-squared p-values."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import scipy.special
    import scipy.stats
else:
    from ..._lazy import scipy

from ...checks._validation import check_lags, check_model_df, check_test
from ._common import check_starts, finite_residual, segment_limit
from .correlation import biased_rho, centred_and_ss, product_counts

# Below this survival probability, log(sf) loses digits in the subnormal range or underflows.
_LOG_SF_SWITCH = 1e-280


def _log_upper_gamma_q(a: float, x: float) -> float:
    """log Q(a, x), the regularised upper incomplete gamma, for x > a + 1.

    Modified Lentz evaluation of the continued fraction for Γ(a, x), carried in log space so
    that p-values far below 1e-308 keep full relative precision in the logarithm.
    """
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    for i in range(1, 10_000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        if abs(d) < tiny:
            d = tiny
        c = b + an / c
        if abs(c) < tiny:
            c = tiny
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-16:
            break
    return -x + a * math.log(x) - float(scipy.special.gammaln(a)) + math.log(h)


def chi2_logsf(q, df) -> np.ndarray:
    """log of the chi-squared survival function, accurate where the probability underflows."""
    q, df = np.broadcast_arrays(np.asarray(q, dtype=np.float64), np.asarray(df, dtype=np.float64))
    out = np.array(scipy.stats.chi2.logsf(q, df), dtype=np.float64)
    sf = scipy.stats.chi2.sf(q, df)
    deep = np.isfinite(q) & (sf < _LOG_SF_SWITCH) & (q / 2 > df / 2 + 1)
    for idx in zip(*np.nonzero(deep)):
        out[idx] = _log_upper_gamma_q(df[idx] / 2.0, q[idx] / 2.0)
    return out


def portmanteau(e, lags, model_df, starts, test) -> dict:
    """Ljung–Box (``test="ljung_box"``) or Box–Pierce statistics at each lag h in ``lags``.

    Uses the biased autocorrelation. Returns ``statistic``, ``pvalue``, ``log_pvalue``
    ``(n_lags, m)`` and ``df`` ``(n_lags,)`` (= h − model_df).
    """
    e = finite_residual(e)
    n = e.shape[0]
    starts = check_starts(starts, n)
    lags = check_lags(lags, segment_limit(starts, n))
    model_df = check_model_df(model_df, int(lags.min()))
    test = check_test(test)

    h_max = int(lags.max())
    d, ss, _ = centred_and_ss(e)
    rho = biased_rho(d, ss, h_max, starts)[1:]
    if test == "ljung_box":
        terms = rho**2 / product_counts(starts, n, h_max)[1:, None]
        cumulative = n * (n + 2.0) * np.cumsum(terms, axis=0)
    else:
        cumulative = n * np.cumsum(rho**2, axis=0)
    statistic = cumulative[lags - 1]
    df = lags - model_df
    pvalue = scipy.stats.chi2.sf(statistic, df[:, None])
    log_pvalue = chi2_logsf(statistic, df[:, None])
    return {
        "statistic": statistic,
        "pvalue": np.asarray(pvalue, dtype=np.float64),
        "log_pvalue": log_pvalue,
        "df": df.astype(np.int64),
    }
