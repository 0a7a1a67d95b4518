"""``physical_consistency``: no physical robot has the parameters (contract §8). Its findings come from
the model's own parameters (``report/_consistency.py``: a link's mass, pseudo-inertia and centre of
mass, friction < 0, the distance of identified base parameters from every consistent robot), not from
a rule over the residual's evidence: they join the report after the rules (``order`` 900)."""

from __future__ import annotations

from collections.abc import Callable

from .._text import number_text
from ._base import Finding, Kind, effect_versus_threshold


def reason(f: Finding, column: Callable[[int], str]) -> str:
    if f.details.get("link"):
        return (f"not a robot: {f.details['link']} breaks {f.details.get('condition')} by {number_text(f.effect)} "
                f"{f.effect_unit}")
    if f.details.get("joint"):
        return f"not a robot: {f.details.get('condition')} broken by {number_text(f.effect)} {f.effect_unit}"
    e, t = effect_versus_threshold(f, percent="share" in (f.effect_unit or ""))
    return (f"no physically consistent robot has these base parameters (the nearest adds {e} to the "
            f"estimation run's residual mean square ≥ {t})")


KIND = Kind(name="physical_consistency",
            description="no physical robot has the parameters (a link's mass, pseudo-inertia, CoM; friction < 0)",
            order=900, rule=None, reason=reason)
