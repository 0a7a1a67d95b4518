"""``predictive_failure``: the validation error exceeds what the estimation run's noise and parameter
uncertainty allow (a Chow-type test; conventions §5)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._finding_words import Words, p_text
from ._base import Context, Finding, Kind, effect_versus_threshold, worded

UNIT = "validation mean square / what the estimation run allows"


def words(name: str, ratio: float, padj: float) -> Words:
    return (f"{name}: the validation mean square is {ratio:.3g}× what the estimation run's noise and parameter "
            f"uncertainty allow (Chow-type F test, Holm-adjusted p {p_text(padj)}).",
            f"the model does not carry over to new motion on {name}: look for a term the estimation trajectory did "
            "not need (a payload, a changed friction) or refit on richer data")


def rule(r: Context) -> list[Finding]:
    """A deficiency on each joint whose test rejects and whose ratio reaches ``predictive_ratio``."""
    if "predictive" not in r.fam or r.ev.predictive is None:
        return []
    p, padj = r.fam["predictive"]
    pred = r.ev.predictive
    ratio = np.asarray(pred["ratio"], dtype=float)
    threshold = r.th.predictive_ratio
    out: list[Finding] = []
    for j in range(ratio.size):
        if not (padj[j] <= r.alpha) or not ratio[j] >= threshold:
            continue
        r.deficient.add(j)
        out.append(worded(
            words(r.name(j), float(ratio[j]), float(padj[j])),
            kind="predictive_failure", severity="deficiency", joints=(j,), statistic=float(ratio[j]),
            pvalue=float(p[j]), pvalue_adjusted=float(padj[j]), effect=float(ratio[j]), effect_unit=UNIT,
            threshold=threshold, details={"expected_mse": float(pred["expected_mse"][j]),
                                          "validation_mse": float(pred["validation_mse"][j])}))
    return out


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f)
    return f"predictive failure (validation mean square {e}× what the estimation run allows ≥ {t}×)"


KIND = Kind(name="predictive_failure",
            description="the validation error exceeds what the estimation run's noise and parameter "
                        "uncertainty allow (Chow-type test)",
            order=620, rule=rule, reason=reason)
