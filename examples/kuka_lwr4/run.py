"""KUKA LWR4+ measurements (FloBaRoID): identify on one run, validate and compare on the others.

    python3 examples/kuka_lwr4/run.py [--out DIR] [--no-figures] [--readme] [--data DIR]

The data are the three logged runs of the FloBaRoID project (LGPL-3.0), shipped inside dynval and
loaded with ``dynval.datasets.load_kuka_lwr4`` (its ``DESCR`` says where they come from). ``--data
DIR`` (or ``$DYNVAL_KUKA_DATA``) reads another directory in FloBaRoID's layout instead
(``data/measurements_{1,2,3}.npz``, ``model/kuka_lwr4.urdf``, ``model/kuka_lwr4_identified.urdf``).
Without pinocchio (``pip install pin``, the ``robots`` extra) the script says so and exits.

Candidates, each predicting the validation runs' torques:

* ``rigid``: base parameters of the URDF regressor (rigid body only), identified on run 1;
* ``rigid+friction``: + viscous and Coulomb friction per joint;
* ``rigid+friction+offset``: + a torque offset per joint;
* ``CAD URDF``: the a-priori model ``kuka_lwr4.urdf`` (RNEA on its inertials, plus its
  ``<dynamics>`` friction), nothing fitted here;
* ``identified URDF``: FloBaRoID's ``kuka_lwr4_identified.urdf`` the same way; it was
  identified upstream on these measurements, so it is counted with its 7·10 inertial and
  7·2 friction parameters.

Before the comparison, the physical consistency of the models (``dynval.robots.physical_consistency``):
the two URDFs' links and friction, the distance of each identified base set from every robot that can
exist, and, with cvxpy installed (the ``physical`` extra), the structures with friction identified
again under the constraints (``URDFModel.identify(..., physical=True)``) and their prediction of run 3
against the unconstrained fit's, then ``dynval.compare`` of the least-squares and the constrained fits
on run 3, each candidate bringing its parameters (``"parameters": fit``) so that its realizability
findings are in its report and its ranking. This section is printed and written to ``summary.txt``;
the comparisons below and the README's verdicts block do not use it.

Velocities and accelerations are the logged ones (FloBaRoID filtered them without time shift).
Run 2 repeats run 1's trajectory, run 3 is a different one: run 2 shows what validating on the
estimation trajectory looks like, run 3 is the real test.

``--readme`` writes the verdicts and decision tables of this run into the block of README.md
between ``<!-- verdicts:begin -->`` and ``<!-- verdicts:end -->``, and the numbers it was made from
into ``verdicts.json`` beside it (tests/test_datasets.py checks that the two agree).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

HERE = Path(__file__).resolve().parent
README = HERE / "README.md"
RECORD = HERE / "verdicts.json"
BEGIN, END = "<!-- verdicts:begin -->", "<!-- verdicts:end -->"
COMMAND = "python3 examples/kuka_lwr4/run.py --readme"
RUN_TEXT = {2: "repeats run 1's trajectory", 3: "a different trajectory"}


# ---------------------------------------------------------------------------- data

def load_runs(data_dir: Path | None = None):
    """Runs 1-3 (objects with q, dq, ddq, tau, sample_rate), the two URDF paths and the source's text."""
    if data_dir is None:
        from dynval.datasets import load_kuka_lwr4

        runs = {k: load_kuka_lwr4(k) for k in (1, 2, 3)}
        return runs, runs[1].urdf, runs[1].urdf_identified, "dynval.datasets.load_kuka_lwr4"
    runs = {}
    for k in (1, 2, 3):
        with np.load(data_dir / "data" / f"measurements_{k}.npz") as f:
            t = np.asarray(f["times"], dtype=float)
            runs[k] = SimpleNamespace(run=k, time=t - t[0], q=np.asarray(f["positions"], dtype=float),
                                      dq=np.asarray(f["velocities"], dtype=float),
                                      ddq=np.asarray(f["accelerations"], dtype=float),
                                      tau=np.asarray(f["torques"], dtype=float),
                                      sample_rate=1.0 / float(np.mean(np.diff(t))))
    model = data_dir / "model"
    return runs, model / "kuka_lwr4.urdf", model / "kuka_lwr4_identified.urdf", str(data_dir)


def data_override(arg: str | None) -> Path | None:
    """The directory given by --data or $DYNVAL_KUKA_DATA, checked; None for the packaged data."""
    given = arg or os.environ.get("DYNVAL_KUKA_DATA") or None
    if given is None:
        return None
    path = Path(given)
    missing = [p for p in ["data/measurements_1.npz", "data/measurements_2.npz", "data/measurements_3.npz",
                           "model/kuka_lwr4.urdf", "model/kuka_lwr4_identified.urdf"] if not (path / p).is_file()]
    if missing:
        source = "--data" if arg else "$DYNVAL_KUKA_DATA"
        raise SystemExit(f"kuka_lwr4: {source} {path} is not a FloBaRoID KUKA directory: no {', '.join(missing)}")
    return path


