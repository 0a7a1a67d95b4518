"""The deciding findings ranked by effect: what to do first is the strongest evidence, not the
first rule that ran (docs/conventions.md §5.10, contract §4).

Every deficiency is put on one scale, the **share of the joint's residual mean square it
explains** (``explained_share``), taken on held-out data where the finding has such a share (a
term refitted on the estimation run and carried to the validation run) and on the validation run
otherwise. A finding that names no cause (worse than a constant, a bias no missing column
accounts for, an error every period shares, a predictive failure) ranks after the findings that
do on its joint; on a joint whose residual carries the prediction's own line
(``prediction_artefact``) the other findings follow that one, since they may read the line;
whiteness only follows from another deficiency on its joint and comes last; a finding without a
share on this scale keeps its rule order after those with one. The count of findings is not a
measure: a weak model has few large findings, a good one many small ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ._findings import Finding
from ._text import number_text

__all__ = ["Ranked", "explained_share", "rank", "deciding", "first_reason", "share_text", "torque_text"]

HELD_OUT = "held_out"
VALIDATION = "validation"


@dataclass(frozen=True)
class Ranked:
    """A deciding finding with its place on the common scale.

    ``share``: the share of ``joint``'s residual mean square the finding explains (None when the
    kind has no such share); ``basis``: ``"held_out"`` (carried from the estimation run to the
    validation run) or ``"validation"`` (measured or fitted on the validation run)."""

    finding: Finding
    share: float | None
    basis: str
    joint: int | None
    leads: bool = True  # names a cause, or stands on a joint where nothing does
    torque_share: float | None = None  # share × (1 − R²) of the joint: of its measured torque's variance
    indirect_torque: float = 0.0  # a missing column's: what adding it removes on the joints it does not enter

    def to_dict(self, joint_names: Sequence[str] | None = None) -> dict[str, Any]:
        f = self.finding
        return {"kind": f.kind, "severity": f.severity, "joints": list(f.joints), "columns": list(f.columns),
                "joint": self.joint, "joint_name": _name(joint_names, self.joint), "share": self.share,
                "share_basis": self.basis if self.share is not None else None, "torque_share": self.torque_share,
                "leads": self.leads,
                "action": f.action}


def _name(names: Sequence[str] | None, j: int | None) -> str | None:
    if j is None:
        return None
    return str(names[j]) if names and 0 <= j < len(names) else f"joint {j + 1}"


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _joint(f: Finding) -> int | None:
    return int(f.joints[0]) if f.joints else None


def explained_share(f: Finding, r2: Sequence[float] | None = None) -> tuple[float | None, str, int | None]:
    """The share of a joint's residual mean square that finding ``f`` explains, its basis and the joint.

    Per kind (conventions §5.10): ``worse_than_constant`` −R²/(1 − R²) (what predicting the mean torque
    would remove); ``bias`` (|ē|/RMSE)² (what removing the mean would); a missing column refitted in
    its share (held out with the estimation refit); a correlation ρ² (what the column explains
    linearly; a refitted column the larger of its leave-one-out share and its share added alone,
    ``details["alone_share"]``); ``oscillation``, ``prediction_artefact`` and ``periodic_error`` their share of the
    residual variance; ``missing_physics`` the named term's share (``details["held_out_share"]``,
    carried from the estimation run, when the rule gives one); ``delay`` the share realigning
    removes on its strongest joint (with ``r2``, per joint, the joint where that share is the most of
    the measured torque's variance: one shift realigns every joint, and its effect is judged where it
    is largest, as any other finding's); ``predictive_failure`` 1 − 1/ratio (the part of the validation
    mean square beyond what the estimation run allows: held out by construction); a
    ``physical_consistency`` finding whose effect is a share of the residual, that share. Others None.
    """
    share, basis, j = _raw_share(f, r2)
    return (None if share is None else min(max(share, 0.0), 1.0)), basis, j


def _raw_share(f: Finding, r2: Sequence[float] | None = None) -> tuple[float | None, str, int | None]:
    d = f.details or {}
    j = _joint(f)
    held = _finite(d.get("held_out_share"))
    if held is not None:
        return max(held, 0.0), HELD_OUT, j
    effect = _finite(f.effect)
    unit = f.effect_unit or ""
    if f.kind == "worse_than_constant":
        fit = _finite(f.statistic)
        return (None if fit is None else -fit / (1.0 - fit)), VALIDATION, j
    if f.kind == "bias":
        return (None if effect is None else effect * effect), VALIDATION, j
    if f.kind == "regressor_correlation":
        if effect is None:
            return None, VALIDATION, j
        if d.get("added_variable"):
            # the larger of what it removes beside the other absent columns and added alone: another
            # absent column can stand in for it in the joint refit, which does not make it weaker
            alone = _finite(d.get("alone_share"))
            return (effect if alone is None else max(effect, alone),
                    HELD_OUT if d.get("method") == "estimation_refit" else VALIDATION, j)
        return effect * effect, VALIDATION, j
    if f.kind in ("oscillation", "prediction_artefact", "periodic_error"):
        return effect, VALIDATION, j
    if f.kind == "missing_physics":
        local = _local(f)
        if local is not None:
            # the term added on its joint alone, refitted on the estimation run, carried to validation
            return _finite(local.get("share")), HELD_OUT, j
        carried = d.get("refit_run") == "estimation"  # refitted there with the model, carried here
        return _finite(d.get("term_share", f.effect)), HELD_OUT if carried else VALIDATION, j
    if f.kind == "delay":
        shares = [_finite(x) for x in d.get("share") or ()]
        own = [(s, jj) for jj, s in enumerate(shares) if s is not None and jj in f.joints]
        if not own:
            return None, VALIDATION, j
        s, jj = max(own, key=lambda sj: (_torque_share(sj[0], sj[1], r2) or 0.0, sj[0]))
        return s, VALIDATION, jj
    if f.kind == "predictive_failure":
        return (None if effect is None or effect <= 0 else max(1.0 - 1.0 / effect, 0.0)), HELD_OUT, j
    if f.kind == "physical_consistency" and "share" in unit:
        return effect, HELD_OUT, j
    return None, VALIDATION, j


def _local(f: Finding) -> dict[str, Any] | None:
    """A joint-local term's stacked refit (``model_terms.local``, relation ``local``), else None."""
    d = f.details or {}
    if f.kind != "missing_physics" or d.get("relation") != "local":
        return None
    local = (d.get("model_terms") or {}).get("local")
    return local if isinstance(local, dict) else None


