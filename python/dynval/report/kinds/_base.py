"""What every finding kind shares: the :class:`Finding` record, the :class:`Thresholds`, the
:class:`Evidence` the rules read, the :class:`Context` a rule runs in, and the :class:`Kind` a kind's
module declares (docs/architecture.md, "Adding a finding kind").

A kind's module (``report/kinds/<kind>.py``) imports this module and nothing of the rules' module
(``report/_findings.py``), which discovers the kinds through :mod:`dynval.report.kinds`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from .. import _finding_words as w
from .._text import versus

__all__ = ["Finding", "Thresholds", "Threshold", "Evidence", "Context", "Kind", "worded", "effect_versus_threshold",
           "declared_thresholds", "declare"]

@dataclass(frozen=True)
class Thresholds:
    """Practical effect sizes a deficiency must reach (all configurable through ``thresholds=``).

    Attributes
    ----------
    bias : float
        ``|ē_j| / RMSE_j`` (0.25: the offset is a quarter of the joint's RMS error, 6 % of its mean
        square). Estimation error alone leaves a smaller mean on a new trajectory (calibrated).
    regressor_correlation : float
        ``|ρ̂_eY(ℓ)|``, the correlation of the residual with a regressor column; ρ² is the share of
        residual variance that column explains linearly (0.15, i.e. 2.25 %).
    missing_term : float
        For a column outside ``model_columns``: the share of the residual's mean square that
        adding the term would remove (0.01).
    oscillation : float
        Share of the residual variance in a spectral peak above the background (0.05).
    missing_physics : float
        Share of a joint's mean square the library of physical terms removes (0.05): a term that
        explains a twentieth of the error is worth modelling; less is left to the noise.
    delay : float
        Share of a joint's mean square that realigning measured and predicted torque removes (0.05).
    delay_phase : float
        Phase lag (degrees) a delay makes at the information band's edge from which it matters for
        control (10°): it misplaces 2 sin(5°) ≈ 17 % of the torque's amplitude at that frequency
        and takes a sixth to a third of a torque loop's usual 30–60° phase margin.
    predictive_ratio : float
        Validation mean square over what the estimation run's noise and Cov(π̂) allow (2.0).
    periodic_error : float
        Share of the residual's variance common to every period of a periodic trajectory, beyond the
        noise and the parameters' expected error (0.05).
    joint_motion : float
        A joint whose validation motion (RMS about its mean) is below this fraction of its
        estimation motion is not validated (0.1).
    detectable_share : float
        A run whose smallest detectable term (90 % power, per joint) must remove more than this
        share of the mean square cannot decide (0.25).
    repeat_distance : float
        Time-aligned relative distance ‖τ_val − τ_est‖/‖τ_est − τ̄_est‖ below which the validation
        run counts as a repeat when neither ``q`` nor the regressor is given for both runs (0.1);
        otherwise the share below decides.
    repeat_share : float
        Share of the validation run whose state lies near the estimation trajectory at any time
        (within ``repeat_tolerance``) above which the validation run counts as a repeat (0.5).
    repeat_tolerance : float
        Distance to the estimation trajectory within which a validation state is near: an RMS over
        the state's coordinates, each in units of the estimation run's standard deviation (0.1).
    condition_number : float
        Column-scaled condition number of the validation regressor (over the identifiable
        combinations it excites) above which the validation data cannot separate the parameters'
        effects (1e3).
    """

    bias: float = 0.25
    regressor_correlation: float = 0.15
    missing_term: float = 0.01
    oscillation: float = 0.05
    missing_physics: float = 0.05
    delay: float = 0.05
    delay_phase: float = 10.0
    predictive_ratio: float = 2.0
    periodic_error: float = 0.05
    joint_motion: float = 0.1
    detectable_share: float = 0.25
    repeat_distance: float = 0.1
    repeat_share: float = 0.5
    repeat_tolerance: float = 0.1
    condition_number: float = 1e3
    declared: tuple[tuple[str, float], ...] = ()
    """Values given for thresholds a kind's module declares (:class:`Threshold`); the others take
    their defaults (:meth:`value`)."""

    def value(self, threshold: Threshold) -> float:
        """A declared threshold's value: as given in ``thresholds=``, else its default."""
        return dict(self.declared).get(threshold.name, threshold.default)

    def as_dict(self) -> dict[str, float]:
        """Every threshold by name, the declared ones after the fields (the report's provenance)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "declared"}
        given = dict(self.declared)
        out.update({name: given.get(name, t.default) for name, t in _DECLARED.items()})
        return out


@dataclass(frozen=True)
class Threshold:
    """A practical effect size a kind's module declares: its ``name`` among ``thresholds=``, its
    ``default`` and what it means (``doc``). The rule reads it with :meth:`Thresholds.value`."""

    name: str
    default: float
    doc: str


_DECLARED: dict[str, Threshold] = {}
"""The thresholds the kinds' modules declare, by name (filled by :func:`declare`, in the order of the kinds)."""


def declared_thresholds() -> dict[str, Threshold]:
    """The thresholds the kinds' modules declare beyond :class:`Thresholds`' fields, by name."""
    return dict(_DECLARED)


