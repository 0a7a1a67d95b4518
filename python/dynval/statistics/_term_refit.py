"""The estimation run's refit that names a flagged joint's physical term (docs/conventions.md §5.2).

The physics test (:func:`dynval.statistics._physics.physics_test`) says which library groups a
joint's validation residual follows; which of them the model *lacks* is what refitting the model
with the group added removes out of sample. This module does that refit, on the estimation run
first (:func:`refit_names`: the group added on every flagged joint at once, the model's columns
refitted with it, the validation mean square it removes), on the validation run where that refit
carries no practical share (cross-fitted there, and the model's own re-weighting where neither
carries: :func:`dynval.statistics._model_terms.name_on_validation`). It also gives the physics
test's Cov(π̂) under the alternative (:func:`alternative_covariance`): the estimation run's noise
once what its own test finds there is refitted with the model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _estimation, _model_terms, _physics
from ._columns import unit_norm_columns
from ._estimation import EstimationFit
from ._physics import Derivatives, PhysicsTest

__all__ = ["derivative_source", "alternative_covariance", "refit_names", "carried_libraries", "joint_local_gains"]


def derivative_source(q: np.ndarray | None, dq: np.ndarray | None, ddq: np.ndarray | None,
                      est_run: Mapping[str, Any] | None) -> str:
    """Where the naming refit's q̇, q̈ come from, one source for both runs: ``"given"`` when the
    user's derivatives are given for both runs, else ``"savgol"`` (Savitzky–Golay of each run's q)."""
    est_run = est_run or {}
    both = dq is not None and ddq is not None and "dq" in est_run and "ddq" in est_run
    return "given" if both else "savgol"


def alternative_covariance(est_run: Mapping[str, Any] | None, est_fit: EstimationFit, sample_rate: float | None,
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
    rigid = {g for _, groups in removed for g in groups if g in _model_terms.RIGID_BODY_KINDS}
    selected = dict(removed)
    structure: list[np.ndarray | None] = []
    for j in range(m):
        want = [g for g in _physics.GROUPS if g in rigid or g in selected.get(j, ())]
        lib = _physics.library(j, q_e, de.dq, de.ddq, pred_e[:, j], sample_rate, only=set(want)) if want else {}
        structure.append(np.hstack([lib[g] for g in want if g in lib]) if want else None)
    return _estimation.noise_covariance(est_fit, reg_e, structure), removed


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
    square, the term is named from the validation run instead
    (:func:`dynval.statistics._model_terms.name_on_validation`).
    ``source`` (:func:`derivative_source`): both runs' libraries take their q̇, q̈ from one source,
    the user's (``"given"``) or Savitzky–Golay of each run's q, never one of each (a "viscous"
    column of one filter is not the model's F_v of another, and refitting it looks like a gain).
    ``declared``: per joint, the groups the model's column names declare
    (:func:`dynval.statistics._model_terms.declared_groups`): the kinds it holds, where neither
    refit carries and the term is named by the re-weighting.

    Each flagged test's ``term``, ``term_share``, ``refit_shares`` and ``refit_run`` are set in
    place. Returns, per flagged joint whose term is named, what the named group's own columns added
    on that joint alone give (:func:`joint_local_gains`).
    """
    flagged = [t for t in tests if t.selected]
    if not flagged:
        return {}
    refit = _estimation_refit(flagged, est_run, est_fit, reg3, q, d, sample_rate, source)
    gains = _group_gains(flagged, refit, meas)
    for t in flagged:
        _name_term(t, gains[t.joint], refit, meas, practical, declared)
    every = {j: float(np.mean((meas[:, j] - reg3[:, j, refit.cols] @ refit.coefficients) ** 2))
             for j in range(refit.m)}
    return {t.joint: joint_local_gains(t.joint, t.term, refit.lib_e[t.joint][t.term], refit.lib_v[t.joint][t.term],
                                       refit.gram, refit.rhs, refit.y_e, refit.y_v, refit.tau_e, meas, every)
            for t in flagged if t.term is not None and t.term in refit.lib_e[t.joint]}


@dataclass(frozen=True)
class _Refit:
    """What every group's refit on the estimation run shares: the model's columns (``cols``) scaled
    to unit norm on the estimation run and the validation rows alike (``y_e``, ``y_v``), their
    normal equations on the estimation run (``gram``, ``rhs``), its torque, the estimated
    coefficients and the validation run's regressor as given (``reg3``), and each flagged joint's
    library on both runs in the estimation run's units (:func:`carried_libraries`)."""

    cols: list[int]
    y_e: np.ndarray
    y_v: np.ndarray
    reg3: np.ndarray
    gram: np.ndarray
    rhs: np.ndarray
    tau_e: np.ndarray
    coefficients: np.ndarray
    lib_e: dict[int, dict[str, np.ndarray]]
    lib_v: dict[int, dict[str, np.ndarray]]

    @property
    def m(self) -> int:
        return int(self.y_e.shape[1])