def _added_alone(f: Finding) -> dict[str, Any] | None:
    """The stacked refit with a physical term's own columns added on its joint alone: a joint-local
    term's (``model_terms.local``), or a term the model lacks (``model_terms.added_alone``)."""
    local = _local(f)
    if local is not None or f.kind != "missing_physics":
        return local
    alone = ((f.details or {}).get("model_terms") or {}).get("added_alone")
    return alone if isinstance(alone, dict) else None


def _carried(f: Finding) -> dict[int, float]:
    """What adding the structure a finding names removes on the joints it does not act on, per joint:
    a missing column's ``details["indirect"]``, a physical term's refit with its own columns added on
    its joint alone, on the other joints."""
    local = _added_alone(f)
    if local is not None:
        shares = {k: _finite(s) for k, s in enumerate(local.get("shares") or ()) if k not in f.joints}
    else:
        shares = {int(k): _finite(s) for k, s in ((f.details or {}).get("indirect") or {}).items()}
    return {k: s for k, s in shares.items() if s is not None}


_TRACE = 0.5
"""A lag correlation of the residual with a model column that a structure the model lacks on the same
joint leaves its trace on follows that structure while the structure removes at least this fraction
of what the correlation explains, both as shares of the joint's residual (a trace is a part of the
structure, never larger than it); the columns of the structure's own kind that the model holds in
part, which the fit bends, follow whatever its size."""


_FOLLOWS = 0.5
"""A joint whose residual mean square a lacking structure elsewhere removes at least this share of
(its refit carried to the validation run) has that structure as its cause: its own findings follow."""


_UMBRELLA = ("worse_than_constant", "periodic_error", "predictive_failure")
"""Kinds that say a joint's error has structure without naming what makes it: on a joint where
another finding names a term, a shift or a line, that finding is the step to take."""


def _names_cause(f: Finding) -> bool:
    """The finding's action names what to change (a term, a column, a shift, a line)."""
    if f.kind == "bias":
        return bool(f.columns)
    return f.kind not in _UMBRELLA and f.kind != "whiteness"


def _missing_column(f: Finding) -> int | None:
    """The column a finding names as missing (a refit or added variable, or the bias it accounts
    for); None for any other finding."""
    added = f.kind == "regressor_correlation" and bool((f.details or {}).get("added_variable"))
    if f.columns and (f.kind == "bias" or added):
        return int(f.columns[0])
    return None


def _torque_share(share: float | None, joint: int | None, r2: Sequence[float] | None) -> float | None:
    """The share of joint ``joint``'s measured-torque variance the finding explains: its share of
    the residual times the residual's share of the torque, 1 − R² (None without R²)."""
    if share is None or joint is None or r2 is None or not 0 <= joint < len(r2):
        return None
    rest = 1.0 - float(r2[joint])
    return share * rest if math.isfinite(rest) and rest > 0 else None


