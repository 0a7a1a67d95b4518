"""The physics test's named terms, as one procedure: from the validation run, the model's columns
and the estimation run to each joint's test, its named term and that term's relation to the model
(docs/conventions.md §5.2).

:func:`name_terms` runs, in turn: the derivatives; how the model's own columns enter the test (their
estimation error under the alternative, :func:`dynval.statistics._term_refit.alternative_covariance`,
or refitted on the validation run as nuisance); the physics test
(:func:`dynval.statistics._physics.physics_test`); the estimation run's refit that names each flagged
joint's term (:func:`dynval.statistics._term_refit.refit_names`); then, relative to the model's
columns (:mod:`dynval.statistics._model_terms`), the kinds it holds, a rigid-body kind it holds on no
joint, each term's relation and a simulator's own parameters refitted. It returns them in one typed
record (:class:`NamedTerms`), which the report words and arranges.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from . import _model_terms, _physics, _term_refit
from ._columns import unit_norm_columns
from ._estimation import EstimationFit
from ._physics import Decimation, Derivatives, PhysicsTest

__all__ = ["NamedTerms", "name_terms"]

ColumnsUse = Literal["none", "estimation", "validation"]
"""How the model's own columns enter the test: not at all (no regressor), their estimation error
widening it (Cov(π̂) of the estimation run), or refitted on the validation run as nuisance."""


@dataclass(frozen=True)
class NamedTerms:
    """Each joint's physics test with its named term and that term's relation to the model
    (:class:`dynval.statistics._physics.PhysicsTest`), and how they were found."""

    tests: list[PhysicsTest]
    derivatives: Derivatives  # the validation run's q̇, q̈ (given or Savitzky–Golay) and their bandwidth
    derivative_source: str  # the naming refit's q̇, q̈ on both runs (:func:`_term_refit.derivative_source`)
    model_columns: ColumnsUse
    # per joint with a group selected on the estimation run, the groups whose refit with the model gave
    # the test's Cov(π̂) under the alternative; None where the estimation fit's own covariance was used
    alternative: list[tuple[int, list[str]]] | None
    named_on_estimation: bool  # the terms were named by the estimation run's refit (else by the test)
    model_kinds: list[dict[str, bool]] | None  # per joint, the library groups the model holds
    simulator_parameters: list[list[dict[str, Any]]] | None  # a simulator model's parameters refitted
    decimation: Decimation  # the factor the test decimated the log by (1: the logged rate)


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


def name_terms(e: np.ndarray, pred: np.ndarray, q: np.ndarray, dq: np.ndarray | None, ddq: np.ndarray | None,
               sample_rate: float | None, reg3: np.ndarray | None, model_columns: Sequence[int] | None,
               est_fit: EstimationFit | None, level: float, est_run: Mapping[str, Any] | None = None,
               meas: np.ndarray | None = None, practical: float = 0.05, column_names: Sequence[str] | None = None,
               band: float | None = None) -> NamedTerms:
    """Each joint's residual ``e`` against the physics library, its term named and related to the
    model's columns.

    ``model_columns``: the model's own columns of the regressor ``reg3`` (the estimation fit's
    when it is given). ``level``: the test's confidence level. ``band``: the report's information
    band (Hz); where it allows, the test runs on the log decimated towards it
    (:func:`dynval.statistics._physics.decimation`, conventions §5.2). ``practical``: the share of
    a joint's mean square below which a term is not named by a refit.

    The model's own columns: with the estimation run their estimation error widens the test
    (Cov(π̂)); with a regressor alone they are refitted on the validation run (what they can
    represent is not missing); with neither, the prediction alone is given and nothing is refitted.
    """
    d = _physics.derivatives(q, sample_rate, dq, ddq)
    cols = None if reg3 is None or model_columns is None else list(model_columns)
    use, alternative, kwargs = _model_columns_in_test(reg3, cols, est_fit, est_run, sample_rate, level, band)
    # each joint's library once, when first read: the test (at the logged rate), the relation to the
    # model and its kinds read the same columns
    libs = _Libraries(q, d, e.shape[0], sample_rate)
    dec = _physics.decimation(e.shape[0], sample_rate, band)
    tests = _physics.physics_test(e, pred, q, d.dq, d.ddq, sample_rate=sample_rate, alpha=1.0 - level,
                                  libraries=libs, band=band, **kwargs)
    # the kinds the model's column names declare: the naming refit and the relation both read them
    declared = _model_terms.declared_groups(reg3, cols, column_names)
    source = _term_refit.derivative_source(q, dq, ddq, est_run)
    # the estimation run names the terms where it can be refitted (its q given); else the test's names stay
    local: dict[int, dict[str, Any]] = {}
    refit = False
    if est_fit is not None and reg3 is not None and meas is not None and est_run is not None and "q" in est_run:
        refit = True
        local = _term_refit.refit_names(tests, est_run, est_fit, reg3, meas, q, d, sample_rate, practical, source,
                                        declared)
    kinds = _model_terms.model_kinds(e, reg3, cols, libs, declared)
    _model_terms.name_absent_kinds(tests, kinds, e, libs, practical)
    _model_terms.relate_terms(tests, e, pred, meas, reg3, cols, est_fit, practical, libs, declared, local)
    return NamedTerms(tests, d, source, use, alternative, refit, kinds,
                      _model_terms.simulator_parameters(pred, meas, reg3, column_names), dec)


def _model_columns_in_test(reg3: np.ndarray | None, cols: list[int] | None, est_fit: EstimationFit | None,
                           est_run: Mapping[str, Any] | None, sample_rate: float | None, level: float,
                           band: float | None) -> tuple[ColumnsUse, list[tuple[int, list[str]]] | None, dict[str, Any]]:
    """How the model's own columns enter the physics test, the groups behind Cov(π̂) under the
    alternative, and the test's keywords that say so."""
    if reg3 is None or cols is None:
        return "none", None, {}
    if est_fit is None:
        # unit-norm columns: the refit's rank decision does not depend on their units (contract §4)
        return "validation", None, {"nuisance": [unit_norm_columns(reg3[:, j, cols]) for j in range(reg3.shape[1])]}
    kwargs: dict[str, Any] = {"model_regressor": reg3[:, :, list(est_fit.columns)],
                              "parameter_covariance": est_fit.covariance}
    found = _term_refit.alternative_covariance(est_run, est_fit, sample_rate, 1.0 - level, band)
    if found is None:
        return "estimation", None, kwargs
    kwargs["parameter_covariance"], removed = found
    return "estimation", removed, kwargs
