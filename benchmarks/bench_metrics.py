"""Speed of dynval's backends on N = 2,000,000 samples × 7 joints (float64), in one run.

Every time is the best of ``--repeat`` calls (default 3) and is printed with its ratio to
*reading both arrays once*, the floor for any one-pass computation, measured two ways: ``np.sum``
of each, and a compiled tight loop that reads every element once (``_core._testing.read_sum``,
the fairer floor for compiled code: ``np.sum``'s pairwise summation is not free).
This is a benchmark, not a test: nothing here asserts a time.

Rows
----
* like with like, the six pooled numbers of the lesson's Python code (RMSE, VAF, fit, R², AIC,
  BIC): the lesson's ``compute_basic_metrics`` (embedded below, with p passed in), the dynval
  reference (``backend="python"``) and the C++ backend (``backend="cpp"``);
* the full set (pooled and per joint, every aggregation, both RMSEs, max, mean, variance,
  criteria): C++ through ``validate(..., max_lag=0)`` and through the ``compute_metrics`` kernel;
  scikit-learn's rmse + r2 + explained_variance + max_error for comparison;
* autocorrelation to 50 lags for 7 joints (C++ blocked direct sums, python reference) against
  statsmodels' ``acf`` (FFT) for one joint;
* cross-correlation of the residual with ``--xc-p`` (70) regressor columns per joint at
  ``--lags`` lags on ``--xc-n`` (200,000) rows: the C++ kernel against reading Y once (compiled),
  its achieved rate (N·m·p·(L+1) multiply-adds), and ``validate`` with that regressor against the
  kernel alone.

Run: ``PYTHONPATH=python python3 benchmarks/bench_metrics.py`` (after building the extension).
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

import dynval
from dynval.report import _regressor_algebra


# --------------------------------------------------------------------------- the lesson (§6)
@dataclass
class ValidationMetrics:
    rmse: float
    vaf: float
    fit_percent: float
    r2: float
    aic: float
    bic: float


def compute_basic_metrics(tau_meas: np.ndarray, tau_pred: np.ndarray, p: int) -> ValidationMetrics:
    """The lesson's Python code, verbatim except that p is passed in instead of fixed at 30."""
    tau_meas = np.asarray(tau_meas)
    tau_pred = np.asarray(tau_pred)
    assert tau_meas.shape == tau_pred.shape
    N, m = tau_meas.shape

    e = tau_meas - tau_pred

    # RMSE over all joints and samples
    rmse = np.sqrt(np.mean(np.sum(e**2, axis=1)))

    # Flatten for convenience
    y = tau_meas.reshape(-1)
    y_hat = tau_pred.reshape(-1)
    e_flat = e.reshape(-1)

    # Means and variance
    y_mean = np.mean(y)
    e_mean = np.mean(e_flat)  # noqa: F841 (kept as in the lesson)
    var_y = np.var(y, ddof=1)
    var_e = np.var(e_flat, ddof=1)

    # VAF (in percent)
    vaf = 100.0 * (1.0 - var_e / var_y)

    # Fit percentage
    num = np.linalg.norm(y - y_hat)
    den = np.linalg.norm(y - y_mean)
    fit_percent = 100.0 * (1.0 - num / den)

    # R^2
    tss = np.sum((y - y_mean) ** 2)
    rss = np.sum((y - y_hat) ** 2)
    r2 = 1.0 - rss / tss

    # AIC and BIC
    sigma2_hat = np.mean(e_flat**2)
    Nm = N * m
    aic = 2.0 * p + Nm * np.log(sigma2_hat)
    bic = p * np.log(Nm) + Nm * np.log(sigma2_hat)

    return ValidationMetrics(rmse, vaf, fit_percent, r2, aic, bic)


# --------------------------------------------------------------------------- dynval
def six_pooled(tau_meas, tau_pred, p, backend):
    """The lesson's six numbers through dynval's public API (rmse as the lesson's code: per_sample)."""
    ic = dynval.criteria(tau_meas, tau_pred, n_params=p, backend=backend)
    return (
        dynval.rmse(tau_meas, tau_pred, convention="per_sample", backend=backend),
        dynval.vaf(tau_meas, tau_pred, backend=backend),
        dynval.fit_percent(tau_meas, tau_pred, backend=backend),
        dynval.r2(tau_meas, tau_pred, backend=backend),
        ic.aic,
        ic.bic,
    )


