"""The physics test's cheaper computations against the computations they replace (issue 38).

Each rule here computes what a library function computed before, in fewer passes or calls; the
reference is that library function (scipy, numpy) or the loop it replaces, never the code under
test. Where the rule claims the same bits, the comparison is exact.

Mutations caught: a prewhitening filter with its taps in the wrong order or a lag off by one; the
interpolation's grid offset or weight off (or a gather that takes the wrong neighbour where the
shifted rows are not consecutive); a block edge measured from the wrong side or only from the
block before; the derivatives' filter pass skipped changing q̇, q̈ or the bands; an R factor
not upper triangular or cut to the wrong rows; a small least squares without the rank cut (a basic
instead of the minimum-norm solution); a Cholesky statistic kept below pinv's cut-off; a one-column
Wald test without the HC1 degrees-of-freedom factor.
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
    for trial in range(20):
        a = rng.normal(0.0, 0.7, order)
        width = (6, 37)[trial % 2]  # 37: across the filter's pieces of 16 columns
        x = rng.normal(size=(997, width)) * rng.lognormal(0.0, 3.0, width)
        x = x[:, 2] if layout == "1d" else np.asfortranarray(x) if layout == "F" else x
        got = _physics._whiten(x, a)
        if order == 0:  # no filter: the rows as given
            assert got is x or (np.shares_memory(got, x) and np.array_equal(got, x))
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
    # the physics library's: the same filter with its interior convolved by FFT
    d = _physics.derivatives(q, fs)
    for got, reference in ((d.dq, full.dq), (d.ddq, full.ddq)):
        assert np.max(np.abs(got - reference)) <= 1e-12 * np.max(np.abs(reference))
    assert d.bandwidth_hz == full.bandwidth_hz


# ------------------------------------------------------------- rules that move the last bits only

def _fft_yule_walker(u, order):
    """The AR(order) coefficients from autocovariances taken by one zero-padded FFT (the former way)."""
    n = u.shape[0]
    uc = u - u.mean()
    nfft = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(uc, nfft)
    acov = np.fft.irfft(f * np.conj(f), nfft)[:order + 1] / n
    return scipy.linalg.solve_toeplitz(acov[:order], acov[1:order + 1])


def test_the_ar_model_from_direct_lag_sums_is_the_ffts():
    rng = np.random.default_rng(5)
    for phi in ([0.6, 0.3], [1.2, -0.5], [0.95, 0.0], [-0.4, 0.1]):
        e = rng.normal(size=6000)
        u = scipy.signal.lfilter([1.0], [1.0, -phi[0], -phi[1]], e) + 3.0
        a, n_eff = _physics._ar_prewhitener(u, 2)
        assert a.size == 2 or (phi[1] == 0.0 and a.size >= 1)
        reference = _fft_yule_walker(u, a.size)
        np.testing.assert_allclose(a, reference, rtol=1e-10, atol=1e-12)
        assert 2.0 <= n_eff <= u.size


def _rows_wald(x, y, base, cand):
    """HC1 Wald statistic (score form) of the columns ``cand`` in the OLS of y on x[:, base + cand],
    from the rows (least squares by numpy.linalg.lstsq on them)."""
    cols = list(base) + list(cand)
    xx = x[:, cols]
    n, k = xx.shape
    r = y - xx @ np.linalg.lstsq(xx, y, rcond=None)[0]
    xt = x[:, cand]
    if len(base):
        xt = xt - x[:, base] @ np.linalg.lstsq(x[:, base], xt, rcond=None)[0]
    h = xt * r[:, None]
    meat = h.T @ h * (n / max(n - k, 1))
    score = xt.T @ y
    return float(score @ np.linalg.pinv(meat) @ score)


@pytest.mark.parametrize("base", [[], [0, 1, 2], [5]])
def test_a_selection_steps_candidates_projected_together_equal_each_fit_on_the_rows(base):
    rng = np.random.default_rng(6)
    n, k = 1500, 14
    x = rng.normal(size=(n, k)) @ (np.eye(k) + 0.3 * rng.normal(size=(k, k)))
    y = x[:, 3] * 0.2 + np.abs(x[:, 0]) * rng.normal(size=n)  # heteroscedastic
    r = np.linalg.qr(np.column_stack([x, y]), mode="r")
    tests = _physics._Tests(r[:, :k], r[:, k], np.asfortranarray(x), y, n)
    candidates = [np.arange(a, b) for a, b in ((3, 5), (6, 7), (7, 12), (12, 14)) if a not in base]
    got = tests.step(np.asarray(base, dtype=int), candidates)
    for w, cand in zip(got, candidates):
        assert w == pytest.approx(_rows_wald(x, y, base, list(cand)), rel=1e-8)


def test_the_r_factor_by_pieces_of_1024_rows_holds_the_gram_matrix():
    rng = np.random.default_rng(8)
    for n in (3978, 5027, 20000):
        x = np.asfortranarray(rng.normal(size=(n, 30)) * np.logspace(0, 4, 30))
        r = _physics._tall_r(x)
        whole = np.linalg.qr(x, mode="r")
        assert r.shape == whole.shape
        np.testing.assert_allclose(np.abs(r), np.abs(whole), rtol=1e-9, atol=1e-9 * np.abs(whole).max())


def test_the_quarter_grids_costs_are_the_loops_where_they_are_read():
    rng = np.random.default_rng(9)
    n, m, big = 5000, 3, 10
    tt = np.arange(n, dtype=float)
    pred = np.column_stack([np.sin(2 * np.pi * f * tt / 500) + 0.3 * np.sign(np.sin(2 * np.pi * f * tt / 500))
                            for f in (0.5, 0.8, 1.3)])
    inner = slice(big + 1, n - big - 1)
    for delay in (2.3, -1.6, 0.0, 4.75):
        meas = np.column_stack([np.interp(tt - delay, tt, pred[:, j]) for j in range(m)]) + \
            rng.normal(0, 0.05, (n, m))
        sse0 = np.sum((meas - pred)[inner] ** 2, axis=0)

        def sse(shift, meas=meas):
            shifted = np.column_stack([np.interp(tt - shift, tt, pred[:, j]) for j in range(m)])
            return np.sum((meas[inner] - shifted[inner]) ** 2, axis=0)

        best = round(delay)
        grid = np.clip(best + np.arange(-1.0, 1.001, 0.25), -big, big)
        reference = np.array([np.sum(sse(d) / sse0) for d in grid])
        got = _physics._grid_costs(meas, pred, inner, grid, sse, sse0)
        i = int(np.argmin(reference))
        assert int(np.argmin(got)) == i
        for k in (i - 1, i, i + 1):
            if 0 <= k < grid.size:
                assert got[k] == reference[k]
        np.testing.assert_allclose(got, reference, rtol=1e-9)


def test_the_joint_test_of_a_first_pass_is_computed_only_when_it_is_kept(monkeypatch):
    """The fit returned holds the test of every group of the problem it comes from, to the bit."""
    rng = np.random.default_rng(11)
    n = 3000
    t = np.arange(n) / 500.0
    q = np.column_stack([np.sin(2 * np.pi * 0.4 * t), np.sin(2 * np.pi * 0.7 * t + 1)])
    d = _physics.derivatives(q, 500.0)
    e = 0.3 * np.sign(d.dq[:, 0]) + 0.1 * scipy.signal.lfilter([1.0], [1.0, -0.6], rng.normal(size=n))
    lib = _physics.library(0, q, d.dq, d.ddq, e, 500.0)
    stack = _physics._Stack(e, np.zeros((n, 0)), lib)
    calls = []
    original = _physics._with_joint_test
    monkeypatch.setattr(_physics, "_with_joint_test", lambda fit: calls.append(fit) or original(fit))
    _, problem, fit = _physics._filtered_fit(stack, 0.05)
    assert fit["selected"] and len(calls) == 2  # the second pass's, then the fit returned (already done)
    reference = _physics._whitened_fit(problem, 0.05)
    assert (fit["f"], fit["pvalue"], fit["selected"]) == (reference["f"], reference["pvalue"], reference["selected"])
    assert "tests" not in fit


def test_the_derivatives_interior_by_fft_is_savgol_filters_to_rounding_and_its_ends_to_the_bit():
    rng = np.random.default_rng(12)
    for n, length in ((20000, 101), (500, 21), (101, 101), (150, 101)):
        x = np.cumsum(rng.normal(size=(n, 3)), axis=0) + 100.0
        half = length // 2
        for deriv in (1, 2):
            reference = scipy.signal.savgol_filter(x, length, 4, deriv=deriv, delta=1e-3, axis=0, mode="interp")
            got = _derivatives._savgol_by_fft(x, length, 4, deriv, 1e-3)
            assert got.shape == reference.shape
            assert np.max(np.abs(got - reference)) <= 1e-12 * np.max(np.abs(reference))
            assert np.array_equal(got[:half], reference[:half]) and np.array_equal(got[-half:], reference[-half:])


def test_a_column_major_library_holds_the_same_columns():
    rng = np.random.default_rng(13)
    n, m = 800, 4
    q = np.cumsum(rng.normal(0.0, 0.01, (n, m)), axis=0)
    d = _physics.derivatives(q, 200.0)
    for j in range(m):
        rows = _physics.library(j, q, d.dq, d.ddq, np.zeros(n), 200.0)
        cols = _physics.library(j, q, d.dq, d.ddq, np.zeros(n), 200.0, column_major=True)
        assert list(rows) == list(cols)
        for g in rows:
            assert cols[g].flags.f_contiguous and np.array_equal(cols[g], rows[g])


def test_the_period_searchs_valleys_are_the_loops():
    from dynval.statistics import _periodic

    def loop(d, threshold):
        below = d <= threshold
        below[0] = False
        out, lag, n = [], 1, d.shape[0]
        while lag < n:
            if below[lag]:
                end = lag
                while end + 1 < n and below[end + 1]:
                    end += 1
                out.append(lag + int(np.argmin(d[lag:end + 1])))
                lag = end + 1
            else:
                lag += 1
        return out

    rng = np.random.default_rng(14)
    for n in (1, 2, 5, 300, 5000):
        d = np.abs(np.cumsum(rng.normal(size=n))) * 0.05 + 0.5 * (1 + np.cos(np.arange(n) / 7.0))
        for threshold in (-1.0, 0.05, 0.3, 1.0, 10.0):
            assert _periodic._valleys(d.copy(), threshold) == loop(d.copy(), threshold)


def test_the_column_major_librarys_scales_are_each_columns_own_to_the_bit():
    rng = np.random.default_rng(15)
    for n in (1, 37, 4000):
        x = np.asfortranarray(rng.normal(size=(n, 6)) * rng.lognormal(0.0, 6.0, 6))
        x[:, 2] = 0.0
        assert np.array_equal(_physics._scales(x), np.array([_physics._scale(c) for c in x.T]))


def test_the_r_factor_from_dgeqrf_is_numpys_to_the_bit():
    # the same Householder QR without numpy's wrapping: R itself, not only up to signs
    rng = np.random.default_rng(16)
    for shape in ((1024, 40), (3978, 45), (45, 45), (7, 12), (3, 1)):
        x = np.asfortranarray(rng.normal(size=shape) * np.logspace(0, 3, shape[1]))
        for piece in (x, np.ascontiguousarray(x), x[1:]):
            assert np.array_equal(_physics._r_of(piece), np.linalg.qr(piece, mode="r"))
    assert _physics._r_of(np.zeros((5, 0))).shape == np.linalg.qr(np.zeros((5, 0)), mode="r").shape


def test_the_small_least_squares_are_numpys_full_rank_and_minimum_norm_when_rank_deficient():
    rng = np.random.default_rng(17)
    rcond = np.finfo(float).eps * 4000
    for rows, cols in ((45, 21), (46, 1), (30, 30)):
        x = rng.normal(size=(rows, cols)) @ (np.eye(cols) + 0.5 * rng.normal(size=(cols, cols)))
        y = rng.normal(size=rows)
        np.testing.assert_allclose(_physics._small_lstsq(x, y, rcond), np.linalg.lstsq(x, y, rcond=rcond)[0],
                                   rtol=1e-9, atol=1e-12)
    # a repeated column and a zero one: numpy's minimum-norm solution splits the coefficient evenly,
    # a basic solution (a QR without the rank cut) would not
    x = rng.normal(size=(40, 5))
    x[:, 3] = x[:, 1]
    x[:, 4] = 0.0
    y = rng.normal(size=40)
    got = _physics._small_lstsq(x, y, rcond)
    np.testing.assert_allclose(got, np.linalg.lstsq(x, y, rcond=rcond)[0], rtol=1e-9, atol=1e-12)
    assert got[1] == pytest.approx(got[3], rel=1e-9) and got[4] == 0.0


def test_the_score_quadratic_is_the_pseudo_inverses_when_conditioned_and_singular():
    rng = np.random.default_rng(18)
    for k in (2, 7, 24):
        h = rng.normal(size=(500, k)) * rng.lognormal(0.0, 1.0, k)
        meat, score = h.T @ h, rng.normal(size=k)
        assert _physics._score_quadratic(score, meat) == pytest.approx(float(score @ np.linalg.pinv(meat) @ score),
                                                                       rel=1e-9)
    # rank 2 of 4 (a score in its range and one outside it): pinv's cut, where a Cholesky factor of
    # the rounding left in the null space would return a huge statistic or fail
    a = rng.normal(size=(4, 2))
    meat = a @ a.T
    for score in (a @ np.array([1.0, -2.0]), rng.normal(size=4)):
        want = float(score @ np.linalg.pinv(meat) @ score)
        assert _physics._score_quadratic(score, meat) == pytest.approx(want, rel=1e-9)
    assert _physics._score_quadratic(np.ones(3), np.zeros((3, 3))) == 0.0
    # a direction below pinv's cut-off (1e-15 of the largest) on which a Cholesky factor still exists
    meat = np.diag([2.0, 3.0, 1e-18])
    assert _physics._score_quadratic(np.ones(3), meat) == pytest.approx(0.5 + 1.0 / 3.0, rel=1e-12)


def test_the_one_column_wald_is_the_row_based_ols_with_hc1():
    # the reference: least squares by numpy.linalg.lstsq on the rows, HC1 sandwich, b²/var
    rng = np.random.default_rng(19)
    for n in (60, 19898):
        x = rng.normal(size=n) * (1.0 + np.arange(n) / n)
        y = 0.05 * x + np.abs(x) * rng.normal(size=n)
        b = np.linalg.lstsq(x[:, None], y, rcond=None)[0][0]
        h = x * (y - b * x)
        var = float(h @ h) * n / (n - 1) / float(x @ x) ** 2
        assert _physics._wald_one(x, y) == pytest.approx(b * b / var, rel=1e-10)
    assert _physics._wald_one(np.zeros(50), rng.normal(size=50)) == 0.0
    assert _physics._wald_one(np.ones(50), np.ones(50)) == 0.0  # an exact fit: no variance left


def _arm_log(n=3000, m=4, seed=5):
    """A slow multi-sine motion and a residual with friction and a posture term on every joint."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    w = 2 * np.pi * np.array([0.2, 0.5, 0.9])
    q = sum(rng.uniform(0.2, 0.6, m) * np.sin(wk * t[:, None] + rng.uniform(0, 6, m)) for wk in w)
    dq = np.gradient(q, t, axis=0)
    ddq = np.gradient(dq, t, axis=0)
    e = 0.3 * np.sign(dq) + 0.2 * np.cos(q) + rng.normal(0.0, 0.1, (n, m))
    return e, q, dq, ddq


def test_the_joints_on_threads_give_the_serial_tests_bit_for_bit(monkeypatch):
    """Kills: a joint's test given another joint's columns or result (the threads' results out of
    order), or a library cache shared by the threads that one of them fills with another's columns."""
    e, q, dq, ddq = _arm_log()
    assert e.shape[0] * e.shape[1] * _physics._TYPICAL_WIDTH >= 1 << 18  # threads are taken here

    def run(threads):
        monkeypatch.setenv("DYNVAL_NUM_THREADS", str(threads))
        return _physics.physics_test(e, e, q, dq, ddq, sample_rate=200.0, band=20.0)

    serial, threaded = run(1), run(2)
    assert [t.selected for t in serial] == [t.selected for t in threaded]
    for a, b in zip(serial, threaded):
        assert a.joint == b.joint
        assert (a.statistic, a.pvalue, a.share, a.term, a.n_eff) == (b.statistic, b.pvalue, b.share, b.term, b.n_eff)
        assert a.shares == b.shares
