"""Fuzzing every public function and every ``_core`` kernel.

The outcome of any call is a result or a documented ``dynval.InputError``; never another
exception, a crash or a warning (pytest turns warnings into errors). Both backends give the same
outcome: the same error kind and message, or results of the same shape that agree numerically
when the data are well conditioned (adversarial draws — NaN, ±inf, 1e300 next to 1e-300 — check
outcomes and shapes only, because rounding legitimately differs there).

Inputs: shapes from empty to a few dozen rows, dtypes float64/float32/int64/bool, layouts C,
Fortran, reversed, strided and negative strides on length-1 axes, special values (subnormals,
the 1e144 bound and just beyond it, ±0, NaN, ±inf), data scales from 1e-310 to 1e140, and
parameters of every kind (huge integers, bools, floats, strings, None, sequences).

``DYNVAL_FUZZ_EXAMPLES`` sets the examples per test (scripts/sanitize.sh runs it against an
AddressSanitizer + UndefinedBehaviorSanitizer build of ``_core``).
"""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dynval
from dynval.kernels import _reference as ref

HAS_CPP = dynval.backends()["cpp"]["available"]
if HAS_CPP:
    from dynval import _core

EXAMPLES = int(os.environ.get("DYNVAL_FUZZ_EXAMPLES", "40"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=list(HealthCheck),
)

SPECIAL = [0.0, -0.0, 1.0, -1.0, np.nan, np.inf, -np.inf, 5e-324, 2.2250738585072014e-308, 1e-300, 1e-162,
           1e-80, 1e80, 1e144, -1e144, 1.0000000000000002e144, 1e300, 1.7976931348623157e308]
SCALES = [1.0, 1e-310, 2.0**-1060, 1e-162, 1e-150, 1e-80, 1e-5, 1e5, 1e80, 1e140]
HUGE_INTS = [0, 1, 2, -1, 2**31, 2**62 + 1, 2**63 - 1, 2**63, -(2**63), 10**400]
ANY_PARAM = st.one_of(
    st.sampled_from(HUGE_INTS),
    st.integers(-3, 12),
    st.booleans(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([None, "pooled", "raw_values", "per_sample", "full", "", "x", [1, 2], [0, 3], (), [2**64]]),
)


# --------------------------------------------------------------------------- data


def _layout(draw, a: np.ndarray) -> np.ndarray:
    """The same values in a drawn memory layout."""
    kind = draw(st.sampled_from(["C", "F", "reversed", "strided", "flip-length-1"]))
    if a.ndim == 0 or a.size == 0:
        return a
    if kind == "F":
        return np.asfortranarray(a)
    if kind == "reversed":
        return np.ascontiguousarray(a[::-1])[::-1]
    if kind == "strided":
        return np.repeat(a, 2, axis=-1)[..., ::2]
    if kind == "flip-length-1":
        index = tuple(slice(None, None, -1) if size == 1 else slice(None) for size in a.shape)
        return np.ascontiguousarray(a[index])[index]
    return a


@st.composite
def values(draw, shape, nice: bool):
    """An array of `shape`: scaled normal data with an offset (nice) or anything (adversarial)."""
    with np.errstate(all="ignore"):  # building the data may overflow on purpose
        return _layout(draw, _values(draw, shape, nice))


def _values(draw, shape, nice):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from(SCALES))
    offset = draw(st.sampled_from([0.0, 0.0, 3.0, -1e3]))
    a = (rng.normal(size=shape) + offset) * scale
    if not nice and a.size:
        for _ in range(draw(st.integers(0, 4))):
            index = tuple(draw(st.integers(0, s - 1)) for s in shape)
            a[index] = draw(st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True)))
        if draw(st.booleans()):
            a = np.round(a * draw(st.sampled_from([1.0, 4.0]))) / 4.0  # ties and constant runs
    dtype = draw(st.sampled_from(["float64", "float64", "float32", "int64", "bool"]))
    if dtype == "float32":
        a = a.astype(np.float32)
    elif dtype in ("int64", "bool"):
        finite = np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)
        a = np.clip(np.round(finite), -1e6, 1e6).astype(dtype)
    return a


