"""Section builders that read the motion: missing physics, predictive failure and the run's power.

They complete ``_sections.py`` for what needs the trajectory (q, q̇, q̈) or the estimation run
(docs/conventions.md §5.2): each takes what it needs and returns one dict, and the rules in
``_findings.py`` read them through the evidence record.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

if TYPE_CHECKING:
    import scipy.stats

    from ._options import Options
    from ._sections import CheckedData, Lagged, Residual
else:
    from .._lazy import scipy

from ..statistics import _estimation, _model_terms, _periodic, _physics
from ..statistics._estimation import EstimationFit
from ..statistics._physics import Derivatives, PhysicsTest
from . import _records as rec
from . import _sections as sec
from ._prepared import Memo, compute_now
from ._regressor_algebra import kinds_without_q, unit_norm_columns

__all__ = ["physics", "delay", "periodic", "predictive", "joint_excitation", "detectable_share"]


def delay(meas: np.ndarray, pred: np.ndarray, sample_rate: float | None) -> dict[str, Any]:
    """The time shift between measured and predicted torque (:func:`dynval.statistics._physics.delay_test`)."""
    return _physics.delay_test(meas, pred, sample_rate=sample_rate)


def physics(e: np.ndarray, pred: np.ndarray, q: np.ndarray, dq: np.ndarray | None, ddq: np.ndarray | None,
            sample_rate: float | None,
            reg3: np.ndarray | None, model_columns: Sequence[int] | None, est_fit: EstimationFit | None, level: float,
            est_run: Mapping[str, Any] | None = None, meas: np.ndarray | None = None, practical: float = 0.05,
            column_names: Sequence[str] | None = None, band: float | None = None) -> dict[str, Any]:
    """Each joint's residual against the physics library (:mod:`dynval.statistics._physics`).

    ``band``: the report's information band (Hz); where it allows, the test runs on the log
    decimated towards it (:func:`dynval.statistics._physics.decimation`, conventions §5.2), and the
    section's ``decimation`` states the factor, the band and the rows.

    The model's own columns: with the estimation run their estimation error widens the test
    (Cov(π̂)); with a regressor alone they are refitted on the validation run (what they can
    represent is not missing); with neither, the prediction alone is given and nothing is refitted.
    The named term is then related to the model's columns (:mod:`dynval.statistics._model_terms`).
    """
    d = _physics.derivatives(q, sample_rate, dq, ddq)
    kwargs: dict[str, Any] = {}
    how = "none (no regressor: the model's own columns are unknown)"
    cols = None if reg3 is None else (list(est_fit.columns) if est_fit is not None else
                                      list(range(reg3.shape[2])) if model_columns is None else list(model_columns))
    if est_fit is not None and reg3 is not None:
        kwargs["model_regressor"] = reg3[:, :, list(est_fit.columns)]
        kwargs["parameter_covariance"] = est_fit.covariance
        how = "their estimation error, Cov(π̂) from the estimation run, widens the test"
        found = _estimation_structure(est_run, est_fit, sample_rate, 1.0 - level, band)
        if found is not None:
            kwargs["parameter_covariance"], removed = found
            how += (" (Cov(π̂) of the noise the estimation run leaves once the model is refitted there with the "
                    "library groups its own test selects, an inertia or gravity group on every joint: "
                    + "; ".join(f"joint {j + 1}: {', '.join(g)}" for j, g in removed) + ")")
    elif reg3 is not None:
        # unit-norm columns: the refit's rank decision does not depend on their units (contract §4)
        kwargs["nuisance"] = [unit_norm_columns(reg3[:, j, cols]) for j in range(reg3.shape[1])]
        how = "refitted on the validation run (what they represent is not missing)"
    # each joint's library once, when first read: the test (at the logged rate), the relation to the
    # model and its kinds read the same columns
    libs = _Libraries(q, d, e.shape[0], sample_rate)
    dec = _physics.decimation(e.shape[0], sample_rate, band)
    tests = _physics.physics_test(e, pred, q, d.dq, d.ddq, sample_rate=sample_rate, alpha=1.0 - level,
                                  libraries=libs, band=band, **kwargs)
    naming = "the group that alone removes nearly the most of the validation residual, fewest columns first"
    local: dict[int, dict[str, Any]] = {}
    source = derivative_source(q, dq, ddq, est_run)
    declared = declared_groups(reg3, cols, column_names)
    if est_fit is not None and reg3 is not None and meas is not None and est_run is not None and "q" in est_run:
        local = refit_names(tests, est_run, est_fit, reg3, meas, q, d, sample_rate, practical, source, declared)
        naming = ("refitted on the estimation run with each group added to the model's columns on every "
                  "flagged joint; the group whose refit removes nearly the most of the joint's validation "
                  "mean square, fewest columns first")
    kinds = model_kinds(e, q, d, sample_rate, reg3, cols, declared, libs)
    name_absent_kinds(tests, kinds, e, libs, practical)
    relate_terms(tests, e, pred, meas, q, d, sample_rate, reg3, cols, est_fit, practical, declared, libs, local)
    return {"naming": naming,
            "method": "prewhitened least squares (AR(≤ 2) by BIC), heteroscedasticity-robust Wald test per joint",
            "model_columns": how, "derivatives": d.method, "derivative_bandwidth_hz": d.bandwidth_hz,
            "derivative_source": source, "estimation_bandwidth_hz": (est_run or {}).get("bandwidth"),
            "groups": list(_physics.GROUPS), "tests": [t.to_dict() for t in tests],
            "model_kinds": kinds,
            "simulator_parameters": simulator_parameters(pred, meas, reg3, column_names),
            "pvalue": np.array([t.pvalue for t in tests]), "share": np.array([t.share for t in tests]),
            "n_eff": np.array([t.n_eff for t in tests]),
            # stated only where the log was decimated: the other reports stay as they were
            **({"decimation": dec.to_dict()} if dec.factor > 1 else {})}


def _estimation_structure(est_run: Mapping[str, Any] | None, est_fit: EstimationFit, sample_rate: float | None,
                          alpha: float, band: float | None) -> tuple[np.ndarray, list[tuple[int, list[str]]]] | None:
    """Cov(π̂) under the alternative (conventions §5.2): the physics test run on the estimation run's
    residual (the model's columns refitted per joint as nuisance), and the covariance of the noise
    the model's columns refitted with the groups selected there leave (a rigid-body group on every
    joint; :func:`dynval.statistics._estimation.noise_covariance`), with the groups selected per joint.
    None without the estimation run's q or where its test selects no group on any joint (the
    covariance is then the estimation fit's own)."""
    if est_run is None or "q" not in est_run or "regressor" not in est_run:
        return None
    q_e = np.asarray(est_run["q"], dtype=float)
    reg_e = np.asarray(est_run["regressor"], dtype=float)
    cols = list(est_fit.columns)
    resid = est_fit.residual
    m = resid.shape[1]
    if q_e.shape != resid.shape:
        return None
    de = _physics.derivatives(q_e, sample_rate, est_run.get("dq"), est_run.get("ddq"))
    pred_e = np.asarray(est_run["tau"], dtype=float) - resid
    nuisance = [unit_norm_columns(reg_e[:, j, cols]) for j in range(m)]
    tests = _physics.physics_test(resid, pred_e, q_e, de.dq, de.ddq, sample_rate=sample_rate, alpha=alpha,
                                  nuisance=nuisance, band=band)
    removed = [(t.joint, list(t.selected)) for t in tests if t.selected]
    if not removed:
        return None
    # a rigid-body kind selected on some joint is taken on every joint: the arm's inertia and gravity
    # load every joint through parameters they share, and the joints where the test did not take it
    # in keep the error of the parameters it bent; a friction, offset or drift is the joint's own
    # (taken on every joint, its columns would fit the noise behind the model's own friction columns)
    rigid = {g for _, groups in removed for g in groups if g in _RIGID_BODY}
    selected = dict(removed)
    structure: list[np.ndarray | None] = []
    for j in range(m):
        want = [g for g in _physics.GROUPS if g in rigid or g in selected.get(j, ())]
        lib = _physics.library(j, q_e, de.dq, de.ddq, pred_e[:, j], sample_rate, only=set(want)) if want else {}
        structure.append(np.hstack([lib[g] for g in want if g in lib]) if want else None)
    return _estimation.noise_covariance(est_fit, reg_e, structure), removed