_LACKS = ("missing", "partial", "coupling", "local")
"""Relations of a physical term to the model's columns (:mod:`dynval.statistics._model_terms`)
in which the model lacks a structure."""


def _trace_columns(terms: dict[str, Any]) -> list[int]:
    """The model's columns a lacking structure leaves its trace on: those most aligned with each
    group selected with the named one (``trace_columns``), or with the named one (``columns``)."""
    return [int(c) for c in terms.get("trace_columns", terms.get("columns", ())) or ()]


def _own_column_trace(f: Finding) -> bool:
    """A lag correlation of the residual with one of the model's own columns."""
    d = f.details or {}
    return f.kind == "regressor_correlation" and not d.get("added_variable") and d.get("in_model") is True


_RIGID_BODY = ("inertia", "gravity")
"""The kinds of a rigid-body model, whose parameters the joints share."""

_REWEIGHT = ("reweight", "unsupported")
"""Relations in which what remains on a joint is carried by the model's own columns with other weights."""


_SPANNED = 0.1
"""A term whose part outside the model's span removes at most this fraction of what re-weighting the
model's own columns removes is, on this run, a re-weighting (a slowly moving elbow's gravity column
is nearly constant: an offset the names say the model lacks is, in the data, that column's weight)."""


def _reweights(f: Finding) -> bool:
    """The finding's step is to re-weight the model's own columns on its joint, or its term is
    spanned by them on this run (:data:`_SPANNED`)."""
    if _own_column_trace(f):
        return True
    if f.kind != "missing_physics":
        return False
    d = f.details or {}
    if d.get("relation") == "local":
        return False
    terms = d.get("model_terms") or {}
    outside, reweight = _finite(terms.get("outside_share")), _finite(terms.get("reweight_share"))
    spanned = outside is not None and reweight is not None and reweight > 0 and outside <= _SPANNED * reweight
    return d.get("relation") in _REWEIGHT or spanned


def _lacks(f: Finding) -> bool:
    """The finding names a structure the model lacks (a missing column, or a physical term outside
    its span that the model's own columns do not make up)."""
    d = f.details or {}
    return ((f.kind == "missing_physics" and d.get("relation") in _LACKS and not _reweights(f))
            or _missing_column(f) is not None)


def _lacks_rigid_body(f: Finding) -> bool:
    """The finding names a rigid-body kind (inertia, gravity) of which the model holds nothing on its
    joint, neither an own column nor a coupling one (relation ``"missing"``)."""
    d = f.details or {}
    return f.kind == "missing_physics" and d.get("term") in _RIGID_BODY and d.get("relation") == "missing"


def _holds_rigid_body(f: Finding) -> bool:
    """A physical term of a rigid-body kind (inertia, gravity) that the model holds on the finding's joint."""
    d = f.details or {}
    terms = d.get("model_terms") or {}
    return f.kind == "missing_physics" and d.get("term") in _RIGID_BODY and terms.get("model_in_group") is True


def _bent_joints(findings: Sequence[Finding]) -> set[int]:
    """Joints whose error is the bend of parameters they share with a joint on which the model lacks a
    structure: least squares over every joint bends the shared parameters to make up for it (a planar
    arm without the shoulder's L1:mz fits the elbow's L2:mz wrong). Re-identifying the shared columns
    alone does not help; adding the missing structure and refitting does. Such a joint's own columns,
    re-weighted, would remove its error; or, where the structure lacking elsewhere is a rigid-body
    kind of which the model holds nothing on that joint (a gravity-only model's inertia), its error
    is a term of a rigid-body kind the model holds here (the posture terms a gravity-only fit bent to
    stand for the inertia it lacks), whatever its part outside the model's span (conventions §5.10)."""
    deficient = [f for f in findings if f.severity == "deficiency" and _lacks(f)]
    lacking = {j for f in deficient for j in f.joints}
    absent = {j for f in deficient if _lacks_rigid_body(f) for j in f.joints}
    bent: set[int] = set()
    for f in findings:
        d = f.details or {}
        shared = set(((d.get("model_terms") or {}).get("shared_with")) or ()) - set(f.joints)
        reweighted = f.kind == "missing_physics" and _reweights(f) and shared & lacking
        if reweighted or (_holds_rigid_body(f) and shared & absent):
            bent.update(f.joints)
    return bent


