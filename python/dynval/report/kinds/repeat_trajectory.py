"""``repeat_trajectory``: the validation run repeats the estimation run (a design finding;
conventions §5.6)."""

from __future__ import annotations

from collections.abc import Callable

from .._finding_words import Words
from .._text import versus
from ._base import Context, Finding, Kind, effect_versus_threshold, worded

ACTION = "validate on a different trajectory: a repeat rewards over-fitting"
_TAIL = "Metrics on it measure the fit, not the prediction of new motion."


def words_by_state(share: float, threshold: float, state: str | None, tolerance: float) -> Words:
    sh, sh_th = versus(share, threshold, ".0f", scale=100.0)
    states = "q, q̇, q̈" if state == "q" else "the regressor's leading principal components"
    return (f"The validation run repeats the estimation run: {sh} % of its states (> {sh_th} %) lie within "
            f"{tolerance:g} of the estimation trajectory at some time (state: {states}, each coordinate in "
            f"estimation-run standard deviations, the distance an RMS over them). {_TAIL}", ACTION)


def words_by_distance(distance: float, threshold: float, measure: str) -> Words:
    dist, dist_th = versus(distance, threshold)
    return (f"The validation run repeats the estimation run: relative {measure} distance {dist} < {dist_th} "
            f"(time-aligned; give q or the regressor of both runs to compare states at any time). {_TAIL}", ACTION)


def rule(r: Context) -> list[Finding]:
    """A share of the validation run near the estimation trajectory at any time above
    ``repeat_share``; without a state in both runs, a time-aligned distance below ``repeat_distance``."""
    d, th = r.ev.repeat, r.th
    if d is None:
        return []
    share = d.get("share")
    if share is not None:
        if not share > th.repeat_share:
            return []
        return [worded(
            words_by_state(share, th.repeat_share, d.get("state"), d.get("tolerance", th.repeat_tolerance)),
            kind="repeat_trajectory", severity="design", effect=float(share),
            effect_unit=f"share of the validation run near the estimation trajectory ({d.get('state')})",
            threshold=th.repeat_share, details=dict(d))]
    if d.get("distance") is None or not d.get("is_repeat", d["distance"] < th.repeat_distance):
        return []
    return [worded(
        words_by_distance(d["distance"], th.repeat_distance, d["measure"]),
        kind="repeat_trajectory", severity="design", effect=float(d["distance"]),
        effect_unit=f"relative distance ({d['measure']})", threshold=th.repeat_distance, details=dict(d))]


def reason(f: Finding, column: Callable[[int], str]) -> str:
    by_state = f.details.get("share") is not None
    e, t = effect_versus_threshold(f, percent="share" in (f.effect_unit or ""))
    if by_state:
        return (f"the validation run repeats the estimation run ({e} of it lies near the estimation trajectory "
                f"at some time > {t})")
    measure = f.details.get("measure", "")
    return (f"the validation run repeats the estimation run (relative {measure + ' ' if measure else ''}"
            f"distance {e} < {t})")


KIND = Kind(name="repeat_trajectory", description="the validation trajectory repeats the estimation trajectory",
            order=800, rule=rule, reason=reason)
