"""The one input checker shared by every dynval function.

Checks run in the contract's order (§2.1): type -> shape -> size -> finiteness -> parameters,
and every message is built here, so the texts are identical across functions. The C++ core
mirrors these messages byte for byte; the ``format_*`` helpers define how values appear.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ._errors import InvalidParameter, InvalidShape, InvalidType, NonFiniteInput, ShapeMismatch, TooFewSamples
from ._typing import ArrayLike

# Largest accepted |value| in the data (contract §1.2): beyond it float64 sums of squares can
# overflow, and implementations would disagree (inf in one, nan in another).
MAX_MAGNITUDE = 1e144
_PREFILTER_BOUND = (MAX_MAGNITUDE / 2.0) ** 2

MULTIOUTPUT_OPTIONS = ("pooled", "raw_values", "uniform_average", "variance_weighted")
CONVENTION_OPTIONS = ("per_element", "per_sample")
BAND_OPTIONS = ("white", "bartlett")
NOISE_MODEL_OPTIONS = ("pooled", "per_joint", "full")
NAN_POLICY_OPTIONS = ("raise", "omit")
PROFILE_OPTIONS = ("lesson", "matlab", "statsmodels", "sklearn")
PORTMANTEAU_TESTS = ("ljung_box", "box_pierce")

# Minimum N per public function (contract §2.2).
MIN_SAMPLES = {
    "residuals": 1,
    "sse": 1,
    "rmse": 1,
    "max_abs_error": 1,
    "residual_mean": 1,
    "vaf": 2,
    "fit_percent": 2,
    "r2": 2,
    "residual_variance": 2,
    "zero_mean_test": 2,
    "autocorrelation": 2,
    "ljung_box": 2,
    "box_pierce": 2,
    "cross_correlation": 2,
    "aic": 2,
    "bic": 2,
    "criteria": 2,
    "validate": 2,
}


# --------------------------------------------------------------------------- formatting


def format_shape(shape) -> str:
    """Write a shape as a Python tuple, e.g. ``(5,)`` or ``(3, 2)``."""
    return repr(tuple(int(s) for s in shape))


# A container with more items than this, or nested deeper, is shown by type and length: the
# message names the bad value without repeating a caller's data (a 10^6-row array is 5 MB of text).
_LISTED_ITEMS = 8
_LISTED_DEPTH = 3
_SHOWN_CHARS = 80
_SHOWN_STR = 1000  # a string is shown whole up to this: a file's path is what the reader must see
_LISTED_CHARS = 400


def format_value(value) -> str:
    """Write a value for a message: short values as their Python repr, large ones by type and size.

    numpy scalars are shown as Python ones (``np.int64(3)`` -> ``3``) so that the C++ core, which
    sees plain numbers, writes the same text (its bindings call this function). A data array is
    never written out: ``<float64 array of shape (1000000,)>``. A list, tuple, dict or 1-D numeric
    array of at most eight items is written item by item (``[500, 300]``); a longer, deeper (three
    levels) or wordier (400 characters) one as ``<list of length 1000000>``; a string longer than 1000 characters
    is cut (``'abc...' (a str of 5000 characters)``); any other object whose repr is long as
    ``<DataFrame of shape (3, 2)>`` if it has a shape, else as its repr cut (``1000...
    (401 characters)`` for 10**400).

    Examples
    --------
    >>> format_value(np.int64(12)), format_value([2, 6]), format_value(np.zeros((1000, 2)))
    ('12', '[2, 6]', '<float64 array of shape (1000, 2)>')
    >>> format_value((list(range(100)), 1))
    '(<list of length 100>, 1)'
    """
    return _shown(value, 0)


def _shown(value, depth: int) -> str:
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return repr(value.item())
        if value.ndim == 1 and value.size <= _LISTED_ITEMS and value.dtype.kind in "biuf":
            # A short 1-D array is a parameter such as lags or segments: its values are what is wrong.
            return _shown_container(value.tolist(), depth)
        return f"<{value.dtype} array of shape {format_shape(value.shape)}>"
    if isinstance(value, np.generic):
        return repr(value.item())
    if isinstance(value, (list, tuple, dict)):
        return _shown_container(value, depth)
    if isinstance(value, (str, bytes)):
        if len(value) <= _SHOWN_STR:
            return repr(value)
        return f"{value[:_SHOWN_CHARS]!r}... (a {type(value).__name__} of {len(value)} characters)"
    text = repr(value)
    if len(text) <= _SHOWN_CHARS:
        return text
    shape = getattr(value, "shape", None)
    if isinstance(shape, tuple) and all(isinstance(s, numbers.Integral) for s in shape):
        return f"<{type(value).__name__} of shape {format_shape(shape)}>"
    return f"{text[:_SHOWN_CHARS]}... ({len(text)} characters)"


def _shown_container(value: list | tuple | dict, depth: int) -> str:
    if len(value) > _LISTED_ITEMS or (depth >= _LISTED_DEPTH and len(value) > 0):
        return f"<{type(value).__name__} of length {len(value)}>"
    if isinstance(value, dict):
        text = "{" + ", ".join(f"{_shown(k, depth + 1)}: {_shown(v, depth + 1)}" for k, v in value.items()) + "}"
    else:
        items = [_shown(v, depth + 1) for v in value]
        if isinstance(value, list):
            text = "[" + ", ".join(items) + "]"
        else:
            text = "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"
    return text if len(text) <= _LISTED_CHARS else f"<{type(value).__name__} of length {len(value)}>"


def format_nonfinite(value: float) -> str:
    """``nan``, ``inf`` or ``-inf``."""
    value = float(value)
    if math.isnan(value):
        return "nan"
    return "inf" if value > 0 else "-inf"


def parameter_error(param: str, requirement: str, value) -> InvalidParameter:
    """Build the contract's InvalidParameter: ``{param} must be {requirement}, got {value!r}``."""
    return InvalidParameter(f"{param} must be {requirement}, got {format_value(value)}")