@st.composite
def problems(draw, nice: bool):
    """(tau, pred, regressor, extras): shapes that usually match, sometimes do not."""
    n = draw(st.integers(0, 40))
    m = draw(st.integers(1, 3))
    p = draw(st.integers(1, 3))
    one_d = m == 1 and draw(st.booleans())
    shape = (n,) if one_d else (n, m)
    tau = draw(values(shape, nice))
    pred_shape = shape if nice or draw(st.integers(0, 9)) else (max(n - 1, 0), m + 1)
    pred = draw(values(pred_shape, nice))
    y = draw(values((n, m, p), nice))
    if not nice and draw(st.integers(0, 9)) == 0:
        y = draw(values((n * m, p), nice))  # the stacked form, with or without n_joints
    max_lag = draw(st.integers(0, max(n - 1, 0))) if nice else draw(st.one_of(st.integers(-2, n + 1), ANY_PARAM))
    segments = None
    if n >= 4 and draw(st.booleans()):
        cut = draw(st.integers(1, n - 1))
        segments = draw(st.sampled_from([[cut, n - cut], [0, cut]]))
        if nice:
            max_lag = min(max_lag, max(cut, n - cut) - 1)
    if not nice and draw(st.integers(0, 4)) == 0:
        segments = draw(st.sampled_from([[0], [n], [2**63 - 1, 2**63 - 1, n + 2], [-1, n + 1], range(10**12), "x"]))
    return tau, pred, y, {"max_lag": max_lag, "segments": segments, "n": n, "m": m}


# --------------------------------------------------------------------------- calls


def _call(f, backend):
    """('ok', value) or ('error', kind, message); any other exception propagates (a failure)."""
    try:
        return ("ok", _plain(f(backend)))
    except dynval.InputError as error:
        return ("error", error.kind, str(error))


