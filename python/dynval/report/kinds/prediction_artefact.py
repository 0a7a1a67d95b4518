"""``prediction_artefact``: a narrow spectral peak in the residual that the prediction holds more of
than the measured torque: the model makes the line (conventions §5.2). The oscillation rule gives it
(:func:`finding`) for a peak whose sides say so (:func:`line_sides`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .._finding_words import NEGLIGIBLE, Words, p_text
from .._text import number_text
from ._base import Context, Evidence, Finding, Kind, effect_versus_threshold, worded

UNIT = "share of residual variance"


def words(name: str, frequency: float, unit: str, share: float, ratio: float, padj: float, big: bool,
          predicted: float, measured: float) -> Words:
    """``predicted``, ``measured``: the line's power in the prediction and in the measured torque."""
    return (f"{name}: the residual's line near {frequency:.3g} {unit} is the prediction's own: the prediction holds "
            f"{predicted:.2g} (squared torque units) there, the measured torque {measured:.2g} ({100 * share:.0f} % of "
            f"the residual's variance, {ratio:.0f}× the background; Holm-adjusted p {p_text(padj)})"
            + (": the model makes a line the robot does not have, not an unmodelled mode (e.g. a friction model's "
               "sign(q̇) chattering at standstill)." if big else NEGLIGIBLE),
            f"smooth what makes the model's line near {frequency:.3g} {unit}: e.g. the model's sign(q̇) chatters at "
            "standstill: smooth the friction model's sign (tanh(q̇/v₀)) or hold it in a stiction band; do not add "
            "compliance" if big else "none: the line is the model's own, but small")


def line_sides(ev: Evidence, b: int, j: int) -> tuple[float, float, float] | None:
    """The measured torque's, the prediction's and the residual's power in the line at bin ``b`` of
    joint ``j`` (the five bins a Hann-windowed line spreads over, times the bin width): squared torque
    units.

    The rule reads the difference of the first two against the third (conventions §5.2): a line S
    in one side moves that side's power by |S|² ≈ the residual's, give or take the cross term
    2 Re(B̄S) with the torque B both sides share, which Welch's averaging shrinks but does not remove
    where the robot's own torque is large at the line. Half the residual's line is the midpoint of
    the two answers; nearer zero (or all three underflowed to 0) the sides cannot tell, and the line
    stays an oscillation."""
    pm, pp, pr = ev.spectrum_power_measured, ev.spectrum_power_prediction, ev.spectrum_power
    if pm is None or pp is None or pr is None:
        return None
    freq = np.asarray(ev.spectrum_frequency, dtype=float)
    df = float(freq[1] - freq[0]) if freq.size > 1 else 1.0
    lo, hi = max(b - 2, 0), b + 3
    measured, predicted, residual = (float(np.sum(x[lo:hi, j]) * df) for x in (pm, pp, pr))
    return measured, predicted, residual


def is_artefact(sides: tuple[float, float, float] | None) -> bool:
    """The prediction holds more of the line than the measured torque by half the residual's line."""
    return sides is not None and sides[1] - sides[0] > 0.5 * sides[2]


def finding(r: Context, j: int, b: int, f: float, sides: tuple[float, float, float], p: Any, padj: Any,
            big: bool) -> Finding:
    """A residual line the prediction holds more of than the measured torque: the model makes it
    (a friction model's sign(q̇) chattering at standstill), not a mode the robot has."""
    ev, th = r.ev, r.th
    assert ev.spectrum_share is not None and ev.spectrum_ratio is not None
    share = float(ev.spectrum_share[b, j])
    ratio = float(ev.spectrum_ratio[b, j])
    measured, predicted, _ = sides
    return worded(
        words(r.name(j), f, ev.frequency_unit, share, ratio, float(padj[b, j]), big, predicted, measured),
        kind="prediction_artefact", severity="deficiency" if big else "note", joints=(j,), statistic=ratio,
        pvalue=float(p[b, j]), pvalue_adjusted=float(padj[b, j]), effect=share, effect_unit=UNIT,
        threshold=th.oscillation,
        details={"frequency": f, "frequency_unit": ev.frequency_unit, "line_power_prediction": predicted,
                 "line_power_measured": measured})


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f, percent=True)
    unit = f.details.get("frequency_unit", "")
    return (f"the prediction's own line near {number_text(f.details.get('frequency'))} {unit} "
            f"({e} of the residual variance ≥ {t}; the prediction holds "
            f"{number_text(f.details.get('line_power_prediction'), '.2g')} there, the measured torque "
            f"{number_text(f.details.get('line_power_measured'), '.2g')})")


KIND = Kind(name="prediction_artefact",
            description="a narrow spectral peak in the residual that the prediction holds more of than the "
                        "measured torque: the model makes the line (e.g. sign(q̇) chattering at standstill)",
            order=500, rule=None, reason=reason, percent=True)
