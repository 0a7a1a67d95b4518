"""Time stamps of a logged run: the grid the lag and spectral analyses use, and what is wrong with it.

Real logs are not uniformly sampled: receive stamps jitter, a logger repeats its last row when no
new sample arrived, and rows go missing. The analyses of dynval work on an equally spaced grid;
given the stamps, they use the nominal step (the median of the positive steps), take the rows as
equally spaced within a segment and split the run into segments at every gap, so that no lagged
product pairs samples across missing time. The stamps themselves are reported: duplicated stamps,
gaps (the largest with its time), steps off the nominal one and the jitter (contract §4,
conventions §1.7).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _validation as v
from ._errors import InvalidParameter, NonFiniteInput, ShapeMismatch

GAP_FACTOR = 1.5
"""A step longer than 1.5 nominal steps is nearer two steps than one: at least one sample is missing
(after k duplicated stamps, k + 1.5: the step then spans k + 1 rows)."""

IRREGULAR_TOLERANCE = 0.1
"""A step (neither a duplicate nor a gap) more than 10 % off the nominal step is irregular."""

RATE_TOLERANCE = 0.01
"""A given sample_rate may differ from the stamps' nominal rate by at most 1 %."""

PLAUSIBLE_RATE = (10.0, 1e5)
"""The rates (Hz) at which a robot logs its torques for a dynamic model: from 10 Hz (slower logs do not
hold the dynamics) to 100 kHz. Stamps at a rate outside are taken for stamps in another unit
(milliseconds of a logger up to 10 kHz give 10 Hz or less; microseconds, nanoseconds) and refused
unless ``time_units_checked=False`` (contract §4)."""

_UNITS = (("milliseconds", 1e3), ("microseconds", 1e6), ("nanoseconds", 1e9))
_TYPICAL_RATE = 1e3  # the rate a guessed unit is chosen nearest to: a robot's usual 1 kHz


@dataclass(frozen=True)
class Timing:
    """What the time stamps say, and the grid the analyses use.

    ``gap_rows``: the rows that follow a gap (each starts a new segment).
    """

    nominal_step: float
    sample_rate: float
    sample_rate_source: str
    n_steps: int
    duplicated_stamps: int
    repeated_rows: int | None
    gaps: int
    largest_gap: float
    largest_gap_time: float | None
    irregular_steps: int
    jitter_rms: float
    largest_step_deviation: float
    duration: float
    gap_rows: tuple[int, ...]
    grid: str

    @property
    def regular(self) -> bool:
        """No duplicated stamp, repeated row, gap or irregular step."""
        return not (self.duplicated_stamps or self.repeated_rows or self.gaps or self.irregular_steps)

    def to_dict(self) -> dict[str, Any]:
        return {"nominal_step": self.nominal_step, "sample_rate": self.sample_rate,
                "sample_rate_source": self.sample_rate_source, "n_steps": self.n_steps,
                "duplicated_stamps": self.duplicated_stamps, "repeated_rows": self.repeated_rows,
                "gaps": self.gaps, "largest_gap": self.largest_gap, "largest_gap_time": self.largest_gap_time,
                "irregular_steps": self.irregular_steps, "jitter_rms": self.jitter_rms,
                "largest_step_deviation": self.largest_step_deviation, "duration": self.duration,
                "gap_rows": list(self.gap_rows), "grid": self.grid, "regular": self.regular}


def stamps(value: Any, n: int, first_row: int | None = None) -> np.ndarray:
    """``time`` as finite seconds of shape (N,), rows in order (InvalidType, ShapeMismatch,
    NonFiniteInput, InvalidParameter naming the first bad row; ``first_row``: the row of a chunk's
    first stamp in its stream, added to the message)."""
    t = v.to_float_array(value, "time")
    if t.ndim == 2 and 1 in t.shape:
        t = t.reshape(-1)
    if t.ndim != 1 or t.shape[0] != n:
        raise ShapeMismatch(f"time must have one stamp per sample, shape ({n},), got {v.format_shape(t.shape)}")

    def in_stream(row: int) -> str:
        return "" if first_row is None else f" (row {first_row + row} of the stream)"

    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        r = int(bad[0])
        raise NonFiniteInput(f"time must be finite seconds, got {float(t[r])!r} at row {r}{in_stream(r)}")
    # the data's range (contract §1.2): differences and squares of such stamps stay finite
    far = np.flatnonzero(np.abs(t) > v.MAX_MAGNITUDE)
    if far.size:
        r = int(far[0])
        raise NonFiniteInput(f"time has a value out of range ({float(t[r])!r}) at row {r}{in_stream(r)}: "
                             f"|t| must be at most {v.MAX_MAGNITUDE:g} s")
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0])
        raise InvalidParameter(f"time must never decrease, got {float(t[k + 1])!r} at row {k + 1} after "
                               f"{float(t[k])!r} at row {k}{in_stream(k + 1)}")
    return t


