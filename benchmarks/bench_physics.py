"""The physics test's cost: ``validate`` with q ÷ ``validate`` without q, in one run.

Rows printed (seconds, best of ``--repeat`` calls; the ratio with its goal ≤ 3× and bar 5×):

* the KUKA LWR4+ runs shipped with dynval (``dynval.datasets``; 5,027 × 7 at 200 Hz): the
  ``rigid+friction`` base parameters identified on run 1 (URDF regressor, pinocchio), validated on
  run 2 (the same trajectory) and run 3 (another one) with the identifiable columns, the model's
  columns, the estimation run and the logged q, q̇, q̈; without q means the same call without q,
  q̇, q̈ and without the estimation run's q, q̇, q̈ (its regressor and torques kept);
* a simulated 7-joint arm logged at 1 kHz for 20 s (20,000 × 7, time stamps given): the KUKA
  URDF's torques on a multi-sine trajectory plus viscous and Coulomb friction the prediction
  lacks and white noise; the prediction and q alone (derivatives by dynval), no regressor.

``--before DIR``: also time a checkout's ``python/`` (e.g. ``git worktree add /tmp/main main``) on the
same data, printed beside as "before" (both then in fresh interpreters, one after the other).
``--clock cpu``: the process's CPU time (``time.process_time``) instead of the wall clock: ``validate``
runs one BLAS thread, so its CPU time is its cost, which other jobs on a shared machine inflate less
than its wall time (they still share the caches and the memory bus).
Without pinocchio the KUKA rows are left out.
Run: ``PYTHONPATH=python python3 benchmarks/bench_physics.py [--repeat 3 --before /tmp/main]``.
This is a benchmark, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from bench_interactive import best_of  # the benchmarks' one timer (best of n calls)

ROOT = Path(__file__).resolve().parents[1]
GOAL, BAR = 3.0, 5.0


def kuka_cases():
    """(name, kwargs with q, kwargs without q) for runs 2 and 3 validated against run 1's fit."""
    from dynval.datasets import load_kuka_lwr4
    from dynval.identify import identify
    from dynval.robots import URDFModel

    runs = {k: load_kuka_lwr4(k) for k in (1, 2, 3)}
    cad = URDFModel(runs[1].urdf)
    regs = {k: cad.regressor(r.q, r.dq, r.ddq) for k, r in runs.items()}
    m = runs[1].q.shape[1]
    full = identify(regs[1][:, :, :13 * m], runs[1].tau)
    keep = list(full.base_columns)
    names = list(cad.column_names())
    own = [i for i, c in enumerate(keep) if c < 12 * m]
    cols = [keep[i] for i in own]
    fit = identify(regs[1][:, :, cols], runs[1].tau)
    out = []
    for k in (2, 3):
        r = runs[k]
        y = np.ascontiguousarray(regs[k][:, :, keep])
        common = dict(tau_meas=r.tau, tau_pred=fit.predict(regs[k][:, :, cols]), n_params=int(fit.rank),
                      regressor=y, time=r.time, joint_names=list(r.joint_names),
                      column_names=[names[c] for c in keep], model_columns=own)
        est = {"regressor": regs[1][:, :, keep], "tau": runs[1].tau}
        with_q = dict(common, q=r.q, dq=r.dq, ddq=r.ddq,
                      estimation=dict(est, q=runs[1].q, dq=runs[1].dq, ddq=runs[1].ddq))
        out.append((f"KUKA run {k} (5,027 × 7, 200 Hz, p = {len(keep)})", with_q, dict(common, estimation=est)))
    return out


def simulated_case(n=20_000, rate=1000.0, seed=0):
    """A 7-joint arm at 1 kHz for 20 s: the KUKA URDF on a multi-sine trajectory, friction missing."""
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    rng = np.random.default_rng(seed)
    cad = URDFModel(load_kuka_lwr4(1).urdf)
    m = 7
    t = np.arange(n) / rate
    w = 2 * np.pi * 0.1 * np.arange(1, 6)
    amp = rng.uniform(0.05, 0.25, (5, m))
    ph = rng.uniform(0, 2 * np.pi, (5, m))
    arg = t[:, None, None] * w[None, :, None] + ph
    q = np.sum(amp * np.sin(arg), axis=1)
    dq = np.sum(amp * w[:, None] * np.cos(arg), axis=1)
    ddq = -np.sum(amp * (w ** 2)[:, None] * np.sin(arg), axis=1)
    pred = cad.predict(q, dq, ddq)
    rms = np.sqrt(np.mean(pred ** 2, axis=0))
    friction = 0.03 * rms * (dq / np.std(dq, axis=0) + np.sign(dq))
    tau = pred + friction + rng.normal(0.0, 0.02, (n, m)) * rms
    stamps = t + rng.normal(0.0, 1e-6, n)
    stamps.sort()
    kw = dict(tau_meas=tau, tau_pred=pred, n_params=0, time=stamps)
    return "simulated 7-joint arm, 1 kHz × 20 s (20,000 × 7)", dict(kw, q=q), kw


def cases(kuka=True):
    out = []
    if kuka:
        try:
            import pinocchio  # noqa: F401
        except ImportError:
            print("pinocchio is not installed: the KUKA rows are left out")
        else:
            out += kuka_cases()
    out.append(simulated_case())
    return out


def measure(repeat, clock="wall"):
    """{case: (seconds with q, seconds without q)} with the dynval on the path."""
    import dynval

    timer = functools.partial(best_of, clock=time.process_time if clock == "cpu" else time.perf_counter)
    out = {}
    for name, with_q, without in cases():
        dynval.validate(**without)  # first call: imports and lazy modules
        out[name] = tuple(timer(lambda kw=kw: dynval.validate(**kw), repeat) for kw in (with_q, without))
    return out


def measure_elsewhere(checkout: Path, repeat: int, clock: str = "wall"):
    """The same figures with ``checkout``'s python/ first on the path (a subprocess)."""
    env = dict(os.environ, PYTHONPATH=str(checkout / "python"))
    code = (f"import sys, json; sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); import bench_physics as b; "
            f"print(json.dumps(b.measure({repeat}, {clock!r})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def verdict(ratio):
    return "PASS" if ratio <= GOAL else "within bar" if ratio <= BAR else "MISS"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="best of this many calls")
    parser.add_argument("--before", type=Path, default=None, help="a checkout whose python/ is timed as 'before'")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="wall: time.perf_counter; cpu: the process's CPU time (time.process_time)")
    args = parser.parse_args(argv)
    # before and after alike: each in a fresh interpreter, one after the other, best of the same count
    before = measure_elsewhere(args.before, args.repeat, args.clock) if args.before is not None else {}
    after = measure_elsewhere(ROOT, args.repeat, args.clock) if args.before is not None else \
        measure(args.repeat, args.clock)
    print(f"validate with q ÷ without q (goal ≤ {GOAL:g}×, bar {BAR:g}×; {args.clock} clock)")
    print(f"{'case':<52} {'with q':>9} {'without':>9} {'ratio':>7}" + ("   before: with q, ratio" if before else ""))
    for name, (wq, wo) in after.items():
        line = f"{name:<52} {wq:>8.3f}s {wo:>8.3f}s {wq / wo:>6.1f}×  {verdict(wq / wo):<10}"
        if name in before:
            bq, bo = before[name]
            line += f"   {bq:>7.2f}s {bq / bo:>6.1f}×"
        print(line)


if __name__ == "__main__":
    main()
