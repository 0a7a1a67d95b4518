"""Size and power of dynval's findings, measured by simulation (docs/conventions.md §7.4).

Prints one table: for each noise (white Gaussian, Student t₃, AR(1) 0.9 and 0.99) and model
(exact and estimated true structure; a model rightly without Coulomb friction; missing Coulomb
friction, missing gravity term, unmodelled lightly damped mode), the share of replicates with any
``deficiency`` finding and the share where the right finding names the right cause, with a 95 %
Clopper–Pearson interval.

    python benchmarks/calibrate_findings.py                 # 500 replicates per case
    python benchmarks/calibrate_findings.py --replicates 100 --backend python
    python benchmarks/calibrate_findings.py --no-estimation  # findings from the validation run alone

The size target is "any deficiency" ≤ 1 − level (5 %) for the right models (exact, estimated, zero_coulomb);
the power target is "right cause" ≥ 90 % under white noise.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

# One BLAS thread per process: the problems are small and threads only contend on a shared machine.
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import scipy.stats  # noqa: E402

from dynval import calibration as C  # noqa: E402


def interval(k: int, n: int) -> str:
    ci = scipy.stats.binomtest(k, n).proportion_ci(0.95)
    return f"{100 * k / n:5.1f} % [{100 * ci.low:4.1f}, {100 * ci.high:5.1f}]"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--replicates", type=int, default=500)
    parser.add_argument("--power-replicates", type=int, default=None,
                        help="replicates of the deficient models under coloured noise (default: --replicates)")
    parser.add_argument("--backend", default=None)
    parser.add_argument("--noises", default=",".join(C.NOISES))
    parser.add_argument("--models", default=",".join(C.MODELS))
    parser.add_argument("--no-estimation", action="store_true",
                        help="validate without the estimation run (the findings see the validation run only)")
    args = parser.parse_args(argv)
    print(f"{'noise':8} {'model':12} {'reps':>5} {'any deficiency (size / power)':>32} {'right cause':>28}  kinds")
    t0 = time.time()
    for noise in args.noises.split(","):
        for model in args.models.split(","):
            reps = args.replicates
            if args.power_replicates and model not in C.SIZE_MODELS and noise != "white":
                reps = args.power_replicates
            r = C.run_case(noise, model, reps, backend=args.backend, with_estimation=not args.no_estimation)
            right = interval(r["right_cause"], reps) if model not in C.SIZE_MODELS else "—"
            kinds = ", ".join(f"{k} {v}" for k, v in sorted(r["kinds"].items()))
            print(f"{noise:8} {model:12} {reps:5d} {interval(r['any_deficiency'], reps):>32} {right:>28}  {kinds}",
                  flush=True)
            print(f"  ({time.time() - t0:.0f} s)", file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
