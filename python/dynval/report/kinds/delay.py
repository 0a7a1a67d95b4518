"""``delay``: the measured torque lags (or leads) the prediction (conventions §5.2): reported whenever
its test rejects, a deficiency when realigning removes a practical share of the error or the phase
lag at the information band's edge matters for control."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from .._finding_words import Words, p_text, percent
from .._text import number_text
from ._base import Context, Finding, Kind, effect_versus_threshold, worded
from ._evidence import delay_explains, phase_lag
from ._views import delay_of, physics_joint

UNIT = "share of the joint's mean square realigning removes"
UNIT_PHASE = "degrees of phase lag at the information band's edge"


def words(shift: float, sample_rate: float | None, shares: Sequence[tuple[str, float]], padj: float, *,
          phase: float | None = None, band: float | None = None, phase_threshold: float = 10.0, big: bool = True,
          masked: Sequence[tuple[str, float, float]] = ()) -> Words:
    """``shift`` in samples; ``shares``: (joint, share of its mean square realigning removes);
    ``phase``: the lag in degrees at the information band's edge ``band`` (Hz with a rate, else
    cycles/sample); ``masked``: (joint, realigning's share, the physical terms' share) where a
    missing term explains more than the shift."""
    unit, value = ("ms", 1000.0 * shift / sample_rate) if sample_rate else ("samples", shift)
    # > 0: the torque sensor lags the encoders; < 0: the encoders lag the torque
    verb, side = ("lags", "lag") if shift > 0 else ("leads", "lead")
    size = f"{abs(value):.3g} {unit}" + (f" ({abs(shift):.3g} samples)" if sample_rate else "")
    lag = ("" if phase is None else
           f", a {phase:.3g}° phase {side} at the information band's edge "
           f"({band:.3g} {'Hz' if sample_rate else 'cycles/sample'})")
    each = "; ".join(f"{name} {percent(share)}" for name, share in shares)
    head = (f"The measured torque {verb} the prediction by {size}{lag} (realigning removes {each} of the mean square; "
            f"Holm-adjusted p {p_text(padj)})")
    if big:
        why = (f"large for control (at least {phase_threshold:g}° at the band's edge)" if phase is not None
               and phase >= phase_threshold else "it removes a practical share of the error")
        return (head + f": a delay between the torque sensor and the encoders, not a missing term; {why}.",
                f"realign the measured torque with the encoders (shift it by {value:+.3g} {unit}), or model the "
                "sensor's filter")
    if masked:
        terms = "; ".join(f"{name} {percent(lib)} against {percent(sh)}" for name, sh, lib in masked)
        return (head + f". The physical terms explain more of these joints' error than the shift ({terms}): the "
                "shift may be the missing term's (a missing viscous term looks like a delay); check the logs' "
                "alignment once the term is in the model.", "none on this evidence: see the missing terms first")
    return (head + f": real, but below the {phase_threshold:g}° at the band's edge that matters for control and the "
            "share that matters for the error.", "none: the delay is real but small")


def rule(r: Context) -> list[Finding]:
    """One finding for a common delay, whenever its test rejects on some joint (conventions §5.2):
    a deficiency on the joints whose shift explains at least what the physical terms do there and
    whose realignment removes the ``delay`` share, or the ``missing_term`` share with a phase lag at
    the information band's edge of at least ``delay_phase`` degrees; a note otherwise (a small lag,
    or a missing term that explains more of the joint's error than the shift: a missing viscous
    term looks like a delay)."""
    ev, th = r.ev, r.th
    if "delay" not in r.fam or ev.physics is None:
        return []
    p, padj = r.fam["delay"]
    dl = delay_of(ev)
    assert dl is not None
    share = dl.share
    d = dl.shift_samples
    # a joint whose error realigning does not reduce holds no evidence of the delay
    significant = [j for j in range(share.size) if padj[j] <= r.alpha and share[j] > 0]
    if not significant or d == 0.0:
        return []
    phase, edge = phase_lag(ev, d)
    lag_matters = phase is not None and phase >= th.delay_phase
    explains = [j for j in significant if delay_explains(ev, j)]
    # the phase decides where realigning moves at least the share a missing term is worth: below
    # it the lag is not resolved by the data, and the band's edge may be the prediction's own steps
    big = [j for j in explains if share[j] >= th.delay or (lag_matters and share[j] >= th.missing_term)]
    r.deficient.update(big)
    joints = big or significant
    fs = ev.sample_rate
    j0 = max(joints, key=lambda j: share[j])
    shares = [(r.name(j), float(share[j])) for j in joints]
    masked = [] if big else [(r.name(j), float(share[j]), float(physics_joint(ev, j).share))
                             for j in significant if j not in explains]
    band = None if edge is None else (edge * fs if fs else edge)
    return [worded(
        words(d, fs, shares, float(padj[j0]), phase=phase, band=band, phase_threshold=th.delay_phase,
              big=bool(big), masked=masked),
        kind="delay", severity="deficiency" if big else "note", joints=tuple(joints), statistic=d,
        pvalue=float(p[j0]), pvalue_adjusted=float(padj[j0]),
        effect=float(share[j0]) if phase is None else float(phase),
        effect_unit=UNIT if phase is None else UNIT_PHASE,
        threshold=th.delay if phase is None else th.delay_phase,
        details={"delay_s": d / fs if fs else None, "delay_samples": d, "share": [float(x) for x in share],
                 "phase_deg": phase, "band_edge": band, "band_unit": "Hz" if fs else "cycles/sample",
                 "significant": significant, "explains": explains})]


def reason(f: Finding, column: Callable[[int], str]) -> str:
    d_s = f.details.get("delay_s")
    samples = float(f.details.get("delay_samples") or 0.0)
    lag = (f"{number_text(abs(1000.0 * d_s), '.3g')} ms" if d_s is not None
           else f"{number_text(abs(samples), '.3g')} samples")
    side = "lag" if samples >= 0 else "lead"
    if f.details.get("phase_deg") is not None:
        e, t = effect_versus_threshold(f, ".3g")
        size = f"a {e}° phase {side} at the information band's edge ≥ {t}°"
    else:
        e, t = effect_versus_threshold(f, percent="share" in (f.effect_unit or ""))
        size = f"realigning removes {e} of the mean square ≥ {t}"
    return f"torque {'delayed by' if samples >= 0 else 'ahead by'} {lag} against the encoders ({size})"


KIND = Kind(name="delay",
            description="the measured torque lags (or leads) the prediction: reported whenever significant, with "
                        "the phase lag at the information band's edge; a deficiency when realigning removes a "
                        "practical share of the error or the phase lag matters for control",
            order=610, rule=rule, reason=reason)
