"""Findings: the report's statistical detectors, as records (docs/conventions.md §5).

A finding is a decision rule applied to evidence the report computed. Every rule that calls the
model deficient needs two things: statistical evidence, with the family-wise error rate held at
α = 1 − level over **all** tests of the report by Holm's step-down method, and a practical effect
at or above a documented threshold (:class:`Thresholds`). A significant but negligible effect is
reported as a ``note``. Colour alone never makes a deficiency: a rejected whiteness test counts
against the model only on a joint where the structure is shown to be the model's (a residual
correlated with a regressor column, a spectral peak, a bias with a practical size).

The rules read an :class:`Evidence` record and nothing else, so they are tested directly; they
decide, and ``_finding_words.py`` words what they decided (each finding's message and action).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

import numpy as np

from ..statistics._stats import correlation_pvalue, holm
from . import _finding_words as w

__all__ = ["Finding", "Thresholds", "Evidence", "SEVERITIES", "KINDS", "compute_findings",
           "resolve_thresholds"]

SEVERITIES = ("deficiency", "design", "note")
"""``deficiency``: the model should change; ``design``: the experiment should change;
``note``: information, including significant but negligible effects."""

KINDS = {
    "worse_than_constant": "a joint's prediction is worse than its mean torque (R² < 0)",
    "bias": "a residual mean that is significant (coloured-noise t-test) and large relative to the RMSE",
    "regressor_correlation": "the residual correlates with a regressor column beyond what both series' colour explains",
    "oscillation": "a narrow spectral peak in the residual (after removing what the regressor explains)",
    "prediction_artefact": "a narrow spectral peak in the residual that the prediction holds more of than the "
                           "measured torque: the model makes the line (e.g. sign(q̇) chattering at standstill)",
    "whiteness": "the residual is not white (Ljung–Box); a deficiency only together with evidence above",
    "sampling_colour": "the residual's colour lies above the band the motion occupies: it is the sensor, "
                       "its filters and the sampling rate, not the model",
    "missing_physics": "the residual follows the motion: a physical term the model lacks (friction, gravity, "
                       "inertia, offset, drift), named from q without its column",
    "delay": "the measured torque lags (or leads) the prediction: reported whenever significant, with the phase lag "
             "at the information band's edge; a deficiency when realigning removes a practical share of the error "
             "or the phase lag matters for control",
    "periodic_error": "a periodic trajectory: what every period of the residual shares exceeds the noise the "
                      "period-to-period variation measures (no whiteness assumed)",
    "predictive_failure": "the validation error exceeds what the estimation run's noise and parameter "
                          "uncertainty allow (Chow-type test)",
    "repeat_trajectory": "the validation trajectory repeats the estimation trajectory",
    "excitation": "the validation regressor leaves columns unexcited or is ill-conditioned, or a joint moves "
                  "far less than in the estimation run",
    "low_information": "the run has too few effective samples to detect a term of practical size",
    "pooling": "the pooled value hides a joint that does much worse",
    "constant_target": "a joint's measured torque is constant",
    "omitted_rows": "rows with non-finite values were omitted",
    "information_criteria": "n_params leaves the criteria no degree of freedom (p >= n - 1): AICc and FPE are "
                            "undefined and AIC and BIC are mostly penalty",
    "time_stamps": "the time stamps are not a uniform grid: duplicated stamps, repeated rows, gaps or "
                   "irregular steps (the grid the analyses used is stated)",
    "processing_band": "spectral or whiteness evidence above the band in which the inputs are trustworthy "
                       "(``bandwidth``): the processing, not the model",
    "physical_consistency": "no physical robot has the parameters (a link's mass, pseudo-inertia, CoM; friction < 0)",
}
"""The documented vocabulary of ``Finding.kind``."""


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


def resolve_thresholds(value: object) -> Thresholds:
    """``None`` → defaults; a mapping overrides named fields; a :class:`Thresholds` as is."""
    from ..checks._validation import format_value, parameter_error

    if value is None:
        return Thresholds()
    if isinstance(value, Thresholds):
        return value
    if isinstance(value, dict):
        names = {f.name for f in fields(Thresholds)}
        for key, x in value.items():
            if key not in names:
                raise parameter_error("thresholds", "a mapping with keys among "
                                      + ", ".join(repr(n) for n in sorted(names)), value)
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or x < 0:
                raise parameter_error(f"thresholds[{format_value(key)}]", "a finite number >= 0", x)
        return replace(Thresholds(), **{k: float(x) for k, x in value.items()})
    raise parameter_error("thresholds", "None, a mapping or a Thresholds", value)


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
        from ..checks._json import to_jsonable

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
    joint_names: list
    r2: np.ndarray
    pooled_r2: float
    constant_target: np.ndarray
    column_names: list | None = None
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
    timing: dict | None = None  # what the time stamps say (dynval.checks._timing.Timing.to_dict)
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
    missing_columns: list | None = None
    missing_method: str = "added_variable"
    missing_statistic: np.ndarray | None = None  # (m, q) or (q,)
    missing_pvalue: np.ndarray | None = None  # (m, q) or (q,)
    missing_share: np.ndarray | None = None  # (m, q): share of the validation mean square it removes
    missing_explains_bias: np.ndarray | None = None  # (m, q) bool: the term accounts for the joint's mean
    missing_enters: np.ndarray | None = None  # (m, q) bool: the column enters the joint's rows (the refit's)
    missing_alone: np.ndarray | None = None  # (m, q): the share the column removes added alone (the refit's)
    # the motion: physics library (with q), predictive test (with the estimation run)
    physics: dict | None = None
    predictive: dict | None = None
    periodic: dict | None = None
    sample_rate: float | None = None
    # validation design
    repeat: dict | None = None
    excitation: dict | None = None
    joint_motion_ratio: np.ndarray | None = None
    detectable_share: np.ndarray | None = None
    noise_n_eff: np.ndarray | None = None
    # per joint, which library groups the model's columns span (None: its columns are unknown)
    model_kinds: list | None = None
    extra_notes: list = field(default_factory=list)
    # tests validate would have run on these inputs and this entry point did not (a stream's spectrum
    # and colour-aware cross-correlation): each counts in Holm's family as a p-value of 1
    untested: int = 0


def _bias_culprit(ev: Evidence, j: int, th: Thresholds):
    """The column outside the model whose absence best explains joint j's bias, if any.

    A term the model lacks shows as an offset on a new trajectory: the column must account for the
    joint's mean (``missing_explains_bias``) and remove at least the missing-term share of its mean
    square. Descriptive: the bias itself is the tested quantity.
    """
    if ev.missing_share is None or ev.missing_explains_bias is None:
        return None
    share = np.asarray(ev.missing_share[j], dtype=float)
    agree = np.asarray(ev.missing_explains_bias[j], dtype=bool)
    with np.errstate(invalid="ignore"):
        ok = np.flatnonzero(agree & (share >= th.missing_term))
    if ok.size == 0:
        return None
    k = int(ok[np.argmax(share[ok])])
    return int(ev.missing_columns[k]), float(share[k])


def _bias_kinds(ev: Evidence, j: int) -> dict[str, bool | None] | None:
    """Which of an offset, a friction and a gravity term the model's columns span on joint j (None
    for a kind the evidence cannot tell, e.g. friction without q); None when the columns are unknown."""
    if ev.model_kinds is None or j >= len(ev.model_kinds):
        return None
    k = ev.model_kinds[j]
    friction = [k[g] for g in ("coulomb", "viscous") if g in k]
    return {"offset": k.get("offset"), "friction": (any(friction) if friction else None),
            "gravity": k.get("gravity")}


def _column_in_model(ev: Evidence, c: int) -> bool | None:
    """A regressor column is the model's unless it is one of the columns tested as missing."""
    if ev.missing_columns is None:
        return True if ev.model_kinds is not None else None
    return int(c) not in {int(x) for x in ev.missing_columns}