def _plain(value):
    if hasattr(value, "to_dict") and not isinstance(value, dict):
        value = value.to_dict()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items() if k not in ("provenance",)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _close(a, b, path="", floor=0.0):
    """``floor``: the least scale of the values compared (a residual mean's is its RMS: a mean of
    values of ±1e6 that nearly cancel is known to rounding of 1e6, not of itself)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _close(a[k], b[k], f"{path}.{k}", _mean_floor(a, b) if k == "mean" else 0.0)
        return
    if isinstance(a, list) and a and isinstance(a[0], (dict, list, str)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{path}[{i}]")
        return
    if isinstance(a, str) or a is None:
        assert a == b, path
        return
    x = np.asarray(a, dtype=np.float64)
    y = np.asarray(b, dtype=np.float64)
    assert x.shape == y.shape, path
    finite = np.isfinite(x) & np.isfinite(y)
    scale = max(np.max(np.abs(x[finite]), initial=0.0), np.max(np.abs(y[finite]), initial=0.0), 1e-300)
    if any(name in path for name in ("vaf", "fit", "r2", "cross_correlation", "autocorrelation")):
        scale = max(scale, 1.0)  # fractions of 1 (or 100): their natural size, not their value
    scale = max(scale, floor)
    np.testing.assert_allclose(x[finite], y[finite], rtol=1e-6, atol=1e-6 * scale, err_msg=path)


def _mean_floor(a: dict, b: dict) -> float:
    """The RMS beside a mean in the same record (``variance`` with ``mean``), else 0."""
    if "variance" not in a:
        return 0.0
    values = [np.asarray(d[k], dtype=np.float64) for d in (a, b) for k in ("variance", "mean")
              if d.get(k) is not None and not isinstance(d[k], str)]
    squares = [np.abs(v) if i % 2 == 0 else v * v for i, v in enumerate(values)]
    finite = [x[np.isfinite(x)] for x in squares]
    return float(np.sqrt(max((float(np.max(x, initial=0.0)) for x in finite), default=0.0)))


def _agree(f, check_values: bool, name: str = ""):
    """Both backends: a result or an InputError, the same kind and message, close values."""
    outcomes = [_call(f, b) for b in (["python", "cpp"] if HAS_CPP else ["python"])]
    if len(outcomes) < 2:
        return
    a, b = outcomes
    assert a[0] == b[0], (a, b)
    if a[0] == "error":
        assert a[1:] == b[1:], (a, b)
        return
    if check_values:
        _close(a[1], b[1], name)
    else:
        _shapes_match(a[1], b[1])


def _shapes_match(a, b):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _shapes_match(a[k], b[k])
    elif not isinstance(a, (str, type(None))) \
            and not (isinstance(a, list) and a and isinstance(a[0], (dict, tuple, list))):
        assert np.shape(a) == np.shape(b)


def _public_calls(tau, pred, y, extra):
    lag, seg = extra["max_lag"], extra["segments"]
    n_joints = extra["m"] if np.ndim(y) == 2 else None
    return {
        "residuals": lambda b: dynval.residuals(tau, pred, backend=b),
        "sse": lambda b: dynval.sse(tau, pred, multioutput="raw_values", backend=b),
        "rmse": lambda b: dynval.rmse(tau, pred, convention="per_sample", backend=b),
        "max_abs_error": lambda b: dynval.max_abs_error(tau, pred, backend=b),
        "vaf": lambda b: dynval.vaf(tau, pred, multioutput="variance_weighted", backend=b),
        "fit_percent": lambda b: dynval.fit_percent(tau, pred, multioutput="uniform_average", backend=b),
        "r2": lambda b: dynval.r2(tau, pred, multioutput="raw_values", backend=b),
        "r2_pooled": lambda b: dynval.r2(tau, pred, backend=b),
        "residual_mean": lambda b: dynval.residual_mean(tau, backend=b),
        "residual_variance": lambda b: dynval.residual_variance(tau, ddof=0, backend=b),
        "zero_mean_test": lambda b: dynval.zero_mean_test(tau, segments=seg, backend=b),
        "autocorrelation": lambda b: dynval.autocorrelation(tau, lag, segments=seg, backend=b),
        "ljung_box": lambda b: dynval.ljung_box(tau, lag, segments=seg, backend=b),
        "box_pierce": lambda b: dynval.box_pierce(tau, [1, lag] if isinstance(lag, int) else lag, segments=seg,
                                                  backend=b),
        "cross_correlation": lambda b: dynval.cross_correlation(tau, y, lag, n_joints=n_joints, segments=seg,
                                                            backend=b).rho,
        "criteria": lambda b: dynval.criteria(tau, pred, n_params=2, noise_model="per_joint", backend=b),
        "aic": lambda b: dynval.aic(tau, pred, n_params=1, noise_model="full", backend=b),
        "bic": lambda b: dynval.bic(tau, pred, n_params=3, backend=b),
        "omit": lambda b: dynval.r2(tau, pred, nan_policy="omit", backend=b),
        "validate": lambda b: _numeric_sections(dynval.validate(
            tau, pred, n_params=2, regressor=y, n_joints=n_joints, segments=seg,
            max_lag=lag if isinstance(lag, int) and lag < 6 else None, backend=b)),
    }


def _numeric_sections(report):
    """The report's numbers; findings and ranked cell lists are decisions at thresholds, where
    rounding may legitimately fall on either side."""
    d = report.to_dict()
    return {k: d[k] for k in ("per_joint", "pooled", "aggregates", "residuals", "information_criteria")}


PUBLIC = sorted(_public_calls(None, None, None, {"max_lag": 0, "segments": None, "m": 1}))


def _difference(a, b):
    with np.errstate(all="ignore"):
        return np.subtract(a, b, dtype=float)


def _numerically_tame(*arrays) -> bool:
    """Well conditioned for a comparison of values: a spread well above the offset's rounding."""
    with np.errstate(all="ignore"):
        return _tame(arrays)


def _tame(arrays) -> bool:
    for a in arrays:
        x = np.asarray(a, dtype=np.float64)
        if x.size == 0 or x.ndim == 0:
            continue
        x = x.reshape(x.shape[0], -1)
        if x.shape[0] < 2:
            continue
        spread = x.max(axis=0) - x.min(axis=0)
        big = np.abs(x).max(axis=0)
        if not np.all(np.isfinite(x)) or np.any(spread < 1e-6 * big) or np.any(big > 1e130) \
                or np.any((big > 0) & (big < 1e-300)):
            return False
    return True


@pytest.mark.parametrize("function", PUBLIC)
@FUZZ
@given(data=st.data())
def test_public_functions_adversarial(function, data):
    tau, pred, y, extra = data.draw(problems(nice=False))
    _agree(_public_calls(tau, pred, y, extra)[function], check_values=False)


@pytest.mark.parametrize("function", PUBLIC)
@FUZZ
@given(data=st.data())
def test_public_functions_agree_on_values(function, data):
    tau, pred, y, extra = data.draw(problems(nice=True))
    with np.errstate(all="ignore"):
        residual = np.asarray(tau, dtype=float) - np.asarray(pred, dtype=float)
    tame = _numerically_tame(tau, pred, residual, y)
    # The full noise model decides singularity on an eigenvalue ratio: near it, the backends may
    # round to different sides. Its values are compared on well-conditioned draws only.
    _agree(_public_calls(tau, pred, y, extra)[function], check_values=tame, name=function)


