"""``information_criteria``: ``n_params`` leaves the criteria no degree of freedom (a note; the
rule of contract §3.7 that makes AICc and FPE nan, said where the reader looks)."""

from __future__ import annotations

from .._finding_words import Words
from ._base import Context, Finding, Kind, worded

UNIT = "parameters"


def words(n_params: int, n_obs: int, noise_model: str) -> Words:
    counted = "N·m samples × joints" if noise_model == "pooled" else f"N samples ({noise_model} noise model)"
    return (f"n_params = {n_params} is not below n − 1 = {n_obs - 1}, where n = {n_obs} is the observations the "
            f"information criteria count ({counted}): AICc and FPE are nan, undefined there (AICc's correction "
            f"2p(p+1)/(n − p − 1) divides by a number that is not positive, and FPE's (1 + p/n)/(1 − p/n) has no "
            f"finite value at p = n), and AIC and BIC are mostly the penalty 2p or p·ln n, "
            f"so they rank models by their size, not by their fit. The tests of the residual do not depend on "
            f"n_params.",
            "compare models on a validation run with more observations than parameters, or by the tests of the "
            "residual; check that n_params counts the identified parameters")


def rule(r: Context) -> list[Finding]:
    p, n = r.ev.n_params, r.ev.criteria_n_obs
    if p is None or n is None or p < n - 1:
        return []
    return [worded(words(p, n, r.ev.noise_model), kind="information_criteria", severity="note", effect=float(p),
                   effect_unit=UNIT, threshold=float(n - 1))]


KIND = Kind(
    name="information_criteria",
    description="n_params leaves the criteria no degree of freedom (p >= n - 1): AICc and FPE are "
                "undefined and AIC and BIC are mostly penalty",
    order=40, rule=rule)
