"""The settings of a report, checked once: ``validate``'s keywords, and the accumulator's.

Each keyword is declared once, in :data:`OPTIONS` (:class:`Option`: its name, type, default, check,
the contract's words, its command-line flag and what the accumulator does with it), in the
contract's order of the checks (§2.1). :func:`check_options` runs the checks in that order, one
function per setting for ``validate`` and :class:`dynval.stream.ValidationAccumulator` alike, and
returns one frozen :class:`Options`; the accumulator refuses those that need the whole series
(:data:`UNSUPPORTED`), ``dynval.cli`` builds its flags from them and :func:`options_table` is the
contract's table (``python -m dynval.coverage --write docs/contract.md`` writes it).
``validate`` passes what its data tell (:class:`Data`) and runs the checks deferred
(``_checks.CheckedCall``: a non-finite value in the data wins over a bad setting); the
accumulator passes None before its first chunk: the checks that need m or p wait for it
(:func:`check_joint_names`, :func:`check_column_names`).

The lags of the report (:class:`Lags`: the segments, the largest lag and where it comes from,
the motion's information band) are chosen once the data are known, by :func:`plan_lags`, for
``validate`` from the whole series and for the accumulator from its sums.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..checks import _timing
from ..checks import _validation as v
from ..checks._errors import InvalidParameter, ShapeMismatch
from ..checks._segments import longest_segment, parse_segments, segment_lengths
from ..checks._typing import BackendName, FloatArray, IntArray, Kernels
from ..kernels._backend import resolve
from ..metrics._profiles import PROFILE_NAMES, Profile, get_profile
from ._assembly import Setting
from ._findings import Thresholds, resolve_thresholds

__all__ = ["Option", "Flag", "OPTIONS", "NAMES", "REQUIRED", "Keywords", "Data", "Options", "Lags", "UNSUPPORTED",
           "check_options", "plan_lags", "to_setting", "options_table"]

MOTION_LAG_SOURCE = "motion: one period of the information band's edge"


class _Required:
    """The default of a keyword the caller must give (``n_params``)."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


class Flag(NamedTuple):
    """An option's flag of ``dynval validate`` and ``dynval compare`` (``dynval.cli`` builds its parser
    from these). ``read``: how the command line reads the text, one of the readers of ``dynval.cli``
    ("int", "float", "text", "segments", "decimate", "names", "file", "time", "estimation"), or
    "switch" (a flag without a value: True when given) and "unswitch" (False when given)."""

    flag: str
    help: str
    metavar: str | None = None
    read: str = "text"
    choices: tuple[str, ...] | None = None


class Checking(NamedTuple):
    """What a setting's check reads besides its value: the data (None for the accumulator before its
    chunks), the settings as given, and those checked before it, by name (``time`` refines ``segments`` and
    ``sample_rate`` there: its gaps split the segments, its stamps give the rate)."""

    data: Data | None
    done: dict[str, Any]
    given: Keywords


class Option(NamedTuple):
    """One keyword of ``validate`` (and of ``compare``, which passes it on; of the accumulator and the
    command line as ``stream`` and ``flag`` say), declared once: :data:`OPTIONS` drives the check
    (:func:`check_options`), the accumulator's refusals (:data:`UNSUPPORTED`), the command line's
    flags and the contract's table (:func:`options_table`); tests hold ``validate``'s and the
    accumulator's signatures to it.

    ``check(value, checking)`` returns the checked value (InvalidParameter naming the value
    otherwise); ``kind`` and ``doc`` are the contract's words; ``stream`` is "supported" (the
    accumulator checks it as ``validate`` does), "update" (given with each chunk, ``update(...)``),
    or "refused: why" (the accumulator takes only None, :data:`UNSUPPORTED`)."""

    name: str
    kind: str
    default: Any
    check: Callable[[Any, Checking], Any]
    doc: str
    flag: Flag | None = None
    stream: str = "supported"

    @property
    def refused(self) -> str | None:
        """Why the accumulator refuses the keyword unless None (None: it takes it)."""
        if self.stream.startswith(("refused: ", "update: ")):
            return self.stream.split(": ", 1)[1]
        return None


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
    lb_lags: list[int]  # the lags of the Ljung–Box statistics (the profile's rule; empty without lags)
    lengths: IntArray  # each segment's length