def sklearn_set(tau_meas, tau_pred):
    from sklearn.metrics import explained_variance_score, max_error, r2_score, root_mean_squared_error

    return (
        root_mean_squared_error(tau_meas, tau_pred, multioutput="raw_values"),
        r2_score(tau_meas, tau_pred, multioutput="raw_values"),
        explained_variance_score(tau_meas, tau_pred, multioutput="raw_values"),
        [max_error(tau_meas[:, j], tau_pred[:, j]) for j in range(tau_meas.shape[1])],
    )


def best_of(f, repeat):
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2_000_000)
    parser.add_argument("--m", type=int, default=7)
    parser.add_argument("--p", type=int, default=30, help="number of model parameters")
    parser.add_argument("--lags", type=int, default=50)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--xc-n", type=int, default=200_000, help="rows of the cross-correlation rows")
    parser.add_argument("--xc-p", type=int, default=70, help="regressor columns per joint (0: skip those rows)")
    args = parser.parse_args(argv)

    rng = np.random.default_rng(2024)
    n, m = args.n, args.m
    # Torques on offsets with a partly autocorrelated residual, like real joint data.
    tau_meas = 10.0 + np.cumsum(rng.normal(size=(n, m)), axis=0) / np.sqrt(n) * 20.0 + np.arange(m)
    tau_pred = tau_meas + 0.2 * rng.normal(size=(n, m)) + 0.05 * np.sin(np.arange(n) / 50.0)[:, None]
    e = tau_meas - tau_pred
    has_cpp = dynval.backends()["cpp"]["available"]

    base = best_of(lambda: (np.sum(tau_meas), np.sum(tau_pred)), args.repeat)
    probe = dynval.kernels._backend.get_backend("cpp")._testing if has_cpp else None
    cbase = best_of(lambda: (probe.read_sum(tau_meas), probe.read_sum(tau_pred)), args.repeat) if probe else None
    rows = []

    def row(group, label, f, repeat=args.repeat):
        t = best_of(f, repeat)
        rows.append((group, label, t, t / base, t / cbase if cbase else float("nan")))

    row("six pooled", "lesson compute_basic_metrics", lambda: compute_basic_metrics(tau_meas, tau_pred, args.p))
    row("six pooled", "dynval python backend", lambda: six_pooled(tau_meas, tau_pred, args.p, "python"), 1)
    if has_cpp:
        row("six pooled", "dynval cpp backend", lambda: six_pooled(tau_meas, tau_pred, args.p, "cpp"))
        core = dynval.kernels._backend.get_backend("cpp")
        row("full set", "cpp validate(..., max_lag=0)",
            lambda: dynval.validate(tau_meas, tau_pred, n_params=args.p, max_lag=0, backend="cpp"))
        row("full set", "cpp compute_metrics kernel",
            lambda: core.compute_metrics(tau_meas, tau_pred, args.p, 1, "pooled"))
    row("full set", "python validate(..., max_lag=0)",
        lambda: dynval.validate(tau_meas, tau_pred, n_params=args.p, max_lag=0, backend="python"), 1)
    try:
        row("full set", "scikit-learn rmse+r2+expl.var+max_error", lambda: sklearn_set(tau_meas, tau_pred))
    except ImportError:
        pass
    if has_cpp:
        row("acf 50 lags", f"cpp autocorrelation, {m} joints",
            lambda: dynval.autocorrelation(e, args.lags, adjusted=False, backend="cpp"))
    row("acf 50 lags", f"python autocorrelation, {m} joints",
        lambda: dynval.autocorrelation(e, args.lags, adjusted=False, backend="python"), 1)
    try:
        from statsmodels.tsa.stattools import acf

        row("acf 50 lags", "statsmodels acf (fft), 1 joint", lambda: acf(e[:, 0], nlags=args.lags, fft=True))
    except ImportError:
        pass

    # Agreement of the six numbers, as a sanity check of what was timed.
    lesson = compute_basic_metrics(tau_meas, tau_pred, args.p)
    print(f"N = {n:,} × m = {m} float64; best of {args.repeat} (python-backend rows: 1 run); "
          f"cpp backend: {'yes' if has_cpp else 'NOT AVAILABLE'}")
    print(f"read once (np.sum of both arrays): {base * 1e3:8.2f} ms")
    if cbase:
        print(f"read once (compiled read_sum of both arrays): {cbase * 1e3:8.2f} ms "
              f"({2 * tau_meas.nbytes / cbase / 1e9:.1f} GB/s)")
    print(f"{'group':<12} {'what':<42} {'ms':>10} {'× np.sum':>10} {'× compiled read':>16}")
    for group, label, t, ratio, cratio in rows:
        print(f"{group:<12} {label:<42} {t * 1e3:10.2f} {ratio:10.2f} {cratio:16.2f}")
    if has_cpp:
        got = six_pooled(tau_meas, tau_pred, args.p, "cpp")
        want = (lesson.rmse, lesson.vaf, lesson.fit_percent, lesson.r2, lesson.aic, lesson.bic)
        diffs = ", ".join(f"{abs(g - w) / max(abs(w), 1e-300):.1e}" for g, w in zip(got, want))
        print(f"relative difference cpp vs lesson (rmse, vaf, fit, r2, aic, bic): {diffs}")
    if has_cpp and args.xc_p:
        cross_correlation_rows(tau_meas, tau_pred, args, probe)


