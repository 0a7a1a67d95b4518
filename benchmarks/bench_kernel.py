"""The C++ lag kernels against this machine's FMA peak per core, in one run.

Every time is the best of ``--repeat`` calls on one thread (``DYNVAL_NUM_THREADS=1``: the figures
are per core), measured as the CPU time of the process (``time.process_time``: on a shared
machine the wall time also counts the time spent waiting for a core; both are printed, the rates
use the CPU time), and is printed with what the kernel achieves against a floor:

* the FMA peak per core: ``_core._testing.fma_peak``, 12 independent chains of 4-double
  multiply-adds compiled like the lag kernels (the same x86-64-v3 clone, or ``-march=native`` in a
  ``DYNVAL_NATIVE`` build), in GFLOP/s (one multiply-add = 2 flops);
* each kernel's rate, 2·(multiply-adds)/time, as a percentage of that peak (target >= 25 %):
  the cross-correlation of the residual with ``--p`` regressor columns per joint
  (N·m·p·(L+1) multiply-adds), the narrow lagged sums (the residual's autocorrelation, N·m·(L+1))
  and the wide lagged sums (the regressor columns' autocorrelations, N·m·p·(L+1)); each public call
  whole, its fixed part (moments, centring) included, and that fixed part alone (``max_lag=0``);
* the cross-correlation against one compiled read of Y (``_core._testing.read_sum``);
* ``validate`` with the regressor against the cross-correlation kernel alone (target <= 2×): with
  the regressor as an array (one call: everything on the regressor is computed), and a repeated
  call on a :func:`dynval.prepare_regressor` result (what a caller validating several candidates
  on one run, or ``compare``, pays per candidate); with ``--profile`` the functions each spends its
  time in (cProfile, by own time).

This is a benchmark, not a test: nothing here asserts a time.

Run: ``PYTHONPATH=python python3 benchmarks/bench_kernel.py [--n 200000 --m 7 --p 70 --lags 50]``
(after building the extension; ``--peak`` gives the peak in GFLOP/s for a module without the probe).
"""

from __future__ import annotations

import argparse
import cProfile
import functools
import io
import os
import pstats
import time

import numpy as np

import dynval

TARGET_PEAK_SHARE = 0.25
TARGET_VALIDATE_RATIO = 2.0


def best_of(f, repeat):
    """(CPU time of the process, wall time), each the best of `repeat` calls."""
    cpu = wall = float("inf")
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        f()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    return cpu, wall


def measured_peak(testing, repeat, iterations):
    """GFLOP/s of the FMA probe on the process CPU time (best of `repeat`) and its instruction set."""
    best, isa = 0.0, "?"
    for _ in range(repeat):
        c0 = time.process_time()
        flops, _, _, isa = testing.fma_peak(iterations)
        best = max(best, flops / (time.process_time() - c0) / 1e9)
    return best, isa


def rate_line(label, times, fma, peak):
    cpu, wall = times
    gflops = 2.0 * fma / cpu / 1e9
    share = gflops / peak
    verdict = "PASS" if share >= TARGET_PEAK_SHARE else "MISS"
    return (f"  {label:<42} {cpu * 1e3:8.1f} ms ({wall * 1e3:8.1f} wall)  {gflops:6.2f} GFLOP/s = "
            f"{100 * share:5.1f} % of peak [{verdict}, target >= {100 * TARGET_PEAK_SHARE:.0f} %]")


def minus(a, b):
    return a[0] - b[0], a[1] - b[1]