def rank(findings: Sequence[Finding], r2: Sequence[float] | None = None) -> list[Ranked]:
    """``findings`` ranked by effect, largest first, in three groups: the findings that lead (those
    that name a cause, and those that do not on a joint where nothing does), then the findings that
    do not name a cause on a joint where another does (its cause is the step to take), then
    whiteness (it only follows from the others). The effect is the share of the joint's residual
    the finding explains times 1 − R² of the joint (``r2``, per joint): the share of its measured
    torque's variance, which compares joints whose residuals differ in size (70 % of a large error
    before 90 % of a small one); the share alone without ``r2``. The findings of one missing column
    (on every joint its refit helps, and the biases it accounts for) rank by their summed effect.
    Within a group a finding without a share comes after those with one; ties keep the given (rule)
    order."""
    named = {j for f in findings if _names_cause(f) for j in f.joints}
    # a joint whose residual carries the prediction's own line: the other findings there may read
    # that line (a chattering sign(q̇) looks like a friction term the model lacks)
    artefact = {j for f in findings if f.kind == "prediction_artefact" for j in f.joints}
    # a structure the model lacks on a joint leaves its trace on the model's columns most aligned
    # with it (a decoupled model's sin q_j carries some of the missing coupling): the residual's
    # correlation with such a column is that trace, and re-identifying the column does not add it
    shares = [explained_share(f, r2) for f in findings]
    # the column is the model's on the correlation's joint and on the lacking structure's: on the same
    # joint it carries the structure's trace, on another the bend least squares gave the shared parameter.
    # On the same joint a trace is a part of the structure, no larger: a correlation that explains more
    # than twice what the structure removes is the column's own weight (both shares of that joint's
    # residual), but for the columns of the structure's own kind where the model holds part of it
    # (partial, coupling, local): the fit bends them to make up for the rest, and their correlation
    # follows whatever its size (a decoupled model's sin q_j beside the gravity coupling it lacks).
    lacking: dict[tuple[int, int], float] = {}
    for f, (share, _, _) in zip(findings, shares):
        d = f.details or {}
        if f.kind == "missing_physics" and d.get("relation") in _LACKS:
            terms = d.get("model_terms") or {}
            bent = {int(c) for c in terms.get("columns", ()) or ()} if d.get("relation") != "missing" else set()
            for joint, column in ((j, c) for j in f.joints for c in _trace_columns(terms)):
                size = math.inf if share is None or column in bent else share
                lacking[joint, column] = max(lacking.get((joint, column), 0.0), size)
    own_share = {id(f): share for f, (share, _, _) in zip(findings, shares)}

    def trace(f: Finding) -> bool:
        columns, mine = {int(c) for c in f.columns}, own_share[id(f)] or 0.0
        return any(c in columns and (j not in f.joints or size >= _TRACE * mine) for (j, c), size in lacking.items())

    bent = _bent_joints(findings)
    # joints whose error adding a lacking structure elsewhere removes (a missing rotor inertia's refit
    # takes most of the wrists' error: the fit had bent the link inertias they share)
    explained = {k for f in findings if f.severity == "deficiency" and _lacks(f)
                 for k, s in _carried(f).items() if s >= _FOLLOWS and k not in f.joints}

    def group(f: Finding) -> int:
        if f.kind == "whiteness":
            return 2
        if f.joints and set(f.joints) <= bent and (_reweights(f) or _holds_rigid_body(f)):
            return 1
        if f.joints and set(f.joints) <= explained and not _lacks(f):
            return 1
        if f.kind != "prediction_artefact" and f.joints and set(f.joints) <= artefact:
            return 1
        if _own_column_trace(f) and f.joints and trace(f):
            return 1
        if _names_cause(f) or not f.joints or not set(f.joints) <= named:
            return 0
        return 1

    ranked = [Ranked(f, share, basis, joint, leads=group(f) == 0, torque_share=_torque_share(share, joint, r2),
                     indirect_torque=_indirect(f, r2)) for f, (share, basis, joint) in zip(findings, shares)]
    with_r2 = r2 is not None and all(r.torque_share is not None for r in ranked if r.share is not None)

    def effect(r: Ranked) -> float | None:
        return r.torque_share if with_r2 else r.share

    # One missing column is one step however many joints it helps: its findings (the refit on each
    # joint, the bias it accounts for) rank by their sum, the strongest of them first.
    cause: dict[int, float] = {}
    for r in ranked:
        c = _missing_column(r.finding)
        e = effect(r)
        if c is not None and e is not None:
            cause[c] = cause.get(c, 0.0) + e + _indirect(r.finding, r2 if with_r2 else None)

    def key(item: tuple[int, Ranked]) -> tuple[int, int, float, float, int]:
        i, r = item
        g = group(r.finding)
        own = effect(r)
        if own is None:
            return (g, 1, 0.0, 0.0, i)
        c = _missing_column(r.finding)
        total = cause[c] if c is not None else own + (r.indirect_torque if _local(r.finding) else 0.0)
        return (g, 0, -total, -own, i)

    return [r for _, r in sorted(enumerate(ranked), key=key)]


