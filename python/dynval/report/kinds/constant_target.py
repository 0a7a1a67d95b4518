"""``constant_target``: a joint's measured torque is constant (a note: R², fit and VAF compare
against nothing there; contract §3)."""

from __future__ import annotations

import numpy as np

from .._finding_words import Words
from ._base import Context, Finding, Kind, worded


def words(name: str, force_finite: bool) -> Words:
    how = "0 or 1 by scikit-learn's force_finite rule" if force_finite else "-inf, or nan for an exact prediction"
    return (f"{name}: the measured torque is constant, so R², fit and VAF compare against nothing "
            f"(reported as {how}).", "validate this joint on a trajectory that moves it")


def rule(r: Context) -> list[Finding]:
    constant = np.asarray(r.ev.constant_target, dtype=bool)
    return [worded(words(r.name(int(j)), r.ev.force_finite), kind="constant_target", severity="note",
                   joints=(int(j),)) for j in np.flatnonzero(constant)]


KIND = Kind(name="constant_target", description="a joint's measured torque is constant", order=30, rule=rule)
