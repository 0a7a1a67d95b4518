"""``excitation``: the validation regressor leaves columns unexcited or is ill-conditioned, or a joint
(a column) moves far less than in the estimation run: design findings (conventions §5.6); and a
note on the structural columns it was reduced by."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .._finding_words import Words, listed_columns
from .._text import versus
from ._base import Context, Evidence, Finding, Kind, Thresholds, effect_versus_threshold, worded

UNIT_STRUCTURAL = "structural columns"
UNIT_COLUMNS = "columns"
UNIT_CONDITION = "column-scaled condition number"
UNIT_JOINT_MOTION = "joint motion (RMS) relative to the estimation run"
UNIT_COLUMN_MOTION = "column RMS relative to the estimation run"


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


def _structural_source(x: dict[str, Any]) -> str | None:
    """What told the structural columns: the section's ``structural_source``; a section without the
    key (from before it) had them from the estimation run when it has them at all."""
    if x.get("structural") is None:
        return None
    return x.get("structural_source") or "estimation"


def regressor_findings(ev: Evidence, th: Thresholds) -> list[Finding]:
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
        out.append(worded(
            structural_columns(cols, structural, p, rank, _structural_source(x) or "estimation"),
            kind="excitation", severity="note", columns=tuple(structural), effect=float(len(structural)),
            effect_unit=UNIT_STRUCTURAL,
            details={"structural": structural, "identifiable_rank": rank,
                     "identifiable_columns": list(x.get("identifiable_columns") or [])}))
    zero = [int(c) for c in x["unexcited"]]
    dependent = [int(c) for c in x.get("inseparable") or []]
    if zero or dependent:
        out.append(worded(
            unexcited_columns(cols, zero, dependent, _structural_source(x)),
            kind="excitation", severity="design", columns=tuple(zero + dependent),
            effect=float(len(zero) + len(dependent)), effect_unit=UNIT_COLUMNS, details=dict(x)))
    elif x["condition_scaled"] > th.condition_number:
        out.append(worded(
            ill_conditioned(x["condition_scaled"], th.condition_number, bool(structural), x.get("validation_rank")),
            kind="excitation", severity="design", effect=float(x["condition_scaled"]),
            effect_unit=UNIT_CONDITION, threshold=th.condition_number, details=dict(x)))
    return out


def joint_motion_findings(r: Context) -> list[Finding]:
    """A joint whose validation motion is below ``joint_motion`` of its estimation-run motion."""
    ev, th = r.ev, r.th
    if ev.joint_motion_ratio is None:
        return []
    ratio = np.asarray(ev.joint_motion_ratio, dtype=float)
    return [worded(
        joint_motion(r.name(int(j)), float(ratio[j]), th.joint_motion),
        kind="excitation", severity="design", joints=(int(j),), effect=float(ratio[j]),
        effect_unit=UNIT_JOINT_MOTION, threshold=th.joint_motion,
        details={"joint_motion_ratio": float(ratio[j])}) for j in np.flatnonzero(ratio < th.joint_motion)]


def column_motion_findings(r: Context) -> list[Finding]:
    """Columns (not already unexcited, unidentifiable, inseparable or structural) the validation run
    excites below ``joint_motion`` of the estimation run."""
    x, th = r.ev.excitation, r.th
    ratio_c = None if x is None else x.get("column_motion_ratio")
    if x is None or ratio_c is None:
        return []
    skip = (set(x["unexcited"]) | set(x["unidentifiable"]) | set(x.get("inseparable") or [])
            | set(x.get("structural") or []))
    weak = [int(c) for c in np.flatnonzero(np.asarray(ratio_c, dtype=float) < th.joint_motion) if c not in skip]
    if not weak:
        return []
    return [worded(
        column_motion([(r.column(c), float(ratio_c[c])) for c in weak], th.joint_motion),
        kind="excitation", severity="design", columns=tuple(weak), effect=float(np.min(np.asarray(ratio_c)[weak])),
        effect_unit=UNIT_COLUMN_MOTION, threshold=th.joint_motion,
        details={"column_motion_ratio": {int(c): float(ratio_c[c]) for c in weak}})]


def rule(r: Context) -> list[Finding]:
    """The validation regressor's findings, then the joints and the columns the run hardly moves."""
    return [*regressor_findings(r.ev, r.th), *joint_motion_findings(r), *column_motion_findings(r)]


def reason(f: Finding, column: Callable[[int], str]) -> str:
    unit = f.effect_unit or ""
    cols = [column(c) for c in f.columns]
    if cols and "estimation run" in unit:
        e, t = effect_versus_threshold(f, ".1f", percent=True)
        return f"the validation run excites {', '.join(cols)} far less than the estimation run ({e} < {t})"
    if cols:
        zero = set(f.details.get("unexcited") or ())
        never = [column(c) for c in f.columns if c in zero]
        apart = [column(c) for c in f.columns if c not in zero]
        return "the validation run " + " and ".join(
            ([f"never excites {', '.join(never)}"] if never else [])
            + ([f"cannot separate {', '.join(apart)} from the other columns"] if apart else []))
    e, t = effect_versus_threshold(f, percent="share" in unit or "motion" in unit)
    if "condition" in unit:
        return f"ill-conditioned validation regressor (column-scaled condition number {e} > {t})"
    if "motion" in unit:
        return f"hardly moves ({e} of its estimation-run motion < {t})"
    text = f"excitation ({unit + ' = ' if unit else ''}{e}" + (f", threshold {t}" if f.threshold is not None else "")
    return text + ")" if f.effect is not None else "excitation"


KIND = Kind(name="excitation",
            description="the validation regressor leaves columns unexcited or is ill-conditioned, or a joint moves "
                        "far less than in the estimation run",
            order=810, rule=rule, reason=reason)
