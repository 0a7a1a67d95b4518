"""``omitted_rows``: rows with non-finite values were omitted (``nan_policy="omit"``; a note)."""

from __future__ import annotations

from .._finding_words import Words
from .._text import counted
from ._base import Context, Finding, Kind, worded

UNIT = "rows"


def words(count: int) -> Words:
    were = "was" if count == 1 else "were"
    return (f"{counted(count, 'row')} with non-finite values {were} omitted; segment breaks were inserted so no lag "
            "joins samples that were not adjacent.", "check the logger for dropped or invalid samples")


def rule(r: Context) -> list[Finding]:
    count = r.ev.omitted_rows
    if not count:
        return []
    return [worded(words(count), kind="omitted_rows", severity="note", effect=float(count), effect_unit=UNIT)]


KIND = Kind(name="omitted_rows", description="rows with non-finite values were omitted", order=20, rule=rule)
