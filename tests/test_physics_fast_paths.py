"""The physics test's cheaper computations against the computations they replace (issue 38).

Each rule here computes what a library function computed before, in fewer passes or calls; the
reference is that library function (scipy, numpy) or the loop it replaces, never the code under
test. Where the rule claims the same bits, the comparison is exact.

Mutations caught: a prewhitening filter with its taps in the wrong order or a lag off by one; the
interpolation's grid offset or weight off (or a gather that takes the wrong neighbour where the
shifted rows are not consecutive); a block edge measured from the wrong side or only from the
block before; the derivatives' filter pass skipped changing q̇, q̈ or the bands.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from dynval.statistics import _derivatives, _model_terms, _physics


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("layout", ["C", "F", "1d"])
def test_the_prewhitening_filter_is_lfilters_to_the_bit(order, layout):
    rng = np.random.default_rng(order)
    for _ in range(20):
        a = rng.normal(0.0, 0.7, order)
        x = rng.normal(size=(997, 6)) * rng.lognormal(0.0, 3.0, 6)
        x = x[:, 2] if layout == "1d" else np.asfortranarray(x) if layout == "F" else x
        got = _physics._whiten(x, a)
        if order == 0:  # no filter: the rows as given
            assert got is x or np.shares_memory(got, x) and np.array_equal(got, x)
            continue
        reference = scipy.signal.lfilter(np.concatenate([[1.0], -a]), [1.0], x, axis=0)[order:]
        assert got.shape == reference.shape
        assert np.array_equal(got, reference)
        # column-major as lfilter's: a product of the rows sums in another order in the other layout
        assert got.ndim == 1 or (got.strides[0] == reference.strides[0] and got.flags.f_contiguous)


def test_the_physics_test_on_the_filtered_rows_is_unchanged():
    """The whole test of a 2-joint scenario with AR noise, with lfilter as the prewhitening filter."""
    from dynval import scenarios

    rep = scenarios.simulate(next(s for s in scenarios.library() if s.key == "right:ar0.99:planar2@1000"), 0)
    got = scenarios.validate_replicate(rep, False).to_dict()["physics"]["tests"]

    def lfiltered(x, a):
        if a.size == 0 or x.size == 0:
            return x[a.size:]
        return scipy.signal.lfilter(np.concatenate([[1.0], -a]), [1.0], x, axis=0)[a.size:]

    original = _physics._whiten
    try:
        _physics._whiten = lfiltered
        reference = scenarios.validate_replicate(rep, False).to_dict()["physics"]["tests"]
    finally:
        _physics._whiten = original
    assert got == reference


def test_the_shifted_prediction_is_numpy_interp_to_the_bit():
    rng = np.random.default_rng(1)
    n, m, big = 3001, 4, 12
    pred = rng.normal(size=(n, m)) * rng.lognormal(0.0, 3.0, m)
    t = np.arange(n, dtype=float)
    inner = slice(big + 1, n - big - 1)
    # quarter samples (the grid), arbitrary shifts (the parabolic refinement) and shifts within
    # rounding of a whole sample, where t − d falls on either side of a grid point from row to row
    shifts = [k / 4 for k in range(-4 * big, 4 * big + 1) if k % 4] + list(rng.uniform(-big, big, 40)) + \
        [3.0 + 1e-13, -2.0 - 1e-13, 5.0 - 4e-13]
    for d in shifts:
        reference = np.column_stack([np.interp(t - d, t, pred[:, j]) for j in range(m)])[inner]
        assert np.array_equal(_physics._shifted(pred, float(d), inner), reference), d


def test_the_delay_tests_result_is_unchanged_by_the_shifted_rows():
    """The whole delay test against the same test with numpy.interp for the shifted prediction."""
    rng = np.random.default_rng(2)
    n, m = 4000, 3
    t = np.arange(n) / 500.0
    pred = np.column_stack([np.sin(2 * np.pi * f * t) + 0.3 * np.sign(np.sin(2 * np.pi * f * t))
                            for f in (0.4, 0.7, 1.1)])
    tt = np.arange(n, dtype=float)
    meas = np.column_stack([np.interp(tt - 2.3, tt, pred[:, j]) for j in range(m)]) + rng.normal(0, 0.05, (n, m))
    got = _physics.delay_test(meas, pred, sample_rate=500.0)

    def interp_shifted(p, shift, rows):
        return np.column_stack([np.interp(tt - shift, tt, p[:, j]) for j in range(p.shape[1])])[rows]

    original = _physics._shifted
    try:
        _physics._shifted = interp_shifted
        reference = _physics.delay_test(meas, pred, sample_rate=500.0)
    finally:
        _physics._shifted = original
    assert 2.0 < got["shift_samples"] < 2.6
    assert got["shift_samples"] == reference["shift_samples"]
    assert np.array_equal(got["share"], reference["share"])
    assert np.array_equal(got["pvalue"], reference["pvalue"], equal_nan=True)


def test_each_rows_distance_to_the_nearest_block_edge_is_the_loops():
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 4000))
        blocks = int(rng.integers(1, 70))
        index = np.arange(n) * blocks // max(n, 1)
        starts = np.flatnonzero(np.diff(index)) + 1
        reference = np.full(n, np.inf)
        for b in starts:
            reference = np.minimum(reference, np.abs(np.arange(n) - b + 0.5))
        assert np.array_equal(_model_terms.edge_distance(n, starts), reference)


def test_derivatives_without_the_positions_pass_are_the_same():
    rng = np.random.default_rng(4)
    fs = 1000.0
    t = np.arange(5000) / fs
    q = np.column_stack([np.sin(2 * np.pi * 0.3 * t), np.cos(2 * np.pi * 0.7 * t)]) + rng.normal(0, 1e-4, (5000, 2))
    full = _derivatives.checked_differentiate(q, fs, window=0.1)
    quick = _derivatives.checked_differentiate(q, fs, window=0.1, positions=False)
    assert np.array_equal(quick.dq, full.dq) and np.array_equal(quick.ddq, full.ddq)
    assert quick.bandwidth_hz == full.bandwidth_hz
    assert quick.derivative_bandwidth_hz == full.derivative_bandwidth_hz
    assert quick.q is q
    d = _physics.derivatives(q, fs)
    assert np.array_equal(d.dq, full.dq) and np.array_equal(d.ddq, full.ddq)
    assert d.bandwidth_hz == full.bandwidth_hz
