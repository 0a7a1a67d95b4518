"""``periodic_error``: on a periodic trajectory, what every period of the residual shares exceeds the
noise the period-to-period variation measures (no whiteness assumed; conventions §5)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .._finding_words import NEGLIGIBLE, Words, p_text
from ._base import Context, Finding, Kind, worded
from ._views import periodic_of

UNIT = "share of the residual's variance common to every period"


def words(name: str, effect: float, n_periods: Any, period: Mapping[str, Any], padj: float, big: bool) -> Words:
    seconds = period["seconds"]
    length = f"{seconds:.4g} s" if seconds else f"{period['samples']:.4g} samples"
    return (f"{name}: {100 * effect:.0f} % of the residual's variance repeats in every one of the {n_periods} "
            f"periods ({length}) beyond what the period-to-period variation allows (noise measured from the "
            f"periods themselves, no whiteness assumed; Holm-adjusted p {p_text(padj)})"
            + (": model error." if big else NEGLIGIBLE),
            "the model misses something the trajectory repeats: see the physics and correlation findings for "
            "which term" if big else "none: the periodic part is real but small")


def rule(r: Context) -> list[Finding]:
    """Each joint whose test rejects: a deficiency when the common share reaches ``periodic_error``."""
    if "periodic" not in r.fam or r.ev.periodic is None:
        return []
    p, padj = r.fam["periodic"]
    per = periodic_of(r.ev)
    assert per is not None
    effect = per.effect_net
    threshold = r.th.periodic_error
    out: list[Finding] = []
    for j in range(effect.size):
        if not (padj[j] <= r.alpha):
            continue
        big = bool(effect[j] >= threshold)
        if big:
            r.deficient.add(j)
        out.append(worded(
            words(r.name(j), float(effect[j]), per.n_periods, per.period, float(padj[j]), big),
            kind="periodic_error", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(per.statistic[j]), pvalue=float(p[j]), pvalue_adjusted=float(padj[j]),
            effect=float(effect[j]), effect_unit=UNIT, threshold=threshold,
            details={"n_periods": per.n_periods, "period": per.period,
                     "noise_variance": float(per.noise_variance[j]),
                     "model_columns_removed": per.model_columns_removed}))
    return out


KIND = Kind(name="periodic_error",
            description="a periodic trajectory: what every period of the residual shares exceeds the noise the "
                        "period-to-period variation measures (no whiteness assumed)",
            order=630, rule=rule, percent=True)
