"""Size and power of dynval's findings on the scenario library of ``dynval.scenarios``.

The scenarios come from the physics (serial arms built in pinocchio: a 2-joint planar arm, a
3-joint anthropomorphic arm, a 4-joint arm; rates 100 Hz to 1 kHz; white, heavy-tailed, AR(1),
low-pass filtered, heteroscedastic and jittered noise), not from dynval.simulate. Each replicate
draws an estimation and a validation trajectory, identifies the model by least squares and
validates it twice: with the missing column offered in the regressor (``model_columns=`` the
model's) and with the model's own columns only. One row per (scenario, offered):

* ``any deficiency``: the share of replicates with a ``deficiency`` finding (size for the right
  model, at most 5 %; for a deficient model the share that calls it deficient at all);
* ``named right``: the share whose findings name the scenario's expected cause
  (``dynval.scenarios.Expected``; target at least 90 %);

both with a 95 % Clopper–Pearson interval, the mean seconds per replicate (simulation and
identification, validation) and the count of replicates with each finding kind (deficiencies;
``kind/design`` for design findings).

    python benchmarks/calibrate_findings.py                        # 200 replicates per scenario
    python benchmarks/calibrate_findings.py --replicates 20 --jobs 2
    python benchmarks/calibrate_findings.py --scenarios right,no_coulomb --replicates 50
    python benchmarks/calibrate_findings.py --quick                # one scenario per class, 10 replicates
    python benchmarks/calibrate_findings.py --list                 # the scenarios and their parameters
    python benchmarks/calibrate_findings.py --legacy --replicates 500 --power-replicates 200
                                            # the 2-DOF table of conventions §5.5 (dynval.calibration)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

# One BLAS thread per process: the problems are small and threads only contend on a shared machine.
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import scipy.stats  # noqa: E402

from dynval import calibration as C  # noqa: E402
from dynval import scenarios as S  # noqa: E402


def interval(k: int, n: int) -> str:
    ci = scipy.stats.binomtest(k, n).proportion_ci(0.95)
    return f"{100 * k / n:5.1f} % [{100 * ci.low:4.1f}, {100 * ci.high:5.1f}]"


def _task(args):
    scenario, replicate, backend = args
    return S.run_replicate(scenario, replicate, backend=backend)


def select(names: str | None, quick: bool) -> list:
    lib = list(S.library())
    if names:
        wanted = [w.strip() for w in names.split(",") if w.strip()]
        unknown = [w for w in wanted if w not in S.CLASSES and w not in {s.key for s in lib}]
        if unknown:
            raise SystemExit(f"unknown scenario(s) {unknown}; classes: {', '.join(S.CLASSES)}, or a key from --list")
        lib = [s for s in lib if s.name in wanted or s.key in wanted]
    if quick:
        seen: set[str] = set()
        first = []
        for s in lib:
            if s.name not in seen:
                seen.add(s.name)
                first.append(s)
        lib = first
    return lib


def run_library(scenarios, replicates: int, jobs: int, backend, first_seed: int = 0, log=None):
    """Run every (scenario, replicate); ``log``: a text file that gets each outcome as a JSON line."""
    tasks = [(s, first_seed + i, backend) for i in range(replicates) for s in scenarios]
    results: dict = {}
    t0 = time.time()
    last = 0.0
    if jobs > 1:
        import multiprocessing

        # a process per core: no threads of their own (the physics test's joints would go on threads)
        os.environ.setdefault("DYNVAL_NUM_THREADS", "1")
        pool = multiprocessing.get_context("spawn").Pool(jobs)
        outcomes = pool.imap_unordered(_task, tasks, chunksize=1)
    else:
        pool = None
        outcomes = map(_task, tasks)
    try:
        for done, records in enumerate(outcomes, 1):
            for r in records:
                results.setdefault((r["key"], r["offered"]), []).append(r)
                if log is not None:
                    log.write(json.dumps(r) + "\n")
            if log is not None:
                log.flush()
            now = time.time()
            if now - last > 10 or done == len(tasks):
                last = now
                rate = (now - t0) / done
                print(f"  [{done}/{len(tasks)}] {records[0]['key']} replicate {records[0]['replicate']}: "
                      f"{now - t0:.0f} s, about {rate * (len(tasks) - done):.0f} s left",
                      file=sys.stderr, flush=True)
    finally:
        if pool is not None:
            pool.close()
            pool.join()
    return results


def table(scenarios, results) -> list[str]:
    lines = [f"{'scenario':40} {'offered':7} {'reps':>4} {'any deficiency':>25} {'named right':>25} "
             f"{'advice right':>25} {'adds a term it has':>25} {'sim s':>6} {'val s':>6}  kinds"]
    for s in scenarios:
        for offered in (True, False):
            rows = results.get((s.key, offered), [])
            if not rows:
                continue
            n = len(rows)
            anyd = sum(r["any_deficiency"] for r in rows)
            right = "—" if s.expected is None else interval(sum(bool(r["named_right"]) for r in rows), n)
            kinds: dict[str, int] = {}
            for r in rows:
                for k in r["kinds"]:
                    kinds[k] = kinds.get(k, 0) + 1
            scored = [r for r in rows if r.get("advice_right") is not None]
            advice = interval(sum(bool(r["advice_right"]) for r in scored), len(scored)) if scored else "—"
            counted = [r for r in rows if "adds_what_it_has" in r]
            adds = (interval(sum(r["adds_what_it_has"] > 0 for r in counted), len(counted))
                    if counted else "—")
            sim = sum(r["seconds_simulate"] for r in rows) / n
            val = sum(r["seconds_validate"] for r in rows) / n
            lines.append(f"{s.key:40} {'yes' if offered else 'no':7} {n:4d} {interval(anyd, n):>25} {right:>25} "
                         f"{advice:>25} {adds:>25} {sim:6.2f} {val:6.2f}  "
                         + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
    return lines


def legacy(args) -> int:
    """The 2-DOF table of docs/conventions.md §5.5 (dynval.calibration, dynval.simulate's arm)."""
    replicates = args.replicates or 500
    print(f"{'noise':8} {'model':12} {'reps':>5} {'any deficiency (size / power)':>32} {'right cause':>28}  kinds")
    t0 = time.time()
    for noise in args.noises.split(","):
        for model in args.models.split(","):
            reps = replicates
            if args.power_replicates and model not in C.SIZE_MODELS and noise != "white":
                reps = args.power_replicates
            r = C.run_case(noise, model, reps, backend=args.backend, with_estimation=not args.no_estimation)
            right = interval(r["right_cause"], reps) if model not in C.SIZE_MODELS else "—"
            kinds = ", ".join(f"{k} {v}" for k, v in sorted(r["kinds"].items()))
            print(f"{noise:8} {model:12} {reps:5d} {interval(r['any_deficiency'], reps):>32} {right:>28}  {kinds}",
                  flush=True)
            print(f"  ({time.time() - t0:.0f} s)", file=sys.stderr, flush=True)
    print(f"total {time.time() - t0:.0f} s")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--replicates", type=int, default=None, help="replicates per scenario (default 200; "
                        "10 with --quick; 500 with --legacy)")
    parser.add_argument("--scenarios", default=None,
                        help="comma-separated classes (right, no_coulomb, ...) or scenario keys (see --list)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (one BLAS thread each)")
    parser.add_argument("--quick", action="store_true", help="the first scenario of each class, 10 replicates")
    parser.add_argument("--first-seed", type=int, default=0, help="number of the first replicate")
    parser.add_argument("--backend", default=None)
    parser.add_argument("--json", default=None,
                        help="also write every replicate's outcome to this file (JSON lines, as they come)")
    parser.add_argument("--table-from", default=None, metavar="FILE",
                        help="print the table of the outcomes a --json run wrote (complete or not), and exit")
    parser.add_argument("--list", action="store_true", help="print the scenarios and their parameters, and exit")
    legacy_group = parser.add_argument_group("the 2-DOF table of dynval.calibration (--legacy)")
    legacy_group.add_argument("--legacy", action="store_true")
    legacy_group.add_argument("--power-replicates", type=int, default=None,
                              help="replicates of the deficient models under coloured noise (default: --replicates)")
    legacy_group.add_argument("--noises", default=",".join(C.NOISES))
    legacy_group.add_argument("--models", default=",".join(C.MODELS))
    legacy_group.add_argument("--no-estimation", action="store_true",
                              help="validate without the estimation run (the findings see the validation run only)")
    args = parser.parse_args(argv)
    if args.legacy:
        return legacy(args)
    scenarios = select(args.scenarios, args.quick)
    if args.list:
        for s in scenarios:
            print(s.describe())
        return 0
    if args.table_from:
        results: dict = {}
        with open(args.table_from, encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    r = json.loads(line)
                    results.setdefault((r["key"], r["offered"]), []).append(r)
        for line in table(scenarios, results):
            print(line)
        return 0
    replicates = args.replicates or (10 if args.quick else 200)
    t0 = time.time()
    log = open(args.json, "w", encoding="utf-8") if args.json else None  # noqa: SIM115
    try:
        results = run_library(scenarios, replicates, max(1, args.jobs), args.backend, args.first_seed, log)
    finally:
        if log is not None:
            log.close()
    for line in table(scenarios, results):
        print(line)
    print(f"total {time.time() - t0:.0f} s ({len(scenarios)} scenarios × {replicates} replicates, "
          f"{max(1, args.jobs)} job(s))")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