def check_time(value: Any, n: int) -> np.ndarray:
    """``time``: finite seconds, shape (N,), never decreasing, advancing over the run."""
    t = stamps(value, n)
    if n >= 2 and not t[-1] > t[0]:
        raise InvalidParameter(f"time must advance, got every stamp equal to {float(t[0])!r}")
    return t


def check_units(nominal: float) -> None:
    """Stamps of the nominal step ``nominal`` (s) must be at a rate a robot logs (PLAUSIBLE_RATE):
    else they look like another unit (InvalidParameter with the fix, e.g. ``pass time / 1000``)."""
    lo, hi = PLAUSIBLE_RATE
    rate = 1.0 / nominal
    if lo <= rate <= hi:
        return
    whole = nominal >= 1.0 and float(nominal).is_integer()
    what = f"a whole number of seconds ({nominal:.6g} s)" if whole else f"{nominal:.6g} s (a rate of {rate:.6g} Hz)"
    unit = _unit_guess(rate)
    fix = "pass them in seconds" if unit is None else f"these look like {unit[0]}: pass time / {unit[1]:.0f}"
    raise InvalidParameter(f"time must be in seconds, got stamps whose step is {what}, outside the rates a robot "
                           f"logs at ({lo:g} Hz to {hi / 1e3:g} kHz); {fix}, or time_units_checked=False if they "
                           "are seconds")


def _unit_guess(rate: float) -> tuple[str, float] | None:
    """The unit (name, stamps per second) that brings ``rate`` into PLAUSIBLE_RATE nearest 1 kHz."""
    lo, hi = PLAUSIBLE_RATE
    fits = [(name, factor) for name, factor in _UNITS if lo <= rate * factor <= hi]
    return min(fits, key=lambda u: abs(math.log10(rate * u[1] / _TYPICAL_RATE)), default=None)


def analyse(t: np.ndarray, sample_rate: float | None = None, rows: np.ndarray | None = None,
            units_checked: bool = True) -> Timing:
    """The stamps ``t`` (checked by :func:`check_time`) against a uniform grid.

    ``sample_rate``: the caller's, checked against the stamps (within 1 %); inferred from them
    otherwise. ``rows``: the data (N, k) whose exact repeats of the previous row are counted.
    ``units_checked``: the nominal step must be one of seconds (:func:`check_units`).
    """
    steps = np.diff(t - t[0])
    nominal = nominal_step(t, steps)
    if units_checked:
        check_units(nominal)
    source = INFERRED
    if sample_rate is not None:
        nominal, source = given_step(sample_rate, nominal), "given"
    duplicated = int(np.count_nonzero(steps == 0))
    # a step after k duplicated stamps spans k + 1 rows: it is a gap only beyond k + 1.5 steps
    spans = 1 + _zeros_before(steps)
    is_gap = steps > (GAP_FACTOR + spans - 1) * nominal
    gaps = int(np.count_nonzero(is_gap))
    largest = float(steps.max()) if steps.size else 0.0
    k = int(np.argmax(steps)) if steps.size else 0
    regular = (steps > 0) & ~is_gap
    deviation = np.abs(steps[regular] - spans[regular] * nominal)
    repeated = None
    if rows is not None and rows.shape[0] >= 2:
        flat = rows.reshape(rows.shape[0], -1)
        repeated = int(np.count_nonzero(np.all(flat[1:] == flat[:-1], axis=1)))
    gap_rows = tuple(int(i) + 1 for i in np.flatnonzero(is_gap))
    grid = grid_text(nominal, source, len(gap_rows))
    return Timing(
        nominal_step=nominal, sample_rate=1.0 / nominal, sample_rate_source=source, n_steps=int(steps.size),
        duplicated_stamps=duplicated, repeated_rows=repeated, gaps=gaps, largest_gap=largest if gaps else 0.0,
        largest_gap_time=float(t[k + 1] - t[0]) if gaps else None,
        irregular_steps=int(np.count_nonzero(deviation > IRREGULAR_TOLERANCE * nominal)),
        jitter_rms=float(np.sqrt(np.mean(deviation**2))) if deviation.size else 0.0,
        largest_step_deviation=float(deviation.max()) if deviation.size else 0.0,
        duration=float(t[-1] - t[0]), gap_rows=gap_rows, grid=grid)


