"""``whiteness``: the residual is not white (Ljung–Box at the information rate; conventions §5.1): a
deficiency only on a joint an earlier rule found deficient. Its rule (700) also gives
``sampling_colour`` (white once decimated) and ``processing_band`` (tested above the bandwidth)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._finding_words import Words, p_text
from .._text import number_text
from . import processing_band, sampling_colour
from ._base import Context, Finding, Kind, worded

UNIT = "max |ρ̂(ℓ)|"


def words(name: str, decimated: bool, lag: int | None, padj: float, backed: bool) -> Words:
    """``backed``: an earlier rule found the joint deficient."""
    rate = ("at the rate the motion needs (the information rate)" if decimated
            else "at the logged rate")
    return (f"{name}: the residuals are correlated in time (not white) {rate} (Ljung–Box up to lag {lag}, "
            f"Holm-adjusted p {p_text(padj)})"
            + (", and the findings above show the structure is the model's." if backed
               else "; colour alone is not evidence against the model (sensor filtering, oversampling and "
                    "estimation error colour residuals too)."),
            "see the findings above for the structure's source" if backed
            else "none on this evidence: colour alone does not show the model is wrong")


def rule(r: Context) -> list[Finding]:
    """Whiteness at the information rate: a deficiency only on a joint an earlier rule found deficient."""
    ev = r.ev
    if "whiteness" not in r.fam:
        return []
    _, padj = r.fam["whiteness"]
    raw = np.asarray(ev.whiteness_pvalue_raw, dtype=float)
    dec = ev.whiteness_pvalue_decimated
    out: list[Finding] = []
    for j in range(len(ev.r2)):
        backed = j in r.deficient
        if dec is not None and raw[j] <= r.alpha and not (padj[j] <= r.alpha):
            if not backed:  # a joint shown deficient above: its colour is not the sensor's
                out.append(sampling_colour.note(r, j, float(dec[j]), float(padj[j])))
            continue
        if not (padj[j] <= r.alpha):
            continue
        tested = float(dec[j] if dec is not None else raw[j])
        if ev.whiteness_above_bandwidth and not backed:
            out.append(processing_band.note(ev, r.name(j), j, "whiteness", None, tested, float(padj[j]), None))
            continue
        out.append(worded(
            words(r.name(j), dec is not None, ev.whiteness_lag, float(padj[j]), backed),
            kind="whiteness", severity="deficiency" if backed else "note", joints=(j,),
            pvalue=tested, pvalue_adjusted=float(padj[j]),
            effect=None if ev.max_abs_acf is None else float(ev.max_abs_acf[j]), effect_unit=UNIT,
            details={"lag": ev.whiteness_lag, "decimation": ev.decimation}))
    return out


def reason(f: Finding, column: Callable[[int], str]) -> str:
    rate = "at the information rate" if (f.details.get("decimation") or 1) > 1 else "at the logged rate"
    return (f"residual not white {rate} (max |ρ̂(ℓ)| = {number_text(f.effect, '.2f')}), explained by the "
            "findings above on this joint")


KIND = Kind(name="whiteness",
            description="the residual is not white (Ljung–Box); a deficiency only together with evidence above",
            order=700, rule=rule, reason=reason)