# --------------------------------------------------------------------------- the checks, in order


def _n_params(value: Any, c: Checking) -> int:
    return v.check_n_params(value)


def _n_joints(value: Any, c: Checking) -> int | None:
    """``n_joints`` against the regressor (or m); the accumulator's, before m is known, alone."""
    data = c.data
    if data is None:
        if value is not None and (not v.is_integer(value) or value <= 0):
            raise v.parameter_error("n_joints", "None or a positive integer", value)
        return None if value is None else int(value)
    if data.reg_shape is not None:
        return v.check_n_joints(value, data.reg_shape[0], data.m, len(data.reg_shape) == 3)
    if value is not None:
        return v.check_n_joints(value, data.n * data.m, data.m, False)
    return None


def _profile(value: Any, c: Checking) -> Profile:
    return get_profile(value)


def _nan_policy(value: Any, c: Checking) -> str:
    return v.check_nan_policy(value)


def _segments(value: Any, c: Checking) -> IntArray:
    """The segments' starts (``validate``'s; with ``nan_policy="omit"`` parsed before the omission)."""
    assert c.data is not None  # the accumulator refuses segments
    return parse_segments(value, c.data.n) if c.data.starts is None else c.data.starts


def _max_lag(value: Any, c: Checking) -> int | None:
    """``max_lag`` as given: below the longest segment; the accumulator's, before its segments are
    known, only >= 0, and given where the profile's default depends on N."""
    data, prof = c.data, c.done["profile"]
    if data is not None:
        return None if value is None else v.check_max_lag(value, longest_segment(c.done["segments"], data.n))
    if value is None:
        if prof.max_lag_cap is None:
            raise v.parameter_error("max_lag", f"an integer with max_lag >= 0 for the {prof.name} profile (its "
                                    "default depends on N, which a stream does not know)", value)
        return None
    if not v.is_integer(value) or value < 0 or value >= 2**63:
        raise v.parameter_error("max_lag", "an integer with max_lag >= 0", value)
    return int(value)


def _level(value: Any, c: Checking) -> float:
    return c.done["profile"].level if value is None else v.check_level(value)


def _backend(value: Any, c: Checking) -> BackendName:
    return resolve(value)[0]


def _noise_model(value: Any, c: Checking) -> str:
    return c.done["profile"].noise_model if value is None else v.check_noise_model(value)


def _sample_rate(value: Any, c: Checking) -> float | None:
    rate: float | None = v.check_sample_rate(value)
    return rate


def _time_units_checked(value: Any, c: Checking) -> bool:
    return v.check_flag("time_units_checked", value)


def _time(value: Any, c: Checking) -> _timing.Timing | None:
    """The time stamps: their summary (in seconds unless not ``time_units_checked``); the segments
    split at their gaps (a given ``max_lag`` must stay below the longest run between gaps), and the
    sample rate theirs."""
    data, done = c.data, c.done
    if data is None or value is None:
        return None
    stamps = _timing.check_time(value, data.given_n)
    # rows omitted for non-finite data leave gaps in the stamps, as they should
    timing = _timing.analyse(stamps if data.kept_rows is None else stamps[data.kept_rows], done["sample_rate"],
                             data.meas, done["time_units_checked"])
    starts = _timing.split_at_gaps(done["segments"], timing.gap_rows)
    longest = longest_segment(starts, data.n)
    max_lag = done["max_lag"]
    if max_lag is not None and max_lag >= longest:
        raise InvalidParameter(f"max_lag must be below {longest}, the longest run of samples between the "
                               f"{timing.gaps} gaps of the time stamps, got {max_lag}")
    done["segments"], done["sample_rate"] = starts, timing.sample_rate
    return timing


