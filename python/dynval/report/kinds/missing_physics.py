"""``missing_physics``: the residual follows the motion: a physical term the model lacks (friction,
gravity, inertia, offset, drift), named from q without its column (conventions §5.2), with what to do
relative to the model's columns (add, complete, re-identify)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from .._finding_words import NEGLIGIBLE, PARTIAL_FORMS, Words, coupling_terms, p_text, simulator_words
from .._text import source_text
from ._base import Context, Finding, Kind, effect_versus_threshold, worded
from ._evidence import delay_explains, simulator_values, term_effect
from ._views import physics_joints

UNIT = "share of the joint's mean square the physical terms remove"


def words(name: str, label: str, others: Sequence[str], together: float, term_share: float,
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
                f"add the coupling (cross-joint) terms of {label} on {name}: {coupling_terms(rel['group'], name)}")
    if kind == "local":
        return _local_words(head, name, label, rel, advice)
    if kind == "partial":
        return (head + f": the model has part of this term ({rel['own_in_span']} of its {rel['own_columns']} own "
                f"columns lie in the span of its columns); what lies outside removes {held}: another shape of it.",
                f"complete {label} on {name}: the model has part of it; add "
                + PARTIAL_FORMS.get(rel["group"], "the form it lacks"))
    return (head + f": a term the model lacks (outside the span of its columns on this joint; it removes {held}).",
            f"add {label} on {name} to the model")


LOCAL_FORMS = {"inertia": "a rotor inertia J_a·q̈ (a motor's reflected inertia)",
               "viscous": "a viscous friction F_v·q̇", "coulomb": "a Coulomb friction F_c·sign q̇",
               "velocity_squared": "a drag term q̇|q̇|", "offset": "a torque offset",
               "gravity": "a torque of its own angle, sin q and cos q (a spring, a counterbalance or a cable: the "
                          "links' gravity would also load the joints before it)",
               "position_harmonic": "position harmonics of its own angle (its motor's cogging)"}
"""What a group's own columns on one joint alone are, as a column of the model (relation ``local``)."""


def _local_words(head: str, name: str, label: str, rel: Mapping[str, Any], advice: Mapping[str, Any]) -> Words:
    """The model's columns span the term on this joint's rows only by moving parameters other joints
    share (``rel["local"]``: the stacked refit with the group's own columns on this joint alone)."""
    gain = rel["local"]
    names = advice.get("joint_names") or []
    form = LOCAL_FORMS.get(rel["group"], f"{label} of this joint's own motion")
    others = [f"{100 * s:.0f} % on {names[k]}" for k, s in sorted(enumerate(gain["shares"]), key=lambda kv: -kv[1])
              if k < len(names) and names[k] != name and s >= advice.get("practical", 0.0)][:3]
    shared = [names[k] for k in rel.get("shared_with") or () if k < len(names)]
    through = f" (shared with {', '.join(shared)})" if shared else ""
    return (head + f": the model's columns span it on {name}'s rows only by moving parameters other joints share"
            f"{through}, so re-identifying them cannot add it; {form} on {name} alone, refitted with the model on "
            f"the estimation run and carried to this run, removes {100 * gain['share']:.0f} % of {name}'s mean square"
            + (f" (and {', '.join(others)}, where the fit had bent the shared parameters)" if others else "") + ".",
            f"add {form} on {name} alone: the model's link terms carry it there only by bending parameters other "
            "joints share")


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
    if run == "absent":
        return (f"; the model holds {label} on no joint, and what its fit re-weights here makes up for it: the "
                f"term's own columns remove {pct} of held-out rows of this run (cross-fitted on alternate blocks)")
    if run == "stream":
        return (f"; {label} alone removes {pct} of this run's mean square (in sample: a stream keeps no rows to "
                "cross-fit on)" if pct else "")
    return (f"; {label}'s own effect on held-out rows of this run (cross-fitted on alternate blocks) is {pct}"
            if pct else "")


def _simulator_parameter(name: str, advice: Mapping[str, Any]) -> Words | None:
    """:func:`simulator_words` for the model column closest to the named term (``advice["simulator"]``:
    its value in the prediction and refitted on this run, when it is a simulator parameter's)."""
    names, values = advice.get("column_names") or [], advice.get("simulator")
    return simulator_words(name, names[0], *values) if names and values else None


