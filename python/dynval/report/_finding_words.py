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

from ._text import number_text, p_clause, versus

Words = tuple[str, str]
"""``(message, action)`` of one finding."""

UNITS = {
    "missing_term": "share of the residual's mean square the term would remove",
    "correlation": "|ρ|",
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

# -- the fit ------------------------------------------------------------------------------------

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


PARTIAL_FORMS = {"coulomb": "the friction shape it lacks (a smooth sign or a Stribeck term)",
            "gravity": "the posture terms it lacks (a centre-of-mass component)",
            "position_harmonic": "the position harmonics it lacks",
            "inertia": "the acceleration terms it lacks"}


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


def coupling_terms(group: str, name: str) -> str:
    if group == "gravity":
        return f"the posture terms sin/cos(q_i + … + q_k) of the link-angle chains through {name}"
    if group == "inertia":
        return "the other joints' accelerations q̈_k (the mass matrix's off-diagonal terms)"
    return "the other joints' terms"


def percent(share: float) -> str:
    """A share in per cent with the digits a reader needs: ``98 %``, ``4.2 %``, ``0.56 %``."""
    x = 100.0 * share
    return f"{x:.0f} %" if abs(x) >= 10 else f"{x:.2g} %"
