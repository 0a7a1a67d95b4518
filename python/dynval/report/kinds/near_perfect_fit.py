"""``near_perfect_fit``: a joint's residual holds less of the measured torque's variance than a torque
sensor's own noise would (a note; conventions §5.11).

A measured torque carries its sensor's noise, which no model predicts: a residual below
``near_perfect_fit`` (1e-6 of the torque's variance, an RMS below 0.1 % of the torque's) says the
prediction was computed from these torques, or the data are simulated without noise. The report's
tests then test the arithmetic, not the model; nothing is decided from it (a note).
"""

from __future__ import annotations

import numpy as np

from .._finding_words import Words
from ._base import Context, Finding, Kind, Threshold, worded

THRESHOLD = Threshold(
    "near_perfect_fit", 1e-6,
    "1 − R² of a joint below which its residual is less than a torque sensor's own noise leaves (1e-6: a "
    "residual RMS below 0.1 % of the torque's RMS)")
UNIT = "1 − R² (share of the measured torque's variance left in the residual)"


def words(name: str, share: float, threshold: float) -> Words:
    return (f"{name}: the residual holds {share:.2g} of the measured torque's variance (below {threshold:g}): "
            "less than a torque sensor's own noise leaves, so the prediction was computed from these torques, or "
            "the data are simulated without noise. The report's tests then test the arithmetic, not the model.",
            "validate a model identified on other data against measured torques")


def rule(r: Context) -> list[Finding]:
    """A note on each joint (not constant) whose 1 − R² is below the threshold (a nan or infinite R²
    is never below it)."""
    ev = r.ev
    threshold = r.th.value(THRESHOLD)
    share = 1.0 - np.asarray(ev.r2, dtype=float)
    constant = np.asarray(ev.constant_target, dtype=bool)
    return [worded(words(r.name(j), float(share[j]), threshold), kind="near_perfect_fit", severity="note",
                   joints=(j,), statistic=float(ev.r2[j]), effect=float(share[j]), effect_unit=UNIT,
                   threshold=threshold)
            for j in range(share.size) if not constant[j] and share[j] < threshold]


KIND = Kind(name="near_perfect_fit",
            description="a joint's residual holds less of the measured torque's variance than a torque sensor's "
                        "noise would: the prediction was computed from the torques, or the data are noise-free",
            order=120, rule=rule, thresholds=(THRESHOLD,), test="worse_than_constant")
