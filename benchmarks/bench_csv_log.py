"""Peak memory and time of ``dynval.io.read_csv_log`` on a long vendor CSV log.

Writes an RTDE-like CSV of ``--seconds`` at ``--rate`` Hz for ``--joints`` joints (``timestamp``,
``actual_q_i``, ``actual_qd_i``, ``target_moment_i`` and ``--extra`` unmapped columns, space
separated, full precision), then reads it with the ``ur_rtde_moment``-like mapping in a fresh child
process that reports its own peak resident memory (VmHWM: its address space's high-water mark) and
the arrays it holds at the end. No figure is asserted; run it, read the ratio.

    PYTHONPATH=python python3 benchmarks/bench_csv_log.py [--seconds 3600 --rate 1000 --joints 7]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

CHILD = r"""
import json, sys, time
from dynval.io import CSVMapping, read_csv_log
path, joints = sys.argv[1], int(sys.argv[2])
mapping = CSVMapping(time="timestamp", q="actual_q_{i}", dq="actual_qd_{i}", effort="target_moment_{i}",
                     n_joints=joints, name="bench")
start = time.perf_counter()
log = read_csv_log(path, mapping)
seconds = time.perf_counter() - start
held = log.time.nbytes + log.q.nbytes + log.dq.nbytes + log.tau.nbytes
peak = next(int(line.split()[1]) * 1024 for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print(json.dumps({"rows": int(log.q.shape[0]), "held": held, "peak": peak, "seconds": seconds}))
"""

BASELINE = ("import dynval.io, sys\n"
            "print(next(int(l.split()[1]) * 1024 for l in open('/proc/self/status') if l.startswith('VmHWM:')))")


def write(path: str, rows: int, rate: float, joints: int, extra: int) -> None:
    names = (["timestamp"] + [f"{f}_{i}" for f in ("actual_q", "actual_qd", "target_moment") for i in range(joints)]
             + [f"other_{k}" for k in range(extra)])
    rng = np.random.default_rng(0)
    block = 100_000
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(" ".join(names) + "\n")
        for start in range(0, rows, block):
            k = min(block, rows - start)
            data = rng.standard_normal((k, len(names)))
            data[:, 0] = 1000.0 + np.arange(start, start + k) / rate
            np.savetxt(handle, data, fmt="%.17g", delimiter=" ")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3600.0, help="log length (default 3600 s)")
    parser.add_argument("--rate", type=float, default=1000.0, help="rows per second (default 1000)")
    parser.add_argument("--joints", type=int, default=7, help="joints (default 7)")
    parser.add_argument("--extra", type=int, default=0, help="unmapped columns (default 0)")
    args = parser.parse_args(argv)
    rows = int(args.seconds * args.rate)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "log.csv")
        start = time.perf_counter()
        write(path, rows, args.rate, args.joints, args.extra)
        written = time.perf_counter() - start
        size = os.path.getsize(path)
        out = subprocess.run([sys.executable, "-c", CHILD, path, str(args.joints)], capture_output=True, text=True,
                             check=True)
        base = int(subprocess.run([sys.executable, "-c", BASELINE], capture_output=True, text=True,
                                  check=True).stdout)
    got = json.loads(out.stdout)
    mb = 1 << 20
    print(f"read_csv_log: {rows:,} rows × {args.joints} joints ({1 + 3 * args.joints + args.extra} columns), "
          f"{size / mb:,.0f} MB of text (written in {written:.0f} s); load average {os.getloadavg()[0]:.2f}")
    print(f"  read in {got['seconds']:.1f} s; arrays held {got['held'] / mb:,.0f} MB; peak resident "
          f"{got['peak'] / mb:,.0f} MB (import dynval.io alone: {base / mb:,.0f} MB); "
          f"(peak − import) / held = {(got['peak'] - base) / got['held']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