# --------------------------------------------------------------------------- type and shape


def to_float_array(x, name: str) -> np.ndarray:
    """Convert an array argument to float64, rejecting anything that is not real numbers.

    Lists and tuples are accepted; bool, integer and float16/float32 are converted once.
    Complex, string, object and datetime data and ``None`` raise :class:`InvalidType`.
    """
    if x is None or isinstance(x, (str, bytes)):
        raise InvalidType(f"{name} must be an array of real numbers, got {type(x).__name__}")
    if isinstance(x, np.ma.MaskedArray):
        # Converting would silently use the values under the mask (contract §1).
        raise InvalidType(
            f"{name} must be an array of real numbers, got a masked array (numpy.ma): fill the masked "
            "values with nan (numpy.ma.filled(x, numpy.nan)) and pass nan_policy='omit'"
        )
    if isinstance(x, np.ndarray):
        arr = x
    else:
        try:
            arr = np.asarray(x)
        except (ValueError, TypeError):
            # Ragged nested sequences: numpy would need dtype=object to hold them.
            raise InvalidType(f"{name} must be an array of real numbers, got object") from None
    if arr.dtype.kind not in "biuf":
        raise InvalidType(f"{name} must be an array of real numbers, got {arr.dtype}")
    return np.asarray(arr, dtype=np.float64)


def promote_signal(arr: np.ndarray, name: str) -> np.ndarray:
    """Check a signal's dimensions and promote ``(N,)`` to ``(N, 1)``."""
    if arr.ndim == 1:
        return arr.reshape(-1, 1)
    if arr.ndim != 2:
        raise InvalidShape(f"{name} must be 1-D (N,) or 2-D (N, m), got shape {format_shape(arr.shape)}")
    if arr.shape[1] == 0:
        raise InvalidShape(f"{name} must have at least one column, got shape {format_shape(arr.shape)}")
    return arr


def check_same_shape(name_a: str, shape_a, a2: np.ndarray, name_b: str, shape_b, b2: np.ndarray) -> None:
    """Raise ShapeMismatch unless the promoted arrays agree; the message shows the user's shapes."""
    if a2.shape != b2.shape:
        raise ShapeMismatch(
            f"{name_a} and {name_b} must have the same shape, got "
            f"{format_shape(shape_a)} and {format_shape(shape_b)}"
        )


class Torques(NamedTuple):
    """What :func:`torque_pair` returns."""

    meas: Any  # (N, m)
    pred: Any  # (N, m)
    reg0: Any  # the regressor converted, its shape not yet checked; or None
    shape: tuple[int, ...]  # the caller's shape of tau_meas (for messages)
    one_d: bool  # both torques were given 1-D


