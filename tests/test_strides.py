"""Arrays with a negative stride on a length-1 axis (``tau[:, ::-1]`` for one joint).

numpy calls such a view C-contiguous, so a conversion that trusts the flag keeps the negative
stride, and pybind11 then refused the array with a raw TypeError. Every public array function and
every ``_core`` kernel must give the same result as for a plain copy, on both backends.
"""

from __future__ import annotations

import numpy as np
import pytest

import dynval

N = 60


def _one_joint(seed=0):
    rng = np.random.default_rng(seed)
    tau = np.cumsum(rng.normal(size=(N, 1)), axis=0)
    pred = tau + 0.2 * rng.normal(size=(N, 1))
    y = np.cumsum(rng.normal(size=(N, 1, 1)), axis=0)
    return tau, pred, y


def _flipped(a):
    """The same values viewed with a negative stride on every length-1 axis."""
    index = tuple(slice(None, None, -1) if size == 1 else slice(None) for size in a.shape)
    view = a[index]
    assert np.array_equal(view, a) and min(view.strides) < 0
    return view


# Every public function that takes arrays, called with (tau, pred, y) or (e, y).
CALLS = {
    "residuals": lambda t, p, y, b: dynval.residuals(t, p, backend=b),
    "sse": lambda t, p, y, b: dynval.sse(t, p, backend=b),
    "rmse": lambda t, p, y, b: dynval.rmse(t, p, backend=b),
    "max_abs_error": lambda t, p, y, b: dynval.max_abs_error(t, p, backend=b),
    "vaf": lambda t, p, y, b: dynval.vaf(t, p, backend=b),
    "fit_percent": lambda t, p, y, b: dynval.fit_percent(t, p, backend=b),
    "r2": lambda t, p, y, b: dynval.r2(t, p, backend=b),
    "residual_mean": lambda t, p, y, b: dynval.residual_mean(t, backend=b),
    "residual_variance": lambda t, p, y, b: dynval.residual_variance(t, backend=b),
    "zero_mean_test": lambda t, p, y, b: dynval.zero_mean_test(t, backend=b).to_dict(),
    "autocorrelation": lambda t, p, y, b: dynval.autocorrelation(t, 5, backend=b),
    "ljung_box": lambda t, p, y, b: dynval.ljung_box(t, [3, 5], backend=b).to_dict(),
    "box_pierce": lambda t, p, y, b: dynval.box_pierce(t, 4, backend=b).to_dict(),
    "cross_correlation": lambda t, p, y, b: dynval.cross_correlation(t, y, 3, backend=b).to_dict(),
    "criteria": lambda t, p, y, b: dynval.criteria(t, p, n_params=2, backend=b).to_dict(),
    "aic": lambda t, p, y, b: dynval.aic(t, p, n_params=2, backend=b),
    "bic": lambda t, p, y, b: dynval.bic(t, p, n_params=2, backend=b),
    "validate": lambda t, p, y, b: dynval.validate(t, p, n_params=2, regressor=y, backend=b).to_dict()["pooled"],
}


def _same(a, b):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    else:
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("function", sorted(CALLS))
@pytest.mark.parametrize("which", ["tau", "pred", "regressor", "all"])
def test_negative_stride_on_a_length_one_axis(function, which, backend):
    tau, pred, y = _one_joint()
    expected = CALLS[function](tau, pred, y, backend)
    args = [tau, pred, y]
    for i, name in enumerate(("tau", "pred", "regressor")):
        if which in (name, "all"):
            args[i] = _flipped(args[i])
    _same(CALLS[function](*args, backend), expected)


def test_one_sample_row_with_negative_stride(backend):
    # A (1, m) array reversed along rows: the other length-1 axis.
    tau = np.arange(4.0).reshape(1, 4)
    flipped = tau[::-1]
    assert flipped.strides[0] < 0
    np.testing.assert_array_equal(dynval.sse(flipped, tau * 0.5, multioutput="raw_values", backend=backend),
                                  (tau[0] * 0.5) ** 2)


@pytest.mark.skipif(not dynval.backends()["cpp"]["available"], reason="needs the compiled backend")
def test_core_kernels_accept_negative_strides():
    from dynval import _core

    tau, pred, y = _one_joint()
    starts = np.array([0])
    t, p, yy = _flipped(tau), _flipped(pred), _flipped(y.reshape(N, 1))
    calls = [
        lambda a, b, c: _core.residuals(a, b),
        lambda a, b, c: _core.sse(a, b, "raw_values"),
        lambda a, b, c: _core.rmse(a, b, "pooled", ""),
        lambda a, b, c: _core.max_abs_error(a, b, "pooled"),
        lambda a, b, c: _core.vaf(a, b, "pooled"),
        lambda a, b, c: _core.fit_percent(a, b, "pooled"),
        lambda a, b, c: _core.r2(a, b, "pooled"),
        lambda a, b, c: _core.residual_mean(a),
        lambda a, b, c: _core.residual_variance(a, 1),
        lambda a, b, c: _core.autocorrelation(a, 4, True, starts),
        lambda a, b, c: _core.portmanteau(a, np.array([2, 4]), 0, starts, "ljung_box"),
        lambda a, b, c: _core.cross_correlation(a, c, 1, 3, True, starts),
        lambda a, b, c: _core.criteria(a, b, 2, "pooled"),
        lambda a, b, c: _core.compute_metrics(a, b, 2, 1, "pooled"),
        lambda a, b, c: _core.first_nonfinite(a),
    ]
    for call in calls:
        _same(call(t, p, yy), call(tau, pred, y.reshape(N, 1)))
