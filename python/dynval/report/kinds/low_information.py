"""``low_information``: the run has too few effective samples to detect a term of practical size (a
design finding, conventions §5.2): on a joint where no deficiency was found, or where the terms named
remove less than the run can detect."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .._finding_words import Words, column_name
from .._text import versus
from ._base import Context, Evidence, Finding, Kind, effect_versus_threshold, worded
from ._views import physics_joint

UNIT = "smallest detectable share of the mean square (90 % power)"


Unresolved = tuple[str, float, tuple[str, float] | None]
"""A term found on a joint the run cannot resolve: its name, its share of the mean square, and the
other kind that removes within the detectable share of it (None where the term removes less)."""


def words(joints: Sequence[tuple[str, float, float, Sequence[Unresolved] | None]], threshold: float) -> Words:
    """``joints``: (name, N_eff, smallest detectable share, the terms found there it cannot resolve, or None)."""
    each = []
    threshold_pct = ""
    for name, n_eff, share, unresolved in joints:
        pct, threshold_pct_j = versus(share, threshold, ".0f", scale=100.0)
        threshold_pct = threshold_pct or threshold_pct_j
        tail = "" if unresolved is None else " — found deficient, but " + "; ".join(map(_unresolved_words, unresolved))
        each.append(f"{name}: N_eff = {n_eff:.0f}, {pct} %" + tail)
    which = (" On a joint found deficient, which term is missing this run cannot tell."
             if any(u is not None for *_, u in joints) else "")
    return (f"This run cannot decide: its noise leaves so few effective samples that a missing term must remove more "
            f"than {threshold_pct} % of the mean square to be found ({'; '.join(each)})." + which,
            "validate on a longer or faster-varying run (more effective samples)")


def _unresolved_words(term: Unresolved) -> str:
    name, share, other = term
    if other is None:
        return f"{name} removes {100 * share:.0f} %, less"
    return f"{name} {100 * share:.0f} % and {other[0]} {100 * other[1]:.0f} % differ by less"


def named_term(ev: Evidence, f: Finding) -> tuple[str, float] | None:
    """The term a deficiency names and the share of the mean square it removes (a missing physical
    term, a missing column refitted in), or None for a deficiency that is not a named term."""
    d = f.details or {}
    if f.kind == "missing_physics":
        return str(d.get("label") or d.get("term")), float(d.get("term_share", math.nan))
    if f.kind == "regressor_correlation" and d.get("added_variable") and f.effect is not None:
        return column_name(ev.column_names, f.columns[0]) if f.columns else "a column", float(f.effect)
    return None


def rival(ev: Evidence, f: Finding, share: float, detectable: float) -> tuple[str, float] | None:
    """Another kind that the refit which named ``f``'s physical term found removing within
    ``detectable`` (the run's smallest detectable share) of the named term's ``share``, the closest;
    None for any other finding or where no kind comes that close: a difference the run cannot detect
    cannot tell the two apart (a velocity-squared drag at 35 % and viscous friction at 29 % where
    the run detects 33 %)."""
    if f.kind != "missing_physics" or ev.physics is None or not f.joints:
        return None
    from ...statistics._physics import LABELS

    t = physics_joint(ev, f.joints[0])
    others = [(g, float(v)) for g, v in t.refit_shares.items() if g != t.term and g in LABELS]
    if not others:
        return None
    g, v = max(others, key=lambda gv: gv[1])
    return (LABELS[g], v) if share - v < detectable else None


def unresolved(ev: Evidence, found: list[Finding], joints: set[int]) -> dict[int, list[Unresolved]]:
    """Of the deficient ``joints``, those whose every deficiency (whiteness, which follows from the
    others, aside) names a term that removes less than the run's smallest detectable share, or no
    more than another kind does by that share (:func:`rival`), with those terms (and the rivals):
    the structure is certain (its test is significant), which term it is the run cannot resolve."""
    if ev.detectable_share is None:
        return {}
    mde = np.asarray(ev.detectable_share, dtype=float)
    out = {}
    for j in sorted(joints):
        deficiencies = [f for f in found if f.severity == "deficiency" and f.kind != "whiteness" and j in f.joints]
        terms: list[Unresolved] = []
        for f in deficiencies:
            t = named_term(ev, f)
            if t is None:
                break
            close = None if t[1] < mde[j] else rival(ev, f, t[1], float(mde[j]))
            if close is None and not t[1] < mde[j]:
                break
            terms.append((t[0], t[1], close))
        else:
            if deficiencies:
                out[j] = terms
    return out


def rule(r: Context) -> list[Finding]:
    """Too few effective samples: on a joint where no deficiency was found, or where the terms
    named remove less than the run can detect (named in the message): where a term above that was
    found, the run did decide."""
    ev, th = r.ev, r.th
    if ev.detectable_share is None:
        return []
    left = unresolved(ev, r.found, r.deficient)
    mde = np.asarray(ev.detectable_share, dtype=float)
    low = [int(j) for j in np.flatnonzero(mde > th.detectable_share) if int(j) not in r.deficient or int(j) in left]
    if not low:
        return []
    n_eff = np.asarray(ev.noise_n_eff, dtype=float)
    each = [(r.name(j), float(n_eff[j]), float(mde[j]), left.get(j)) for j in low]
    return [worded(
        words(each, th.detectable_share),
        kind="low_information", severity="design", joints=tuple(low), effect=float(mde[low].max()),
        effect_unit=UNIT, threshold=th.detectable_share,
        details={"detectable_share": [float(x) for x in mde], "noise_n_eff": [float(x) for x in n_eff],
                 "unresolved": sorted(int(j) for j in left if j in low)})]


def reason(f: Finding, column: Callable[[int], str]) -> str:
    e, t = effect_versus_threshold(f, percent=True)
    return f"too few effective samples (the smallest detectable term removes {e} of the mean square > {t})"


KIND = Kind(name="low_information",
            description="the run has too few effective samples to detect a term of practical size",
            order=820, rule=rule, reason=reason, percent=True)
