"""``worse_than_constant``: a joint's prediction is worse than its mean torque (R² < 0; a
deficiency without a test: the effect is the decision, conventions §5)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._finding_words import Words
from .._text import versus
from ._base import Context, Finding, Kind, worded

UNIT = "1 − R² beyond 1 (fraction of TSS)"


def words(name: str, r2: float, hidden_by: float | None) -> Words:
    """``hidden_by``: the pooled R² when it looks good (> 0) over several joints."""
    return (f"{name} does worse than a constant: R² = {versus(r2, 0.0, '.3f')[0]}"
            + (f", yet the pooled R² is {hidden_by:.3f} (pooling flattens all joints with one mean, so the "
               "high-torque joints dominate it; read the per-joint values)." if hidden_by is not None else "."),
            f"check {name}'s terms, signs and units: predicting its mean torque does better")


def rule(r: Context) -> list[Finding]:
    """A joint predicted worse than its mean torque, with the pooled R² when it hides the joint."""
    ev = r.ev
    m = len(ev.r2)
    constant = np.asarray(ev.constant_target, dtype=bool)
    r2 = np.asarray(ev.r2, dtype=float)
    pooled_good = m > 1 and np.isfinite(ev.pooled_r2) and ev.pooled_r2 > 0
    out: list[Finding] = []
    for j in range(m):
        if constant[j] or not np.isfinite(r2[j]) or r2[j] >= 0:
            continue
        r.deficient.add(j)
        out.append(worded(
            words(r.name(j), float(r2[j]), float(ev.pooled_r2) if pooled_good else None),
            kind="worse_than_constant", severity="deficiency", joints=(j,), statistic=float(r2[j]),
            effect=float(-r2[j]), effect_unit=UNIT, threshold=0.0))
    return out


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = versus(f.statistic, 0.0, ".3f")
    return f"worse than a constant (R² = {e} < {t})"


KIND = Kind(name="worse_than_constant",
            description="a joint's prediction is worse than its mean torque (R² < 0)",
            order=100, rule=rule, reason=reason)