class _Libraries(Sequence[Mapping[str, np.ndarray]]):
    """Each joint's physics library at the logged rate, each group built when first read (a
    decimated test builds its own from the decimated motion: then only the named terms' groups and,
    with a regressor, the model's kinds need these); the joints share the posture chains' sin and cos."""

    def __init__(self, q: np.ndarray, d: Derivatives, n: int, sample_rate: float | None) -> None:
        self._args = (q, d.dq, d.ddq, np.zeros(n), sample_rate)
        self._m = int(q.shape[1])
        self._chains: dict[Any, Any] = {}
        self._joints = [_JointLibrary(self, j) for j in range(self._m)]

    def __len__(self) -> int:
        return self._m

    def __getitem__(self, j: Any) -> Any:
        return self._joints[j]

    def build(self, j: int, group: str) -> np.ndarray:
        q, dq, ddq, zeros, fs = self._args
        return _physics.library(j, q, dq, ddq, zeros, fs, chains=self._chains, only={group})[group]


class _JointLibrary(Mapping[str, np.ndarray]):
    """One joint's library (:func:`dynval.statistics._physics.library`'s groups, in its order)."""

    def __init__(self, owner: _Libraries, j: int) -> None:
        self._owner, self._j = owner, j
        self._built: dict[str, np.ndarray] = {}

    def __getitem__(self, group: str) -> np.ndarray:
        if group not in _physics.GROUPS:
            raise KeyError(group)
        if group not in self._built:
            self._built[group] = self._owner.build(self._j, group)
        return self._built[group]

    def __iter__(self) -> Iterator[str]:
        return iter(_physics.GROUPS)

    def __len__(self) -> int:
        return len(_physics.GROUPS)


