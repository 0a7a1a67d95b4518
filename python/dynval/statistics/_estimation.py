"""What the estimation run tells the findings: the parameters' uncertainty and which term to add.

A model validated on a new trajectory leaves a residual that is noise *plus* the error of its
estimated parameters, Y_val (π − π̂). On coloured data that error is large (few effective samples)
and it shows on the validation run as a mean and as correlations with the model's own columns, which
a test that only knows the validation noise would blame on the model. Given the estimation run
(``estimation={"regressor", "tau"}``), dynval refits the model's columns by least squares on it and
takes the covariance of π̂ from the sandwich (XᵀX)⁻¹ XᵀΓX (XᵀX)⁻¹ with Γ the prewhitened covariance
of the estimation residual (:func:`dynval.statistics._stats.score_covariance`, coloured noise allowed). That covariance
widens the bias test and the residual × regressor tests by exactly the part of the statistic the
parameter error explains (docs/conventions.md §5.4).

The same run answers "which term is missing": refit with each column the model lacks added, test
its coefficient (Wald t with the same covariance) and measure, on the validation run, the share of
each joint's mean square the added term removes — an out-of-sample effect, and the column named.
Without the estimation run the validation run alone answers it (:func:`added_variable`): the
residual's correlation with the part of each absent column the model's columns cannot represent.
The residual × regressor standard deviations widened by the parameter error are
:func:`parameter_error_sd`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

if TYPE_CHECKING:
    import scipy.stats
else:
    from .._lazy import scipy

from . import _stats

__all__ = ["EstimationFit", "fit_columns", "missing_terms", "quadratic_forms", "noise_covariance",
           "parameter_error_sd", "added_variable"]

_T = TypeVar("_T")
# A store of results that depend on the regressor alone, keyed by what they depend on (the report's
# prepared regressor keeps them across calls): memo(key, compute) returns compute()'s value.
Memo = Callable[[tuple[Hashable, ...], Callable[[], Any]], Any]


def _compute_now(key: tuple[Hashable, ...], compute: Callable[[], _T]) -> _T:
    """The memo that keeps nothing."""
    return compute()


@dataclass(frozen=True)
class EstimationFit:
    """Least squares of ``columns`` on the stacked estimation run, with a coloured-noise covariance."""

    columns: tuple
    coefficients: np.ndarray  # (k,)
    covariance: np.ndarray  # (k, k): the sandwich with the residual's autocovariance
    residual: np.ndarray  # (N_e, m)
    n_eff: np.ndarray  # (m,) of the residual


def _column_scales(stacked):
    """Per column 1/its norm, and 0 for a zero column (contract §4: norm 0 or at most 1e-13 of the
    median norm): the least squares and the pseudo-inverse are taken on unit-norm columns, so that
    their rank decisions (relative to the largest singular value) and the minimum-norm choice among
    dependent columns do not depend on the columns' units (columns 1e6 apart put a direction of the
    Gram matrix below pinv's 1e-15), and a column the run does not excite gets no coefficient and no
    variance."""
    from ._columns import column_norms, zero_columns

    norms = column_norms(stacked)
    zero = zero_columns(norms)
    return np.where(zero, 0.0, 1.0 / np.where(zero, 1.0, norms))


def _least_squares(reg3, tau, columns):
    x = reg3[:, :, list(columns)]
    n, m, k = x.shape
    stacked = x.reshape(n * m, k)
    d = _column_scales(stacked)
    coef_s, *_ = np.linalg.lstsq(stacked * d, tau.reshape(-1), rcond=None)
    coef = coef_s * d
    return x, coef, tau - x @ coef


def _sandwich(x, resid):
    """(XᵀX)⁺ XᵀΓX (XᵀX)⁺ with Γ the residual's prewhitened covariance; and the residual's N_eff.
    (XᵀX)⁺ = D (DXᵀXD)⁺ D on the unit-size columns XD (:func:`_column_scales`)."""
    k = x.shape[2]
    stacked = x.reshape(-1, k)
    d = _column_scales(stacked)
    xs = stacked * d
    ainv = d[:, None] * np.linalg.pinv(xs.T @ xs) * d[None, :]  # a column the run does not excite has no variance
    n_eff = _stats.long_run_variance(resid, np.array([0])).n_eff
    return ainv @ _stats.score_covariance(x, resid) @ ainv, n_eff


def fit_columns(reg3, tau, columns) -> EstimationFit:
    """Refit ``columns`` on the estimation run; covariance from the residual's autocovariance."""
    x, coef, resid = _least_squares(reg3, tau, columns)
    cov, n_eff = _sandwich(x, resid)
    return EstimationFit(tuple(int(c) for c in columns), coef, cov, resid, n_eff)


