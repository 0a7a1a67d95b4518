"""Streaming and distributed validation against in-memory ``validate``, on the same data, in one run.

Rows printed (times in seconds; ratios as stated):

* ``validate`` in memory with the default backend (cpp when built) and with the python backend;
* the same quantities as a streamed report holds, from the public functions on the whole arrays
  (``validate(..., max_lag=0)``, autocorrelation, Ljung–Box, zero-mean test, cross-correlation):
  the like-for-like in-memory cost;
* the streaming accumulator (``dynval.stream``) on each backend (``cpp``: the C++ ``stream_state``;
  ``python``: numpy) fed ``--chunk`` rows at a time, and its ratio to each in-memory run;
* the C++ accumulator's throughput against a compiled loop that reads tau_meas and tau_pred once
  (``_core._testing.read_sum``), at ``--lags`` and at ``max_lag=0`` (every chunk read once);
* with ``--rss-n N`` (e.g. 50000000): the C++ accumulator on N rows streamed from two memory-mapped
  ``.npy`` files in ``--rss-dir`` (written first, chunk by chunk), in a fresh process: its peak RSS
  (``ru_maxrss``) and its throughput against the compiled read of the same mapped files;
* ``dynval.dask.validate`` on a ``LocalCluster`` of ``--workers`` worker processes (one thread
  each), the data already held by the workers (as they would read it from shared storage), and
  its ratio to the single-process accumulator on the same data: once with dask's default worker
  environment, once without its ``MALLOC_TRIM_THRESHOLD_`` (see :func:`dask_row`).

``validate`` computes sections the stream leaves out (the spectrum, the coloured-noise bias test,
whiteness at the information rate: contract §4.1), so its time covers more work.
Run: ``python3 benchmarks/bench_stream.py [--n 2000000 --m 7 --p 0 --lags 50 --chunk 100000 --workers 2]``.
This is a benchmark, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import dynval
from dynval.stream import ValidationAccumulator


def robot_like(rows, m, p, seed=0):
    """Smooth joint torques with offsets, a coloured residual with a small mean and a sinusoidal
    regressor, for the sample indices ``rows`` (a block can be made where it is used)."""
    rng = np.random.default_rng([seed, int(rows[0]) if len(rows) else 0])
    t = np.asarray(rows, dtype=np.float64)[:, None] / 1000.0
    freq = np.arange(1, m + 1) * 0.37
    offsets = np.random.default_rng(seed).normal(size=(1, m)) * 5.0
    tau = 20.0 * np.sin(t * freq) + offsets
    e = 0.3 * rng.normal(size=tau.shape) + 0.2 * np.sin(t * 3.1) + 0.1
    y = np.stack([np.sin(t * freq * (c + 1)) for c in range(p)], axis=2) if p else None
    return tau, tau - e, y


def _block(rows, m, p):
    """One block of every array side by side, (c, m·(2 + p)): a worker makes all three together."""
    tau, pred, y = robot_like(rows, m, p)
    return np.concatenate([tau, pred] + ([y.reshape(len(rows), m * p)] if p else []), axis=1)


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def same_quantities(tau, pred, y, args, backend):
    """What a streamed report holds, from the public functions on the whole arrays: the like-for-like
    in-memory cost (validate also builds the spectrum, the bias test and the decimated whiteness)."""
    dynval.validate(tau, pred, n_params=args.params, max_lag=0, backend=backend)
    e = dynval.residuals(tau, pred, backend=backend)
    dynval.autocorrelation(e, args.lags, backend=backend)
    dynval.ljung_box(e, args.lags, backend=backend)
    dynval.zero_mean_test(e, backend=backend)
    if y is not None:
        dynval.cross_correlation(e, y, args.lags, backend=backend)


def stream_report(tau, pred, y, args, backend=None, max_lag=None):
    acc = ValidationAccumulator(n_params=args.params, max_lag=args.lags if max_lag is None else max_lag,
                                backend=backend)
    for k in range(0, tau.shape[0], args.chunk):
        acc.update(tau[k:k + args.chunk], pred[k:k + args.chunk], None if y is None else y[k:k + args.chunk])
    return acc.result()


def dask_arrays(args):
    """The same data as dask arrays made on the workers; the three arrays of a block share a worker,
    as when a task reads its rows of every array from storage."""
    import dask.array as da

    m, p = args.m, args.p
    rows = da.arange(args.n, chunks=args.chunk)
    both = da.map_blocks(_block, rows, m, p, new_axis=1, chunks=(rows.chunks[0], (m * (2 + p),)), dtype=float)
    y = both[:, 2 * m:].reshape(args.n, m, p) if p else None
    return both[:, :m], both[:, m:2 * m], y


def dask_row(args, stream_seconds, keep_malloc_trim):
    """The cluster run: the workers hold the data (as if read from shared storage), then validate it.

    dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536, which also stops glibc from
    raising its mmap threshold: every large temporary (the FFT buffers of the lagged sums) is then
    mapped and zeroed afresh. The second run starts the workers without it.
    """
    import dask
    from dask.distributed import Client, LocalCluster, wait

    import dynval.dask

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ"))
    if not keep_malloc_trim:
        environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    spec = {"n_workers": args.workers, "threads_per_worker": 1, "processes": True, "dashboard_address": None}
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}), LocalCluster(**spec) as cluster, \
            Client(cluster) as client:
        arrays = client.persist([a for a in dask_arrays(args) if a is not None])
        wait(arrays)
        regressor = arrays[2] if args.p else None

        def run():
            return dynval.dask.validate(arrays[0], arrays[1], n_params=args.params, max_lag=args.lags,
                                        regressor=regressor)

        run()  # the workers import dynval, numpy and scipy once
        best = min(timed(run)[0] for _ in range(args.repeat))
    label = f"dask.validate, {args.workers} workers" + (", dask's env" if keep_malloc_trim else ", no malloc trim")
    print(f"{label:<44} {best:>9.2f}   {best / stream_seconds:>6.2f} × the single-process accumulator")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=2_000_000)
    parser.add_argument("--m", type=int, default=7)
    parser.add_argument("--p", type=int, default=0, help="regressor columns (0: none)")
    parser.add_argument("--lags", type=int, default=50)
    parser.add_argument("--params", type=int, default=30)
    parser.add_argument("--chunk", type=int, default=100_000, help="rows per stream chunk and per dask block")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--rss-n", type=int, default=0, help="rows of the memory-mapped RSS run (0: skip)")
    parser.add_argument("--rss-dir", default="/tmp", help="where the .npy files of the RSS run are written")
    parser.add_argument("--rss-child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--skip-dask", action="store_true")
    args = parser.parse_args(argv)
    if args.rss_child:
        return rss_child(args)
    tau, pred, y = (np.concatenate(parts) if parts[0] is not None else None for parts in zip(*(
        robot_like(np.arange(k, min(k + args.chunk, args.n)), args.m, args.p)
        for k in range(0, args.n, args.chunk))))
    print(f"N = {args.n} × m = {args.m}, p = {args.p}, {args.lags} lags, chunks of {args.chunk} rows; "
          f"{os.cpu_count()} cores; backends {[b for b, i in dynval.backends().items() if i['available']]}")
    rows = []
    for backend in [b for b in ("cpp", "python") if dynval.backends()[b]["available"]]:
        seconds = min(timed(lambda b=backend: dynval.validate(tau, pred, n_params=args.params, max_lag=args.lags,
                                                              regressor=y, backend=b))[0] for _ in range(args.repeat))
        rows.append((f"validate ({backend})", seconds))
        print(f"{'validate in memory, ' + backend + ' backend':<44} {seconds:>9.2f}")
        seconds = min(timed(lambda b=backend: same_quantities(tau, pred, y, args, b))[0] for _ in range(args.repeat))
        rows.append((f"same quantities ({backend})", seconds))
        print(f"{'same quantities in memory, ' + backend + ' backend':<44} {seconds:>9.2f}")
    backends = [b for b in ("cpp", "python") if dynval.backends()[b]["available"]]
    per_backend = {}
    for backend in backends:
        per_backend[backend] = min(timed(lambda b=backend: stream_report(tau, pred, y, args, b))[0]
                                   for _ in range(args.repeat))
        print(f"{'stream accumulator (' + backend + ')':<44} {per_backend[backend]:>9.2f}")
        for name, seconds in rows:
            print(f"{'  stream (' + backend + ') / ' + name:<44} {per_backend[backend] / seconds:>9.2f}")
    stream_seconds = per_backend[backends[0]]
    if "cpp" in backends:
        compiled_read_rows(tau, pred, y, args, per_backend["cpp"])
    if args.rss_n:
        rss_run(args)
    if args.skip_dask:
        return
    try:
        import distributed  # noqa: F401
    except ImportError:
        print("dask.validate: skipped (pip install 'dynval[dask]')")
        return
    for keep in (True, False):
        dask_row(args, stream_seconds, keep)


def compiled_read_rows(tau, pred, y, args, stream_seconds):
    """The C++ accumulator against a compiled loop that reads every input element once."""
    probe = dynval.kernels._backend.get_backend("cpp")._testing
    arrays = [tau, pred] + ([y] if y is not None else [])
    read = min(timed(lambda: [probe.read_sum(a) for a in arrays])[0] for _ in range(max(3, args.repeat)))
    zero = min(timed(lambda: stream_report(tau, pred, y, args, "cpp", 0))[0] for _ in range(args.repeat))
    mb = sum(a.nbytes for a in arrays) / 1e6
    print(f"{'compiled read of the inputs (read_sum)':<44} {read:>9.3f}   ({mb / read / 1e3:.1f} GB/s)")
    for label, seconds in ((f"max_lag={args.lags}", stream_seconds), ("max_lag=0", zero)):
        print(f"{'stream accumulator (cpp), ' + label:<44} {seconds:>9.3f}   {mb / seconds:8.0f} MB/s = "
              f"{100 * read / seconds:5.1f} % of the compiled read")


def rss_run(args):
    """Writes N rows to two .npy files chunk by chunk, then streams them in a fresh process."""
    import subprocess
    import sys

    paths = [os.path.join(args.rss_dir, f"dynval_bench_{name}.npy") for name in ("tau", "pred")]
    start = time.perf_counter()
    maps = [np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(args.rss_n, args.m))
            for path in paths]
    for k in range(0, args.rss_n, args.chunk):
        tau, pred, _ = robot_like(np.arange(k, min(k + args.chunk, args.rss_n)), args.m, 0)
        maps[0][k:k + len(tau)] = tau
        maps[1][k:k + len(tau)] = pred
    for mm in maps:
        mm.flush()
    del maps
    print(f"wrote {args.rss_n:,} × {args.m} rows to two .npy files ({2 * args.rss_n * args.m * 8 / 1e9:.1f} GB) "
          f"in {time.perf_counter() - start:.1f} s")
    try:
        for lags in (args.lags, 0):
            out = subprocess.run([sys.executable, __file__, "--rss-child", ",".join(paths), "--m", str(args.m),
                                  "--lags", str(lags), "--chunk", str(args.chunk), "--params", str(args.params)],
                                 check=True, capture_output=True, text=True)
            print(out.stdout, end="")
    finally:
        for path in paths:
            os.remove(path)


def peak_rss_mb():
    """This process's peak resident set (VmHWM; ru_maxrss would include the parent's before exec)."""
    with open("/proc/self/status") as status:
        line = next(x for x in status if x.startswith("VmHWM:"))
    return int(line.split()[1]) / 1024


def mapped_chunks(a, rows):
    """Copies of consecutive chunks of a memory-mapped array, as a file reader would give them. The
    pages of each chunk are released from the mapping once copied (madvise DONTNEED: they stay in
    the page cache), so the resident set measures the reader, not the mapped file."""
    import mmap

    mm = a._mmap
    page = mmap.PAGESIZE
    done = 0
    for k in range(0, a.shape[0], rows):
        chunk = np.array(a[k:k + rows])
        end = (a.offset + (k + len(chunk)) * a.strides[0]) // page * page
        if end > done:
            mm.madvise(mmap.MADV_DONTNEED, done, end - done)
            done = end
        yield chunk


def rss_child(args):
    """In a fresh process: compiled read of the mapped files, then the C++ accumulator over them."""
    probe = dynval.kernels._backend.get_backend("cpp")._testing
    paths = args.rss_child.split(",")
    n, m = np.load(paths[0], mmap_mode="r").shape
    before = peak_rss_mb()

    def maps():
        return [np.load(path, mmap_mode="r") for path in paths]

    read = timed(lambda: [probe.read_sum(c) for a in maps() for c in mapped_chunks(a, args.chunk)])[0]

    def run():
        acc = ValidationAccumulator(n_params=args.params, max_lag=args.lags, backend="cpp")
        tau, pred = maps()
        for t, p in zip(mapped_chunks(tau, args.chunk), mapped_chunks(pred, args.chunk)):
            acc.update(t, p)
        return acc.result()

    seconds, report = timed(run)
    peak = peak_rss_mb()
    print(f"memory-mapped run, N = {n:,} × {m}, max_lag={args.lags}: accumulator {seconds:.1f} s, "
          f"compiled read of the same chunks {read:.1f} s ({100 * read / seconds:.1f} %); peak RSS {peak:.0f} MB "
          f"(after imports {before:.0f} MB); N in the report {report.provenance['n_samples']:,}")


if __name__ == "__main__":
    main()