def derivative_source(q: np.ndarray | None, dq: np.ndarray | None, ddq: np.ndarray | None,
                      est_run: Mapping[str, Any] | None) -> str:
    """Where the naming refit's q̇, q̈ come from, one source for both runs: ``"given"`` when the
    user's derivatives are given for both runs, else ``"savgol"`` (Savitzky–Golay of each run's q)."""
    est_run = est_run or {}
    both = dq is not None and ddq is not None and "dq" in est_run and "ddq" in est_run
    return "given" if both else "savgol"


def declared_groups(reg3: np.ndarray | None, cols: Sequence[int] | None,
                    column_names: Sequence[str] | None) -> list[set[str]] | None:
    """Per joint, the groups the names of the model's columns active on it declare."""
    if reg3 is None or cols is None or not column_names:
        return None
    out = []
    for j in range(reg3.shape[1]):
        active = np.sqrt(np.mean(reg3[:, j, cols] ** 2, axis=0)) > 0
        out.append(_model_terms.declared_kinds([column_names[c] for c, a in zip(cols, active) if a]))
    return out


def model_kinds(e: np.ndarray | None, q: np.ndarray | None, d: Derivatives | None, sample_rate: float | None,
                reg3: np.ndarray | None,
                cols: Sequence[int] | None,
                declared: list[set[str]] | None = None,
                libraries: Sequence[Mapping[str, np.ndarray]] | None = None) -> list[dict[str, bool]] | None:
    """Per joint, which library groups the model's columns span (an own column of each within
    the tolerance of :mod:`dynval.statistics._model_terms`); None when its columns are unknown.
    ``libraries``: each joint's library when built already."""
    if reg3 is None or cols is None or e is None:
        return None
    n, m = e.shape
    # every column: a view of the joint's columns, not a gathered copy of its whole (N, p) block
    # per joint (the same values; a 91-column regressor's copy is 15 MB a joint at 20,000 rows)
    every = len(cols) == reg3.shape[2] and all(int(c) == i for i, c in enumerate(cols))
    out = []
    for j in range(m):
        lib = libraries[j] if libraries is not None else _model_terms.library_for(
            j, q, None if q is None or d is None else d.dq, None if q is None or d is None else d.ddq, n, sample_rate)
        y_j = reg3[:, j, :] if every else reg3[:, j, cols]
        out.append(_model_terms.kinds_present(j, y_j, lib, m, declared[j] if declared else set()))
    return out


_LACKING = ("missing", "partial", "coupling")
"""Relations in which the model lacks the named term (:func:`dynval.statistics._model_terms.relate`)."""

_RIGID_BODY = ("inertia", "gravity")
"""The kinds every rigid-body model of a moving arm holds: a model that holds one of them on no joint
lacks it as a whole (a gravity-only model of a moving arm lacks its inertia)."""


