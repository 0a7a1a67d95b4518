"""``pooling``: the pooled R² hides a joint that does much worse (a note)."""

from __future__ import annotations

import numpy as np

from .._finding_words import Words
from ._base import Context, Finding, Kind, worded

UNIT = "R² below pooled"
MARGIN = 0.05
"""How far below the pooled R² a joint's R² must be to be named."""


def words(name: str, r2: float, pooled: float) -> Words:
    return (f"{name}: R² = {r2:.3f}, well below the pooled {pooled:.3f}, which the larger torques of other "
            "joints dominate.", "read the per-joint values")


def rule(r: Context) -> list[Finding]:
    """Each joint (of several, not constant) whose R², not negative, is more than MARGIN below the pooled R²."""
    ev = r.ev
    r2 = np.asarray(ev.r2, dtype=float)
    constant = np.asarray(ev.constant_target, dtype=bool)
    if r2.size < 2 or not np.isfinite(ev.pooled_r2):
        return []
    return [worded(words(r.name(j), float(r2[j]), float(ev.pooled_r2)), kind="pooling", severity="note",
                   joints=(j,), statistic=float(r2[j]), effect=float(ev.pooled_r2 - r2[j]), effect_unit=UNIT,
                   threshold=MARGIN)
            for j in range(r2.size) if not constant[j] and np.isfinite(r2[j]) and 0 <= r2[j] < ev.pooled_r2 - MARGIN]


KIND = Kind(name="pooling", description="the pooled value hides a joint that does much worse", order=110, rule=rule)
