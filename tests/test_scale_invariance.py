"""Scale invariance as a property (contract §4, the column scaling rule; §8 for identify(physical=True)).

A regressor column's unit, the torques' unit and a joint's own unit decide nothing: every result the
contract calls unit-free is checked under random scalings drawn by hypothesis, against the result of
the data as they are. Per-column factors are drawn from 1e-6..1e6 where the zero-column test takes
part (its reference, the median norm, keeps its promise there), from 1e-140..1e140 where only each
column's own normalisation does (the stream's cross-correlation); the torques' common factor from
1e-140..1e140 (contract §1.3).

Each property catches a comparison of one column's or signal's size with another's: the zero test
against the largest norm (validate, compare, the design section, identify), a rank decision of a least
squares or pseudo-inverse on raw columns (the estimation refit, the physics and periodic sections'
nuisance refits), a weight or tolerance in the units of the data (identify(physical=True)), a sum
formed across columns of different units (the stream).
"""

from __future__ import annotations

import importlib.util
import math
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dynval
from dynval.identify import identify
from dynval.report import _sections
from dynval.stream import ValidationAccumulator

N, M, P = 400, 2, 6
DECISIONS = ("unexcited", "inseparable", "unidentifiable", "structural", "identifiable_rank",
             "identifiable_columns", "validation_rank")
HAVE_CVXPY = importlib.util.find_spec("cvxpy") is not None


def _exponents(lo: float, hi: float, size: int) -> st.SearchStrategy[list[float]]:
    return st.lists(st.floats(lo, hi, allow_nan=False), min_size=size, max_size=size)


def _factors(exponents: list[float]) -> np.ndarray:
    return np.power(10.0, np.asarray(exponents))


@lru_cache(maxsize=1)
def _runs():
    """Two runs of a six-column regressor: four excited columns, one zero in both runs (structural),
    one an exact combination of two others; a prediction that misses 0.2 of column 1, coloured noise."""
    rng = np.random.default_rng(37)

    def smooth(x):
        return np.cumsum(x, axis=0) / 8 + x

    ye, yv = smooth(rng.normal(size=(N, M, P))), smooth(rng.normal(size=(N, M, P)))
    for y in (ye, yv):
        y[:, :, 4] = 0.0
        y[:, :, 5] = 0.3 * y[:, :, 0] - 1.7 * y[:, :, 2]
    theta = np.array([1.0, -0.5, 0.8, 0.3, 0.0, 0.0])
    pred = np.einsum("njp,p->nj", yv, theta)
    noise = rng.normal(size=(N, M))
    noise[1:] += 0.5 * noise[:-1]
    meas = pred + 0.2 * yv[:, :, 1] + 0.3 * noise
    return ye, yv, pred, meas


def _validate(meas, pred, yv, ye, **keywords):
    return dynval.validate(meas, pred, n_params=4, regressor=yv, estimation={"regressor": ye}, max_lag=10,
                           **keywords)


@lru_cache(maxsize=1)
def _reference():
    ye, yv, pred, meas = _runs()
    return _validate(meas, pred, yv, ye)


def _decided(report):
    return sorted((f.kind, f.severity, f.joints, f.columns) for f in report.findings)


def _same_numbers(got, want, rtol, atol=0.0):
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)], rtol=rtol, atol=atol)


# --------------------------------------------------------------------------- validate and compare


@settings(max_examples=50)
@given(_exponents(-6.0, 6.0, P))
def test_validate_does_not_depend_on_a_columns_unit(exponents):
    ye, yv, pred, meas = _runs()
    s = _factors(exponents)
    got, want = _validate(meas, pred, yv * s, ye * s), _reference()
    assert _decided(got) == _decided(want)
    x, x0 = got.design["excitation"], want.design["excitation"]
    assert {k: x[k] for k in DECISIONS} == {k: x0[k] for k in DECISIONS}
    assert x["condition_scaled"] == pytest.approx(x0["condition_scaled"], rel=1e-6)
    _same_numbers(x["column_motion_ratio"], x0["column_motion_ratio"], 1e-9)
    cc, cc0 = got.cross_correlation, want.cross_correlation
    _same_numbers(cc["max_abs_rho"], cc0["max_abs_rho"], 1e-9)
    _same_numbers(cc["z_max"], cc0["z_max"], 1e-9)
    np.testing.assert_array_equal(cc["lag_of_max"], cc0["lag_of_max"])
    assert [c[:3] for c in cc["top_cells"]] == [c[:3] for c in cc0["top_cells"]]  # the heatmap's cells


@lru_cache(maxsize=1)
def _estimation_tau():
    ye, _, _, _ = _runs()
    theta = np.array([1.0, -0.5, 0.8, 0.3, 0.0, 0.0])
    return np.einsum("njp,p->nj", ye, theta) + 0.2 * ye[:, :, 1] + 0.3 * np.random.default_rng(3).normal(size=(N, M))


