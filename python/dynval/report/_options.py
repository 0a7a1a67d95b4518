"""The settings of a report, checked once: ``validate``'s keywords, and the accumulator's.

``validate`` and :class:`dynval.stream.ValidationAccumulator` take the same keywords; the
accumulator refuses those that need the whole series (:data:`UNSUPPORTED`). :func:`check_options`
checks each in the contract's order (§2.1): n_params, n_joints, profile, nan_policy, segments,
max_lag, level, backend, noise_model, sample_rate, time_units_checked, time, bandwidth, decimate, joint_names,
column_names, q, dq, ddq, estimation, thresholds, cross_correlation_detail, model_columns,
allow_wide, with one function per setting for both, and returns one frozen :class:`Options`.
``validate`` passes what its data tell (:class:`Data`) and runs the checks deferred
(``_checks.CheckedCall``: a non-finite value in the data wins over a bad setting); the
accumulator passes None before its first chunk: the checks that need m or p wait for it
(:func:`check_joint_names`, :func:`check_column_names`).

The lags of the report (:class:`Lags`: the segments, the largest lag and where it comes from,
the motion's information band) are chosen once the data are known, by :func:`plan_lags`, for
``validate`` from the whole series and for the accumulator from its sums.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..checks import _timing
from ..checks import _validation as v
from ..checks._errors import InvalidParameter, ShapeMismatch
from ..checks._segments import longest_segment, parse_segments
from ..checks._typing import BackendName, FloatArray, IntArray, Kernels
from ..kernels._backend import resolve
from ..metrics._profiles import Profile, get_profile
from ._assembly import Setting
from ._findings import Thresholds, resolve_thresholds

__all__ = ["Keywords", "Data", "Options", "Lags", "UNSUPPORTED", "check_options", "plan_lags", "to_setting"]

UNSUPPORTED = {
    "segments": "call break_segment() between records instead",
    "decimate": "whiteness at the information rate needs the whole series",
    "q": "give q (and dq, ddq) with each chunk: update(..., q=...)",
    "estimation": "the estimation run's refit and repeat check need whole series",
    "cross_correlation_detail": "the colour-aware cross-correlation needs the whole series; rho is always given",
    "model_columns": "the added-variable test projects whole columns",
}
"""Keywords of ``validate`` the accumulator refuses unless None, with the reason."""

MOTION_LAG_SOURCE = "motion: one period of the information band's edge"


@dataclass(frozen=True)
class Keywords:
    """The settings as the caller gave them, unchecked (``validate``'s defaults)."""

    n_params: Any
    n_joints: Any = None
    profile: Any = "lesson"
    nan_policy: Any = "raise"
    segments: Any = None
    max_lag: Any = None
    level: Any = None
    backend: Any = None
    noise_model: Any = None
    sample_rate: Any = None
    time: Any = None
    time_units_checked: Any = True
    bandwidth: Any = None
    decimate: Any = "auto"
    joint_names: Any = None
    column_names: Any = None
    q: Any = None
    dq: Any = None
    ddq: Any = None
    estimation: Any = None
    thresholds: Any = None
    cross_correlation_detail: Any = "top"
    model_columns: Any = None
    allow_wide: Any = False


class Data(NamedTuple):
    """What ``validate``'s data tell the checks of its settings (after the data step)."""

    n: int  # samples, after nan_policy="omit"
    m: int
    p: int | None  # regressor columns
    reg_shape: tuple[int, ...] | None  # the regressor's shape as given (n_joints is checked against it)
    starts: IntArray | None  # the caller's segments, parsed before omission (nan_policy="omit")
    given_n: int  # samples as given (time stamps, q, dq, ddq have as many)
    kept_rows: IntArray | None  # the rows kept by the omission (None: every row)
    meas: FloatArray  # tau_meas after omission (the time stamps' repeated rows)


@dataclass(frozen=True, eq=False)
class Options:
    """The checked settings: ``validate``'s, or the accumulator's (which has no data yet: the
    fields that need the whole series are None there, its names wait for its first chunk)."""

    n_params: int
    n_joints: int | None
    profile: Profile
    nan_policy: str
    max_lag: int | None  # as given (None: the profile's default, or the motion's, plan_lags)
    level: float
    backend: BackendName
    noise_model: str
    sample_rate: float | None  # given, or validate's from the time stamps
    time_units_checked: bool
    bandwidth: float | None
    joint_names: tuple[str, ...] | None
    column_names: tuple[str, ...] | None
    thresholds: Thresholds
    allow_wide: bool
    # validate's only: what needs the whole series
    starts: IntArray | None = None  # segment starts, split at the time stamps' gaps
    timing: _timing.Timing | None = None
    decimate: str | int | None = None
    q: FloatArray | None = None
    dq: FloatArray | None = None
    ddq: FloatArray | None = None
    estimation: dict[str, FloatArray] | None = None
    detail: str = "top"
    model_columns: list[int] | None = None

    @property
    def kernel(self) -> Kernels:
        """The kernels of the checked backend."""
        return resolve(self.backend)[1]


class Lags(NamedTuple):
    """The frame of a report's lag analysis, chosen once the data are known (:func:`plan_lags`)."""

    starts: IntArray
    longest: int  # the longest segment
    max_lag: int
    source: str  # "given", "profile 'name'" or the motion's
    band: float | None  # the motion's information band f_I (Hz), validate with a sample rate
    white_lag: int | None  # the decimated whiteness test's lag (when the motion sets max_lag)


# --------------------------------------------------------------------------- the checks, in order


def check_options(k: Keywords, data: Data | None) -> Options:
    """Every setting in the contract's order; ``data`` None for the accumulator before its chunks."""
    n_params = v.check_n_params(k.n_params)
    n_joints = _n_joints(k.n_joints, data)
    prof = get_profile(k.profile)
    nan_policy = v.check_nan_policy(k.nan_policy)
    if data is None:
        starts = _refused("segments", k.segments)
    else:
        starts = parse_segments(k.segments, data.n) if data.starts is None else data.starts
    max_lag = _max_lag(k.max_lag, prof, data, starts)
    level = prof.level if k.level is None else v.check_level(k.level)
    backend, _ = resolve(k.backend)
    noise_model = prof.noise_model if k.noise_model is None else v.check_noise_model(k.noise_model)
    sample_rate = v.check_sample_rate(k.sample_rate)
    units_checked = v.check_flag("time_units_checked", k.time_units_checked)
    timing = None
    if data is not None and k.time is not None:  # the accumulator's stamps come with its chunks
        assert starts is not None
        timing, starts = _time_stamps(k.time, max_lag, sample_rate, units_checked, data, starts)
        sample_rate = timing.sample_rate
    # the accumulator's rate may also come with its chunks' stamps: checked when they set it
    bandwidth = v.check_bandwidth(k.bandwidth, sample_rate, rate_known=data is not None or sample_rate is not None)
    decimate = _refused("decimate", k.decimate) if data is None else v.check_decimate(k.decimate)
    joint_names = _joint_names(k.joint_names, data, n_joints)
    column_names = _names(k.column_names) if data is None else check_column_names(k.column_names, data.p)
    q, dq, ddq = _motion_signals(k, data)
    estimation = _refused("estimation", k.estimation) if data is None else _estimation(k.estimation, data)
    thresholds = resolve_thresholds(k.thresholds)
    if data is None:
        detail = _refused("cross_correlation_detail", k.cross_correlation_detail)
        model_columns = _refused("model_columns", k.model_columns)
    else:
        detail = v.check_detail(k.cross_correlation_detail)
        model_columns = v.check_model_columns(k.model_columns, data.p, column_names)
    allow_wide = v.check_allow_wide(k.allow_wide)
    return Options(n_params=n_params, n_joints=n_joints, profile=prof, nan_policy=nan_policy, max_lag=max_lag,
                   level=level, backend=backend, noise_model=noise_model, sample_rate=sample_rate,
                   time_units_checked=units_checked, bandwidth=bandwidth, joint_names=joint_names,
                   column_names=column_names, thresholds=thresholds,
                   allow_wide=allow_wide, starts=starts, timing=timing, decimate=decimate, q=q, dq=dq, ddq=ddq,
                   estimation=estimation, detail=detail or "top", model_columns=model_columns)


def _refused(name: str, value: object) -> Any:
    """A keyword of ``validate`` the accumulator does not take: only None is accepted (and kept)."""
    if value is not None:
        raise v.parameter_error(name, f"None for ValidationAccumulator ({UNSUPPORTED[name]})", value)
    return None


def _n_joints(value: Any, data: Data | None) -> int | None:
    """``n_joints`` against the regressor (or m); the accumulator's, before m is known, alone."""
    if data is None:
        if value is not None and (not v.is_integer(value) or value <= 0):
            raise v.parameter_error("n_joints", "None or a positive integer", value)
        return None if value is None else int(value)
    if data.reg_shape is not None:
        return v.check_n_joints(value, data.reg_shape[0], data.m, len(data.reg_shape) == 3)
    if value is not None:
        return v.check_n_joints(value, data.n * data.m, data.m, False)
    return None


def _max_lag(value: Any, prof: Profile, data: Data | None, starts: IntArray | None) -> int | None:
    """``max_lag`` as given: below the longest segment; the accumulator's, before its segments are
    known, only >= 0, and given where the profile's default depends on N."""
    if data is not None:
        assert starts is not None
        return None if value is None else v.check_max_lag(value, longest_segment(starts, data.n))
    if value is None:
        if prof.max_lag_cap is None:
            raise v.parameter_error("max_lag", f"an integer with max_lag >= 0 for the {prof.name} profile (its "
                                    "default depends on N, which a stream does not know)", value)
        return None
    if not v.is_integer(value) or value < 0 or value >= 2**63:
        raise v.parameter_error("max_lag", "an integer with max_lag >= 0", value)
    return int(value)


def _time_stamps(time: Any, max_lag: int | None, sample_rate: float | None, units_checked: bool, data: Data,
                 starts: IntArray) -> tuple[_timing.Timing, IntArray]:
    """The time stamps: their summary (in seconds unless not ``units_checked``), and the segments
    split at their gaps (a given ``max_lag`` must stay below the longest run between gaps)."""
    stamps = _timing.check_time(time, data.given_n)
    # rows omitted for non-finite data leave gaps in the stamps, as they should
    timing = _timing.analyse(stamps if data.kept_rows is None else stamps[data.kept_rows], sample_rate, data.meas,
                             units_checked)
    starts = _timing.split_at_gaps(starts, timing.gap_rows)
    longest = longest_segment(starts, data.n)
    if max_lag is not None and max_lag >= longest:
        raise InvalidParameter(f"max_lag must be below {longest}, the longest run of samples between the "
                               f"{timing.gaps} gaps of the time stamps, got {max_lag}")
    return timing, starts


def _names(value: Any) -> Any:
    """Names as a tuple (settings are compared and hashed); checked when m or p is known."""
    if value is None or isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        return value
    return tuple(value)


def _joint_names(value: Any, data: Data | None, n_joints: int | None) -> Any:
    if data is not None:
        return _names(check_joint_names(value, data.m))
    if n_joints is not None:  # the accumulator knows m from n_joints
        check_joint_names(value, n_joints)
    return _names(value)


def check_joint_names(value: Any, m: int) -> list[str] | None:
    """``joint_names``: None or m distinct strings."""
    names: list[str] | None = v.check_names("joint_names", value, m, "joint")
    return names


def check_column_names(value: Any, p: int | None, show: Callable[[Any], Any] = lambda x: x) -> tuple[str, ...] | None:
    """``column_names``: None, or (with a regressor of p columns) p distinct strings. ``show``: how
    the message shows the value without a regressor."""
    if value is not None and p is None:
        raise v.parameter_error("column_names", "None without a regressor", show(value))
    names: tuple[str, ...] | None = _names(v.check_names("column_names", value, p or 0, "regressor column"))
    return names


def _motion_signals(k: Keywords, data: Data | None) -> tuple[FloatArray | None, ...]:
    """``q``, ``dq``, ``ddq``: (N, m) signals of the validation run; dq and ddq need q."""
    if data is None:
        return _refused("q", k.q), None, None
    q, dq, ddq = (None if x is None else v.check_signal_like(x, name, data.given_n, data.m)
                  for x, name in ((k.q, "q"), (k.dq, "dq"), (k.ddq, "ddq")))
    if q is None and (dq is not None or ddq is not None):
        raise v.parameter_error("dq" if dq is not None else "ddq", "None without q", k.dq if dq is not None else k.ddq)
    return q, dq, ddq


def _estimation(value: Any, data: Data) -> dict[str, FloatArray] | None:
    """``estimation``: the estimation run's arrays, with the regressor's columns and N agreeing."""
    estimation: dict[str, FloatArray] | None = v.check_estimation(value, data.m)
    if estimation is None or "regressor" not in estimation:
        return estimation
    reg = estimation["regressor"]
    if data.p is not None and reg.shape[2] != data.p:
        raise ShapeMismatch(f"estimation['regressor'] must have the p={data.p} columns of regressor, got shape "
                            f"{v.format_shape(np.shape(value['regressor']))}")
    if "tau" in estimation and reg.shape[0] != estimation["tau"].shape[0]:
        raise ShapeMismatch(f"estimation['regressor'] and estimation['tau'] must have the same N, got "
                            f"{reg.shape[0]} and {estimation['tau'].shape[0]} samples")
    return estimation


# --------------------------------------------------------------------------- lags and the report's setting


def plan_lags(o: Options, n: int, starts: IntArray, pred: FloatArray | None = None) -> Lags:
    """The lag analysis of n samples in the segments ``starts``: a given ``max_lag`` (below the
    longest segment), else the profile's default; with the prediction and a sample rate
    (``validate``), the motion's time scale instead: one period of the information band's edge."""
    prof = o.profile
    longest = longest_segment(starts, n)
    band = None if pred is None else _motion_band(pred, starts, o)
    if o.max_lag is not None:
        return Lags(starts, longest, v.check_max_lag(o.max_lag, longest), "given", band, None)
    max_lag = prof.default_max_lag(n, longest)
    if max_lag > 0 and band is not None:
        # the decimated whiteness test keeps the profile's count of lags
        white_lag = (prof.ljung_box_lags(n, max_lag, longest) or [None])[0]
        return Lags(starts, longest, _motion_max_lag(band, o, n, longest), MOTION_LAG_SOURCE, band, white_lag)
    return Lags(starts, longest, max_lag, f"profile {prof.name!r}", band, None)


def _motion_band(pred: FloatArray, starts: IntArray, o: Options) -> float | None:
    """The information band f_I of the motion (99 % of the prediction's power, at most
    ``bandwidth``), in Hz; None without a sample rate, or when the prediction carries no power."""
    if o.sample_rate is None:
        return None
    from ..statistics._stats import information_bandwidth

    band = information_bandwidth(pred, starts, sample_rate=o.sample_rate)
    if not (np.isfinite(band) and band > 0):
        return None
    # a prediction made of filtered inputs carries the filter's leakage above its bandwidth: the
    # motion cannot be trusted there either
    return band if o.bandwidth is None else min(band, o.bandwidth)


def _motion_max_lag(band: float, o: Options, n: int, longest: int) -> int:
    """The default largest lag with a sample rate: the motion's time scale, one period 1/f_I of the
    information band's edge (lags within it see one phenomenon), at most four times the profile's
    count and below the longest segment."""
    assert o.sample_rate is not None
    # a band far below the rate (bandwidth=1e-307) gives more lags than any cap: capped before int
    lags = int(math.ceil(min(o.sample_rate / band, float(longest))))
    cap = 4 * max(o.profile.default_max_lag(n, n + 1), 1)
    return int(max(1, min(lags, cap, longest - 1)))


def to_setting(o: Options, lags: Lags, m: int, *, sample_rate: float | None, timing: _timing.Timing | None,
               streaming: bool = False, not_tested: list[dict[str, Any]] | None = None) -> Setting:
    """What the assembler reads: the settings, the lags chosen, the names (``joint j`` by default);
    ``not_tested``: the tests the entry point left out (:func:`dynval.coverage.not_tested`)."""
    joint_names = list(o.joint_names) if o.joint_names is not None else [f"joint {j + 1}" for j in range(m)]
    return Setting(prof=o.profile, noise_model=o.noise_model, level=o.level, max_lag=lags.max_lag,
                   lag_source=lags.source, sample_rate=sample_rate, timing=timing, bandwidth=o.bandwidth,
                   nan_policy=o.nan_policy, n_params=o.n_params, joint_names=joint_names,
                   column_names=list(o.column_names) if o.column_names is not None else None,
                   model_columns=o.model_columns, thresholds=o.thresholds, backend=o.backend,
                   decimate=o.decimate, streaming=streaming, not_tested=list(not_tested or []))