def torque_pair(tau_meas, tau_pred, regressor=None, convert=to_float_array) -> Torques:
    """The type checks of the torques and the regressor, then the torques' shape checks, in the
    contract's order; shared by every entry point (the metrics, ``validate``, the accumulator's
    chunks, dask). Both torques come back promoted to (N, m); the regressor's shape needs N, m
    and ``n_joints`` and is checked by the caller (:func:`regressor_shape`).

    ``convert``: the type step (:func:`to_float_array`; dask passes its lazy equivalent).
    """
    meas0 = convert(tau_meas, "tau_meas")
    pred0 = convert(tau_pred, "tau_pred")
    reg0 = None if regressor is None else convert(regressor, "regressor")
    meas = promote_signal(meas0, "tau_meas")
    pred = promote_signal(pred0, "tau_pred")
    check_same_shape("tau_meas", meas0.shape, meas, "tau_pred", pred0.shape, pred)
    return Torques(meas, pred, reg0, tuple(meas0.shape), meas0.ndim == 1 and pred0.ndim == 1)


def regressor_shape(y: np.ndarray, name_e: str, n: int, m: int, n_joints) -> int:
    """Check the regressor's shape against ``e`` (N, m) and return the number of columns p.

    The regressor is ``(N, m, p)``, or ``(N*m, p)`` stacked sample-major with ``n_joints``.
    Only the shape is checked here; ``n_joints`` itself is a parameter (see
    :func:`check_n_joints`), checked later in the contract's order.
    """
    shape = format_shape(y.shape)
    if y.ndim == 3:
        if y.shape[2] == 0:
            raise InvalidShape(f"regressor must have at least one column, got shape {shape}")
        if y.shape[0] != n or y.shape[1] != m:
            raise ShapeMismatch(f"regressor must have shape (N, m, p) = ({n}, {m}, p) to match {name_e}, got {shape}")
        return int(y.shape[2])
    if y.ndim == 2 and n_joints is not None:
        if y.shape[1] == 0:
            raise InvalidShape(f"regressor must have at least one column, got shape {shape}")
        if y.shape[0] != n * m:
            raise ShapeMismatch(f"regressor has {y.shape[0]} rows, which is not N*m = {n}*{m}")
        return int(y.shape[1])
    raise InvalidShape(f"regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape {shape}")


def regressor_to_2d(y: np.ndarray, n: int, m: int, p: int) -> np.ndarray:
    """View a checked regressor as ``(N, m*p)``: column ``j*p + c`` is joint j, column c."""
    # Both accepted forms hold sample k, joint j, column c at the same flat position
    # (k*m + j)*p + c, so one reshape serves both.
    return np.ascontiguousarray(y.reshape(n, m * p))


def check_min_samples(function: str, n: int, minimum: int | None = None) -> None:
    """Raise TooFewSamples when ``n`` is below the function's minimum (contract §2.2)."""
    k = MIN_SAMPLES[function] if minimum is None else minimum
    if n < k:
        raise TooFewSamples(f"{function} needs at least {k} samples, got N={n}")


def check_orientation(function: str, name: str, shape, allow_wide) -> None:
    """Refuse fewer samples than joints (N < m) unless ``allow_wide`` (contract §2.2).

    Samples are rows, so (6, 5000) is almost always a transposed array, whose report would be
    thousands of lines of nonsense. A value of ``allow_wide`` that is not True or False cannot
    decide here; it is reported by :func:`check_allow_wide` in the parameter step.
    """
    if len(shape) != 2 or shape[0] >= shape[1]:
        return
    if not isinstance(allow_wide, (bool, np.bool_)) or allow_wide:
        return
    raise TooFewSamples(
        f"{function} needs at least as many samples as joints (N >= m), got {name} of shape "
        f"{format_shape(shape)}: samples are rows and joints columns, so the data look transposed; "
        "transpose them, or pass allow_wide=True if N < m is intended")


def check_allow_wide(value) -> bool:
    """``allow_wide`` is exactly True or False (numpy bools too)."""
    return check_flag("allow_wide", value)


def check_flag(name: str, value) -> bool:
    """A switch ``name`` is exactly True or False (numpy bools too)."""
    if not isinstance(value, (bool, np.bool_)):
        raise parameter_error(name, "True or False", value)
    return bool(value)


