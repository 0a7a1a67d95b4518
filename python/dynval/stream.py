"""Streaming validation: the report of :func:`dynval.validate` from data read in chunks.

:class:`ValidationAccumulator` takes the keywords of ``validate`` that make sense without the
whole series, reads ``tau_meas``, ``tau_pred`` (and the regressor) chunk by chunk, and gives a
:class:`~dynval.ValidationReport` equal, within the agreement tolerance of the backends (1e-14
of each quantity's natural size), to ``validate`` on the concatenated data with the same segments:

* point metrics pooled and per joint, their aggregates;
* residual mean, variance (the profile's ddof) and the zero-mean test, both halves;
* the coloured-noise bias test, ``validate``'s estimator from the lag sums and the rows at the
  segments' ends (equal to rounding with segments longer than the lags held, contract §4.1), unless
  its bandwidth needs more lags than are held;
* autocorrelation with its band and Ljung–Box, across chunk boundaries, honouring segments;
* the cross-correlation ρ with the regressor columns at lags 0..max_lag;
* the information criteria of the noise model, and their N_eff-based variants with the bias test;
* with time stamps (``update(..., time=...)``), the ``timing`` section and the ``time_stamps`` note,
  a gap in the stamps ending the segment as :meth:`~ValidationAccumulator.break_segment` does.

* without a regressor, the residual's Welch spectrum and its peak tests, summed window by window
  (``dynval.streaming._welch``; merged accumulators keep it only across a break);

Sections that need the whole series are None or partial (``design`` and ``segment_metrics`` None,
``spectrum`` with a regressor; ``whiteness`` at the logged rate only; the cross-correlation without its
colour-aware fields; findings from this evidence only, Holm over a family of ``validate``'s size):
docs/contract.md §4.1 lists them, and the report names every test it left out
(``provenance["not_tested"]``, :mod:`dynval.coverage`).

Two accumulators over consecutive time ranges combine with :meth:`~ValidationAccumulator.merge`
(the argument's rows come after the accumulator's): the lags join across the junction, as they do
between two chunks of one accumulator, unless a :meth:`~ValidationAccumulator.break_segment`
separates them. Merging is associative, so partial accumulators can be combined in any tree
(``dynval.dask`` does this on a cluster). The state is O(L·m·p) numbers (L the number of lags) plus
one integer per segment, whatever the number of rows.

Examples
--------
>>> import numpy as np, dynval
>>> from dynval.stream import ValidationAccumulator
>>> rng = np.random.default_rng(0)
>>> tau = rng.normal(size=(1000, 2)); pred = tau + 0.1 * rng.normal(size=(1000, 2))
>>> acc = ValidationAccumulator(n_params=4, max_lag=10)
>>> for k in range(0, 1000, 64):
...     acc.update(tau[k:k + 64], pred[k:k + 64])
>>> report = acc.result()
>>> want = dynval.validate(tau, pred, n_params=4, max_lag=10)
>>> bool(np.allclose(report.autocorrelation["rho"], want.autocorrelation["rho"], rtol=0, atol=1e-14))
True
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
import scipy.stats

from .checks import _timing
from .checks import _validation as v
from .checks._checks import Array, CheckedCall
from .checks._errors import InputError, InvalidParameter, ShapeMismatch
from .checks._typing import (
    ArrayLike,
    BoolArray,
    FloatArray,
    FusedMetrics,
    IntArray,
    Integer,
    NanPolicy,
    NoiseModel,
    ProfileName,
)
from .coverage import not_tested
from .kernels._reference.fit import fit_values, r2_values, uniform_average, vaf_values, variance_weighted
from .kernels._reference.information import assemble, fit_term_from_sums, pooled_sum
from .kernels._reference.portmanteau import chi2_logsf
from .metrics._profiles import Profile
from .metrics._results import ZeroMeanTest
from .report import _records as rec
from .report import _sections as sec
from .report._assembly import Sections, ValidationReport, assemble_report, provenance
from .report._findings import Thresholds
from .report._motion import detectable_share
from .report._options import (
    NAMES,
    OPTIONS,
    UNSUPPORTED,
    Keywords,
    Options,
    check_column_names,
    check_joint_names,
    check_options,
    plan_lags,
    to_setting,
)
from .statistics import _physics, _stats
from .statistics._physics_stream import PhysicsSums
from .statistics._stats import iid_t_test, newey_west_bandwidth, newey_west_n_eff, z_two_sided
from .streaming._edges import SegmentEdges
from .streaming._stream import CoreState, Layout, Snapshot, Stamps, State, state_too_large
from .streaming._welch import SIZES, WelchSums

__all__ = ["ValidationAccumulator", "UNSUPPORTED", "ZERO_MEAN_MAX_SAMPLES"]

ZERO_MEAN_MAX_SAMPLES = 10**9
"""Largest N for which the accumulator carries the lags of the zero-mean test's N_eff half.