def _indirect(f: Finding, r2: Sequence[float] | None) -> float:
    """What a missing column's refit removes on the joints it does not act on (``details["indirect"]``:
    joint → share of its residual), on the scale :func:`rank` compares (of the torque with ``r2``)."""
    total = 0.0
    for joint, share in _carried(f).items():
        scaled = share if r2 is None else _torque_share(share, int(joint), r2)
        total += scaled if scaled is not None else 0.0
    return total


def deciding(findings: Sequence[Finding], r2: Sequence[float] | None = None) -> list[Ranked]:
    """The deficiencies of a report, ranked (whiteness only when it is all there is); ``r2`` the
    report's per-joint R² (see :func:`rank`)."""
    deficient = [f for f in findings if f.severity == "deficiency"]
    primary = [f for f in deficient if f.kind != "whiteness"] or deficient
    return rank(primary, r2)


def share_text(share: float | None) -> str:
    """A share as a person reads it: ``62 %``, ``0.4 %``, ``n/a``."""
    if share is None:
        return "n/a"
    pct = 100.0 * share
    return f"{number_text(pct, '.2g' if pct < 10 else '.0f')} %"


def torque_text(x: float) -> str:
    """A share of the measured torque's variance: ``3.5 %`` of it, or ``6.5×`` it once the error
    exceeds the torque (a joint worse than a constant)."""
    return share_text(x) + " of" if x < 1.0 else f"{number_text(x, '.2g')}×"


def _indirect_text(r: Ranked, joint_names: Sequence[str] | None) -> str:
    """A missing column's effect on the joints it does not act on, or a physical term's added on its
    joint alone, which counts in its rank (a physical term's: where it removes a practical share, the
    largest first)."""
    indirect = (r.finding.details or {}).get("indirect") or {}
    if _added_alone(r.finding) is not None:
        practical = _finite(r.finding.threshold) or 0.0
        indirect = dict(sorted(((k, s) for k, s in _carried(r.finding).items() if s >= practical),
                               key=lambda kv: -kv[1])[:4])
    if not indirect:
        return ""
    where = ", ".join(f"{share_text(float(s))} on {_name(joint_names, int(j))}" for j, s in indirect.items())
    return (f" and, added alone, {where} (the parameters the fit bent there"
            + (f"; {torque_text(r.indirect_torque)} the torque's variance there" if r.indirect_torque > 0 else "")
            + ")")


def _basis_text(r: Ranked) -> str:
    return "carried from the estimation run" if r.basis == HELD_OUT else "on the validation run"


def first_reason(ranked: Sequence[Ranked], joint_names: Sequence[str] | None = None) -> str:
    """Why the first deciding finding is first: its share against the other leading findings'."""
    if not ranked:
        return ""
    top = ranked[0]
    leading = [r for r in ranked if r.leads]
    n, rest = len(leading), len(ranked) - len(leading)
    behind = (f"; {rest} more follow{'s' if rest == 1 else ''} on joints where a leading finding stands (structure "
              "without a named cause, a model column's correlation that a structure the model lacks explains, the "
              "error shared parameters carry for a structure another joint lacks, or findings that may read the "
              "prediction's own line)" if rest else "")
    if top.share is None:
        return (f"first in rule order: none of the {n} leading findings explains a share of the residual that can "
                "be compared" if n > 1 else "the only leading finding") + behind
    where = _name(joint_names, top.joint)
    text = (f"first because it explains {share_text(top.share)} of the residual's mean square"
            + (f" on {where}" if where else "") + f" ({_basis_text(top)}"
            + (f"; {torque_text(top.torque_share)} the measured torque's variance there" if top.torque_share
               is not None else "") + ")" + _indirect_text(top, joint_names))
    if n == 1:
        return text + ", the only deciding finding that names a cause" + behind if rest else \
            text + ", the only deciding finding"
    by_torque = top.torque_share is not None
    second = next(((r.torque_share if by_torque else r.share) for r in leading[1:]
                   if (r.torque_share if by_torque else r.share) is not None), None)
    return (text + f", the largest of {n} deciding findings" + (" that name a cause" if rest else "")
            + (" by the share of the torque they explain" if by_torque else "")
            + (f" (next: {torque_text(second).removesuffix(' of') if by_torque else share_text(second)})"
               if second is not None else "") + behind)
