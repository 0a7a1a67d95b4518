"""Contract §1: shapes, promotion, accepted types, return types, regressor forms, segment forms."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval.checks import _segments

RNG = np.random.default_rng(20)
MEAS = RNG.standard_normal(30).cumsum()
PRED = MEAS + 0.3 * RNG.standard_normal(30)
E = MEAS - PRED

PAIR_FUNCTIONS = {
    "sse": ("pooled", "raw_values"),
    "max_abs_error": ("pooled", "raw_values"),
    "rmse": ("pooled", "raw_values", "uniform_average"),
    "vaf": ("pooled", "raw_values", "uniform_average", "variance_weighted"),
    "fit_percent": ("pooled", "raw_values", "uniform_average", "variance_weighted"),
    "r2": ("pooled", "raw_values", "uniform_average", "variance_weighted"),
}


@pytest.mark.parametrize("name", sorted(PAIR_FUNCTIONS))
def test_one_d_equals_column_and_return_types(backend, name):
    f = getattr(dynval, name)
    col_m, col_p = MEAS[:, None], PRED[:, None]
    for mo in PAIR_FUNCTIONS[name]:
        values = [
            f(MEAS, PRED, multioutput=mo, backend=backend),
            f(col_m, col_p, multioutput=mo, backend=backend),
            f(MEAS, col_p, multioutput=mo, backend=backend),
            f(col_m, PRED, multioutput=mo, backend=backend),
        ]
        for v in values:
            if mo == "raw_values":
                assert isinstance(v, np.ndarray) and v.shape == (1,) and v.dtype == np.float64
            else:
                assert type(v) is float
        np.testing.assert_array_equal(np.asarray(values[0]), np.asarray(values[1]))
        np.testing.assert_array_equal(np.asarray(values[0]), np.asarray(values[2]))
        np.testing.assert_array_equal(np.asarray(values[0]), np.asarray(values[3]))


def test_per_joint_shapes(backend):
    meas = RNG.standard_normal((25, 4))
    pred = meas + 0.1
    for name in PAIR_FUNCTIONS:
        v = getattr(dynval, name)(meas, pred, multioutput="raw_values", backend=backend)
        assert v.shape == (4,) and v.dtype == np.float64
    assert dynval.residual_mean(meas, backend=backend).shape == (4,)
    assert dynval.residual_variance(meas, backend=backend).shape == (4,)
    assert dynval.residual_mean(MEAS, backend=backend).shape == (1,)
    assert dynval.residual_variance(MEAS, ddof=0, backend=backend).shape == (1,)


@pytest.mark.parametrize(
    "convert",
    [
        lambda a: a.tolist(),
        lambda a: tuple(a.tolist()),
        lambda a: a.astype(np.float32),
        lambda a: np.asfortranarray(np.column_stack([a, a]))[:, 0],  # strided view
        lambda a: np.ascontiguousarray(a[::-1])[::-1],  # negative stride
    ],
    ids=["list", "tuple", "float32", "strided", "reversed"],
)
def test_array_likes(backend, convert):
    m, p = convert(MEAS), convert(PRED)
    expected = dynval.r2(np.array(m, dtype=np.float64), np.array(p, dtype=np.float64), backend=backend)
    assert dynval.r2(m, p, backend=backend) == expected
    assert dynval.autocorrelation(m, 3, backend=backend).tolist() == dynval.autocorrelation(
        np.array(m, dtype=np.float64), 3, backend=backend).tolist()


def test_int_bool_float32_are_converted_once(backend):
    ints = np.array([[1, 4], [2, 3], [5, 9], [7, 1]])
    assert dynval.sse(ints, ints[::-1], backend=backend) == dynval.sse(ints.astype(float), ints[::-1].astype(float),
                                                                       backend=backend)
    flags = np.array([True, False, True, True, False])
    assert dynval.sse(flags, ~flags, backend=backend) == 5.0
    f32 = np.array([0.1, 0.2, 0.7], dtype=np.float32)
    assert dynval.sse(f32, np.zeros(3, dtype=np.float16), backend=backend) == float(np.sum(f32.astype(np.float64) ** 2))
    assert dynval.residual_mean([1, 2, 4], backend=backend).tolist() == [7 / 3]


def test_residuals_shape(backend):
    assert dynval.residuals(MEAS, PRED, backend=backend).shape == (30,)
    assert dynval.residuals(MEAS, PRED[:, None], backend=backend).shape == (30, 1)
    np.testing.assert_array_equal(dynval.residuals(MEAS, PRED, backend=backend), MEAS - PRED)
    two = np.column_stack([MEAS, PRED])
    assert dynval.residuals(two, two * 0.5, backend=backend).shape == (30, 2)


def test_autocorrelation_shapes(backend):
    one = dynval.autocorrelation(E, 5, backend=backend)
    col = dynval.autocorrelation(E[:, None], 5, backend=backend)
    assert one.shape == (6,) and col.shape == (6, 1)
    np.testing.assert_array_equal(one, col[:, 0])
    two = dynval.autocorrelation(np.column_stack([E, E[::-1]]), 5, backend=backend)
    assert two.shape == (6, 2)
    np.testing.assert_array_equal(two[:, 0], one)


def test_result_shapes(backend):
    e = np.column_stack([E, E[::-1], np.sin(np.arange(30.0))])
    lb = dynval.ljung_box(e, [2, 4], model_df=1, backend=backend)
    assert lb.lags.dtype == np.int64 and lb.lags.shape == (2,) and lb.df.shape == (2,)
    assert lb.statistic.shape == lb.pvalue.shape == lb.log_pvalue.shape == (2, 3)
    assert dynval.box_pierce(E, 3, backend=backend).statistic.shape == (1, 1)
    zm = dynval.zero_mean_test(e, backend=backend)
    for field in ("mean", "std", "statistic_iid", "pvalue_iid", "statistic_eff", "pvalue_eff", "df_eff", "n_eff"):
        assert getattr(zm, field).shape == (3,), field
    assert zm.n_samples == 30 and zm.df_iid == 29 and isinstance(zm.bandwidth, int)
    cc = dynval.cross_correlation(e, RNG.standard_normal((30, 3, 2)), 4, backend=backend)
    assert cc.rho.shape == (3, 2, 5) and cc.constant_mask.shape == (3, 2) and cc.constant_mask.dtype == bool
    assert isinstance(cc.band, float) and isinstance(cc.outside, list)
    ic = dynval.criteria(e, e * 0.9, n_params=2, backend=backend)
    assert all(type(getattr(ic, k)) is float for k in ("aic", "bic", "aicc", "fpe", "naic"))
    assert ic.n_obs == 90 and ic.n_params == 2 and ic.noise_model == "pooled"
    d = ic.to_dict()
    assert d["n_obs"] == 90 and isinstance(d["aic"], float)
    assert isinstance(lb.to_dict()["statistic"], list)
    with pytest.raises(AttributeError):
        ic.aic = 0.0  # frozen


def test_cross_correlation_one_d_residual(backend):
    y3 = RNG.standard_normal((30, 1, 2))
    a = dynval.cross_correlation(E, y3, 3, backend=backend)
    b = dynval.cross_correlation(E[:, None], y3[:, 0, :], 3, n_joints=1, backend=backend)
    np.testing.assert_array_equal(a.rho, b.rho)


def test_parse_segments_forms():
    assert _segments.parse_segments(None, 10).tolist() == [0]
    assert _segments.parse_segments([10], 10).tolist() == [0]
    assert _segments.parse_segments([0], 10).tolist() == [0]
    assert _segments.parse_segments([3, 3, 4], 10).tolist() == [0, 3, 6]
    assert _segments.parse_segments((0, 3, 6), 10).tolist() == [0, 3, 6]
    assert _segments.parse_segments(np.array([2, 8], dtype=np.int32), 10).tolist() == [0, 2]
    assert _segments.parse_segments([0, 9], 10).tolist() == [0, 9]
    for bad in ([True, 9], [0, 0], [3, -1, 8], [0, 4, 4], np.array([[0, 5]]), "05", 3.0):
        with pytest.raises(dynval.InvalidParameter):
            _segments.parse_segments(bad, 10)


def test_omit_refines_segments():
    a = np.arange(10.0).reshape(-1, 1)
    a[[0, 4, 5]] = np.nan
    b = np.ones((10, 2))
    b[8, 1] = np.inf
    kept, starts, omitted = _segments.omit_nonfinite([a, b], np.array([0, 6]))
    # kept rows 1,2,3 | 6,7 | 9  -> new indices 0..2 | 3..4 | 5
    assert omitted == 4
    assert kept[0].ravel().tolist() == [1.0, 2.0, 3.0, 6.0, 7.0, 9.0]
    assert starts.tolist() == [0, 3, 5]