def _tests(ev: Evidence):
    """Every p-value of the report as (family, index, p) blocks for one Holm correction."""
    blocks = []
    if ev.bias_pvalue is not None:
        blocks.append(("bias", np.asarray(ev.bias_pvalue, dtype=float)))
    if ev.whiteness_pvalue_raw is not None:
        blocks.append(("whiteness", np.asarray(
            ev.whiteness_pvalue_decimated if ev.whiteness_pvalue_decimated is not None
            else ev.whiteness_pvalue_raw, dtype=float)))
    if ev.spectrum_pvalue is not None:
        blocks.append(("spectrum", np.asarray(ev.spectrum_pvalue, dtype=float)))
    if ev.xcorr_rho is not None:
        blocks.append(("xcorr", correlation_pvalue(ev.xcorr_rho, ev.xcorr_sd)))
    if ev.missing_pvalue is not None:
        blocks.append(("missing", np.asarray(ev.missing_pvalue, dtype=float)))
    if ev.physics is not None:
        blocks.append(("physics", np.asarray(ev.physics["pvalue"], dtype=float)))
        if "delay" in ev.physics:
            blocks.append(("delay", np.asarray(ev.physics["delay"]["pvalue"], dtype=float)))
    if ev.predictive is not None:
        blocks.append(("predictive", np.asarray(ev.predictive["pvalue"], dtype=float)))
    if ev.periodic is not None and ev.periodic.get("used", True):  # used False: a period not tested
        blocks.append(("periodic", np.asarray(ev.periodic["pvalue"], dtype=float)))
    return blocks


def holm_family(ev: Evidence) -> dict[str, Any]:
    """Raw and Holm-adjusted p-values of every test in the report, by family; and the count.

    The tests the entry point left out (``ev.untested``) join the family as p-values of 1: the
    others are corrected for a family the size of ``validate``'s, so that leaving a test out never
    makes another more significant than ``validate`` would (docs/conventions.md §5).
    """
    blocks = _tests(ev)
    flat = np.concatenate([b.reshape(-1) for _, b in blocks]) if blocks else np.zeros(0)
    adjusted = holm(np.concatenate([flat, np.ones(ev.untested)]))[:flat.size]
    out: dict[str, Any] = {}
    pos = 0
    for name, b in blocks:
        size = b.size
        out[name] = (b, adjusted[pos:pos + size].reshape(b.shape))
        pos += size
    out["_count"] = int(np.sum(~np.isnan(flat))) + ev.untested
    return out


def cell_pvalue_adjusted(family: dict[str, Any]) -> np.ndarray | None:
    """(m, p): each residual × column cell's smallest Holm-adjusted p-value over its lags, the
    number the correlation rule compares with 1 − level (NaN for a constant column)."""
    if "xcorr" not in family:
        return None
    padj = np.asarray(family["xcorr"][1], dtype=float)
    undefined = np.isnan(padj).all(axis=2)
    smallest = np.min(np.where(np.isnan(padj), np.inf, padj), axis=2)
    return np.where(undefined, np.nan, smallest)


def compute_findings(ev: Evidence, thresholds: Thresholds | None = None, *,
                     family: dict[str, Any] | None = None) -> list[Finding]:
    """Apply every rule to the evidence; returns a list of :class:`Finding`, deficiencies first.

    ``family`` is :func:`holm_family` of the same evidence when the caller already has it."""
    r = _Rules(ev, thresholds or Thresholds(), 1.0 - ev.level, holm_family(ev) if family is None else family)
    out = r.found
    for rule in _RULES:
        out.extend(rule(r))
    order = {s: i for i, s in enumerate(SEVERITIES)}
    out.sort(key=lambda f: order[f.severity])
    return out


@dataclass
class _Rules:
    """What every rule reads, and what earlier rules found: rules run in the order of ``_RULES``
    (a joint's whiteness is a deficiency only when an earlier rule found that joint deficient, and
    the correlations of a joint whose missing term was named are not repeated)."""

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


def _worded(words: w.Words, **record: Any) -> Finding:
    """A finding with its message and action."""
    message, action = words
    return Finding(message=message, action=action, **record)