# ---------------------------------------------------------------------------- the README block

def record(k: int, cmp) -> dict:
    """What the README block shows of one comparison: decision table, per-joint R², verdict."""
    rows = []
    for name in cmp.ranking:
        row = cmp.table["pooled"][name]
        rows.append({"model": name, "p": int(row["n_params"]), "rmse": float(row["rmse"]), "vaf": float(row["vaf"]),
                     "r2": float(row["r2"]), "delta_aic": float(row[f"delta_{cmp.criterion}"]),
                     "deficiencies": int(row["n_deficiencies"]),
                     "strongest_share": None if row.get("strongest_share") is None else float(row["strongest_share"]),
                     "r2_per_joint": [float(x) for x in cmp.table["per_joint"][name]["r2"]]})
    v = cmp.verdict
    return {"run": k, "what": RUN_TEXT[k], "criterion": cmp.criterion,
            "joint_names": list(cmp.reports[cmp.names[0]].provenance["joint_names"]), "rows": rows,
            "verdict": {"decision": v.decision, "model": v.model, "first_step": v.first_step,
                        "first_reason": v.first_reason,
                        "decided_by": [{"kind": d.kind, "severity": d.severity, "model": d.model,
                                        "joints": list(d.joints), "columns": list(d.columns)} for d in v.decided_by]}}


def _decided_by(items: list) -> str:
    """The decisive findings grouped by kind: "`missing_physics` (deficiency of M) on a, b, c"."""
    groups: dict = {}
    for d in items:
        groups.setdefault((d["kind"], d["severity"], d["model"]), []).extend(d["joints"] + d["columns"])
    parts = []
    for (kind, severity, model), where in groups.items():
        owner = f"{severity} of {model}" if model else f"{severity} of the comparison"
        parts.append(f"`{kind}` ({owner})" + (" on " + ", ".join(where) if where else ""))
    return "; ".join(parts) if parts else "no finding (nothing stands against the model)"


def _deficiency_cell(row: dict) -> str:
    """The count, and the share of a joint's residual its strongest deficiency explains: the count
    alone reads backwards (a weak model has few large findings, a good one many small ones)."""
    share = row.get("strongest_share")
    if not row["deficiencies"] or share is None:
        return f"{row['deficiencies']}"
    pct = 100.0 * share
    return f"{row['deficiencies']} ({pct:.0f} %)" if pct >= 10 else f"{row['deficiencies']} ({pct:.2g} %)"


def render_block(records: list) -> str:
    """The README block (without its markers) for the records of :func:`record`."""
    out = [f"<!-- Written by `{COMMAND}` from verdicts.json; rerun it instead of editing. -->"]
    for r in records:
        v = r["verdict"]
        short = [j.replace("_joint", "") for j in r["joint_names"]]
        out += ["", f"**Run {r['run']}** ({r['what']}): verdict **{v['decision']}** `{v['model']}`, decided by "
                f"{_decided_by(v['decided_by'])}." + (f" First step: {v['first_step']}." if v["first_step"] else "")
                + (f" ({v['first_reason'][0].upper()}{v['first_reason'][1:]}.)" if v.get("first_reason") else ""),
                "", f"| rank | model | p | RMSE (N·m) | VAF % | R² pooled | Δ{r['criterion'].upper()} | deficiencies "
                + ("(strongest share) " if any(row.get("strongest_share") is not None for row in r["rows"]) else "")
                + "| "
                + " | ".join(f"R² {j}" for j in short) + " |",
                "|---:|---|---:|---:|---:|---:|---:|---:|" + "---:|" * len(short)]
        for i, row in enumerate(r["rows"]):
            out.append(f"| {i + 1} | {row['model']} | {row['p']} | {row['rmse']:.3f} | {row['vaf']:.2f} | "
                       f"{row['r2']:.4f} | {row['delta_aic']:.0f} | {_deficiency_cell(row)} | "
                       + " | ".join(f"{x:.2f}" for x in row["r2_per_joint"]) + " |")
    return "\n".join(out)


