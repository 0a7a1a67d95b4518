"""The words of the findings: each kind's message and action, and the units of its effect.

Only wording: what decides (which joint, which column, deficiency or note) is in
``_findings.py``, which passes the numbers it decided on. A function per kind returns
``(message, action)``; the summary's wording is in ``_summary.py``, a comparison's in
``_reasons.py``, and every number is written by ``_text`` (contract §4).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ._text import counted, number_text, p_clause, versus

Words = tuple[str, str]
"""``(message, action)`` of one finding."""

UNITS = {
    "omitted_rows": "rows",
    "information_criteria": "parameters",
    "worse_than_constant": "1 − R² beyond 1 (fraction of TSS)",
    "pooling": "R² below pooled",
    "bias": "|mean| / RMSE",
    "missing_term": "share of the residual's mean square the term would remove",
    "correlation": "|ρ|",
    "oscillation": "share of residual variance",
    "prediction_artefact": "share of residual variance",
    "sampling_colour": "decimation factor",
    "whiteness": "max |ρ̂(ℓ)|",
    "time_stamps": "irregular steps",
    "processing_band": "share of residual variance",
    "periodic_error": "share of the residual's variance common to every period",
    "missing_physics": "share of the joint's mean square the physical terms remove",
    "delay": "share of the joint's mean square realigning removes",
    "delay_phase": "degrees of phase lag at the information band's edge",
    "predictive_failure": "validation mean square / what the estimation run allows",
    "structural": "structural columns",
    "columns": "columns",
    "condition": "column-scaled condition number",
    "joint_motion": "joint motion (RMS) relative to the estimation run",
    "column_motion": "column RMS relative to the estimation run",
    "low_information": "smallest detectable share of the mean square (90 % power)",
}
"""``Finding.effect_unit`` by rule (the repeat finding's names its state or measure)."""

NEGLIGIBLE = ": significant but negligible."


def joint_name(names: Sequence[str] | None, j: int) -> str:
    return names[j] if names and j < len(names) else f"joint {j + 1}"


def column_name(names: Sequence[str] | None, c: int) -> str:
    return names[c] if names and c < len(names) else f"column {c + 1}"


def p_text(p: Any, log_p: Any = None) -> str:
    """``= 0.0123`` or ``< 1e-300``: the relation and the value, for "p {…}" in a message
    (:func:`dynval.report._text.p_clause`, the one p-value wording of every text, contract §4)."""
    return p_clause(p, log_p)


def lag_text(lag: int, sample_rate: float | None) -> str:
    """``lag 36`` or, with a rate, ``lag 36 (36 ms)``."""
    if sample_rate is None or lag == 0:
        return f"lag {lag}"
    seconds = lag / sample_rate
    return f"lag {lag} ({seconds:.3g} s)" if seconds >= 1 else f"lag {lag} ({1e3 * seconds:.3g} ms)"


def listed_columns(cols: Sequence[str] | None, columns: Sequence[int], most: int = 6) -> str:
    names = [column_name(cols, c) for c in columns]
    return ", ".join(names[:most]) + (f", … ({len(names)} in all)" if len(names) > most else "")


# -- the data -----------------------------------------------------------------------------------

def omitted_rows(count: int) -> Words:
    were = "was" if count == 1 else "were"
    return (f"{counted(count, 'row')} with non-finite values {were} omitted; segment breaks were inserted so no lag "
            "joins samples that were not adjacent.", "check the logger for dropped or invalid samples")


def information_criteria(n_params: int, n_obs: int, noise_model: str) -> Words:
    counted = "N·m samples × joints" if noise_model == "pooled" else f"N samples ({noise_model} noise model)"
    return (f"n_params = {n_params} is not below n − 1 = {n_obs - 1}, where n = {n_obs} is the observations the "
            f"information criteria count ({counted}): AICc and FPE are nan, undefined there (AICc's correction "
            f"2p(p+1)/(n − p − 1) divides by a number that is not positive, and FPE's (1 + p/n)/(1 − p/n) has no "
            f"finite value at p = n), and AIC and BIC are mostly the penalty 2p or p·ln n, "
            f"so they rank models by their size, not by their fit. The tests of the residual do not depend on "
            f"n_params.",
            "compare models on a validation run with more observations than parameters, or by the tests of the "
            "residual; check that n_params counts the identified parameters")


def constant_target(name: str, force_finite: bool) -> Words:
    how = "0 or 1 by scikit-learn's force_finite rule" if force_finite else "-inf, or nan for an exact prediction"
    return (f"{name}: the measured torque is constant, so R², fit and VAF compare against nothing "
            f"(reported as {how}).", "validate this joint on a trajectory that moves it")


def time_stamps(t: Mapping[str, Any]) -> Words:
    """The irregular steps of a time-stamp record (``dynval.checks._timing.Timing.to_dict``)."""

    parts = []
    if t["duplicated_stamps"]:
        parts.append(counted(t["duplicated_stamps"], "duplicated stamp"))
    if t["repeated_rows"]:
        parts.append(f"{counted(t['repeated_rows'], 'row')} repeating the previous row's torques exactly "
                     f"({100 * t['repeated_rows'] / max(t['n_steps'], 1):.2g} %)")
    if t["gaps"]:
        parts.append(f"{counted(t['gaps'], 'gap')} (largest {1e3 * t['largest_gap']:.4g} ms at "
                     f"t = {t['largest_gap_time']:.4g} s)")
    if t["irregular_steps"]:
        parts.append(f"{counted(t['irregular_steps'], 'step')} more than 10 % off the nominal one (jitter RMS "
                     f"{1e3 * t['jitter_rms']:.3g} ms, largest deviation {1e3 * t['largest_step_deviation']:.3g} ms)")
    return (f"Time stamps on a {1e3 * t['nominal_step']:.4g} ms nominal step: " + "; ".join(parts)
            + f". The lag and spectral analyses use {t['grid']}.",
            "check the logger's clock and buffering; lags and frequencies assume the stated grid")


# -- the fit ------------------------------------------------------------------------------------

def worse_than_constant(name: str, r2: float, hidden_by: float | None) -> Words:
    """``hidden_by``: the pooled R² when it looks good (> 0) over several joints."""
    return (f"{name} does worse than a constant: R² = {versus(r2, 0.0, '.3f')[0]}"
            + (f", yet the pooled R² is {hidden_by:.3f} (pooling flattens all joints with one mean, so the "
               "high-torque joints dominate it; read the per-joint values)." if hidden_by is not None else "."),
            f"check {name}'s terms, signs and units: predicting its mean torque does better")


def pooling(name: str, r2: float, pooled: float) -> Words:
    return (f"{name}: R² = {r2:.3f}, well below the pooled {pooled:.3f}, which the larger torques of other "
            "joints dominate.", "read the per-joint values")


def bias(name: str, mean: float, effect: float, threshold: float, n_eff: float, n: int, padj: float, big: bool,
         culprit: tuple[str, float] | None, kinds: Mapping[str, bool | None] | None = None,
         term: tuple[str, str, str] | None = None) -> Words:
    """``culprit``: the missing column that accounts for the mean, and its share; ``kinds``: which of
    an offset, a friction and a gravity term the model has (:func:`bias_action`); ``term``: (group,
    label, relation) of a physical term the model lacks on the joint, whose mean the bias is."""
    pct = versus(effect, threshold, ".0f", scale=100.0)
    head = (f"{name}: residual mean {mean:+.4g} ({pct[0]} % of the RMSE; coloured-noise t-test N_eff = {n_eff:.0f} "
            f"of {n}, Holm-adjusted p {p_text(padj)})")
    if not big:
        return (head + f": significant but negligible (below {pct[1]} % of the RMSE).",
                "none: the bias is real but too small to matter")
    tail = f"; the missing term {culprit[0]} accounts for it." if culprit else "."
    if culprit is not None:
        action = (f"add the term {culprit[0]} on {name}: without it the model leaves this offset "
                  f"({100 * culprit[1]:.1f} % of the mean square is its part outside the model)")
    elif term is not None:
        group, label, relation = term
        tail = f"; the physical term the model lacks on this joint ({label}, see below) accounts for it."
        action = (f"add the coupling (cross-joint) terms of {label} on {name}: {_coupling_terms(group, name)}"
                  if relation == "coupling" else
                  f"complete {label} on {name}: add {_PARTIAL.get(group, 'the form it lacks')}"
                  if relation == "partial" else f"add {label} on {name}: the bias is its mean on this trajectory")
    else:
        action = bias_action(name, kinds)
    return head + ": a systematic bias, e.g. a missing offset, friction or gravity term" + tail, action


BIAS_KINDS = (("offset", "a torque offset (sensor bias)"), ("friction", "a friction"), ("gravity", "a gravity term"))


def bias_action(name: str, kinds: Mapping[str, bool | None] | None) -> str:
    """What to do about a bias, relative to the model: add only what it lacks; re-identify what it has.

    ``kinds``: for "offset", "friction", "gravity", True (the model's columns span it on the joint),
    False (they do not) or None (not known); None when the model's columns are unknown."""
    if kinds is None:
        return (f"look for a torque offset (sensor bias), a friction or a gravity term on {name}: a bias of this "
                "kind remains (the model's columns are unknown, so whether it has them cannot be told)")
    lacks = [w for k, w in BIAS_KINDS if kinds.get(k) is False]
    has = [w.replace("a ", "", 1) for k, w in BIAS_KINDS if kinds.get(k) is True]
    unknown = [w for k, w in BIAS_KINDS if kinds.get(k) is None]
    parts = []
    if lacks:
        parts.append(f"add {' or '.join(lacks)} on {name} (the model lacks it)")
    if unknown:
        parts.append(f"look for {' or '.join(unknown)} (with q the report would tell whether the model has it)")
    if has:
        parts.append(("re-identify " if not parts else "or re-identify ") + f"the {', '.join(has)} the model has on "
                     f"{name}: its weight differs on this run (changed between runs, or the sensor's offset moved)")
    return "; ".join(parts)


def missing_term(name: str, terms: Sequence[tuple[str, float, float] | tuple[str, float, float, float]], refit: bool,
                 padj: float, big: bool,
                 indirect: Sequence[tuple[str, float]] = ()) -> Words:
    """``terms``: (column, statistic, share, share added alone or nan) of the chosen columns,
    strongest first; ``indirect``: (joint, share) of the joints the first column does not enter
    whose error adding it removes too (through the parameters refitted with it)."""
    symbol = "t" if refit else "ρ"

    def alone_text(share: float, alone: float) -> str:
        # said only where it differs: another absent column of the joint refit can stand in for this one
        return (f"; {100 * alone:.1f} % added alone" if math.isfinite(alone) and abs(alone - share) >= 0.01
                else "")

    listed = "; ".join(f"{t[0]} ({symbol} = {t[1]:+.3g}, would remove {100 * t[2]:.1f} % of the mean square"
                       f"{alone_text(t[2], t[3] if len(t) > 3 else math.nan)})" for t in terms[:3])
    how = ("refitted on the estimation run with the term added (Wald t with the coloured-noise covariance; the "
           "share is measured on the validation run)" if refit
           else "after removing what the model's own columns represent")
    if indirect:
        how += (f"; adding {terms[0][0]} alone (the model's parameters refitted with it) also removes "
                + ", ".join(f"{100 * s:.1f} % on {joint}" for joint, s in indirect)
                + " (joints it does not act on: the estimation run's fit made up for it there)")
    return (f"{name}: a term the model lacks explains part of the residual: {listed}; {how} (Holm-adjusted p "
            f"{p_text(padj)})" + (": a missing term." if big else NEGLIGIBLE),
            f"add the term {terms[0][0]} to the model" if big else "none: the term would explain too little to matter")


def regressor_correlation(name: str, hits: Sequence[tuple[str, str, float]], threshold: float, best: float,
                          padj: float, big: bool, in_model: bool | None = None,
                          simulator: tuple[float, float] | None = None) -> Words:
    """``hits``: (column, lag text, ρ) of the chosen columns, strongest first; ``in_model``: the
    first column is one of the model's (True), outside it (False), or not known (None);
    ``simulator``: the first column's (value in the prediction, value refitted on this run) when it
    is a simulator parameter's at lag 0 (:func:`simulator_words`)."""
    listed = "; ".join(f"{c} ({lag}, ρ = {versus(rho, threshold, '+.3f', absolute=True)[0]})"
                       for c, lag, rho in hits[:3])
    head = (f"{name}: the residual correlates with {listed} beyond what the colour of both series explains "
            f"(Holm-adjusted p {p_text(padj)})")
    if big:
        sim = simulator_words(name, hits[0][0], *simulator) if in_model and simulator else None
        if sim:
            return (head + ": the model has this column but does not use the information in it (a mis-weighted "
                    f"term, or one that changed between runs): {sim[0]}.", sim[1])
        if in_model:
            return (head + ": the model has this column but does not use the information in it (a mis-weighted "
                    "term, or one that changed between runs).",
                    f"re-identify the term of {hits[0][0]} on {name}: the model has it, its weight does not fit "
                    "this run")
        if in_model is False:
            return (head + ": the model lacks this column and the residual uses its information (a missing term).",
                    f"add the term {hits[0][0]} on {name}: the model lacks it")
        return (head + ": the model does not use the information in this column (a missing or mis-weighted term).",
                f"add or re-weight the term of {hits[0][0]} on {name}: the model does not use the information in it")
    return (head + f": significant but negligible (|ρ| below {versus(best, threshold)[1]}).",
            "none: the correlation is real but too small to matter")


def oscillation(name: str, frequency: float, unit: str, share: float, ratio: float, padj: float, big: bool) -> Words:
    return (f"{name}: the residual oscillates near {frequency:.3g} {unit} ({100 * share:.0f} % of its variance, "
            f"{ratio:.0f}× the background; Holm-adjusted p {p_text(padj)})"
            + (": dynamics the model lacks, e.g. a flexible joint or link (an unmodelled mode)." if big
               else NEGLIGIBLE),
            f"an unmodelled mode near {frequency:.3g} {unit}: add joint or link compliance (a spring–damper) or keep "
            "trajectories away from it" if big else "none: the peak is real but small")


def prediction_artefact(name: str, frequency: float, unit: str, share: float, ratio: float, padj: float, big: bool,
                        predicted: float, measured: float) -> Words:
    """``predicted``, ``measured``: the line's power in the prediction and in the measured torque."""
    return (f"{name}: the residual's line near {frequency:.3g} {unit} is the prediction's own: the prediction holds "
            f"{predicted:.2g} (squared torque units) there, the measured torque {measured:.2g} ({100 * share:.0f} % of "
            f"the residual's variance, {ratio:.0f}× the background; Holm-adjusted p {p_text(padj)})"
            + (": the model makes a line the robot does not have, not an unmodelled mode (e.g. a friction model's "
               "sign(q̇) chattering at standstill)." if big else NEGLIGIBLE),
            f"smooth what makes the model's line near {frequency:.3g} {unit}: e.g. the model's sign(q̇) chatters at "
            "standstill: smooth the friction model's sign (tanh(q̇/v₀)) or hold it in a stiction band; do not add "
            "compliance" if big else "none: the line is the model's own, but small")


def sampling_colour(name: str, band: float | None, unit: str, decimation: int) -> Words:
    """``band``: the information band the decimation came from; None for a factor given as is."""
    reduced = (f"reduced to the band the motion occupies (below {band:.3g} {unit}, decimated by {decimation})"
               if band is not None else f"decimated by {decimation} (the factor given)")
    return (f"{name}: the residual is coloured at the logged rate but white once {reduced}: the colour is what the "
            "sensor, its filters and the sampling make, not the model.",
            "none for the model; test at the rate the motion needs (decimate=) or log less filtered data")


def whiteness(name: str, decimated: bool, lag: int | None, padj: float, backed: bool) -> Words:
    """``backed``: an earlier rule found the joint deficient."""
    rate = ("at the rate the motion needs (the information rate)" if decimated
            else "at the logged rate")
    return (f"{name}: the residuals are correlated in time (not white) {rate} (Ljung–Box up to lag {lag}, "
            f"Holm-adjusted p {p_text(padj)})"
            + (", and the findings above show the structure is the model's." if backed
               else "; colour alone is not evidence against the model (sensor filtering, oversampling and "
                    "estimation error colour residuals too)."),
            "see the findings above for the structure's source" if backed
            else "none on this evidence: colour alone does not show the model is wrong")


def processing_band(name: str, frequency: float | None, bandwidth: float, padj: float) -> Words:
    """Evidence above the inputs' bandwidth: a spectral peak at ``frequency`` Hz, or (None) whiteness."""
    if frequency is not None:
        f_text, bw_text = versus(frequency, bandwidth)
        evidence = f"a spectral peak near {f_text} Hz lies above the inputs' {bw_text} Hz bandwidth"
    else:
        evidence = (f"the residual's colour, tested at a rate whose band reaches above the inputs' "
                    f"{bandwidth:.3g} Hz bandwidth,")
    return (f"{name}: {evidence} (Holm-adjusted p {p_text(padj)}): what the differentiating or sensor filter makes "
            "there is processing, not the model.", "none for the model: the inputs are not trustworthy there")


# -- the motion ---------------------------------------------------------------------------------

def periodic_error(name: str, effect: float, n_periods: Any, period: Mapping[str, Any], padj: float,
                   big: bool) -> Words:
    seconds = period["seconds"]
    length = f"{seconds:.4g} s" if seconds else f"{period['samples']:.4g} samples"
    return (f"{name}: {100 * effect:.0f} % of the residual's variance repeats in every one of the {n_periods} "
            f"periods ({length}) beyond what the period-to-period variation allows (noise measured from the "
            f"periods themselves, no whiteness assumed; Holm-adjusted p {p_text(padj)})"
            + (": model error." if big else NEGLIGIBLE),
            "the model misses something the trajectory repeats: see the physics and correlation findings for "
            "which term" if big else "none: the periodic part is real but small")


def missing_physics(name: str, label: str, others: Sequence[str], together: float, term_share: float,
                    share: float, padj: float, big: bool, advice: Mapping[str, Any] | None = None) -> Words:
    """``advice``: how the named term's share was measured (``refit_run``, ``effect``, ``derivatives``)
    and its ``relation`` to the model's columns (None: the columns are unknown)."""
    advice = advice or {}
    named = label + (f" (with {', '.join(others)})" if others else "")
    head = (f"{name}: the residual follows the motion: {named} removes {100 * together:.0f} % of its mean square "
            f"({100 * term_share:.0f} % by {label} alone; every physical term together {100 * share:.0f} %, "
            f"prewhitened Wald test, Holm-adjusted p {p_text(padj)})")
    head += _measured(label, advice)
    if not big:
        return (head + NEGLIGIBLE, "none: the structure is real but too small to matter")
    rel: Mapping[str, Any] = advice.get("relation") or {}
    kind = rel.get("relation")
    if kind is None:
        return (head + f": a structure of this kind remains ({label}); the model's columns are unknown, so whether "
                "it lacks the term or weights it wrongly cannot be told.",
                f"look for {label} on {name}: a structure of this kind remains (give the regressor to tell a "
                "missing term from a mis-weighted one)")
    held = f"{100 * rel['outside_share']:.0f} % of the mean square on held-out rows"
    # re-identifying is advice only where the refit carries to rows it did not see (a refit that
    # makes held-out rows worse is a weight this run does not pin down)
    carries = rel["reweight_share"] >= advice.get("practical", 0.0)
    if kind == "reweight":
        simulator = _simulator_parameter(name, advice)
        return (head + f": the model has this term (its columns span it, each column within "
                f"{100 * rel['tolerance']:.0f} % of its RMS), so it is mis-weighted or changed between runs: "
                + (simulator[0] if simulator else _coefficients(advice))
                + f"; re-identifying the model's columns would remove "
                f"{100 * rel['reweight_share']:.0f} % of the joint's mean square (cross-fitted on this run).",
                simulator[1] if simulator else
                f"re-identify {label} on {name}: the model has the term, its weight differs on this run (a friction "
                "or load that changed between runs, or a term the estimation run did not excite)" if carries else
                f"re-identify {label} on {name} with this run and the estimation run together: the model has the "
                f"term, and refitted on this run alone its weight does not carry to held-out rows "
                f"({100 * rel['reweight_share']:.0f} %), so neither run pins it down by itself (then validate on a "
                "third run)")
    if kind == "unsupported" and carries:
        return (head + f": the model lacks {label}, but adding it does not carry to held-out rows of this run "
                f"({100 * rel['outside_share']:.0f} %); re-identifying the model's own columns removes "
                f"{100 * rel['reweight_share']:.0f} % there (cross-fitted): its terms are mis-weighted.",
                f"re-identify the model's terms on {name}: what remains is carried by its own columns with other "
                f"weights, not by {label}")
    if kind == "unsupported":
        return (head + f": the model lacks {label}, but adding it does not carry to held-out rows of this run "
                f"({100 * rel['outside_share']:.0f} %), nor does re-identifying the model's own columns "
                f"({100 * rel['reweight_share']:.0f} %, cross-fitted): what remains is no fixed term this run can "
                "pin down (it changes within the run, or its noise is slower than the cross-fit's blocks).",
                f"no change of the model's terms carries to held-out rows on {name}: look for what changes within "
                "the run (temperature, a load, the logs' alignment), or validate on a longer run, before changing "
                "the model")
    if kind == "coupling":
        return (head + f": the model has {label} of {name}'s own motion but not its coupling to the other joints: "
                f"the cross-joint columns lie outside its span and remove {held} (a decoupled model of a coupled "
                "arm).",
                f"add the coupling (cross-joint) terms of {label} on {name}: {_coupling_terms(rel['group'], name)}")
    if kind == "partial":
        return (head + f": the model has part of this term ({rel['own_in_span']} of its {rel['own_columns']} own "
                f"columns lie in the span of its columns); what lies outside removes {held}: another shape of it.",
                f"complete {label} on {name}: the model has part of it; add "
                + _PARTIAL.get(rel["group"], "the form it lacks"))
    return (head + f": a term the model lacks (outside the span of its columns on this joint; it removes {held}).",
            f"add {label} on {name} to the model")


_PARTIAL = {"coulomb": "the friction shape it lacks (a smooth sign or a Stribeck term)",
            "gravity": "the posture terms it lacks (a centre-of-mass component)",
            "position_harmonic": "the position harmonics it lacks",
            "inertia": "the acceleration terms it lacks"}


def _measured(label: str, advice: Mapping[str, Any]) -> str:
    """How the named term's own share was measured, and from which derivatives."""
    run = advice.get("refit_run")
    effect = advice.get("effect")
    pct = "" if effect is None or effect != effect else f"{100 * effect:.0f} %"
    if run == "estimation":
        return (f"; {label} refitted alone with the model on the estimation run and carried to this run removes "
                f"{pct} (derivatives: {advice.get('derivatives')})")
    if run == "validation":
        return (f"; named by a fallback refit on this run alone (no group refitted on the estimation run helped): "
                f"added to the model's columns refitted here it removes {pct} of held-out rows (cross-fitted on "
                "alternate blocks of this run)")
    return (f"; {label}'s own effect on held-out rows of this run (cross-fitted on alternate blocks) is {pct}"
            if pct else "")


def _simulator_parameter(name: str, advice: Mapping[str, Any]) -> Words | None:
    """:func:`simulator_words` for the model column closest to the named term (``advice["simulator"]``:
    its value in the prediction and refitted on this run, when it is a simulator parameter's)."""
    names, values = advice.get("column_names") or [], advice.get("simulator")
    return simulator_words(name, names[0], *values) if names and values else None


def simulator_words(name: str, column: str, given: float, refit: float) -> Words | None:
    """When ``column`` is a simulator parameter of joint ``name`` (an MJCF model's ``damping_<joint>``,
    ...): what the residual follows, in that parameter's unit (the column's coefficient refitted on
    this run, as ``MJCFModel.retune`` refits it, minus its value in the prediction), and the value
    to retune it to. None for another column, or one the run could not refit."""
    from ..statistics._model_terms import SIMULATOR_PARAMETERS, simulator_attribute

    parsed = simulator_attribute(column)
    delta = refit - given
    if parsed is None or parsed[1] != name or math.isnan(delta):
        return None
    attribute = parsed[0]
    motion, unit = SIMULATOR_PARAMETERS[attribute]
    side = "low" if delta > 0 else "high"
    return (f"{attribute} on {name} is too {side}: the residual follows {motion} with {delta:+.2g} {unit} "
            f"({number_text(given, '.4g')} in the model, {number_text(refit, '.4g')} refitted on this run)",
            f"retune {attribute} on {name} in the simulator model: {number_text(given, '.4g')} → "
            f"{number_text(refit, '.4g')} {unit} (refitted on this run; MJCFModel.retune gives its standard "
            "deviation)")


def _coefficients(advice: Mapping[str, Any]) -> str:
    rel = advice["relation"]
    where = "estimated on the estimation run" if rel.get("estimated_from") == "estimation" else "in the prediction"
    names = advice.get("column_names") or [f"column {c + 1}" for c in rel.get("columns", [])]
    parts = [f"{c} {e:.4g} {where}, {r:.4g} refitted on this run"
             for c, e, r in zip(names, rel.get("estimated", []), rel.get("refitted", []))]
    return "; ".join(parts) if parts else "its coefficients differ"


def _coupling_terms(group: str, name: str) -> str:
    if group == "gravity":
        return f"the posture terms sin/cos(q_i + … + q_k) of the link-angle chains through {name}"
    if group == "inertia":
        return "the other joints' accelerations q̈_k (the mass matrix's off-diagonal terms)"
    return "the other joints' terms"


def _pct(share: float) -> str:
    """A share in per cent with the digits a reader needs: ``98 %``, ``4.2 %``, ``0.56 %``."""
    x = 100.0 * share
    return f"{x:.0f} %" if abs(x) >= 10 else f"{x:.2g} %"


def delay(shift: float, sample_rate: float | None, shares: Sequence[tuple[str, float]], padj: float, *,
          phase: float | None = None, band: float | None = None, phase_threshold: float = 10.0, big: bool = True,
          masked: Sequence[tuple[str, float, float]] = ()) -> Words:
    """``shift`` in samples; ``shares``: (joint, share of its mean square realigning removes);
    ``phase``: the lag in degrees at the information band's edge ``band`` (Hz with a rate, else
    cycles/sample); ``masked``: (joint, realigning's share, the physical terms' share) where a
    missing term explains more than the shift."""
    unit, value = ("ms", 1000.0 * shift / sample_rate) if sample_rate else ("samples", shift)
    # > 0: the torque sensor lags the encoders; < 0: the encoders lag the torque
    verb, side = ("lags", "lag") if shift > 0 else ("leads", "lead")
    size = f"{abs(value):.3g} {unit}" + (f" ({abs(shift):.3g} samples)" if sample_rate else "")
    lag = ("" if phase is None else
           f", a {phase:.3g}° phase {side} at the information band's edge "
           f"({band:.3g} {'Hz' if sample_rate else 'cycles/sample'})")
    each = "; ".join(f"{name} {_pct(share)}" for name, share in shares)
    head = (f"The measured torque {verb} the prediction by {size}{lag} (realigning removes {each} of the mean square; "
            f"Holm-adjusted p {p_text(padj)})")
    if big:
        why = (f"large for control (at least {phase_threshold:g}° at the band's edge)" if phase is not None
               and phase >= phase_threshold else "it removes a practical share of the error")
        return (head + f": a delay between the torque sensor and the encoders, not a missing term; {why}.",
                f"realign the measured torque with the encoders (shift it by {value:+.3g} {unit}), or model the "
                "sensor's filter")
    if masked:
        terms = "; ".join(f"{name} {_pct(lib)} against {_pct(sh)}" for name, sh, lib in masked)
        return (head + f". The physical terms explain more of these joints' error than the shift ({terms}): the "
                "shift may be the missing term's (a missing viscous term looks like a delay); check the logs' "
                "alignment once the term is in the model.", "none on this evidence: see the missing terms first")
    return (head + f": real, but below the {phase_threshold:g}° at the band's edge that matters for control and the "
            "share that matters for the error.", "none: the delay is real but small")


def predictive_failure(name: str, ratio: float, padj: float) -> Words:
    return (f"{name}: the validation mean square is {ratio:.3g}× what the estimation run's noise and parameter "
            f"uncertainty allow (Chow-type F test, Holm-adjusted p {p_text(padj)}).",
            f"the model does not carry over to new motion on {name}: look for a term the estimation trajectory did "
            "not need (a payload, a changed friction) or refit on richer data")


# -- the design ---------------------------------------------------------------------------------

REPEAT_ACTION = "validate on a different trajectory: a repeat rewards over-fitting"
_REPEAT_TAIL = "Metrics on it measure the fit, not the prediction of new motion."


def repeat_by_state(share: float, threshold: float, state: str | None, tolerance: float) -> Words:
    sh, sh_th = versus(share, threshold, ".0f", scale=100.0)
    states = "q, q̇, q̈" if state == "q" else "the regressor's leading principal components"
    return (f"The validation run repeats the estimation run: {sh} % of its states (> {sh_th} %) lie within "
            f"{tolerance:g} of the estimation trajectory at some time (state: {states}, each coordinate in "
            f"estimation-run standard deviations, the distance an RMS over them). {_REPEAT_TAIL}", REPEAT_ACTION)


def repeat_by_distance(distance: float, threshold: float, measure: str) -> Words:
    dist, dist_th = versus(distance, threshold)
    return (f"The validation run repeats the estimation run: relative {measure} distance {dist} < {dist_th} "
            f"(time-aligned; give q or the regressor of both runs to compare states at any time). {_REPEAT_TAIL}",
            REPEAT_ACTION)


_WHERE_STRUCTURAL = {"estimation": "in both runs",
                     "model": "in this run and at every state of the model's structure it was prepared with"}


def structural_columns(cols: Sequence[str] | None, structural: Sequence[int], p: int | None,
                       rank: int | None, source: str = "estimation") -> Words:
    """``source``: what told them structural: the estimation run's regressor, or the model's
    structure a prepared regressor carries."""
    return (f"{len(structural)} of the regressor's {p} columns are zero or exact combinations of the others "
            f"{_WHERE_STRUCTURAL[source]} ({listed_columns(cols, structural)}): no trajectory of this structure "
            "excites them apart, so they "
            f"were reduced to {rank} identifiable combinations (the base parameters), on which the excitation "
            "checks ran.", "none: no trajectory of this structure can excite them apart")


def unexcited_columns(cols: Sequence[str] | None, zero: Sequence[int], dependent: Sequence[int],
                      source: str | None) -> Words:
    """``source``: what tells the structural columns: "estimation" (the estimation run's
    regressor), "model" (the model's structure a prepared regressor carries), or None (unknown)."""
    parts = []
    if zero:
        parts.append(f"never excites {listed_columns(cols, zero)}")
    if dependent:
        parts.append(f"cannot separate {listed_columns(cols, dependent)} from the other columns (in this run they "
                     "are combinations of them)")
    if source == "estimation":
        tail = ": the estimation run excites them apart, so the validation cannot test these terms."
    elif source == "model":
        tail = (": the model's structure excites them apart (they are not structural), so this trajectory "
                "cannot test these terms.")
    else:
        tail = (": the validation cannot test these terms. Without the estimation run's regressor "
                "(estimation={'regressor': ...}) it is not known whether they are structural (zero or "
                "combinations of other columns for every trajectory of this structure, as some parameters "
                "of a fixed-base arm's first links are) or a flaw of this trajectory; reduce the regressor to "
                "its base columns, give the estimation run's regressor, or prepare the regressor with the "
                "model's structure (URDFModel.prepared_regressor).")
    return ("The validation regressor " + " and ".join(parts) + tail,
            "add motion that excites these columns to the validation trajectory")


def ill_conditioned(condition: float, threshold: float, reduced: bool, rank: int | None) -> Words:
    """``reduced``: structural columns were reduced, and the number was computed over the validation
    run's ``rank`` identifiable combinations."""
    cond, cond_th = versus(condition, threshold)
    over = f" over its {rank} identifiable combinations" if reduced else ""
    return (f"The validation regressor is ill-conditioned (column-scaled condition number{over} {cond} > {cond_th}): "
            "it cannot separate the effects of the parameters.", "use a richer validation trajectory")


def joint_motion(name: str, ratio: float, threshold: float) -> Words:
    return (f"{name} moves {versus(ratio, threshold, '.1f', scale=100.0)[0]} % of its estimation-run motion: the "
            "validation cannot test the terms of this joint.",
            f"move {name} in the validation run as much as in the estimation run")


def column_motion(weak: Sequence[tuple[str, float]], threshold: float) -> Words:
    """``weak``: (column, its RMS relative to the estimation run)."""
    listed = ", ".join(f"{c} ({versus(ratio, threshold, '.1f', scale=100.0)[0]} %)" for c, ratio in weak)
    return (f"The validation run excites {listed} far less than the estimation run did: it cannot test these terms.",
            "excite these columns in the validation run as much as in the estimation run")


def low_information(joints: Sequence[tuple[str, float, float, Sequence[tuple[str, float]] | None]],
                    threshold: float) -> Words:
    """``joints``: (name, N_eff, smallest detectable share, the terms found there that remove less, or None)."""
    each = []
    threshold_pct = ""
    for name, n_eff, share, unresolved in joints:
        pct, threshold_pct_j = versus(share, threshold, ".0f", scale=100.0)
        threshold_pct = threshold_pct or threshold_pct_j
        tail = "" if unresolved is None else _unresolved(unresolved)
        each.append(f"{name}: N_eff = {n_eff:.0f}, {pct} %" + tail)
    return (f"This run cannot decide: its noise leaves so few effective samples that a missing term must remove more "
            f"than {threshold_pct} % of the mean square to be found ({'; '.join(each)}).",
            "validate on a longer or faster-varying run (more effective samples)")


def _unresolved(terms: Sequence[tuple[str, float]]) -> str:
    named = " and ".join(f"{name} {100 * share:.0f} %" for name, share in terms)
    return (f" — found deficient, but what is named there removes less: {named}, so which term is missing this run "
            "cannot tell")
