"""Information criteria (AIC, BIC, AICc, FPE, nAIC) with explicit noise models (contract §3.7).

The Gaussian constant is dropped here; profiles that keep it add it in the report.
"""

from __future__ import annotations

import math

import numpy as np

from ...checks._validation import check_n_obs, check_n_params, check_noise_model, check_rss
from ._common import finite_pair
from .norms import joint_major, pooled, sumsq_scaled

_LN2 = math.log(2.0)


def assemble(fit_term: float, n: int, n_vec: int, size: float, p: int) -> dict:
    """aic, bic, aicc, fpe, naic from F, n, N_vec, S and p (contract §3.7's order; nan where p >= n − 1)."""
    aic = fit_term + 2 * p
    bic = fit_term + p * math.log(n)
    if p < n - 1:
        aicc = aic + 2.0 * p * (p + 1) / (n - p - 1)
        fpe = size * (1 + p / n) / (1 - p / n)
    else:
        aicc = fpe = math.nan
    naic = fit_term / n_vec + 2.0 * p / n
    return {"aic": float(aic), "bic": float(bic), "aicc": float(aicc), "fpe": float(fpe), "naic": float(naic)}


def _n_log(n: int, variance: float) -> float:
    """n·ln(σ²), -inf for σ² = 0 without a numpy warning."""
    return -math.inf if variance == 0 else n * math.log(variance)


def information_criteria(rss, n_obs, n_params) -> dict:
    """Criteria from a residual sum of squares: σ̂² = rss/n, aic = 2p + n·ln σ̂², ..."""
    rss = check_rss(rss)
    n = check_n_obs(n_obs)
    p = check_n_params(n_params, n)
    variance = rss / n
    return assemble(_n_log(n, variance), n, n, variance, p)


def pooled_sum(s: np.ndarray, k: np.ndarray) -> tuple[float, int]:
    """Σ_j s_j·4^k_j as (total, K) with the value total·4^K, K the largest joint's exponent."""
    live = s > 0
    top = int(k[live].max()) if live.any() else 0
    return float(np.sum(np.ldexp(s, 2 * (k - top)))), top


def fit_term(e: np.ndarray, noise_model: str, sse=None):
    """(F, n, N_vec, S) of contract §3.7 for residuals ``e`` ``(N, m)``.

    ``sse``, the per-joint Σe² as (s, k) scaled sums (value s·4^k) when the caller has it
    already, saves a pass over ``e``. Logarithms take the exponent exactly, so F stays finite
    for data whose squares underflow.
    """
    n_samples, m = e.shape
    if noise_model == "pooled" and sse is None:
        s, ks = sumsq_scaled(pooled(e))
        return fit_term_from_sums(noise_model, n_samples, m, (s, ks))
    if noise_model == "per_joint" and sse is None:
        return fit_term_from_sums(noise_model, n_samples, m, sumsq_scaled(joint_major(e)))
    if noise_model != "full":
        return fit_term_from_sums(noise_model, n_samples, m, sse)
    # One power of two for every joint (Σ̂ of e·2^-k is Σ̂·4^-k), so eigenvalue ratios stay.
    k = int(sumsq_scaled(pooled(e))[1][0])
    if k:
        e = np.ldexp(e, -k)
    sigma = (e.T @ e) / n_samples  # not demeaned (MATLAB's multi-output convention)
    return fit_term_from_sums(noise_model, n_samples, m, None, sigma, k)


def fit_term_from_sums(noise_model: str, n_samples: int, m: int, sse, sigma=None, k_sigma: int = 0):
    """(F, n, N_vec, S) of contract §3.7 from sums: ``sse`` the per-joint Σe² as scaled sums
    (s, k) (value s·4^k; pooled: one entry is enough) for the pooled and per-joint models;
    ``sigma`` = EᵀE/N scaled by 4^-``k_sigma`` for the full one. :func:`fit_term` and the
    stream accumulator both come here.
    """
    if noise_model == "pooled":
        n = n_samples * m
        total, k = pooled_sum(*sse)
        if total == 0:
            return -math.inf, n, n, 0.0
        log_variance = math.log(total / n) + 2 * k * _LN2
        return n * log_variance, n, n, float(np.ldexp(total / n, 2 * k))
    if noise_model == "per_joint":
        s, k = sse
        if np.any(s == 0):
            return -math.inf, n_samples, n_samples, 0.0
        log_size = float(np.sum(np.log(s / n_samples) + 2 * k * _LN2))
        return n_samples * log_size, n_samples, n_samples, _exp(log_size)
    # Eigenvalues with numpy's matrix_rank tolerance decide singularity, so that both backends call
    # the same near-singular covariance singular (an LU or LDLT pivot test rounds differently).
    eigenvalues = np.linalg.eigvalsh(sigma)
    largest = float(eigenvalues[-1])
    if largest <= 0.0 or float(eigenvalues[0]) <= m * np.finfo(float).eps * largest:
        return -math.inf, n_samples, n_samples, 0.0
    logdet = math.fsum(np.log(eigenvalues)) + 2 * k_sigma * m * _LN2
    return n_samples * logdet, n_samples, n_samples, _exp(logdet)


def _exp(x: float) -> float:
    """e**x, +inf where it overflows (det Σ̂ of large in-range data): IEEE, as the C++ core gives."""
    try:
        return math.exp(x)
    except OverflowError:
        return math.inf


def criteria(meas, pred, n_params, noise_model) -> dict:
    """Criteria of ``tau_meas − tau_pred`` under a noise model; aicc, fpe nan when p >= n − 1."""
    meas, pred = finite_pair(meas, pred)
    p = check_n_params(n_params)
    noise_model = check_noise_model(noise_model)
    f, n, n_vec, size = fit_term(meas - pred, noise_model)
    out = assemble(f, n, n_vec, size, p)
    out["n_obs"] = int(n)
    out["fit_term"] = float(f)
    return out
