"""``regressor_correlation``: the residual against the regressor's columns (conventions §5.2). Two
rules, run in this order at the kind's place: a column the model lacks (with ``estimation=`` the
refit on the estimation run with every absent column, else the added-variable correlation on the
validation run), then the residual's lag correlation with each column beyond what the colour of
both series explains, on the joints no missing column already explains."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .._finding_words import NEGLIGIBLE, Words, lag_text, p_text, simulator_words
from .._text import versus
from ._base import Context, Evidence, Finding, Kind, effect_versus_threshold, worded
from ._evidence import simulator_values

UNITS = {
    "missing_term": "share of the residual's mean square the term would remove",
    "correlation": "|ρ|",
}
"""``Finding.effect_unit`` of each of the two rules."""


def missing_term_words(name: str, terms: Sequence[tuple[str, float, float] | tuple[str, float, float, float]],
                       refit: bool, padj: float, big: bool, indirect: Sequence[tuple[str, float]] = ()) -> Words:
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


def correlation_words(name: str, hits: Sequence[tuple[str, str, float]], threshold: float, best: float,
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


def column_in_model(ev: Evidence, c: int) -> bool | None:
    """A regressor column is the model's unless it is one of the columns tested as missing."""
    if ev.missing_columns is None:
        return True if ev.model_kinds is not None else None
    return int(c) not in {int(x) for x in ev.missing_columns}


def alone_share(ev: Evidence, j: int, k: int) -> float:
    """The share of joint j's validation mean square absent column k removes added alone (nan unknown)."""
    if ev.missing_alone is None:
        return math.nan
    x = float(np.asarray(ev.missing_alone)[j, k])
    return x if math.isfinite(x) else math.nan


def strongest_lag(rho: np.ndarray, sig: np.ndarray) -> int:
    """The smallest significant lag that sees nearly the strongest correlation: lags within the
    motion's time scale see one phenomenon, and the earliest is the one to name."""
    size = np.abs(rho[sig])
    return int(sig[np.flatnonzero(size >= 0.9 * size.max())[0]])


def missing_term_rule(r: Context) -> list[Finding]:
    """A column the model lacks: the residual against the part of it the model cannot represent."""
    ev, th = r.ev, r.th
    if "missing" not in r.fam:
        return []
    p, padj = r.fam["missing"]
    stat = np.asarray(ev.missing_statistic, dtype=float)
    share = np.asarray(ev.missing_share, dtype=float)
    per_column = p.ndim == 1  # the estimation refit: one test per column, its effect per joint
    refit = ev.missing_method == "estimation_refit"
    missing = [] if ev.missing_columns is None else ev.missing_columns

    def at(a: np.ndarray, j: int, k: int) -> float:
        return float(a[k] if a.ndim == 1 else a[j, k])

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
        terms = [(r.column(missing[kk]), float(at(stat, j, kk)), float(share[j, kk]), alone_share(ev, j, kk))
                 for kk in chosen]
        # what the column moves on the joints it does not enter: its own effect when known (the
        # leave-one-out share there can be taken by another absent column of the joint refit)
        moved = {jj: (alone_share(ev, jj, k) if ev.missing_alone is not None else float(share[jj, k]))
                 for jj in range(share.shape[0]) if not enters[jj, k]}
        indirect = {jj: s for jj, s in moved.items() if s >= th.missing_term}
        details: dict[str, object] = {"lag": 0, "t" if refit else "ρ": float(at(stat, j, k)), "added_variable": True,
                                      "method": ev.missing_method, "indirect": indirect}
        if ev.missing_alone is not None:
            details["alone_share"] = alone_share(ev, j, k)
        out.append(worded(
            missing_term_words(r.name(j), terms, refit, float(at(padj, j, k)), big,
                               [(r.name(jj), s) for jj, s in indirect.items()]),
            kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
            columns=tuple(int(missing[kk]) for kk in chosen), statistic=float(at(stat, j, k)),
            pvalue=float(at(p, j, k)), pvalue_adjusted=float(at(padj, j, k)), effect=float(size[j, k]),
            effect_unit=UNITS["missing_term"], threshold=th.missing_term, details=details))
    return out


def correlation_rule(r: Context) -> list[Finding]:
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
                lag = strongest_lag(rho[j, c], sig)
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
        listed = [(r.column(cc), lag_text(ll, ev.sample_rate), float(rho[j, cc, ll])) for _, cc, ll in chosen]
        out.append(worded(
            correlation_words(r.name(j), listed, th.regressor_correlation, float(best), float(padj[j, c, lag]), big,
                              column_in_model(ev, c), simulator_values(ev, j, c) if lag == 0 else None),
            kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
            columns=tuple(int(cc) for _, cc, _ in chosen), statistic=float(z[j, c, lag]),
            pvalue=float(p[j, c, lag]), pvalue_adjusted=float(padj[j, c, lag]), effect=float(best),
            effect_unit=UNITS["correlation"], threshold=th.regressor_correlation,
            details={"lag": lag, "rho": float(rho[j, c, lag]), "n_significant_columns": len(hits),
                     "in_model": column_in_model(ev, c)}))
    return out


def rule(r: Context) -> list[Finding]:
    """The missing columns, then the correlations (which skip the joints a missing column explains)."""
    return missing_term_rule(r) + correlation_rule(r)


def column_relation(f: Finding) -> str:
    """What a correlated column is to the model, from the finding's record (``details["in_model"]``:
    the model has it, lacks it, or its columns are unknown), never from its words."""
    in_model = (f.details or {}).get("in_model")
    if in_model is True:
        return "a mis-weighted term (the model has it)"
    if in_model is False:
        return "a missing term"
    return "a missing or mis-weighted term"


def reason(f: Finding, column: Callable[[int], str]) -> str:
    """Its line in ``compare``'s reasons: the missing column and its share, or the correlation and
    what the column is to the model."""
    cols = [column(c) for c in f.columns]
    if "share" in f.effect_unit:
        e, t = effect_versus_threshold(f, percent=True)
        return (f"missing term {cols[0] if cols else '(unnamed)'} (would remove {e} of the residual's "
                f"mean square ≥ {t})" + (f"; {', '.join(cols[1:])} also significant" if len(cols) > 1 else ""))
    e, t = effect_versus_threshold(f, ".2f")
    return (f"residual correlates with {', '.join(cols) or 'a regressor column'} (|ρ| up to "
            f"{e} ≥ {t}): " + column_relation(f))


KIND = Kind(name="regressor_correlation",
            description="the residual correlates with a regressor column beyond what both series' colour explains",
            order=300, rule=rule, reason=reason)
