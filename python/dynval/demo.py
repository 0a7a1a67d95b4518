"""The embedded demonstration: from a simulated robot to a decision, with pictures.

``dynval demo [--scenario NAME] [--out DIR]`` needs no input. It simulates the 2-DOF arm of
:mod:`dynval.simulate` in one of its scenarios (``friction`` by default), identifies the three
candidate model structures — rigid body, + friction, + friction and torque offsets — by least
squares on an estimation trajectory (:func:`dynval.identify.identify`), predicts a *different*
validation trajectory with each, validates every prediction with :func:`dynval.validate`
(cross-correlating the residual with every candidate column, so a missing term is named),
compares them with :func:`dynval.compare`, and prints the decision table, the findings of the
chosen model and the verdict. With ``--out DIR`` it also writes the figures (PNG), the whole
result as JSON and one self-contained HTML report.

Scenarios and what they teach: ``rigid`` (no deficiency: the simplest model is enough),
``friction`` (the friction model wins and its residuals are white), ``flexible`` (an elastic
joint: an oscillation at the simulated mode frequency, the lesson's Problem 5), ``offset`` (a
torque-sensor offset needs its own column) and ``repeat`` (validating on the estimation
trajectory: a design warning, whatever the model).

The physics (regressor, parameters, trajectories) lives in :mod:`dynval.simulate`; the names
below are re-exported for existing users.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .simulate import (  # noqa: F401 - re-exported
    CANDIDATES,
    COLUMN_NAMES,
    DEFAULT_ARM,
    GRAVITY,
    PARAMETER_NAMES,
    SCENARIOS,
    ArmParameters,
    SimulatedData,
    base_parameters,
    fourier_trajectory,
    regressor,
    simulate,
)

if TYPE_CHECKING:
    from .checks._typing import BackendName, ProfileName
    from .comparison._compare import ComparisonReport

__all__ = [
    "ArmParameters",
    "DEFAULT_ARM",
    "GRAVITY",
    "PARAMETER_NAMES",
    "SCENARIOS",
    "base_parameters",
    "regressor",
    "fourier_trajectory",
    "DemoResult",
    "run_demo",
    "readme_figure",
    "main",
]


def _stderr(msg: str) -> None:
    print(f"[dynval demo] {msg}", file=sys.stderr, flush=True)


@dataclass
class DemoResult:
    """Everything :func:`run_demo` computed.

    ``data`` is the :class:`dynval.simulate.SimulatedData`; ``identified``, ``predictions`` and
    ``reports`` map each candidate name to its :class:`dynval.identify.IdentificationResult`,
    predicted validation torques ``(N, 2)`` and :class:`dynval.ValidationReport`; ``comparison``
    is the :func:`dynval.compare` result (None if this build has no ``compare``), and ``chosen``
    the chosen candidate's name. ``files`` lists what was written with ``out``.
    """

    scenario: str
    data: SimulatedData
    identified: dict
    predictions: dict
    reports: dict
    comparison: ComparisonReport | None
    chosen: str
    files: list = field(default_factory=list)

    @property
    def names(self) -> list:
        return list(self.identified)

    def to_dict(self) -> dict:
        """JSON-ready dictionary: the scenario, every identification and report, the comparison."""
        from .checks._json import to_jsonable

        d = self.data
        out = {
            "demo": "2-DOF planar arm in a vertical plane",
            "scenario": self.scenario,
            "description": d.description,
            "seed": d.seed,
            "n_samples": d.n_samples,
            "sample_rate_hz": d.sample_rate,
            "torque_noise_std": d.noise,
            "mode_frequency_hz": d.mode_frequency,
            "true_parameters": dict(d.true_parameters),
            "chosen": self.chosen,
            "models": {
                name: {"identification": self.identified[name].to_dict(),
                       "report": self.reports[name].to_dict()}
                for name in self.names
            },
            "comparison": self.comparison.to_dict() if self.comparison is not None else None,
        }
        return to_jsonable(out)

    def summary(self) -> str:
        """Readable text: the set-up, the identified parameters, the decision table, findings, verdict."""
        return _format_result(self)


def _accepts(func, name) -> bool:
    try:
        params = inspect.signature(func).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def run_demo(scenario: str = "friction", out=None, progress=_stderr, *, seed: int = 0, n_samples: int = 2000,
             noise: float = 0.2, profile: ProfileName = "lesson", backend: BackendName | None = None) -> DemoResult:
    """Simulate a scenario, identify the candidates, validate and compare them.

    Parameters
    ----------
    scenario : str
        One of :data:`dynval.simulate.SCENARIOS`.
    out : str or Path or None
        Directory to write the figures, ``demo.json`` and ``report.html`` into (created).
    progress : callable or None
        Called with a short message before each step (default: a line on stderr).
    seed, n_samples, noise : see :func:`dynval.simulate.simulate`.
    profile, backend : passed to :func:`dynval.validate`.

    Examples
    --------
    >>> from dynval.demo import run_demo
    >>> result = run_demo("friction", n_samples=500, progress=None)
    >>> result.names
    ['rigid', 'friction', 'friction+offset']
    """
    from .comparison._compare import compare
    from .identify import identify

    say = progress or (lambda msg: None)
    say(f"simulating scenario '{scenario}': estimation and validation trajectories")
    d = simulate(scenario, seed=seed, n_samples=n_samples, noise=noise)
    est, val = d.estimation, d.validation
    common: dict[str, Any] = dict(sample_rate=d.sample_rate, joint_names=list(d.joint_names),
                  column_names=list(d.full_column_names), q=val.q,
                  estimation={"q": est.q, "regressor": est.full_regressor, "tau": est.tau_meas})

    identified, predictions, reports = {}, {}, {}
    for name in d.candidates:
        cols = d.column_names[name]
        say(f"identifying '{name}' ({len(cols)} columns) by least squares on the estimation trajectory")
        res = identify(est.regressors[name], est.tau_meas, column_names=cols)
        identified[name] = res
        predictions[name] = res.predict(val.regressors[name])

    say("validating and comparing the candidates on the validation trajectory")
    kwargs = dict(common)
    for key, value in (("profile", profile), ("backend", backend)):
        if _accepts(compare, key):
            kwargs[key] = value
    comparison = compare(val.tau_meas, {name: (predictions[name], identified[name].rank, val.full_regressor)
                                        for name in d.candidates}, **kwargs)
    reports = dict(comparison.reports)
    chosen = comparison.verdict.model or comparison.ranking[0]

    result = DemoResult(scenario=scenario, data=d, identified=identified, predictions=predictions,
                        reports=reports, comparison=comparison, chosen=chosen)
    if out is not None:
        _write_outputs(result, Path(out), say)
    return result


def _write_outputs(result: DemoResult, out: Path, say) -> None:
    out.mkdir(parents=True, exist_ok=True)
    d = result.data
    val = d.validation
    say(f"writing JSON to {out / 'demo.json'}")
    path = out / "demo.json"
    path.write_text(json.dumps(result.to_dict(), indent=1, allow_nan=False, ensure_ascii=False), encoding="utf-8")
    result.files.append(str(path))
    try:
        from . import plot
    except ImportError:  # pragma: no cover
        plot = None
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        say("matplotlib is not installed: no figures (pip install 'dynval[plot]')")
        plot = None
    chosen = result.chosen
    rep = result.reports[chosen]
    band = result.identified[chosen].prediction_interval(val.regressors[chosen])
    if plot is not None:
        say(f"writing figures to {out}")
        figures = [
            ("prediction.png", plot.prediction(
                val.tau_meas, result.predictions[chosen], report=rep, model_name=chosen, window=(0.0, 10.0),
                interval=band)),
            ("residuals.png", plot.residuals(val.tau_meas, result.predictions[chosen], report=rep,
                                             title=f"Residual torque per joint — {chosen}")),
            ("autocorrelation.png", plot.autocorrelation(
                rep, title=f"Residual autocorrelation per joint — {chosen}")),
            ("autocorrelation_candidates.png", plot.autocorrelation_by_model(result.reports, joint=0, chosen=chosen)),
            ("metrics.png", plot.metrics(result.comparison if result.comparison is not None else result.reports,
                                         chosen=chosen)),
        ]
        if rep.cross_correlation is not None:
            figures.append(("cross_correlation.png", plot.cross_correlation(
                rep, title=f"Residual × regressor cross-correlation — {chosen}")))
        if getattr(rep, "spectrum", None) is not None:
            figures.append(("spectrum.png", plot.spectrum(
                rep, reference=d.mode_frequency, reference_label="simulated mode",
                title=f"Residual spectrum per joint — {chosen}")))
        for fname, fig in figures:
            result.files.append(plot.save(fig, out / fname))
    say(f"writing the HTML report to {out / 'report.html'}")
    from .html import write_report

    intro = (f"Scenario '{d.scenario}': {d.description}. {d.n_samples} samples at {d.sample_rate:g} Hz per "
             f"trajectory, torque noise σ = {d.noise:g} N·m; identified on one trajectory, validated on "
             + ("the same trajectory (new noise)." if d.scenario == "repeat" else "a different one."))
    target = result.comparison if result.comparison is not None else rep
    extra = []
    if result.comparison is None and plot is not None:
        extra.append((plot.metrics(result.reports, chosen=chosen),
                      "Per-joint VAF, fit and R² of every candidate."))
    path = write_report(target, out / "report.html", tau_meas=val.tau_meas,
                        tau_pred=result.predictions if result.comparison is not None else result.predictions[chosen],
                        title=f"dynval demo — scenario '{d.scenario}'", intro=intro, figures=extra,
                        reference_frequency=d.mode_frequency, reference_label="simulated mode",
                        interval={chosen: band} if result.comparison is not None else band)
    result.files.append(path)


def _format_result(result: DemoResult) -> str:
    d = result.data
    names = result.names
    lines = [
        f"dynval demo: 2-DOF planar arm in a vertical plane — scenario '{d.scenario}'",
        f"  true system: {d.description}",
        f"  torque noise σ = {d.noise:g} N·m; {d.n_samples} samples at {d.sample_rate:g} Hz per trajectory "
        f"(seed {d.seed})",
        "  identified by least squares on the estimation trajectory, validated on "
        + ("the SAME trajectory (new noise)" if d.scenario == "repeat" else "a different trajectory"),
    ]
    if d.mode_frequency:
        lines.append(f"  elastic joint 2: simulated mode at {d.mode_frequency:.3g} Hz")
    lines += ["", "Identified parameters (estimate ± std, %σ)"]
    header = f"  {'name':<7}{'true':>9}"
    for n in names:
        header += f"{n:>27}"
    lines.append(header)
    for c in COLUMN_NAMES:
        row = f"  {c:<7}{d.true_parameters[c]:>9.4f}"
        for n in names:
            res = result.identified[n]
            if c in res.column_names and res.column_names.index(c) in res.base_columns:
                i = res.base_columns.index(res.column_names.index(c))
                row += f" {res.estimate[i]:9.4f} ± {res.std[i]:<8.2g}{res.rel_std_percent[i]:6.1f}%"
            else:
                row += f"{'—':>27}"
        lines.append(row)
    lines += ["  condition number of the estimation regressor: " +
              ", ".join(f"{n} {result.identified[n].condition_number:.3g}" for n in names)]

    if result.comparison is not None and hasattr(result.comparison, "summary"):
        # The comparison's text holds the decision table, the chosen model's findings and the verdict.
        lines += ["", "=" * 78, "Comparison on the validation trajectory", "=" * 78, result.comparison.summary()]
    else:
        lines += ["", "=" * 78, "Decision table (validation trajectory, pooled over joints)", "=" * 78]
        lines.append(f"  {'model':<17}{'params':>7}{'RMSE':>9}{'VAF %':>9}{'AIC':>11}{'BIC':>11}"
                     f"{'LB log10 p (per joint)':>26}")
        for n in names:
            rep = result.reports[n]
            ic = rep.information_criteria
            lb = rep.ljung_box
            lbp = (" ".join(f"{v / math.log(10):.1f}" for v in np.asarray(lb["log_pvalue"])[0])
                   if lb is not None else "—")
            mark = " *" if n == result.chosen else ""
            lines.append(f"  {n + mark:<17}{rep.provenance['n_params']:>7}{rep.pooled['rmse_per_element']:>9.4f}"
                         f"{rep.pooled['vaf']:>9.3f}{ic['aic']:>11.1f}{ic['bic']:>11.1f}{lbp:>26}")
        lines.append("  * lowest BIC (this build has no dynval.compare: no verdict)")
        rep = result.reports[result.chosen]
        lines += ["", "=" * 78, f"Findings for the chosen model '{result.chosen}'", "=" * 78]
        findings = getattr(rep, "findings", None)
        if findings is None:
            lines += [f"  - {t}" for t in (getattr(rep, "warnings_text", []) or [])] or ["  none"]
        elif not findings:
            lines.append("  none: nothing in the residuals calls for a change")
        else:
            for f in findings:
                lines.append(f"  [{f.severity}] {f.message}")
                if getattr(f, "action", ""):
                    lines.append(f"      → {f.action}")
    if result.files:
        lines += ["", "Files written:"] + [f"  {f}" for f in result.files]
    return "\n".join(lines)


def readme_figure(path, *, scenario: str = "friction", seed: int = 0) -> str:
    """Write the README's figure: residual autocorrelation of each candidate in a scenario."""
    from . import plot

    result = run_demo(scenario, progress=None, seed=seed)
    fig = plot.autocorrelation_by_model(result.reports, joint=0, chosen=result.chosen)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return plot.save(fig, path, dpi=100)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Arguments of ``dynval demo``."""
    if parser is None:
        parser = argparse.ArgumentParser(prog="dynval demo")
    parser.description = (
        "Simulate a 2-DOF arm in a scenario, identify three candidate models (rigid body, + friction, "
        "+ friction and offsets) on one trajectory, validate and compare them on another, and print the "
        "decision table, the findings and the verdict. Scenarios: " + ", ".join(SCENARIOS) + ".")
    parser.add_argument("--scenario", default="friction", choices=SCENARIOS,
                        help="what the simulated arm has (default friction)")
    parser.add_argument("--out", default=None, metavar="DIR",
                        help="also write figures (PNG), demo.json and report.html into DIR")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--n-samples", type=int, default=2000,
                        help="samples per trajectory at 100 Hz (default 2000)")
    parser.add_argument("--noise", type=float, default=0.2,
                        help="torque sensor noise standard deviation in N·m (default 0.2)")
    parser.add_argument("--profile", default="lesson",
                        help="convention profile: lesson, matlab, statsmodels, sklearn (default lesson)")
    parser.add_argument("--backend", default=None, help="computation backend (python or cpp)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of the text report")
    return parser


def main(argv=None) -> int:
    """Entry point of ``dynval demo`` (and ``python -m dynval.demo``); returns the exit code.

    ``python -m dynval.demo --readme-figure PATH`` regenerates the README's figure.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--readme-figure"]:
        if len(argv) != 2:
            print("usage: python -m dynval.demo --readme-figure PATH", file=sys.stderr)
            return 2
        print(readme_figure(argv[1]))
        return 0
    args = build_parser().parse_args(argv)
    return run_from_args(args)


def run_from_args(args) -> int:
    """Run the demo for parsed arguments (shared with :mod:`dynval.cli`)."""
    if args.n_samples < 200:
        print(f"dynval demo: error: --n-samples must be at least 200, got {args.n_samples}", file=sys.stderr)
        return 2
    if not (args.noise >= 0.0 and np.isfinite(args.noise)):
        print(f"dynval demo: error: --noise must be a finite number >= 0, got {args.noise}", file=sys.stderr)
        return 2
    result = run_demo(getattr(args, "scenario", "friction"), out=getattr(args, "out", None), progress=_stderr,
                      seed=args.seed, n_samples=args.n_samples, noise=args.noise, profile=args.profile,
                      backend=args.backend)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2, allow_nan=False, ensure_ascii=False))
    else:
        print(result.summary())
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
