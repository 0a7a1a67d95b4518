"""Size and power of the sim2real findings on the simulated KUKA case (docs/conventions.md §5.9).

    PYTHONPATH=python python3 benchmarks/calibrate_mjcf.py [--replicates 50] [--first 0] [--noise 0.3] [--seed 0]
    PYTHONPATH=python python3 benchmarks/calibrate_mjcf.py --table-from OUT1 OUT2 ...

``--first`` starts at another replicate (replicates ``first .. first + replicates − 1``), so runs
split over processes join with ``--table-from`` their printed outputs (each replicate's line).

The robot is the packaged MJCF (``load_kuka_lwr4(run).mjcf``) with its own parameters: its
``MJCFModel.predict`` on the logged motions of run 1 (estimation) and run 3 (validation), plus
white Gaussian noise of ``--noise`` N·m on every joint, drawn per replicate from
``numpy.random.default_rng([seed, replicate])``. Three candidates are validated on each replicate
with ``MJCFModel.compare`` (regressor, model columns, q, time and the estimation run) and
``MJCFModel.retune``:

* ``right``: the packaged MJCF; counted when the verdict is not accept (the size);
* ``damping``: ``lwr_0_joint`` damping 0.5 instead of 1.3 N·m·s/rad; counted as named right when the
  verdict is refine and the first retune entry is (``lwr_0_joint``, ``damping``);
* ``armature``: ``lwr_3_joint`` armature 0.1 instead of 0.3 kg·m²; named right likewise with
  (``lwr_3_joint``, ``armature``).

Prints one line per case: the count, the rate and its 95 % Clopper–Pearson interval.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

from dynval.datasets import load_kuka_lwr4
from dynval.mjcf import MJCFModel

#: case → (joint, attribute, wrong value); None is the right model
CASES = {"right": None, "damping": ("lwr_0_joint", "damping", 0.5), "armature": ("lwr_3_joint", "armature", 0.1)}


def variant(xml: str, joint: str, attribute: str, value: float) -> str:
    """The MJCF text with one joint attribute changed."""
    out, n = re.subn(rf'(<joint name="{joint}"[^>]*\b{attribute}=")[^"]*(")', rf"\g<1>{value!r}\g<2>", xml)
    assert n == 1, (joint, attribute)
    return out


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    a = (1 - level) / 2
    lo = stats.beta.ppf(a, k, n - k + 1) if k else 0.0
    hi = stats.beta.ppf(1 - a, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def outcome(case: str, model: MJCFModel, val, est, tau_val, tau_est) -> bool:
    """True when the case counts: a right model not accepted, a wrong one refined with its parameter named."""
    report = model.compare(val.q, val.dq, val.ddq, tau_val, estimation=(est.q, est.dq, est.ddq, tau_est), time=val.time)
    if CASES[case] is None:
        return report.verdict.decision != "accept"
    first = model.retune(report, val.q, val.dq, val.ddq, tau_val)[:1]
    joint, attribute, _ = CASES[case]
    return report.verdict.decision == "refine" and [(r.joint, r.attribute) for r in first] == [(joint, attribute)]


def table(results: dict[tuple[int, str], bool]) -> None:
    """One line per case: count, rate and its 95 % Clopper–Pearson interval."""
    n = len({rep for rep, _ in results})
    for case in CASES:
        k = sum(v for (_, c), v in results.items() if c == case)
        lo, hi = clopper_pearson(k, n)
        what = "not accepted" if CASES[case] is None else "refined, parameter named"
        print(f"{case:9s} {what:26s} {k:3d}/{n}  {100 * k / n:5.1f} % [{100 * lo:5.1f}, {100 * hi:5.1f}]")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replicates", type=int, default=50)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--noise", type=float, default=0.3, help="noise standard deviation, N·m")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--table-from", nargs="+", type=Path, metavar="OUT")
    args = parser.parse_args(argv)
    if args.table_from:
        lines = [ln.split() for f in args.table_from for ln in f.read_text().splitlines() if ln.startswith("rep ")]
        table({(int(w[1]), w[2]): w[3] == "1" for w in lines})
        return 0
    est, val = load_kuka_lwr4(1), load_kuka_lwr4(3)
    xml = est.mjcf.read_text(encoding="utf-8")
    models = {c: MJCFModel(xml if w is None else variant(xml, *w)) for c, w in CASES.items()}
    clean = [models["right"].predict(r.q, r.dq, r.ddq) for r in (est, val)]
    results = {}
    start = time.perf_counter()
    for rep in range(args.first, args.first + args.replicates):
        rng = np.random.default_rng([args.seed, rep])
        tau_est, tau_val = (c + args.noise * rng.standard_normal(c.shape) for c in clean)
        for case, model in models.items():
            results[rep, case] = outcome(case, model, val, est, tau_val, tau_est)
            print(f"rep {rep} {case} {int(results[rep, case])}", flush=True)
    seconds = time.perf_counter() - start
    print(f"simulated KUKA (runs 1 -> 3), noise {args.noise} N·m, {args.replicates} replicates, {seconds:.0f} s")
    table(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
