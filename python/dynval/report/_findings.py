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
from dataclasses import fields, replace
from typing import Any

import numpy as np

from ..statistics._stats import correlation_pvalue, holm
from . import _finding_words as w
from .kinds import KINDS as _DECLARED_KINDS
from .kinds._base import Context, Evidence, Finding, Thresholds, declared_thresholds, worded
from .kinds._evidence import simulator_values as _simulator_values

__all__ = ["Finding", "Thresholds", "Evidence", "SEVERITIES", "KINDS", "compute_findings",
           "resolve_thresholds"]

SEVERITIES = ("deficiency", "design", "note")
"""``deficiency``: the model should change; ``design``: the experiment should change;
``note``: information, including significant but negligible effects."""

_LISTED = {
    "regressor_correlation": "the residual correlates with a regressor column beyond what both series' colour explains",
}
"""The kinds whose rules are still in this module (the others are declared in ``report/kinds/``)."""


def resolve_thresholds(value: object) -> Thresholds:
    """``None`` → defaults; a mapping overrides named fields; a :class:`Thresholds` as is."""
    from ..checks._validation import format_value, parameter_error

    if value is None:
        return Thresholds()
    if isinstance(value, Thresholds):
        return value
    if isinstance(value, dict):
        own = {f.name for f in fields(Thresholds)} - {"declared"}
        declared = declared_thresholds()
        for key, x in value.items():
            if key not in own and key not in declared:
                raise parameter_error("thresholds", "a mapping with keys among "
                                      + ", ".join(repr(n) for n in sorted(own | set(declared))), value)
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or x < 0:
                raise parameter_error(f"thresholds[{format_value(key)}]", "a finite number >= 0", x)
        given = tuple((k, float(x)) for k, x in value.items() if k in declared)
        return replace(Thresholds(), **{k: float(x) for k, x in value.items() if k in own}, declared=given)
    raise parameter_error("thresholds", "None, a mapping or a Thresholds", value)


def _column_in_model(ev: Evidence, c: int) -> bool | None:
    """A regressor column is the model's unless it is one of the columns tested as missing."""
    if ev.missing_columns is None:
        return True if ev.model_kinds is not None else None
    return int(c) not in {int(x) for x in ev.missing_columns}


def _tests(ev: Evidence) -> list[tuple[str, np.ndarray]]:
    """Every p-value of the report as (family, index, p) blocks for one Holm correction."""
    blocks: list[tuple[str, np.ndarray]] = []
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
    r = Context(ev, thresholds or Thresholds(), 1.0 - ev.level, holm_family(ev) if family is None else family)
    out = r.found
    for rule in _ALL_RULES:
        out.extend(rule(r))
    order = {s: i for i, s in enumerate(SEVERITIES)}
    out.sort(key=lambda f: order[f.severity])
    return out


def _worded(words: w.Words, **record: Any) -> Finding:
    """A finding with its message and action."""
    return worded(words, **record)

def _missing_term_rule(r: Context) -> list[Finding]:
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
        terms = [(r.column(missing[kk]), float(at(stat, j, kk)), float(share[j, kk]),
                  _alone(ev, j, kk)) for kk in chosen]
        # what the column moves on the joints it does not enter: its own effect when known (the
        # leave-one-out share there can be taken by another absent column of the joint refit)
        moved = {jj: (_alone(ev, jj, k) if ev.missing_alone is not None else float(share[jj, k]))
                 for jj in range(share.shape[0]) if not enters[jj, k]}
        indirect = {jj: s for jj, s in moved.items() if s >= th.missing_term}
        details: dict[str, Any] = {"lag": 0, "t" if refit else "ρ": float(at(stat, j, k)), "added_variable": True,
                   "method": ev.missing_method, "indirect": indirect}
        if ev.missing_alone is not None:
            details["alone_share"] = _alone(ev, j, k)
        out.append(_worded(
            w.missing_term(r.name(j), terms, refit, float(at(padj, j, k)), big,
                           [(r.name(jj), s) for jj, s in indirect.items()]),
            kind="regressor_correlation", severity="deficiency" if big else "note", joints=(j,),
            columns=tuple(int(missing[kk]) for kk in chosen), statistic=float(at(stat, j, k)),
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


def _regressor_correlation_rule(r: Context) -> list[Finding]:
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


def _extra_notes_rule(r: Context) -> list[Finding]:
    """The findings the caller hands in with the evidence (``Evidence.extra_notes``), after the rules'."""
    return list(r.ev.extra_notes)


_RULES = ((300, _missing_term_rule), (400, _regressor_correlation_rule),
          (830, _extra_notes_rule))
"""The rules still in this module, each with its place; the kinds of ``report/kinds/`` take their places
among these (``Kind.order``): the data notes (10–40), the fit (100–120), bias (200), missing columns
(300, here), correlations (400, here), the spectrum (500), the motion (600–630), whiteness
(700), the repeat (800), the validation design (810, 820) and the notes handed in (830, here)."""

ORDER = {"regressor_correlation": 300}
"""The place of each kind of this module's rules (the first of its two: the missing columns, 300, then the
correlations, 400)."""

_ALL_RULES = tuple(rule for _, rule in sorted(
    [*_RULES, *((k.order, k.rule) for k in _DECLARED_KINDS.values() if k.rule is not None)], key=lambda t: t[0]))
"""Every rule, in the order they run."""

KINDS = {name: description for name, description, _ in sorted(
    [*((n, d, ORDER[n]) for n, d in _LISTED.items()),
     *((k.name, k.description, k.order) for k in _DECLARED_KINDS.values())], key=lambda t: t[2])}
"""The documented vocabulary of ``Finding.kind``, in the order of the rules."""