def _bandwidth(value: Any, c: Checking) -> float | None:
    # the accumulator's rate may also come with its chunks' stamps: checked when they set it
    rate = c.done["sample_rate"]
    band: float | None = v.check_bandwidth(value, rate, rate_known=c.data is not None or rate is not None)
    return band


def _decimate(value: Any, c: Checking) -> str | int | None:
    factor: str | int | None = v.check_decimate(value)
    return factor


def _names(value: Any) -> Any:
    """Names as a tuple (settings are compared and hashed); checked when m or p is known."""
    if value is None or isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        return value
    return tuple(value)


def _joint_names(value: Any, c: Checking) -> Any:
    n_joints = c.done["n_joints"]
    if c.data is not None:
        return _names(check_joint_names(value, c.data.m))
    if n_joints is not None:  # the accumulator knows m from n_joints
        check_joint_names(value, n_joints)
    return _names(value)


def check_joint_names(value: Any, m: int) -> list[str] | None:
    """``joint_names``: None or m distinct strings."""
    names: list[str] | None = v.check_names("joint_names", value, m, "joint")
    return names


def _column_names(value: Any, c: Checking) -> Any:
    return _names(value) if c.data is None else check_column_names(value, c.data.p)


def check_column_names(value: Any, p: int | None, show: Callable[[Any], Any] = lambda x: x) -> tuple[str, ...] | None:
    """``column_names``: None, or (with a regressor of p columns) p distinct strings. ``show``: how
    the message shows the value without a regressor."""
    if value is not None and p is None:
        raise v.parameter_error("column_names", "None without a regressor", show(value))
    names: tuple[str, ...] | None = _names(v.check_names("column_names", value, p or 0, "regressor column"))
    return names


def _signal(name: str) -> Callable[[Any, Checking], FloatArray | None]:
    """``q``, ``dq``, ``ddq``: (N, m) signals of the validation run."""
    def check(value: Any, c: Checking) -> FloatArray | None:
        assert c.data is not None  # given with the accumulator's chunks
        return None if value is None else v.check_signal_like(value, name, c.data.given_n, c.data.m)
    return check


def _ddq(value: Any, c: Checking) -> FloatArray | None:
    """``ddq``, then the rule of ``dq`` and ``ddq`` together (after the three are checked): they need q."""
    ddq = _signal("ddq")(value, c)
    dq = c.done["dq"]
    if c.done["q"] is None and (dq is not None or ddq is not None):
        raise v.parameter_error("dq" if dq is not None else "ddq", "None without q",
                                c.given.dq if dq is not None else value)
    return ddq


def _estimation(value: Any, c: Checking) -> dict[str, FloatArray] | None:
    """``estimation``: the estimation run's arrays, with the regressor's columns and N agreeing."""
    data = c.data
    assert data is not None  # the accumulator refuses it
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


def _thresholds(value: Any, c: Checking) -> Thresholds:
    return resolve_thresholds(value)


def _detail(value: Any, c: Checking) -> str:
    return v.check_detail(value)


def _model_columns(value: Any, c: Checking) -> list[int] | None:
    assert c.data is not None  # the accumulator refuses it
    columns: list[int] | None = v.check_model_columns(value, c.data.p, c.done["column_names"])
    return columns


def _allow_wide(value: Any, c: Checking) -> bool:
    return v.check_allow_wide(value)


