"""``processing_band``: spectral or whiteness evidence above the band in which the inputs are
trustworthy (``bandwidth``): the processing, not the model (a note). The oscillation and whiteness
rules give it (:func:`note`) in place of their own finding."""

from __future__ import annotations

from typing import Any

from .._finding_words import Words, p_text
from .._text import versus
from ._base import Evidence, Finding, Kind, worded

UNIT = "share of residual variance"


def words(name: str, frequency: float | None, bandwidth: float, padj: float) -> Words:
    """Evidence above the inputs' bandwidth: a spectral peak at ``frequency`` Hz, or (None) whiteness."""
    if frequency is not None:
        f_text, bw_text = versus(frequency, bandwidth)
        evidence = f"a spectral peak near {f_text} Hz lies above the inputs' {bw_text} Hz bandwidth"
    else:
        evidence = (f"the residual's colour, tested at a rate whose band reaches above the inputs' "
                    f"{bandwidth:.3g} Hz bandwidth,")
    return (f"{name}: {evidence} (Holm-adjusted p {p_text(padj)}): what the differentiating or sensor filter makes "
            "there is processing, not the model.", "none for the model: the inputs are not trustworthy there")


def note(ev: Evidence, name: str, j: int, what: str, frequency: float | None, p: float, padj: float,
         share: float | None) -> Finding:
    """Evidence above ``bandwidth`` Hz: the inputs' processing (a differentiating or sensor filter).

    ``frequency``: the spectral peak's (Hz); None for whiteness tested at a rate that still sees
    above the bandwidth."""
    assert ev.bandwidth is not None
    # whiteness has no effect here, and its unit has been null in the reports since the kind was added
    unit: dict[str, Any] = {"effect_unit": UNIT if share is not None else None}
    return worded(
        words(name, frequency, ev.bandwidth, padj), kind="processing_band", severity="note", joints=(j,), pvalue=p,
        pvalue_adjusted=padj, effect=share, threshold=ev.bandwidth,
        details={"evidence": what, "bandwidth": ev.bandwidth, "frequency": frequency}, **unit)


KIND = Kind(name="processing_band",
            description="spectral or whiteness evidence above the band in which the inputs are trustworthy "
                        "(``bandwidth``): the processing, not the model",
            order=500, rule=None)