# --------------------------------------------------------------------------- finiteness


def in_range(a) -> np.ndarray:
    """Elementwise: finite and |x| <= MAX_MAGNITUDE (False for NaN and ±inf)."""
    return np.abs(a) <= MAX_MAGNITUDE


def first_nonfinite(a: ArrayLike) -> tuple[int, int, float] | None:
    """Return ``(row, col, value)`` of the first value that is not :func:`in_range`, or None.

    Row-major order (the contract's "first bad index"): NaN, ±inf, or |x| > MAX_MAGNITUDE.
    """
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1:
        a = a.reshape(-1, 1)
    if a.size == 0:
        return None
    # One pass without a temporary: d = Σx² (BLAS). A sum of non-negative terms is never below
    # the rounded square of any term, so d <= (MAX_MAGNITUDE/2)² proves every |x| in range (and
    # NaN or ±inf make d NaN or inf). Otherwise the exact elementwise scan below decides.
    flat = a.ravel(order="K")
    with np.errstate(over="ignore", invalid="ignore"):
        if float(np.dot(flat, flat)) <= _PREFILTER_BOUND:
            return None
    bad = ~in_range(a)
    if not bad.any():
        return None
    first = int(np.flatnonzero(bad.ravel(order="C"))[0])
    row, col = divmod(first, a.shape[1])
    return row, col, float(a[row, col])


def nonfinite_error(name: str, row: int, col: int, value: float, n_columns: int | None = None) -> NonFiniteInput:
    """Build the NonFiniteInput message.

    With ``n_columns`` (a regressor viewed as ``(N, m*p)``), the location is written as
    sample, joint and column.
    """
    if n_columns:
        joint, column = divmod(col, n_columns)
        where = f"at sample {row}, joint {joint}, column {column}"
    else:
        where = f"at row {row}, column {col}"
    if math.isfinite(value):
        return NonFiniteInput(f"{name} has a value out of range ({value!r}) {where}: |x| must be at most 1e+144")
    return NonFiniteInput(f"{name} has a non-finite value ({format_nonfinite(value)}) {where}")


def check_finite(a: np.ndarray, name: str, n_columns: int | None = None) -> None:
    """Raise NonFiniteInput at the first NaN or +/-inf of ``a``."""
    found = first_nonfinite(a)
    if found is not None:
        raise nonfinite_error(name, *found, n_columns=n_columns)


# --------------------------------------------------------------------------- parameters


def is_integer(value) -> bool:
    """True for Python and numpy integers that fit in int64; False for bool and floats (even integral).

    The int64 bound is the contract's, so that every language can hold every accepted value.
    """
    return (isinstance(value, (numbers.Integral, np.integer)) and not isinstance(value, (bool, np.bool_))
            and -(2**63) <= int(value) < 2**63)