_NORMAL_RCOND = 1e-10
"""Eigenvalues of the unit-diagonal normal equations below this fraction of the largest are dependent
directions (a column within 1e-5 of the others' span adds nothing to the residual)."""


def noise_covariance(fit: EstimationFit, reg3, structure) -> np.ndarray:
    """Cov(π̂) with the estimation residual's structure removed: the sandwich of :func:`fit_columns`
    on the residual of the stacked refit of the model's columns and ``structure[j]`` (an (N, k_j)
    array on joint j's rows, or None), scaled by √(N·m/(N·m − r)), r the rank the structure adds
    to the model's, so that white noise keeps its variance. The estimation fit's own covariance when
    no joint has a structure.

    A model that lacks a term leaves it in its estimation residual, and a slow deterministic torque
    read as coloured noise makes the sandwich's long-run variance (so Cov(π̂)) orders of magnitude too
    wide: the parameters' sampling error is the noise's, not the missing torque's. This is the
    covariance under the alternative, as a Wald test takes it (conventions §5.2, "Cov(π̂) under the
    alternative"). The refit is solved on its normal equations, assembled joint by joint (the
    structure's columns are each on one joint's rows), scaled to a unit diagonal, directions below
    :data:`_NORMAL_RCOND` left out: only its residual is used, which such directions do not move."""
    blocks = [(j, np.asarray(c, dtype=np.float64)) for j, c in enumerate(structure) if c is not None and c.shape[1]]
    if not blocks:
        return fit.covariance
    x = np.asarray(reg3, dtype=np.float64)[:, :, list(fit.columns)]
    resid = np.asarray(fit.residual, dtype=np.float64)
    n, m, k = x.shape
    sizes = np.cumsum([k] + [c.shape[1] for _, c in blocks])
    gram = np.zeros((sizes[-1], sizes[-1]))
    rhs = np.zeros(sizes[-1])
    gram[:k, :k] = np.einsum("nmk,nml->kl", x, x)
    rhs[:k] = np.einsum("nmk,nm->k", x, resid)
    for (j, c), lo, hi in zip(blocks, sizes[:-1], sizes[1:]):
        gram[:k, lo:hi] = x[:, j, :].T @ c
        gram[lo:hi, :k] = gram[:k, lo:hi].T
        gram[lo:hi, lo:hi] = c.T @ c
        rhs[lo:hi] = c.T @ resid[:, j]
    coef, rank = _solve_normal(gram, rhs)
    own = _solve_normal(gram[:k, :k], rhs[:k])[1] if k else 0
    left = resid - x @ coef[:k]
    for (j, c), lo, hi in zip(blocks, sizes[:-1], sizes[1:]):
        left[:, j] -= c @ coef[lo:hi]
    left *= np.sqrt(n * m / max(n * m - (rank - own), 1))
    return _sandwich(x, left)[0]


def _solve_normal(gram: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, int]:
    """The minimum-norm solution of the normal equations on their unit-diagonal scaling (zero columns
    left out), and their rank (eigenvalues above :data:`_NORMAL_RCOND` of the largest)."""
    diag = np.diag(gram)
    d = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 0.0)
    w, v = np.linalg.eigh(gram * d[:, None] * d[None, :])
    keep = w > _NORMAL_RCOND * max(float(w.max(initial=0.0)), 0.0)
    coef = v[:, keep] @ ((v[:, keep].T @ (rhs * d)) / w[keep])
    return coef * d, int(keep.sum())