@dataclass(frozen=True, repr=False)
class Finding:
    """One finding of a report.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    severity : str
        One of :data:`SEVERITIES`.
    joints, columns : tuple of int
        0-based joint and regressor-column indices it concerns (strongest first).
    statistic, pvalue, pvalue_adjusted : float or None
        The test statistic, its p-value and the Holm-adjusted p-value over every test of the
        report (None for rules that are not tests).
    effect : float or None
        The practical effect size, in ``effect_unit``; ``threshold`` is the rule's threshold.
    action : str
        What to do (the lesson's flowchart: which term to add, or what to change in the data).
    message : str
        The finding in plain words.
    details : dict
        Rule-specific numbers (a frequency, a lag, distances, ...).
    """

    kind: str
    severity: str
    joints: tuple[int, ...] = ()
    columns: tuple[int, ...] = ()
    statistic: float | None = None
    pvalue: float | None = None
    pvalue_adjusted: float | None = None
    effect: float | None = None
    effect_unit: str = ""
    threshold: float | None = None
    action: str = ""
    message: str = ""
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (non-finite numbers as strings, like the report)."""
        from ...checks._json import to_jsonable

        out: dict[str, Any] = to_jsonable(asdict(self))
        return out

    def __repr__(self) -> str:
        # one line a reader can scan in a list of findings; every field stays an attribute
        where = "".join(f" {name}={list(value)}" for name, value in (("joints", self.joints), ("columns", self.columns))
                        if value)
        p = "" if self.pvalue_adjusted is None else f" p_adj={self.pvalue_adjusted:.3g}"
        message = self.message if len(self.message) <= 100 else self.message[:99] + "…"
        return f"<Finding {self.severity} {self.kind}{where}{p}: {message}>"


@dataclass
class Evidence:
    """Everything the rules read; the report pipeline fills it (arrays are per joint ``(m,)``).

    Optional parts are None when the report did not compute them (no lags, no regressor, ...).
    """

    n_samples: int
    level: float
    joint_names: list[str]
    r2: np.ndarray
    pooled_r2: float
    constant_target: np.ndarray
    column_names: list[str] | None = None
    omitted_rows: int = 0
    force_finite: bool = False
    # the information criteria's parameter and observation counts (n: N·m pooled, N otherwise)
    n_params: int | None = None
    criteria_n_obs: int | None = None
    noise_model: str = "pooled"
    # bias: the residual mean against its coloured-noise standard error
    mean: np.ndarray | None = None
    rmse: np.ndarray | None = None
    bias_statistic: np.ndarray | None = None
    bias_pvalue: np.ndarray | None = None
    n_eff: np.ndarray | None = None
    # whiteness: Ljung–Box at the raw rate and, if decimated, at the information rate
    whiteness_lag: int | None = None
    whiteness_pvalue_raw: np.ndarray | None = None
    whiteness_log_pvalue_raw: np.ndarray | None = None
    whiteness_pvalue_decimated: np.ndarray | None = None
    decimation: int = 1
    information_band: float | None = None
    whiteness_above_bandwidth: bool = False  # the test still sees frequencies above ``bandwidth``
    bandwidth: float | None = None  # Hz: the inputs are trustworthy below it only
    timing: dict[str, Any] | None = None  # what the time stamps say (dynval.checks._timing.Timing.to_dict)
    max_abs_acf: np.ndarray | None = None
    # spectrum of the residual (after projecting out the regressor when one is given)
    spectrum_frequency: np.ndarray | None = None
    spectrum_pvalue: np.ndarray | None = None  # (F, m), nan where not tested
    spectrum_ratio: np.ndarray | None = None
    spectrum_share: np.ndarray | None = None  # (F, m): variance share of a peak centred there
    spectrum_is_peak: np.ndarray | None = None  # (F, m) bool: local maxima
    spectrum_power: np.ndarray | None = None  # (F, m): the residual's power the peaks are tested on
    spectrum_power_measured: np.ndarray | None = None  # (F, m): the measured torque's power, same grid
    spectrum_power_prediction: np.ndarray | None = None  # (F, m): the prediction's power, same grid
    frequency_unit: str = "cycles/sample"
    # cross-correlation of the residual with regressor columns, colour-aware
    xcorr_rho: np.ndarray | None = None  # (m, p, L+1)
    xcorr_sd: np.ndarray | None = None  # (m, p, L+1)
    xcorr_mask: np.ndarray | None = None  # (m, p)
    # the columns the model lacks: added-variable correlations on the validation run (statistic ρ,
    # one test per joint and column, (m, q)) or, with the estimation run, the refit with each added
    # (statistic the Wald t of its coefficient, one test per column, (q,))
    missing_columns: list[int] | None = None
    missing_method: str = "added_variable"
    missing_statistic: np.ndarray | None = None  # (m, q) or (q,)
    missing_pvalue: np.ndarray | None = None  # (m, q) or (q,)
    missing_share: np.ndarray | None = None  # (m, q): share of the validation mean square it removes
    missing_explains_bias: np.ndarray | None = None  # (m, q) bool: the term accounts for the joint's mean
    missing_enters: np.ndarray | None = None  # (m, q) bool: the column enters the joint's rows (the refit's)
    missing_alone: np.ndarray | None = None  # (m, q): the share the column removes added alone (the refit's)
    # the motion: physics library (with q), predictive test (with the estimation run)
    # the sections' records (report/_records.py: Physics, Predictive, Periodic), read as mappings, or
    # a test's plain mappings of the same names; Any: their nested per-joint mappings (contract §4)
    physics: Mapping[str, Any] | None = None
    predictive: Mapping[str, Any] | None = None
    periodic: Mapping[str, Any] | None = None
    sample_rate: float | None = None
    # validation design
    repeat: dict[str, Any] | None = None
    excitation: dict[str, Any] | None = None
    joint_motion_ratio: np.ndarray | None = None
    detectable_share: np.ndarray | None = None
    noise_n_eff: np.ndarray | None = None
    # per joint, which library groups the model's columns span (None: its columns are unknown)
    model_kinds: list[dict[str, bool]] | None = None
    extra_notes: list[Finding] = field(default_factory=list)
    # tests validate would have run on these inputs and this entry point did not (a stream's spectrum
    # and colour-aware cross-correlation): each counts in Holm's family as a p-value of 1
    untested: int = 0


@dataclass
class Context:
    """What every rule reads, and what earlier rules found: rules run in the order of their kinds'
    ``order`` (a joint's whiteness is a deficiency only when an earlier rule found that joint
    deficient, and the correlations of a joint whose missing term was named are not repeated)."""

    ev: Evidence
    th: Thresholds
    alpha: float
    fam: dict[str, Any]
    deficient: set[int] = field(default_factory=set)
    missing: set[int] = field(default_factory=set)
    found: list[Finding] = field(default_factory=list)  # the findings of the rules that ran

    def name(self, j: int) -> str:
        return w.joint_name(self.ev.joint_names, j)

    def column(self, c: int) -> str:
        return w.column_name(self.ev.column_names, c)


def worded(words: w.Words, **record: Any) -> Finding:
    """A finding with its message and action."""
    message, action = words
    return Finding(message=message, action=action, **record)


def effect_versus_threshold(f: Finding, fmt: str = ".3g", *, percent: bool = False) -> tuple[str, str]:
    """A finding's effect and its threshold, with the digits that keep them in the order the rule
    found (:func:`dynval.report._text.versus`): 0.2496 against 0.25 → "24.96 %", "25 %" with ``percent``."""
    e, t = versus(f.effect, f.threshold, fmt, scale=100.0 if percent else 1.0)
    if percent:
        e, t = (s if s in ("n/a", "nan") else f"{s} %" for s in (e, t))
    return e, t


Rule = Callable[[Context], list[Finding]]
"""A kind's rule: the findings of its kind from the context (and what it adds to ``deficient``)."""