def is_real_number(value) -> bool:
    """True for Python and numpy real numbers other than bool."""
    return isinstance(value, (numbers.Real, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _quoted(options) -> str:
    return ", ".join(repr(o) for o in options)


def check_choice(param: str, value, options) -> str:
    """Return ``value`` if it is one of the string ``options``; else InvalidParameter."""
    if not isinstance(value, str) or value not in options:
        raise parameter_error(param, f"one of {_quoted(options)}", value)
    return value


def check_multioutput(value, allowed, function: str) -> str:
    """Check ``multioutput`` against the four names, then against the ones ``function`` supports."""
    check_choice("multioutput", value, MULTIOUTPUT_OPTIONS)
    if value not in allowed:
        raise parameter_error("multioutput", f"one of {_quoted(allowed)} for {function}", value)
    return value


def check_convention(value, multioutput: str) -> str:
    """Check rmse's ``convention``; ``None`` or ``""`` mean the default. Returns ``""`` for it."""
    if value is None or (isinstance(value, str) and value == ""):
        return ""
    if multioutput != "pooled":
        raise parameter_error("convention", "None unless multioutput='pooled'", value)
    return check_choice("convention", value, CONVENTION_OPTIONS)


def check_ddof(value, n: int) -> int:
    """``ddof`` is an integer with 0 <= ddof < N."""
    if not is_integer(value) or not 0 <= value < n:
        raise parameter_error("ddof", f"an integer with 0 <= ddof < N={n}", value)
    return int(value)


def check_max_lag(value, limit: int) -> int:
    """``max_lag`` is an integer with 0 <= max_lag < limit (the longest segment)."""
    if not is_integer(value) or not 0 <= value < limit:
        raise parameter_error("max_lag", f"an integer with 0 <= max_lag < {limit}", value)
    return int(value)


def check_lags(value, limit: int) -> np.ndarray:
    """``lags``: a positive integer or a non-empty sequence of them, each below ``limit``."""
    requirement = f"a positive integer or a non-empty sequence of positive integers less than {limit}"
    # A range or an integer array is checked by its ends or in one pass before anything is built
    # from it: range(1, 10**12) is refused at once, not after materialising a list of its items.
    if isinstance(value, range):
        if len(value) == 0 or min(value[0], value[-1]) <= 0 or max(value[0], value[-1]) >= limit:
            raise parameter_error("lags", requirement, value)
        return np.arange(value.start, value.stop, value.step, dtype=np.int64)
    if isinstance(value, np.ndarray) and value.ndim == 1 and value.dtype.kind in "iu":
        if value.size == 0 or value.min() <= 0 or value.max() >= limit:
            raise parameter_error("lags", requirement, value)
        return value.astype(np.int64)
    if is_integer(value):
        items = [value]
    elif (isinstance(value, np.ndarray) and value.ndim == 1) or (
            isinstance(value, Sequence) and not isinstance(value, (str, bytes))):
        items = list(value)
    else:
        raise parameter_error("lags", requirement, value)
    if not items or not all(is_integer(v) and 0 < v < limit for v in items):
        raise parameter_error("lags", requirement, value)
    return np.asarray([int(v) for v in items], dtype=np.int64)


def check_model_df(value, min_lag: int) -> int:
    """``model_df`` is an integer with 0 <= model_df < min(lags)."""
    if not is_integer(value) or not 0 <= value < min_lag:
        raise parameter_error("model_df", f"an integer with 0 <= model_df < {min_lag}", value)
    return int(value)


def check_level(value) -> float:
    """``level`` is a number strictly between 0 and 1."""
    if not is_real_number(value) or not 0 < value < 1:
        raise parameter_error("level", "a number with 0 < level < 1", value)
    return float(value)


def check_band(value) -> str:
    return check_choice("band", value, BAND_OPTIONS)


def check_noise_model(value) -> str:
    return check_choice("noise_model", value, NOISE_MODEL_OPTIONS)


def check_nan_policy(value) -> str:
    return check_choice("nan_policy", value, NAN_POLICY_OPTIONS)


def check_profile(value) -> str:
    return check_choice("profile", value, PROFILE_OPTIONS)


def check_adjusted(value) -> bool:
    """``adjusted`` is exactly True or False (numpy bools too)."""
    if not isinstance(value, (bool, np.bool_)):
        raise parameter_error("adjusted", "True or False", value)
    return bool(value)


def check_n_params(value, n_obs: int | None = None) -> int:
    """``n_params >= 0``; with ``n_obs`` also ``n_params < n_obs - 1`` (aicc and fpe need it)."""
    if not is_integer(value) or value < 0:
        raise parameter_error("n_params", "an integer with n_params >= 0", value)
    if n_obs is not None and not value < n_obs - 1:
        raise parameter_error("n_params", f"less than n_obs - 1 = {n_obs - 1}", value)
    return int(value)


def check_n_obs(value) -> int:
    if not is_integer(value) or value < 1:
        raise parameter_error("n_obs", "an integer with n_obs >= 1", value)
    return int(value)


def check_rss(value) -> float:
    # An integer beyond float64's range (10**400) is not a finite float64: the same error, not
    # Python's OverflowError from the conversion.
    try:
        as_float = float(value) if is_real_number(value) else math.nan
    except OverflowError:
        as_float = math.inf
    if not math.isfinite(as_float) or as_float < 0:
        raise parameter_error("rss", "a finite number >= 0", value)
    return as_float


def check_n(value) -> int:
    """``n`` of :func:`confidence_band`: an integer >= 1."""
    if not is_integer(value) or value < 1:
        raise parameter_error("n", "an integer with n >= 1", value)
    return int(value)


def check_n_joints(value, rows: int, m: int, three_d: bool) -> int | None:
    """Check ``n_joints`` for a regressor with ``rows`` rows against ``e`` with ``m`` joints.

    A stacked 2-D regressor needs a positive integer dividing its rows; it must also equal m.
    A 3-D regressor needs nothing, so ``n_joints`` must be None or m.
    """
    if three_d and value is None:
        return None
    if not is_integer(value) or value <= 0 or (not three_d and rows % value != 0):
        raise parameter_error("n_joints", "a positive integer dividing the regressor rows", value)
    if value != m:
        raise parameter_error("n_joints", f"equal to the number of joints of e (m={m})", value)
    return int(value)


def check_test(value) -> str:
    """Kernel-level option of ``portmanteau``: which statistic."""
    return check_choice("test", value, PORTMANTEAU_TESTS)


def check_n_columns(value, total: int, m: int) -> int:
    """Kernel-level ``n_columns`` of ``cross_correlation``: p with ``m * p`` equal to Y's columns."""
    if not is_integer(value) or value <= 0 or value * m != total:
        raise parameter_error("n_columns", f"a positive integer with m*n_columns = {total}", value)
    return int(value)


# --------------------------------------------------------------------------- report options


def check_sample_rate(value):
    """``sample_rate``: None, or a finite number > 0 (Hz)."""
    if value is None:
        return None
    if not is_real_number(value) or not math.isfinite(value) or value <= 0:
        raise parameter_error("sample_rate", "None or a finite number > 0 (Hz)", value)
    return float(value)


def check_bandwidth(value, sample_rate, rate_known: bool = True):
    """``bandwidth``: None, or a finite number > 0 (Hz), which needs a sample rate (or time stamps)
    and is at most its Nyquist frequency (``rate_known`` False: the rate comes later, with a
    stream's time stamps, :func:`check_nyquist`)."""
    if value is None:
        return None
    if not is_real_number(value) or not math.isfinite(value) or value <= 0:
        raise parameter_error("bandwidth", "None or a finite number > 0 (Hz)", value)
    if not rate_known:
        return float(value)
    if sample_rate is None:
        raise parameter_error("bandwidth", "None without sample_rate or time (it is in Hz)", value)
    check_nyquist(value, sample_rate)
    return float(value)


def check_nyquist(bandwidth, sample_rate: float) -> None:
    """A band above the Nyquist frequency says nothing about the samples (InvalidParameter)."""
    nyquist = float(sample_rate) / 2.0
    if bandwidth > nyquist:
        raise parameter_error("bandwidth", f"at most the Nyquist frequency {nyquist:.6g} Hz (half the sample rate "
                              f"{float(sample_rate):.6g} Hz)", bandwidth)


def check_decimate(value):
    """``decimate``: 'auto', None, or an integer >= 1."""
    if value is None or (isinstance(value, str) and value == "auto"):
        return value
    if not is_integer(value) or int(value) < 1 or int(value) >= 2**63:
        raise parameter_error("decimate", "'auto', None or an integer >= 1", value)
    return int(value)


def check_names(param: str, value, count: int, what: str):
    """``joint_names`` / ``column_names``: None or ``count`` distinct strings."""
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise parameter_error(param, f"None or a sequence of {count} distinct strings (one per {what})", value)
    names = list(value)
    if len(names) != count or not all(isinstance(s, str) and s for s in names) or len(set(names)) != count:
        raise parameter_error(param, f"None or a sequence of {count} distinct strings (one per {what})", value)
    return names


def check_detail(value) -> str:
    return check_choice("cross_correlation_detail", value, ("top", "full"))


def named_segments(segments):
    """``{name: length}`` or ``[(name, length), ...]`` → (names, lengths); anything else (None, [])."""
    if isinstance(segments, dict):
        items = list(segments.items())
    elif (isinstance(segments, (list, tuple)) and segments
          and all(isinstance(t, tuple) and len(t) == 2 and isinstance(t[0], str) for t in segments)):
        items = list(segments)
    else:
        return None, segments
    names = [k for k, _ in items]
    if not all(isinstance(k, str) and k for k in names) or len(set(names)) != len(names):
        raise parameter_error("segments", "a mapping of distinct non-empty names to positive lengths", segments)
    return names, [v for _, v in items]


def check_signal_like(value, name: str, n: int, m: int) -> np.ndarray:
    """An extra (N, m) signal such as the validation run's ``q``: same checks as tau_meas."""
    arr = to_float_array(value, name)
    two = promote_signal(arr, name)
    if two.shape != (n, m):
        raise ShapeMismatch(f"tau_meas and {name} must have the same shape, got ({n}, {m}) and "
                            f"{format_shape(arr.shape)}")
    check_finite(two, name)
    return two


ESTIMATION_KEYS = ("q", "dq", "ddq", "regressor", "tau", "bandwidth")


def check_estimation(value, m: int):
    """``estimation``: a mapping with any of 'q', 'dq', 'ddq', 'regressor', 'tau', 'bandwidth' for
    the estimation run (contract §4: 'dq', 'ddq' need 'q' and its shape; 'bandwidth' Hz > 0)."""
    if value is None:
        return None
    requirement = "None or a mapping with any of " + ", ".join(repr(k) for k in ESTIMATION_KEYS)
    if not isinstance(value, dict) or not value:
        raise parameter_error("estimation", requirement, value)
    unknown = [k for k in value if k not in ESTIMATION_KEYS]
    if unknown:  # name the key, not the arrays
        raise InvalidParameter(f"estimation must be {requirement}, got a mapping with the key {unknown[0]!r}")
    out: dict[str, Any] = {}
    for key, arr in value.items():
        name = f"estimation[{format_value(key)}]"
        if key == "bandwidth":
            if isinstance(arr, bool) or not isinstance(arr, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(float(arr)) or not float(arr) > 0:
                raise parameter_error(name, "a finite number of Hz > 0", arr)
            out[key] = float(arr)
            continue
        a = to_float_array(arr, name)
        if key == "regressor":
            if a.ndim == 2 and a.shape[0] % m == 0:
                a = a.reshape(a.shape[0] // m, m, a.shape[1])
            if a.ndim != 3 or a.shape[1] != m:
                raise InvalidShape(f"{name} must be 3-D (N, m, p) with m={m}, or 2-D (N*m, p), got shape "
                                   f"{format_shape(np.shape(arr))}")
            check_finite(a.reshape(a.shape[0], -1), name)
        else:
            a = promote_signal(a, name)
            if a.shape[1] != m:
                raise ShapeMismatch(f"{name} must have m={m} columns, got shape {format_shape(np.shape(arr))}")
            check_finite(a, name)
        out[key] = a
    for key in ("dq", "ddq"):
        if key in out and "q" not in out:
            raise parameter_error(f"estimation[{key!r}]", "given with estimation['q'] (the positions they derive from)",
                                  "without estimation['q']")
        if key in out and out[key].shape != out["q"].shape:
            raise ShapeMismatch(f"estimation[{key!r}] must have the shape of estimation['q'] "
                                f"{format_shape(out['q'].shape)}, got shape {format_shape(out[key].shape)}")
    return out


def check_model_columns(value, p: int | None, column_names):
    """``model_columns``: None, or the regressor columns (indices or names) the model contains."""
    if value is None:
        return None
    requirement = ("None or a sequence of regressor column indices or names"
                   + ("" if p is not None else " (it needs a regressor)"))
    if p is None or isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise parameter_error("model_columns", requirement, value)
    out = []
    for item in value:
        if isinstance(item, str) and column_names is not None and item in column_names:
            out.append(column_names.index(item))
        elif is_integer(item) and 0 <= int(item) < p:
            out.append(int(item))
        else:
            raise parameter_error("model_columns", requirement, value)
    return sorted(set(out))


def motion_arrays(n: int, q: Any, dq: Any, ddq: Any) -> list[np.ndarray]:
    """q, dq, ddq checked as (N, n) finite arrays of one shape (a robot model's motion: URDF, MJCF)."""
    arrays = []
    for name, x in (("q", q), ("dq", dq), ("ddq", ddq)):
        a = promote_signal(to_float_array(x, name), name)
        if a.shape[1] != n:
            raise parameter_error(name, f"an array of shape (N, {n})", f"shape {a.shape}")
        check_finite(a, name)
        arrays.append(np.ascontiguousarray(a))
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise ShapeMismatch(f"q, dq and ddq must have the same shape, got "
                            f"{arrays[0].shape}, {arrays[1].shape} and {arrays[2].shape}")
    return arrays