def quadratic_forms(fit: EstimationFit, g) -> np.ndarray:
    """gᵀ Cov(π̂) g for each row g of ``g`` (..., k): the variance a linear statistic gets from π̂."""
    g = np.asarray(g, dtype=np.float64)
    return np.einsum("...i,ij,...j->...", g, fit.covariance, g)


def missing_terms(est_reg3, est_tau, val_reg3, val_tau, model_columns):
    """Refit with every column outside ``model_columns`` added together; test each and measure
    what it removes once the others are in.

    Terms that interact are refitted together (a shoulder friction column refitted alone also moves
    the elbow's parameters and can look like the elbow's missing term): one least-squares refit on
    the estimation run with the model's columns and every absent column, the Wald t of each added
    coefficient with the coloured-noise covariance, and, per column c, the refit without c.

    Returns a dict: ``columns`` (q,), ``statistic`` (q,) Wald t of each added coefficient in the
    joint refit, ``pvalue`` (q,) from Student t with N_eff − 1 degrees of freedom (N_eff the
    smallest effective sample size of the estimation residual's joints), ``share`` (m, q) the share
    of each joint's validation mean square column c removes from the refit without it (negative when
    it makes the validation worse; on a joint whose rows c enters in neither run, what it moves
    through the shared parameters refitted with it), ``alone`` (m, q) the share column c removes
    when it is the only column added to the model's (refitted on the estimation run, measured on the
    validation run), ``enters`` (m, q): c enters the joint's rows in
    one of the runs (an offset of the shoulder does not enter the wrist's: adding it is the
    shoulder's step, which also helps the wrist), and ``explains_bias`` (m, q): c enters the joint
    and adding it at least halves the joint's validation mean. None when every column is in the model.
    """
    p = est_reg3.shape[2]
    inside = [int(c) for c in model_columns]
    outside = [c for c in range(p) if c not in set(inside)]
    if not outside:
        return None
    n_val, m = val_tau.shape
    _, coef0, _ = _least_squares(est_reg3, est_tau, inside) if inside else (None, np.zeros(0), est_tau)
    e0 = val_tau - (val_reg3[:, :, inside] @ coef0 if inside else 0.0)
    mse0 = np.mean(e0**2, axis=0)
    q = len(outside)
    stat, pval = np.full(q, np.nan), np.full(q, np.nan)
    share, explains = np.full((m, q), np.nan), np.zeros((m, q), dtype=bool)
    alone = np.full((m, q), np.nan)
    every = inside + outside
    x, coef, resid = _least_squares(est_reg3, est_tau, every)
    cov, n_eff = _sandwich(x, resid)
    df = max(float(np.min(n_eff)) - 1.0, 1.0)
    for i in range(q):
        k = len(inside) + i
        if cov[k, k] > 0:
            stat[i] = coef[k] / np.sqrt(cov[k, k])
            pval[i] = 2.0 * scipy.stats.t.sf(abs(stat[i]), df)
    # The refits without one column from the estimation run's Gram matrix, their validation mean
    # squares and means from the validation run's (per joint): no pass over the rows per column.
    stacked = est_reg3[:, :, every].reshape(-1, len(every))
    d = _column_scales(stacked)  # the refits without one column on unit-size columns, as above
    gram, rhs = (stacked * d).T @ (stacked * d), (stacked * d).T @ est_tau.reshape(-1)
    yv = val_reg3[:, :, every]
    gv = np.einsum("nmk,nml->mkl", yv, yv)
    bv = np.einsum("nmk,nm->mk", yv, val_tau)
    tt = np.einsum("nm,nm->m", val_tau, val_tau)
    ysum, tsum = yv.sum(axis=0), val_tau.sum(axis=0)

    def validation(keep, c):
        mse = (tt - 2.0 * bv[:, keep] @ c + np.einsum("k,mkl,l->m", c, gv[np.ix_(range(m), keep, keep)], c)) / n_val
        return mse, (tsum - ysum[:, keep] @ c) / n_val

    mse_all, mean_all = validation(list(range(len(every))), coef)
    for i in range(q):
        keep = [k for k in range(len(every)) if k != len(inside) + i]
        c_wo = np.linalg.lstsq(gram[np.ix_(keep, keep)], rhs[keep], rcond=None)[0] * d[keep]
        mse_wo, mean_wo = validation(keep, c_wo)
        with np.errstate(invalid="ignore", divide="ignore"):
            share[:, i] = (mse_wo - mse_all) / mse0
        explains[:, i] = np.abs(mean_all) <= 0.5 * np.abs(mean_wo)
        # the column's own effect: what a user who adds this column alone gets (the leave-one-out
        # share above can be small when another absent column stands in for it in the joint refit)
        own = list(range(len(inside))) + [len(inside) + i]
        c_own = np.linalg.lstsq(gram[np.ix_(own, own)], rhs[own], rcond=None)[0] * d[own]
        with np.errstate(invalid="ignore", divide="ignore"):
            alone[:, i] = (mse0 - validation(own, c_own)[0]) / mse0
    enters = np.any(val_reg3[:, :, outside] != 0, axis=0) | np.any(est_reg3[:, :, outside] != 0, axis=0)
    explains &= enters
    return {"enters": enters, "columns": outside, "statistic": stat, "pvalue": pval, "share": share,
            "alone": alone, "explains_bias": explains, "method": "estimation_refit"}


