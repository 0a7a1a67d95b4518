"""Peak memory of ``dynval.validate`` with a regressor, per backend, against the input's size.

Each measurement runs in a fresh child process: it builds the inputs (N × 7 torques, an
(N, 7, p) regressor), notes its peak resident set size, calls ``validate`` and reports the peak
again. Printed per backend: the input size, the peak RSS after the call, and peak / input, the
target being at most 2 (the input included). No time is asserted; run it, read the ratios.

    PYTHONPATH=python python3 benchmarks/bench_memory.py [--n 2000000 --p 8 --backends python,cpp]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

CHILD = r"""
import json, resource, sys, time
import numpy as np
import dynval
n, p, backend = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
m = 7
rng = np.random.default_rng(0)
regressor = rng.standard_normal((n, m, p))
pi = rng.standard_normal(p)
tau_pred = regressor @ pi
tau_meas = tau_pred + 0.1 * rng.standard_normal((n, m))
size = regressor.nbytes + tau_meas.nbytes + tau_pred.nbytes
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
start = time.perf_counter()
dynval.validate(tau_meas, tau_pred, n_params=p, regressor=regressor, backend=backend, sample_rate=100.0)
seconds = time.perf_counter() - start
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"input": size, "before": before, "peak": after, "seconds": seconds}))
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2_000_000, help="samples (default 2,000,000)")
    parser.add_argument("--p", type=int, default=8, help="regressor columns (default 8)")
    parser.add_argument("--backends", default="python,cpp", help="comma-separated (default python,cpp)")
    args = parser.parse_args(argv)
    print(f"validate with a regressor: N = {args.n:,} × 7 joints, p = {args.p}; load average "
          f"{os.getloadavg()[0]:.2f}")
    print(f"{'backend':8s} {'input MB':>9s} {'before MB':>10s} {'peak MB':>8s} {'peak / input':>13s} {'s':>6s}")
    for backend in args.backends.split(","):
        out = subprocess.run([sys.executable, "-c", CHILD, str(args.n), str(args.p), backend],
                             capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        mb = 1e6
        print(f"{backend:8s} {r['input'] / mb:9.0f} {r['before'] / mb:10.0f} {r['peak'] / mb:8.0f} "
              f"{r['peak'] / r['input']:13.2f} {r['seconds']:6.1f}")
    print("before: peak RSS once the inputs exist (interpreter, libraries and the inputs themselves)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