def _refitted(yv, ye):
    # the estimation run's refit (parameter error, missing terms): least squares and a pseudo-inverse
    _, _, pred, meas = _runs()
    return dynval.validate(meas, pred, n_params=3, regressor=yv, max_lag=10, model_columns=[0, 2, 3],
                           estimation={"regressor": ye, "tau": _estimation_tau()})


@lru_cache(maxsize=1)
def _refitted_reference():
    ye, yv, _, _ = _runs()
    return _refitted(yv, ye)


@settings(max_examples=30)
@given(_exponents(-6.0, 6.0, P))
def test_the_estimation_refit_does_not_depend_on_a_columns_unit(exponents):
    # its pseudo-inverse truncated a direction of a Gram matrix whose columns were 1e6 apart: the
    # parameter error's standard error moved by up to 60 % and findings changed
    ye, yv, _, _ = _runs()
    s = _factors(exponents)
    got, want = _refitted(yv * s, ye * s), _refitted_reference()
    assert _decided(got) == _decided(want)
    _same_numbers(got.bias["parameter_standard_error"], want.bias["parameter_standard_error"], 1e-9)
    missing, missing0 = got.cross_correlation["missing_terms"], want.cross_correlation["missing_terms"]
    _same_numbers(missing["statistic"], missing0["statistic"], 1e-6)
    _same_numbers(missing["share"], missing0["share"], 1e-6, atol=1e-9)  # a zero column's share: roundoff


@settings(max_examples=30)
@given(st.floats(-140.0, 140.0))
def test_validate_does_not_depend_on_the_torques_unit(exponent):
    ye, yv, pred, meas = _runs()
    c = 10.0**exponent
    got, want = _validate(meas * c, pred * c, yv, ye), _reference()
    assert _decided(got) == _decided(want)
    for section, key in (("per_joint", "r2"), ("per_joint", "vaf"), ("pooled", "r2"), ("ljung_box", "pvalue"),
                         ("bias", "pvalue"), ("cross_correlation", "max_abs_rho")):
        _same_numbers(getattr(got, section)[key], getattr(want, section)[key], 1e-9)
    assert got.per_joint["rmse"] == pytest.approx(c * want.per_joint["rmse"], rel=1e-12)


@settings(max_examples=30)
@given(_exponents(-6.0, 6.0, M))
def test_a_joints_unit_changes_none_of_its_per_joint_results(exponents):
    ye, yv, pred, meas = _runs()
    c = _factors(exponents)
    got, want = _validate(meas * c, pred * c, yv, ye), _reference()
    for section, key in (("per_joint", "r2"), ("per_joint", "vaf"), ("per_joint", "nrmse"), ("ljung_box", "pvalue"),
                         ("bias", "pvalue"), ("bias", "statistic"), ("autocorrelation", "rho"),
                         ("cross_correlation", "max_abs_rho"), ("cross_correlation", "z_max")):
        _same_numbers(getattr(got, section)[key], getattr(want, section)[key], 1e-9)
    per_joint = [f for f in _decided(got) if f[2] and f[0] != "pooling"]
    assert per_joint == [f for f in _decided(want) if f[2] and f[0] != "pooling"]


@lru_cache(maxsize=1)
def _moving_runs():
    """Two runs of the simulated two-joint arm (q and its derivatives, 10 regressor columns), torques
    with Coulomb friction the model lacks: the physics section finds it."""
    from dynval import simulate as sim

    t = np.arange(3000) / 100.0  # three periods: the periodic section runs
    runs = []
    for seed in (20, 21):
        rng = np.random.default_rng(seed)
        k = np.arange(1, 6)
        q, dq, ddq = sim.fourier_trajectory(t, rng.uniform(-0.5, 0.5, 2), rng.uniform(0.3, 0.8, (2, 5)) / k,
                                            rng.uniform(0.0, 2.0 * math.pi, (2, 5)), 0.1)
        runs.append((q, sim.regressor(q, dq, ddq)))
    theta = np.random.default_rng(1).normal(size=runs[0][1].shape[2])
    taus = [y @ theta + 0.3 * np.sign(np.gradient(q, axis=0)) + 0.05 * np.random.default_rng(2).normal(size=q.shape)
            for q, y in runs]
    return runs, taus, theta


def _physics_report(s, with_estimation):
    ((qe, ye), (qv, yv)), (te, tv), theta = _moving_runs()
    est = {"regressor": ye * s, "tau": te, "q": qe} if with_estimation else None
    return dynval.validate(tv, yv @ theta, n_params=yv.shape[2], regressor=yv * s, q=qv, sample_rate=100.0,
                           estimation=est)


