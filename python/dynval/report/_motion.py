"""Section builders that read the motion: missing physics, predictive failure and the run's power.

They complete ``_sections.py`` for what needs the trajectory (q, q̇, q̈) or the estimation run
(docs/conventions.md §5.2): each takes what it needs and returns one dict, and the rules in
``_findings.py`` read them through the evidence record. The statistics behind them live below the
report, each asked once: the physics test's named terms and their relation to the model
(:func:`dynval.statistics._named_terms.name_terms`, one typed record that :func:`physics` words),
the delay (:mod:`dynval.statistics._physics`) and the periodic noise
(:func:`dynval.statistics._periodic.periodic_error_test`), each on the model's own columns as the
phase picks them once (:func:`_model_columns`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

if TYPE_CHECKING:
    import scipy.stats

    from ._options import Options
    from ._sections import CheckedData, Lagged, Residual
else:
    from .._lazy import scipy

from ..statistics import _model_terms, _named_terms, _periodic, _physics
from ..statistics._estimation import EstimationFit
from . import _records as rec
from . import _sections as sec
from ._prepared import Memo, compute_now
from ._regressor_algebra import kinds_without_q

__all__ = ["physics", "delay", "predictive", "joint_excitation", "detectable_share"]


def delay(meas: np.ndarray, pred: np.ndarray, sample_rate: float | None) -> dict[str, Any]:
    """The time shift between measured and predicted torque (:func:`dynval.statistics._physics.delay_test`)."""
    return _physics.delay_test(meas, pred, sample_rate=sample_rate)


def physics(e: np.ndarray, pred: np.ndarray, q: np.ndarray, dq: np.ndarray | None, ddq: np.ndarray | None,
            sample_rate: float | None,
            reg3: np.ndarray | None, cols: Sequence[int] | None, est_fit: EstimationFit | None, level: float,
            est_run: Mapping[str, Any] | None = None, meas: np.ndarray | None = None, practical: float = 0.05,
            column_names: Sequence[str] | None = None, band: float | None = None) -> dict[str, Any]:
    """Each joint's residual against the physics library, its term named and related to the model
    (:func:`dynval.statistics._named_terms.name_terms`, one call), as the section's mapping: the
    section's ``decimation`` states the factor, the band and the rows where the log was decimated."""
    named = _named_terms.name_terms(e, pred, q, dq, ddq, sample_rate, reg3, cols, est_fit, level, est_run, meas,
                                    practical, column_names, band)
    tests, d, dec = named.tests, named.derivatives, named.decimation
    return {"naming": _NAMING_ESTIMATION if named.named_on_estimation else _NAMING_VALIDATION,
            "method": "prewhitened least squares (AR(≤ 2) by BIC), heteroscedasticity-robust Wald test per joint",
            "model_columns": _model_columns_words(named), "derivatives": d.method,
            "derivative_bandwidth_hz": d.bandwidth_hz,
            "derivative_source": named.derivative_source, "estimation_bandwidth_hz": (est_run or {}).get("bandwidth"),
            "groups": list(_physics.GROUPS), "tests": [t.to_dict() for t in tests],
            "model_kinds": named.model_kinds,
            "simulator_parameters": named.simulator_parameters,
            "pvalue": np.array([t.pvalue for t in tests]), "share": np.array([t.share for t in tests]),
            "n_eff": np.array([t.n_eff for t in tests]),
            # stated only where the log was decimated: the other reports stay as they were
            **({"decimation": dec.to_dict()} if dec.factor > 1 else {})}


_NAMING_VALIDATION = "the group that alone removes nearly the most of the validation residual, fewest columns first"
_NAMING_ESTIMATION = ("refitted on the estimation run with each group added to the model's columns on every "
                      "flagged joint; the group whose refit removes nearly the most of the joint's validation "
                      "mean square, fewest columns first")


def _model_columns_words(named: _named_terms.NamedTerms) -> str:
    """How the model's own columns entered the test, in the section's words."""
    if named.model_columns == "none":
        return "none (no regressor: the model's own columns are unknown)"
    if named.model_columns == "validation":
        return "refitted on the validation run (what they represent is not missing)"
    how = "their estimation error, Cov(π̂) from the estimation run, widens the test"
    if named.alternative is not None:
        how += (" (Cov(π̂) of the noise the estimation run leaves once the model is refitted there with the "
                "library groups its own test selects, an inertia or gravity group on every joint: "
                + "; ".join(f"joint {j + 1}: {', '.join(g)}" for j, g in named.alternative) + ")")
    return how