# The command line's help texts that tests read literally (its examples are parsed).
SEGMENTS_HELP = "independent records, comma-separated: lengths (e.g. 500,300) or starts beginning at 0 (e.g. 0,500)"
TIME_HELP = ("time stamps of the samples in seconds: a 1-D array, or one column of a table named as FILE:COLUMN "
             "(log.csv:t by its header name, log.csv:0 by an index counted from 0; log.npz:t, log.parquet:t, "
             "log.h5:/t). The sample rate is inferred from them (--sample-rate must agree within 1 %%), a gap "
             "splits the lag analysis, and duplicated, missing and irregular stamps are reported. Stamps at a rate "
             "outside 10 Hz to 100 kHz (whole seconds apart, say) look like ms, us or ns and are refused with the "
             "fix (divide by 1000, ...) unless --time-units-unchecked")

OPTIONS: tuple[Option, ...] = (
    Option("n_params", "int >= 0", REQUIRED, _n_params,
           "number of identified parameters p (always given: there is no default)"),
    Option("n_joints", "int > 0 or None", None, _n_joints, "joints m of a stacked (N·m, p) regressor",
           Flag("--n-joints", "joints m of a stacked 2-D regressor", "M", "int")),
    Option("profile", "str", "lesson", _profile, "the convention profile that fills every default (§3)",
           Flag("--profile", "convention profile (default lesson)", None, "text", PROFILE_NAMES)),
    Option("nan_policy", "str", "raise", _nan_policy,
           "`raise`, or `omit` the rows with a non-finite value (a segment break where rows were deleted)",
           Flag("--nan-policy", "raise on NaN/inf, or omit those rows (default raise)", None, "text",
                ("raise", "omit"))),
    Option("segments", "lengths, starts or named lengths", None, _segments,
           "independent records (§1.1); named lengths also get their own metrics",
           Flag("--segments", SEGMENTS_HELP, "S", "segments"),
           stream="refused: call break_segment() between records instead"),
    Option("max_lag", "int >= 0 or None", None, _max_lag,
           "largest lag of the autocorrelation and cross-correlation; None: the profile's, or with a sample "
           "rate the motion's time scale; 0 skips the lag analysis",
           Flag("--max-lag", "largest lag of the residual analysis (default: the profile's; 0 skips it)", "L",
                "int")),
    Option("level", "float in (0, 1) or None", None, _level,
           "confidence level of the bands and findings (None: the profile's)",
           Flag("--level", "confidence level of bands and findings, 0 < X < 1 (default: the profile's)", "X",
                "float")),
    Option("backend", "str or None", None, _backend, "computation backend, `python` or `cpp` (None: the default)",
           Flag("--backend", "computation backend: python or cpp")),
    Option("noise_model", "str or None", None, _noise_model,
           "noise model of the information criteria, `pooled`, `per_joint` or `full` (None: the profile's)",
           Flag("--noise-model", "noise model of the information criteria (default: the profile's)", None, "text",
                ("pooled", "per_joint", "full"))),
    Option("sample_rate", "float > 0 or None", None, _sample_rate,
           "samples per second: frequencies in Hz (else cycles per sample); inferred from `time`",
           Flag("--sample-rate", "samples per second (frequencies in Hz)", "HZ", "float")),
    Option("time_units_checked", "bool", True, _time_units_checked,
           "False accepts time stamps at any rate (else 10 Hz to 100 kHz)",
           Flag("--time-units-unchecked",
                "accept --time stamps at any rate (they must still be seconds float64 can count)", None, "unswitch")),
    Option("time", "array (N,) or None", None, _time,
           "time stamps in seconds: the timing section, a gap splits the segments, the rate inferred",
           Flag("--time", TIME_HELP, "FILE[:COLUMN]", "time"), stream="update"),
    Option("bandwidth", "float > 0 or None", None, _bandwidth,
           "band (Hz) in which the inputs are trustworthy: evidence above it is a note; needs a rate, at most "
           "its Nyquist frequency",
           Flag("--bandwidth", "band in which the inputs are trustworthy (the differentiation or sensor filter): "
                "spectral and whiteness evidence above it is a note, never a deficiency; needs --sample-rate or "
                "--time, and at most their Nyquist frequency (half the rate)", "HZ", "float")),
    Option("decimate", "`auto`, None or int >= 1", "auto", _decimate,
           "whiteness also at the information rate: `auto`, a factor, or None (the logged rate only)",
           Flag("--decimate", "whiteness at the information rate: auto (default), none, or a factor", "Q",
                "decimate"),
           stream="refused: whiteness at the information rate needs the whole series"),
    Option("joint_names", "m distinct str or None", None, _joint_names, "names of the joints in every table",
           Flag("--joint-names", "joint names, comma-separated", "A,B,..", "names")),
    Option("column_names", "p distinct str or None", None, _column_names,
           "names of the regressor's columns (needs a regressor)",
           Flag("--column-names", "regressor column names, comma-separated", "A,B,..", "names")),
    Option("q", "array (N, m) or None", None, _signal("q"),
           "joint positions of the validation run: the repeat check and the physics library",
           Flag("--q", "joint positions of the validation run (N, m)", "FILE", "file"),
           stream="update: give q (and dq, ddq) with each chunk: update(..., q=...)"),
    Option("dq", "array (N, m) or None", None, _signal("dq"), "joint velocities of the validation run (needs q)",
           stream="update"),
    Option("ddq", "array (N, m) or None", None, _ddq, "joint accelerations of the validation run (needs q)",
           stream="update"),
    Option("estimation", "mapping or None", None, _estimation,
           "the estimation run: any of `q`, `dq`, `ddq`, `regressor`, `tau`, `bandwidth`",
           Flag("--estimation", "the estimation run (repeatable): q=FILE, regressor=FILE, tau=FILE", "KEY=FILE",
                "estimation"),
           stream="refused: the estimation run's refit and repeat check need whole series"),
    Option("thresholds", "Thresholds, mapping or None", None, _thresholds,
           "practical effect sizes a deficiency must reach (§4, `thresholds`)"),
    Option("cross_correlation_detail", "str", "top", _detail,
           "`top`: the strongest cross-correlation cells; `full`: also the whole ρ array",
           stream="refused: the colour-aware cross-correlation needs the whole series; rho is always given"),
    Option("model_columns", "int or str sequence, or None", None, _model_columns,
           "the regressor columns the model contains: the others are tested as missing terms",
           stream="refused: the added-variable test projects whole columns"),
    Option("allow_wide", "bool", False, _allow_wide, "accept fewer samples than joints (N < m)",
           Flag("--allow-wide", "accept fewer samples than joints (N < m); without it such data are taken for "
                "transposed and refused", None, "switch")),
)
"""Every keyword of ``validate`` in the contract's order of its checks (§2.1)."""