def _estimation_refit(flagged: Sequence[PhysicsTest], est_run: Mapping[str, Any], est_fit: EstimationFit,
                      reg3: np.ndarray, q: np.ndarray, d: Derivatives, sample_rate: float | None,
                      source: str) -> _Refit:
    """The model's columns and the flagged joints' libraries, ready for every group's refit."""
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
    both = {t.joint: carried_libraries(t.joint, q_e, de, q, d, sample_rate) for t in flagged}
    return _Refit(cols, y_e, y_v, reg3, gram, rhs, tau_e, est_fit.coefficients,
                  {j: pair[0] for j, pair in both.items()}, {j: pair[1] for j, pair in both.items()})


def _group_gains(flagged: Sequence[PhysicsTest], refit: _Refit, meas: np.ndarray) -> dict[int, dict[str, float]]:
    """Per flagged joint and library group, the share of the joint's validation mean square (the
    model as estimated) that the model refitted on the estimation run with the group added on
    every flagged joint's rows removes."""
    lib_e, lib_v, k = refit.lib_e, refit.lib_v, len(refit.cols)
    base = {t.joint: float(np.mean((meas[:, t.joint] - refit.reg3[:, t.joint, refit.cols] @ refit.coefficients) ** 2))
            for t in flagged}
    gains: dict[int, dict[str, float]] = {t.joint: {} for t in flagged}
    for g in lib_e[flagged[0].joint]:
        joints = [t.joint for t in flagged if g in lib_e[t.joint]]
        blocks = [lib_e[j][g] for j in joints]
        sizes = np.cumsum([0] + [b.shape[1] for b in blocks])
        # normal equations of [model columns | the group on each flagged joint's rows]
        cross = np.hstack([refit.y_e[:, j, :].T @ b for j, b in zip(joints, blocks)])
        inner = np.zeros((sizes[-1], sizes[-1]))
        for i, b in enumerate(blocks):
            inner[sizes[i]:sizes[i + 1], sizes[i]:sizes[i + 1]] = b.T @ b
        a = np.block([[refit.gram, cross], [cross.T, inner]])
        rhs_g = np.concatenate([refit.rhs] + [b.T @ refit.tau_e[:, j] for j, b in zip(joints, blocks)])
        coef = np.linalg.lstsq(a, rhs_g, rcond=None)[0]
        for i, j in enumerate(joints):
            resid = (meas[:, j] - refit.y_v[:, j, :] @ coef[:k]
                     - lib_v[j][g] @ coef[k + sizes[i]:k + sizes[i + 1]])
            if base[j] > 0:
                gains[j][g] = (base[j] - float(np.mean(resid**2))) / base[j]
    return gains


def _name_term(t: PhysicsTest, gj: dict[str, float], refit: _Refit, meas: np.ndarray, practical: float,
               declared: list[set[str]] | None) -> None:
    """Joint t.joint's term from its groups' estimation-run gains ``gj``, else from the validation
    run (:func:`dynval.statistics._model_terms.name_on_validation`), set on ``t``."""
    j = t.joint
    how = "estimation"
    if not gj or not max(gj.values()) >= practical:
        # No group helps by a practical share once refitted on the estimation run: the model's
        # columns absorbed the term there (an offset into the gravity columns of a joint that
        # hardly changes posture), or its parameter error (other joints' noise through the
        # shared parameters) outweighs the term. Name it from what the model's own columns cannot
        # represent on the validation run.
        gv = _model_terms.name_on_validation(t, meas[:, j], refit.reg3[:, j, refit.cols], refit.coefficients,
                                             refit.lib_v[j], refit.m, practical, declared[j] if declared else None)
        if gv is None:
            return
        gj, how = gv, "validation"
    best = _physics.name_group(gj, {g: refit.lib_e[j][g].shape[1] for g in gj})
    t.term, t.term_share = best, max(0.0, gj[best])
    t.refit_shares = {g: float(v) for g, v in gj.items()}
    t.refit_run = how


_NORMAL_RCOND = 1e-10
"""Singular values of unit-norm normal equations below this fraction of the largest are dependent
directions (1e-5 of the design's: a column within 1e-5 of the others' span adds nothing)."""


def carried_libraries(j: int, q_e: np.ndarray, de: Derivatives, q: np.ndarray, d: Derivatives,
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


def joint_local_gains(j: int, group: str, lib_e: np.ndarray, lib_v: np.ndarray, gram: np.ndarray, rhs: np.ndarray,
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