@FUZZ
@given(rss=st.one_of(ANY_PARAM, st.floats(0, 1e308)), n_obs=ANY_PARAM, n_params=ANY_PARAM,
       level=st.one_of(ANY_PARAM, st.floats(0, 1)))
def test_scalar_functions(rss, n_obs, n_params, level):
    _agree(lambda b: dynval.information_criteria(rss, n_obs, n_params, backend=b), check_values=True)
    _agree(lambda b: dynval.confidence_band(n_obs, level=level, backend=b), check_values=True)


# --------------------------------------------------------------------------- kernels


@st.composite
def kernel_arrays(draw):
    n = draw(st.integers(0, 30))
    m = draw(st.integers(0, 3))
    nice = draw(st.booleans())
    a = draw(values((n, m), nice))
    b = draw(values((n, m) if draw(st.integers(0, 5)) else (n + 1, m), nice))
    return a, b, nice


def _kernel_calls(a, b, p1, p2, p3, starts):
    return {
        "residuals": lambda k: k.residuals(a, b),
        "sse": lambda k: k.sse(a, b, p1),
        "rmse": lambda k: k.rmse(a, b, p1, p2 if isinstance(p2, str) else ""),
        "max_abs_error": lambda k: k.max_abs_error(a, b, p1),
        "vaf": lambda k: k.vaf(a, b, p1),
        "fit_percent": lambda k: k.fit_percent(a, b, p1),
        "r2": lambda k: k.r2(a, b, p1),
        "residual_mean": lambda k: k.residual_mean(a),
        "residual_variance": lambda k: k.residual_variance(a, p1),
        "autocorrelation": lambda k: k.autocorrelation(a, p1, p2, starts),
        "portmanteau": lambda k: k.portmanteau(a, p1 if not isinstance(p1, int) else np.array([p1]), p2, starts,
                                               p3 if isinstance(p3, str) else "box_pierce"),
        "cross_correlation": lambda k: k.cross_correlation(a, b, p1, p2, p3, starts),
        "information_criteria": lambda k: k.information_criteria(p1, p2, p3),
        "criteria": lambda k: k.criteria(a, b, p1, p2),
        "compute_metrics": lambda k: k.compute_metrics(a, b, p1, p2, p3),
        "first_nonfinite": lambda k: k.first_nonfinite(a),
    }


KERNELS = sorted(_kernel_calls(*([None] * 6)))


@pytest.mark.skipif(not HAS_CPP, reason="needs the compiled backend")
@pytest.mark.parametrize("kernel", KERNELS)
@FUZZ
@given(arrays=kernel_arrays(), p1=ANY_PARAM, p2=ANY_PARAM, p3=ANY_PARAM,
       starts=st.sampled_from([[0], [0, 2], [0, 2**62], [1], [0, 0], [], [2**63 - 1]]))
def test_kernels_agree(kernel, arrays, p1, p2, p3, starts):
    a, b, nice = arrays
    call = _kernel_calls(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64), p1, p2, p3,
                         np.asarray(starts, dtype=np.int64))[kernel]
    # The reference kernels leave shape checks to the facade (contract §5: the facade checks
    # type, shape and size); the C++ kernels check them too. Shapes the facade would refuse are
    # fuzzed on _core alone, for crashes.
    valid_shapes = a.ndim == 2 and a.shape[0] >= 2 and a.shape[1] >= 1 and a.shape == b.shape
    outcomes = []
    for module in (ref, _core) if valid_shapes else (_core,):
        try:
            outcomes.append(("ok", call(module)))
        except dynval.InputError as error:
            outcomes.append(("error", error.kind))
        except (TypeError, OverflowError) as error:
            # Kernels take typed arguments (contract §5.1): a wrong Python type for an option is
            # refused by the binding or by numpy before any check. Never a crash, never silent.
            outcomes.append(("type", type(error).__name__))
    kinds = {o[0] for o in outcomes}
    if "type" in kinds or not valid_shapes:
        return
    assert outcomes[0][0] == outcomes[1][0], (outcomes[0][:2], outcomes[1][:2])
    if outcomes[0][0] == "error":
        assert outcomes[0][1] == outcomes[1][1]
    elif nice and a.shape == b.shape and _numerically_tame(a, b, _difference(a, b)):
        _close(_plain(outcomes[0][1]), _plain(outcomes[1][1]), kernel)