Its Newey–West bandwidth K = ⌊4(N/100)^(2/9)⌋ grows with N, which a stream does not know in
advance; the accumulator keeps K(1e9) = 143 lags of the residual's autocorrelation (a few
kilobytes). Beyond that N the corrected half is None, as with ``max_lag=0``."""

# Rows gathered before they are summed: small chunks are pooled into one block, so that the
# per-block work (centring, lagged sums, the products across the junction) is shared.
_MIN_BLOCK_ROWS = 256
# Largest block, in values of m·(p + 2) columns: bounds the FFT temporaries of the lagged sums.
_MAX_BLOCK_VALUES = 1 << 22
_MAX_BLOCK_ROWS = 1 << 16
# The time stamps of the first rows, at least this many steps (the whole first chunk when it holds
# more), give the nominal step that classifies every later step (without a sample rate) and the
# median step that counts the steps of the inferred rate; until then the rows wait, unsummed.
SETTLE_STEPS = 100

# What an update changes before its stamps are checked against the grid they set (restored on a refusal).
_WAITING_FIELDS = ("_layout", "_chunks", "_rows_seen", "_timed", "_first_seen", "_last_seen", "_waiting",
                   "_waiting_rows")

# The settings two accumulators must share to merge: every keyword it takes, in the order their
# difference is reported (the contract's, OPTIONS').
_MERGED_SETTINGS = tuple(o.name for o in OPTIONS if o.stream == "supported")


class ValidationAccumulator:
    """Validation report of data that arrive in chunks (module docstring; contract §4.1).

    Parameters
    ----------
    n_params : int
        Number of identified parameters p, as for :func:`dynval.validate`.
    max_lag : int, optional
        Largest lag of the autocorrelation and cross-correlation. ``None`` takes the profile's
        cap (50 lesson and sklearn, 25 matlab), reduced to the longest segment − 1 at
        :meth:`result` as ``validate`` does; the ``statsmodels`` profile's default depends on N,
        which a stream does not know, so it needs an explicit value. ``0`` reads every chunk once.
    n_joints : int, optional
        Number of joints m: needed for a stacked ``(c·m, p)`` regressor chunk; otherwise taken
        from the first chunk.
    profile, level, noise_model, nan_policy, sample_rate, joint_names, column_names, thresholds, allow_wide
        As for :func:`dynval.validate`. ``nan_policy="omit"`` deletes rows and inserts a segment
        break where rows were deleted, across chunk boundaries too.
    time_units_checked : bool
        As for :func:`dynval.validate`: False accepts time stamps at any rate. Checked on the
        stamps that set the nominal step (the first 100 steps), and again on the whole stream's at
        :meth:`result`.
    bandwidth : float, optional
        As for :func:`dynval.validate`: whiteness evidence above it (Hz) is a ``processing_band``
        note. Needs ``sample_rate`` or time stamps with the chunks (``update(..., time=...)``), and
        is at most their Nyquist frequency.
    backend : None, "python" or "cpp"
        Where the sums run: ``"cpp"`` the C++ core's ``StreamState``, ``"python"`` numpy (the
        reference); ``None`` the default backend (:func:`dynval.backends`). The report is built
        in Python from the sums either way.
    segments, decimate, q, estimation, cross_correlation_detail, model_columns
        Not supported (they need the whole series): anything but None raises InvalidParameter
        naming the keyword (:data:`UNSUPPORTED` gives the reasons).

    Examples
    --------
    >>> import numpy as np
    >>> acc = ValidationAccumulator(n_params=1, max_lag=2)
    >>> acc.update([1.0, 2.0, 3.0], [1.1, 1.9, 3.2])
    >>> acc.break_segment()
    >>> acc.update([4.0, 5.0, 6.0], [3.9, 5.1, 6.0])
    >>> acc.result().provenance["segments"]
    [3, 3]
    """

    def __init__(self, *, n_params: Integer, max_lag: Integer | None = None, n_joints: Integer | None = None,
                 profile: ProfileName = "lesson", level: float | None = None, noise_model: NoiseModel | None = None,
                 nan_policy: NanPolicy = "raise", backend: Literal["python", "cpp"] | None = None,
                 sample_rate: float | None = None, time_units_checked: bool = True, bandwidth: float | None = None,
                 joint_names: Sequence[str] | None = None, column_names: Sequence[str] | None = None,
                 thresholds: Thresholds | dict[str, float] | None = None, allow_wide: bool = False,
                 segments: None = None, decimate: None = None, q: None = None, estimation: None = None,
                 cross_correlation_detail: None = None, model_columns: None = None) -> None:
        # validate's checks, in its order (contract §2.1), the unsupported keywords refused in their places
        given = {name: value for name, value in locals().items() if name in NAMES}  # OPTIONS' keywords
        self._settings = check_options(Keywords(**given), None)
        self._layout: Layout | None = None  # set by the first chunk: m, p and the lags held
        self._state: State | CoreState | None = None
        self._welch: WelchSums | None = None  # the residual's window periodograms (no regressor, lags held)
        self._edges: SegmentEdges | None = None  # the residual at the inner segment junctions (lags held)
        self._entry = "stream"  # whose tests the report names as left out (dynval.coverage): dask's, the CLI's
        # rows of the current segment not yet summed: (tau_meas, tau_pred, regressor) chunks
        self._pending: list[tuple[FloatArray, FloatArray, FloatArray | None]] = []
        self._pending_rows = 0
        self._break_first = False  # break_segment() before the first chunk
        self._chunks = 0
        self._rows_seen = 0
        self._omitted = 0
        # time stamps: given with every chunk (True) or none (False), decided by the first update
        self._timed: bool | None = None
        self._stamps: Stamps | None = None  # their summary, once the nominal step is known
        # without a sample rate, the updates (and breaks) that come before the nominal step is known:
        # ("rows", meas, pred, reg, time, breaks, kept stamps) or ("break",)
        self._waiting: list[tuple[Any, ...]] | None = None
        self._waiting_rows = 0  # kept rows in it
        self._frozen_rows = 0  # waiting rows summed because their stamps never advanced (_sum_frozen)
        self._first_seen: float | None = None  # the first and the last stamp of any row (omitted too)
        self._last_seen: float | None = None
        # the physics test's sums, with q given with the chunks: which of q, dq, ddq (decided by the
        # first update), and the rows waiting for the sample rate the stamps will give
        self._motion: tuple[bool, bool, bool] | None = None
        self._physics: PhysicsSums | None = None
        self._physics_waiting: list[tuple[FloatArray | None, ...]] = []

    # ----------------------------------------------------------------------- public

    @property
    def n_samples(self) -> int:
        """Rows accumulated so far (after ``nan_policy="omit"``)."""
        return (0 if self._state is None else self._state.n) + self._pending_rows + self._waiting_rows

    def update(self, tau_meas_chunk: ArrayLike, tau_pred_chunk: ArrayLike,
               regressor_chunk: ArrayLike | None = None, *, time: ArrayLike | None = None,
               q: ArrayLike | None = None, dq: ArrayLike | None = None, ddq: ArrayLike | None = None) -> None:
        """Add the next rows.

        Every chunk must have the same m (and p, and a regressor either always or never); errors
        name the chunk, counted from 0. A rejected chunk leaves the accumulator unchanged. Chunks
        of any length (1 row, fewer rows than max_lag, 0) are fine: lags join across chunk
        boundaries.

        With ``time``, the report gets ``validate``'s ``timing`` section and ``time_stamps`` note,
        and a gap in the stamps (a step longer than 1.5 nominal steps) ends the segment as
        :meth:`break_segment` does. Steps are classified against the nominal step of
        ``sample_rate``, else of the stamps of the first chunk (at least 100 steps: a shorter
        first chunk waits, unsummed, for the next ones); contract §4.1.

        Parameters
        ----------
        tau_meas_chunk, tau_pred_chunk : array_like, (c,) or (c, m)
            The next c rows of measured and predicted torque.
        regressor_chunk : array_like, (c, m, p) or (c·m, p) with ``n_joints``, optional
            The regressor's rows, for the cross-correlation section.
        time : array_like, (c,), optional
            The rows' time stamps in seconds, never decreasing (across chunks too). Given with
            the first update, needed with every update; not given, refused with every later one.
        q, dq, ddq : array_like, (c, m), optional
            The rows' joint positions (and velocities, accelerations; derived from q with
            ``validate``'s Savitzky–Golay filter when not given), for the missing-physics test
            (contract §4.1): like ``time``, given with every update or with none. Needs
            ``sample_rate`` or ``time`` for derived ones.

        Returns
        -------
        None

        Examples
        --------
        >>> acc = ValidationAccumulator(n_params=1, max_lag=1)
        >>> acc.update([1.0, 2.0, 3.0], [1.1, 1.9, 3.2])
        >>> acc.n_samples
        3

        An empty chunk adds nothing, and a chunk of the wrong width is refused, naming the chunk:

        >>> acc.update(np.empty(0), np.empty(0))
        >>> acc.update([[1.0, 2.0]], [[1.0, 2.0]])
        Traceback (most recent call last):
            ...
        dynval.checks._errors.ShapeMismatch: chunk 2: tau_meas must have m=1 columns like the chunks before it, ...
        >>> acc.n_samples
        3
        """
        self._update(tau_meas_chunk, tau_pred_chunk, regressor_chunk, (), time, (q, dq, ddq))

    def _update(self, tau_meas: ArrayLike, tau_pred: ArrayLike, regressor: ArrayLike | None,
                breaks: Sequence[int], time: ArrayLike | None = None,
                motion: tuple[ArrayLike | None, ...] = (None, None, None)) -> None:
        """:meth:`update` with segment breaks before the chunk's rows ``breaks`` (sorted; 0 is a
        break before its first row): ``dynval.dask`` hands each block its part of ``segments``."""
        meas, pred, reg = self._checked_chunk(tau_meas, tau_pred, regressor)
        stamps = self._checked_time(time, meas.shape[0])
        moving = self._checked_motion(motion, meas.shape, stamps is not None)
        self._take_update(meas, pred, reg, breaks, stamps)
        if moving is not None:
            self._feed_physics(meas, pred, reg, moving)

    def _take_update(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None, breaks: Sequence[int],
                     stamps: FloatArray | None) -> None:
        """Sum a checked chunk, or keep it until its stamps set the grid."""
        # what the chunk changes before its stamps may settle the grid (and be refused there)
        before = {name: getattr(self, name) for name in _WAITING_FIELDS}
        if self._layout is None:
            self._layout = self._new_layout(meas.shape[1], 0 if reg is None else reg.shape[2])
        self._chunks += 1
        self._rows_seen += meas.shape[0]
        if self._timed is None:
            self._timed = stamps is not None
        if stamps is None:
            self._feed_chunk(meas, pred, reg, breaks)
            return
        if stamps.size:
            self._first_seen = float(stamps[0]) if self._first_seen is None else self._first_seen
            self._last_seen = float(stamps[-1])
        if self._stamps is None and self._waiting is None:
            self._waiting = []
        if self._waiting is None:
            self._feed_timed(meas, pred, reg, stamps, breaks)
            return
        # Rows kept for later are copied: the caller may refill its buffer for the next chunk.
        keep = self._kept(meas, pred, reg)
        kept = stamps.copy() if keep is None else stamps[keep]
        self._waiting.append(("rows", meas.copy(), pred.copy(), None if reg is None else reg.copy(), stamps.copy(),
                              tuple(breaks), kept))
        self._waiting_rows += kept.size
        try:
            self._settle_when_known()
        except InputError as exc:  # the stamps that set the grid refused: the chunk is not taken
            if self._waiting is not None and self._waiting and self._waiting[-1][0] == "rows":
                self._waiting.pop()
            for name, value in before.items():
                setattr(self, name, value)
            raise type(exc)(f"chunk {before['_chunks']}: {exc}") from None

    def _feed_chunk(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None, breaks: Sequence[int]) -> None:
        """Sum a checked chunk, with segment breaks before its rows ``breaks``."""
        feed = self._feed_omitting if self._settings.nan_policy == "omit" else self._feed
        start = 0
        for stop in breaks:
            feed(meas[start:stop], pred[start:stop], None if reg is None else reg[start:stop])
            self.break_segment()
            start = stop
        feed(meas[start:], pred[start:], None if reg is None else reg[start:])

    def _feed_timed(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None, stamps: FloatArray,
                    breaks: Sequence[int]) -> None:
        """A chunk with its stamps, once the nominal step is known: a gap breaks the segment."""
        assert self._stamps is not None
        keep = self._kept(meas, pred, reg)
        if keep is None:
            gaps = self._stamps.add(stamps, meas)
        else:  # omitted rows' stamps leave the run (a gap, when rows are missing in time)
            gaps = np.flatnonzero(keep)[self._stamps.add(stamps[keep], meas[keep])]
        if gaps.size:
            breaks = sorted(set(breaks).union(int(i) for i in gaps))
        self._feed_chunk(meas, pred, reg, breaks)

    def _kept(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None) -> BoolArray | None:
        """The rows ``nan_policy="omit"`` keeps (None: every row is kept)."""
        if self._settings.nan_policy != "omit":
            return None
        keep = cast(BoolArray, v.in_range(meas).all(axis=1) & v.in_range(pred).all(axis=1))  # (c,)
        if reg is not None:
            keep &= v.in_range(reg.reshape(reg.shape[0], reg.shape[1] * reg.shape[2])).all(axis=1)
        return keep

    def _settle_when_known(self) -> None:
        """Sum the waiting updates once their stamps hold SETTLE_STEPS steps, one of them positive.
        Waiting stamps that never advanced are summed at once (a frozen clock: every step a
        duplicate whatever the grid), so that the rows held stay bounded."""
        if self._waiting is None or self._waiting_rows + self._frozen_rows <= SETTLE_STEPS:
            return
        stamps = self._first_stamps()
        if stamps is not None:
            self._settle(stamps)
        else:
            self._sum_frozen()

    def _sum_frozen(self) -> None:
        """Sum the waiting rows, whose stamps are all equal (no positive step), against a nominal step
        still unknown (NaN: a zero step is a duplicate, never a gap nor irregular, on any grid); the
        nominal step replaces it when the stamps advance (:meth:`_settle`)."""
        assert self._waiting is not None
        events, self._waiting = self._waiting, None
        self._frozen_rows += self._waiting_rows
        self._waiting_rows = 0
        if self._stamps is None:
            self._stamps = Stamps(math.nan, math.nan)
        for event in events:
            if event[0] == "break":
                self.break_segment()
            else:
                self._feed_timed(*event[1:6])
        self._waiting = []

    def _waiting_stamps(self) -> list[FloatArray]:
        """The stamps that set the nominal step: after a summed frozen start its stamp, then the
        waiting rows' kept stamps."""
        assert self._waiting is not None
        parts = [event[6] for event in self._waiting if event[0] == "rows"]
        if self._stamps is not None and self._stamps.last is not None:  # after a summed frozen start
            parts.insert(0, np.array([self._stamps.last]))
        return parts

    def _first_stamps(self, later: Sequence[FloatArray] = ()) -> Stamps | None:
        """The summary that classifies the steps: the nominal step of ``sample_rate``, else the one
        ``_timing`` finds in the waiting stamps (and ``later``'s, in a merge), and their median step
        (which counts the steps of the inferred rate); None without a positive step."""
        parts = [*self._waiting_stamps(), *later]
        t = np.concatenate(parts) if parts else np.zeros(0)
        steps = np.diff(t - t[0]) if t.size else t
        positive = steps[steps > 0]
        if not positive.size:
            return None
        cfg = self._settings
        nominal = _timing.nominal_step(t, steps)
        if cfg.time_units_checked:
            _timing.check_units(nominal)
        if cfg.sample_rate is None:
            if cfg.bandwidth is not None:
                v.check_nyquist(cfg.bandwidth, 1.0 / nominal)
        else:  # checked against these stamps now, before any step is classified against it
            nominal = _timing.given_step(cfg.sample_rate, nominal)
        return Stamps(nominal, float(np.median(positive)))

    def _settle(self, stamps: Stamps) -> None:
        """Classify and sum the waiting updates with the summary ``stamps`` (its nominal step)."""
        assert self._waiting is not None
        events, self._waiting, self._waiting_rows = self._waiting, None, 0
        if self._stamps is None:
            self._stamps = stamps
        else:  # a frozen start, summed before the grid was known: only duplicates, nothing to recentre
            self._stamps.nominal, self._stamps.median = stamps.nominal, stamps.median
        for event in events:
            if event[0] == "break":
                self.break_segment()
            else:
                self._feed_timed(*event[1:6])

    def _checked_time(self, time: ArrayLike | None, c: int) -> FloatArray | None:
        """A chunk's time stamps: given like the chunks before, shape (c,), finite, never
        decreasing (across chunks too); the errors name the chunk and the row in the stream."""
        index, cfg = self._chunks, self._settings
        try:
            if self._timed is not None and self._timed != (time is not None):
                had = "time stamps" if self._timed else "none"
                raise InvalidParameter(f"time must be given with every chunk or with none; the chunks before it "
                                       f"had {had}")
            if time is None:
                if self._timed is None and cfg.bandwidth is not None and cfg.sample_rate is None:
                    v.check_bandwidth(cfg.bandwidth, None)
                return None
            t = _timing.stamps(time, c, self._rows_seen)
            if t.size and self._last_seen is not None and t[0] < self._last_seen:
                raise InvalidParameter(f"time must never decrease, got {float(t[0])!r} at row 0 after "
                                       f"{self._last_seen!r}, the last stamp before this chunk (row "
                                       f"{self._rows_seen} of the stream)")
        except InputError as exc:
            raise type(exc)(f"chunk {index}: {exc}") from None
        return t

    def _checked_motion(self, motion: tuple[ArrayLike | None, ...], shape: tuple[int, ...], timed: bool
                        ) -> tuple[FloatArray, FloatArray | None, FloatArray | None] | None:
        """A chunk's q, dq, ddq: (c, m) finite, given like the chunks before (q with every chunk
        or none; dq, ddq likewise, and only with q); the errors name the chunk."""
        q, dq, ddq = motion
        given = (q is not None, dq is not None, ddq is not None)
        try:
            if q is None and (dq is not None or ddq is not None):
                raise v.parameter_error("dq" if dq is not None else "ddq", "None without q",
                                        dq if dq is not None else ddq)
            if self._motion is not None and self._motion != given:
                name = ("q", "dq", "ddq")[[a != b for a, b in zip(self._motion, given)].index(True)]
                had = "it" if self._motion[("q", "dq", "ddq").index(name)] else "none"
                raise InvalidParameter(f"{name} must be given with every chunk or with none; the chunks before it "
                                       f"had {had}")
            if self._motion is None and self._chunks and given[0]:
                raise InvalidParameter("q must be given with every chunk or with none; the chunks before it had none")
            if q is None:
                return None
            if self._settings.sample_rate is None and not timed and not (given[1] and given[2]):
                raise InvalidParameter("sample_rate must be given (or time stamps with the chunks) to derive dq and "
                                       "ddq from q on a stream")
            c, m = shape[0], shape[1]
            arrays = tuple(None if x is None else v.check_signal_like(x, name, c, m)
                           for x, name in ((q, "q"), (dq, "dq"), (ddq, "ddq")))
        except InputError as exc:
            raise type(exc)(f"chunk {self._chunks}: {exc}") from None
        self._motion = given
        return cast(tuple[FloatArray, FloatArray | None, FloatArray | None], arrays)

    def _feed_physics(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None,
                      moving: tuple[FloatArray, FloatArray | None, FloatArray | None]) -> None:
        """Add the chunk's rows to the physics test's sums (the rows nan_policy keeps), once the
        sample rate is known (``sample_rate``, or the nominal step of the stamps)."""
        keep = self._kept(meas, pred, reg)
        rows: tuple[FloatArray | None, ...] = (meas - pred, *moving, reg)
        if keep is not None:
            rows = tuple(None if x is None else x[keep] for x in rows)
        self._physics_waiting.append(rows)
        rate = self._physics_rate()
        assert self._motion is not None
        if rate is None and self._timed and not (self._motion[1] and self._motion[2]):
            return  # derived q̇, q̈ wait for the stamps' rate (given ones need none)
        if self._physics is None:
            self._physics = PhysicsSums(meas.shape[1], sample_rate=rate, alpha=1.0 - self._settings.level)
        for e, q, dq, ddq, r in self._physics_waiting:
            self._physics.update(e, q, dq, ddq, r)
        self._physics_waiting = []

    def _physics_rate(self) -> float | None:
        """The physics test's sample rate: ``sample_rate``, else the stamps' nominal step's once known."""
        if self._settings.sample_rate is not None:
            return float(self._settings.sample_rate)
        if self._stamps is not None and self._stamps.nominal == self._stamps.nominal and self._stamps.nominal > 0:
            return 1.0 / float(self._stamps.nominal)
        return None

    def break_segment(self) -> None:
        """End the current segment: no lagged product joins the rows before and after this call
        (contract §1.1; means stay overall).

        Returns
        -------
        None

        Examples
        --------
        >>> acc = ValidationAccumulator(n_params=1, max_lag=1)
        >>> acc.update([1.0, 2.0, 3.0], [1.1, 1.9, 3.2])
        >>> acc.break_segment()
        >>> acc.update([4.0, 5.0], [3.9, 5.1])

        Repeated breaks make no empty segment:

        >>> acc.break_segment(); acc.break_segment()
        >>> acc.update([6.0, 7.0], [6.1, 6.8])
        >>> acc.result().provenance["segments"]
        [3, 2, 2]
        """
        if self._waiting is not None:
            self._waiting.append(("break",))
            return
        self._flush()
        if self._state is None:
            self._break_first = True
        else:
            self._state.end_break = True
        if self._welch is not None:
            self._welch.end_segment()
        if self._edges is not None:
            self._edges.end_segment()

    def merge(self, other: ValidationAccumulator) -> ValidationAccumulator:
        """Add ``other``'s data, which come after this accumulator's in time; returns ``self``.

        Lags join across the junction (as between two chunks) unless ``self`` ended, or ``other``
        started, with :meth:`break_segment`. ``other`` is not modified. Both need equal settings
        and the same m (and p). ``(a.merge(b)).merge(c)`` and ``a.merge(b.copy().merge(c))`` give
        the same report.

        With time stamps, both have them or neither, and ``other``'s continue after this one's (its
        first stamp not before this one's last): the step across the junction counts as one between
        two chunks (a gap there breaks the segment); each operand's own steps keep the classification
        of its nominal step (contract §4.1).

        Parameters
        ----------
        other : ValidationAccumulator
            Built with the same settings, holding data of the same m and p.

        Returns
        -------
        ValidationAccumulator
            ``self``, now holding both.

        Examples
        --------
        >>> import dynval
        >>> tau = np.sin(np.arange(200.0)); pred = tau + 0.1 * np.cos(np.arange(200.0) * 0.7)
        >>> a = ValidationAccumulator(n_params=1, max_lag=5); a.update(tau[:120], pred[:120])
        >>> b = ValidationAccumulator(n_params=1, max_lag=5); b.update(tau[120:], pred[120:])
        >>> whole = dynval.validate(tau, pred, n_params=1, max_lag=5)
        >>> rho = a.merge(b).result().autocorrelation["rho"]
        >>> bool(np.max(np.abs(rho - whole.autocorrelation["rho"])) < 1e-14)
        True

        An empty accumulator merges as nothing:

        >>> a.merge(ValidationAccumulator(n_params=1, max_lag=5)).n_samples
        200
        """
        if not isinstance(other, ValidationAccumulator):
            raise v.parameter_error("other", "a ValidationAccumulator", type(other).__name__)
        self._check_same_settings(other)
        self._check_same_layout(other)
        self._check_same_timing(other)
        if any(acc._motion is not None and acc._motion[0] for acc in (self, other)):
            raise InvalidParameter("other cannot be merged: an accumulator updated with q holds the physics test's "
                                   "sums, which do not merge (each fixes its prewhitening filter on its own first "
                                   "rows)")
        later = other.copy()
        self._layout = self._layout or later._layout
        if self._timed is None and later._timed is not None:  # nothing given here yet: the other's way
            self._timed = later._timed
            if later._waiting is not None:
                self._waiting = []
        if later._timed and not self._merge_waiting(later):
            later._flush()
            self._flush()
            assert later._stamps is not None
            if self._stamps is None:
                self._stamps = later._stamps
            elif self._stamps.join(later._stamps):
                self.break_segment()  # a gap at the junction: no lag joins it
        later._flush()
        self._flush()
        if later._state is None:
            if later._break_first:
                self.break_segment()
        else:
            if self._state is None:
                self._state = self._new_state(later._state.layout)
                self._state.end_break = self._break_first
            self._state.merge(later._state)
            self._merge_welch(later)
        self._chunks += other._chunks
        self._rows_seen += other._rows_seen
        self._omitted += other._omitted
        return self

    def _merge_welch(self, later: ValidationAccumulator) -> None:
        """The window periodograms and the segment junctions of a merge (``later`` flushed, with rows)."""
        if later._welch is not None:
            if self._welch is None:
                self._welch = WelchSums(later._welch.m)
                self._welch.start_break = self._break_first
            self._welch.merge(later._welch)
        if later._edges is not None:
            if self._edges is None:
                self._edges = SegmentEdges(later._edges.m, later._edges.k)
                self._edges.start_break = self._break_first
            self._edges.merge(later._edges)

    def _merge_waiting(self, later: ValidationAccumulator) -> bool:
        """The time stamps of a merge: True when both still wait for their nominal step (``later``'s
        updates then simply queue after this one's); else both are settled, one on the other's
        nominal step when it waits."""
        if self._last_seen is not None and later._first_seen is not None and later._first_seen < self._last_seen:
            raise InvalidParameter(f"other's time stamps must continue after this one's, got its first stamp "
                                   f"{later._first_seen!r} before this one's last stamp {self._last_seen!r}")
        self._first_seen = later._first_seen if self._first_seen is None else self._first_seen
        self._last_seen = later._last_seen if later._last_seen is not None else self._last_seen
        if self._waiting is not None and later._waiting is not None and later._stamps is not None:
            return self._merge_frozen_start(later)
        if self._waiting is not None and later._waiting is not None:
            if later._break_first:
                self._waiting.append(("break",))
                later._break_first = False
            self._waiting.extend(later._waiting)
            self._waiting_rows += later._waiting_rows
            self._settle_when_known()
            return True
        if self._waiting is not None:
            assert later._stamps is not None
            self._settle(Stamps(later._stamps.nominal, later._stamps.median))
        elif later._waiting is not None:
            assert self._stamps is not None
            later._settle(Stamps(self._stamps.nominal, self._stamps.median))
        return False

    def _merge_frozen_start(self, later: ValidationAccumulator) -> bool:
        """Both wait for their nominal step, and ``later``'s frozen start is summed already: its rows
        cannot queue after these. Both settle on the nominal step of their waiting stamps together
        (fewer than SETTLE_STEPS perhaps); when none advanced, every step is a duplicate: these rows
        are summed as a frozen start too and ``later``'s waiting updates queue after them (the
        summaries and the states then join as settled ones, the caller's part: returns False)."""
        assert self._waiting is not None and later._waiting is not None
        stamps = self._first_stamps(later._waiting_stamps())
        if stamps is not None:
            self._settle(stamps)
            later._settle(Stamps(stamps.nominal, stamps.median))
            return False
        self._sum_frozen()
        assert self._waiting is not None
        self._waiting.extend(later._waiting)
        self._waiting_rows += later._waiting_rows
        self._frozen_rows += later._frozen_rows
        later._waiting, later._waiting_rows = [], 0
        return False

    def _check_same_timing(self, other: ValidationAccumulator) -> None:
        if self._timed is not None and other._timed is not None and self._timed != other._timed:
            def said(timed: bool) -> str:
                return "with time stamps" if timed else "without time stamps"
            raise InvalidParameter(f"other must be updated {said(self._timed)} like this one, got other updated "
                                   f"{said(other._timed)}")

    def copy(self) -> ValidationAccumulator:
        """An independent copy (merge trees that reuse a partial result need one)."""
        return copy.deepcopy(self)

    def result(self) -> ValidationReport:
        """The report of every row so far (the accumulator stays usable).

        Raises TooFewSamples below 2 rows (or N < m without ``allow_wide``) and InvalidParameter
        when an explicit ``max_lag`` is not below the longest segment (contract §2.1 texts).

        Returns
        -------
        ValidationReport
            The sections ``validate`` gives, some partial or None (contract §4.1).

        Examples
        --------
        >>> acc = ValidationAccumulator(n_params=1, max_lag=1)
        >>> acc.update([1.0, 2.0, 3.0], [1.1, 1.9, 3.2])
        >>> round(float(acc.result().per_joint["rmse"][0]), 6)
        0.141421

        With fewer than 2 rows there is no report:

        >>> ValidationAccumulator(n_params=1).result()
        Traceback (most recent call last):
            ...
        dynval.checks._errors.TooFewSamples: ValidationAccumulator.result needs at least 2 samples, got N=0
        """
        n = self.n_samples
        v.check_min_samples("ValidationAccumulator.result", n, 2)
        assert self._layout is not None  # check_min_samples refused an empty stream
        cfg = self._settings
        v.check_orientation("ValidationAccumulator.result", "tau_meas", (n, self._layout.m), cfg.allow_wide)
        acc = self
        if self._timed:
            first, last = self._first_seen, self._last_seen
            if not (first is not None and last is not None and last > first):
                raise InvalidParameter(f"time must advance, got every stamp equal to {self._first_seen!r}")
            if self._waiting is not None:  # fewer stamps than SETTLE_STEPS: settle a copy on those there are
                acc = self.copy()
                stamps = acc._first_stamps()
                if stamps is None:
                    raise InvalidParameter("time must advance, got every stamp of the rows kept (nan_policy="
                                           "'omit') equal")
                acc._settle(stamps)
        acc._flush()
        st = acc._state
        assert st is not None
        timing = None
        if acc._stamps is not None:
            timing = acc._stamps.timing(cfg.sample_rate, cfg.time_units_checked)
            if cfg.bandwidth is not None:
                v.check_nyquist(cfg.bandwidth, timing.sample_rate)
        elif cfg.bandwidth is not None and cfg.sample_rate is None:
            v.check_bandwidth(cfg.bandwidth, None)
        return _report(st.snapshot(), cfg, acc._omitted, timing, acc._welch, self._entry, acc._edges,
                       acc._physics_section())

    def _physics_section(self) -> dict[str, Any] | None:
        """The report's physics section from the sums (on a copy: the stream goes on), as
        ``validate``'s (:func:`dynval.report._motion.physics`) without what needs the rows again: the
        naming refits on the estimation run, the cross-fitted shares and the relation to the model's
        columns. None without q, or when rows were omitted (``validate`` then has none either)."""
        if self._motion is None or not self._motion[0] or self._omitted:
            return None
        sums = copy.deepcopy(self._physics)
        if self._physics_waiting:
            if sums is None:
                assert self._layout is not None
                sums = PhysicsSums(self._layout.m, sample_rate=self._physics_rate(),
                                   alpha=1.0 - self._settings.level)
            for rows in self._physics_waiting:
                sums.update(*rows)
        if sums is None:
            return None
        tests = sums.tests()
        for t in tests:  # the named term's effect is its share in sample (nothing to cross-fit on)
            t.refit_run = "stream" if t.term is not None else None
        method, band = sums.derivative_method()
        regressor = self._layout is not None and self._layout.p > 0
        return {"naming": "the group that alone removes nearly the most of the validation residual, fewest columns "
                          "first",
                "method": ("prewhitened least squares (AR(≤ 2) by BIC), heteroscedasticity-robust Wald test per joint; "
                           f"from chunks: the prewhitening filter, the Coulomb velocity scale and N_eff/N fixed on "
                           f"the first {sums.first_block} rows, the HC1 meat from the rows up to {sums.meat_rows}, "
                           f"past them weighted by the residual of the first rows' fit; every row tested "
                           f"(no decimation); conventions §5.2"),
                "model_columns": ("refitted on the validation run (what they represent is not missing)" if regressor
                                  else "none (no regressor: the model's own columns are unknown)"),
                "derivatives": method, "derivative_bandwidth_hz": band, "derivative_source": "savgol",
                "estimation_bandwidth_hz": None, "groups": list(_physics.GROUPS), "tests": [t.to_dict() for t in tests],
                "model_kinds": None, "simulator_parameters": None,
                "pvalue": np.array([t.pvalue for t in tests]), "share": np.array([t.share for t in tests]),
                "n_eff": np.array([t.n_eff for t in tests])}

    # ----------------------------------------------------------------------- chunks

    def _checked_chunk(self, tau_meas: ArrayLike, tau_pred: ArrayLike,
                       regressor: ArrayLike | None) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """The contract's data checks on one chunk, then its agreement with the chunks before it."""
        index = self._chunks
        try:
            meas, pred, reg0, shape, _ = v.torque_pair(tau_meas, tau_pred, regressor)
            c, m = meas.shape
            self._check_continues(shape, m, reg0)
            reg = None
            if reg0 is not None:
                p = v.regressor_shape(reg0, "tau_meas", c, m, self._settings.n_joints)
                self._check_columns(reg0.shape, p)
                reg = v.regressor_to_2d(reg0, c, m, p).reshape(c, m, p)
            if self._layout is None:
                self._check_names(m, None if reg is None else reg.shape[2])
            if self._settings.nan_policy == "raise":
                # the backend's scan: the C++ core's is one compiled pass over the chunk
                arrays: list[Array] = [("tau_meas", meas, None), ("tau_pred", pred, None)]
                if reg is not None:
                    arrays.append(("regressor", reg.reshape(c, m * reg.shape[2]), reg.shape[2]))
                CheckedCall("ValidationAccumulator.update", arrays, scan=self._settings.kernel.first_nonfinite,
                            first_row=self._rows_seen).require_finite()
        except InputError as exc:
            raise type(exc)(f"chunk {index}: {exc}") from None
        return meas, pred, reg

    def _check_continues(self, shape: tuple[int, ...], m: int, reg0: FloatArray | None) -> None:
        n_joints = self._settings.n_joints
        if n_joints is not None and m != n_joints:
            raise ShapeMismatch(f"tau_meas must have n_joints={n_joints} columns, got shape {v.format_shape(shape)}")
        layout = self._layout
        if layout is None:
            return
        if m != layout.m:
            raise ShapeMismatch(f"tau_meas must have m={layout.m} columns like the chunks before it, got shape "
                                f"{v.format_shape(shape)}")
        if (reg0 is None) != (layout.p == 0):
            had = "one" if layout.p else "none"
            raise ShapeMismatch("regressor must be given with every chunk or with none; the chunks before it "
                                f"had {had}")

    def _check_columns(self, shape: tuple[int, ...], p: int) -> None:
        layout = self._layout
        if layout is not None and p != layout.p:
            raise ShapeMismatch(f"regressor must have p={layout.p} columns like the chunks before it, got shape "
                                f"{v.format_shape(shape)}")

    def _check_names(self, m: int, p: int | None) -> None:
        """The names, once the first chunk tells m and p (validate's checks)."""
        cfg = self._settings
        check_joint_names(cfg.joint_names, m)
        check_column_names(cfg.column_names, p, show=list)

    def _feed_omitting(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None) -> None:
        """``nan_policy="omit"``: delete bad rows; a break where rows were deleted (contract §1.2)."""
        keep = self._kept(meas, pred, reg)
        assert keep is not None  # nan_policy="omit"
        self._omitted += int(keep.size - keep.sum())
        edges = np.flatnonzero(np.diff(np.concatenate(([0], keep.astype(np.int8), [0]))))
        for a, b in zip(edges[0::2], edges[1::2]):  # runs of kept rows [a, b)
            if a > 0:
                self.break_segment()
            self._feed(meas[a:b], pred[a:b], None if reg is None else reg[a:b])
        if keep.size and not keep[-1]:
            self.break_segment()

    def _feed(self, meas: FloatArray, pred: FloatArray, reg: FloatArray | None) -> None:
        if meas.shape[0] == 0:
            return
        self._pending.append((meas, pred, reg))
        self._pending_rows += meas.shape[0]
        if self._pending_rows >= _buffer_rows(self._known_layout):
            self._flush()
        else:
            # Rows kept for later are copied: the caller may refill its buffer for the next chunk.
            self._pending[-1] = (meas.copy(), pred.copy(), None if reg is None else reg.copy())

    def _flush(self) -> None:
        """Sum the gathered rows as blocks of one segment."""
        if not self._pending:
            return
        layout = self._known_layout
        meas, pred, reg = (None if parts[0] is None else np.concatenate(parts) if len(parts) > 1 else parts[0]
                           for parts in zip(*self._pending))
        assert meas is not None and pred is not None  # only the regressor is optional
        self._pending, self._pending_rows = [], 0
        if self._state is None:
            self._state = self._new_state(layout)
            self._state.end_break = self._break_first
        self._state.append_measured(meas, pred, reg, _block_rows(layout))
        if layout.acf_lags:
            e = meas - pred
            if self._edges is None:
                self._edges = SegmentEdges(layout.m, layout.acf_lags)
                self._edges.start_break = self._break_first
            self._edges.add(e)
            if not layout.p:  # validate's spectrum needs lags; with a regressor, it is of the projection
                if self._welch is None:
                    self._welch = WelchSums(layout.m)
                    self._welch.start_break = self._break_first
                self._welch.add(e)

    def _new_state(self, layout: Layout) -> State | CoreState:
        return CoreState(layout) if self._settings.backend == "cpp" else State(layout)

    @property
    def _known_layout(self) -> Layout:
        """The layout, which the first chunk sets before any rows are gathered."""
        assert self._layout is not None
        return self._layout

    def _new_layout(self, m: int, p: int) -> Layout:
        cfg = self._settings
        prof = cfg.profile
        xcorr = prof.max_lag_cap if cfg.max_lag is None else cfg.max_lag
        assert xcorr is not None  # _check_max_lag refused max_lag=None for a profile without a cap
        if xcorr == 0:
            layout = Layout(m=m, p=p, acf_lags=0, xcorr_lags=0, gram=cfg.noise_model == "full")
        else:
            acf = max(xcorr, newey_west_bandwidth(ZERO_MEAN_MAX_SAMPLES),
                      10 if prof.ljung_box_rule == "statsmodels" else 0)
            layout = Layout(m=m, p=p, acf_lags=acf, xcorr_lags=xcorr, gram=cfg.noise_model == "full")
        # Refused from the first chunk's shape, before any sum is allocated (contract §4.1).
        too_large = state_too_large(layout)
        if too_large is not None:
            raise InvalidParameter(f"max_lag={v.format_value(cfg.max_lag)}: {too_large}; lower max_lag (0 holds no "
                                   f"lags) or stream fewer columns")
        return layout

    # ----------------------------------------------------------------------- merge checks

    def _check_same_settings(self, other: ValidationAccumulator) -> None:
        for name in _MERGED_SETTINGS:
            mine, theirs = getattr(self._settings, name), getattr(other._settings, name)
            if mine != theirs:
                shown: Callable[[Any], Any] = (lambda x: x.name) if name == "profile" else (lambda x: x)
                raise InvalidParameter(f"other must be a ValidationAccumulator with the same settings, got {name}="
                                       f"{v.format_value(shown(theirs))} where this one has {name}="
                                       f"{v.format_value(shown(mine))}")

    def _check_same_layout(self, other: ValidationAccumulator) -> None:
        mine, theirs = self._layout, other._layout
        if mine is not None and theirs is not None and (mine.m, mine.p) != (theirs.m, theirs.p):
            raise ShapeMismatch(f"other must hold data of the same shape, got m={theirs.m} joints and "
                                f"p={theirs.p} regressor columns where this one has m={mine.m} and p={mine.p}")