def _zeros_before(steps: np.ndarray) -> np.ndarray:
    """For each step, how many zero steps come right before it."""
    idx = np.arange(steps.size)
    last_positive = np.maximum.accumulate(np.where(steps != 0, idx, -1))
    previous = np.concatenate(([-1], last_positive[:-1]))
    return idx - 1 - previous


def nominal_step(t: np.ndarray, steps: np.ndarray) -> float:
    """The grid's step: the run's span over the number of nominal steps it holds (a gap counts as
    the steps it misses, a duplicated stamp as none; the median step decides the count), rounded
    to the fewest significant digits of the rate that the span's uncertainty cannot tell apart
    (epoch stamps in float64 are quantised to 2.4e-7 s: k/200 s stamps then give exactly 200 Hz;
    jittered stamps give their grid's rate when the jitter hides the difference)."""
    median = float(np.median(steps[steps > 0]))
    check_resolvable(median, float(steps.sum()))
    counts = np.rint(steps / median)
    counted = counts >= 1
    span = float(steps[counted].sum())
    rate = float(counts[counted].sum() / span)
    # the span's uncertainty: the clock's resolution at these stamps and, for jittered stamps,
    # three standard errors of the two end stamps' deviations from the grid
    jitter = float(np.sqrt(np.mean((steps[counted] - counts[counted] / rate) ** 2)))
    uncertainty = 2.0 * float(np.spacing(max(abs(t[0]), abs(t[-1])))) + 3.0 * jitter
    return rounded_step(rate, span, uncertainty)


MAX_STEPS = 2.0**53
"""Most nominal steps a run may hold: float64 counts integers exactly up to 2⁵³."""

MIN_STEP = 1.0 / v.MAX_MAGNITUDE
"""Smallest median step (s): the reciprocal of the data's range, so that the rate stays within it."""


def check_resolvable(median: float, span: float) -> None:
    """Steps float64 can count: the median step at least MIN_STEP and the span at most MAX_STEPS of
    them (InvalidParameter otherwise)."""
    if median < MIN_STEP or span / median > MAX_STEPS:
        raise InvalidParameter(f"time must advance by steps float64 can count (a median step of at least "
                               f"{MIN_STEP:g} s, at most 2**53 of them), got a median step of {median!r} s over "
                               f"a span of {span!r} s")


def rounded_step(rate: float, span: float, uncertainty: float) -> float:
    """1/rate, the rate rounded to the fewest significant digits within ``rate·uncertainty/span``
    (the stamps cannot tell those rates apart); the stream's summary uses it too."""
    tolerance = rate * uncertainty / span
    for digits in range(1, 16):
        rounded = float(f"{rate:.{digits}g}")
        if abs(rounded - rate) <= tolerance:
            return 1.0 / rounded
    return 1.0 / rate


INFERRED = "inferred from time (mean step, gaps counted in steps)"
"""``Timing.sample_rate_source`` of a rate found in the stamps."""


def given_step(sample_rate: float, nominal: float) -> float:
    """The step of a given ``sample_rate``, which must agree with the stamps' ``nominal`` step
    within 1 % (InvalidParameter otherwise)."""
    given = 1.0 / float(sample_rate)
    if abs(given - nominal) > RATE_TOLERANCE * nominal:
        raise InvalidParameter(
            f"sample_rate={float(sample_rate):g} Hz disagrees with the time stamps, whose median step "
            f"{nominal:.6g} s is {1.0 / nominal:.6g} Hz (time must be in seconds)")
    return given


def grid_text(nominal: float, source: str, n_gaps: int) -> str:
    """``Timing.grid``: the grid the lag and spectral analyses use."""
    grid = (f"equally spaced rows at the {'given' if source == 'given' else 'nominal'} rate "
            f"{1.0 / nominal:.6g} Hz (step {nominal:.6g} s)")
    if n_gaps:
        grid += (f"; split into {n_gaps + 1} segments at the {n_gaps} "
                 f"gap{'s' if n_gaps > 1 else ''} (> {GAP_FACTOR:g} steps)")
    return grid


def split_at_gaps(starts: np.ndarray, gap_rows: tuple[int, ...]) -> np.ndarray:
    """Segment starts refined with a start at every row that follows a gap."""
    if not gap_rows:
        return starts
    return np.union1d(np.asarray(starts, dtype=np.int64), np.asarray(gap_rows, dtype=np.int64)).astype(np.int64)
