"""Write every report of a fixed set of runs as JSON (and its summary and HTML) and hash them.

    PYTHONPATH=python python3 benchmarks/snapshot_reports.py OUT_DIR [--replicates N] [--quick]

A refactoring of the report (its sections, rules, words, compare) must leave every output byte-identical:
run this on the untouched tree into one directory, on the changed tree into another, and compare the
``SHA256SUMS`` files (``diff``) or the directories (``diff -r``). The runs:

* the scenario library (:func:`dynval.scenarios.library`), ``--replicates`` replicates of each
  scenario, each validated with the offered regressor and with the model's own columns;
* the demo's comparisons (every scenario of :data:`dynval.simulate.SCENARIOS`, 2000 samples);
* the KUKA LWR4+ runs (:mod:`dynval.datasets`): the rigid+friction+offset structure identified on
  run 1, compared on runs 2 and 3 with its smaller structures (needs pinocchio; skipped without it);
* the stream: the demo's friction scenario through :class:`dynval.stream.ValidationAccumulator`.

Each output is written as ``NAME.json`` (``to_dict``, keys sorted), ``NAME.txt`` (``summary()``) and,
for compare results, ``NAME.html`` (``dynval.html.render_report``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def _write(out: Path, name: str, obj: Any, html: bool = False) -> None:
    safe = name.replace("/", "_").replace(":", "_").replace("@", "_")
    (out / f"{safe}.json").write_text(json.dumps(obj.to_dict(), sort_keys=True, indent=1, allow_nan=False))
    (out / f"{safe}.txt").write_text(obj.summary())
    if html:
        from dynval.html import render_report

        (out / f"{safe}.html").write_text(_undated(render_report(obj)))


def _undated(text: str) -> str:
    """The page without the minute it was made, which is all that differs between two runs."""
    return re.sub(r"\d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC", "YYYY-MM-DD hh:mm UTC", text)


def scenario_reports(out: Path, replicates: int, quick: bool) -> int:
    from dynval import scenarios

    count = 0
    library = scenarios.library()
    for s in library[::6] if quick else library:
        for k in range(replicates):
            rep = scenarios.simulate(s, k)
            prediction = scenarios.fit(rep)
            for offered in (True, False):
                report = scenarios.validate_replicate(rep, offered, prediction=prediction)
                _write(out, f"scenario-{s.key}-r{k}-{'offered' if offered else 'own'}", report)
                count += 1
    return count


def demo_reports(out: Path) -> int:
    from dynval.demo import run_demo
    from dynval.simulate import SCENARIOS

    count = 0
    for scenario in SCENARIOS:
        result = run_demo(scenario, progress=None)
        assert result.comparison is not None
        _write(out, f"demo-{scenario}", result.comparison, html=True)
        count += 1 + len(result.comparison.reports)
    return count


def kuka_reports(out: Path) -> int:
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        print("snapshot: pinocchio missing, KUKA runs skipped", file=sys.stderr)
        return 0
    import dynval
    from dynval.datasets import load_kuka_lwr4
    from dynval.identify import identify
    from dynval.robots import URDFModel

    runs = {k: load_kuka_lwr4(k) for k in (1, 2, 3)}
    cad = URDFModel(runs[1].urdf)
    n = len(cad.joint_names)
    columns = list(cad.column_names())
    regs = {k: cad.regressor(r.q, r.dq, r.ddq) for k, r in runs.items()}
    structures = {"rigid": list(range(10 * n)), "rigid+friction": list(range(12 * n)),
                  "rigid+friction+offset": list(range(13 * n))}
    fits = {name: (identify(regs[1][:, :, cols], runs[1].tau), cols) for name, cols in structures.items()}
    keep = list(fits["rigid+friction+offset"][0].base_columns)
    est = runs[1]
    count = 0
    for k in (2, 3):
        val = runs[k]
        y = np.ascontiguousarray(regs[k][:, :, keep])
        own = {name: [i for i, c in enumerate(keep) if c in set(cols)] for name, (_, cols) in fits.items()}
        candidates = {name: {"prediction": res.predict(regs[k][:, :, cols]), "n_params": res.rank, "regressor": y,
                             "model_columns": own[name]} for name, (res, cols) in fits.items()}
        cmp = dynval.compare(val.tau, candidates, time=val.time, joint_names=list(cad.joint_names),
                             column_names=[columns[c] for c in keep], q=val.q, dq=val.dq, ddq=val.ddq,
                             estimation={"q": est.q, "dq": est.dq, "ddq": est.ddq, "regressor": regs[1][:, :, keep],
                                         "tau": est.tau})
        _write(out, f"kuka-run{k}", cmp, html=True)
        count += 1 + len(cmp.reports)
    return count


def stream_reports(out: Path) -> int:
    from dynval.simulate import simulate
    from dynval.stream import ValidationAccumulator

    d = simulate("friction", seed=0, n_samples=2000)
    val = d.validation
    reg = val.regressors["friction"]
    from dynval.identify import identify

    res = identify(d.estimation.regressors["friction"], d.estimation.tau_meas)
    pred = res.predict(reg)
    acc = ValidationAccumulator(n_params=res.rank, sample_rate=d.sample_rate)
    for lo in range(0, val.tau_meas.shape[0], 500):
        acc.update(val.tau_meas[lo:lo + 500], pred[lo:lo + 500], reg[lo:lo + 500])
    _write(out, "stream-friction", acc.result())
    return 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="directory to write into (created)")
    parser.add_argument("--replicates", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="every sixth scenario, no KUKA")
    parser.add_argument("--rehash", action="store_true", help="only hash OUT again (after removing the pages' dates)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    n = 0
    if args.rehash:
        for page in out.glob("*.html"):
            page.write_text(_undated(page.read_text()))
    else:
        n = scenario_reports(out, args.replicates, args.quick) + demo_reports(out) + stream_reports(out)
    if not (args.quick or args.rehash):
        n += kuka_reports(out)
    sums = [f"{hashlib.sha256(p.read_bytes()).hexdigest()}  {p.name}" for p in sorted(out.iterdir())
            if p.name != "SHA256SUMS"]
    (out / "SHA256SUMS").write_text("\n".join(sums) + "\n")
    total = hashlib.sha256("\n".join(sums).encode()).hexdigest()[:16]
    print(f"snapshot: {n} reports, {len(sums)} files in {out} ({time.perf_counter() - t0:.0f} s); total {total}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
