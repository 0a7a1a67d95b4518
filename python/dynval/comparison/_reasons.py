"""The words of ``dynval.compare``: each candidate's reasons, one short line per deficiency or
design finding (where, what, the effect against its threshold), or its rank when it has none.

Only wording: what decides is in ``_compare.py``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..checks._typing import ReportSections
from ..report._findings import Finding
from ..report._text import number_text
from ..report.kinds import KINDS
from ..report.kinds._base import effect_versus_threshold

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

__all__ = ["joint_name", "column_name", "finding_reason", "candidate_reasons"]


def joint_name(report: ReportSections, j: int) -> str:
    names = report.provenance.get("joint_names")
    return str(names[j]) if names and 0 <= j < len(names) else f"joint {j + 1}"


def column_name(report: ReportSections, c: int) -> str:
    names = report.provenance.get("column_names")
    return str(names[c]) if names and 0 <= c < len(names) else f"column {c + 1}"


def _g(x: float | None, fmt: str = ".3g") -> str:
    """A number of a finding (None or non-finite as a word)."""
    return number_text(x, fmt)


_vs = effect_versus_threshold


def finding_reason(f: Finding, report: ReportSections) -> str:
    """One short reason from a finding's own fields: where, what, the effect and its threshold."""
    joints = ", ".join(joint_name(report, j) for j in f.joints)
    prefix = ("design: " if f.severity == "design" else "") + (f"{joints}: " if joints else "")
    declared = KINDS.get(f.kind)
    reason = (declared.reason if declared is not None else None) or _generic_reason
    return prefix + reason(f, lambda c: column_name(report, c))


def _generic_reason(f: Finding, column: Callable[[int], str]) -> str:
    """A kind's name, effect and threshold: the reason of a kind that declares none."""
    declared = KINDS.get(f.kind)
    e, t = _vs(f, percent=declared.percent if declared is not None else "share" in (f.effect_unit or ""))
    text = f.kind.replace("_", " ")
    if f.effect is not None:
        text += (f" ({f.effect_unit + ' = ' if f.effect_unit else ''}{e}"
                 + (f", threshold {t}" if f.threshold is not None else "") + ")")
    return text


def _with_share(text: str, f: Finding, share: float | None, shared: bool) -> str:
    """A reason with the share of the residual its finding explains (when the reason does not
    already print that number) and whether every candidate has it."""
    from ..report._ranking import share_text

    if share is not None and (f.effect is None or abs(share - float(f.effect)) > 1e-12 * max(1.0, abs(share))):
        text += f"; explains {share_text(share)} of the joint's residual"
    return text + (" — shared by all candidates" if shared else "")


def candidate_reasons(ranking: list[str], reports: Mapping[str, ReportSections], criterion: str,
                      crit: dict[str, float],
                      matter: Mapping[str, Sequence[tuple[Finding, Any, bool]]] | None = None
                      ) -> dict[str, tuple[str, ...]]:
    """Every candidate's reasons, in ranking order (see :class:`ComparisonReport`).

    ``matter``: per candidate its deficiency and design findings in the order to print them, each
    with its ranking record (``share``) and whether every candidate has it; the report's order
    when omitted."""
    out: dict[str, tuple[str, ...]] = {}
    best = ranking[0]
    for rank, n in enumerate(ranking, 1):
        r = reports[n]
        if matter is not None:
            items = [(f, getattr(x, "share", None), sh) for f, x, sh in matter[n]]
        else:
            items = [(f, None, False) for f in r.findings if f.severity in ("deficiency", "design")]
        if items:
            out[n] = tuple(_with_share(finding_reason(f, r), f, share, sh) for f, share, sh in items)
        elif rank == 1:
            out[n] = (f"no deficiency: rank 1 of {len(ranking)}, the lowest {criterion} "
                      f"({_g(crit[n], '.1f')}) among the candidates without a deficiency",)
        else:
            out[n] = (f"no deficiency: rank {rank} of {len(ranking)}, {criterion} {_g(crit[n], '.1f')} "
                      f"(Δ{criterion} = {_g(crit[n] - crit[best], '+.1f')} to {best})",)
    return out
