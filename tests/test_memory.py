"""Memory bounds of validate with a regressor (allocations traced, not timed).

``tracemalloc`` sees numpy's buffers, so the bound is deterministic: the extra memory validate
allocates while it runs, over the inputs it was given (at most 1.5 times their size at this N, where
the fixed blocks weigh more; about 0.95 at N = 2,000,000). Before the blockwise passes the
python backend needed about 5.7 times the input on top of it (an FFT of every regressor column at
once, a centred copy of the regressor per joint, two SVDs of copies of the stacked regressor);
benchmarks/bench_memory.py measures the peak RSS of the full-size case.
"""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest

import dynval
from dynval.report import _regressor_algebra, _sections
from dynval.statistics import _stats


def _inputs(n, m=7, p=8):
    rng = np.random.default_rng(3)
    regressor = rng.standard_normal((n, m, p))
    pred = regressor @ rng.standard_normal(p)
    return pred + 0.1 * rng.standard_normal((n, m)), pred, regressor


def test_validate_with_a_regressor_allocates_at_most_the_input(backend):
    # ``backend``: conftest's fixture, every available backend
    # a first small call imports the modules validate reads lazily: their import is not an allocation
    # that grows with the input (run alone in a fresh process it was a tenth of the input's size)
    dynval.validate(*_inputs(2_000)[:2], n_params=8, regressor=_inputs(2_000)[2], backend=backend, sample_rate=100.0)
    tau, pred, regressor = _inputs(120_000)
    size = tau.nbytes + pred.nbytes + regressor.nbytes
    tracemalloc.start()
    try:
        dynval.validate(tau, pred, n_params=8, regressor=regressor, backend=backend, sample_rate=100.0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= 1.5 * size, f"validate allocated {peak / size:.2f} times its input"


def test_batched_autocorrelations_do_not_depend_on_the_batch(monkeypatch):
    x = np.random.default_rng(4).standard_normal((3000, 11)) + np.arange(11)
    starts = np.array([0, 1000, 2500])
    whole = _stats.acf_fft(x, starts, 40)
    monkeypatch.setattr(_stats, "_FFT_BATCH_BYTES", 48 * 3000 * 2)  # two columns per batch
    # the transforms of one column do not depend on its neighbours, up to the FFT's rounding
    np.testing.assert_allclose(_stats.acf_fft(x, starts, 40), whole, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("centre", [True, False])
def test_autocorrelations_of_live_columns_in_runs_are_those_of_the_columns_side_by_side(monkeypatch, centre):
    # a regressor's live columns come in runs (one per joint); batches of three cross them
    rng = np.random.default_rng(9)
    live = np.array([1, 2, 3, 6, 7, 10, 11])
    x = np.zeros((2000, 13))
    x[:, live] = rng.standard_normal((2000, live.size)).cumsum(axis=0) + np.arange(live.size)
    x[:, 7] = 2.5  # live but constant: nan once centred
    starts = np.array([0, 700])
    monkeypatch.setattr(_stats, "_FFT_BATCH_BYTES", 48 * 2000 * 3)
    for lags in (40, 5):  # by transforms, and by direct sums
        got = _stats.acf_fft(x, starts, lags, live=live, centre=centre)
        # the same columns centred on the same means, in the same batches: the same numbers
        want = _stats.acf_fft(x[:, live] - x.mean(axis=0)[live] if centre else x[:, live], starts, lags, centre=False)
        assert got[:, live].tobytes() == want.tobytes()
        assert np.isnan(np.delete(got, live, axis=1)).all()
        assert np.isnan(got[:, 7]).all() == centre


def test_condition_numbers_from_the_blockwise_r_factor():
    rng = np.random.default_rng(5)
    x = rng.standard_normal((5000, 6)) * np.array([1.0, 10.0, 1e-3, 1e4, 1.0, 3.0])
    x[:, 5] = x[:, 0] + 1e-6 * x[:, 5]  # nearly dependent: a large condition number
    cols = np.arange(6)
    r = _regressor_algebra._r_factor(x, cols, block=700)
    np.testing.assert_allclose(np.linalg.svd(r, compute_uv=False), np.linalg.svd(x, compute_uv=False),
                               rtol=1e-9)
    norms = np.linalg.norm(x, axis=0)
    np.testing.assert_allclose(np.linalg.svd(r / norms, compute_uv=False),
                               np.linalg.svd(x / norms, compute_uv=False), rtol=1e-9)


def test_singular_values_leave_the_gram_matrix_when_it_loses_digits():
    rng = np.random.default_rng(6)
    x = rng.standard_normal((20_000, 5))
    x[:, 4] = x[:, 3] + 1e-9 * x[:, 4]  # condition number about 1e9: the Gram matrix keeps none of σ_min
    cols = np.arange(5)
    norms = np.linalg.norm(x, axis=0)
    raw, scaled = _regressor_algebra._singular_values(x, cols, norms)
    np.testing.assert_allclose(raw, np.linalg.svd(x, compute_uv=False), rtol=1e-6)
    np.testing.assert_allclose(scaled, np.linalg.svd(x / norms, compute_uv=False), rtol=1e-6)
    # and on a regressor with condition number 1e5 the one-pass route is within eps·cond² ≈ 2e-6
    y = rng.standard_normal((20_000, 5)) * np.array([1.0, 1e3, 1e-2, 5.0, 1.0])
    raw, scaled = _regressor_algebra._singular_values(y, cols, np.linalg.norm(y, axis=0))
    np.testing.assert_allclose(raw, np.linalg.svd(y, compute_uv=False), rtol=2e-6)


def test_least_squares_equals_lstsq_well_and_ill_conditioned():
    rng = np.random.default_rng(7)
    y = rng.standard_normal((5_000, 6)) * np.array([1.0, 1e4, 1e-3, 1.0, 2.0, 1.0])
    b = y @ rng.standard_normal(6) + rng.standard_normal(5_000)
    for design in (y, np.column_stack([y, y[:, 0] + 1e-10 * y[:, 1]])):
        want = b - design @ np.linalg.lstsq(design, b, rcond=None)[0]
        got = b - design @ _regressor_algebra._least_squares(design, b)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.linalg.norm(b))


def _regressor_with_zero_columns(n=4000, m=3, p=5, seed=8):
    rng = np.random.default_rng(seed)
    reg3 = rng.standard_normal((n, m, p)) * np.array([1.0, 30.0, 1e-3, 2.0, 1.0])
    reg3[:, 1, 0] = 0.0  # a link's parameter that does not act on an earlier joint
    reg3[:, :, 4] = 0.0  # a column no joint excites
    e = 0.3 * rng.standard_normal((n, m)) + reg3[:, :, 1] * 1e-3
    return e, reg3


def test_joint_grams_are_each_joints_gram_and_their_sum_the_stacked_one():
    _, reg3 = _regressor_with_zero_columns()
    grams = _regressor_algebra.JointGrams(reg3, block=333)  # blocks that do not divide N
    for j in range(reg3.shape[1]):
        np.testing.assert_allclose(grams.gram[j], reg3[:, j, :].T @ reg3[:, j, :], rtol=1e-13, atol=1e-9)
    stacked = reg3.reshape(-1, reg3.shape[2])
    np.testing.assert_allclose(grams.stacked(), stacked.T @ stacked, rtol=1e-13, atol=1e-9)
    assert grams.usable  # exactly zero columns do not force the scaled routes


@pytest.mark.parametrize("tiny", [1e-170, 2.0**-1040])
def test_joint_grams_are_not_used_where_squares_underflow(tiny):
    _, reg3 = _regressor_with_zero_columns()
    reg3[:, 2, 0] = tiny  # squares underflow to a zero diagonal: not a zero column
    assert not _regressor_algebra.JointGrams(reg3).usable
    reg3[:, 2, 0] = 1e150  # sums of squares beyond 1e280
    assert not _regressor_algebra.JointGrams(reg3).usable


@pytest.mark.parametrize("scale", [1.0, 1e-170, 1e140])
def test_projection_and_excitation_are_the_same_with_the_shared_gram_pass(scale):
    e, reg3 = _regressor_with_zero_columns()
    e, reg3 = e * scale, reg3 * scale
    grams = _regressor_algebra.JointGrams(reg3)
    shared = _regressor_algebra._project_out(e, reg3, grams)
    alone = _regressor_algebra._project_out(e, reg3)  # the exactly scaled route, joint by joint
    np.testing.assert_allclose(shared, alone, rtol=0, atol=1e-12 * np.abs(e).max())
    # and the projection is one: orthogonal to every column of its joint
    for j in range(reg3.shape[1]):
        y = reg3[:, j, :] / scale
        assert np.max(np.abs(y.T @ (shared[:, j] / scale))) < 1e-9 * np.linalg.norm(y) * np.linalg.norm(e[:, j] / scale)
    a = _sections.design(reg3, None, None, None, 0.1, grams)["excitation"]
    b = _sections.design(reg3, None, None, None, 0.1)["excitation"]
    assert a["unexcited"] == b["unexcited"] == [4]
    np.testing.assert_allclose(a["column_norms"], b["column_norms"], rtol=1e-13)
    np.testing.assert_allclose([a["condition_raw"], a["condition_scaled"]],
                               [b["condition_raw"], b["condition_scaled"]], rtol=1e-6)  # eps·cond², cond 3e4


def _numpy_scipy_blas(info):
    """The BLAS libraries numpy and scipy use, out of threadpoolctl's list of every loaded one.

    Other packages bring their own (cvxpy's SCS loads an OpenBLAS of its own, built single-threaded,
    when cvxpy is imported by another test); the limits are about numpy's and scipy's linear algebra.
    A wheel keeps its library inside its package (``numpy.libs/``, ``scipy.libs/``, or the package
    itself); a library outside every site-packages directory is a system BLAS, which numpy and scipy
    are then linked against. Never empty: the check cannot pass by looking at nothing.
    """
    import os
    import site

    import scipy

    roots = [os.path.realpath(d) for d in site.getsitepackages() + [site.getusersitepackages()]]
    own = {os.path.basename(os.path.dirname(os.path.realpath(mod.__file__))) for mod in (np, scipy)}

    def belongs(path):
        path = os.path.realpath(path)
        for root in roots:
            if path.startswith(root + os.sep):
                top = path[len(root) + 1:].split(os.sep)[0]
                return top.split(".")[0] in own or top.split("-")[0] in own
        return True

    out = [lib for lib in info if lib["user_api"] == "blas" and belongs(lib["filepath"])]
    assert out, f"no BLAS of numpy or scipy among {[lib['filepath'] for lib in info]}"
    return out


def test_the_blas_filter_keeps_numpy_and_scipy_and_drops_another_packages_own():
    import os
    import site

    root = site.getsitepackages()[0]
    info = [{"user_api": "blas", "filepath": os.path.join(root, "numpy.libs", "libopenblas.so"), "num_threads": 2},
            {"user_api": "blas", "filepath": os.path.join(root, "scs.libs", "libopenblas.so"), "num_threads": 1},
            {"user_api": "blas", "filepath": os.path.join(root, "scipy", "linalg", "libblas.so"), "num_threads": 2},
            {"user_api": "openmp", "filepath": os.path.join(root, "numpy.libs", "libgomp.so"), "num_threads": 2},
            {"user_api": "blas", "filepath": "/usr/lib/x86_64-linux-gnu/libopenblas.so.0", "num_threads": 2}]
    kept = [os.path.relpath(lib["filepath"], root) if lib["filepath"].startswith(root) else lib["filepath"]
            for lib in _numpy_scipy_blas(info)]
    assert kept == [os.path.join("numpy.libs", "libopenblas.so"), os.path.join("scipy", "linalg", "libblas.so"),
                    "/usr/lib/x86_64-linux-gnu/libopenblas.so.0"]


def test_validate_and_identify_run_their_linear_algebra_on_one_blas_thread(monkeypatch):
    # A multi-threaded BLAS spinning at its barriers on a busy machine made one Gram matrix 100×
    # slower (benchmarks/README.md); the caller's own limit comes back afterwards.
    threadpoolctl = pytest.importorskip("threadpoolctl")
    identify_module = importlib.import_module("dynval.identify")

    def blas_threads():
        return {lib["num_threads"] for lib in _numpy_scipy_blas(threadpoolctl.threadpool_info())}

    seen = {}

    def spy(name, func):
        def recorded(*args, **kwargs):
            seen[name] = blas_threads()
            return func(*args, **kwargs)
        return recorded

    monkeypatch.setattr(_sections, "design", spy("validate", _sections.design))
    monkeypatch.setattr(identify_module, "_solve", spy("identify", identify_module._solve))
    tau, pred, regressor = _inputs(600, m=2, p=3)
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        dynval.validate(tau, pred, n_params=3, regressor=regressor)
        dynval.identify(regressor, tau)
        assert blas_threads() == {2}
    assert seen == {"validate": {1}, "identify": {1}}


def test_the_transforms_use_the_cores_threads_only_on_large_work(monkeypatch):
    # acf_fft's transforms run on DYNVAL_NUM_THREADS threads (the core's setting) when a batch holds
    # millions of values, and on one below (a thread costs more than a small transform).
    from dynval.kernels import _threads

    seen = []
    real = _stats.scipy.fft.rfft

    def spy(*args, **kwargs):
        seen.append(kwargs.get("workers"))
        return real(*args, **kwargs)

    monkeypatch.setattr(_stats.scipy.fft, "rfft", spy)
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "3")
    small = np.random.default_rng(7).standard_normal((2000, 4))
    _stats.acf_fft(small, np.array([0]), 40)
    large = np.random.default_rng(8).standard_normal((_threads.MIN_PARALLEL_VALUES // 8 + 1, 8))  # one batch
    _stats.acf_fft(large, np.array([0]), 40)
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "1")
    _stats.acf_fft(large, np.array([0]), 40)
    assert seen == [1, 3, 1]


@pytest.mark.parametrize("n", [600, 3])
def test_the_stacked_r_comes_from_each_joints_nonzero_columns(n):
    # R of the stacked regressor·2^-k from each joint's R (of its nonzero columns, scaled by its own
    # powers of two), stacked and factored again: the stacked matrix's singular values, with zero
    # columns on some joints, a joint all zero, and (n = 3) fewer rows than a joint's columns.
    rng = np.random.default_rng(9)
    reg3 = rng.standard_normal((n, 4, 6)) * np.array([1.0, 1e3, 1e-3, 1.0, 5.0, 1.0])
    reg3[:, 1, :2] = 0.0
    reg3[:, 3, :] = 0.0
    reg3[:, 2, 5] = 0.0
    k = np.array([3, -2, 10, 0, 1, 0])
    r = _regressor_algebra._stacked_r(reg3, k)
    stacked = np.ldexp(reg3.reshape(-1, 6), -k)
    assert r.shape == (min(stacked.shape[0], 6), 6)
    expected = np.linalg.svd(stacked, compute_uv=False)
    # a QR is backward stable: each singular value to about eps·σ_max, not relative to itself
    np.testing.assert_allclose(np.linalg.svd(r, compute_uv=False), expected, rtol=1e-12, atol=1e-14 * expected[0])
    np.testing.assert_allclose(r.T @ r, stacked.T @ stacked, rtol=1e-12, atol=1e-13 * expected[0] ** 2)