def _coefficients(advice: Mapping[str, Any]) -> str:
    rel = advice["relation"]
    where = "estimated on the estimation run" if rel.get("estimated_from") == "estimation" else "in the prediction"
    names = advice.get("column_names") or [f"column {c + 1}" for c in rel.get("columns", [])]
    parts = [f"{c} {e:.4g} {where}, {r:.4g} refitted on this run"
             for c, e, r in zip(names, rel.get("estimated", []), rel.get("refitted", []))]
    return "; ".join(parts) if parts else "its coefficients differ"


def _derivative_words(physics: Mapping[str, Any]) -> str:
    return source_text(str(physics.get("derivative_source", "savgol")))


def rule(r: Context) -> list[Finding]:
    """The physical term named on each joint whose library test rejects, unless realigning explains the
    joint better (a delay): a deficiency when its share and its out-of-sample effect reach
    ``missing_physics``."""
    from ...statistics._physics import LABELS

    ev, th = r.ev, r.th
    if "physics" not in r.fam or ev.physics is None:
        return []
    p, padj = r.fam["physics"]
    out: list[Finding] = []
    joints = physics_joints(ev)
    for j, t in enumerate(joints):
        if not (padj[j] <= r.alpha) or delay_explains(ev, j):
            continue
        shares = t.shares
        term = t.term
        if term is None:
            continue
        effect = term_effect(t)
        big = bool(t.share >= th.missing_physics and effect >= th.missing_physics)
        if big:
            r.deficient.add(j)
        label = LABELS[term]
        others = [LABELS[g] for g, sh in sorted(shares.items(), key=lambda kv: -kv[1]) if g != term and sh >= 0.01]
        together = float(t.selected_share)
        rel = t.relation
        advice = {"refit_run": t.refit_run, "effect": effect, "relation": rel, "practical": th.missing_physics,
                  "joint_names": [r.name(k) for k in range(len(joints))],
                  "derivatives": _derivative_words(ev.physics),
                  "column_names": None if rel is None else [r.column(c) for c in rel.get("columns", [])],
                  "simulator": simulator_values(ev, j, rel["columns"][0]) if rel and rel.get("columns") else None}
        out.append(worded(
            words(r.name(j), label, others, together, float(t.term_share), float(t.share), float(padj[j]), big,
                  advice),
            kind="missing_physics", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(t.statistic), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(t.share), effect_unit=UNIT, threshold=th.missing_physics,
            details={"term": term, "label": label, "term_share": float(t.term_share),
                     "selected_share": together, "selected": list(t.selected), "shares": dict(shares),
                     "n_eff": float(t.n_eff), "method": ev.physics["method"],
                     "derivatives": ev.physics["derivatives"], "refit_run": t.refit_run,
                     "effect_out_of_sample": effect, "heldout_share": t.heldout_share,
                     "carried_share": t.carried_share,
                     "relation": t.relation_name,
                     "model_terms": None if rel is None else dict(rel),
                     "derivative_source": ev.physics.get("derivative_source")}))
    return out


RELATION = {
    "missing": "missing",
    "reweight": "mis-weighted or changed between runs (the model has it):",
    "coupling": "missing the cross-joint coupling of",
    "partial": "part of a term the model has, another shape of",
    "local": "missing on this joint alone (the model spans it only through parameters other joints share):",
}
"""The physics finding relative to the model's columns (``details["relation"]``) in ``compare``'s
reason; without it (the columns unknown) a structure of the kind remains."""


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f, percent=True)
    label = f.details.get("label") or f.details.get("term") or "a physical term"
    if f.details.get("relation") == "unsupported":
        return (f"mis-weighted terms, not {label} (adding it does not carry to held-out rows; the physical "
                f"terms would remove {e} of the mean square ≥ {t})")
    what = RELATION.get(str(f.details.get("relation")), "a structure of this kind remains:")
    return f"{what} {label} (the physical terms would remove {e} of the mean square ≥ {t})"


KIND = Kind(name="missing_physics",
            description="the residual follows the motion: a physical term the model lacks (friction, gravity, "
                        "inertia, offset, drift), named from q without its column",
            order=600, rule=rule, reason=reason, percent=True)