@lru_cache(maxsize=2)
def _physics_reference(with_estimation):
    return _physics_report(np.ones(10), with_estimation)


@settings(max_examples=15)
@given(_exponents(-6.0, 6.0, 10), st.booleans())
def test_the_physics_and_periodic_sections_do_not_depend_on_a_columns_unit(exponents, with_estimation):
    # the model's own columns refitted as nuisance terms (validation run, periodic projection, the
    # estimation refit that names the term) once took their rank decisions on the raw columns
    got, want = _physics_report(_factors(exponents), with_estimation), _physics_reference(with_estimation)
    assert _decided(got) == _decided(want)
    for key in ("pvalue", "share"):
        _same_numbers(got.physics[key], want.physics[key], 1e-6, atol=1e-12)
    assert [t["term"] for t in got.physics["tests"]] == [t["term"] for t in want.physics["tests"]]
    _same_numbers(got.periodic["pvalue"], want.periodic["pvalue"], 1e-6)


@lru_cache(maxsize=1)
def _candidates():
    _, yv, pred, _ = _runs()
    return {"full": (pred + 0.2 * yv[:, :, 1], 5), "short": (pred, 4)}


def _compare(meas, candidates, yv, ye):
    return dynval.compare(meas, candidates, regressor=yv, max_lag=10, estimation={"regressor": ye})


@settings(max_examples=50)
@given(_exponents(-6.0, 6.0, P), st.floats(-140.0, 140.0))
def test_compare_does_not_depend_on_the_units(exponents, exponent):
    ye, yv, _, meas = _runs()
    s, c = _factors(exponents), 10.0**exponent
    want = _compare(meas, _candidates(), yv, ye)
    scaled = {name: (value * c, k) for name, (value, k) in _candidates().items()}
    got = _compare(meas * c, scaled, yv * s, ye * s)
    assert (got.verdict.decision, got.verdict.model, got.ranking) == (want.verdict.decision, want.verdict.model,
                                                                     want.ranking)
    assert _decided_all(got) == _decided_all(want)


def _decided_all(comparison):
    return {name: _decided(report) for name, report in comparison.reports.items()}


# --------------------------------------------------------------------------- the design section


@settings(max_examples=50)
@given(_exponents(-6.0, 6.0, 9))
def test_the_design_sections_columns_do_not_depend_on_their_units(exponents):
    # nine columns: a roundoff column (zero at any of these units: 1e-17 of the others), a column
    # exactly zero in both runs, one zero in the validation run only, one equal to twice another in
    # the validation run only (inseparable), one combination in both runs (structural)
    ye, yv, _, _ = _design_runs()
    s = _factors(exponents)
    # the roundoff column in the smallest of the units stays below 1e-13 of the median norm: the
    # rule's range (contract §4); multiplied by 1e6 while the others are divided by 1e6 it is a column
    s[6] = s.min()
    for est in (True, False):
        got = _sections.design(yv * s, None, {"regressor": ye * s} if est else None, None, None, None)["excitation"]
        want = _design_reference(est)
        assert {k: got[k] for k in DECISIONS} == {k: want[k] for k in DECISIONS}, est
        assert got["condition_scaled"] == pytest.approx(want["condition_scaled"], rel=1e-6)


@lru_cache(maxsize=1)
def _design_runs():
    rng = np.random.default_rng(38)
    ye, yv = rng.normal(size=(300, 2, 9)), rng.normal(size=(300, 2, 9))
    for y in (ye, yv):
        y[:, :, 4] = 0.0
        y[:, :, 5] = y[:, :, 0] - 2.0 * y[:, :, 1]
        y[:, :, 6] = 1e-17 * np.cos(y[:, :, 3])
    yv[:, :, 2] = 0.0
    yv[:, :, 8] = 2.0 * yv[:, :, 7]
    return ye, yv, None, None


@lru_cache(maxsize=2)
def _design_reference(est: bool):
    ye, yv, _, _ = _design_runs()
    x = _sections.design(yv, None, {"regressor": ye} if est else None, None, None, None)["excitation"]
    if est:  # what the test is about: each kind of column is there
        assert (x["unidentifiable"], x["structural"], x["unexcited"], x["inseparable"]) == ([4, 6], [4, 5, 6], [2], [8])
    return x


# --------------------------------------------------------------------------- identify


@lru_cache(maxsize=1)
def _identify_problem():
    rng = np.random.default_rng(39)
    y = rng.normal(size=(300, 2, 6))
    y[:, :, 5] = y[:, :, 0] + y[:, :, 1]  # an exactly dependent set: the base choice is by rounding
    tau = y[:, :, :5] @ np.array([1.0, -2.0, 0.5, 3.0, 0.1]) + 0.05 * rng.normal(size=(300, 2))
    return y, tau, identify(y, tau)


