"""The streamed report at every accepted magnitude (contract §1.3, §4.1): the accumulators hold
their sums in units of a power of two per column, so residuals at 1e±90, 1e-100, 1e-200 or a
subnormal magnitude, and regressor columns 1e70 apart from them, give ``validate``'s report (to
the agreement tolerance of tests/test_stream.py) on both backends, whatever the chunking and the
merge order.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import dynval
from dynval.stream import ValidationAccumulator
from dynval.streaming._stream import Compensated, Layout, State
from test_stream import assert_same_report

# (residual scale, target scale, regressor scale): the magnitudes reported broken and their neighbours
SCALES = [(1e90, 1e90, 1e70), (1e-90, 1e-90, 1e-90), (1e-100, 1e-100, 1e-100), (1e-100, 1e-100, 1.0),
          (1e-200, 1e-200, 1.0), (1e140, 1e140, 1e-200), (1e-300, 1e-300, 1e-300), (5e-321, 1e-310, 1e-310)]


def _problem(scale_e, scale_t, scale_y, n=300, m=2, p=3, seed=4):
    rng = np.random.default_rng(seed)
    tau = scale_t * (np.cumsum(rng.normal(size=(n, m)), axis=0) / 10 + rng.normal(size=(1, m)))
    resid = scale_e * (rng.normal(size=(n, m)) + 0.3 * np.cumsum(rng.normal(size=(n, m)), axis=0) / 10)
    y = scale_y * (rng.normal(size=(n, m, p)) + tau[:, :, None] / scale_t * rng.normal(size=(1, 1, p)))
    return tau, tau - resid, y


def _streamed(tau, pred, y, backend, cuts, **keywords):
    acc = ValidationAccumulator(n_params=3, backend=backend, **keywords)
    bounds = [0, *cuts, tau.shape[0]]
    for a, b in zip(bounds[:-1], bounds[1:]):
        acc.update(tau[a:b], pred[a:b], y[a:b])
    return acc.result()


@pytest.mark.parametrize("scales", SCALES, ids=[f"{s[0]:.0e}-{s[2]:.0e}" for s in SCALES])
def test_streamed_equals_validate_at_every_scale(scales, backend):
    tau, pred, y = _problem(*scales)
    if scales[0] < 1e-300:  # subnormal residuals: the target's own digits, far below, stay out of them
        pred = tau - scales[0] * np.round(np.random.default_rng(5).normal(size=tau.shape) * 20)
    got = _streamed(tau, pred, y, backend, [1, 37, 38, 150], max_lag=6)
    want = dynval.validate(tau, pred, regressor=y, n_params=3, max_lag=6, backend="python",
                           cross_correlation_detail="full")
    assert_same_report(got, want, tau, pred, y)
    # the numbers reported broken: ρ 0 at 1e90 / 1e70 and ±inf at 1e-100, every cell "outside"
    rho = got.cross_correlation["rho"]
    assert np.all(np.isfinite(rho)) and np.max(np.abs(rho)) > 0.01 and np.max(np.abs(rho)) <= 1.0
    assert got.cross_correlation["n_outside_white_band"] == want.cross_correlation["n_outside_white_band"]


@pytest.mark.parametrize("noise_model", ["pooled", "per_joint", "full"])
def test_backends_agree_on_tiny_and_huge_joints_side_by_side(noise_model):
    """One joint near 1e-200 next to one near 1e100: per-joint exponents, pooled sums on the larger;
    the full noise model's covariance of two joints near 1e-200 on one exponent, as validate's."""
    tau, pred, y = _problem(1.0, 1.0, 1.0, m=2)
    # the full model's covariance of joints 1e300 apart is singular to float64: there both are tiny
    scales = [1e-200, 3e-201] if noise_model == "full" else [1e-200, 1e100]
    tau, pred = tau * scales, pred * scales
    want = dynval.validate(tau, pred, regressor=y, n_params=3, max_lag=4, noise_model=noise_model,
                           backend="python", cross_correlation_detail="full")
    for backend in [b for b in ("python", "cpp") if dynval.backends()[b]["available"]]:
        got = _streamed(tau, pred, y, backend, [100, 101, 250], max_lag=4, noise_model=noise_model)
        assert_same_report(got, want, tau, pred, y)


def test_chunks_of_very_different_magnitude_merge_exactly(backend):
    """The first chunk near 1e-250, the later ones near 1e100: the first chunk's exponent is not
    kept (its units would overflow the later squares); merges move to the larger exponent."""
    tau, pred, y = _problem(1.0, 1.0, 1.0, n=240)
    tau[:60] *= 1e-250
    pred[:60] *= 1e-250
    y[:60] *= 1e-250
    tau[60:] *= 1e100
    pred[60:] *= 1e100
    y[60:] *= 1e100
    want = dynval.validate(tau, pred, regressor=y, n_params=3, max_lag=5, backend="python",
                           cross_correlation_detail="full")
    got = _streamed(tau, pred, y, backend, [20, 60, 61, 200], max_lag=5)
    assert_same_report(got, want, tau, pred, y)


def test_merge_trees_agree_at_small_scale(backend):
    tau, pred, y = _problem(1e-200, 1e-200, 1e-90, n=200)
    want = dynval.validate(tau, pred, regressor=y, n_params=3, max_lag=5, backend="python",
                           cross_correlation_detail="full")
    accs = []
    for a, b in [(0, 3), (3, 70), (70, 71), (71, 200)]:
        acc = ValidationAccumulator(n_params=3, max_lag=5, backend=backend)
        acc.update(tau[a:b], pred[a:b], y[a:b])
        accs.append(acc)
    left = accs[0].copy().merge(accs[1])  # ((0, 1), (2, 3)): the exponents meet at the root
    got = left.merge(accs[2].copy().merge(accs[3])).result()
    assert_same_report(got, want, tau, pred, y)
    assert np.all(np.isfinite(got.cross_correlation["rho"])) and np.all(np.isfinite(got.autocorrelation["rho"]))


def test_pickled_state_keeps_its_exponents(backend):
    tau, pred, y = _problem(1e-200, 1e-200, 1e-200, n=100)
    acc = ValidationAccumulator(n_params=3, max_lag=5, backend=backend)
    acc.update(tau[:50], pred[:50], y[:50])
    clone = pickle.loads(pickle.dumps(acc))
    for a in (acc, clone):
        a.update(tau[50:], pred[50:], y[50:])
    np.testing.assert_array_equal(clone.result().cross_correlation["rho"], acc.result().cross_correlation["rho"])


def test_exponents_are_those_of_the_largest_value():
    """The reference state's exponents after merges: frexp of each column's largest |x|, as
    validate's scaling takes them (contract §4.1)."""
    rng = np.random.default_rng(2)
    e = rng.normal(size=(90, 2)) * [3e-200, 5e40]
    e[70, 0] = -7e-190  # the largest |e| of joint 0 in a later block
    layout = Layout(m=2, p=0, acf_lags=3, xcorr_lags=0, gram=True)
    st = State(layout)
    for a in range(0, 90, 25):
        st.merge(State.from_block(layout, e[a:a + 25], e[a:a + 25], None))
    np.testing.assert_array_equal(st.exp_e, np.frexp(np.abs(e).max(axis=0))[1])
    assert np.all(np.abs(st.k_e) < 1) and np.all(np.abs(st.prod_e.value()[0]) <= 90)