def parameter_error_sd(rho, sd, e, reg3, fit: EstimationFit, starts, adjusted: bool, level: float,
                       memo: Memo = _compute_now) -> np.ndarray:
    """Widen the residual × regressor standard deviations by the estimated parameters' error.

    The residual on a new run is noise + Y_S δ (δ = π − π̂, S the model's columns), so its
    cross-covariance with column c at lag ℓ holds Σ_k δ_k R̂_{Y_k Y_c}(ℓ), of variance gᵀ Cov(π̂) g.
    Only cells with a raw p-value ≤ α are recomputed: the others cannot be rejected by Holm and
    only grow. Returns the new sd (m, p, L+1). ``adjusted``: the lag-ℓ products divided by their
    count (else by N); ``memo``: where the caller keeps what depends on the regressor alone.
    """
    alpha = 1.0 - level
    p_raw = _stats.correlation_pvalue(rho, sd)
    cells = np.argwhere(p_raw <= alpha)
    if cells.size == 0:
        return sd
    n = e.shape[0]
    sd = sd.copy()
    lengths = np.diff(np.append(starts, n))
    cols = list(fit.columns)
    ec = e - e.mean(axis=0)
    var_e = np.einsum("nm,nm->m", ec, ec) / n
    yc, var_y = memo(("centred_columns", reg3.shape), lambda: _centred_regressor(reg3))
    by_cell: dict[tuple[int, int], list[int]] = {}
    for j, c, lag in cells:
        by_cell.setdefault((int(j), int(lag)), []).append(int(c))
    one_segment = len(starts) == 1 and int(starts[0]) == 0
    model_cols: dict[int, np.ndarray] = {}
    for (j, lag), which in sorted(by_cell.items()):
        if one_segment:
            # the lagged rows are views of the joint's columns: no index arrays, no copies of Y
            if j not in model_cols:
                model_cols[j] = memo(("centred_model_columns", reg3.shape, j, fit.columns),
                                     partial(_joint_columns, yc, j, cols))
            g = (model_cols[j][lag:].T @ yc[:n - lag, j, which]).T
        else:
            cur, prev, _ = _stats._segment_lag_pairs(yc[:, j, :], starts, lag)
            g = (cur[:, cols].T @ prev[:, which]).T
        n_pairs = float(np.maximum(lengths - lag, 0).sum())
        g = g / (n_pairs if adjusted else float(n))  # (len(which), k)
        extra = quadratic_forms(fit, g)
        with np.errstate(invalid="ignore", divide="ignore"):
            sd[j, which, lag] = np.sqrt(sd[j, which, lag] ** 2 + extra / (var_e[j] * var_y[j, which]))
    return sd


def _joint_columns(yc: np.ndarray, j: int, cols: list[int]) -> np.ndarray:
    """Joint j's ``cols`` of the centred regressor, contiguous."""
    return np.ascontiguousarray(yc[:, j, cols])


