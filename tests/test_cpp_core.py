"""Tests specific to the compiled backend ``dynval._core``.

* memory layouts (Fortran order, strided and reversed views, float32, int) reach the kernels
  correctly and give the python backend's numbers;
* C-contiguous float64 arrays are used without a copy;
* errors raised in C++ are the facade's own ``dynval.InputError`` subclasses, with the python
  backend's messages byte for byte;
* the χ² survival function and its logarithm against scipy (and mpmath where p underflows).

The whole module is skipped when the compiled backend is not available.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats

import dynval

if not dynval.backends()["cpp"]["available"]:
    pytest.skip("the compiled backend dynval._core is not available", allow_module_level=True)

from dynval import _core
from dynval.kernels import _reference as ref


def _signals(n=240, m=3, seed=0, offset=0.0):
    rng = np.random.default_rng(seed)
    tau = offset + np.cumsum(rng.normal(size=(n, m)), axis=0)
    pred = tau + 0.3 * rng.normal(size=(n, m)) + 0.05
    return tau, pred


def _layouts(a):
    """The same values in several memory layouts and dtypes (name, array, exact values)."""
    wide = np.zeros((a.shape[0] * 2, a.shape[1] * 2))
    wide[::2, ::2] = a
    return [
        ("C", np.ascontiguousarray(a), a),
        ("F", np.asfortranarray(a), a),
        ("row-strided", wide[::2, ::2], a),
        ("col-strided", np.repeat(a, 2, axis=1)[:, ::2], a),
        ("reversed", np.ascontiguousarray(a[::-1])[::-1], a),
        ("reversed-both", np.ascontiguousarray(a[::-1, ::-1])[::-1, ::-1], a),
        ("float32", a.astype(np.float32), a.astype(np.float32).astype(np.float64)),
        ("int64", np.round(a * 100).astype(np.int64), np.round(a * 100)),
    ]


LAYOUT_IDS = [name for name, _, _ in _layouts(np.zeros((4, 2)))]


# --------------------------------------------------------------------------- layouts


@pytest.mark.parametrize("layout", LAYOUT_IDS)
def test_point_kernels_read_every_layout(layout):
    tau, pred = _signals()
    views_t = {name: (arr, exact) for name, arr, exact in _layouts(tau)}
    views_p = {name: (arr, exact) for name, arr, exact in _layouts(pred)}
    t_view, t_exact = views_t[layout]
    p_view, p_exact = views_p[layout]
    for name in ("vaf", "fit_percent", "r2"):
        for how in ("pooled", "raw_values", "uniform_average", "variance_weighted"):
            got = getattr(_core, name)(t_view, p_view, how)
            want = getattr(ref, name)(t_exact, p_exact, how)
            np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(_core.sse(t_view, p_view, "raw_values"), ref.sse(t_exact, p_exact, "raw_values"),
                               rtol=1e-14)
    np.testing.assert_array_equal(_core.residuals(t_view, p_view), t_exact - p_exact)
    np.testing.assert_array_equal(_core.max_abs_error(t_view, p_view, "raw_values"),
                                  np.abs(t_exact - p_exact).max(axis=0))
    got = _core.compute_metrics(t_view, p_view, 4, 1, "full")
    want = ref.compute_metrics(t_exact, p_exact, 4, 1, "full")
    for key, value in want.items():
        np.testing.assert_allclose(got[key], value, rtol=1e-12, atol=1e-12, err_msg=key)


@pytest.mark.parametrize("layout", LAYOUT_IDS)
def test_lag_kernels_read_every_layout(layout):
    tau, pred = _signals(seed=1)
    e = tau - pred
    view, exact = {name: (arr, ex) for name, arr, ex in _layouts(e)}[layout]
    starts = np.array([0, 100], dtype=np.int64)
    np.testing.assert_allclose(_core.autocorrelation(view, 12, True, starts),
                               ref.autocorrelation(exact, 12, True, starts), atol=1e-14)
    got = _core.portmanteau(view, np.array([3, 12]), 1, starts, "ljung_box")
    want = ref.portmanteau(exact, np.array([3, 12]), 1, starts, "ljung_box")
    np.testing.assert_allclose(got["statistic"], want["statistic"], rtol=1e-12)
    np.testing.assert_array_equal(got["df"], want["df"])
    y = np.repeat(exact, 2, axis=1) + np.arange(exact.shape[1] * 2)  # (N, m·p), p = 2
    y_view = {name: arr for name, arr, _ in _layouts(y)}[layout]
    if layout in ("float32", "int64"):
        y = {name: ex for name, _, ex in _layouts(y)}[layout]
    got = _core.cross_correlation(view, y_view, 2, 5, False, starts)
    want = ref.cross_correlation(exact, y, 2, 5, False, starts)
    np.testing.assert_allclose(got["rho"], want["rho"], atol=1e-14)
    np.testing.assert_array_equal(got["constant_mask"], want["constant_mask"])


def test_facade_accepts_every_layout_on_cpp():
    tau, pred = _signals(seed=2)
    want = dynval.r2(tau, pred, multioutput="raw_values", backend="python")
    for _, t_view, _ in _layouts(tau)[:6]:
        for _, p_view, _ in _layouts(pred)[:6]:
            got = dynval.r2(t_view, p_view, multioutput="raw_values", backend="cpp")
            np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-15)


def test_one_d_input_is_one_joint():
    tau, pred = _signals(m=1)
    assert _core.r2(tau[:, 0], pred[:, 0], "pooled") == pytest.approx(ref.r2(tau, pred, "pooled"), rel=1e-14)
    assert _core.autocorrelation(tau[:, 0], 3, True, None).shape == (4, 1)


# --------------------------------------------------------------------------- zero copy


def test_c_contiguous_float64_is_not_copied():
    a = np.ascontiguousarray(np.random.default_rng(3).normal(size=(50, 4)))
    assert _core._testing.data_address(a) == a.ctypes.data
    assert _core._testing.data_address(a[10:20]) == a[10:20].ctypes.data  # a row block stays contiguous
    v = np.ascontiguousarray(a[:, 0])
    assert _core._testing.data_address(v) == v.ctypes.data


@pytest.mark.parametrize("make", [np.asfortranarray, lambda a: a[::2], lambda a: a[::-1],
                                  lambda a: a.astype(np.float32)], ids=["F", "strided", "reversed", "float32"])
def test_other_layouts_are_converted_once(make):
    a = np.random.default_rng(4).normal(size=(50, 4))
    view = make(a)
    # A copy is made (the address differs) and the values the kernel reads are the right ones.
    assert _core._testing.data_address(view) != view.ctypes.data
    np.testing.assert_array_equal(_core.residuals(view, np.zeros(view.shape)), view.astype(np.float64))


def test_read_sum_reads_every_element_once():
    a = np.random.default_rng(5).normal(size=(1001, 7))
    assert _core._testing.read_sum(a) == pytest.approx(float(np.sum(a)), rel=1e-12, abs=1e-12)
    assert _core._testing.read_sum(a[::3]) == pytest.approx(float(np.sum(a[::3])), rel=1e-12, abs=1e-12)
    assert _core._testing.read_sum(np.zeros((0, 3))) == 0.0


def test_stream_state_binding_checks_and_copies():
    with pytest.raises(dynval.InvalidParameter, match=r"^n_joints must be a positive integer, got 0$"):
        _core.StreamState(0, 0, 0, 0, False)
    with pytest.raises(dynval.InvalidParameter, match=r"xcorr_lags <= acf_lags"):
        _core.StreamState(2, 1, 3, 5, False)
    st = _core.StreamState(2, 0, 3, 0, True)
    e = np.random.default_rng(6).normal(size=(40, 2))
    st.append(e, e + 1.0, None)
    with pytest.raises(dynval.InvalidShape):
        st.append(np.zeros((3, 3)), np.zeros((3, 3)), None)
    twin = st.copy()
    twin.append(e, e, None)
    assert (st.n, twin.n, st.lengths) == (40, 80, [40])
    sums = st.sums()
    # centres and sums in the units 2^exp_e of each joint (contract §4.1)
    mean = np.ldexp(sums["k_e"] + sums["cur_e"][0] / 40, sums["exp_e"])
    np.testing.assert_allclose(mean, e.mean(axis=0), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- errors


def _raises_same(call_core, call_ref):
    with pytest.raises(dynval.InputError) as want:
        call_ref()
    with pytest.raises(dynval.InputError) as got:
        call_core()
    assert type(got.value) is type(want.value)
    assert str(got.value) == str(want.value)
    assert got.value.kind == want.value.kind
    return got.value


def _error_cases():
    t, p = _signals(n=20, m=2, seed=5)
    e = t - p
    t_nan = t.copy()
    t_nan[7, 1] = np.nan
    p_inf = p.copy()
    p_inf[3, 0] = -np.inf
    y = np.repeat(e, 2, axis=1)
    y_bad = y.copy()
    y_bad[4, 3] = np.inf
    s0 = np.array([0], dtype=np.int64)
    return {
        "nonfinite-meas-first": lambda k: k.r2(t_nan, p_inf, "pooled"),
        "nonfinite-pred": lambda k: k.sse(t, p_inf, "raw_values"),
        "nonfinite-before-parameter": lambda k: k.rmse(t_nan, p, "bogus", ""),
        "nonfinite-e": lambda k: k.autocorrelation(np.where(np.isnan(t_nan), np.inf, e), 2, True, s0),
        "nonfinite-regressor": lambda k: k.cross_correlation(e, y_bad, 2, 2, True, s0),
        "nonfinite-regressor-bad-p": lambda k: k.cross_correlation(e, y_bad, 3, 2, True, s0),
        "nonfinite-first-nonfinite-kernel-ok": lambda k: k.residuals(t, p_inf),
        "multioutput": lambda k: k.vaf(t, p, "mean"),
        "multioutput-type": lambda k: k.vaf(t, p, 3),
        "multioutput-for-sse": lambda k: k.sse(t, p, "uniform_average"),
        "multioutput-for-rmse": lambda k: k.rmse(t, p, "variance_weighted", ""),
        "convention": lambda k: k.rmse(t, p, "pooled", "per_joint"),
        "convention-not-pooled": lambda k: k.rmse(t, p, "raw_values", "per_sample"),
        "ddof": lambda k: k.residual_variance(e, 20),
        "ddof-bool": lambda k: k.residual_variance(e, True),
        "ddof-float": lambda k: k.residual_variance(e, 1.0),
        "max_lag": lambda k: k.autocorrelation(e, 20, True, s0),
        "max_lag-segments": lambda k: k.autocorrelation(e, 10, True, np.array([0, 10])),
        "adjusted": lambda k: k.autocorrelation(e, 2, 1, s0),
        "segments": lambda k: k.autocorrelation(e, 2, True, np.array([0, 25])),
        "segments-not-starts": lambda k: k.autocorrelation(e, 2, True, np.array([10, 10])),
        "lags": lambda k: k.portmanteau(e, np.array([2, 20]), 0, s0, "ljung_box"),
        "lags-empty": lambda k: k.portmanteau(e, np.array([], dtype=np.int64), 0, s0, "ljung_box"),
        "model_df": lambda k: k.portmanteau(e, np.array([2, 5]), 2, s0, "box_pierce"),
        "test": lambda k: k.portmanteau(e, np.array([2]), 0, s0, "q_test"),
        "n_columns": lambda k: k.cross_correlation(e, y, 3, 2, True, s0),
        "noise_model": lambda k: k.criteria(t, p, 2, "diagonal"),
        "n_params": lambda k: k.criteria(t, p, -2, "pooled"),
        "n_params-metrics": lambda k: k.compute_metrics(t, p, 2.5, 1, "pooled"),
        "ddof-metrics": lambda k: k.compute_metrics(t, p, 2, -1, "pooled"),
        "rss": lambda k: k.information_criteria(-1.0, 10, 2),
        "rss-nan": lambda k: k.information_criteria(float("nan"), 10, 2),
        "n_obs": lambda k: k.information_criteria(1.0, 0, 2),
        # The core takes plain C++ values; the binding turns a wrong-typed argument into one the
        # core refuses at its place in the order, and writes the caller's argument back.
        "max_lag-float": lambda k: k.autocorrelation(e, 2.0, True, s0),
        "max_lag-str-after-segments": lambda k: k.autocorrelation(e, "2", True, np.array([0, 25])),
        "adjusted-after-max_lag": lambda k: k.autocorrelation(e, 20, "yes", s0),
        "adjusted-after-nonfinite": lambda k: k.cross_correlation(e, y_bad, 2, 2, None, s0),
        "adjusted-last": lambda k: k.cross_correlation(e, y, 2, 2, np.float64(1.0), s0),
        "n_columns-float": lambda k: k.cross_correlation(e, y, 2.0, 2, True, s0),
        "lags-float-list": lambda k: k.portmanteau(e, [1, 2.0], 0, s0, "ljung_box"),
        "model_df-before-test": lambda k: k.portmanteau(e, np.array([2]), 5, s0, 3),
        "rss-int-beyond-float": lambda k: k.information_criteria(10**400, 10, 2),
        "n_params-numpy": lambda k: k.information_criteria(1.0, 10, np.int64(-3)),
        "noise_model-none": lambda k: k.compute_metrics(t, p, 2, 1, None),
        "n_params-aicc": lambda k: k.information_criteria(1.0, 10, 9),
    }


@pytest.mark.parametrize("case", sorted(_error_cases()))
def test_errors_match_the_reference(case):
    call = _error_cases()[case]
    if case == "nonfinite-first-nonfinite-kernel-ok":
        err = _raises_same(lambda: call(_core), lambda: call(ref))
        assert isinstance(err, dynval.NonFiniteInput)
        return
    err = _raises_same(lambda: call(_core), lambda: call(ref))
    assert isinstance(err, ValueError)


def test_errors_are_facade_classes_not_new_types():
    t, p = _signals(n=10, m=1)
    with pytest.raises(dynval.InvalidParameter) as info:
        _core.r2(t, p, "nope")
    assert type(info.value).__module__ == "dynval.checks._errors"
    assert not any(name.endswith("Error") for name in dir(_core) if not name.startswith("_"))
    # Through the facade as well, for every kind the kernels raise.
    with pytest.raises(dynval.NonFiniteInput, match=r"tau_pred has a non-finite value \(nan\) at row 2, column 0"):
        bad = p.copy()
        bad[2, 0] = np.nan
        dynval.sse(t, bad, backend="cpp")


def test_first_nonfinite_matches_reference():
    a = np.random.default_rng(6).normal(size=(700, 3))
    assert _core.first_nonfinite(a) is None
    for row, col, value in [(0, 0, np.nan), (299, 2, np.inf), (699, 1, -np.inf)]:
        b = a.copy()
        b[row, col] = value
        b[row + 1 :, :] = np.nan if row + 1 < 700 else b[row + 1 :, :]
        got = _core.first_nonfinite(b)
        assert got[:2] == ref.first_nonfinite(b)[:2] == (row, col)
        assert str(got[2]) == str(value)
        assert _core.first_nonfinite(np.asfortranarray(b))[:2] == (row, col)


# --------------------------------------------------------------------------- distributions


def test_chi2_sf_against_scipy_on_a_grid():
    df = np.arange(1, 201)[:, None].astype(float)
    q = np.concatenate([[1e-3, 0.1, 0.5], np.geomspace(1.0, 1e5, 60)])[None, :]
    q, df = np.broadcast_arrays(q, df)
    want = scipy.stats.chi2.sf(q, df)
    got = _core._testing.chi2_sf(q, df)
    normal = want > 1e-300
    np.testing.assert_allclose(got[normal], want[normal], rtol=1e-12, atol=0)
    assert np.all(got[want == 0] == 0)
    # log p-values: scipy's logsf is exact where sf does not underflow.
    want_log = scipy.stats.chi2.logsf(q, df)
    finite = np.isfinite(want_log) & (want > 1e-300)
    np.testing.assert_allclose(_core._testing.chi2_logsf(q, df)[finite], want_log[finite], rtol=1e-12, atol=0)


def test_chi2_logsf_where_the_pvalue_underflows():
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    cases = [(1e5, 1), (1e5, 200), (5e4, 37), (2000.0, 3), (1900.0, 150), (3e3, 200)]
    for q, df in cases:
        assert scipy.stats.chi2.sf(q, df) < 1e-280
        want = float(mpmath.log(mpmath.gammainc(df / 2, q / 2, mpmath.inf, regularized=True)))
        assert _core._testing.chi2_logsf(q, df) == pytest.approx(want, rel=1e-12)


def test_normal_quantile_and_band_against_scipy():
    p = np.array([0.5, 0.8, 0.975, 0.995, 0.9995, 1 - 1e-10])
    np.testing.assert_allclose(_core._testing.normal_quantile(p), scipy.stats.norm.ppf(p), rtol=1e-14, atol=1e-15)
    assert _core._testing.confidence_band(400, 0.99) == pytest.approx(
        scipy.stats.norm.ppf(0.995) / 20.0, rel=1e-14)


@pytest.mark.parametrize(("n", "level", "message"), [
    (10, 1.0, "level must be a number with 0 < level < 1, got 1.0"),      # the core writes 1
    (10, "0.9", "level must be a number with 0 < level < 1, got '0.9'"),  # the core gets NaN
    (True, 0.9, "n must be an integer with n >= 1, got True"),            # the core gets -1
    (2**64, 0.9, "n must be an integer with n >= 1, got 18446744073709551616"),
])
def test_binding_writes_the_callers_argument_in_parameter_errors(n, level, message):
    # The core takes plain values and writes them the C++ way; the binding shows the argument as
    # Python writes it, as the facade's own message does.
    with pytest.raises(dynval.InvalidParameter) as info:
        _core._testing.confidence_band(n, level)
    assert str(info.value) == message
    if isinstance(n, int) and not isinstance(n, bool) and n < 2**63:
        with pytest.raises(dynval.InvalidParameter) as facade:
            dynval.confidence_band(n, level=level)
        assert str(facade.value) == message


# --------------------------------------------------------------------------- accuracy


def test_large_offset_keeps_digits():
    # NIST StRD NumAcc4 style: a 1e7 offset on values spaced 0.1 apart; the centred sums are
    # exact in both backends only if neither loses the offset's digits.
    base = np.array([0.2, 0.1, 0.3, 0.1, 0.3, 0.1, 0.3, 0.1, 0.3, 0.2] * 100)
    tau = np.column_stack([1e7 + base, -1e7 + 2 * base])
    pred = tau + 0.01 * np.cos(np.arange(1000))[:, None]
    for key in ("vaf", "r2", "residual_variance", "residual_mean"):
        got = _core.compute_metrics(tau, pred, 2, 1, "pooled")[key]
        want = ref.compute_metrics(tau, pred, 2, 1, "pooled")[key]
        np.testing.assert_allclose(got, want, rtol=1e-13, err_msg=key)
    rho_c = _core.autocorrelation(tau, 20, True, None)
    rho_r = ref.autocorrelation(tau, 20, True, np.array([0]))
    np.testing.assert_allclose(rho_c, rho_r, atol=1e-13)


def test_compute_metrics_fields_and_types():
    tau, pred = _signals()
    out = _core.compute_metrics(tau, pred, 6, 1, "pooled")
    want = ref.compute_metrics(tau, pred, 6, 1, "pooled")
    assert set(out) == set(want)
    for key, value in want.items():
        if isinstance(value, np.ndarray):
            assert isinstance(out[key], np.ndarray) and out[key].dtype == value.dtype, key
            assert out[key].shape == value.shape, key
        else:
            assert type(out[key]) is type(value), key
    assert math.isfinite(out["aic"])


# --------------------------------------------------------------------------- size overflow


def test_cross_correlation_column_count_that_wraps_is_refused():
    # (2^62 + 1)·4 wraps to 4, the regressor's column count: the product must be checked.
    e = np.sin(np.arange(48.0)).reshape(12, 4)
    y = np.cos(np.arange(48.0)).reshape(12, 4)
    message = r"^n_columns must be a positive integer with m\*n_columns = 4, got 4611686018427387905$"
    with pytest.raises(dynval.InvalidParameter, match=message):
        _core.cross_correlation(e, y, 2**62 + 1, 0, True, np.array([0]))


@pytest.mark.parametrize("n_columns", [2**63 - 1, -(2**62) - 1, 2**62, 2**63 // 4 + 1])
def test_cross_correlation_huge_column_counts_are_parameter_errors(n_columns):
    e = np.sin(np.arange(48.0)).reshape(12, 4)
    with pytest.raises(dynval.InvalidParameter, match=r"^n_columns must be"):
        _core.cross_correlation(e, e, n_columns, 0, True, np.array([0]))


@pytest.mark.parametrize("lags", [2**63, np.array([2**63], dtype=np.uint64), [3, 2**64], np.uint64(2**63)],
                         ids=["int", "uint64-array", "list", "uint64"])
def test_lags_beyond_64_bits_are_parameter_errors(lags):
    # Found by tests/test_fuzz.py: the binding cast each lag straight to long long, and a value
    # beyond it escaped as pybind11's RuntimeError.
    e = np.sin(np.arange(40.0)).reshape(20, 2)
    for kernel in (_core, ref):
        with pytest.raises(dynval.InvalidParameter, match=r"^lags must be"):
            kernel.portmanteau(e, lags, 0, np.array([0]), "ljung_box")


def test_kept_regressor_moments_give_the_same_cross_correlation():
    # regressor_moments(Y) given back (a prepared regressor keeps them): the call's result bit for
    # bit; moments of another regressor shape are refused with ShapeMismatch, not used.
    rng = np.random.default_rng(41)
    e = rng.normal(size=(500, 3))
    y = rng.normal(size=(500, 3 * 4))
    y[:, 5] = 2.0  # a constant column: nan either way
    starts = np.array([0, 200])
    kept = _core.regressor_moments(y)
    assert (kept.n_samples, kept.n_columns) == (500, 12)
    for adjusted in (True, False):
        a = _core.cross_correlation(e, y, 4, 7, adjusted, starts)
        b = _core.cross_correlation(e, y, 4, 7, adjusted, starts, kept)
        np.testing.assert_array_equal(a["rho"], b["rho"])
        np.testing.assert_array_equal(a["constant_mask"], b["constant_mask"])
    with pytest.raises(dynval.ShapeMismatch, match=r"moments are of a \(500, 12\) regressor, not of this \(499, 12\)"):
        _core.cross_correlation(e[:-1], np.ascontiguousarray(y[:-1]), 4, 2, True, np.array([0]), kept)