def test_compensated_scale_is_exact():
    c = Compensated(np.array([1.5, -3.0]))
    c.lo[:] = [2.0**-60, 0.0]
    c.scale(np.array([-700, 5]))
    np.testing.assert_array_equal(c.hi, [1.5 * 2.0**-700, -96.0])
    np.testing.assert_array_equal(c.lo, [2.0**-760, 0.0])


def test_in_memory_colour_factor_is_the_same_on_both_backends():
    """validate's colour-aware band at 1e-200: the reference's FFT autocorrelation scales each
    column by a power of two as the compiled kernel does (it gave a factor 1.0 against 1.98)."""
    if not dynval.backends()["cpp"]["available"]:
        pytest.skip("needs the compiled backend")
    rng = np.random.default_rng(1)
    e = np.cumsum(rng.normal(size=(400, 2)), axis=0) * 1e-201
    tau = rng.normal(size=(400, 2)) * 1e-200
    y = rng.normal(size=(400, 2, 3))
    got = {b: dynval.validate(tau, tau - e, regressor=y, n_params=4, max_lag=5, backend=b).cross_correlation
           for b in ("python", "cpp")}
    assert got["python"]["colour_lags"] == got["cpp"]["colour_lags"]
    np.testing.assert_allclose(got["python"]["colour_factor"], got["cpp"]["colour_factor"], rtol=1e-12)
    assert np.max(got["python"]["colour_factor"]) > 1.0  # the coloured residual is seen at all