def name_absent_kinds(tests: Sequence[PhysicsTest], kinds: list[dict[str, bool]] | None, e: np.ndarray,
                      libraries: Sequence[Mapping[str, np.ndarray]], practical: float) -> None:
    """Name a rigid-body kind the model holds on no joint where the test selects it (conventions §5.2,
    "A kind the model lacks on every joint"): on a joint whose term was named by a kind the model
    holds (on some joint), the named term is the fit's re-weighting of what it has, bent to make up
    for the kind it lacks; adding that kind and refitting is the step. Named only where the kind's
    own columns, cross-fitted on the validation run, remove a practical share of the joint's mean
    square (its ``term_share`` then). ``kinds``: per joint, the groups the model holds."""
    if not kinds:
        return
    absent = [g for g in _RIGID_BODY if not any(k.get(g) for k in kinds)]
    held = {g for k in kinds for g, v in k.items() if v}
    for t in tests:
        if t.term is None or t.term not in held:
            continue
        ej = e[:, t.joint]
        total = float(ej @ ej)
        for g in absent:
            if g not in t.selected or g not in libraries[t.joint] or not total > 0:
                continue
            share = (total - _model_terms.crossfit_sse(ej, libraries[t.joint][g])) / total
            if share >= practical:
                t.term, t.term_share, t.refit_run = g, share, "absent"
                break


def relate_terms(tests: Sequence[PhysicsTest], e: np.ndarray, pred: np.ndarray, meas: np.ndarray | None, q: np.ndarray,
                 d: Derivatives, sample_rate: float | None, reg3: np.ndarray | None, cols: Sequence[int] | None,
                 est_fit: EstimationFit | None,
                 practical: float, declared: list[set[str]] | None = None,
                 libraries: Sequence[Mapping[str, np.ndarray]] | None = None,
                 local: Mapping[int, dict[str, Any]] | None = None) -> None:
    """Each named term's own effect out of sample (alone, cross-fitted on the validation run) and,
    with the model's columns known, its relation to them: mis-weighted, partial, coupling or missing,
    with the coefficients of the model's columns closest to it, estimated and refitted on this run.
    ``libraries``: each joint's library when built already. ``local``: per joint, what the named
    group's own columns added on that joint alone give (:func:`refit_names`): a term the joint's
    columns span only by bending parameters other joints share is ``local``, not a re-weighting."""
    n, m = e.shape
    for t in tests:
        if t.term is None:
            continue
        j = t.joint
        lib = libraries[j] if libraries is not None else _model_terms.library_for(j, q, d.dq, d.ddq, n, sample_rate)
        if t.term not in lib:
            continue
        ej = e[:, j]
        total = float(ej @ ej)
        if not total > 0:
            continue
        t.heldout_share = (total - _model_terms.crossfit_sse(ej, lib[t.term])) / total
        if reg3 is None or cols is None:
            continue
        y_j = reg3[:, j, cols]
        active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
        both = np.hstack([y_j[:, active], lib[t.term]])
        base = _model_terms.crossfit_sse(ej, y_j[:, active], full=both)
        t.carried_share = (base - _model_terms.crossfit_sse(ej, both, full=both)) / total
        rel = _model_terms.relate(j, t.term, ej, y_j, lib, m, practical, declared[j] if declared else set())
        gain = (local or {}).get(j)
        if (rel["relation"] == "reweight" and gain is not None and gain["group"] == t.term
                and gain["share"] >= practical):
            rel["relation"], rel["local"] = "local", gain
        elif rel["relation"] in _LACKING and gain is not None and gain["group"] == t.term:
            # what its own columns added on this joint alone remove on the others: the parameters
            # the fit bent there for it (conventions §5.10, "One missing column is one step")
            rel["added_alone"] = gain
        near = _model_terms.aligned_columns(y_j, lib[t.term])
        in_pred, refit = _joint_coefficients(y_j, active, pred[:, j], None if meas is None else meas[:, j])
        est_coef = np.asarray(est_fit.coefficients, dtype=float) if est_fit is not None else in_pred
        rel["columns"] = [int(cols[c]) for c in near]
        # the model's columns most aligned with each group the selection took in with the named one:
        # a structure the model lacks leaves its trace on them (a decoupled model's sin q_j carries
        # part of the missing gravity coupling when inertia is the term named)
        rel["trace_columns"] = sorted({int(cols[c]) for g in t.selected if g in lib
                                       for c in _model_terms.aligned_columns(y_j, lib[g])} | set(rel["columns"]))
        # the other joints whose rows these columns enter: a structure the model lacks there bends
        # their shared parameters in the fit, and the error this leaves here is its trace
        rel["shared_with"] = [k for k in range(m) if k != j and any(np.any(reg3[:, k, cols[c]] != 0) for c in near)]
        rel["estimated"] = [float(est_coef[c]) for c in near]
        rel["refitted"] = [float(refit[c]) for c in near]
        rel["estimated_from"] = "estimation" if est_fit is not None else "prediction"
        t.relation = rel