Reason = Callable[[Finding, Callable[[int], str]], str]
"""A kind's line in ``compare``'s reasons: from the finding's record and a column's name by index,
what it found with its effect against its threshold (the joints and "design: " are added)."""


@dataclass(frozen=True)
class Kind:
    """One finding kind, declared once in its module as ``KIND`` (docs/architecture.md).

    Attributes
    ----------
    name : str
        ``Finding.kind``.
    description : str
        What it detects (``dynval.FINDING_KINDS``, the site's findings page).
    order : int
        Its rule's place among the rules (:data:`dynval.report._findings.ORDER` lists the others'):
        a rule sees what the rules before it found (``Context.deficient``, ``Context.found``).
    rule : callable or None
        ``rule(context) -> list[Finding]``; None for a kind another kind's rule gives (in place of its
        own finding: ``prediction_artefact`` and ``processing_band`` from ``oscillation``'s,
        ``sampling_colour`` from ``whiteness``'), whose ``order`` is then that rule's.
    reason : callable or None
        ``reason(finding, column_name) -> str``: its line in ``compare``'s reasons (None: the
        generic line of its name, effect and threshold).
    thresholds : tuple of Threshold
        The practical effect sizes it declares beyond :class:`Thresholds`' fields.
    percent : bool
        The generic reason and ``compare`` write its effect and threshold as percentages.
    test : str or None
        The test of :data:`dynval.coverage.TESTS` whose evidence it reads (what the entry points leave
        out, contract §4.1), when not listed there.
    """

    name: str
    description: str
    order: int
    rule: Rule | None
    reason: Reason | None = None
    thresholds: tuple[Threshold, ...] = ()
    percent: bool = False
    test: str | None = None


def declare(kind: Kind) -> None:
    """Make a kind's thresholds known to :class:`Thresholds` (the registry calls it once per kind)."""
    for t in kind.thresholds:
        if t.name in _DECLARED or t.name in {f.name for f in fields(Thresholds)}:
            raise ValueError(f"finding kind {kind.name!r}: threshold {t.name!r} is declared twice")
        _DECLARED[t.name] = t