def rewrite_block(text: str, block: str) -> str:
    """``text`` with the lines between its one BEGIN and one END marker replaced by ``block``."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(END) < text.index(BEGIN):
        raise ValueError(f"the text must hold one {BEGIN} line followed by one {END} line")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return head + BEGIN + "\n" + block.strip("\n") + "\n" + END + tail


def read_block(text: str) -> str:
    """The block between the markers, as :func:`rewrite_block` writes it."""
    return text.split(BEGIN)[1].split(END)[0].strip("\n")


# ---------------------------------------------------------------------------- physical consistency

def physical_section(cad, identified_urdf, fits, regs, runs) -> list:
    """Lines on the physical consistency of the URDFs and of the fits, and the constrained fits' run 3."""
    import dynval
    from dynval.robots import physical_consistency

    lines = ["", "Physical consistency (dynval.robots.physical_consistency)"]
    for label, model in (("CAD URDF", cad), ("identified URDF", identified_urdf)):
        found = physical_consistency(model)
        lines.append(f"  {label}: {len(found)} finding(s)" + (":" if found else ""))
        lines += [f"    {f.message}" for f in found]
    try:
        import cvxpy  # noqa: F401
    except ImportError:
        lines.append("  (cvxpy is not installed: pip install \".[physical]\" for the base-parameter distance and the "
                     "constrained identification)")
        return lines

    def rmse(run, prediction):
        return float(np.sqrt(np.mean((run.tau - prediction) ** 2)))

    est, val = runs[1], runs[3]
    candidates = {}
    for name in ("rigid+friction", "rigid+friction+offset"):
        res, cols = fits[name]
        found = physical_consistency(res)
        lines.append(f"  {name} (least squares on run 1): " + (found[0].message if found else "a consistent robot"))
        start = time.perf_counter()
        fit = cad.identify(est.q, est.dq, est.ddq, est.tau, offset=name.endswith("offset"), physical=True)
        took = time.perf_counter() - start
        assert physical_consistency(fit) == [], "the constrained fit must be a robot"
        y_est, y_val = regs[1][:, :, cols], regs[3][:, :, cols]
        unconstrained, constrained = rmse(val, res.predict(y_val)), rmse(val, fit.predict(y_val))
        fitted = (rmse(est, fit.predict(y_est)), rmse(est, res.predict(y_est)))
        lines.append(f"    under the constraints (prior: the CAD URDF): RMSE on run 1 {fitted[0]:.3f} N·m (least "
                     f"squares {fitted[1]:.3f}); on run 3 {constrained:.3f} N·m against {unconstrained:.3f}, ratio "
                     f"{constrained / unconstrained:.3f}; identify took {took:.1f} s, the SDP "
                     f"{fit.physical['solve_time']:.2f} s ({fit.physical['solver']})")
        for label, r in (("least squares", res), ("physical", fit)):
            candidates[f"{name}, {label}"] = {"prediction": r.predict(y_val), "n_params": r.rank, "parameters": r}
    # Each candidate brings its parameters: their physical consistency is among its findings, and a
    # candidate that is no robot is deficient, so it ranks after the sound ones.
    candidates["identified URDF"] = {"prediction": identified_urdf.predict(val.q, val.dq, val.ddq),
                                     "n_params": 10 * len(cad.joint_names) + 2 * len(cad.joint_names),
                                     "parameters": identified_urdf}
    cmp = dynval.compare(val.tau, candidates, time=val.time, joint_names=list(cad.joint_names))
    lines += ["", "Unconstrained against physically consistent identification (run 1), validated on run 3, "
              "each candidate with its parameters (compare(..., {name: {..., 'parameters': fit}})):"]
    lines += ["  " + line for line in cmp.summary().split("\n")]
    return lines


# ---------------------------------------------------------------------------- the run

