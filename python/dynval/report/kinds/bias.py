"""``bias``: a residual mean that is significant (coloured-noise t-test) and large relative to the
RMSE (conventions §5.2), with the missing column or physical term it comes from when one is found."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from .._finding_words import PARTIAL_FORMS, Words, bias_action, coupling_terms, p_text
from .._text import versus
from ._base import Context, Evidence, Finding, Kind, Thresholds, effect_versus_threshold, worded
from ._evidence import delay_explains, term_effect
from ._views import physics_joint

UNIT = "|mean| / RMSE"


def words(name: str, mean: float, effect: float, threshold: float, n_eff: float, n: int, padj: float, big: bool,
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
        action = (f"add the coupling (cross-joint) terms of {label} on {name}: {coupling_terms(group, name)}"
                  if relation == "coupling" else
                  f"complete {label} on {name}: add {PARTIAL_FORMS.get(group, 'the form it lacks')}"
                  if relation == "partial" else f"add {label} on {name}: the bias is its mean on this trajectory")
    else:
        action = bias_action(name, kinds)
    return head + ": a systematic bias, e.g. a missing offset, friction or gravity term" + tail, action


def culprit(ev: Evidence, j: int, th: Thresholds) -> tuple[int, float] | None:
    """The column outside the model whose absence best explains joint j's bias, if any.

    A term the model lacks shows as an offset on a new trajectory: the column must account for the
    joint's mean (``missing_explains_bias``) and remove at least the missing-term share of its mean
    square. Descriptive: the bias itself is the tested quantity.
    """
    if ev.missing_share is None or ev.missing_explains_bias is None or ev.missing_columns is None:
        return None
    share = np.asarray(ev.missing_share[j], dtype=float)
    agree = np.asarray(ev.missing_explains_bias[j], dtype=bool)
    with np.errstate(invalid="ignore"):
        ok = np.flatnonzero(agree & (share >= th.missing_term))
    if ok.size == 0:
        return None
    k = int(ok[np.argmax(share[ok])])
    return int(ev.missing_columns[k]), float(share[k])


def model_kinds(ev: Evidence, j: int) -> dict[str, bool | None] | None:
    """Which of an offset, a friction and a gravity term the model's columns span on joint j (None
    for a kind the evidence cannot tell, e.g. friction without q); None when the columns are unknown."""
    if ev.model_kinds is None or j >= len(ev.model_kinds):
        return None
    k = ev.model_kinds[j]
    friction = [k[g] for g in ("coulomb", "viscous") if g in k]
    return {"offset": k.get("offset"), "friction": (any(friction) if friction else None),
            "gravity": k.get("gravity")}


def physical_term(r: Context, j: int) -> tuple[str, str, str] | None:
    """The physical term the library finds on joint j, when the model lacks it (missing, its
    coupling, or a part of it) and it is a practical deficiency there: (group, label, relation). A
    term the model lacks shows on a new trajectory as an offset too, and is what to change."""
    from ...statistics._physics import LABELS

    ev = r.ev
    if ev.physics is None or "physics" not in r.fam or delay_explains(ev, j):
        return None
    t = physics_joint(ev, j)
    rel = t.relation_name
    if t.term is None or rel not in ("missing", "coupling", "partial") or not r.fam["physics"][1][j] <= r.alpha:
        return None
    if not (t.share >= r.th.missing_physics and term_effect(t) >= r.th.missing_physics):
        return None
    return t.term, LABELS[t.term], rel


def rule(r: Context) -> list[Finding]:
    """A residual mean beyond its coloured-noise standard error, and the missing term it comes from."""
    ev, th = r.ev, r.th
    if "bias" not in r.fam or ev.bias_statistic is None or ev.n_eff is None:
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
        found = culprit(ev, j, th)
        named = None if found is None else (r.column(found[0]), found[1])
        term = None if found is not None else physical_term(r, j)
        out.append(worded(
            words(r.name(j), float(mean[j]), float(effect[j]), th.bias, float(ev.n_eff[j]), ev.n_samples,
                  float(padj[j]), big, named, model_kinds(ev, j), term),
            kind="bias", severity="deficiency" if big else "note", joints=(j,),
            columns=() if found is None else (found[0],),
            statistic=float(ev.bias_statistic[j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(effect[j]), effect_unit=UNIT, threshold=th.bias,
            details={"mean": float(mean[j]), "n_eff": float(ev.n_eff[j]),
                     **({} if term is None else {"term": term[0], "relation": term[2]})}))
    return out


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f, percent=True)
    return (f"residual bias (|mean| = {e} of the RMSE ≥ {t})"
            + (f", which the missing term {column(f.columns[0])} accounts for" if f.columns else ""))


KIND = Kind(name="bias",
            description="a residual mean that is significant (coloured-noise t-test) and large relative to the RMSE",
            order=200, rule=rule, reason=reason, percent=True)
