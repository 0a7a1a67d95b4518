"""``sampling_colour``: the residual's colour lies above the band the motion occupies: the sensor, its
filters and the sampling rate, not the model (a note the whiteness rule gives, :func:`note`)."""

from __future__ import annotations

from .._finding_words import Words
from ._base import Context, Finding, Kind, worded

UNIT = "decimation factor"


def words(name: str, band: float | None, unit: str, decimation: int) -> Words:
    """``band``: the information band the decimation came from; None for a factor given as is."""
    reduced = (f"reduced to the band the motion occupies (below {band:.3g} {unit}, decimated by {decimation})"
               if band is not None else f"decimated by {decimation} (the factor given)")
    return (f"{name}: the residual is coloured at the logged rate but white once {reduced}: the colour is what the "
            "sensor, its filters and the sampling make, not the model.",
            "none for the model; test at the rate the motion needs (decimate=) or log less filtered data")


def note(r: Context, j: int, pvalue: float, padj: float) -> Finding:
    ev = r.ev
    return worded(words(r.name(j), ev.information_band, ev.frequency_unit, ev.decimation), kind="sampling_colour",
                  severity="note", joints=(j,), pvalue=pvalue, pvalue_adjusted=padj, effect=float(ev.decimation),
                  effect_unit=UNIT,
                  details={"information_band": ev.information_band, "frequency_unit": ev.frequency_unit})


KIND = Kind(name="sampling_colour",
            description="the residual's colour lies above the band the motion occupies: it is the sensor, "
                        "its filters and the sampling rate, not the model",
            order=700, rule=None)
