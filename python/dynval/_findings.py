"""Findings: the report's statistical detectors, as records (docs/conventions.md §5).

A finding is a decision rule applied to evidence the report computed. Every rule that calls the
model deficient needs two things: statistical evidence, with the family-wise error rate held at
α = 1 − level over **all** tests of the report by Holm's step-down method, and a practical effect
at or above a documented threshold (:class:`Thresholds`). A significant but negligible effect is
reported as a ``note``. Colour alone never makes a deficiency: a rejected whiteness test counts
against the model only on a joint where the structure is shown to be the model's (a residual
correlated with a regressor column, a spectral peak, a bias with a practical size).

The rules read an :class:`Evidence` record and nothing else, so they are tested directly; the
wording of the summary lives in ``_summary.py``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

import numpy as np

from ._stats import correlation_pvalue, holm
from ._text import p_clause, versus

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
    "whiteness": "the residual is not white (Ljung–Box); a deficiency only together with evidence above",
    "sampling_colour": "the residual's colour lies above the band the motion occupies: it is the sensor, "
                       "its filters and the sampling rate, not the model",
    "missing_physics": "the residual follows the motion: a physical term the model lacks (friction, gravity, "
                       "inertia, offset, drift), named from q without its column",
    "delay": "the measured torque lags (or leads) the prediction: realigning removes a practical share of the error",
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
        |ē_j| / RMSE_j (0.25: the offset is a quarter of the joint's RMS error, 6 % of its mean
        square). Estimation error alone leaves a smaller mean on a new trajectory (calibrated).
    regressor_correlation : float
        |ρ̂_eY(ℓ)|, the correlation of the residual with a regressor column; ρ² is the share of
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
    from ._validation import parameter_error

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
                raise parameter_error(f"thresholds[{key!r}]", "a finite number >= 0", x)
        return replace(Thresholds(), **{k: float(x) for k, x in value.items()})
    raise parameter_error("thresholds", "None, a mapping or a Thresholds", value)


@dataclass(frozen=True)
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
        from ._json import to_jsonable

        out: dict[str, Any] = to_jsonable(asdict(self))
        return out


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
    timing: dict | None = None  # what the time stamps say (dynval._timing.Timing.to_dict)
    max_abs_acf: np.ndarray | None = None
    # spectrum of the residual (after projecting out the regressor when one is given)
    spectrum_frequency: np.ndarray | None = None
    spectrum_pvalue: np.ndarray | None = None  # (F, m), nan where not tested
    spectrum_ratio: np.ndarray | None = None
    spectrum_share: np.ndarray | None = None  # (F, m): variance share of a peak centred there
    spectrum_is_peak: np.ndarray | None = None  # (F, m) bool: local maxima
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
    extra_notes: list = field(default_factory=list)


def _name(names, j):
    return names[j] if names and j < len(names) else f"joint {j + 1}"


def _col(names, c):
    return names[c] if names and c < len(names) else f"column {c + 1}"


def _p_text(p, log_p=None) -> str:
    """``= 0.0123`` or ``< 1e-300``: the relation and the value, for "p {…}" in a message
    (:func:`dynval._text.p_clause`, the one p-value wording of every text, contract §4)."""
    return p_clause(p, log_p)


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
    if ev.periodic is not None:
        blocks.append(("periodic", np.asarray(ev.periodic["pvalue"], dtype=float)))
    return blocks


def holm_family(ev: Evidence) -> dict[str, Any]:
    """Raw and Holm-adjusted p-values of every test in the report, by family; and the count."""
    blocks = _tests(ev)
    flat = np.concatenate([b.reshape(-1) for _, b in blocks]) if blocks else np.zeros(0)
    adjusted = holm(flat)
    out: dict[str, Any] = {}
    pos = 0
    for name, b in blocks:
        size = b.size
        out[name] = (b, adjusted[pos:pos + size].reshape(b.shape))
        pos += size
    out["_count"] = int(np.sum(~np.isnan(flat)))
    return out


def compute_findings(ev: Evidence, thresholds: Thresholds | None = None) -> list[Finding]:
    """Apply every rule to the evidence; returns a list of :class:`Finding`, deficiencies first."""
    r = _Rules(ev, thresholds or Thresholds(), 1.0 - ev.level, holm_family(ev))
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

    def common(self) -> tuple[Evidence, Thresholds, float, dict[str, Any], list[str], list[str] | None]:
        """What most rules read: evidence, thresholds, α, the Holm family, joint and column names."""
        return self.ev, self.th, self.alpha, self.fam, self.ev.joint_names, self.ev.column_names


def _data_notes(r: _Rules) -> list[Finding]:
    """Notes on the data themselves: time stamps, omitted rows, constant joints."""
    ev, names = r.ev, r.ev.joint_names
    out: list[Finding] = []
    out.extend(_timing_findings(ev))
    if ev.omitted_rows:
        out.append(Finding(kind="omitted_rows", severity="note", effect=float(ev.omitted_rows),
                           effect_unit="rows", action="check the logger for dropped or invalid samples",
                           message=f"{ev.omitted_rows} rows with non-finite values were omitted; segment "
                                   "breaks were inserted so no lag joins samples that were not adjacent."))
    constant = np.asarray(ev.constant_target, dtype=bool)
    for j in np.flatnonzero(constant):
        how = ("0 or 1 by scikit-learn's force_finite rule" if ev.force_finite
               else "-inf, or nan for an exact prediction")
        out.append(Finding(kind="constant_target", severity="note", joints=(int(j),),
                           action="validate this joint on a trajectory that moves it",
                           message=f"{_name(names, j)}: the measured torque is constant, so R², fit and VAF "
                                   f"compare against nothing (reported as {how})."))
    return out


def _worse_than_constant_rule(r: _Rules) -> list[Finding]:
    """A joint predicted worse than its mean torque (no test: the effect is the decision), and the
    joints the pooled R² hides."""
    ev, names = r.ev, r.ev.joint_names
    m = len(r.ev.r2)
    deficient_joints = r.deficient
    constant = np.asarray(r.ev.constant_target, dtype=bool)
    out: list[Finding] = []
    r2 = np.asarray(ev.r2, dtype=float)
    for j in range(m):
        if constant[j] or not np.isfinite(r2[j]) or r2[j] >= 0:
            continue
        deficient_joints.add(j)
        hidden = m > 1 and np.isfinite(ev.pooled_r2) and ev.pooled_r2 > 0
        out.append(Finding(
            kind="worse_than_constant", severity="deficiency", joints=(j,), statistic=float(r2[j]),
            effect=float(-r2[j]), effect_unit="1 − R² beyond 1 (fraction of TSS)", threshold=0.0,
            action=f"check {_name(names, j)}'s terms, signs and units: predicting its mean torque does better",
            message=(f"{_name(names, j)} does worse than a constant: R² = {versus(r2[j], 0.0, '.3f')[0]}"
                     + (f", yet the pooled R² is {ev.pooled_r2:.3f} (pooling flattens all joints with one "
                        "mean, so the high-torque joints dominate it; read the per-joint values)." if hidden
                        else "."))))
    if m > 1 and np.isfinite(ev.pooled_r2):
        for j in range(m):
            if not constant[j] and np.isfinite(r2[j]) and 0 <= r2[j] < ev.pooled_r2 - 0.05:
                out.append(Finding(kind="pooling", severity="note", joints=(j,), statistic=float(r2[j]),
                                   effect=float(ev.pooled_r2 - r2[j]), effect_unit="R² below pooled",
                                   threshold=0.05, action="read the per-joint values",
                                   message=f"{_name(names, j)}: R² = {r2[j]:.3f}, well below the pooled "
                                           f"{ev.pooled_r2:.3f}, which the larger torques of other joints dominate."))
    return out


def _bias_rule(r: _Rules) -> list[Finding]:
    """A residual mean beyond its coloured-noise standard error, and the missing term it comes from."""
    ev, th, alpha, fam, names, cols = r.common()
    m = len(r.ev.r2)
    deficient_joints = r.deficient
    out: list[Finding] = []
    if "bias" in fam:
        p, padj = fam["bias"]
        mean = np.asarray(ev.mean, dtype=float)
        rmse = np.asarray(ev.rmse, dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            effect = np.abs(mean) / rmse
        for j in range(m):
            if not (padj[j] <= alpha):
                continue
            big = bool(effect[j] >= th.bias)
            if big:
                deficient_joints.add(j)
            culprit = _bias_culprit(ev, j, th)
            if culprit is not None:
                c, share_c = culprit
                action = (f"add the term {_col(cols, c)} on {_name(names, j)}: without it the model leaves this "
                          f"offset ({100 * share_c:.1f} % of the mean square is its part outside the model)")
            else:
                action = f"add a torque offset (sensor bias), a friction or a gravity term on {_name(names, j)}"
            bias_pct = versus(effect[j], th.bias, ".0f", scale=100.0)
            out.append(Finding(
                kind="bias", severity="deficiency" if big else "note", joints=(j,),
                columns=() if culprit is None else (culprit[0],),
                statistic=float(ev.bias_statistic[j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
                effect=float(effect[j]), effect_unit="|mean| / RMSE", threshold=th.bias,
                action=action if big else "none: the bias is real but too small to matter",
                details={"mean": float(mean[j]), "n_eff": float(ev.n_eff[j])},
                message=(f"{_name(names, j)}: residual mean {mean[j]:+.4g} "
                         f"({bias_pct[0]} % of the RMSE; coloured-noise t-test N_eff = {ev.n_eff[j]:.0f} "
                         f"of {ev.n_samples}, Holm-adjusted p {_p_text(padj[j])})"
                         + ((": a systematic bias, e.g. a missing offset, friction or gravity term"
                             + (f"; the missing term {_col(cols, culprit[0])} accounts for it." if culprit else "."))
                            if big else f": significant but negligible (below {bias_pct[1]} % of the RMSE)."))))
    return out


def _missing_term_rule(r: _Rules) -> list[Finding]:
    """A column the model lacks: the residual against the part of it the model cannot represent."""
    ev, th, alpha, fam, names, cols = r.common()
    deficient_joints = r.deficient
    out: list[Finding] = []
    missing_joints = r.missing
    if "missing" in fam:
        p, padj = fam["missing"]
        stat = np.asarray(ev.missing_statistic, dtype=float)
        share = np.asarray(ev.missing_share, dtype=float)
        per_column = p.ndim == 1  # the estimation refit: one test per column, its effect per joint
        refit = ev.missing_method == "estimation_refit"

        def at(a, j, k):
            return a[k] if a.ndim == 1 else a[j, k]

        for j in range(share.shape[0]):
            sig = [k for k in range(share.shape[1]) if at(padj, j, k) <= alpha]
            if not sig:
                continue
            sig.sort(key=lambda k: -np.nan_to_num(share[j, k], nan=-np.inf))
            strong = [k for k in sig if share[j, k] >= th.missing_term]
            if per_column and not strong:
                continue  # a column that matters on another joint only says nothing about this one
            chosen = strong or sig
            k = chosen[0]
            c = int(ev.missing_columns[k])
            big = bool(strong)
            if big:
                deficient_joints.add(j)
                missing_joints.add(j)
            symbol = "t" if refit else "ρ"
            listed = "; ".join(f"{_col(cols, ev.missing_columns[kk])} ({symbol} = {at(stat, j, kk):+.3g}, would remove "
                               f"{100 * share[j, kk]:.1f} % of the mean square)" for kk in chosen[:3])
            how = ("refitted on the estimation run with the term added (Wald t with the coloured-noise "
                   "covariance; the share is measured on the validation run)" if refit
                   else "after removing what the model's own columns represent")
            out.append(Finding(
                kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
                columns=tuple(int(ev.missing_columns[kk]) for kk in chosen), statistic=float(at(stat, j, k)),
                pvalue=float(at(p, j, k)), pvalue_adjusted=float(at(padj, j, k)), effect=float(share[j, k]),
                effect_unit="share of the residual's mean square the term would remove",
                threshold=th.missing_term,
                action=(f"add the term {_col(cols, c)} to the model" if big
                        else "none: the term would explain too little to matter"),
                details={"lag": 0, symbol: float(at(stat, j, k)), "added_variable": True,
                         "method": ev.missing_method},
                message=(f"{_name(names, j)}: a term the model lacks explains part of the residual: {listed}; "
                         f"{how} (Holm-adjusted p {_p_text(at(padj, j, k))})"
                         + (": a missing term." if big else ": significant but negligible."))))
    return out


def _regressor_correlation_rule(r: _Rules) -> list[Finding]:
    """The residual correlating with a regressor column beyond both series' colour."""
    ev, th, alpha, fam, names, cols = r.common()
    deficient_joints = r.deficient
    missing_joints = r.missing
    out: list[Finding] = []
    if "xcorr" in fam:
        p, padj = fam["xcorr"]
        rho = np.asarray(ev.xcorr_rho, dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.abs(rho) / ev.xcorr_sd
        for j in range(rho.shape[0]):
            if j in missing_joints:
                continue  # the missing term found above explains this joint's correlations
            hits = []
            for c in range(rho.shape[1]):
                sig = np.flatnonzero(padj[j, c] <= alpha)
                if sig.size == 0:
                    continue
                # the smallest lag that sees nearly the strongest correlation: lags within the
                # motion's time scale see one phenomenon, and the earliest is the one to name
                size = np.abs(rho[j, c, sig])
                lag = int(sig[np.flatnonzero(size >= 0.9 * size.max())[0]])
                hits.append((abs(rho[j, c, lag]), c, lag))
            if not hits:
                continue
            hits.sort(key=lambda t: (-t[0], t[1]))
            strong = [h for h in hits if h[0] >= th.regressor_correlation]
            chosen = strong or hits
            best, c, lag = chosen[0]
            big = bool(strong)
            if big:
                deficient_joints.add(j)
            th_rho = th.regressor_correlation
            listed = "; ".join(f"{_col(cols, cc)} ({_lag_text(ll, ev.sample_rate)}, "
                               f"ρ = {versus(rho[j, cc, ll], th_rho, '+.3f', absolute=True)[0]})"
                               for _, cc, ll in chosen[:3])
            out.append(Finding(
                kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
                columns=tuple(int(cc) for _, cc, _ in chosen), statistic=float(z[j, c, lag]),
                pvalue=float(p[j, c, lag]), pvalue_adjusted=float(padj[j, c, lag]), effect=float(best),
                effect_unit="|ρ|", threshold=th.regressor_correlation,
                action=(f"add or re-weight the term of {_col(cols, c)} on {_name(names, j)}: the model does not "
                        "use the information in it" if big
                        else "none: the correlation is real but too small to matter"),
                details={"lag": lag, "rho": float(rho[j, c, lag]), "n_significant_columns": len(hits)},
                message=(f"{_name(names, j)}: the residual correlates with {listed} beyond what the colour of "
                         f"both series explains (Holm-adjusted p {_p_text(padj[j, c, lag])})"
                         + (": the model does not use the information in this column (a missing or "
                            "mis-weighted term)." if big
                            else f": significant but negligible (|ρ| below {versus(best, th_rho)[1]})."))))
    return out


def _oscillation_rule(r: _Rules) -> list[Finding]:
    """A spectral peak standing above the smooth background (a mode), or above the inputs' bandwidth."""
    ev, th, alpha, fam, names, _cols = r.common()
    deficient_joints = r.deficient
    out: list[Finding] = []
    if "spectrum" in fam:
        p, padj = fam["spectrum"]
        freq = np.asarray(ev.spectrum_frequency, dtype=float)
        share = np.asarray(ev.spectrum_share, dtype=float)
        is_peak = np.asarray(ev.spectrum_is_peak, dtype=bool)
        for j in range(p.shape[1]):
            sig = np.flatnonzero((padj[:, j] <= alpha) & is_peak[:, j])
            if sig.size == 0:
                continue
            b = int(sig[np.argmax(share[sig, j])])
            f = freq[b]
            unit = ev.frequency_unit
            if ev.bandwidth is not None and f > ev.bandwidth:
                out.append(_processing_note(ev, j, "oscillation", float(f), float(p[b, j]), float(padj[b, j]),
                                            float(share[b, j])))
                continue
            big = bool(share[b, j] >= th.oscillation)
            if big:
                deficient_joints.add(j)
            out.append(Finding(
                kind="oscillation", severity="deficiency" if big else "note", joints=(j,),
                statistic=float(ev.spectrum_ratio[b, j]), pvalue=float(p[b, j]), pvalue_adjusted=float(padj[b, j]),
                effect=float(share[b, j]), effect_unit="share of residual variance", threshold=th.oscillation,
                action=(f"an unmodelled mode near {f:.3g} {unit}: add joint or link compliance (a spring–damper) "
                        "or keep trajectories away from it" if big else "none: the peak is real but small"),
                details={"frequency": float(f), "frequency_unit": unit, "n_peaks": int(sig.size)},
                message=(f"{_name(names, j)}: the residual oscillates near {f:.3g} {unit} "
                         f"({100 * share[b, j]:.0f} % of its variance, {ev.spectrum_ratio[b, j]:.0f}× the background; "
                         f"Holm-adjusted p {_p_text(padj[b, j])})"
                         + (": unmodelled dynamics, e.g. joint flexibility (the lesson's Problem 5)." if big
                            else ": significant but negligible."))))
    return out


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
    if f.kind == "regressor_correlation" and "share" in (f.effect_unit or "") and f.effect is not None:
        return _col(ev.column_names, f.columns[0]) if f.columns else "a column", float(f.effect)
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
    ev, _th, alpha, fam, names, _cols = r.common()
    m = len(r.ev.r2)
    deficient_joints = r.deficient
    out: list[Finding] = []
    if "whiteness" in fam:
        _, padj = fam["whiteness"]
        raw = np.asarray(ev.whiteness_pvalue_raw, dtype=float)
        dec = ev.whiteness_pvalue_decimated
        for j in range(m):
            raw_reject = bool(raw[j] <= alpha)
            if dec is not None and raw_reject and not (padj[j] <= alpha):
                if j in deficient_joints:
                    continue  # the structure is shown above: its colour is not the sensor's
                band = ev.information_band
                out.append(Finding(
                    kind="sampling_colour", severity="note", joints=(j,), pvalue=float(dec[j]),
                    pvalue_adjusted=float(padj[j]), effect=float(ev.decimation), effect_unit="decimation factor",
                    action="none for the model; validate at the information rate (decimate=) or log less filtered data",
                    details={"information_band": band, "frequency_unit": ev.frequency_unit},
                    message=(f"{_name(names, j)}: the residual is coloured at the logged rate but white once reduced "
                             f"to the band the motion occupies (below {band:.3g} {ev.frequency_unit}, decimated by "
                             f"{ev.decimation}): the colour is what the sensor, its filters and the sampling make, "
                             "not the model.")))
                continue
            if not (padj[j] <= alpha):
                continue
            if ev.whiteness_above_bandwidth and j not in deficient_joints:
                out.append(_processing_note(ev, j, "whiteness", None, float(dec[j] if dec is not None else raw[j]),
                                            float(padj[j]), None))
                continue
            backed = j in deficient_joints
            rate = "at the information rate" if dec is not None else "at the logged rate"
            out.append(Finding(
                kind="whiteness", severity="deficiency" if backed else "note", joints=(j,),
                pvalue=float(dec[j] if dec is not None else raw[j]), pvalue_adjusted=float(padj[j]),
                effect=None if ev.max_abs_acf is None else float(ev.max_abs_acf[j]), effect_unit="max |ρ̂(ℓ)|",
                action=("see the findings above for the structure's source" if backed
                        else "none on this evidence: colour alone does not show the model is wrong"),
                details={"lag": ev.whiteness_lag, "decimation": ev.decimation},
                message=(f"{_name(names, j)}: the residuals are not white {rate} (Ljung–Box up to lag "
                         f"{ev.whiteness_lag}, Holm-adjusted p {_p_text(padj[j])})"
                         + (", and the findings above show the structure is the model's." if backed
                            else "; colour alone is not evidence against the model (sensor filtering, "
                                 "oversampling and estimation error colour residuals too)."))))
    return out


def _validation_design_rule(r: _Rules) -> list[Finding]:
    """The validation run's design: repeat, excitation, information."""
    return [*_repeat_findings(r.ev, r.th), *_excitation_findings(r.ev, r.th),
            *_design_findings(r.ev, r.th, r.deficient, _unresolved(r.ev, r.found, r.deficient)), *r.ev.extra_notes]


_RULES = (_data_notes, _worse_than_constant_rule, _bias_rule, _missing_term_rule, _regressor_correlation_rule,
          _oscillation_rule, _motion_rule, _whiteness_rule, _validation_design_rule)
"""The rules, in the order they run."""


def _lag_text(lag: int, sample_rate: float | None) -> str:
    """``lag 36`` or, with a rate, ``lag 36 (36 ms)``."""
    if sample_rate is None or lag == 0:
        return f"lag {lag}"
    seconds = lag / sample_rate
    return f"lag {lag} ({seconds:.3g} s)" if seconds >= 1 else f"lag {lag} ({1e3 * seconds:.3g} ms)"


def _timing_findings(ev: Evidence) -> list[Finding]:
    """A note on time stamps that are not a uniform grid, with the counts and the grid used."""
    t = ev.timing
    if t is None or t["regular"]:
        return []
    step = t["nominal_step"]

    def count(k: int, what: str) -> str:
        return f"{k} {what}" + ("" if k == 1 else "s")

    parts = []
    if t["duplicated_stamps"]:
        parts.append(count(t["duplicated_stamps"], "duplicated stamp"))
    if t["repeated_rows"]:
        parts.append(f"{count(t['repeated_rows'], 'row')} repeating the previous row's torques exactly "
                     f"({100 * t['repeated_rows'] / max(t['n_steps'], 1):.2g} %)")
    if t["gaps"]:
        parts.append(f"{count(t['gaps'], 'gap')} (largest {1e3 * t['largest_gap']:.4g} ms at "
                     f"t = {t['largest_gap_time']:.4g} s)")
    if t["irregular_steps"]:
        parts.append(f"{count(t['irregular_steps'], 'step')} more than 10 % off the nominal one (jitter RMS "
                     f"{1e3 * t['jitter_rms']:.3g} ms, largest deviation {1e3 * t['largest_step_deviation']:.3g} ms)")
    return [Finding(
        kind="time_stamps", severity="note", effect=float(t["gaps"] + t["duplicated_stamps"] + t["irregular_steps"]),
        effect_unit="irregular steps", details=dict(t),
        action="check the logger's clock and buffering; lags and frequencies assume the stated grid",
        message=(f"Time stamps on a {1e3 * step:.4g} ms nominal step: " + "; ".join(parts)
                 + f". The lag and spectral analyses use {t['grid']}."))]


def _processing_note(ev: Evidence, j: int, what: str, frequency: float | None, p: float, padj: float,
                     share: float | None) -> Finding:
    """Evidence above ``bandwidth`` Hz: the inputs' processing (a differentiating or sensor filter).

    ``frequency``: the spectral peak's (Hz); None for whiteness tested at a rate that still sees
    above the bandwidth."""
    assert ev.bandwidth is not None
    if frequency is not None:
        f_text, bw_text = versus(frequency, ev.bandwidth)
        evidence = f"a spectral peak near {f_text} Hz lies above the inputs' {bw_text} Hz bandwidth"
    else:
        evidence = (f"the residual's colour, tested at a rate whose band reaches above the inputs' "
                    f"{ev.bandwidth:.3g} Hz bandwidth,")
    return Finding(
        kind="processing_band", severity="note", joints=(j,), pvalue=p, pvalue_adjusted=padj,
        effect=share, effect_unit="share of residual variance" if share is not None else None,
        threshold=ev.bandwidth,
        action="none for the model: the inputs are not trustworthy there",
        details={"evidence": what, "bandwidth": ev.bandwidth, "frequency": frequency},
        message=(f"{_name(ev.joint_names, j)}: {evidence} (Holm-adjusted p {_p_text(padj)}): what the "
                 "differentiating or sensor filter makes there is processing, not the model."))


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
    seconds = per["period"]["seconds"]
    length = f"{seconds:.4g} s" if seconds else f"{per['period']['samples']:.4g} samples"
    out: list[Finding] = []
    bad: set[int] = set()
    for j in range(effect.size):
        if not (padj[j] <= alpha):
            continue
        big = bool(effect[j] >= th.periodic_error)
        if big:
            bad.add(j)
        out.append(Finding(
            kind="periodic_error", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(per["statistic"][j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(effect[j]), effect_unit="share of the residual's variance common to every period",
            threshold=th.periodic_error,
            action=("the model misses something the trajectory repeats: see the physics and correlation "
                    "findings for which term" if big else "none: the periodic part is real but small"),
            details={"n_periods": int(per["n_periods"]), "period": per["period"],
                     "noise_variance": float(per["noise_variance"][j]),
                     "model_columns_removed": bool(per.get("model_columns_removed", False))},
            message=(f"{_name(ev.joint_names, j)}: {100 * effect[j]:.0f} % of the residual's variance repeats in "
                     f"every one of the {per['n_periods']} periods ({length}) beyond what the period-to-period "
                     f"variation allows (noise measured from the periods themselves, no whiteness assumed; "
                     f"Holm-adjusted p {_p_text(padj[j])})"
                     + (": model error." if big else ": significant but negligible."))))
    return out, bad


def _physics_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    from ._physics import LABELS

    p, padj = pvalues
    names = ev.joint_names
    out: list[Finding] = []
    bad: set[int] = set()
    for j, t in enumerate(ev.physics["tests"]):
        if not (padj[j] <= alpha) or _delay_explains(ev, j):
            continue
        shares = t["shares"]
        term = t["term"]
        if term is None:
            continue
        big = bool(t["share"] >= th.missing_physics and t["term_share"] >= th.missing_physics)
        if big:
            bad.add(j)
        label = LABELS[term]
        others = [LABELS[g] for g, sh in sorted(shares.items(), key=lambda kv: -kv[1]) if g != term and sh >= 0.01]
        named = label + (f" (with {', '.join(others)})" if others else "")
        together = float(t.get("selected_share", t["term_share"]))
        out.append(Finding(
            kind="missing_physics", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(t["statistic"]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(t["share"]), effect_unit="share of the joint's mean square the physical terms remove",
            threshold=th.missing_physics,
            action=(f"add {label} on {_name(names, j)} to the model" if big
                    else "none: the structure is real but too small to matter"),
            details={"term": term, "label": label, "term_share": float(t["term_share"]),
                     "selected_share": together, "selected": list(t["selected"]), "shares": dict(shares),
                     "n_eff": float(t["n_eff"]), "method": ev.physics["method"],
                     "derivatives": ev.physics["derivatives"]},
            message=(f"{_name(names, j)}: the residual follows the motion: {named} removes "
                     f"{100 * together:.0f} % of its mean square ({100 * t['term_share']:.0f} % by {label} alone; "
                     f"every physical term together {100 * t['share']:.0f} %, "
                     f"prewhitened Wald test, Holm-adjusted p {_p_text(padj[j])})"
                     + (": a term the model lacks." if big else ": significant but negligible."))))
    return out, bad


def _delay_explains(ev: Evidence, j: int) -> bool:
    """Realigning removes at least as much of joint j's mean square as the physical terms: the
    structure is a time shift, not a missing term (a missing viscous term looks like a small shift)."""
    dl = ev.physics.get("delay") if ev.physics else None
    if dl is None:
        return False
    share = float(dl["share"][j])
    lib = ev.physics["tests"][j]["share"]
    return bool(share >= (lib if lib == lib else 0.0))


def _delay_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    """One finding for a common delay: joints whose test rejects and whose realignment removes at
    least the threshold's share of the mean square."""
    p, padj = pvalues
    dl = ev.physics["delay"]
    share = np.asarray(dl["share"], dtype=float)
    joints = [j for j in range(share.size) if padj[j] <= alpha and share[j] >= th.delay and _delay_explains(ev, j)]
    if not joints:
        return [], set()
    names = ev.joint_names
    fs = ev.sample_rate
    d = float(dl["shift_samples"])
    unit, value = ("ms", 1000.0 * d / fs) if fs else ("samples", d)
    j0 = max(joints, key=lambda j: share[j])
    each = "; ".join(f"{_name(names, j)} {100 * share[j]:.0f} %" for j in joints)
    return [Finding(
        kind="delay", severity="deficiency", joints=tuple(joints), statistic=d, pvalue=float(p[j0]),
        pvalue_adjusted=float(padj[j0]), effect=float(share[j0]),
        effect_unit="share of the joint's mean square realigning removes", threshold=th.delay,
        action=(f"realign the measured torque with the encoders (shift it by {value:+.3g} {unit}), "
                "or model the sensor's filter"),
        details={"delay_s": d / fs if fs else None, "delay_samples": d, "share": [float(x) for x in share]},
        message=(f"The measured torque lags the prediction by {value:+.3g} {unit} (realigning removes {each} "
                 f"of the mean square; Holm-adjusted p {_p_text(padj[j0])}): a delay between the torque "
                 "sensor and the encoders, not a missing term."))], set(joints)


def _predictive_findings(ev: Evidence, pvalues, th: Thresholds, alpha: float) -> tuple[list[Finding], set[int]]:
    p, padj = pvalues
    ratio = np.asarray(ev.predictive["ratio"], dtype=float)
    out: list[Finding] = []
    bad: set[int] = set()
    for j in range(ratio.size):
        if not (padj[j] <= alpha) or not ratio[j] >= th.predictive_ratio:
            continue
        bad.add(j)
        out.append(Finding(
            kind="predictive_failure", severity="deficiency", joints=(j,), statistic=float(ratio[j]),
            pvalue=float(p[j]), pvalue_adjusted=float(padj[j]), effect=float(ratio[j]),
            effect_unit="validation mean square / what the estimation run allows",
            threshold=th.predictive_ratio,
            action=(f"the model does not carry over to new motion on {_name(ev.joint_names, j)}: look for a term "
                    "the estimation trajectory did not need (a payload, a changed friction) or refit on richer data"),
            details={"expected_mse": float(ev.predictive["expected_mse"][j]),
                     "validation_mse": float(ev.predictive["validation_mse"][j])},
            message=(f"{_name(ev.joint_names, j)}: the validation mean square is {ratio[j]:.3g}× what the "
                     "estimation run's noise and parameter uncertainty allow (Chow-type F test, Holm-adjusted p "
                     f"{_p_text(padj[j])}).")))
    return out, bad


def _repeat_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
    """``repeat_trajectory``: a share of the validation run near the estimation trajectory at any
    time above ``repeat_share`` (conventions §5.6); without a state in both runs, a time-aligned
    distance below ``repeat_distance``."""
    d = ev.repeat
    if d is None:
        return []
    action = "validate on a different trajectory: a repeat rewards over-fitting"
    share = d.get("share")
    if share is not None:
        if not share > th.repeat_share:
            return []
        sh, sh_th = versus(share, th.repeat_share, ".0f", scale=100.0)
        state = "q, q̇, q̈" if d.get("state") == "q" else "the regressor's leading principal components"
        return [Finding(
            kind="repeat_trajectory", severity="design", effect=float(share),
            effect_unit=f"share of the validation run near the estimation trajectory ({d.get('state')})",
            threshold=th.repeat_share, action=action, details=dict(d),
            message=(f"The validation run repeats the estimation run: {sh} % of its states (> {sh_th} %) lie within "
                     f"{d.get('tolerance', th.repeat_tolerance):g} of the estimation trajectory at some time "
                     f"(state: {state}, each coordinate in estimation-run standard deviations, the distance an "
                     "RMS over them). Metrics on it measure the fit, not the prediction of new motion."))]
    if d.get("distance") is None or not d.get("is_repeat", d["distance"] < th.repeat_distance):
        return []
    dist, dist_th = versus(d["distance"], th.repeat_distance)
    return [Finding(
        kind="repeat_trajectory", severity="design", effect=float(d["distance"]),
        effect_unit=f"relative distance ({d['measure']})", threshold=th.repeat_distance, action=action,
        details=dict(d),
        message=(f"The validation run repeats the estimation run: relative {d['measure']} distance "
                 f"{dist} < {dist_th} (time-aligned; give q or the regressor of both runs to compare states at "
                 "any time). Metrics on it measure the fit, not the prediction of new motion."))]


def _listed(cols, columns, most: int = 6) -> str:
    names = [_col(cols, c) for c in columns]
    return ", ".join(names[:most]) + (f", … ({len(names)} in all)" if len(names) > most else "")


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
        out.append(Finding(
            kind="excitation", severity="note", columns=tuple(structural), effect=float(len(structural)),
            effect_unit="structural columns", action="none: no trajectory of this structure can excite them apart",
            details={"structural": structural, "identifiable_rank": rank,
                     "identifiable_columns": list(x.get("identifiable_columns") or [])},
            message=(f"{len(structural)} of the regressor's {p} columns are zero or exact combinations of the "
                     f"others in both runs ({_listed(cols, structural)}): no trajectory of this structure excites "
                     f"them apart, so they were reduced to {rank} identifiable combinations (the base "
                     "parameters), on which the excitation checks ran.")))
    zero = [int(c) for c in x["unexcited"]]
    dependent = [int(c) for c in x.get("inseparable") or []]
    if zero or dependent:
        parts = []
        if zero:
            parts.append(f"never excites {_listed(cols, zero)}")
        if dependent:
            parts.append(f"cannot separate {_listed(cols, dependent)} from the other columns (in this run they are "
                         "combinations of them)")
        if x.get("structural") is not None:
            tail = ": the estimation run excites them apart, so the validation cannot test these terms."
        else:
            tail = (": the validation cannot test these terms. Without the estimation run's regressor "
                    "(estimation={'regressor': ...}) it is not known whether they are structural (zero or "
                    "combinations of other columns for every trajectory of this structure, as some parameters "
                    "of a fixed-base arm's first links are) or a flaw of this trajectory; reduce the regressor to "
                    "its base columns, or give the estimation run's regressor.")
        out.append(Finding(
            kind="excitation", severity="design", columns=tuple(zero + dependent),
            effect=float(len(zero) + len(dependent)), effect_unit="columns",
            action="add motion that excites these columns to the validation trajectory",
            details=dict(x), message="The validation regressor " + " and ".join(parts) + tail))
    elif x["condition_scaled"] > th.condition_number:
        cond, cond_th = versus(x["condition_scaled"], th.condition_number)
        over = (f" over its {x.get('validation_rank')} identifiable combinations" if structural else "")
        out.append(Finding(
            kind="excitation", severity="design", effect=float(x["condition_scaled"]),
            effect_unit="column-scaled condition number", threshold=th.condition_number,
            action="use a richer validation trajectory", details=dict(x),
            message=(f"The validation regressor is ill-conditioned (column-scaled condition number{over} "
                     f"{cond} > {cond_th}): it cannot separate the effects of the parameters.")))
    return out


def _unresolved_text(terms: list[tuple[str, float]]) -> str:
    named = " and ".join(f"{name} {100 * share:.0f} %" for name, share in terms)
    return (f" — found deficient, but what is named there removes less: {named}, so which term is missing "
            "this run cannot tell")


def _design_findings(ev: Evidence, th: Thresholds, decided: frozenset[int] | set[int] = frozenset(),
                     unresolved: dict[int, list[tuple[str, float]]] | None = None) -> list[Finding]:
    """Runs that cannot decide: a joint that hardly moves, too few effective samples (on a joint
    where no deficiency was found, or where the term named removes less than the run can detect,
    ``unresolved``, with the terms named: where a term above that was found, the run did decide)."""
    unresolved = unresolved or {}
    out: list[Finding] = []
    names = ev.joint_names
    if ev.joint_motion_ratio is not None:
        ratio = np.asarray(ev.joint_motion_ratio, dtype=float)
        for j in np.flatnonzero(ratio < th.joint_motion):
            out.append(Finding(
                kind="excitation", severity="design", joints=(int(j),), effect=float(ratio[j]),
                effect_unit="joint motion (RMS) relative to the estimation run", threshold=th.joint_motion,
                action=f"move {_name(names, j)} in the validation run as much as in the estimation run",
                details={"joint_motion_ratio": float(ratio[j])},
                message=(f"{_name(names, j)} moves {versus(ratio[j], th.joint_motion, '.1f', scale=100.0)[0]} % "
                         "of its estimation-run motion: the "
                         "validation cannot test the terms of this joint.")))
    ratio_c = None if ev.excitation is None else ev.excitation.get("column_motion_ratio")
    if ratio_c is not None:
        x = ev.excitation
        skip = (set(x["unexcited"]) | set(x["unidentifiable"]) | set(x.get("inseparable") or [])
                | set(x.get("structural") or []))
        weak = [int(c) for c in np.flatnonzero(np.asarray(ratio_c, dtype=float) < th.joint_motion) if c not in skip]
        if weak:
            listed = ", ".join(f"{_col(ev.column_names, c)} "
                               f"({versus(ratio_c[c], th.joint_motion, '.1f', scale=100.0)[0]} %)" for c in weak)
            out.append(Finding(
                kind="excitation", severity="design", columns=tuple(weak),
                effect=float(np.min(np.asarray(ratio_c)[weak])),
                effect_unit="column RMS relative to the estimation run", threshold=th.joint_motion,
                action="excite these columns in the validation run as much as in the estimation run",
                details={"column_motion_ratio": {int(c): float(ratio_c[c]) for c in weak}},
                message=(f"The validation run excites {listed} far less than the estimation run did: it cannot "
                         "test these terms.")))
    if ev.detectable_share is not None:
        mde = np.asarray(ev.detectable_share, dtype=float)
        low = [int(j) for j in np.flatnonzero(mde > th.detectable_share)
               if int(j) not in decided or int(j) in unresolved]
        if low:
            n_eff = np.asarray(ev.noise_n_eff, dtype=float)
            mde_pct = {j: versus(mde[j], th.detectable_share, ".0f", scale=100.0) for j in low}
            each = "; ".join(f"{_name(names, j)}: N_eff = {n_eff[j]:.0f}, {mde_pct[j][0]} %"
                             + (_unresolved_text(unresolved[j]) if j in unresolved else "") for j in low)
            out.append(Finding(
                kind="low_information", severity="design", joints=tuple(low), effect=float(mde[low].max()),
                effect_unit="smallest detectable share of the mean square (90 % power)",
                threshold=th.detectable_share,
                action="validate on a longer or faster-varying run (more effective samples)",
                details={"detectable_share": [float(x) for x in mde], "noise_n_eff": [float(x) for x in n_eff],
                         "unresolved": sorted(int(j) for j in unresolved if j in low)},
                message=(f"This run cannot decide: its noise leaves so few effective samples that a missing term "
                         f"must remove more than {mde_pct[low[0]][1]} % of the mean square to be found "
                         f"({each}).")))
    return out
