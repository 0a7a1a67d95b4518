"""KUKA LWR4+ measurements (FloBaRoID): identify on one run, validate and compare on the others.

    python3 examples/kuka_lwr4/run.py [--data DIR] [--out DIR]

The data are the three logged runs of the FloBaRoID project (LGPL-3.0; see the data
directory's README.md and LICENSE.md). They are read from ``../shared/data/robots/
kuka_lwr4_flobaroid`` beside the repository (or ``--data``, or ``DYNVAL_KUKA_DATA``) and never
copied. Without the data, or without pinocchio (``pip install pin``), the script says so and
exits with status 0.

Candidates, each predicting the validation runs' torques:

* ``rigid``: base parameters of the URDF regressor (rigid body only), identified on run 1;
* ``rigid+friction``: + viscous and Coulomb friction per joint;
* ``rigid+friction+offset``: + a torque offset per joint;
* ``CAD URDF``: the a-priori model ``kuka_lwr4.urdf`` (RNEA on its inertials, plus its
  ``<dynamics>`` friction), nothing fitted here;
* ``identified URDF``: FloBaRoID's ``kuka_lwr4_identified.urdf`` the same way; it was
  identified upstream on these measurements, so it is counted with its 7·10 inertial and
  7·2 friction parameters.

Velocities and accelerations are the logged ones (FloBaRoID filtered them without time shift).
Run 2 repeats run 1's trajectory, run 3 is a different one: run 2 shows what validating on the
estimation trajectory looks like, run 3 is the real test.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DEFAULT_DATA = HERE.parents[2] / "shared" / "data" / "robots" / "kuka_lwr4_flobaroid"


def find_data(arg=None):
    for candidate in (arg, os.environ.get("DYNVAL_KUKA_DATA"), DEFAULT_DATA):
        if candidate and (Path(candidate) / "data" / "measurements_1.npz").is_file():
            return Path(candidate)
    return None


def load_run(data_dir: Path, k: int) -> dict:
    with np.load(data_dir / "data" / f"measurements_{k}.npz") as f:
        run = {key: np.asarray(f[key], dtype=float) for key in ("times", "positions", "velocities",
                                                                 "accelerations", "torques")}
    run["name"] = f"run {k}"
    dt = np.diff(run["times"])
    run["sample_rate"] = 1.0 / float(np.mean(dt))
    return run


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=None, help="FloBaRoID KUKA data directory")
    parser.add_argument("--out", default="kuka_lwr4_out", help="output directory (default ./kuka_lwr4_out)")
    parser.add_argument("--no-figures", action="store_true", help="tables only")
    args = parser.parse_args(argv)

    data_dir = find_data(args.data)
    if data_dir is None:
        print(f"kuka_lwr4: data not found (looked in --data, $DYNVAL_KUKA_DATA and {DEFAULT_DATA}); skipping.")
        return 0
    try:
        import pinocchio  # noqa: F401

        from dynval.robots import URDFModel
    except ImportError:
        print("kuka_lwr4: pinocchio is not installed (pip install pin); skipping.")
        return 0
    import dynval

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    say = lambda msg: print(f"[kuka_lwr4] {msg}", file=sys.stderr, flush=True)  # noqa: E731

    start = time.perf_counter()
    cad = URDFModel(data_dir / "model" / "kuka_lwr4.urdf")
    identified_urdf = URDFModel(data_dir / "model" / "kuka_lwr4_identified.urdf")
    joints = list(cad.joint_names)
    columns = list(cad.column_names())
    runs = {k: load_run(data_dir, k) for k in (1, 2, 3)}
    est = runs[1]
    say(f"{len(joints)} joints, {len(columns)} regressor columns; runs of "
        + ", ".join(f"{r['positions'].shape[0]} samples" for r in runs.values())
        + f" at {est['sample_rate']:.1f} Hz")

    def motion(run):
        return run["positions"], run["velocities"], run["accelerations"]

    say("building the regressors (pinocchio computeJointTorqueRegressor)")
    regs = {k: cad.regressor(*motion(r)) for k, r in runs.items()}
    n_inertial = 10 * len(joints)
    n = len(joints)
    structures = {
        "rigid": list(range(n_inertial)),
        "rigid+friction": list(range(n_inertial + 2 * n)),
        "rigid+friction+offset": list(range(n_inertial + 3 * n)),
    }
    from dynval.identify import identify

    fits = {}
    lines = ["KUKA LWR4+ (FloBaRoID measurements): identification on run 1",
             f"  {'candidate':<24}{'columns':>8}{'rank':>6}{'cond':>10}{'σ (N·m)':>10}  largest %σ"]
    for name, cols in structures.items():
        res = identify(regs[1][:, :, cols], est["torques"], column_names=[columns[c] for c in cols])
        fits[name] = (res, cols)
        worst = int(np.argmax(res.rel_std_percent))
        lines.append(f"  {name:<24}{len(cols):>8}{res.rank:>6}{res.condition_number:>10.3g}"
                     f"{np.sqrt(res.sigma2):>10.3g}  {res.rel_std_percent[worst]:.3g} % ({res.base_names[worst]})")
    print("\n".join(lines))

    # Residuals are cross-correlated with the identifiable columns only (the base set of the
    # largest structure): the others are zero or repeats for every motion of this arm (link 1
    # only turns about its axis), so no trajectory could excite them and they test nothing.
    keep = list(fits["rigid+friction+offset"][0].base_columns)
    keep_names = [columns[c] for c in keep]
    texts = []
    for k in (2, 3):
        val = runs[k]
        y = regs[k]
        preds = {name: (res.predict(y[:, :, cols]), res.rank) for name, (res, cols) in fits.items()}
        preds["CAD URDF"] = (cad.predict(*motion(val)), 0)
        preds["identified URDF"] = (identified_urdf.predict(*motion(val)), n_inertial + 2 * n)
        what = "repeats run 1's trajectory" if k == 2 else "a different trajectory"
        say(f"comparing the candidates on run {k} ({what})")
        common = dict(sample_rate=val["sample_rate"], joint_names=joints, column_names=keep_names,
                      q=val["positions"], dq=val["velocities"], ddq=val["accelerations"],
                      estimation={"q": est["positions"], "regressor": regs[1][:, :, keep], "tau": est["torques"]})
        t0 = time.perf_counter()
        y_keep = np.ascontiguousarray(y[:, :, keep])
        cmp = dynval.compare(val["torques"], {name: (p, n_params, y_keep) for name, (p, n_params) in preds.items()},
                             **common)
        say(f"compared in {time.perf_counter() - t0:.1f} s")
        text = f"\n{'=' * 100}\nValidation on run {k} ({what})\n{'=' * 100}\n{cmp.summary()}"
        print(text)
        texts.append(text)
        if not args.no_figures:
            from dynval import html, plot

            chosen = cmp.verdict.model or cmp.ranking[0]
            rep = cmp.reports[chosen]
            prefix = out / f"run{k}"
            window = (0.0, 10.0)
            files = [
                plot.save(plot.metrics(cmp, title=f"Per-joint fit on run {k} ({what})"), f"{prefix}_metrics.png"),
                plot.save(plot.prediction(val["torques"], preds[chosen][0], report=rep, model_name=chosen,
                                          window=window), f"{prefix}_prediction.png"),
                plot.save(plot.autocorrelation(rep, title=f"Residual autocorrelation — {chosen}, run {k}"),
                          f"{prefix}_autocorrelation.png"),
            ]
            if rep.cross_correlation is not None:
                fig = plot.cross_correlation(rep, title=f"Residual × regressor column, {chosen}, run {k}")
                files.append(plot.save(fig, f"{prefix}_cross_correlation.png"))
            if getattr(rep, "spectrum", None) is not None:
                files.append(plot.save(plot.spectrum(rep, title=f"Residual spectrum — {chosen}, run {k}"),
                                       f"{prefix}_spectrum.png"))
            t0 = time.perf_counter()
            files.append(html.write_report(
                cmp, f"{prefix}_report.html", tau_meas=val["torques"],
                tau_pred={name: p for name, (p, _) in preds.items()},
                title=f"KUKA LWR4+: candidates validated on run {k}",
                intro=f"Identified on run 1, validated on run {k} ({what}). Data: FloBaRoID (LGPL-3.0), "
                      f"read from {data_dir}."))
            say("wrote " + ", ".join(Path(f).name for f in files) + f" (report {time.perf_counter() - t0:.1f} s)")
    (out / "summary.txt").write_text("\n".join(lines) + "\n" + "\n".join(texts) + "\n", encoding="utf-8")
    say(f"done in {time.perf_counter() - start:.1f} s; outputs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