def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="kuka_lwr4_out", help="output directory (default ./kuka_lwr4_out)")
    parser.add_argument("--no-figures", action="store_true", help="tables only")
    parser.add_argument("--readme", action="store_true",
                        help=f"write the verdicts into {README.relative_to(HERE.parents[1])} and {RECORD.name}")
    parser.add_argument("--data", default=None,
                        help="a FloBaRoID KUKA directory to read instead of the packaged data "
                             "(default: $DYNVAL_KUKA_DATA, else dynval.datasets)")
    args = parser.parse_args(argv)

    data_dir = data_override(args.data)
    if args.readme and data_dir is not None:
        parser.error("--readme describes the packaged data: leave out --data and $DYNVAL_KUKA_DATA")
    try:
        import pinocchio  # noqa: F401

        from dynval.robots import URDFModel
    except ImportError:
        print("kuka_lwr4: pinocchio is not installed (pip install pin, or pip install \".[robots]\"); skipping.")
        return 1 if args.readme else 0
    import dynval

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    say = lambda msg: print(f"[kuka_lwr4] {msg}", file=sys.stderr, flush=True)  # noqa: E731

    start = time.perf_counter()
    runs, urdf, urdf_identified, source = load_runs(data_dir)
    cad = URDFModel(urdf)
    identified_urdf = URDFModel(urdf_identified)
    joints = list(cad.joint_names)
    columns = list(cad.column_names())
    est = runs[1]
    say(f"{len(joints)} joints, {len(columns)} regressor columns; runs of "
        + ", ".join(f"{r.q.shape[0]} samples" for r in runs.values())
        + f" at {est.sample_rate:.1f} Hz, from {source}")

    def motion(run):
        return run.q, run.dq, run.ddq

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
        res = identify(regs[1][:, :, cols], est.tau, column_names=[columns[c] for c in cols])
        fits[name] = (res, cols)
        worst = int(np.argmax(res.rel_std_percent))
        lines.append(f"  {name:<24}{len(cols):>8}{res.rank:>6}{res.condition_number:>10.3g}"
                     f"{np.sqrt(res.sigma2):>10.3g}  {res.rel_std_percent[worst]:.3g} % ({res.base_names[worst]})")
    lines += physical_section(cad, identified_urdf, fits, regs, runs)
    print("\n".join(lines))

    # Residuals are cross-correlated with the identifiable columns only (the base set of the
    # largest structure): the others are zero or repeats for every motion of this arm (link 1
    # only turns about its axis), so no trajectory could excite them and they test nothing.
    keep = list(fits["rigid+friction+offset"][0].base_columns)
    keep_names = [columns[c] for c in keep]
    texts, records = [], []
    for k in (2, 3):
        val = runs[k]
        y = regs[k]
        preds = {name: (res.predict(y[:, :, cols]), res.rank) for name, (res, cols) in fits.items()}
        preds["CAD URDF"] = (cad.predict(*motion(val)), 0)
        preds["identified URDF"] = (identified_urdf.predict(*motion(val)), n_inertial + 2 * n)
        what = RUN_TEXT[k]
        say(f"comparing the candidates on run {k} ({what})")
        # the logged stamps set the grid (200.004 Hz nominal; a note counts their irregular steps)
        # FloBaRoID's filtered q̇, q̈ for both runs: one derivative source for the model, the
        # validation test and the estimation run's refits
        common = dict(time=val.time, joint_names=joints, column_names=keep_names,
                      q=val.q, dq=val.dq, ddq=val.ddq,
                      estimation={"q": est.q, "dq": est.dq, "ddq": est.ddq, "regressor": regs[1][:, :, keep],
                                  "tau": est.tau})
        t0 = time.perf_counter()
        y_keep = np.ascontiguousarray(y[:, :, keep])
        # each candidate's own columns among the identifiable ones: the URDF models hold the rigid
        # body and their <dynamics> friction, no offset; the others are tested as missing terms
        held = dict(structures, **{"CAD URDF": structures["rigid+friction"],
                                   "identified URDF": structures["rigid+friction"]})
        own = {name: [i for i, c in enumerate(keep) if c in set(held[name])] for name in preds}
        cmp = dynval.compare(val.tau, {name: {"prediction": p, "n_params": n_params, "regressor": y_keep,
                                              "model_columns": own[name]}
                                       for name, (p, n_params) in preds.items()}, **common)
        say(f"compared in {time.perf_counter() - t0:.1f} s")
        text = f"\n{'=' * 100}\nValidation on run {k} ({what})\n{'=' * 100}\n{cmp.summary()}"
        print(text)
        texts.append(text)
        records.append(record(k, cmp))
        if not args.no_figures:
            from dynval import html, plot

            chosen = cmp.verdict.model or cmp.ranking[0]
            rep = cmp.reports[chosen]
            prefix = out / f"run{k}"
            window = (0.0, 10.0)
            files = [
                plot.save(plot.metrics(cmp, title=f"Per-joint fit on run {k} ({what})"), f"{prefix}_metrics.png"),
                plot.save(plot.prediction(val.tau, preds[chosen][0], report=rep, model_name=chosen,
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
                cmp, f"{prefix}_report.html", tau_meas=val.tau,
                tau_pred={name: p for name, (p, _) in preds.items()},
                title=f"KUKA LWR4+: candidates validated on run {k}",
                intro=f"Identified on run 1, validated on run {k} ({what}). Data: FloBaRoID (LGPL-3.0), "
                      f"read from {source}."))
            say("wrote " + ", ".join(Path(f).name for f in files) + f" (report {time.perf_counter() - t0:.1f} s)")
    (out / "summary.txt").write_text("\n".join(lines) + "\n" + "\n".join(texts) + "\n", encoding="utf-8")
    if args.readme:
        RECORD.write_text(json.dumps({"command": COMMAND, "runs": records}, indent=1, ensure_ascii=False) + "\n",
                          encoding="utf-8")
        README.write_text(rewrite_block(README.read_text(encoding="utf-8"), render_block(records)), encoding="utf-8")
        say(f"wrote the verdicts into {README} and {RECORD.name}")
    say(f"done in {time.perf_counter() - start:.1f} s; outputs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