def cross_correlation_rows(tau_meas, tau_pred, args, probe):
    """The cross-correlation kernel on (N, m, p) regressors: × reading Y once, rate, and validate."""
    core = dynval.kernels._backend.get_backend("cpp")
    n, m, p, lags = min(args.xc_n, tau_meas.shape[0]), tau_meas.shape[1], args.xc_p, args.lags
    rng = np.random.default_rng(7)
    tau, pred = tau_meas[:n], tau_pred[:n]
    y = rng.normal(size=(n, m, p)) + tau[:, :, None] * rng.normal(size=(1, m, p))
    e = tau - pred
    y2 = y.reshape(n, m * p)
    starts = np.zeros(1, dtype=np.int64)
    read_y = best_of(lambda: probe.read_sum(y2), args.repeat)
    kernel = best_of(lambda: core.cross_correlation(e, y2, p, lags, True, starts), args.repeat)
    full = best_of(lambda: dynval.validate(tau, pred, n_params=args.p, regressor=y, max_lag=lags, backend="cpp"), 1)
    # validate's one pass of Gram matrices, with the BLAS's own threads and with the one thread
    # validate limits it to (dynval/kernels/_blas.py): on a busy machine the first can be 100× slower
    gram_default = best_of(lambda: _regressor_algebra.JointGrams(y), 1)
    with threadpool_limits(limits=1, user_api="blas"):
        gram_one = best_of(lambda: _regressor_algebra.JointGrams(y), 1)
    fma = n * m * p * (lags + 1)
    print(f"cross-correlation: N = {n:,} × m = {m}, p = {p} columns per joint, lags 0..{lags} "
          f"(Y is {y.nbytes / 1e6:.0f} MB; {fma / 1e9:.2f} G multiply-adds)")
    print(f"  read Y once (compiled read_sum): {read_y * 1e3:10.2f} ms ({y.nbytes / read_y / 1e9:.1f} GB/s)")
    print(f"  cpp cross_correlation kernel: {kernel * 1e3:10.2f} ms = {kernel / read_y:6.1f} × read Y once; "
          f"{fma / kernel / 1e9:.2f} G multiply-adds/s = {2 * fma / kernel / 1e9:.2f} GFLOP/s")
    print(f"  cpp validate(..., regressor=Y, max_lag={lags}): {full * 1e3:.2f} ms = {full / kernel:6.2f} × the kernel "
          f"alone (1 run)")
    print(f"  each joint's Gram matrix (validate's pass): {gram_default * 1e3:.2f} ms with the BLAS's threads, "
          f"{gram_one * 1e3:.2f} ms with one (1 run each; load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