def _data_notes(r: _Rules) -> list[Finding]:
    """Notes on the data themselves: time stamps, omitted rows, constant joints."""
    ev = r.ev
    out: list[Finding] = []
    out.extend(_timing_findings(ev))
    if ev.omitted_rows:
        out.append(_worded(w.omitted_rows(ev.omitted_rows), kind="omitted_rows", severity="note",
                           effect=float(ev.omitted_rows), effect_unit=w.UNITS["omitted_rows"]))
    constant = np.asarray(ev.constant_target, dtype=bool)
    for j in np.flatnonzero(constant):
        out.append(_worded(w.constant_target(r.name(int(j)), ev.force_finite), kind="constant_target", severity="note",
                           joints=(int(j),)))
    if ev.n_params is not None and ev.criteria_n_obs is not None and ev.n_params >= ev.criteria_n_obs - 1:
        # the rule of contract §3.7 that makes aicc and fpe nan, said where the reader looks
        out.append(_worded(w.information_criteria(ev.n_params, ev.criteria_n_obs, ev.noise_model),
                           kind="information_criteria", severity="note", effect=float(ev.n_params),
                           effect_unit=w.UNITS["information_criteria"], threshold=float(ev.criteria_n_obs - 1)))
    return out


def _worse_than_constant_rule(r: _Rules) -> list[Finding]:
    """A joint predicted worse than its mean torque (no test: the effect is the decision), and the
    joints the pooled R² hides."""
    ev = r.ev
    m = len(ev.r2)
    constant = np.asarray(ev.constant_target, dtype=bool)
    out: list[Finding] = []
    r2 = np.asarray(ev.r2, dtype=float)
    pooled_good = m > 1 and np.isfinite(ev.pooled_r2) and ev.pooled_r2 > 0
    for j in range(m):
        if constant[j] or not np.isfinite(r2[j]) or r2[j] >= 0:
            continue
        r.deficient.add(j)
        out.append(_worded(
            w.worse_than_constant(r.name(j), float(r2[j]), float(ev.pooled_r2) if pooled_good else None),
            kind="worse_than_constant", severity="deficiency", joints=(j,), statistic=float(r2[j]),
            effect=float(-r2[j]), effect_unit=w.UNITS["worse_than_constant"], threshold=0.0))
    if m > 1 and np.isfinite(ev.pooled_r2):
        for j in range(m):
            if not constant[j] and np.isfinite(r2[j]) and 0 <= r2[j] < ev.pooled_r2 - 0.05:
                out.append(_worded(w.pooling(r.name(j), float(r2[j]), float(ev.pooled_r2)), kind="pooling",
                                   severity="note", joints=(j,), statistic=float(r2[j]),
                                   effect=float(ev.pooled_r2 - r2[j]), effect_unit=w.UNITS["pooling"],
                                   threshold=0.05))
    return out


