"""``time_stamps``: the time stamps are not a uniform grid (a note; conventions §5)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .._finding_words import Words
from .._text import counted
from ._base import Context, Finding, Kind, worded

UNIT = "irregular steps"


def words(t: Mapping[str, Any]) -> Words:
    """The irregular steps of a time-stamp record (``dynval.checks._timing.Timing.to_dict``)."""
    parts = []
    if t["duplicated_stamps"]:
        parts.append(counted(t["duplicated_stamps"], "duplicated stamp"))
    if t["repeated_rows"]:
        parts.append(f"{counted(t['repeated_rows'], 'row')} repeating the previous row's torques exactly "
                     f"({100 * t['repeated_rows'] / max(t['n_steps'], 1):.2g} %)")
    if t["gaps"]:
        parts.append(f"{counted(t['gaps'], 'gap')} (largest {1e3 * t['largest_gap']:.4g} ms at "
                     f"t = {t['largest_gap_time']:.4g} s)")
    if t["irregular_steps"]:
        parts.append(f"{counted(t['irregular_steps'], 'step')} more than 10 % off the nominal one (jitter RMS "
                     f"{1e3 * t['jitter_rms']:.3g} ms, largest deviation {1e3 * t['largest_step_deviation']:.3g} ms)")
    return (f"Time stamps on a {1e3 * t['nominal_step']:.4g} ms nominal step: " + "; ".join(parts)
            + f". The lag and spectral analyses use {t['grid']}.",
            "check the logger's clock and buffering; lags and frequencies assume the stated grid")


def rule(r: Context) -> list[Finding]:
    """A note on time stamps that are not a uniform grid, with the counts and the grid used."""
    t = r.ev.timing
    if t is None or t["regular"]:
        return []
    return [worded(words(t), kind="time_stamps", severity="note",
                   effect=float(t["gaps"] + t["duplicated_stamps"] + t["irregular_steps"]), effect_unit=UNIT,
                   details=dict(t))]


KIND = Kind(
    name="time_stamps",
    description="the time stamps are not a uniform grid: duplicated stamps, repeated rows, gaps or "
                "irregular steps (the grid the analyses used is stated)",
    order=10, rule=rule)