# --------------------------------------------------------------------------- StreamState.__setstate__


@st.composite
def saved_stream_states(draw):
    """A pickled ``_core.StreamState`` (its ``__getstate__`` tuple) with one to three of its items
    replaced: arrays of other sizes and values, counts, lengths, exponents, layouts."""
    m, p = draw(st.integers(1, 3)), draw(st.integers(0, 2))
    acf = draw(st.integers(0, 6))
    layout = (m, p, acf, draw(st.integers(0, acf)), draw(st.booleans()))
    state = _core.StreamState(*layout)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    for _ in range(draw(st.integers(0, 2))):
        rows = draw(st.integers(0, 12))
        y = rng.normal(size=(rows, m * p)) if p else None
        state.append(rng.normal(size=(rows, m)), rng.normal(size=(rows, m)), y)
        if draw(st.booleans()):
            state.end_break = True
    saved = list(state.__getstate__())
    arrays = list(saved[6])
    small_ints = st.one_of(st.integers(-3, 40), st.sampled_from(HUGE_INTS))
    for _ in range(draw(st.integers(1, 3))):
        what = draw(st.sampled_from(["array", "array", "array", "n", "lengths", "pairs", "exps", "layout", "flag"]))
        if what == "array":
            i = draw(st.integers(0, len(arrays) - 1))
            size = draw(st.integers(0, 2 * arrays[i].size + 3))
            values = np.array(draw(st.lists(st.sampled_from(SPECIAL + [0.5, -2.0]), min_size=size, max_size=size)))
            kind = draw(st.sampled_from(["float64", "float32", "int64"]))
            with np.errstate(all="ignore"):  # 1e300 as float32 is inf on purpose
                arrays[i] = np.arange(size) if kind == "int64" else values.astype(kind)
        elif what == "n":
            saved[1] = draw(small_ints)
        elif what == "lengths":
            saved[2] = draw(st.lists(small_ints, max_size=4))
        elif what == "pairs":
            saved[5] = np.array(draw(st.lists(st.integers(-2, 50), max_size=10)), dtype=np.int64)
        elif what == "exps":
            exps = list(saved[7])
            k = draw(st.integers(0, 2))
            exps[k] = np.array(draw(st.lists(st.sampled_from([0, 1, -1073, 1024, 1025, -5000, 2**40]), max_size=7)),
                               dtype=np.int64)
            saved[7] = tuple(exps)
        elif what == "layout":
            saved[0] = tuple(draw(st.lists(small_ints, min_size=4, max_size=4))) + (draw(st.booleans()),)
        else:
            saved[draw(st.sampled_from([3, 4]))] = draw(ANY_PARAM)
    saved[6] = arrays
    return tuple(saved)


def _exercise(state) -> None:
    """Everything a restored state can be asked: its sums, copies, pickling, merges both ways with a
    state of its layout, more rows."""
    layout = state.__getstate__()[0]
    m, p = layout[0], layout[1]
    state.sums()
    pickle.loads(pickle.dumps(state.copy())).sums()
    rng = np.random.default_rng(0)
    other = _core.StreamState(*layout)
    other.append(rng.normal(size=(9, m)), rng.normal(size=(9, m)), rng.normal(size=(9, m * p)) if p else None)
    before = other.copy()
    before.merge(state)
    before.sums()
    state.merge(other)
    state.append(rng.normal(size=(5, m)), rng.normal(size=(5, m)), rng.normal(size=(5, m * p)) if p else None)
    state.sums()


@pytest.mark.skipif(not HAS_CPP, reason="needs the compiled backend")
@FUZZ
@given(saved=saved_stream_states())
def test_stream_state_setstate_checks_every_size(saved):
    """A pickle whose sizes do not match its layout is refused (InvalidParameter naming the field,
    or ValueError for a layout over the state's bound, TypeError for a wrong container) before
    anything reads it; one that is accepted is a state every operation can use. Under
    scripts/sanitize.sh an out-of-bounds access here is a sanitizer report."""
    restored = _core.StreamState.__new__(_core.StreamState)
    try:
        restored.__setstate__(saved)
    except dynval.InputError as error:
        assert str(error).startswith("StreamState.__setstate__: ")
        return
    except (ValueError, TypeError):
        return
    try:
        _exercise(restored)
    except dynval.InputError as error:  # row counts whose sum overflows 64 bits
        assert "overflow 64 bits" in str(error), error