def _joint_coefficients(y_j: np.ndarray, active: np.ndarray, pred_j: np.ndarray,
                        meas_j: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Joint j's model columns' coefficients in the prediction and refitted on the measured torque
    (least squares on the columns active on the joint; nan refitted without the measurement)."""
    in_pred = np.zeros(y_j.shape[1])
    in_pred[active] = _model_terms.coefficients(y_j[:, active], pred_j)
    refit = np.zeros(y_j.shape[1])
    refit[active] = _model_terms.coefficients(y_j[:, active], meas_j) if meas_j is not None else np.nan
    return in_pred, refit


def simulator_parameters(pred: np.ndarray | None, meas: np.ndarray | None, reg3: np.ndarray | None,
                         column_names: Sequence[str] | None) -> list[list[dict[str, Any]]] | None:
    """Per joint, the simulator columns active on it (an MJCF model's ``armature_``, ``damping_``,
    ``frictionloss_<joint>``, contract §11) with their coefficient in the prediction (the model's own
    value) and refitted on this run, by least squares on every regressor column active on the joint:
    an MJCF regressor's columns are each on one joint, so this is the joint's share of
    :func:`dynval.identify.identify` of the whole regressor, the value ``MJCFModel.retune`` refits.
    None when the regressor has no such column."""
    if reg3 is None or not column_names or meas is None or pred is None:
        return None
    if not any(_model_terms.simulator_attribute(name) for name in column_names):
        return None
    out: list[list[dict[str, Any]]] = []
    for j in range(reg3.shape[1]):
        y_j = reg3[:, j, :]
        active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
        named = [c for c in range(y_j.shape[1]) if active[c] and _model_terms.simulator_attribute(column_names[c])]
        if not named:
            out.append([])
            continue
        in_pred, refit = _joint_coefficients(y_j, active, pred[:, j], meas[:, j])
        out.append([{"column": c, "name": str(column_names[c]), "predicted": float(in_pred[c]),
                     "refitted": float(refit[c])} for c in named])
    return out if any(out) else None


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


def periodic(e: np.ndarray, q: np.ndarray, sample_rate: float | None, band: float | None,
             est_fit: EstimationFit | None = None, reg3: np.ndarray | None = None,
             model_columns: Sequence[int] | None = None) -> dict[str, Any] | None:
    """When the validation trajectory repeats itself (at least two whole periods of q), the residual's
    part common to every period against the noise the period-to-period variation measures
    (:func:`dynval.statistics._periodic.periodic_noise_test`, no whiteness assumed).

    A model's estimation error Y(π − π̂) repeats with the trajectory too: with a regressor, each
    joint's residual is first cleared of what the model's own columns represent (least squares on
    the validation run), so what is tested is periodic error the model cannot represent.
    """
    period = _periodic.detect_period(q, sample_rate=sample_rate)
    if period is None:
        return None
    if round(period.samples) < _periodic.MIN_TESTED_PERIOD:
        return _untested_period(period, f"q repeats every {period.samples:.3g} samples: an encoder dithering by a "
                                        "count at standstill, not a repeated trajectory; such a period has no "
                                        "harmonic below the Nyquist frequency, so no periodic test")
    projected = False
    if reg3 is not None:
        cols = (list(est_fit.columns) if est_fit is not None
                else list(range(reg3.shape[2])) if model_columns is None else list(model_columns))
        e = e.copy()
        for j in range(e.shape[1]):
            y = unit_norm_columns(reg3[:, j, cols])  # the projection in any unit of the columns
            if y.size:
                e[:, j] -= y @ np.linalg.lstsq(y, e[:, j], rcond=None)[0]
        projected = True
    use_band = band if band is not None and np.isfinite(band) and band > 0 else None
    try:
        test = _periodic.periodic_noise_test(e, period, sample_rate=sample_rate, band=use_band)
    except ValueError:
        if use_band is None:
            return None
        try:
            test = _periodic.periodic_noise_test(e, period, sample_rate=sample_rate)
        except ValueError as exc:
            return _untested_period(period, f"no periodic test: {exc}")
    out = {"used": True, "period": period.to_dict(), **test.to_dict()}
    out["model_columns_removed"] = projected
    out["effect_net"] = np.clip(np.asarray(test.effect, dtype=float), 0.0, 1.0)
    return out

def _untested_period(period: _periodic.Period, note: str) -> dict[str, Any]:
    """The periodic section of a period that cannot be tested: ``used`` False and the ``note`` why."""
    return {"used": False, "period": period.to_dict(), "note": note}


def refit_names(tests: Sequence[PhysicsTest], est_run: Mapping[str, Any], est_fit: EstimationFit,
                reg3: np.ndarray, meas: np.ndarray, q: np.ndarray, d: Derivatives, sample_rate: float | None,
                practical: float = 0.05,
                source: str = "savgol", declared: list[set[str]] | None = None) -> dict[int, dict[str, Any]]:
    """Name each flagged joint's term as an engineer would: refit the model's columns on the
    estimation run with one library group added on every flagged joint at once (a friction or an
    offset is usually missing on all joints alike, and the joints' terms interact through the
    shared parameters), and name per joint the group whose refit removes the most of its validation
    mean square (of the groups near the best, the one with the fewest columns: :func:`_physics.name_group`).

    ``practical``: when no group so refitted removes that share of the joint's validation mean
    square, the term is named from the validation run instead (:func:`_validation_refit_gains`).
    ``source`` (:func:`derivative_source`): both runs' libraries take their q̇, q̈ from one source,
    the user's (``"given"``) or Savitzky–Golay of each run's q, never one of each (a "viscous"
    column of one filter is not the model's F_v of another, and refitting it looks like a gain).
    ``declared``: per joint, the groups the model's column names declare (:func:`declared_groups`):
    the kinds it holds, where neither refit carries and the term is named by the re-weighting.

    Returns, per flagged joint whose term is named, what the named group's own columns added on that
    joint alone give (:func:`_joint_local_gains`).
    """
    flagged = [t for t in tests if t.selected]
    if not flagged:
        return {}
    cols = list(est_fit.columns)
    q_e = est_run["q"]
    if source == "given":
        de = _physics.derivatives(q_e, sample_rate, est_run["dq"], est_run["ddq"])
    else:
        de = _physics.derivatives(q_e, sample_rate)
        d = _physics.derivatives(q, sample_rate)
    tau_e = est_run["tau"]
    n_e, m, k = est_run["regressor"][:, :, cols].shape
    # the refits on unit-norm columns (zero ones left out: scale 0), so that their rank decisions do
    # not depend on the columns' units (contract §4); the validation rows scaled alike
    scales = _estimation._column_scales(est_run["regressor"][:, :, cols].reshape(n_e * m, k))
    y_e = est_run["regressor"][:, :, cols] * scales
    y_v = reg3[:, :, cols] * scales
    x = y_e.reshape(n_e * m, k)
    gram, rhs = x.T @ x, x.T @ tau_e.reshape(-1)
    both = {t.joint: _carried_libraries(t.joint, q_e, de, q, d, sample_rate) for t in flagged}
    lib_e = {j: pair[0] for j, pair in both.items()}
    lib_v = {j: pair[1] for j, pair in both.items()}
    base = {t.joint: float(np.mean((meas[:, t.joint] - reg3[:, t.joint, cols] @ est_fit.coefficients) ** 2))
            for t in flagged}
    gains: dict[int, dict[str, float]] = {t.joint: {} for t in flagged}
    for g in lib_e[flagged[0].joint]:
        joints = [t.joint for t in flagged if g in lib_e[t.joint]]
        blocks = [lib_e[j][g] for j in joints]
        sizes = np.cumsum([0] + [b.shape[1] for b in blocks])
        # normal equations of [model columns | the group on each flagged joint's rows]
        cross = np.hstack([y_e[:, j, :].T @ b for j, b in zip(joints, blocks)])
        inner = np.zeros((sizes[-1], sizes[-1]))
        for i, b in enumerate(blocks):
            inner[sizes[i]:sizes[i + 1], sizes[i]:sizes[i + 1]] = b.T @ b
        a = np.block([[gram, cross], [cross.T, inner]])
        rhs_g = np.concatenate([rhs] + [b.T @ tau_e[:, j] for j, b in zip(joints, blocks)])
        coef = np.linalg.lstsq(a, rhs_g, rcond=None)[0]
        for i, j in enumerate(joints):
            resid = meas[:, j] - y_v[:, j, :] @ coef[:k] - lib_v[j][g] @ coef[k + sizes[i]:k + sizes[i + 1]]
            if base[j] > 0:
                gains[j][g] = (base[j] - float(np.mean(resid**2))) / base[j]
    for t in flagged:
        gj = gains[t.joint]
        how = "estimation"
        if not gj or not max(gj.values()) >= practical:
            # No group helps by a practical share once refitted on the estimation run: the model's
            # columns absorbed the term there (an offset into the gravity columns of a joint that
            # hardly changes posture), or its parameter error (other joints' noise through the
            # shared parameters) outweighs the term. Name the group that best explains, on the
            # validation run, what the model's own columns cannot represent there.
            gv = _validation_refit_gains(meas[:, t.joint], unit_norm_columns(reg3[:, t.joint, cols]), lib_v[t.joint])
            if not gv or not max(gv.values()) >= practical:
                # Neither refit names a group that carries a practical share: the model's columns
                # span what remains (mis-weighted, not missing). Where the validation test named a kind
                # the model does not hold, name the held kind of their re-weighting instead.
                y_j = unit_norm_columns(reg3[:, t.joint, cols])
                held = ({g: g in declared[t.joint] for g in lib_v[t.joint]} if declared else
                        _model_terms.kinds_present(t.joint, y_j, lib_v[t.joint], m))
                if t.term is None or held.get(t.term):
                    continue
                named = _reweighted_group(meas[:, t.joint] - reg3[:, t.joint, cols] @ est_fit.coefficients, y_j,
                                          {g: x for g, x in lib_v[t.joint].items() if held.get(g)})
                if named is not None:
                    t.term = named
                continue
            gj, how = gv, "validation"
        best = _physics.name_group(gj, {g: lib_e[t.joint][g].shape[1] for g in gj})
        t.term, t.term_share = best, max(0.0, gj[best])
        t.refit_shares = {g: float(v) for g, v in gj.items()}
        t.refit_run = how
    every = {j: float(np.mean((meas[:, j] - reg3[:, j, cols] @ est_fit.coefficients) ** 2)) for j in range(m)}
    return {t.joint: _joint_local_gains(t.joint, t.term, lib_e[t.joint][t.term], lib_v[t.joint][t.term], gram, rhs,
                                        y_e, y_v, tau_e, meas, every)
            for t in flagged if t.term is not None and t.term in lib_e[t.joint]}


_NORMAL_RCOND = 1e-10
"""Singular values of unit-norm normal equations below this fraction of the largest are dependent
directions (1e-5 of the design's: a column within 1e-5 of the others' span adds nothing)."""


def _reweighted_group(e_j: np.ndarray, y_j: np.ndarray, groups: Mapping[str, np.ndarray]) -> str | None:
    """The library group that best represents what re-weighting the model's columns changes on this
    run: the residual's least-squares fit on the model's columns (the torque the changed weights
    make), and the group of ``groups`` (those the model holds) that explains the most of it. A
    payload changes the weights of the model's gravity and inertia columns: what they then add is a
    posture term, not a position harmonic that the validation test's selection may have taken first.
    None when the re-weighting adds nothing."""
    active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
    if not np.any(active) or not groups:
        return None
    y = y_j[:, active]
    r = y @ np.linalg.lstsq(y, e_j, rcond=None)[0]
    total = float(r @ r)
    if not total > 0:
        return None
    shares = {}
    for g, x in groups.items():
        left = r - x @ np.linalg.lstsq(x, r, rcond=None)[0]
        shares[g] = 1.0 - float(left @ left) / total
    # the largest share, not the fewest columns near it: every group is fitted to the same torque
    # of the model's own columns, which a slowly moving joint's constant-like columns all nearly fit
    return max(shares, key=lambda g: (shares[g], -groups[g].shape[1]))


def _carried_libraries(j: int, q_e: np.ndarray, de: Derivatives, q: np.ndarray, d: Derivatives,
                        sample_rate: float | None) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Joint j's library on the estimation run and on the validation run in the estimation run's
    units: a coefficient refitted on the one is carried to the other, so each column is scaled by its
    RMS on the estimation run on both (the library scales each run by its own RMS: a validation run
    moving 20 % faster would carry a viscous term 20 % too small, and a column the model has, refitted
    again, would look like a gain), and the Coulomb shapes take the estimation run's velocity scale on
    both (the same shape). The drift is each run's own time, as the library defines it."""
    vs = _physics._scale(de.dq[:, j])

    def raw(q_r: np.ndarray, d_r: Derivatives) -> dict[str, np.ndarray]:
        n = q_r.shape[0]
        u = np.zeros(n)  # unscaled columns (the drift is replaced below)
        return _physics.library(j, q_r, d_r.dq, d_r.ddq, np.zeros(n), sample_rate, velocity_scale=vs, row_index=u)

    est, val = raw(q_e, de), raw(q, d)
    scales = {g: np.array([_physics._scale(c) for c in x.T]) for g, x in est.items() if g != "drift"}
    out = ({g: x / scales[g] for g, x in est.items() if g != "drift"},
           {g: x / scales[g] for g, x in val.items() if g != "drift"})
    for lib, q_r in zip(out, (q_e, q)):
        lib["drift"] = _physics.library(j, None, None, None, np.zeros(q_r.shape[0]), sample_rate)["drift"]
    return out


def _joint_local_gains(j: int, group: str, lib_e: np.ndarray, lib_v: np.ndarray, gram: np.ndarray, rhs: np.ndarray,
                       y_e: np.ndarray, y_v: np.ndarray, tau_e: np.ndarray, meas: np.ndarray,
                       base: Mapping[int, float]) -> dict[str, Any]:
    """The group's own columns (functions of joint j's motion alone: a rotor inertia's q̈_j, a friction
    of q̇_j) added on joint j's rows only, the model refitted with them on the estimation run (unit-norm
    model columns, its normal equations ``gram``, ``rhs``): per joint, the share of its validation mean
    square (``base``, the model as estimated) this removes. A term the model's columns span on joint j's
    rows by moving parameters that other joints share (a link inertia that also loads the joints before
    it) is not one the model has there: adding it lets the fit stop bending them (conventions §5.2,
    "Joint-local terms")."""
    m = meas.shape[1]
    own = lib_e[:, ~_model_terms.coupling_mask(group, j, m, lib_e.shape[1])]
    own_v = lib_v[:, ~_model_terms.coupling_mask(group, j, m, lib_v.shape[1])]
    k = gram.shape[0]
    # unit-norm added columns and a relative cutoff on the normal equations (whose condition is the
    # square of the design's): a column the model already has on this joint alone is dependent, and
    # must add nothing rather than a rounding-sized direction scaled up
    norm = np.sqrt(np.sum(own * own, axis=0))
    scale = np.where(norm > 0, 1.0 / np.where(norm > 0, norm, 1.0), 0.0)
    own, own_v = own * scale, own_v * scale
    a = np.block([[gram, y_e[:, j, :].T @ own], [own.T @ y_e[:, j, :], own.T @ own]])
    coef = np.linalg.lstsq(a, np.concatenate([rhs, own.T @ tau_e[:, j]]), rcond=_NORMAL_RCOND)[0]
    shares = []
    for i in range(m):
        resid = meas[:, i] - y_v[:, i, :] @ coef[:k] - (own_v @ coef[k:] if i == j else 0.0)
        shares.append((base[i] - float(np.mean(resid**2))) / base[i] if base[i] > 0 else 0.0)
    return {"group": group, "columns": int(own.shape[1]), "share": shares[j], "shares": shares}


def _validation_refit_gains(tau_j: np.ndarray, y_j: np.ndarray, groups: Mapping[str, np.ndarray]) -> dict[str, float]:
    """Per group, the share of the residual left by the model's columns refitted on this run that
    the group removes when added to them, out of sample: cross-fitted on alternate blocks of the run
    (:func:`dynval.statistics._model_terms.crossfit_sse`, the rows near a block's edge unscored), so
    a group that fits the noise of the rows it sees does not count."""
    out = {}
    for g, b in groups.items():
        both = np.hstack([y_j, b])
        base = _model_terms.crossfit_sse(tau_j, y_j, full=both)
        if base > 0:
            out[g] = (base - _model_terms.crossfit_sse(tau_j, both, full=both)) / base
    return out


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
    library = noise = kinds_spanned = None
    if o.q is not None and d.e is not None and not d.omitted:
        phys = physics(d.e, d.pred, o.q, o.dq, o.ddq, o.sample_rate, d.reg3, o.model_columns, r.est_fit, o.level,
                       o.estimation, d.meas, practical=o.thresholds.missing_physics, column_names=o.column_names,
                       band=d.lags.band if o.decimate == "auto" else None)
        library = rec.Physics.of({**phys, "delay": delay(d.meas, d.pred, o.sample_rate)})
        band = None if lagged.white is None else lagged.white.information_band
        noise = rec.record_or_none(rec.Periodic, periodic(d.e, o.q, o.sample_rate, band, r.est_fit, d.reg3,
                                                          o.model_columns))
    elif d.reg3 is not None and d.e is not None:
        # without q the model's columns still tell whether it has an offset (the bias rule's words)
        cols = (list(r.est_fit.columns) if r.est_fit is not None else
                list(range(d.reg3.shape[2])) if o.model_columns is None else list(o.model_columns))
        declared = declared_groups(d.reg3, cols, o.column_names)
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