@settings(max_examples=50)
@given(_exponents(-6.0, 6.0, 6), st.floats(-100.0, 100.0))
def test_identify_does_not_depend_on_the_units(exponents, exponent):
    y, tau, want = _identify_problem()
    s, c = _factors(exponents), 10.0**exponent
    got = identify(y * s, tau * c)
    assert got.rank == want.rank == 5
    np.testing.assert_allclose(got.predict(y * s), c * want.predict(y), rtol=1e-7, atol=1e-9 * c * np.abs(tau).max())
    assert got.residual_sse == pytest.approx(c * c * want.residual_sse, rel=1e-9)
    assert got.sigma2 == pytest.approx(c * c * want.sigma2, rel=1e-9)
    if got.base_columns == want.base_columns:  # the same base set: the same parameters in the new units
        b = list(got.base_columns)
        np.testing.assert_allclose(got.estimate * s[b] / c, want.estimate, rtol=1e-6)
        np.testing.assert_allclose(got.rel_std_percent, want.rel_std_percent, rtol=1e-6)


@lru_cache(maxsize=1)
def _one_link():
    """A link whose least-squares estimate is impossible (0.1 + 0.1 < 0.3 about its centre of mass),
    and its two friction coefficients, the columns of unequal sizes."""
    m, c = 2.0, np.array([0.1, 0.2, -0.1])
    moments = np.diag([0.1, 0.1, 0.3])
    io = moments + m * (c @ c * np.eye(3) - np.outer(c, c))
    truth = np.array([m, *(m * c), io[0, 0], io[0, 1], io[1, 1], io[0, 2], io[1, 2], io[2, 2], 0.5, -0.4])
    rng = np.random.default_rng(40)
    a = rng.normal(size=(150, 12)) * np.geomspace(0.2, 20.0, 12)
    cols = [f"b:{p}" for p in ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")] + ["Fv_j", "Fc_j"]
    b = a @ truth + rng.normal(0.0, 0.01, 150)
    return a, b, cols, identify(a, b, column_names=cols, physical=True)


def _rms(a, b, full):
    return float(np.sqrt(np.mean((b - a @ full) ** 2)))


@pytest.mark.skipif(not HAVE_CVXPY, reason="cvxpy (the physical extra) is not installed")
@settings(max_examples=10)
@given(st.floats(-12.0, 12.0), st.floats(-4.0, 4.0), st.floats(-4.0, 4.0), st.floats(-4.0, 4.0))
def test_the_constrained_fit_does_not_depend_on_the_units(torque, link, viscous, coulomb):
    # the torques' unit, the link's (its ten columns alike) and each friction coefficient's
    a, b, cols, want = _one_link()
    c = 10.0**torque
    s = np.concatenate([np.full(10, 10.0**link), [10.0**viscous, 10.0**coulomb]])
    got = identify(a * s, b * c, column_names=cols, physical=True)
    assert got.physical["status"] == want.physical["status"] == "optimal"
    full = got.full_parameters * s / c
    assert _rms(a, b, full) == pytest.approx(_rms(a, b, want.full_parameters), rel=1e-6)
    assert got.physical["distance2"] == pytest.approx(want.physical["distance2"], rel=1e-5)
    np.testing.assert_allclose(full, want.full_parameters, atol=1e-3 * np.abs(want.full_parameters).max())


# --------------------------------------------------------------------------- the stream


def _streamed(meas, pred, y):
    acc = ValidationAccumulator(n_params=4, max_lag=10, backend="python")
    for i in range(0, N, 150):
        acc.update(meas[i:i + 150], pred[i:i + 150], y[i:i + 150])
    return acc.result()


@lru_cache(maxsize=1)
def _streamed_reference():
    _, yv, pred, meas = _runs()
    return _streamed(meas, pred, yv)


@settings(max_examples=50)
@given(_exponents(-140.0, 140.0, P), st.floats(-140.0, 140.0))
def test_the_stream_does_not_depend_on_the_units(exponents, exponent):
    _, yv, pred, meas = _runs()
    s, c = _factors(exponents), 10.0**exponent
    got, want = _streamed(meas * c, pred * c, yv * s), _streamed_reference()
    assert _decided(got) == _decided(want)
    for section, key in (("per_joint", "r2"), ("ljung_box", "pvalue"), ("autocorrelation", "rho"),
                         ("cross_correlation", "rho")):
        _same_numbers(getattr(got, section)[key], getattr(want, section)[key], 1e-8)
    assert got.cross_correlation["n_outside_white_band"] == want.cross_correlation["n_outside_white_band"]
    assert math.isclose(float(got.pooled["rmse_per_element"]), c * float(want.pooled["rmse_per_element"]),
                        rel_tol=1e-12)