def predictive(e: np.ndarray | None, est_fit: EstimationFit | None, reg3: np.ndarray | None, n_eff_val: np.ndarray,
               memo: Memo[Any] = compute_now) -> dict[str, Any] | None:
    """Does the validation error exceed what the estimation run's noise and Cov(π̂) allow?

    A Chow-type predictive test per joint: the validation mean square against s²_est (the
    estimation residual's, with its degrees of freedom) plus the mean of y_kᵀ Cov(π̂) y_k over the
    validation rows; F with (N_eff,val, N_eff,est − k/m) degrees of freedom, so colour is allowed for.
    The effect is the ratio of mean squares. The model columns' mean Gram matrix per joint depends
    on the regressor alone: ``memo`` (a prepared regressor's) keeps it.
    """
    if est_fit is None or reg3 is None or e is None:
        return None
    cols = list(est_fit.columns)
    m = e.shape[1]
    res = est_fit.residual
    n_est = res.shape[0]
    k = len(cols)
    dof = max(n_est * m - k, 1)
    s2 = np.sum(res**2, axis=0) / (dof / m)
    gram = memo(("model_gram", reg3.shape, tuple(cols)), lambda: model_gram(reg3, cols))
    param = np.einsum("mkl,kl->m", gram, est_fit.covariance)
    expected = s2 + param
    mse = np.mean(e**2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = mse / expected
    # A variance estimate has 2N/(2 + κ) degrees of freedom when the excess kurtosis is κ (heavy
    # tails make the ratio of two mean squares far more variable than Gaussian F says).
    df1 = np.clip(np.asarray(n_eff_val, dtype=float) * _kurtosis_factor(e), 1.0, None)
    df2 = np.clip((np.asarray(est_fit.n_eff, dtype=float) - k / m) * _kurtosis_factor(res), 1.0, None)
    p = scipy.stats.f.sf(ratio, df1, df2)
    return {"method": "Chow-type predictive F test (N_eff degrees of freedom)", "ratio": ratio,
            "expected_mse": expected, "validation_mse": mse, "noise_variance_estimation": s2,
            "parameter_variance": param, "df": np.column_stack([df1, df2]), "pvalue": p}


def model_gram(reg3: np.ndarray, cols: Sequence[int]) -> np.ndarray:
    """Each joint's mean Gram matrix of the model's columns, Y_{j,S}ᵀY_{j,S}/N, (m, k, k)."""
    gram: np.ndarray = np.einsum("nmk,nml->mkl", reg3[:, :, cols], reg3[:, :, cols]) / reg3.shape[0]
    return gram


def _kurtosis_factor(x: np.ndarray) -> np.ndarray:
    """2/(2 + κ) per column, κ the excess kurtosis (0 for Gaussian data; at most 1)."""
    kappa = scipy.stats.kurtosis(np.asarray(x, dtype=float), axis=0, fisher=True, bias=False)
    factor: np.ndarray = 2.0 / (2.0 + np.clip(np.nan_to_num(kappa), 0.0, None))
    return factor


def joint_excitation(q_val: np.ndarray | None, q_est: np.ndarray | None) -> np.ndarray | None:
    """Each joint's motion on the validation run relative to the estimation run (RMS about the mean)."""
    if q_val is None or q_est is None or q_val.shape[1] != q_est.shape[1]:
        return None
    sv = np.std(q_val, axis=0)
    se = np.std(q_est, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(se > 0, sv / se, np.nan)


def detectable_share(n_eff: np.ndarray, n_tests: int, level: float, power: float = 0.9) -> np.ndarray:
    """The smallest share of a joint's mean square that one added term must remove to be found with
    probability ``power`` at the Holm-corrected level: s = c/(N_eff + c), c = (z₁₋α/(2T) + z_power)²
    (the t statistic of a term that removes s is about √(N_eff s/(1 − s)))."""
    alpha = (1.0 - level) / max(n_tests, 1)
    c = (scipy.stats.norm.isf(alpha / 2.0) + scipy.stats.norm.ppf(power)) ** 2
    n_eff = np.asarray(n_eff, dtype=float)
    return c / (n_eff + c) if math.isfinite(c) else np.full_like(n_eff, np.nan)


def _model_columns(reg3: np.ndarray, est_fit: EstimationFit | None, given: Sequence[int] | None) -> list[int]:
    """The model's own columns of the regressor: the estimation fit's, else those given, else every
    one; what the physics test, the periodic section and the kinds without q read alike."""
    if est_fit is not None:
        return list(est_fit.columns)
    return list(range(reg3.shape[2])) if given is None else list(given)


# --------------------------------------------------------------------------- validate's motion phase


class Motion(NamedTuple):
    """The validation design and what the motion says."""

    design: rec.Design | None
    physics: rec.Physics | None = None
    periodic: rec.Periodic | None = None
    predictive: rec.Predictive | None = None
    model_kinds: list[dict[str, bool]] | None = None


def motion_phase(d: CheckedData, o: Options, r: Residual, lagged: Lagged) -> Motion:
    """The validation design, and what the motion says: physics library, delay, periodic noise,
    predictive test, each joint's motion and the smallest detectable effect."""
    design = sec.design(d.reg3, o.q, o.estimation, d.meas, o.thresholds, r.grams, sample_rate=o.sample_rate,
                        memo=d.memo, estimation_key=r.est_key, structure=d.structure)
    cols = None if d.reg3 is None else _model_columns(d.reg3, r.est_fit, o.model_columns)
    library = noise = kinds_spanned = None
    if o.q is not None and d.e is not None and not d.omitted:
        phys = physics(d.e, d.pred, o.q, o.dq, o.ddq, o.sample_rate, d.reg3, cols, r.est_fit, o.level,
                       o.estimation, d.meas, practical=o.thresholds.missing_physics, column_names=o.column_names,
                       band=d.lags.band if o.decimate == "auto" else None)
        library = rec.Physics.of({**phys, "delay": delay(d.meas, d.pred, o.sample_rate)})
        band = None if lagged.white is None else lagged.white.information_band
        # the residual's periodic part beyond what the model's own columns represent
        noise = rec.record_or_none(rec.Periodic, _periodic.periodic_error_test(d.e, o.q, o.sample_rate, band, d.reg3,
                                                                               cols))
    elif d.reg3 is not None and d.e is not None and cols is not None:
        # without q the model's columns still tell whether it has an offset (the bias rule's words)
        declared = _model_terms.declared_groups(d.reg3, cols, o.column_names)
        # the regressor's work alone (each joint's span of the model's columns, read from the
        # joint's R factor that the spectrum and the excitation share): kept by a prepared
        # regressor, so compare's candidates with the same columns do it once
        key = ("model_kinds", d.reg3.shape, tuple(int(c) for c in cols),
               None if declared is None else tuple(frozenset(x) for x in declared))
        reg3 = d.reg3
        kinds = d.memo(key, lambda: kinds_without_q(reg3, cols, declared, d.memo))
        kinds_spanned = None if kinds is None else [dict(x) for x in kinds]
    test = None
    if r.est_fit is not None and r.n_eff is not None:
        test = rec.record_or_none(rec.Predictive, predictive(d.e, r.est_fit, d.reg3, r.n_eff, memo=d.memo))
    return Motion(_motion_design(design, o, library, d.m), library, noise, test, kinds_spanned)


def _motion_design(design: rec.Design | None, o: Options, phys: rec.Physics | None, m: int) -> rec.Design | None:
    """The design section completed with what the motion says: each joint's motion against the
    estimation run's, and the smallest effect this run can detect per joint."""
    est_q = (o.estimation or {}).get("q")
    ratio = joint_excitation(o.q, est_q)
    # the noise's N_eff: what the physical terms leave (the residual's own N_eff counts a missing
    # term's slow structure as colour); without q it is not known
    noise_n_eff = phys.n_eff if phys is not None else None
    if ratio is None and noise_n_eff is None:
        return design
    more: dict[str, Any] = {}
    if ratio is not None:
        more["joint_motion_ratio"] = ratio
    if noise_n_eff is not None:
        more["noise_n_eff"] = np.asarray(noise_n_eff, dtype=float)
        more["detectable_share"] = detectable_share(noise_n_eff, m, o.level)
    return (design or rec.Design.of({})).with_(**more)