NAMES = tuple(o.name for o in OPTIONS)

UNSUPPORTED = {o.name: o.refused for o in OPTIONS if o.refused is not None}
"""Keywords of ``validate`` the accumulator refuses unless None, with the reason."""


class Keywords:
    """The settings as the caller gave them, unchecked: every name of :data:`OPTIONS`, its declared
    default when not given (``n_params`` must be given)."""

    __slots__ = ("_given",)

    def __init__(self, **given: Any) -> None:
        unknown = [name for name in given if name not in NAMES]
        if unknown:
            raise TypeError(f"unexpected keyword argument {unknown[0]!r}")
        if "n_params" not in given:
            raise TypeError("missing keyword argument 'n_params'")
        self._given = {o.name: given.get(o.name, o.default) for o in OPTIONS}

    def __getattr__(self, name: str) -> Any:
        try:
            return self._given[name]
        except KeyError:
            raise AttributeError(name) from None


def check_options(k: Keywords, data: Data | None) -> Options:
    """Every setting in the contract's order (:data:`OPTIONS`); ``data`` None for the accumulator
    before its chunks: what it takes with its chunks waits for them, what it refuses must be None."""
    c = Checking(data, {}, k)
    for o in OPTIONS:
        value = getattr(k, o.name)
        if data is not None or o.stream == "supported":
            c.done[o.name] = o.check(value, c)
        else:
            c.done[o.name] = None if o.refused is None else _refused(o.name, value)
    d = c.done
    return Options(n_params=d["n_params"], n_joints=d["n_joints"], profile=d["profile"], nan_policy=d["nan_policy"],
                   max_lag=d["max_lag"], level=d["level"], backend=d["backend"], noise_model=d["noise_model"],
                   sample_rate=d["sample_rate"], time_units_checked=d["time_units_checked"],
                   bandwidth=d["bandwidth"], joint_names=d["joint_names"], column_names=d["column_names"],
                   thresholds=d["thresholds"], allow_wide=d["allow_wide"], starts=d["segments"], timing=d["time"],
                   decimate=d["decimate"], q=d["q"], dq=d["dq"], ddq=d["ddq"], estimation=d["estimation"],
                   detail=d["cross_correlation_detail"] or "top", model_columns=d["model_columns"])