def profile_validate(call, top):
    profiler = cProfile.Profile()
    profiler.enable()
    call()
    profiler.disable()
    out = io.StringIO()
    pstats.Stats(profiler, stream=out).sort_stats("tottime").print_stats(top)
    return out.getvalue()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200_000, help="rows of the residual and the regressor")
    parser.add_argument("--m", type=int, default=7, help="joints")
    parser.add_argument("--p", type=int, default=70, help="regressor columns per joint")
    parser.add_argument("--lags", type=int, default=50, help="largest lag")
    parser.add_argument("--narrow-n", type=int, default=2_000_000, help="rows of the narrow lagged sums")
    parser.add_argument("--repeat", type=int, default=3, help="calls per kernel; the best is kept")
    parser.add_argument("--peak-iterations", type=int, default=100_000_000,
                        help="steps of the FMA probe (12 chains × 4 doubles each)")
    parser.add_argument("--peak", type=float, default=None, help="FMA peak in GFLOP/s instead of measuring it")
    parser.add_argument("--skip-validate", action="store_true", help="leave out the validate row")
    parser.add_argument("--profile", type=int, default=0, metavar="K",
                        help="print validate's K most expensive functions (cProfile, own time)")
    args = parser.parse_args(argv)
    os.environ["DYNVAL_NUM_THREADS"] = "1"  # read by the core at each call: per-core figures

    if not dynval.backends()["cpp"]["available"]:
        raise SystemExit("the cpp backend is not available: build the extension first")
    core = dynval.kernels._backend.get_backend("cpp")
    testing = core._testing
    if args.peak is not None:
        peak, isa = args.peak, "given with --peak"
    elif hasattr(testing, "fma_peak"):
        peak, isa = measured_peak(testing, args.repeat, args.peak_iterations)
    else:
        raise SystemExit("this module has no _testing.fma_peak: give the peak with --peak GFLOPS")

    n, m, p, lags = args.n, args.m, args.p, args.lags
    rng = np.random.default_rng(7)
    tau = 10.0 + np.cumsum(rng.normal(size=(n, m)), axis=0) / np.sqrt(n) * 20.0 + np.arange(m)
    pred = tau + 0.2 * rng.normal(size=(n, m)) + 0.05 * np.sin(np.arange(n) / 50.0)[:, None]
    e = tau - pred
    y = rng.normal(size=(n, m, p)) + tau[:, :, None] * rng.normal(size=(1, m, p))
    y2 = y.reshape(n, m * p)
    starts = np.zeros(1, dtype=np.int64)
    narrow = rng.normal(size=(args.narrow_n, m)).cumsum(axis=0) * 0.01 + rng.normal(size=(args.narrow_n, m))

    read_y = best_of(lambda: testing.read_sum(y2), args.repeat)
    xc = best_of(lambda: core.cross_correlation(e, y2, p, lags, True, starts), args.repeat)
    xc0 = best_of(lambda: core.cross_correlation(e, y2, p, 0, True, starts), args.repeat)
    nw = best_of(lambda: core.autocorrelation(narrow, lags, False, starts), args.repeat)
    nw0 = best_of(lambda: core.autocorrelation(narrow, 0, False, starts), args.repeat)
    wd = best_of(lambda: core.autocorrelation(y2, lags, False, starts), args.repeat)
    wd0 = best_of(lambda: core.autocorrelation(y2, 0, False, starts), args.repeat)

    cross_fma = n * m * p * (lags + 1)
    narrow_fma = args.narrow_n * m * (lags + 1)
    print(f"one thread; best of {args.repeat}; CPU time (wall in brackets); "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"FMA peak per core: {peak:.1f} GFLOP/s ({isa})")
    print(f"cross-correlation: N = {n:,} × m = {m}, p = {p}, lags 0..{lags} ({cross_fma / 1e9:.2f} G multiply-adds; "
          f"Y is {y.nbytes / 1e6:.0f} MB)")
    print(rate_line("cpp cross_correlation (whole call)", xc, cross_fma, peak))
    print(rate_line("  its lag products (call − max_lag=0 call)", minus(xc, xc0), cross_fma, peak))
    print(f"  {'  max_lag=0 call (moments of Y, centring)':<42} {xc0[0] * 1e3:8.1f} ms ({xc0[1] * 1e3:8.1f} wall)")
    print(f"  {'read Y once (compiled)':<42} {read_y[0] * 1e3:8.1f} ms ({read_y[1] * 1e3:8.1f} wall)  "
          f"{y.nbytes / read_y[0] / 1e9:.1f} GB/s; the call = {xc[0] / read_y[0]:.1f} × the read")
    print(f"narrow lagged sums (autocorrelation): N = {args.narrow_n:,} × {m}, lags 0..{lags} "
          f"({narrow_fma / 1e9:.2f} G multiply-adds)")
    print(rate_line("cpp autocorrelation (whole call)", nw, narrow_fma, peak))
    print(rate_line("  its lag products (call − max_lag=0 call)", minus(nw, nw0), narrow_fma, peak))
    print(f"wide lagged sums (the regressor's autocorrelations): N = {n:,} × {m * p}, lags 0..{lags} "
          f"({cross_fma / 1e9:.2f} G multiply-adds)")
    print(rate_line("cpp autocorrelation (whole call)", wd, cross_fma, peak))
    print(rate_line("  its lag products (call − max_lag=0 call)", minus(wd, wd0), cross_fma, peak))

    if not args.skip_validate:
        def call():
            return dynval.validate(tau, pred, n_params=30, regressor=y, max_lag=lags, backend="cpp")

        full = best_of(call, 2)  # the first call also imports what dynval loads on first use
        ratio = full[0] / xc[0]
        verdict = "PASS" if ratio <= TARGET_VALIDATE_RATIO else "MISS"
        print(f"cpp validate(..., regressor=Y, max_lag={lags}) (best of 2): {full[0] * 1e3:.1f} ms "
              f"({full[1] * 1e3:.1f} wall) = {ratio:.2f} × the cross-correlation kernel alone "
              f"[{verdict}, target <= {TARGET_VALIDATE_RATIO:.0f} ×]")
        prepared = dynval.prepare_regressor(y)
        call_prepared = functools.partial(dynval.validate, tau, pred, n_params=30, regressor=prepared,
                                          max_lag=lags, backend="cpp")
        call_prepared()  # the first call keeps the regressor's own work
        other = 0.99 * pred + 0.01 * tau  # another candidate on the same regressor
        again = best_of(lambda: dynval.validate(tau, other, n_params=30, regressor=prepared, max_lag=lags,
                                                backend="cpp"), args.repeat)
        ratio = again[0] / xc[0]
        verdict = "PASS" if ratio <= TARGET_VALIDATE_RATIO else "MISS"
        print(f"cpp validate(..., regressor=prepare_regressor(Y)), a repeated call (best of {args.repeat}): "
              f"{again[0] * 1e3:.1f} ms ({again[1] * 1e3:.1f} wall) = {ratio:.2f} × the kernel alone "
              f"[{verdict}, target <= {TARGET_VALIDATE_RATIO:.0f} ×]")
        if args.profile:
            print(profile_validate(call, args.profile))
            print(profile_validate(call_prepared, args.profile))


if __name__ == "__main__":
    main()
