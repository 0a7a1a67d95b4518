"""Readings of the evidence that several kinds' rules share (the motion's sections as the rules read
them): whether a delay explains a joint better than the physical terms, a named term's out-of-sample
effect."""

from __future__ import annotations

import math

from ._base import Evidence
from ._views import JointPhysics, delay_of, physics_joint

__all__ = ["delay_explains", "term_effect", "phase_lag", "simulator_values"]


def delay_explains(ev: Evidence, j: int) -> bool:
    """Realigning removes at least as much of joint j's mean square as the physical terms: the
    structure is a time shift, not a missing term (a missing viscous term looks like a small shift)."""
    dl = delay_of(ev)
    if dl is None:
        return False
    share = float(dl.share[j])
    lib = physics_joint(ev, j).share
    return bool(share >= (lib if lib == lib else 0.0))


def term_effect(t: JointPhysics) -> float:
    """The named term's share of the joint's mean square, out of sample: refitted with the model on
    the estimation run and carried to validation, or (a fallback refit on this run) cross-fitted on
    it; from the validation test alone, what it adds to the model's columns cross-fitted (what
    re-identifying them gains when the model spans it), or its own effect alone cross-fitted when
    the columns are unknown. Coloured noise a term fits by chance does not carry to held-out rows."""
    if t.refit_run in ("estimation", "validation"):
        return float(t.term_share)
    rel = t.relation
    if rel is not None:
        value = rel["reweight_share"] if t.relation_name in ("reweight", "unsupported") else t.carried_share
    else:
        value = t.heldout_share
    value = float("nan") if value is None else float(value)
    return value if value == value else float(t.term_share)


def phase_lag(ev: Evidence, shift: float) -> tuple[float | None, float | None]:
    """The phase lag (degrees) a shift of ``shift`` samples makes at the information band's edge,
    and that edge in cycles per sample; (None, None) without an information band."""
    band = ev.information_band
    if band is None or not math.isfinite(float(band)) or band <= 0:
        return None, None
    per_sample = float(band) / float(ev.sample_rate) if ev.frequency_unit == "Hz" and ev.sample_rate else float(band)
    return 360.0 * per_sample * abs(shift), per_sample


def simulator_values(ev: Evidence, j: int, c: int) -> tuple[float, float] | None:
    """Column c's (value in the prediction, value refitted on this run) on joint j when it is a
    simulator parameter's (``physics["simulator_parameters"]``), else None."""
    per_joint = (ev.physics or {}).get("simulator_parameters") or []
    for entry in per_joint[j] if j < len(per_joint) else []:
        if entry["column"] == c:
            return float(entry["predicted"]), float(entry["refitted"])
    return None
