"""Interactive use on a real log: ``compare``, repeated ``validate`` and ``import dynval``, in one run.

Rows printed (seconds; each with its target and PASS or MISS):

* ``compare`` of three candidates sharing one regressor, beside a read of its inputs (``np.sum``
  of the measured torques, the three predictions and the regressor, best of 10): target ≤ 1 s and
  ≤ 100 × the read;
* ``validate`` with the regressor against the cross-correlation kernel alone (the compiled
  ``cross_correlation`` of the same residual and regressor at the lags ``validate`` chose): the
  plain array, and a :func:`dynval.prepare_regressor` result already used once (the repeated
  call): target ≤ 2 × the kernel;
* ``import dynval`` in fresh interpreters (the import statement alone, timed inside the process;
  median of ``--imports`` runs): target ≤ 0.3 s. ``import numpy`` alone is printed beside it.

Data: the KUKA LWR4+ measurements of FloBaRoID as dynval ships them (``dynval.datasets``), or a
FloBaRoID directory given with ``--data``, when pinocchio is there: the three runs and run 1 again
end to end, 20,108 × 7 samples at 200 Hz, and the URDF's 91-column joint-torque regressor (102 MB);
the candidates are the CAD URDF's and the identified URDF's torques and a least squares fit of all
91 columns. Otherwise a simulated equivalent of the same shape (smooth columns, a joint's columns
of the links before it zero, as on a serial arm).
Run: ``python3 benchmarks/bench_interactive.py [--data DIR --repeat 3 --imports 5]``.
This is a benchmark, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import dynval
from dynval.kernels._backend import get_backend

ROOT = Path(__file__).resolve().parents[1]
RATE = 200.0


def kuka_log(data: Path | None):
    """The three runs and run 1 again end to end: torques, regressor and the three candidates.

    ``data`` is a FloBaRoID KUKA directory (``data/measurements_K.npz``, ``model/*.urdf``); None takes
    the same runs and URDFs as dynval ships them (``dynval.datasets.load_kuka_lwr4``).
    """
    from dynval.robots import URDFModel

    if data is None:
        from dynval.datasets import load_kuka_lwr4

        shipped = [load_kuka_lwr4(k) for k in (1, 2, 3, 1)]
        q, dq, ddq, tau = (np.concatenate([getattr(r, key) for r in shipped]) for key in ("q", "dq", "ddq", "tau"))
        cad, identified = URDFModel(shipped[0].urdf), URDFModel(shipped[0].urdf_identified)
        where = "the KUKA LWR4+ runs shipped with dynval (dynval.datasets)"
    else:
        runs = [np.load(data / "data" / f"measurements_{k}.npz") for k in (1, 2, 3, 1)]
        q, dq, ddq, tau = (np.concatenate([r[key] for r in runs])
                           for key in ("positions", "velocities", "accelerations", "torques"))
        cad = URDFModel(str(data / "model" / "kuka_lwr4.urdf"))
        identified = URDFModel(str(data / "model" / "kuka_lwr4_identified.urdf"))
        where = f"KUKA LWR4+ log from {data}"
    y = np.ascontiguousarray(cad.regressor(q, dq, ddq))
    preds = {"CAD URDF": (cad.predict(q, dq, ddq), 0), "identified URDF": (identified.predict(q, dq, ddq), 84)}
    return where, tau, y, preds


def simulated_log(n=20_108, m=7, p=91, seed=0):
    """Smooth regressor columns of a serial arm's shape (joint j's columns of links before j zero)
    and torques from made-up parameters with coloured noise; two imperfect candidates."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None] / RATE
    y = np.zeros((n, m, p))
    per_link = p // m
    for j in range(m):
        live = slice(j * per_link, p)  # the columns of link j and beyond act on joint j
        width = p - j * per_link
        freq = rng.uniform(0.05, 2.0, width)
        phase = rng.uniform(0, 2 * np.pi, width)
        y[:, j, live] = np.sin(2 * np.pi * freq * t + phase) * rng.uniform(0.5, 5.0, width)
    pi = rng.normal(size=p)
    noise = np.cumsum(rng.normal(0.0, 0.02, (n, m)), axis=0) * 0.05 + rng.normal(0.0, 0.1, (n, m))
    tau = y @ pi + noise
    preds = {"CAD URDF": (y @ (pi * 1.1), 0), "identified URDF": (y @ (pi + rng.normal(0, 0.01, p)), 84)}
    return "simulated log (pinocchio is not installed)", tau, y, preds


def load(data: Path | None):
    """The KUKA log (``--data``, else the shipped runs) when pinocchio is there, else the simulated one."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return simulated_log()
    if data is not None and not (data / "data").is_dir():
        raise SystemExit(f"--data {data}: not a FloBaRoID KUKA directory (no data/ in it); leave --data out "
                         "to use the runs shipped with dynval")
    return kuka_log(data)


def best_of(fn, repeat, clock=time.perf_counter):
    """The least time over ``repeat`` calls of fn (seconds) by ``clock`` (wall clock by default;
    ``time.process_time``: this process's CPU time)."""
    times = []
    for _ in range(repeat):
        start = clock()
        fn()
        times.append(clock() - start)
    return min(times)


def verdict(value, target, unit):
    return f"target ≤ {target:g}{unit}: {'PASS' if value <= target else 'MISS'}"


def compare_rows(tau, y, cands, repeat):
    arrays = [tau, y] + [p for p, _ in cands.values()]
    read = best_of(lambda: [np.sum(a) for a in arrays], 10)
    seconds = best_of(lambda: dynval.compare(tau, cands, regressor=y, sample_rate=RATE), repeat)
    mb = sum(a.nbytes for a in arrays) / 1e6
    print(f"{'read of the inputs (np.sum of each)':<52} {read * 1e3:>8.2f} ms  {mb:.0f} MB")
    print(f"{'compare, 3 candidates, shared regressor':<52} {seconds:>8.3f} s   {verdict(seconds, 1.0, ' s')}")
    print(f"{'  compare / read':<52} {seconds / read:>8.0f} ×   {verdict(seconds / read, 100, ' ×')}")


def validate_rows(tau, y, pred, repeat):
    report = dynval.validate(tau, pred, n_params=91, regressor=y, sample_rate=RATE)
    lag = int(report.cross_correlation["max_lag"])
    n, m, p = y.shape
    kernel = get_backend("cpp")
    e = np.ascontiguousarray(tau - pred)
    y2 = y.reshape(n, m * p)
    starts = np.zeros(1, dtype=np.int64)
    alone = best_of(lambda: kernel.cross_correlation(e, y2, p, lag, False, starts), repeat)
    plain = best_of(lambda: dynval.validate(tau, pred, n_params=91, regressor=y, sample_rate=RATE), repeat)
    prepared = dynval.prepare_regressor(y)
    dynval.validate(tau, pred, n_params=91, regressor=prepared, sample_rate=RATE)  # the first call keeps its work
    again = best_of(lambda: dynval.validate(tau, 0.99 * pred, n_params=91, regressor=prepared, sample_rate=RATE),
                    repeat)
    print(f"{f'cross_correlation kernel alone ({lag} lags)':<52} {alone:>8.3f} s")
    print(f"{'validate, regressor as an array':<52} {plain:>8.3f} s   {plain / alone:>5.1f} ×   "
          f"{verdict(plain / alone, 2, ' ×')}")
    print(f"{'validate, prepared regressor (a repeated call)':<52} {again:>8.3f} s   {again / alone:>5.1f} ×   "
          f"{verdict(again / alone, 2, ' ×')}")


def import_seconds(module: str, runs: int) -> list[float]:
    code = f"import time; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python"))
    out = []
    for _ in range(runs):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
        out.append(float(done.stdout.strip()))
    return out


def import_rows(runs):
    numpy_s = statistics.median(import_seconds("numpy", runs))
    dyn = import_seconds("dynval", runs)
    median = statistics.median(dyn)
    print(f"{'import numpy (median of ' + str(runs) + ')':<52} {numpy_s:>8.3f} s")
    print(f"{'import dynval (median of ' + str(runs) + ')':<52} {median:>8.3f} s   {verdict(median, 0.3, ' s')}   "
          f"(min {min(dyn):.3f}, max {max(dyn):.3f})")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=None,
                        help="a FloBaRoID KUKA directory (default: the runs shipped with dynval)")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many calls of compare and validate")
    parser.add_argument("--imports", type=int, default=5, help="fresh interpreters timing import dynval")
    args = parser.parse_args(argv)
    what, tau, y, preds = load(args.data)
    n, m, p = y.shape
    stacked = y.reshape(n * m, p)
    fit = (stacked @ np.linalg.lstsq(stacked, tau.reshape(-1), rcond=None)[0]).reshape(n, m)
    cands = dict(preds, **{"least squares": (fit, p)})
    print(f"{what}: N = {n:,} × m = {m}, regressor p = {p} ({y.nbytes / 1e6:.0f} MB), {RATE:g} Hz")
    compare_rows(tau, y, cands, args.repeat)
    validate_rows(tau, y, fit, args.repeat)
    import_rows(args.imports)


if __name__ == "__main__":
    main()