def _refused(name: str, value: object) -> Any:
    """A keyword of ``validate`` the accumulator does not take: only None is accepted (and kept)."""
    if value is not None:
        raise v.parameter_error(name, f"None for ValidationAccumulator ({UNSUPPORTED[name]})", value)
    return None


# --------------------------------------------------------------------------- the contract's table

TABLE_START, TABLE_END = "<!-- options-table:start -->", "<!-- options-table:end -->"
"""The markers around :func:`options_table` in docs/contract.md §4."""


def options_table() -> str:
    """The keywords of ``validate`` as the contract's table (§4): type, default, the command line's
    flag and the accumulator's part, from :data:`OPTIONS`."""
    lines = ["| keyword | type | default | command line | stream | what it sets |", "|---|---|---|---|---|---|"]
    for o in OPTIONS:
        default = "required" if o.default is REQUIRED else f"`{o.default!r}`"
        flag = "—" if o.flag is None else f"`{o.flag.flag}`"
        stream = {"supported": "yes", "update": "with each chunk"}.get(o.stream, "refused")
        if o.stream.startswith("update: "):
            stream = "with each chunk"
        lines.append(f"| `{o.name}` | {o.kind} | {default} | {flag} | {stream} | {o.doc} |")
    return "\n".join(lines)


def write_table(path: str) -> None:
    """Put :func:`options_table` between :data:`TABLE_START` and :data:`TABLE_END` in the file at ``path``."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    a, b = text.index(TABLE_START) + len(TABLE_START), text.index(TABLE_END)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text[:a] + "\n" + options_table() + "\n" + text[b:])


# --------------------------------------------------------------------------- lags and the report's setting


def plan_lags(o: Options, n: int, starts: IntArray, pred: FloatArray | None = None) -> Lags:
    """The lag analysis of n samples in the segments ``starts``, planned once for every phase: a given
    ``max_lag`` (below the longest segment), else the profile's default; with the prediction and a
    sample rate (``validate``), the motion's time scale instead: one period of the information band's
    edge. The Ljung–Box lags and the segments' lengths come with it."""
    prof = o.profile
    lengths = segment_lengths(starts, n)
    longest = longest_segment(starts, n)
    band = None if pred is None else _motion_band(pred, starts, o)
    source, white_lag = "given", None
    if o.max_lag is not None:
        max_lag = v.check_max_lag(o.max_lag, longest)
    else:
        max_lag, source = prof.default_max_lag(n, longest), f"profile {prof.name!r}"
        if max_lag > 0 and band is not None:
            assert o.sample_rate is not None  # a band needs a rate
            # the decimated whiteness test keeps the profile's count of lags
            white_lag = (prof.ljung_box_lags(n, max_lag, longest) or [None])[0]
            max_lag, source = prof.motion_max_lag(o.sample_rate / band, n, longest), MOTION_LAG_SOURCE
    return Lags(starts, longest, max_lag, source, band, white_lag, prof.ljung_box_lags(n, max_lag, longest), lengths)


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

