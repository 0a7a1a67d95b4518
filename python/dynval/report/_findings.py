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
from .kinds import KINDS as _DECLARED_KINDS
from .kinds._base import Context, Evidence, Finding, Thresholds, declared_thresholds

__all__ = ["Finding", "Thresholds", "Evidence", "SEVERITIES", "KINDS", "compute_findings",
           "resolve_thresholds"]

SEVERITIES = ("deficiency", "design", "note")
"""``deficiency``: the model should change; ``design``: the experiment should change;
``note``: information, including significant but negligible effects."""

_LISTED: dict[str, str] = {}
"""The kinds whose rules are still in this module (none: every kind is declared in ``report/kinds/``)."""


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


def _extra_notes_rule(r: Context) -> list[Finding]:
    """The findings the caller hands in with the evidence (``Evidence.extra_notes``), after the rules'."""
    return list(r.ev.extra_notes)


_RULES = ((830, _extra_notes_rule),)
"""The rules still in this module, each with its place; the kinds of ``report/kinds/`` take their places
among these (``Kind.order``): the data notes (10–40), the fit (100–120), bias (200), missing columns
and correlations (300), the spectrum (500), the motion (600–630), whiteness
(700), the repeat (800), the validation design (810, 820) and the notes handed in (830, here)."""

ORDER: dict[str, int] = {}
"""The place of each kind of this module's rules (none left)."""

_ALL_RULES = tuple(rule for _, rule in sorted(
    [*_RULES, *((k.order, k.rule) for k in _DECLARED_KINDS.values() if k.rule is not None)], key=lambda t: t[0]))
"""Every rule, in the order they run."""

KINDS = {name: description for name, description, _ in sorted(
    [*((n, d, ORDER[n]) for n, d in _LISTED.items()),
     *((k.name, k.description, k.order) for k in _DECLARED_KINDS.values())], key=lambda t: t[2])}
"""The documented vocabulary of ``Finding.kind``, in the order of the rules."""