def _buffer_rows(layout: Layout) -> int:
    """Rows gathered before they are summed (a block shorter than its lags costs as much as a long one)."""
    return max(_MIN_BLOCK_ROWS, 4 * (layout.acf_lags + 1))


def _block_rows(layout: Layout) -> int:
    per_row = layout.m * (layout.p + 2)
    return int(min(_MAX_BLOCK_ROWS, max(4 * (layout.acf_lags + 1), _MAX_BLOCK_VALUES // per_row)))


# --------------------------------------------------------------------------- the report


@dataclass
class _Moments:
    """Centred sums of the whole stream, from the accumulated state, in the units 2^exp of their
    columns (``exp_e``, ``exp_t``, ``exp_y``: the state's power-of-two exponents, contract §4.1)."""

    n: int
    m: int
    mean_e: np.ndarray  # (m,), scaled by 2^-exp_e
    cov_e: np.ndarray  # (L+1, m): Σ(e_t − ē)(e_{t−ℓ} − ē) over the pairs, scaled by 4^-exp_e
    e_constant: np.ndarray
    mean_t: np.ndarray
    tss: np.ndarray
    t_constant: np.ndarray
    pairs: np.ndarray  # (L+1,) n_ℓ
    cov_ey: np.ndarray | None  # (Lx+1, m, p), scaled by 2^-(exp_e + exp_y)
    ss_y: np.ndarray | None  # (m, p)
    y_constant: np.ndarray | None
    sigma: np.ndarray | None  # EᵀE/N (full noise model), scaled by 4^-max(exp_e)
    exp_e: np.ndarray
    exp_t: np.ndarray
    cur1: np.ndarray | None = None  # (m,) Σ(e − ē) over the current elements of the lag-1 pairs, scaled
    lag1: np.ndarray | None = None  # (m,) and over their lagged elements


def _moments(st: State | Snapshot) -> _Moments:
    """Centre every sum on the overall means (contract §1.1: means are overall)."""
    n, m = st.n, st.layout.m
    cur, lag, pairs = st.cur_e.value(), st.lag_e.value(), st.pairs
    a = cur[0] / n  # ē − K_e, tiny: the centres follow the running means
    cov_e = st.prod_e.value() - a * (cur + lag) + pairs[:, None] * a * a
    e_constant = st.min_e == st.max_e
    cov_e[0] = np.where(e_constant, 0.0, np.maximum(cov_e[0], 0.0))
    s_t = st.sum_t.value()
    t_constant = st.min_t == st.max_t
    tss = np.where(t_constant, 0.0, np.maximum(st.sq_t.value() - s_t * s_t / n, 0.0))
    cov_ey = ss_y = y_constant = sigma = None
    if st.layout.p:
        lag_y = st.lag_y.value()
        b = lag_y[0] / n
        lx = st.layout.xcorr_lags
        cov_ey = (st.prod_ey.value() - b[None] * cur[: lx + 1, :, None] - a[None, :, None] * lag_y
                  + pairs[: lx + 1, None, None] * a[None, :, None] * b[None])
        y_constant = st.min_y == st.max_y
        ss_y = np.where(y_constant, 0.0, np.maximum(st.sq_y.value() - lag_y[0] * lag_y[0] / n, 0.0))
    mean_e = st.k_e + a
    if st.gram is not None:
        # one exponent for the whole matrix, the largest joint's (contract §1.3: over the whole residual)
        shift = st.exp_e - st.exp_e.max()
        s = cur[0]
        centred = np.ldexp(st.gram.value() - np.outer(s, s) / n, shift[:, None] + shift[None, :])
        mean_c = np.ldexp(mean_e, shift)
        sigma = centred / n + np.outer(mean_c, mean_c)  # not demeaned (MATLAB's multi-output convention)
    lagged = cur.shape[0] > 1
    return _Moments(n=n, m=m, mean_e=mean_e, cov_e=cov_e, e_constant=e_constant, mean_t=st.k_t + s_t / n,
                    tss=tss, t_constant=t_constant, pairs=pairs, cov_ey=cov_ey, ss_y=ss_y, y_constant=y_constant,
                    sigma=sigma, exp_e=st.exp_e, exp_t=st.exp_t,
                    cur1=cur[1] - pairs[1] * a if lagged else None, lag1=lag[1] - pairs[1] * a if lagged else None)


def _pooled_ss(ss: np.ndarray, centre: np.ndarray, offset: np.ndarray, exps: np.ndarray, n: int,
               constant: bool) -> tuple[float, int]:
    """Σ over all N·m values of (x − x̄)² from per-joint parts: Σ_j SS_j + N Σ_j (x̄_j − x̄)², both ≥ 0,
    as a scaled sum (s, K): the value s·4^K, K the largest of the joints' exponents ``exps``.

    Joint j's mean is ``centre[j] + offset[j]`` (in units 2^exps[j]); the differences between means
    are taken on that pair (centres first, they are close floats), so the low digits of the offsets
    are not rounded away against a large common mean.
    """
    top = int(exps.max())
    if constant:
        return 0.0, top
    shift = exps - top
    d = (np.ldexp(centre, shift) - np.ldexp(centre[0], shift[0])) + np.ldexp(offset, shift)
    return float(np.sum(np.ldexp(ss, 2 * shift)) + n * np.sum((d - np.mean(d)) ** 2)), top


def _fused_metrics(mo: _Moments, st: State | Snapshot, n_params: int, ddof: int, noise_model: str) -> FusedMetrics:
    """The fields of the fused ``compute_metrics`` kernel (contract §5.1) from the moments."""
    n, m = mo.n, mo.m
    ssc_e = mo.cov_e[0]
    # Scaled sums (value s·4^k, k the columns' exponents, contract §4.1), as validate's kernels give them.
    exp_e, exp_t = mo.exp_e, mo.exp_t
    sse_s = ssc_e + n * mo.mean_e * mo.mean_e  # both terms ≥ 0: nothing cancels
    total_s, total_k = pooled_sum(sse_s, exp_e)
    sse_total = float(np.ldexp(total_s, 2 * total_k))
    parts = {"sse": sse_s, "tss": mo.tss, "ssc_e": ssc_e, "constant": mo.t_constant, "e_constant": mo.e_constant,
             "sse_exp": exp_e, "tss_exp": exp_t, "ssc_e_exp": exp_e}
    t_flat = bool(st.min_t.min() == st.max_t.max())
    e_flat = bool(st.min_e.min() == st.max_e.max())
    tss_pooled, tss_k = _pooled_ss(mo.tss, st.k_t, st.sum_t.value() / n, exp_t, n, t_flat)
    ssc_pooled, ssc_k = _pooled_ss(ssc_e, st.k_e, st.cur_e.value()[0] / n, exp_e, n, e_flat)
    flat = {"sse": np.array([total_s]), "tss": np.array([tss_pooled]), "ssc_e": np.array([ssc_pooled]),
            "constant": np.array([t_flat]), "e_constant": np.array([e_flat]),
            "sse_exp": np.array([total_k]), "tss_exp": np.array([tss_k]), "ssc_e_exp": np.array([ssc_k])}
    rmse = np.ldexp(np.sqrt(sse_s / n), exp_e)
    vaf, fit, r2 = vaf_values(parts), fit_values(parts), r2_values(parts)
    max_abs = np.maximum(np.abs(st.min_e), np.abs(st.max_e))
    f, n_ic, n_vec, size = fit_term_from_sums(noise_model, n, m, (sse_s, exp_e), mo.sigma, int(exp_e.max()))
    ic = assemble(f, n_ic, n_vec, size, n_params)
    return {
        "n_samples": n, "n_joints": m, "n_params": n_params, "sse": np.ldexp(sse_s, 2 * exp_e), "rmse": rmse,
        "max_abs_error": max_abs, "vaf": vaf, "fit_percent": fit, "r2": r2,
        "residual_mean": np.ldexp(mo.mean_e, exp_e), "residual_variance": np.ldexp(ssc_e / (n - ddof), 2 * exp_e),
        "constant_target": mo.t_constant.copy(), "sse_total": sse_total,
        "rmse_per_element": float(np.ldexp(math.sqrt(total_s / (n * m)), total_k)),
        "rmse_per_sample": float(np.ldexp(math.sqrt(total_s / n), total_k)),
        "max_abs_error_pooled": float(max_abs.max()),
        "vaf_pooled": float(vaf_values(flat)[0]), "fit_percent_pooled": float(fit_values(flat)[0]),
        "r2_pooled": float(r2_values(flat)[0]), "constant_target_pooled": t_flat,
        "rmse_uniform_average": float(np.mean(rmse)), "vaf_uniform_average": uniform_average(vaf),
        "fit_percent_uniform_average": uniform_average(fit), "r2_uniform_average": uniform_average(r2),
        "vaf_variance_weighted": variance_weighted(vaf, parts),
        "fit_percent_variance_weighted": variance_weighted(fit, parts),
        "r2_variance_weighted": variance_weighted(r2, parts),
        "aic": ic["aic"], "bic": ic["bic"], "aicc": ic["aicc"], "fpe": ic["fpe"], "naic": ic["naic"],
    }


class _Kernel:
    """The two kernel calls of the report's section builders (``_sections``), answered from the
    centred sums: the builders then add the bands, the lags outside and the p-values as for
    ``validate``. The data arguments are unused: the sums stand for them."""

    def __init__(self, mo: _Moments) -> None:
        self.mo = mo

    def autocorrelation(self, e: object, max_lag: int, adjusted: bool, starts: object) -> FloatArray:
        mo = self.mo
        ss = mo.cov_e[0]
        denom = mo.pairs[: max_lag + 1].astype(float) if adjusted else np.full(max_lag + 1, float(mo.n))
        with np.errstate(divide="ignore", invalid="ignore"):
            rho: FloatArray = (mo.cov_e[: max_lag + 1] / denom[:, None]) / (ss / mo.n)
        rho[0] = 1.0
        rho[:, mo.e_constant | (ss == 0)] = np.nan
        return rho

    def portmanteau(self, e: object, lags: IntArray, model_df: int, starts: object, test: str) -> dict[str, Any]:
        mo = self.mo
        n = mo.n
        h = int(np.max(lags))
        rho = self.autocorrelation(None, h, False, None)[1:]
        cumulative = n * (n + 2.0) * np.cumsum(rho**2 / mo.pairs[1: h + 1, None], axis=0)
        statistic = cumulative[np.asarray(lags) - 1]
        df = np.asarray(lags) - model_df
        return {"statistic": statistic, "pvalue": np.asarray(scipy.stats.chi2.sf(statistic, df[:, None])),
                "log_pvalue": chi2_logsf(statistic, df[:, None]), "df": df.astype(np.int64)}


def _zero_mean_test(mo: _Moments, kernel: _Kernel, longest: int, lags_held: int) -> dict[str, Any]:
    """``zero_mean_test`` (contract §3.3) from the sums; the N_eff half None past its lags."""
    n = mo.n
    mean = mo.mean_e  # scaled by 2^-exp_e: the t statistics do not see the scale, the report does
    std = np.sqrt(mo.cov_e[0] / (n - 1))
    t_iid, p_iid = iid_t_test(mean, std, n)
    k = newey_west_bandwidth(n)
    k_used = min(k, longest - 1)
    eff: dict[str, Any] = {"statistic_eff": None, "pvalue_eff": None, "df_eff": None, "n_eff": None, "bandwidth": None}
    if k_used <= lags_held:
        n_eff = newey_west_n_eff(np.asarray(kernel.autocorrelation(None, k_used, False, None)), k, n)
        t_eff, p_eff = iid_t_test(mean, std, n_eff)
        eff = {"statistic_eff": t_eff, "pvalue_eff": p_eff, "df_eff": n_eff - 1.0, "n_eff": n_eff, "bandwidth": k}
    zmt = ZeroMeanTest(mean=np.ldexp(mean, mo.exp_e), std=np.ldexp(std, mo.exp_e), n_samples=n,
                       statistic_iid=t_iid, pvalue_iid=p_iid, df_iid=n - 1, **eff)
    return {f: getattr(zmt, f) for f in zmt.__dataclass_fields__}


def _bias_test(mo: _Moments, st: State | Snapshot, rmse: np.ndarray, longest: int,
               edges: SegmentEdges | None = None) -> tuple[rec.Bias | None, str | None]:
    """``validate``'s bias test (contract §3.3, docs/conventions.md §5.4) from the lagged sums: the
    same prewhitened Bartlett long-run variance, its autocovariances the stream's, corrected at the
    stream's two ends with the rows the state keeps there and at the inner segment junctions with
    ``edges``. None, and why, when Andrews' bandwidth needs more lags than the stream holds."""
    assert mo.cur1 is not None and mo.lag1 is not None  # lags are held
    held = mo.cov_e.shape[0] - 1

    def centred(rows: np.ndarray, length: int) -> np.ndarray | None:
        # the rows of a segment longer than the lags held (the end terms assume it), in the sums' units
        return np.ldexp(rows, -mo.exp_e[None]) - mo.mean_e if length > held and rows.shape[0] >= held else None

    head, tail = centred(st.head_e, st.lengths[0]), centred(st.tail_e, st.lengths[-1])
    starts = None if head is None else (head * head[0], head)
    ends = None if tail is None else (tail[::-1] * tail[-1], tail[::-1])
    if edges is not None:
        inner_starts, inner_ends = edges.centred(mo.mean_e, mo.exp_e)
        starts, ends = _added(starts, inner_starts, held), _added(ends, inner_ends, held)
    lr, needed = _stats.long_run_variance_from_sums(mo.cov_e, mo.pairs, mo.n, mo.cur1, mo.lag1, longest,
                                                    starts=starts, ends=ends)
    if lr is None:
        return None, (f"its bandwidth needs the residual's autocovariance at {needed} lags and the stream holds "
                      f"{held}: pass max_lag={needed} or more")
    return sec.bias_section(_stats.bias_t_test(mo.mean_e, lr, mo.n, exponents=mo.exp_e), rmse), None


def _added(a: tuple[np.ndarray, np.ndarray] | None, b: tuple[np.ndarray, np.ndarray] | None,
           rows: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The sum of two (products, values) pairs of edge sums over their first ``rows`` rows."""
    if a is None or b is None:
        return a if b is None else b
    return a[0][:rows] + b[0][:rows], a[1][:rows] + b[1][:rows]


def _cross_correlation(mo: _Moments, max_lag: int, prof: Profile, level: float) -> rec.CrossCorrelation:
    """ρ of the residual with every regressor column at lags 0..max_lag (contract §3.6) and the
    white band; the colour-aware fields of ``validate``'s section need whole series (§4.1)."""
    n = mo.n
    assert mo.cov_ey is not None and mo.ss_y is not None and mo.y_constant is not None  # a regressor was given
    ss_e = mo.cov_e[0]
    denom = mo.pairs[: max_lag + 1].astype(float) if prof.adjusted else np.full(max_lag + 1, float(n))
    # Two roots, never the root of the product (contract §1.3); each sum in its columns' units, so
    # the exponents cancel in the ratio.
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = (mo.cov_ey[: max_lag + 1] / denom[:, None, None]) / (np.sqrt(ss_e / n)[:, None] * np.sqrt(mo.ss_y / n))
    bound = (n / denom)[:, None, None]  # Cauchy-Schwarz: |rho(l)| <= N/D_l, whatever the rounding (contract §3.6)
    rho = np.clip(rho, -bound, bound)
    rho = np.moveaxis(rho, 0, 2).copy()  # (m, p, L+1)
    dead = mo.y_constant | (mo.e_constant | (ss_e == 0))[:, None] | (mo.ss_y == 0)
    rho[dead] = np.nan
    band = z_two_sided(level) / math.sqrt(n)
    with np.errstate(invalid="ignore"):
        hits = np.argwhere(np.abs(rho) > band)
    outside = sorted(((int(j), int(c), int(lag), float(rho[j, c, lag]), float(abs(rho[j, c, lag]) / band))
                      for j, c, lag in hits), key=lambda t: (-t[4], t[0], t[1], t[2]))
    return rec.CrossCorrelation.of({"max_lag": int(max_lag), "adjusted": bool(prof.adjusted),
                                    "constant_mask": mo.y_constant.copy(), "band": float(band), "level": float(level),
                                    "n_outside_white_band": len(hits), "rho": rho, "outside": outside})


def _untested_count(mo: _Moments, lagged: bool, spec: rec.Spectrum | None, cross: rec.CrossCorrelation | None,
                    starts: np.ndarray) -> int:
    """The tests ``validate`` would add to the Holm family on the same data that a stream leaves
    out: every spectral bin it tests on each varying joint, and the colour-aware cross-correlation's
    cells (docs/conventions.md §5)."""
    count = 0
    if lagged and spec is None:
        varying = int(np.count_nonzero(~mo.e_constant & (mo.cov_e[0] > 0)))
        count += varying * _stats.spectrum_tests_per_joint(starts, mo.n)
    if cross is not None:
        count += int(np.count_nonzero(np.isfinite(cross.rho)))
    return count


def _spectrum(mo: _Moments, welch: WelchSums | None, starts: np.ndarray,
              sample_rate: float | None) -> tuple[tuple[rec.Spectrum, _stats.Spectrum] | None, str | None]:
    """``validate``'s spectrum section and peak tests from the window periodograms (no regressor:
    with one, ``validate`` projects it out first), or None and why not."""
    if welch is None:
        return None, None  # a regressor was given: the declaration says why (dynval.coverage)
    if welch.off_grid is not None:
        return None, welch.off_grid
    nperseg = _stats._default_nperseg(starts, mo.n, None)
    if nperseg not in SIZES:
        return None, f"the longest segment holds {nperseg} rows, fewer than a Welch window of {SIZES[0]}"
    fs = 1.0 if sample_rate is None else float(sample_rate)
    k = _stats._rate_exponent(fs)
    rate = math.ldexp(fs, -k)
    power, windows = welch.power(nperseg, mo.exp_e)
    freq = np.fft.rfftfreq(nperseg, 1.0) * rate
    if power is not None:
        power = power / rate  # a density per unit of the rate, as scipy's welch at fs = rate
    spec = _stats.spectrum_from_welch(freq, power, windows, mo.cov_e[0] / mo.n, mo.exp_e, k, nperseg)
    return (sec.spectrum_section(spec, sample_rate, False), spec), None


def _report(st: State | Snapshot, cfg: Options, omitted: int,
            timing: _timing.Timing | None = None, welch: WelchSums | None = None,
            entry: str = "stream", edges: SegmentEdges | None = None,
            physics: dict[str, Any] | None = None) -> ValidationReport:
    """The sections mergeable sums allow (no design or motion, no spectrum with a regressor: they
    need the whole series, contract §4.1; the tests left out named in ``not_tested``), then the
    assembler every report goes through."""
    prof = cfg.profile
    sample_rate = cfg.sample_rate if timing is None else timing.sample_rate
    n, m, p = st.n, st.layout.m, st.layout.p
    starts = np.concatenate(([0], np.cumsum(st.lengths[:-1]))).astype(np.int64)
    lags = plan_lags(cfg, n, starts)
    max_lag = lags.max_lag
    mo = _moments(st)
    kernel = _Kernel(mo)
    km = _fused_metrics(mo, st, cfg.n_params, prof.ddof, cfg.noise_model)
    per_joint, pooled, aggregates = sec.point_metrics(km, prof)
    lagged = max_lag > 0
    zmt = (_zero_mean_test(mo, kernel, lags.longest, st.layout.acf_lags) if lagged
           else _stats.iid_zero_mean(km["residual_mean"], km["residual_variance"], n, prof.ddof)._asdict())
    residuals = rec.Residuals.of({"mean": np.asarray(km["residual_mean"], dtype=np.float64),
                                  "variance": np.asarray(km["residual_variance"], dtype=np.float64),
                                  "ddof": prof.ddof, "zero_mean_test": zmt})
    skipped: dict[str, str] = {}
    bias = None
    if lagged:
        bias, why = _bias_test(mo, st, per_joint.rmse, lags.longest, edges)
        if why is not None:
            skipped["bias"] = why
    ic = sec.information_criteria(km, prof, cfg.noise_model, n, m, cfg.n_params, None if bias is None else bias.n_eff)
    lb_lags = lags.lb_lags
    acf = lb = white = spec = spec_tests = None
    if lagged:
        acf = sec.autocorrelation(kernel, None, max_lag, prof, cfg.level, starts, n)
        if lb_lags:
            lb = sec.ljung_box(kernel, None, lb_lags, starts)
            white = sec.whiteness(kernel, lb, None, sample_rate, bandwidth=cfg.bandwidth)
    cross = _cross_correlation(mo, max_lag, prof, cfg.level) if p else None
    if lagged:
        spectral, why = _spectrum(mo, welch, starts, sample_rate)
        if spectral is not None:
            spec, spec_tests = spectral
        elif why is not None:
            skipped["spectrum"] = why
    physical = design = None
    if physics is not None:
        physical = rec.Physics.of(physics)
        # validate's design section of a run without an estimation run: what the physical terms leave
        design = rec.Design.of({"noise_n_eff": np.asarray(physics["n_eff"], dtype=float),
                                "detectable_share": detectable_share(physics["n_eff"], m, cfg.level)})
    b = Sections(km=km, per_joint=per_joint, pooled=pooled, aggregates=aggregates, residuals=residuals, ic=ic,
                 bias=bias, acf=acf, lb=lb, lb_lags=lb_lags, white=white, spec=spec, spec_tests=spec_tests,
                 cross=cross, design=design, physics=physical,
                 untested=_untested_count(mo, acf is not None, spec, cross, starts))
    given = {"lags"} if lagged else set()
    given |= ({"regressor"} if p else set()) | ({"time"} if timing is not None else set())
    given |= {"q"} if physics is not None else set()
    s = to_setting(cfg, lags, m, sample_rate=sample_rate, timing=timing, streaming=True,
                   not_tested=not_tested(entry, given, skipped))
    prov = provenance(s, b, n=n, m=m, p_cols=p, lengths=st.lengths, seg_names=None, omitted=omitted)
    if physics is not None:  # what the streamed physics test fixed on its first rows (conventions §5.2)
        prov["conventions"]["physics_stream"] = physics["method"].split("; ", 1)[1]
    return assemble_report(s, b, prov, n=n, m=m, omitted=omitted)