def _centred_regressor(reg3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The regressor less its column means, and each column's variance (over N)."""
    yc = reg3 - reg3.mean(axis=0)
    return yc, np.einsum("nmp,nmp->mp", yc, yc) / reg3.shape[0]


def added_variable(e, reg3, model_columns: Sequence[int], starts, n_eff) -> dict[str, Any] | None:
    """Lag-0 correlation of each joint's residual with the part of each column the model lacks.

    For a column c outside the model's columns S, z_c = Y_c − P_S Y_c (least squares on the
    validation data, per joint) is what the model cannot represent of it; a missing term shows as
    a residual correlated with its z_c, while the model's compensation through S does not
    (the added-variable or partial-regression idea). Standard deviations are colour-aware as in
    the report's cross-correlation (Bartlett's variance with J ≥ 5 N/N_eff lags of the residual,
    ``n_eff`` its joints' effective sample sizes, None: white). Returns the ``missing_terms``
    mapping (``method`` "added_variable": ``columns`` (q,), ``statistic`` ρ, ``sd``, ``pvalue``,
    ``share``, ``explains_bias``, each (m, q)), or None when no column is outside the model or
    there are fewer than 4 rows per column.
    """
    n, m, p = reg3.shape
    outside = [c for c in range(p) if c not in set(model_columns)]
    if not outside or n < 4 * p:
        return None
    inside = [c for c in range(p) if c in set(model_columns)]
    z = np.empty((n, m, len(outside)))
    for j in range(m):
        y_out = reg3[:, j, outside]
        if inside:
            coef, *_ = np.linalg.lstsq(reg3[:, j, inside], y_out, rcond=None)
            y_out = y_out - reg3[:, j, inside] @ coef
        z[:, j, :] = y_out
    ec = e - e.mean(axis=0)
    zc = z - z.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.einsum("nm,nmq->mq", ec, zc) / np.sqrt(
            np.einsum("nm,nm->m", ec, ec)[:, None] * np.einsum("nmq,nmq->mq", zc, zc))
    # A column the model represents entirely (z ≈ 0) carries no evidence.
    rho = np.where(np.einsum("nmq,nmq->mq", zc, zc) > 1e-20 * np.einsum("nmq,nmq->mq", reg3[:, :, outside] ** 2,
                                                                       np.ones_like(zc)), rho, np.nan)
    lengths = np.diff(np.append(starts, n))
    tau_int = float(np.fmax.reduce(n / np.asarray(n_eff, dtype=float))) if n_eff is not None else 1.0
    tau_int = tau_int if np.isfinite(tau_int) else 1.0
    big = int(min(int(lengths.max()) - 1, max(1, math.ceil(5.0 * tau_int)), max(n // 4, 1)))
    rho_e = _stats.acf_fft(e, starts, big)
    rho_z = _stats.acf_fft(z.reshape(n, -1), starts, big).reshape(big + 1, m, len(outside))
    sd = _stats.cross_correlation_sd(rho_e, rho_z, np.array([float(n)]), np.array([float(n)]), n)[:, :, 0]
    # Effect: the share of the residual's mean square the term would remove if added (uncentred,
    # so a term whose absence shows as a bias counts its mean too).
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.einsum("nm,nmq->mq", e, z) ** 2 / (np.einsum("nm,nm->m", e, e)[:, None]
                                                      * np.einsum("nmq,nmq->mq", z, z))
    share = np.where(np.isnan(rho), np.nan, share)
    # The term accounts for the residual's mean when it would move it towards zero: sign(b·z̄) = sign(ē),
    # b = eᵀz/zᵀz.
    with np.errstate(invalid="ignore", divide="ignore"):
        sign = np.sign(np.einsum("nm,nmq->mq", e, z) * z.mean(axis=0))
    explains = sign * np.sign(e.mean(axis=0))[:, None] > 0
    return {"method": "added_variable", "columns": outside, "statistic": rho, "sd": sd,
                                "pvalue": _stats.correlation_pvalue(rho, sd), "share": share,
                                "explains_bias": explains}
