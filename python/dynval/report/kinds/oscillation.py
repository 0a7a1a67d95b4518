"""``oscillation``: a narrow spectral peak in the residual (after removing what the regressor
explains; conventions §5.2). Its rule (500) also gives ``prediction_artefact`` for a line the
prediction makes, and ``processing_band`` for a peak above the inputs' bandwidth."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._finding_words import NEGLIGIBLE, Words, p_text
from .._text import number_text
from . import prediction_artefact, processing_band
from ._base import Context, Finding, Kind, effect_versus_threshold, worded

UNIT = "share of residual variance"


def words(name: str, frequency: float, unit: str, share: float, ratio: float, padj: float, big: bool) -> Words:
    return (f"{name}: the residual oscillates near {frequency:.3g} {unit} ({100 * share:.0f} % of its variance, "
            f"{ratio:.0f}× the background; Holm-adjusted p {p_text(padj)})"
            + (": dynamics the model lacks, e.g. a flexible joint or link (an unmodelled mode)." if big
               else NEGLIGIBLE),
            f"an unmodelled mode near {frequency:.3g} {unit}: add joint or link compliance (a spring–damper) or keep "
            "trajectories away from it" if big else "none: the peak is real but small")


def rule(r: Context) -> list[Finding]:
    """A spectral peak standing above the smooth background (a mode), or above the inputs' bandwidth."""
    ev, th = r.ev, r.th
    if "spectrum" not in r.fam or ev.spectrum_share is None or ev.spectrum_ratio is None:
        return []
    p, padj = r.fam["spectrum"]
    freq = np.asarray(ev.spectrum_frequency, dtype=float)
    share = np.asarray(ev.spectrum_share, dtype=float)
    is_peak = np.asarray(ev.spectrum_is_peak, dtype=bool)
    unit = ev.frequency_unit
    out: list[Finding] = []
    for j in range(p.shape[1]):
        sig = np.flatnonzero((padj[:, j] <= r.alpha) & is_peak[:, j])
        if sig.size == 0:
            continue
        b = int(sig[np.argmax(share[sig, j])])
        f = float(freq[b])
        if ev.bandwidth is not None and f > ev.bandwidth:
            out.append(processing_band.note(ev, r.name(j), j, "oscillation", f, float(p[b, j]), float(padj[b, j]),
                                            float(share[b, j])))
            continue
        big = bool(share[b, j] >= th.oscillation)
        if big:
            r.deficient.add(j)
        sides = prediction_artefact.line_sides(ev, b, j)
        if sides is not None and prediction_artefact.is_artefact(sides):
            out.append(prediction_artefact.finding(r, j, b, f, sides, p, padj, big))
            continue
        out.append(worded(
            words(r.name(j), f, unit, float(share[b, j]), float(ev.spectrum_ratio[b, j]), float(padj[b, j]), big),
            kind="oscillation", severity="deficiency" if big else "note", joints=(j,),
            statistic=float(ev.spectrum_ratio[b, j]), pvalue=float(p[b, j]), pvalue_adjusted=float(padj[b, j]),
            effect=float(share[b, j]), effect_unit=UNIT, threshold=th.oscillation,
            details={"frequency": f, "frequency_unit": unit, "n_peaks": int(sig.size)}))
    return out


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f, percent=True)
    return (f"oscillation near {number_text(f.details.get('frequency'))} {f.details.get('frequency_unit', '')} "
            f"({e} of the residual variance ≥ {t})")


KIND = Kind(name="oscillation",
            description="a narrow spectral peak in the residual (after removing what the regressor explains)",
            order=500, rule=rule, reason=reason, percent=True)