def _bias_rule(r: _Rules) -> list[Finding]:
    """A residual mean beyond its coloured-noise standard error, and the missing term it comes from."""
    ev, th = r.ev, r.th
    if "bias" not in r.fam:
        return []
    p, padj = r.fam["bias"]
    mean = np.asarray(ev.mean, dtype=float)
    rmse = np.asarray(ev.rmse, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        effect = np.abs(mean) / rmse
    out: list[Finding] = []
    for j in range(len(ev.r2)):
        if not (padj[j] <= r.alpha):
            continue
        big = bool(effect[j] >= th.bias)
        if big:
            r.deficient.add(j)
        culprit = _bias_culprit(ev, j, th)
        named = None if culprit is None else (r.column(culprit[0]), culprit[1])
        term = None if culprit is not None else _bias_term(r, j)
        out.append(_worded(
            w.bias(r.name(j), float(mean[j]), float(effect[j]), th.bias, float(ev.n_eff[j]), ev.n_samples,
                   float(padj[j]), big, named, _bias_kinds(ev, j), term),
            kind="bias", severity="deficiency" if big else "note", joints=(j,),
            columns=() if culprit is None else (culprit[0],),
            statistic=float(ev.bias_statistic[j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(effect[j]), effect_unit=w.UNITS["bias"], threshold=th.bias,
            details={"mean": float(mean[j]), "n_eff": float(ev.n_eff[j]),
                     **({} if term is None else {"term": term[0], "relation": term[2]})}))
    return out


def _bias_term(r: _Rules, j: int) -> tuple[str, str, str] | None:
    """The physical term the library finds on joint j, when the model lacks it (missing, its
    coupling, or a part of it) and it is a practical deficiency there: (group, label, relation). A
    term the model lacks shows on a new trajectory as an offset too, and is what to change."""
    from ..statistics._physics import LABELS

    ev = r.ev
    if ev.physics is None or "physics" not in r.fam or _delay_explains(ev, j):
        return None
    t = ev.physics["tests"][j]
    rel = (t.get("relation") or {}).get("relation")
    if t["term"] is None or rel not in ("missing", "coupling", "partial") or not r.fam["physics"][1][j] <= r.alpha:
        return None
    if not (t["share"] >= r.th.missing_physics and _term_effect(t) >= r.th.missing_physics):
        return None
    return t["term"], LABELS[t["term"]], rel


def _missing_term_rule(r: _Rules) -> list[Finding]:
    """A column the model lacks: the residual against the part of it the model cannot represent."""
    ev, th = r.ev, r.th
    if "missing" not in r.fam:
        return []
    p, padj = r.fam["missing"]
    stat = np.asarray(ev.missing_statistic, dtype=float)
    share = np.asarray(ev.missing_share, dtype=float)
    per_column = p.ndim == 1  # the estimation refit: one test per column, its effect per joint
    refit = ev.missing_method == "estimation_refit"

    def at(a, j, k):
        return a[k] if a.ndim == 1 else a[j, k]

    enters = (np.ones(share.shape, dtype=bool) if ev.missing_enters is None or not per_column
              else np.asarray(ev.missing_enters, dtype=bool))
    # a column's effect: the larger of what it removes beside the other absent columns and added
    # alone (two absent columns that stand in for each other each have a small leave-one-out share)
    size = share if ev.missing_alone is None else np.fmax(share, np.asarray(ev.missing_alone, dtype=float))
    out: list[Finding] = []
    for j in range(share.shape[0]):
        # a column that does not enter this joint's rows is the step of the joints it enters; what
        # it moves here (through the parameters refitted with it) is said there
        sig = [k for k in range(share.shape[1]) if at(padj, j, k) <= r.alpha and enters[j, k]]
        if not sig:
            continue
        sig.sort(key=lambda k: -np.nan_to_num(size[j, k], nan=-np.inf))
        strong = [k for k in sig if size[j, k] >= th.missing_term]
        if per_column and not strong:
            continue  # a column that matters on another joint only says nothing about this one
        chosen = strong or sig
        k = chosen[0]
        big = bool(strong)
        if big:
            r.deficient.add(j)
            r.missing.add(j)
        terms = [(r.column(ev.missing_columns[kk]), float(at(stat, j, kk)), float(share[j, kk]),
                  _alone(ev, j, kk)) for kk in chosen]
        # what the column moves on the joints it does not enter: its own effect when known (the
        # leave-one-out share there can be taken by another absent column of the joint refit)
        moved = {jj: (_alone(ev, jj, k) if ev.missing_alone is not None else float(share[jj, k]))
                 for jj in range(share.shape[0]) if not enters[jj, k]}
        indirect = {jj: s for jj, s in moved.items() if s >= th.missing_term}
        details = {"lag": 0, "t" if refit else "ρ": float(at(stat, j, k)), "added_variable": True,
                   "method": ev.missing_method, "indirect": indirect}
        if ev.missing_alone is not None:
            details["alone_share"] = _alone(ev, j, k)
        out.append(_worded(
            w.missing_term(r.name(j), terms, refit, float(at(padj, j, k)), big,
                           [(r.name(jj), s) for jj, s in indirect.items()]),
            kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
            columns=tuple(int(ev.missing_columns[kk]) for kk in chosen), statistic=float(at(stat, j, k)),
            pvalue=float(at(p, j, k)), pvalue_adjusted=float(at(padj, j, k)), effect=float(size[j, k]),
            effect_unit=w.UNITS["missing_term"], threshold=th.missing_term,
            details=details))
    return out


def _alone(ev: Evidence, j: int, k: int) -> float:
    """The share of joint j's validation mean square absent column k removes added alone (nan unknown)."""
    if ev.missing_alone is None:
        return math.nan
    x = float(np.asarray(ev.missing_alone)[j, k])
    return x if math.isfinite(x) else math.nan


def _strongest_lag(rho: np.ndarray, sig: np.ndarray) -> int:
    """The smallest significant lag that sees nearly the strongest correlation: lags within the
    motion's time scale see one phenomenon, and the earliest is the one to name."""
    size = np.abs(rho[sig])
    return int(sig[np.flatnonzero(size >= 0.9 * size.max())[0]])


def _regressor_correlation_rule(r: _Rules) -> list[Finding]:
    """The residual correlating with a regressor column beyond both series' colour."""
    ev, th = r.ev, r.th
    if "xcorr" not in r.fam:
        return []
    p, padj = r.fam["xcorr"]
    rho = np.asarray(ev.xcorr_rho, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.abs(rho) / ev.xcorr_sd
    out: list[Finding] = []
    for j in range(rho.shape[0]):
        if j in r.missing:
            continue  # the missing term found above explains this joint's correlations
        hits = []
        for c in range(rho.shape[1]):
            sig = np.flatnonzero(padj[j, c] <= r.alpha)
            if sig.size:
                lag = _strongest_lag(rho[j, c], sig)
                hits.append((abs(rho[j, c, lag]), c, lag))
        if not hits:
            continue
        hits.sort(key=lambda t: (-t[0], t[1]))
        strong = [h for h in hits if h[0] >= th.regressor_correlation]
        chosen = strong or hits
        best, c, lag = chosen[0]
        big = bool(strong)
        if big:
            r.deficient.add(j)
        listed = [(r.column(cc), w.lag_text(ll, ev.sample_rate), float(rho[j, cc, ll])) for _, cc, ll in chosen]
        out.append(_worded(
            w.regressor_correlation(r.name(j), listed, th.regressor_correlation, float(best),
                                    float(padj[j, c, lag]), big, _column_in_model(ev, c),
                                    _simulator_values(ev, j, c) if lag == 0 else None),
            kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
            columns=tuple(int(cc) for _, cc, _ in chosen), statistic=float(z[j, c, lag]),
            pvalue=float(p[j, c, lag]), pvalue_adjusted=float(padj[j, c, lag]), effect=float(best),
            effect_unit=w.UNITS["correlation"], threshold=th.regressor_correlation,
            details={"lag": lag, "rho": float(rho[j, c, lag]), "n_significant_columns": len(hits),
                     "in_model": _column_in_model(ev, c)}))
    return out


def _simulator_values(ev: Evidence, j: int, c: int) -> tuple[float, float] | None:
    """Column c's (value in the prediction, value refitted on this run) on joint j when it is a
    simulator parameter's (``physics["simulator_parameters"]``), else None."""
    per_joint = (ev.physics or {}).get("simulator_parameters") or []
    for entry in per_joint[j] if j < len(per_joint) else []:
        if entry["column"] == c:
            return float(entry["predicted"]), float(entry["refitted"])
    return None


def _oscillation_rule(r: _Rules) -> list[Finding]:
    """A spectral peak standing above the smooth background (a mode), or above the inputs' bandwidth."""
    ev, th = r.ev, r.th
    if "spectrum" not in r.fam:
        return []
    p, padj = r.fam["spectrum"]
    freq = np.asarray(ev.spectrum_frequency, dtype=float)
    share = np.asarray(ev.spectrum_share, dtype=float)
    is_peak = np.asarray(ev.spectrum_is_peak, dtype=bool)
    unit = ev.frequency_unit
    out: list[Finding] = []
    for j in range(p.shape[1]):
        sig = np.flatnonzero((padj[:, j] <= r.alpha) & is_peak[:, j])
        if sig.size == 0:
            continue
        b = int(sig[np.argmax(share[sig, j])])
        f = float(freq[b])
        if ev.bandwidth is not None and f > ev.bandwidth:
            out.append(_processing_note(ev, j, "oscillation", f, float(p[b, j]), float(padj[b, j]),
                                        float(share[b, j])))
            continue
        big = bool(share[b, j] >= th.oscillation)
        if big:
            r.deficient.add(j)
        sides = _line_sides(ev, b, j)
        if sides is not None and sides[1] - sides[0] > 0.5 * sides[2]:
            out.append(_prediction_artefact(r, j, b, f, sides, p, padj, big))
            continue
        out.append(_worded(
            w.oscillation(r.name(j), f, unit, float(share[b, j]), float(ev.spectrum_ratio[b, j]),
                          float(padj[b, j]), big),
            kind="oscillation", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(ev.spectrum_ratio[b, j]), pvalue=float(p[b, j]), pvalue_adjusted=float(padj[b, j]),
            effect=float(share[b, j]), effect_unit=w.UNITS["oscillation"], threshold=th.oscillation,
            details={"frequency": f, "frequency_unit": unit, "n_peaks": int(sig.size)}))
    return out


def _line_sides(ev: Evidence, b: int, j: int) -> tuple[float, float, float] | None:
    """The measured torque's, the prediction's and the residual's power in the line at bin ``b`` of
    joint ``j`` (the five bins a Hann-windowed line spreads over, times the bin width): squared torque
    units.

    The rule reads the difference of the first two against the third (conventions §5.2): a line S
    in one side moves that side's power by |S|² ≈ the residual's, give or take the cross term
    2 Re(B̄S) with the torque B both sides share, which Welch's averaging shrinks but does not remove
    where the robot's own torque is large at the line. Half the residual's line is the midpoint of
    the two answers; nearer zero (or all three underflowed to 0) the sides cannot tell, and the line
    stays an oscillation."""
    pm, pp, pr = ev.spectrum_power_measured, ev.spectrum_power_prediction, ev.spectrum_power
    if pm is None or pp is None or pr is None:
        return None
    freq = np.asarray(ev.spectrum_frequency, dtype=float)
    df = float(freq[1] - freq[0]) if freq.size > 1 else 1.0
    lo, hi = max(b - 2, 0), b + 3
    return tuple(float(np.sum(x[lo:hi, j]) * df) for x in (pm, pp, pr))  # type: ignore[return-value]


def _prediction_artefact(r: _Rules, j: int, b: int, f: float, sides: tuple[float, float, float], p, padj,
                         big: bool) -> Finding:
    """A residual line the prediction holds more of than the measured torque: the model makes it
    (a friction model's sign(q̇) chattering at standstill), not a mode the robot has."""
    ev, th = r.ev, r.th
    share = float(ev.spectrum_share[b, j])
    ratio = float(ev.spectrum_ratio[b, j])
    measured, predicted, _ = sides
    return _worded(
        w.prediction_artefact(r.name(j), f, ev.frequency_unit, share, ratio, float(padj[b, j]), big, predicted,
                              measured),
        kind="prediction_artefact", severity="deficiency" if big else "note", joints=(j,), statistic=ratio,
        pvalue=float(p[b, j]), pvalue_adjusted=float(padj[b, j]), effect=share,
        effect_unit=w.UNITS["prediction_artefact"], threshold=th.oscillation,
        details={"frequency": f, "frequency_unit": ev.frequency_unit, "line_power_prediction": predicted,
                 "line_power_measured": measured})


def _motion_rule(r: _Rules) -> list[Finding]:
    """The rules that read the motion: missing physics, delay, predictive failure, periodic error."""
    found, joints = _motion_findings(r.ev, r.fam, r.th, r.alpha)
    r.deficient |= joints
    return found


def _named_term(ev: Evidence, f: Finding) -> tuple[str, float] | None:
    """The term a deficiency names and the share of the mean square it removes (a missing physical
    term, a missing column refitted in), or None for a deficiency that is not a named term."""
    d = f.details or {}
    if f.kind == "missing_physics":
        return str(d.get("label") or d.get("term")), float(d.get("term_share", math.nan))
    if f.kind == "regressor_correlation" and d.get("added_variable") and f.effect is not None:
        return w.column_name(ev.column_names, f.columns[0]) if f.columns else "a column", float(f.effect)
    return None


def _unresolved(ev: Evidence, found: list[Finding], joints: set[int]) -> dict[int, list[tuple[str, float]]]:
    """Of the deficient ``joints``, those whose every deficiency (whiteness, which follows from the
    others, aside) names a term that removes less than the run's smallest detectable share, with
    those terms: the structure is certain (its test is significant), which term it is the run
    cannot resolve."""
    if ev.detectable_share is None:
        return {}
    mde = np.asarray(ev.detectable_share, dtype=float)
    out = {}
    for j in sorted(joints):
        named = [_named_term(ev, f) for f in found
                 if f.severity == "deficiency" and f.kind != "whiteness" and j in f.joints]
        if named and all(t is not None and t[1] < mde[j] for t in named):
            out[j] = [t for t in named if t is not None]
    return out


def _whiteness_rule(r: _Rules) -> list[Finding]:
    """Whiteness at the information rate: a deficiency only on a joint an earlier rule found deficient."""
    ev = r.ev
    if "whiteness" not in r.fam:
        return []
    _, padj = r.fam["whiteness"]
    raw = np.asarray(ev.whiteness_pvalue_raw, dtype=float)
    dec = ev.whiteness_pvalue_decimated
    out: list[Finding] = []
    for j in range(len(ev.r2)):
        backed = j in r.deficient
        if dec is not None and raw[j] <= r.alpha and not (padj[j] <= r.alpha):
            if not backed:  # a joint shown deficient above: its colour is not the sensor's
                out.append(_worded(
                    w.sampling_colour(r.name(j), ev.information_band, ev.frequency_unit, ev.decimation),
                    kind="sampling_colour", severity="note", joints=(j,), pvalue=float(dec[j]),
                    pvalue_adjusted=float(padj[j]), effect=float(ev.decimation),
                    effect_unit=w.UNITS["sampling_colour"],
                    details={"information_band": ev.information_band, "frequency_unit": ev.frequency_unit}))
            continue
        if not (padj[j] <= r.alpha):
            continue
        tested = float(dec[j] if dec is not None else raw[j])
        if ev.whiteness_above_bandwidth and not backed:
            out.append(_processing_note(ev, j, "whiteness", None, tested, float(padj[j]), None))
            continue
        out.append(_worded(
            w.whiteness(r.name(j), dec is not None, ev.whiteness_lag, float(padj[j]), backed),
            kind="whiteness", severity="deficiency" if backed else "note", joints=(j,),
            pvalue=tested, pvalue_adjusted=float(padj[j]),
            effect=None if ev.max_abs_acf is None else float(ev.max_abs_acf[j]), effect_unit=w.UNITS["whiteness"],
            details={"lag": ev.whiteness_lag, "decimation": ev.decimation}))
    return out


def _validation_design_rule(r: _Rules) -> list[Finding]:
    """The validation run's design: repeat, excitation, information."""
    return [*_repeat_findings(r.ev, r.th), *_excitation_findings(r.ev, r.th),
            *_design_findings(r.ev, r.th, r.deficient, _unresolved(r.ev, r.found, r.deficient)), *r.ev.extra_notes]


_RULES = (_data_notes, _worse_than_constant_rule, _bias_rule, _missing_term_rule, _regressor_correlation_rule,
          _oscillation_rule, _motion_rule, _whiteness_rule, _validation_design_rule)
"""The rules, in the order they run."""


def _timing_findings(ev: Evidence) -> list[Finding]:
    """A note on time stamps that are not a uniform grid, with the counts and the grid used."""
    t = ev.timing
    if t is None or t["regular"]:
        return []
    return [_worded(
        w.time_stamps(t), kind="time_stamps", severity="note",
        effect=float(t["gaps"] + t["duplicated_stamps"] + t["irregular_steps"]),
        effect_unit=w.UNITS["time_stamps"], details=dict(t))]


def _processing_note(ev: Evidence, j: int, what: str, frequency: float | None, p: float, padj: float,
                     share: float | None) -> Finding:
    """Evidence above ``bandwidth`` Hz: the inputs' processing (a differentiating or sensor filter).

    ``frequency``: the spectral peak's (Hz); None for whiteness tested at a rate that still sees
    above the bandwidth."""
    assert ev.bandwidth is not None
    return _worded(
        w.processing_band(w.joint_name(ev.joint_names, j), frequency, ev.bandwidth, padj),
        kind="processing_band", severity="note", joints=(j,), pvalue=p, pvalue_adjusted=padj,
        effect=share, effect_unit=w.UNITS["processing_band"] if share is not None else None,
        threshold=ev.bandwidth, details={"evidence": what, "bandwidth": ev.bandwidth, "frequency": frequency})


def _motion_findings(ev: Evidence, fam, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    """The rules that read the motion: missing physics, delay, predictive failure, periodic error."""
    rules = (("physics", _physics_findings), ("delay", _delay_findings), ("predictive", _predictive_findings),
             ("periodic", _periodic_findings))
    out: list[Finding] = []
    joints: set[int] = set()
    for family, rule in rules:
        if family in fam:
            found, bad = rule(ev, fam[family], th, alpha)
            out += found
            joints |= bad
    return out, joints


def _periodic_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    p, padj = pvalues
    per = ev.periodic
    effect = np.asarray(per["effect_net"], dtype=float)
    out: list[Finding] = []
    bad: set[int] = set()
    for j in range(effect.size):
        if not (padj[j] <= alpha):
            continue
        big = bool(effect[j] >= th.periodic_error)
        if big:
            bad.add(j)
        out.append(_worded(
            w.periodic_error(w.joint_name(ev.joint_names, j), float(effect[j]), per["n_periods"], per["period"],
                             float(padj[j]), big),
            kind="periodic_error", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(per["statistic"][j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(effect[j]), effect_unit=w.UNITS["periodic_error"], threshold=th.periodic_error,
            details={"n_periods": int(per["n_periods"]), "period": per["period"],
                     "noise_variance": float(per["noise_variance"][j]),
                     "model_columns_removed": bool(per.get("model_columns_removed", False))}))
    return out, bad


def _physics_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    from ..statistics._physics import LABELS

    p, padj = pvalues
    out: list[Finding] = []
    bad: set[int] = set()
    for j, t in enumerate(ev.physics["tests"]):
        if not (padj[j] <= alpha) or _delay_explains(ev, j):
            continue
        shares = t["shares"]
        term = t["term"]
        if term is None:
            continue
        effect = _term_effect(t)
        big = bool(t["share"] >= th.missing_physics and effect >= th.missing_physics)
        if big:
            bad.add(j)
        label = LABELS[term]
        others = [LABELS[g] for g, sh in sorted(shares.items(), key=lambda kv: -kv[1]) if g != term and sh >= 0.01]
        together = float(t.get("selected_share", t["term_share"]))
        rel = t.get("relation")
        advice = {"refit_run": t.get("refit_run"), "effect": effect, "relation": rel, "practical": th.missing_physics,
                  "derivatives": _derivative_words(ev.physics),
                  "column_names": None if rel is None else [w.column_name(ev.column_names, c)
                                                             for c in rel.get("columns", [])],
                  "simulator": _simulator_values(ev, j, rel["columns"][0]) if rel and rel.get("columns") else None}
        out.append(_worded(
            w.missing_physics(w.joint_name(ev.joint_names, j), label, others, together, float(t["term_share"]),
                              float(t["share"]), float(padj[j]), big, advice),
            kind="missing_physics", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(t["statistic"]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(t["share"]), effect_unit=w.UNITS["missing_physics"], threshold=th.missing_physics,
            details={"term": term, "label": label, "term_share": float(t["term_share"]),
                     "selected_share": together, "selected": list(t["selected"]), "shares": dict(shares),
                     "n_eff": float(t["n_eff"]), "method": ev.physics["method"],
                     "derivatives": ev.physics["derivatives"], "refit_run": t.get("refit_run"),
                     "effect_out_of_sample": effect, "heldout_share": t.get("heldout_share"),
                     "carried_share": t.get("carried_share"),
                     "relation": None if rel is None else rel.get("relation"),
                     "model_terms": None if rel is None else dict(rel),
                     "derivative_source": ev.physics.get("derivative_source")}))
    return out, bad


def _term_effect(t: dict[str, Any]) -> float:
    """The named term's share of the joint's mean square, out of sample: refitted with the model on
    the estimation run and carried to validation, or (a fallback refit on this run) cross-fitted on
    it; from the validation test alone, what it adds to the model's columns cross-fitted (what
    re-identifying them gains when the model spans it), or its own effect alone cross-fitted when
    the columns are unknown. Coloured noise a term fits by chance does not carry to held-out rows."""
    if t.get("refit_run") in ("estimation", "validation"):
        return float(t["term_share"])
    rel = t.get("relation")
    if rel is not None:
        value = (rel["reweight_share"] if rel.get("relation") in ("reweight", "unsupported")
                 else t.get("carried_share"))
    else:
        value = t.get("heldout_share")
    value = float("nan") if value is None else float(value)
    return value if value == value else float(t["term_share"])


def _derivative_words(physics: dict[str, Any]) -> str:
    from ._motion import source_text

    return source_text(str(physics.get("derivative_source", "savgol")))


def _delay_explains(ev: Evidence, j: int) -> bool:
    """Realigning removes at least as much of joint j's mean square as the physical terms: the
    structure is a time shift, not a missing term (a missing viscous term looks like a small shift)."""
    dl = ev.physics.get("delay") if ev.physics else None
    if dl is None:
        return False
    share = float(dl["share"][j])
    lib = ev.physics["tests"][j]["share"]
    return bool(share >= (lib if lib == lib else 0.0))


def _phase_lag(ev: Evidence, shift: float) -> tuple[float | None, float | None]:
    """The phase lag (degrees) a shift of ``shift`` samples makes at the information band's edge,
    and that edge in cycles per sample; (None, None) without an information band."""
    band = ev.information_band
    if band is None or not math.isfinite(float(band)) or band <= 0:
        return None, None
    per_sample = float(band) / float(ev.sample_rate) if ev.frequency_unit == "Hz" and ev.sample_rate else float(band)
    return 360.0 * per_sample * abs(shift), per_sample


def _delay_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    """One finding for a common delay, whenever its test rejects on some joint (conventions §5.2):
    a deficiency on the joints whose shift explains at least what the physical terms do there and
    whose realignment removes the ``delay`` share, or the ``missing_term`` share with a phase lag at
    the information band's edge of at least ``delay_phase`` degrees; a note otherwise (a small lag,
    or a missing term that explains more of the joint's error than the shift: a missing viscous
    term looks like a delay)."""
    p, padj = pvalues
    dl = ev.physics["delay"]
    share = np.asarray(dl["share"], dtype=float)
    d = float(dl["shift_samples"])
    # a joint whose error realigning does not reduce holds no evidence of the delay
    significant = [j for j in range(share.size) if padj[j] <= alpha and share[j] > 0]
    if not significant or d == 0.0:
        return [], set()
    phase, edge = _phase_lag(ev, d)
    lag_matters = phase is not None and phase >= th.delay_phase
    explains = [j for j in significant if _delay_explains(ev, j)]
    # the phase decides where realigning moves at least the share a missing term is worth: below
    # it the lag is not resolved by the data, and the band's edge may be the prediction's own steps
    big = [j for j in explains if share[j] >= th.delay or (lag_matters and share[j] >= th.missing_term)]
    joints = big or significant
    fs = ev.sample_rate
    j0 = max(joints, key=lambda j: share[j])
    shares = [(w.joint_name(ev.joint_names, j), float(share[j])) for j in joints]
    masked = [] if big else [(w.joint_name(ev.joint_names, j), float(share[j]), float(ev.physics["tests"][j]["share"]))
                             for j in significant if j not in explains]
    band = None if edge is None else (edge * fs if fs else edge)
    return [_worded(
        w.delay(d, fs, shares, float(padj[j0]), phase=phase, band=band, phase_threshold=th.delay_phase,
                big=bool(big), masked=masked),
        kind="delay", severity="deficiency" if big else "note", joints=tuple(joints), statistic=d,
        pvalue=float(p[j0]), pvalue_adjusted=float(padj[j0]),
        effect=float(share[j0]) if phase is None else float(phase),
        effect_unit=w.UNITS["delay"] if phase is None else w.UNITS["delay_phase"],
        threshold=th.delay if phase is None else th.delay_phase,
        details={"delay_s": d / fs if fs else None, "delay_samples": d, "share": [float(x) for x in share],
                 "phase_deg": phase, "band_edge": band, "band_unit": "Hz" if fs else "cycles/sample",
                 "significant": significant, "explains": explains})], set(big)


def _predictive_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    p, padj = pvalues
    ratio = np.asarray(ev.predictive["ratio"], dtype=float)
    out: list[Finding] = []
    bad: set[int] = set()
    for j in range(ratio.size):
        if not (padj[j] <= alpha) or not ratio[j] >= th.predictive_ratio:
            continue
        bad.add(j)
        out.append(_worded(
            w.predictive_failure(w.joint_name(ev.joint_names, j), float(ratio[j]), float(padj[j])),
            kind="predictive_failure", severity="deficiency", joints=(j,), statistic=float(ratio[j]),
            pvalue=float(p[j]), pvalue_adjusted=float(padj[j]), effect=float(ratio[j]),
            effect_unit=w.UNITS["predictive_failure"], threshold=th.predictive_ratio,
            details={"expected_mse": float(ev.predictive["expected_mse"][j]),
                     "validation_mse": float(ev.predictive["validation_mse"][j])}))
    return out, bad


def _repeat_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
    """``repeat_trajectory``: a share of the validation run near the estimation trajectory at any
    time above ``repeat_share`` (conventions §5.6); without a state in both runs, a time-aligned
    distance below ``repeat_distance``."""
    d = ev.repeat
    if d is None:
        return []
    share = d.get("share")
    if share is not None:
        if not share > th.repeat_share:
            return []
        return [_worded(
            w.repeat_by_state(share, th.repeat_share, d.get("state"), d.get("tolerance", th.repeat_tolerance)),
            kind="repeat_trajectory", severity="design", effect=float(share),
            effect_unit=f"share of the validation run near the estimation trajectory ({d.get('state')})",
            threshold=th.repeat_share, details=dict(d))]
    if d.get("distance") is None or not d.get("is_repeat", d["distance"] < th.repeat_distance):
        return []
    return [_worded(
        w.repeat_by_distance(d["distance"], th.repeat_distance, d["measure"]),
        kind="repeat_trajectory", severity="design", effect=float(d["distance"]),
        effect_unit=f"relative distance ({d['measure']})", threshold=th.repeat_distance, details=dict(d))]


def _excitation_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
    """The validation regressor: structural columns reduced (a note), combinations the estimation
    run excites and the validation run does not, an ill-conditioned validation regressor."""
    x = ev.excitation
    if x is None:
        return []
    cols = ev.column_names
    out: list[Finding] = []
    structural = list(x.get("structural") or [])
    p = len(x["column_norms"]) if x.get("column_norms") is not None else None
    rank = x.get("identifiable_rank")
    if structural:
        out.append(_worded(
            w.structural_columns(cols, structural, p, rank, _structural_source(x) or "estimation"),
            kind="excitation", severity="note", columns=tuple(structural), effect=float(len(structural)),
            effect_unit=w.UNITS["structural"],
            details={"structural": structural, "identifiable_rank": rank,
                     "identifiable_columns": list(x.get("identifiable_columns") or [])}))
    zero = [int(c) for c in x["unexcited"]]
    dependent = [int(c) for c in x.get("inseparable") or []]
    if zero or dependent:
        out.append(_worded(
            w.unexcited_columns(cols, zero, dependent, _structural_source(x)),
            kind="excitation", severity="design", columns=tuple(zero + dependent),
            effect=float(len(zero) + len(dependent)), effect_unit=w.UNITS["columns"], details=dict(x)))
    elif x["condition_scaled"] > th.condition_number:
        out.append(_worded(
            w.ill_conditioned(x["condition_scaled"], th.condition_number, bool(structural), x.get("validation_rank")),
            kind="excitation", severity="design", effect=float(x["condition_scaled"]),
            effect_unit=w.UNITS["condition"], threshold=th.condition_number, details=dict(x)))
    return out


def _structural_source(x: dict[str, Any]) -> str | None:
    """What told the structural columns: the section's ``structural_source``; a section without the
    key (from before it) had them from the estimation run when it has them at all."""
    if x.get("structural") is None:
        return None
    return x.get("structural_source") or "estimation"


def _design_findings(ev: Evidence, th: Thresholds, decided: frozenset[int] | set[int] = frozenset(),
                     unresolved: dict[int, list[tuple[str, float]]] | None = None) -> list[Finding]:
    """Runs that cannot decide: a joint that hardly moves, a column the run hardly excites, too few
    effective samples."""
    return [*_joint_motion_findings(ev, th), *_column_motion_findings(ev, th),
            *_low_information_findings(ev, th, decided, unresolved or {})]


def _joint_motion_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
    """A joint whose validation motion is below ``joint_motion`` of its estimation-run motion."""
    if ev.joint_motion_ratio is None:
        return []
    ratio = np.asarray(ev.joint_motion_ratio, dtype=float)
    return [_worded(
        w.joint_motion(w.joint_name(ev.joint_names, int(j)), float(ratio[j]), th.joint_motion),
        kind="excitation", severity="design", joints=(int(j),), effect=float(ratio[j]),
        effect_unit=w.UNITS["joint_motion"], threshold=th.joint_motion,
        details={"joint_motion_ratio": float(ratio[j])}) for j in np.flatnonzero(ratio < th.joint_motion)]


def _column_motion_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
    """Columns (not already unexcited, unidentifiable, inseparable or structural) the validation run
    excites below ``joint_motion`` of the estimation run."""
    x = ev.excitation
    ratio_c = None if x is None else x.get("column_motion_ratio")
    if ratio_c is None:
        return []
    skip = (set(x["unexcited"]) | set(x["unidentifiable"]) | set(x.get("inseparable") or [])
            | set(x.get("structural") or []))
    weak = [int(c) for c in np.flatnonzero(np.asarray(ratio_c, dtype=float) < th.joint_motion) if c not in skip]
    if not weak:
        return []
    return [_worded(
        w.column_motion([(w.column_name(ev.column_names, c), float(ratio_c[c])) for c in weak], th.joint_motion),
        kind="excitation", severity="design", columns=tuple(weak), effect=float(np.min(np.asarray(ratio_c)[weak])),
        effect_unit=w.UNITS["column_motion"], threshold=th.joint_motion,
        details={"column_motion_ratio": {int(c): float(ratio_c[c]) for c in weak}})]


def _low_information_findings(ev: Evidence, th: Thresholds, decided: frozenset[int] | set[int],
                              unresolved: dict[int, list[tuple[str, float]]]) -> list[Finding]:
    """Too few effective samples: on a joint where no deficiency was found, or where the terms
    named remove less than the run can detect (``unresolved``, named in the message): where a term
    above that was found, the run did decide."""
    if ev.detectable_share is None:
        return []
    mde = np.asarray(ev.detectable_share, dtype=float)
    low = [int(j) for j in np.flatnonzero(mde > th.detectable_share) if int(j) not in decided or int(j) in unresolved]
    if not low:
        return []
    n_eff = np.asarray(ev.noise_n_eff, dtype=float)
    each = [(w.joint_name(ev.joint_names, j), float(n_eff[j]), float(mde[j]), unresolved.get(j)) for j in low]
    return [_worded(
        w.low_information(each, th.detectable_share),
        kind="low_information", severity="design", joints=tuple(low), effect=float(mde[low].max()),
        effect_unit=w.UNITS["low_information"], threshold=th.detectable_share,
        details={"detectable_share": [float(x) for x in mde], "noise_n_eff": [float(x) for x in n_eff],
                 "unresolved": sorted(int(j) for j in unresolved if j in low)})]
