"""Contract §2: error kinds, exact messages, check order (type -> shape -> size -> finiteness -> parameters)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import dynval
from dynval.checks import _validation
from dynval.kernels import _backend
from dynval.statistics._periodic import detect_period

NAN, INF = float("nan"), float("inf")
GOOD = np.arange(10.0)
GOOD2 = np.column_stack([np.arange(10.0), np.arange(10.0) ** 2])


def raises(kind, message):
    """pytest.raises for a contract error with an exact message."""
    return pytest.raises(dynval.error_class(kind), match="^" + re.escape(message) + "$")


# --------------------------------------------------------------------------- the classes


def test_error_classes_and_kinds():
    assert dynval.ERROR_KINDS == (
        "InvalidType",
        "InvalidShape",
        "ShapeMismatch",
        "TooFewSamples",
        "NonFiniteInput",
        "InvalidParameter",
    )
    for kind in dynval.ERROR_KINDS:
        cls = dynval.error_class(kind)
        assert cls is getattr(dynval, kind)
        assert issubclass(cls, dynval.InputError) and issubclass(cls, ValueError)
        assert cls("x").kind == kind
    assert issubclass(dynval.InvalidType, TypeError)
    assert not issubclass(dynval.InvalidShape, TypeError)
    with pytest.raises(KeyError):
        dynval.error_class("Nope")


# --------------------------------------------------------------------------- InvalidType


@pytest.mark.parametrize(
    ("value", "what"),
    [
        (None, "NoneType"),
        ("abc", "str"),
        (np.array([1 + 2j, 3j]), "complex128"),
        (["a", "b"], "<U1"),
        (np.array([1.0, None], dtype=object), "object"),
        (np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[D]"), "datetime64[D]"),
        ([[1.0, 2.0], [3.0]], "object"),
    ],
)
def test_invalid_type(backend, value, what):
    with raises("InvalidType", f"tau_meas must be an array of real numbers, got {what}"):
        dynval.r2(value, [1.0, 2.0], backend=backend)
    with raises("InvalidType", f"tau_pred must be an array of real numbers, got {what}"):
        dynval.r2([1.0, 2.0], value, backend=backend)


def test_invalid_type_is_type_error(backend):
    with pytest.raises(TypeError):
        dynval.sse(None, None, backend=backend)
    with raises("InvalidType", "e must be an array of real numbers, got complex128"):
        dynval.autocorrelation(np.ones(5, dtype=complex), 1, backend=backend)
    with raises("InvalidType", "regressor must be an array of real numbers, got NoneType"):
        dynval.cross_correlation(GOOD, None, 1, backend=backend)


# --------------------------------------------------------------------------- InvalidShape


def test_invalid_shape_signal(backend):
    with raises("InvalidShape", "tau_meas must be 1-D (N,) or 2-D (N, m), got shape (2, 2, 2)"):
        dynval.rmse(np.ones((2, 2, 2)), np.ones((2, 2, 2)), backend=backend)
    with raises("InvalidShape", "tau_pred must be 1-D (N,) or 2-D (N, m), got shape ()"):
        dynval.rmse([1.0], 1.0, backend=backend)
    with raises("InvalidShape", "tau_meas must have at least one column, got shape (3, 0)"):
        dynval.rmse(np.ones((3, 0)), np.ones((3, 0)), backend=backend)
    with raises("InvalidShape", "e must be 1-D (N,) or 2-D (N, m), got shape (4, 1, 1)"):
        dynval.residual_mean(np.ones((4, 1, 1)), backend=backend)


def test_invalid_shape_regressor(backend):
    msg = "regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape {}"
    with raises("InvalidShape", msg.format("(10, 3)")):
        dynval.cross_correlation(GOOD, np.ones((10, 3)), 1, backend=backend)
    with raises("InvalidShape", msg.format("(10,)")):
        dynval.cross_correlation(GOOD, np.ones(10), 1, n_joints=1, backend=backend)
    with raises("InvalidShape", msg.format("(10, 1, 1, 1)")):
        dynval.cross_correlation(GOOD, np.ones((10, 1, 1, 1)), 1, backend=backend)
    with raises("InvalidShape", "regressor must have at least one column, got shape (10, 1, 0)"):
        dynval.cross_correlation(GOOD, np.ones((10, 1, 0)), 1, backend=backend)


# --------------------------------------------------------------------------- ShapeMismatch


def test_shape_mismatch(backend):
    with raises("ShapeMismatch", "tau_meas and tau_pred must have the same shape, got (5,) and (4,)"):
        dynval.r2(np.ones(5), np.ones(4), backend=backend)
    with raises("ShapeMismatch", "tau_meas and tau_pred must have the same shape, got (5, 2) and (5, 3)"):
        dynval.sse(np.ones((5, 2)), np.ones((5, 3)), backend=backend)
    with raises("ShapeMismatch", "tau_meas and tau_pred must have the same shape, got (5,) and (5, 2)"):
        dynval.sse(np.ones(5), np.ones((5, 2)), backend=backend)


def test_shape_mismatch_regressor(backend):
    with raises("ShapeMismatch", "regressor must have shape (N, m, p) = (10, 2, p) to match e, got (9, 2, 3)"):
        dynval.cross_correlation(GOOD2, np.ones((9, 2, 3)), 1, backend=backend)
    with raises("ShapeMismatch", "regressor must have shape (N, m, p) = (10, 2, p) to match e, got (10, 1, 3)"):
        dynval.cross_correlation(GOOD2, np.ones((10, 1, 3)), 1, backend=backend)
    with raises("ShapeMismatch", "regressor has 19 rows, which is not N*m = 10*2"):
        dynval.cross_correlation(GOOD2, np.ones((19, 3)), 1, n_joints=2, backend=backend)


# --------------------------------------------------------------------------- TooFewSamples

MINIMUM = {
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
}


def call_with_n(function, n, backend):
    """Call a public function on n samples of otherwise valid data."""
    x = np.linspace(0.0, 1.0, n)
    f = getattr(dynval, function)
    if function in ("residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2"):
        return f(x, x + 1.0, backend=backend)
    if function in ("aic", "bic"):
        return f(x, x + 1.0, n_params=0, backend=backend)
    if function in ("residual_mean", "residual_variance", "zero_mean_test"):
        return f(x, backend=backend)
    if function == "autocorrelation":
        return f(x, 0, backend=backend)
    if function in ("ljung_box", "box_pierce"):
        return f(x, 1, backend=backend)
    return f(x, x[:, None, None], 0, backend=backend)


@pytest.mark.parametrize("function", sorted(MINIMUM))
def test_too_few_samples(backend, function):
    k = MINIMUM[function]
    with raises("TooFewSamples", f"{function} needs at least {k} samples, got N={k - 1}"):
        call_with_n(function, k - 1, backend)
    call_with_n(function, k, backend)  # the minimum itself is accepted


def test_too_few_samples_after_omission(backend):
    with raises("TooFewSamples", "r2 needs at least 2 samples, got N=1"):
        dynval.r2([1.0, NAN, 3.0], [1.0, 2.0, INF], nan_policy="omit", backend=backend)
    with raises("TooFewSamples", "sse needs at least 1 samples, got N=0"):
        dynval.sse([NAN], [1.0], nan_policy="omit", backend=backend)


# --------------------------------------------------------------------------- NonFiniteInput


def test_nonfinite_messages(backend):
    a = np.ones((4, 2))
    a[2, 0] = NAN
    a[1, 1] = INF  # first in row-major order
    with raises("NonFiniteInput", "tau_meas has a non-finite value (inf) at row 1, column 1"):
        dynval.sse(a, np.ones((4, 2)), backend=backend)
    with raises("NonFiniteInput", "tau_pred has a non-finite value (-inf) at row 3, column 0"):
        dynval.sse(np.ones(4), [1.0, 2.0, 3.0, -INF], backend=backend)
    with raises("NonFiniteInput", "e has a non-finite value (nan) at row 2, column 0"):
        dynval.autocorrelation([1.0, 2.0, NAN, 4.0], 1, backend=backend)


def test_nonfinite_argument_order(backend):
    with raises("NonFiniteInput", "tau_meas has a non-finite value (nan) at row 3, column 0"):
        dynval.r2([1.0, 2.0, 3.0, NAN], [NAN, 2.0, 3.0, 4.0], backend=backend)


def test_nonfinite_regressor(backend):
    y = np.ones((10, 2, 3))
    y[3, 1, 2] = NAN
    e = GOOD2.copy()
    with raises("NonFiniteInput", "regressor has a non-finite value (nan) at sample 3, joint 1, column 2"):
        dynval.cross_correlation(e, y, 1, backend=backend)
    e[9, 0] = -INF
    with raises("NonFiniteInput", "e has a non-finite value (-inf) at row 9, column 0"):
        dynval.cross_correlation(e, y, 1, backend=backend)


@pytest.mark.parametrize(
    "function", ["residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "aic", "bic", "criteria"]
)
def test_nonfinite_every_pair_function(backend, function):
    kwargs = {"n_params": 1} if function in ("aic", "bic", "criteria") else {}
    with raises("NonFiniteInput", "tau_pred has a non-finite value (nan) at row 0, column 0"):
        getattr(dynval, function)(GOOD, np.r_[NAN, GOOD[1:]], backend=backend, **kwargs)


# --------------------------------------------------------------------------- InvalidParameter

BAD_PARAMETERS = [
    # (callable, message)
    (lambda b: dynval.r2(GOOD, GOOD + 1, multioutput="mean", backend=b),
     "multioutput must be one of 'pooled', 'raw_values', 'uniform_average', 'variance_weighted', got 'mean'"),
    (lambda b: dynval.sse(GOOD, GOOD + 1, multioutput="uniform_average", backend=b),
     "multioutput must be one of 'pooled', 'raw_values' for sse, got 'uniform_average'"),
    (lambda b: dynval.max_abs_error(GOOD, GOOD + 1, multioutput="variance_weighted", backend=b),
     "multioutput must be one of 'pooled', 'raw_values' for max_abs_error, got 'variance_weighted'"),
    (lambda b: dynval.rmse(GOOD, GOOD + 1, multioutput="variance_weighted", backend=b),
     "multioutput must be one of 'pooled', 'raw_values', 'uniform_average' for rmse, got 'variance_weighted'"),
    (lambda b: dynval.vaf(GOOD, GOOD + 1, multioutput=None, backend=b),
     "multioutput must be one of 'pooled', 'raw_values', 'uniform_average', 'variance_weighted', got None"),
    (lambda b: dynval.rmse(GOOD, GOOD + 1, convention="per_joint", backend=b),
     "convention must be one of 'per_element', 'per_sample', got 'per_joint'"),
    (lambda b: dynval.rmse(GOOD, GOOD + 1, multioutput="raw_values", convention="per_sample", backend=b),
     "convention must be None unless multioutput='pooled', got 'per_sample'"),
    (lambda b: dynval.residual_variance(GOOD, ddof=10, backend=b),
     "ddof must be an integer with 0 <= ddof < N=10, got 10"),
    (lambda b: dynval.residual_variance(GOOD, ddof=-1, backend=b),
     "ddof must be an integer with 0 <= ddof < N=10, got -1"),
    (lambda b: dynval.residual_variance(GOOD, ddof=True, backend=b),
     "ddof must be an integer with 0 <= ddof < N=10, got True"),
    (lambda b: dynval.residual_variance(GOOD, ddof=1.0, backend=b),
     "ddof must be an integer with 0 <= ddof < N=10, got 1.0"),
    (lambda b: dynval.autocorrelation(GOOD, 10, backend=b),
     "max_lag must be an integer with 0 <= max_lag < 10, got 10"),
    (lambda b: dynval.autocorrelation(GOOD, -1, backend=b),
     "max_lag must be an integer with 0 <= max_lag < 10, got -1"),
    (lambda b: dynval.autocorrelation(GOOD, True, backend=b),
     "max_lag must be an integer with 0 <= max_lag < 10, got True"),
    (lambda b: dynval.autocorrelation(GOOD, 2.0, backend=b),
     "max_lag must be an integer with 0 <= max_lag < 10, got 2.0"),
    (lambda b: dynval.autocorrelation(GOOD, 6, segments=[6, 4], backend=b),
     "max_lag must be an integer with 0 <= max_lag < 6, got 6"),
    (lambda b: dynval.autocorrelation(GOOD, 1, adjusted=1, backend=b),
     "adjusted must be True or False, got 1"),
    (lambda b: dynval.autocorrelation(GOOD, 1, adjusted="yes", backend=b),
     "adjusted must be True or False, got 'yes'"),
    (lambda b: dynval.ljung_box(GOOD, 0, backend=b),
     "lags must be a positive integer or a non-empty sequence of positive integers less than 10, got 0"),
    (lambda b: dynval.ljung_box(GOOD, [], backend=b),
     "lags must be a positive integer or a non-empty sequence of positive integers less than 10, got []"),
    (lambda b: dynval.box_pierce(GOOD, [1, 10], backend=b),
     "lags must be a positive integer or a non-empty sequence of positive integers less than 10, got [1, 10]"),
    (lambda b: dynval.box_pierce(GOOD, 2.5, backend=b),
     "lags must be a positive integer or a non-empty sequence of positive integers less than 10, got 2.5"),
    (lambda b: dynval.ljung_box(GOOD, [True], backend=b),
     "lags must be a positive integer or a non-empty sequence of positive integers less than 10, got [True]"),
    (lambda b: dynval.ljung_box(GOOD, [3, 5], model_df=3, backend=b),
     "model_df must be an integer with 0 <= model_df < 3, got 3"),
    (lambda b: dynval.ljung_box(GOOD, 4, model_df=-1, backend=b),
     "model_df must be an integer with 0 <= model_df < 4, got -1"),
    (lambda b: dynval.cross_correlation(GOOD, GOOD[:, None, None], 1, level=1.0, backend=b),
     "level must be a number with 0 < level < 1, got 1.0"),
    (lambda b: dynval.cross_correlation(GOOD, GOOD[:, None, None], 1, level=True, backend=b),
     "level must be a number with 0 < level < 1, got True"),
    (lambda b: dynval.confidence_band(10, level=0, backend=b),
     "level must be a number with 0 < level < 1, got 0"),
    (lambda b: dynval.confidence_band(0, backend=b),
     "n must be an integer with n >= 1, got 0"),
    (lambda b: dynval.confidence_band(10.0, backend=b),
     "n must be an integer with n >= 1, got 10.0"),
    (lambda b: dynval.criteria(GOOD, GOOD + 1, n_params=2, noise_model="diag", backend=b),
     "noise_model must be one of 'pooled', 'per_joint', 'full', got 'diag'"),
    (lambda b: dynval.aic(GOOD, GOOD + 1, n_params=-1, backend=b),
     "n_params must be an integer with n_params >= 0, got -1"),
    (lambda b: dynval.bic(GOOD, GOOD + 1, n_params=None, backend=b),
     "n_params must be an integer with n_params >= 0, got None"),
    (lambda b: dynval.information_criteria(1.0, 10, 9, backend=b),
     "n_params must be less than n_obs - 1 = 9, got 9"),
    (lambda b: dynval.information_criteria(1.0, 0, 0, backend=b),
     "n_obs must be an integer with n_obs >= 1, got 0"),
    (lambda b: dynval.information_criteria(-1.0, 10, 0, backend=b),
     "rss must be a finite number >= 0, got -1.0"),
    (lambda b: dynval.information_criteria(float("nan"), 10, 0, backend=b),
     "rss must be a finite number >= 0, got nan"),
    (lambda b: dynval.information_criteria(np.float64(np.inf), 10, 0, backend=b),
     "rss must be a finite number >= 0, got inf"),
    (lambda b: dynval.cross_correlation(GOOD2, np.ones((20, 3)), 1, n_joints=3, backend=b),
     "n_joints must be a positive integer dividing the regressor rows, got 3"),
    (lambda b: dynval.cross_correlation(GOOD2, np.ones((20, 3)), 1, n_joints=0, backend=b),
     "n_joints must be a positive integer dividing the regressor rows, got 0"),
    (lambda b: dynval.autocorrelation(GOOD, 1, segments=[5, 4], backend=b),
     "segments must be positive lengths summing to N=10, or increa"
     "sing starts beginning at 0 and below N=10, got [5, 4]"),
    (lambda b: dynval.autocorrelation(GOOD, 1, segments=[0, 10], backend=b),
     "segments must be positive lengths summing to N=10, or increa"
     "sing starts beginning at 0 and below N=10, got [0, 10]"),
    (lambda b: dynval.autocorrelation(GOOD, 1, segments=[0, 5, 3], backend=b),
     "segments must be positive lengths summing to N=10, or increa"
     "sing starts beginning at 0 and below N=10, got [0, 5, 3]"),
    (lambda b: dynval.zero_mean_test(GOOD, segments=10, backend=b),
     "segments must be positive lengths summing to N=10, or increasing starts beginning at 0 and below N=10, got 10"),
    (lambda b: dynval.zero_mean_test(GOOD, segments=[], backend=b),
     "segments must be positive lengths summing to N=10, or increasing starts beginning at 0 and below N=10, got []"),
    (lambda b: dynval.ljung_box(GOOD, 1, segments=[5.0, 5.0], backend=b),
     "segments must be positive lengths summing to N=10, or increa"
     "sing starts beginning at 0 and below N=10, got [5.0, 5.0]"),
    (lambda b: dynval.r2(GOOD, GOOD + 1, nan_policy="ignore", backend=b),
     "nan_policy must be one of 'raise', 'omit', got 'ignore'"),
]


@pytest.mark.parametrize("index", range(len(BAD_PARAMETERS)))
def test_invalid_parameter(backend, index):
    call, message = BAD_PARAMETERS[index]
    with raises("InvalidParameter", message):
        call(backend)


def test_invalid_backend():
    names = ", ".join(repr(n) for n in ("python", "cpp") if dynval.backends()[n]["available"])
    with raises("InvalidParameter", f"backend must be one of {names}, got 'fortran'"):
        dynval.r2(GOOD, GOOD + 1, backend="fortran")
    with raises("InvalidParameter", f"backend must be one of {names}, got 'fortran'"):
        dynval.set_backend("fortran")
    if not dynval.backends()["cpp"]["available"]:
        with raises("InvalidParameter", "backend must be one of 'python', got 'cpp'"):
            dynval.sse(GOOD, GOOD, backend="cpp")


def test_option_checks_used_by_reports():
    with raises("InvalidParameter", "band must be one of 'white', 'bartlett', got 'pink'"):
        _validation.check_band("pink")
    with raises("InvalidParameter", "profile must be one of 'lesson', 'matlab', 'statsmodels', 'sklearn', got 'r'"):
        _validation.check_profile("r")


def test_numpy_values_are_written_as_python_values(backend):
    with raises("InvalidParameter", "max_lag must be an integer with 0 <= max_lag < 10, got 12"):
        dynval.autocorrelation(GOOD, np.int64(12), backend=backend)
    with raises("InvalidParameter", "lags must be a positive integer or a non-empty sequence of positive integers "
                                    "less than 10, got [0, 1]"):
        dynval.ljung_box(GOOD, np.array([0, 1]), backend=backend)
    # numpy integers are integers
    assert dynval.autocorrelation(GOOD, np.int32(2), backend=backend).shape == (3,)


# --------------------------------------------------------------------------- order


def test_order_type_before_shape(backend):
    with raises("InvalidType", "tau_pred must be an array of real numbers, got complex128"):
        dynval.r2(np.ones((2, 2, 2)), np.ones(3, dtype=complex), backend=backend)


def test_order_shape_before_mismatch_and_size(backend):
    with raises("InvalidShape", "tau_pred must be 1-D (N,) or 2-D (N, m), got shape (1, 1, 1)"):
        dynval.r2(np.ones(0), np.ones((1, 1, 1)), backend=backend)
    with raises("ShapeMismatch", "tau_meas and tau_pred must have the same shape, got (0,) and (1,)"):
        dynval.r2(np.ones(0), np.ones(1), backend=backend)


def test_order_size_before_finiteness(backend):
    with raises("TooFewSamples", "r2 needs at least 2 samples, got N=1"):
        dynval.r2([NAN], [1.0], multioutput="bad", backend=backend)


def test_order_finiteness_before_parameters(backend):
    bad = np.r_[GOOD[:-1], NAN]
    msg = "tau_meas has a non-finite value (nan) at row 9, column 0"
    with raises("NonFiniteInput", msg):
        dynval.r2(bad, GOOD, multioutput="bad", backend=backend)
    with raises("NonFiniteInput", msg):
        dynval.r2(bad, GOOD, nan_policy="bad", backend=backend)
    with raises("NonFiniteInput", msg):
        dynval.r2(bad, GOOD, backend="fortran")
    with raises("NonFiniteInput", msg):
        dynval.aic(bad, GOOD, n_params=-3, backend=backend)
    emsg = "e has a non-finite value (nan) at row 9, column 0"
    with raises("NonFiniteInput", emsg):
        dynval.autocorrelation(bad, 50, segments=[1, 2], backend=backend)
    with raises("NonFiniteInput", emsg):
        dynval.ljung_box(bad, 0, model_df=-1, backend=backend)
    with raises("NonFiniteInput", emsg):
        dynval.residual_variance(bad, ddof=99, backend=backend)
    y = np.ones((10, 1, 1))
    y[4, 0, 0] = INF
    with raises("NonFiniteInput", "regressor has a non-finite value (inf) at sample 4, joint 0, column 0"):
        dynval.cross_correlation(GOOD, y, 1, level=2.0, backend=backend)


def test_omit_makes_parameter_errors_visible(backend):
    bad = np.r_[GOOD[:-1], NAN]
    # nine rows remain, so the limit is 9
    with raises("InvalidParameter", "max_lag must be an integer with 0 <= max_lag < 9, got 9"):
        dynval.autocorrelation(bad, 9, nan_policy="omit", backend=backend)


def test_order_within_parameters(backend):
    seg = ("segments must be positive lengths summing to N=10, or increa"
           "sing starts beginning at 0 and below N=10, got [3]")
    with raises("InvalidParameter", "nan_policy must be one of 'raise', 'omit', got 'x'"):
        dynval.autocorrelation(GOOD, 99, segments=[3], nan_policy="x", backend="fortran")
    with raises("InvalidParameter", seg):
        dynval.autocorrelation(GOOD, 99, adjusted=None, segments=[3], backend=backend)
    with raises("InvalidParameter", "max_lag must be an integer with 0 <= max_lag < 10, got 99"):
        dynval.autocorrelation(GOOD, 99, adjusted=None, backend=backend)
    mo = "multioutput must be one of 'pooled', 'raw_values', 'uniform_average', 'variance_weighted', got 'x'"
    with raises("InvalidParameter", mo):
        dynval.rmse(GOOD, GOOD, multioutput="x", convention="y", backend=backend)


# --------------------------------------------------------------------------- kernels


def test_kernels_check_finiteness_then_parameters(backend):
    kernel = _backend.get_backend(backend)
    meas = np.r_[GOOD[:-1], NAN].reshape(-1, 1)
    pred = GOOD.reshape(-1, 1)
    with raises("NonFiniteInput", "tau_meas has a non-finite value (nan) at row 9, column 0"):
        kernel.r2(meas, pred, "bad")
    with raises("InvalidParameter", "multioutput must be one of 'pooled', 'raw_values' for sse, got 'uniform_average'"):
        kernel.sse(pred, pred, "uniform_average")
    with raises("InvalidParameter", "max_lag must be an integer with 0 <= max_lag < 10, got 10"):
        kernel.autocorrelation(pred, 10, True, np.zeros(1, dtype=np.int64))
    with raises("InvalidParameter", "n_params must be less than n_obs - 1 = 9, got 9"):
        kernel.information_criteria(1.0, 10, 9)
    assert kernel.first_nonfinite(pred) is None
    row, col, value = kernel.first_nonfinite(meas)
    assert (row, col) == (9, 0) and np.isnan(value)


# --------------------------------------------------------------------------- out-of-range values (contract §1.2)

OUT_OF_RANGE_CALLS = {
    "r2": lambda a, b, be: dynval.r2(a, b, backend=be),
    "sse": lambda a, b, be: dynval.sse(a, b, backend=be),
    "residuals": lambda a, b, be: dynval.residuals(a, b, backend=be),
    "criteria": lambda a, b, be: dynval.criteria(a, b, n_params=1, backend=be),
    "validate": lambda a, b, be: dynval.validate(a, b, n_params=1, max_lag=2, backend=be),
}


@pytest.mark.parametrize("function", sorted(OUT_OF_RANGE_CALLS))
@pytest.mark.parametrize("where", ["tau_meas", "tau_pred"])
def test_values_beyond_the_magnitude_bound_are_rejected_like_non_finite_ones(backend, function, where):
    # Squares of such values overflow: one implementation would give inf, another nan. Both
    # backends reject them with the same message, at the first bad index; a NaN later in the
    # array does not take precedence.
    meas = np.linspace(1.0, 2.0, 40).reshape(20, 2)
    pred = meas + 0.25
    target = meas if where == "tau_meas" else pred
    target[5, 1] = -3e200
    target[9, 0] = np.nan
    message = rf"^{where} has a value out of range \(-3e\+200\) at row 5, column 1: \|x\| must be at most 1e\+144$"
    with pytest.raises(dynval.NonFiniteInput, match=message):
        OUT_OF_RANGE_CALLS[function](meas, pred, backend)


def test_the_magnitude_bound_itself_is_accepted_and_just_above_it_is_not(backend):
    meas = np.array([[1e144], [-1e144], [0.0]])
    assert dynval.sse(meas, np.zeros_like(meas), backend=backend) == 2e288
    meas[2, 0] = np.nextafter(1e144, np.inf)
    with pytest.raises(dynval.NonFiniteInput, match="out of range"):
        dynval.sse(meas, np.zeros_like(meas), backend=backend)


def test_residual_functions_and_the_regressor_apply_the_bound(backend):
    e = np.sin(np.arange(30.0)).reshape(15, 2)
    e[3, 0] = 1e150
    with pytest.raises(dynval.NonFiniteInput, match=r"^e has a value out of range \(1e\+150\) at row 3, column 0"):
        dynval.autocorrelation(e, 2, backend=backend)
    with pytest.raises(dynval.NonFiniteInput, match=r"^e has a value out of range"):
        dynval.ljung_box(e, 2, backend=backend)
    e[3, 0] = 0.5
    y = np.cos(np.arange(90.0)).reshape(15, 2, 3)
    y[4, 1, 2] = -1e300
    with pytest.raises(dynval.NonFiniteInput,
                       match=r"^regressor has a value out of range \(-1e\+300\) at sample 4, joint 1, column 2: "):
        dynval.cross_correlation(e, y, 2, backend=backend)


def test_omit_deletes_rows_with_out_of_range_values(backend):
    meas = np.linspace(1.0, 3.0, 40).reshape(20, 2)
    pred = meas + np.sin(np.arange(40.0)).reshape(20, 2) * 0.1
    huge = pred.copy()
    huge[7, 0] = 1e200
    kept = np.delete(np.arange(20), 7)
    assert dynval.r2(meas, huge, nan_policy="omit", backend=backend) == pytest.approx(
        dynval.r2(meas[kept], pred[kept], backend=backend), rel=1e-15)


@pytest.mark.parametrize("value", [2**63, -(2**63) - 1, 10**20])
def test_integer_parameters_must_fit_in_int64_in_every_backend(backend, value):
    meas = np.linspace(1.0, 2.0, 20)
    with pytest.raises(dynval.InvalidParameter,
                       match=rf"^n_params must be an integer with n_params >= 0, got {value}$"):
        dynval.criteria(meas, meas + 0.1, n_params=value, backend=backend)


# --------------------------------------------------------------------------- N < m (contract §2.2)


def test_validate_refuses_fewer_samples_than_joints_unless_allowed(backend):
    rng = np.random.default_rng(3)
    wide = rng.normal(size=(6, 40))
    pred = wide + 0.1
    message = ("validate needs at least as many samples as joints (N >= m), got tau_meas of shape (6, 40): "
               "samples are rows and joints columns, so the data look transposed; transpose them, or pass "
               "allow_wide=True if N < m is intended")
    with pytest.raises(dynval.TooFewSamples) as info:
        dynval.validate(wide, pred, n_params=1, backend=backend)
    assert str(info.value) == message
    report = dynval.validate(wide, pred, n_params=1, allow_wide=True, backend=backend)
    assert report.provenance["n_joints"] == 40
    square = rng.normal(size=(5, 5))
    assert dynval.validate(square, square + 0.1, n_params=1, backend=backend).provenance["n_samples"] == 5


def test_the_wide_check_follows_the_contract_order():
    wide = np.ones((3, 4))
    # The N >= 2 minimum comes first; a shape mismatch before both.
    with pytest.raises(dynval.TooFewSamples, match="at least 2 samples"):
        dynval.validate(wide[:1], wide[:1], n_params=1)
    with pytest.raises(dynval.ShapeMismatch):
        dynval.validate(wide, wide[:, :3], n_params=1)
    # A bad allow_wide is a parameter error, reported in the parameter step.
    with pytest.raises(dynval.InvalidParameter, match=r"^allow_wide must be True or False, got 'yes'$"):
        dynval.validate(np.arange(8.0).reshape(4, 2), np.arange(8.0).reshape(4, 2) + 1, n_params=1,
                        allow_wide="yes")
    with pytest.raises(dynval.InvalidParameter, match=r"^allow_wide must be True or False, got 1$"):
        dynval.validate(wide, wide + 1, n_params=1, allow_wide=1)


def test_compare_passes_allow_wide_on():
    rng = np.random.default_rng(4)
    wide = rng.normal(size=(8, 12))
    candidates = {"a": (wide + 0.1, 1), "b": (wide + rng.normal(scale=0.1, size=wide.shape), 2)}
    with pytest.raises(dynval.TooFewSamples, match="allow_wide=True"):
        dynval.compare(wide, candidates)
    assert sorted(dynval.compare(wide, candidates, allow_wide=True, max_lag=2).ranking) == ["a", "b"]


# --------------------------------------------------------------------------- values in messages


class _Framed:
    """A table-like object whose repr is long (as a DataFrame's is)."""

    shape = (100_000, 3)

    def __repr__(self):
        return "x" * 10_000


@pytest.mark.parametrize("value, shown", [
    (np.zeros(10**6), "<float64 array of shape (1000000,)>"),
    (np.zeros((3, 2)), "<float64 array of shape (3, 2)>"),
    (np.arange(9), "<int64 array of shape (9,)>"),
    (np.arange(3), "[0, 1, 2]"),
    (list(range(10**5)), "<list of length 100000>"),
    ((np.ones(10**5), 3), "(<float64 array of shape (100000,)>, 3)"),
    ({"prediction": np.ones((5, 2)), "n_params": 1}, "{'prediction': <float64 array of shape (5, 2)>, 'n_params': 1}"),
    ([[[[1]]]], "[[[<list of length 1>]]]"),
    ("a" * 10**6, repr("a" * 80) + "... (a str of 1000000 characters)"),
    (_Framed(), "<_Framed of shape (100000, 3)>"),
    (10**400, "1" + "0" * 79 + "... (401 characters)"),
    ([2, 6], "[2, 6]"),
    ((5,), "(5,)"),
    (np.int64(12), "12"),
])
def test_a_value_is_shown_by_type_and_size_never_by_its_data(value, shown):
    """Contract §2.1: arrays and long arguments appear by type and shape or length; short ones as typed."""
    assert _validation.format_value(value) == shown


@pytest.mark.parametrize("call", [
    # a 10^6-row dq without q (the message was 5 MB)
    lambda: dynval.validate(np.arange(10.0**6), np.zeros(10**6), n_params=1, dq=np.ones(10**6)),
    # an array where a (prediction, n_params) pair belongs (732,092 characters)
    lambda: dynval.compare(np.ones((20_000, 2)), {"a": np.ones((20_000, 2)), "b": np.ones((20_000, 2)) * 1.01}),
    lambda: dynval.validate(np.ones(100), np.ones(100), n_params=1, thresholds={"b" * 10**6: 1.0}),
    lambda: detect_period(np.sin(np.arange(100.0)), sample_rate=np.ones(10**5)),
])
def test_messages_stay_short_whatever_the_argument(call):
    with pytest.raises(dynval.InputError) as info:
        call()
    assert len(str(info.value)) < 600, len(str(info.value))


def test_the_cpp_bindings_write_values_as_the_facade_does(backend):
    """The bindings call the facade's formatter: the same text in both backends, and no data."""
    message = ("lags must be a positive integer or a non-empty sequence of positive integers less than 10, "
               "got <int64 array of shape (2, 1)>")
    with raises("InvalidParameter", message):
        dynval.ljung_box(GOOD, np.array([[1], [2]]), backend=backend)
    with raises("InvalidParameter",
                "max_lag must be an integer with 0 <= max_lag < 10, got <float64 array of shape (9,)>"):
        dynval.autocorrelation(GOOD, np.ones(9), backend=backend)
