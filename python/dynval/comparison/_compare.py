"""``dynval.compare``: candidate models side by side, a ranking and the lesson's decision.

The rule (docs/conventions.md §6), applied in this order and reported with its reasons:

1. **redesign** when a candidate's report has a ``design`` finding (``low_information``: the
   best-ranked candidate's, unless it lies only on joints found deficient with a term below
   detection while another deficiency was resolved; the validation run repeats the
   estimation run; columns excited in the estimation run but not in the validation run; an
   ill-conditioned validation regressor);
2. **refine** the best-ranked model when it has a ``deficiency`` finding: each deficiency names
   the term to add and the evidence;
3. **redesign** when no deficiency explains it but every candidate's residual fails the whiteness
   test at the information rate (whiteness cannot discriminate these models on this data);
4. **accept** the best-ranked model otherwise.

Ranking: candidates without a deficiency first, then by the chosen criterion (the lesson's AIC by
default; ``criterion=`` picks bic, aicc or an N_eff-based variant), ties by name.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from ..checks import _validation as v
from ..checks._json import to_frame, to_jsonable
from ..checks._typing import ArrayLike, FloatArray, Integer
from ..report._findings import Finding
from ..report._prepared import PreparedRegressor, prepare_regressor
from ..report._ranking import Ranked, first_reason, rank, share_text
from ..report._report import ValidationReport, validate
from ._reasons import candidate_reasons, column_name, joint_name

__all__ = ["compare", "ComparisonReport", "Verdict", "Decisive", "CRITERIA", "DECISIONS"]

CRITERIA = ("aic", "bic", "aicc", "aic_neff", "bic_neff", "aicc_neff")
DECISIONS = ("accept", "refine", "redesign")

#: One candidate of :func:`compare`: ``(prediction, n_params)``, ``(prediction, n_params, regressor)``
#: or a mapping with "prediction", "n_params" and optionally "regressor", "model_columns".
CandidateSpec = tuple[ArrayLike, Integer] | tuple[ArrayLike, Integer, ArrayLike | None] | list[Any] | dict[str, Any]


@dataclass(frozen=True)
class Decisive:
    """A finding that decided the verdict, named by the candidate whose report holds it.

    Attributes
    ----------
    model : str
        The candidate whose report holds the finding (the best-ranked one first when several hold
        the same finding); ``""`` for a finding of the comparison itself (whiteness cannot
        discriminate).
    kind, severity : str
        The finding's ``kind`` (see :data:`dynval.report._findings.KINDS`) and ``severity``.
    joints, columns : tuple of str
        The joint and regressor-column names it concerns (strongest first); names from the
        report's ``joint_names``/``column_names``, else "joint 1", "column 1", ...
    message : str
        The finding's message, its evidence in plain words.
    share, share_basis : float or None, str or None
        The share of the joint's residual mean square the finding explains and where it was
        measured (``"held_out"``: carried from the estimation run; ``"validation"``), None for a
        kind without such a share (conventions §5.10).
    shared : bool
        Every candidate's report has a finding of the same kind on the same joints (or, without
        joints, the same columns): it does not tell the candidates apart.
    """

    model: str
    kind: str
    severity: str
    joints: tuple[str, ...] = ()
    columns: tuple[str, ...] = ()
    message: str = ""
    share: float | None = None
    share_basis: str | None = None
    shared: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, "kind": self.kind, "severity": self.severity, "joints": list(self.joints),
                "columns": list(self.columns), "message": self.message, "share": self.share,
                "share_basis": self.share_basis, "shared": self.shared}

    def label(self) -> str:
        """A short name for the text: "oscillation on shoulder (deficiency of friction)", with the
        share of the residual it explains and "shared by all candidates" when they apply."""
        where = ", ".join(self.joints + self.columns)
        owner = f"{self.severity} of {self.model}" if self.model else f"{self.severity} of the comparison"
        extra = "".join([f", explains {share_text(self.share)} of the residual" if self.share is not None else "",
                         ", shared by all candidates" if self.shared else ""])
        return f"{self.kind}{' on ' + where if where else ''} ({owner}{extra})"


@dataclass(frozen=True)
class Verdict:
    """The decision of the lesson's flowchart: ``decision`` (accept, refine, redesign), the
    ``model`` it concerns (the best-ranked candidate) and the ``reasons``, each with its numbers.

    ``decided_by`` names the finding(s) that decided it: the design finding(s) for a redesign, the
    best model's deficiencies for refine (a whiteness deficiency only follows from another
    deficiency on its joint, so it is left out unless it is all there is), the comparison's own
    finding when whiteness cannot discriminate, nothing for accept. For refine they are ranked by
    the share of the residual each explains, strongest first (conventions §5.10). ``first_step`` is
    what to do first: the action of the first decisive finding, or "nothing to change" for accept;
    ``first_reason`` says why it is first.
    """

    decision: str
    model: str
    reasons: tuple[str, ...]
    decided_by: tuple[Decisive, ...] = ()
    first_step: str = ""
    first_reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"decision": self.decision, "model": self.model, "reasons": list(self.reasons),
                "decided_by": [d.to_dict() for d in self.decided_by], "first_step": self.first_step,
                "first_reason": self.first_reason}

    def summary(self) -> str:
        """The verdict as text: the decision, what decided it, what to do first, the reasons."""
        from ..report._summary import format_verdict

        return "\n".join(format_verdict(self))

    def __str__(self) -> str:
        return self.summary()


@dataclass
class ComparisonReport:
    """Result of :func:`dynval.compare`.

    Attributes
    ----------
    names : list of str
        Candidates in the order given.
    ranking : list of str
        Candidates, best first.
    criterion : str
        The information criterion used for ranking and Akaike weights.
    table : dict
        ``pooled``: per candidate rmse (per element), vaf, fit_percent, r2, aic, bic, aicc, their Δ to
        the best, akaike_weight, whiteness, bias, n_params, n_deficiencies; ``per_joint``: per candidate
        the per-joint rmse, vaf, fit_percent, r2 (arrays (m,)).
    reports : dict
        Candidate name → its :class:`ValidationReport`.
    verdict : Verdict
    findings : list of Finding
        Findings about the comparison itself (e.g. whiteness cannot discriminate).
    reasons : dict
        Candidate name → tuple of short reasons, in ranking order: one per deficiency or design
        finding of its report (joint and column names, the effect and its threshold, the share of
        the residual it explains, "shared by all candidates"), deficiencies strongest first, or, for
        a candidate with none, one positive reason ("no deficiency: ...", its rank and criterion).
    deciding : dict
        Candidate name → its deficiency and design findings as :class:`Decisive` records, in the
        order of ``reasons``: deficiencies ranked by the share of the residual each explains
        (``share``, ``share_basis``), then design findings; ``shared`` marks a finding every
        candidate has (the same kind on the same joints), which does not tell them apart.
    """

    names: list[str]
    ranking: list[str]
    criterion: str
    table: dict[str, Any]
    reports: dict[str, ValidationReport]
    verdict: Verdict
    findings: list[Finding] = field(default_factory=list)
    reasons: dict[str, tuple[str, ...]] = field(default_factory=dict)
    deciding: dict[str, tuple[Decisive, ...]] = field(default_factory=dict)

    def to_dict(self, *, reports: bool = True) -> dict[str, Any]:
        """JSON-ready dictionary; ``reports=False`` leaves out the candidates' full reports."""
        out = {"names": list(self.names), "ranking": list(self.ranking), "criterion": self.criterion,
               "table": to_jsonable(self.table), "verdict": self.verdict.to_dict(),
               "findings": [f.to_dict() for f in self.findings],
               "reasons": {k: list(r) for k, r in self.reasons.items()},
               "deciding": {k: [x.to_dict() for x in d] for k, d in self.deciding.items()}}
        if reports:
            out["reports"] = {k: r.to_dict() for k, r in self.reports.items()}
        return out

    def to_json(self, *, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def to_frame(self) -> Any:
        """The pooled decision table as a pandas DataFrame (pandas is optional): one row per
        candidate in ranking order (index ``model``), the columns of ``table["pooled"]``."""
        rows = self.table["pooled"]
        keys = list(dict.fromkeys(k for name in self.ranking for k in rows[name]))
        columns = {k: [rows[name].get(k) for name in self.ranking] for k in keys}
        return to_frame(columns, list(self.ranking), "model", "ComparisonReport.to_frame")

    def _repr_html_(self) -> str | None:
        """The comparison as a notebook shows it: verdict, decision table, reasons, each candidate's
        tables and findings (dynval.html)."""
        from ..report import _display

        return _display.render(self)

    def summary(self) -> str:
        from ..report._summary import format_comparison

        return format_comparison(self)

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        return (f"ComparisonReport(candidates={self.names!r}, ranking={self.ranking!r}, "
                f"decision={self.verdict.decision!r}, model={self.verdict.model!r})")


def _candidate(name: str, spec: object) -> tuple[Any, Any, Any, Any]:
    """``(pred, p)``, ``(pred, p, regressor)`` or a mapping with prediction, n_params[, regressor,
    model_columns, parameters]."""
    where = f"candidates[{v.format_value(name)}]"
    if isinstance(spec, dict):
        unknown = set(spec) - {"prediction", "n_params", "regressor", "model_columns", "parameters"}
        if unknown or "prediction" not in spec or "n_params" not in spec:
            raise v.parameter_error(where, "(prediction, n_params[, regressor]) or a mapping "
                                    "with 'prediction', 'n_params' and optionally 'regressor', 'model_columns', "
                                    "'parameters'", spec)
        return spec["prediction"], spec["n_params"], spec.get("regressor"), spec.get("model_columns")
    if isinstance(spec, (tuple, list)) and len(spec) in (2, 3) and v.is_integer(spec[1]):
        return spec[0], spec[1], spec[2] if len(spec) == 3 else None, None
    raise v.parameter_error(where, "(prediction, n_params[, regressor]) or a mapping "
                            "with 'prediction', 'n_params' and optionally 'regressor', 'model_columns', "
                            "'parameters'", spec)


def _shared(regressor: Any, prepared: dict[int, Any]) -> Any:
    """The regressor prepared once per array object (:func:`dynval.prepare_regressor`), so that
    its residual-independent work is shared by the candidates. Only a float64 ndarray is prepared
    here: it needs no conversion, so each ``validate`` still checks it (and words any error) as
    the array itself; anything else is passed on as given."""
    if not (isinstance(regressor, np.ndarray) and regressor.dtype == np.float64 and regressor.flags.c_contiguous):
        return regressor
    if id(regressor) not in prepared:
        prepared[id(regressor)] = (regressor, prepare_regressor(regressor))  # the array held: its id stays its own
    return prepared[id(regressor)][1]


def _parameters(spec: object) -> Any:
    """A candidate's own parameters (``"parameters"`` of its mapping), checked for physical
    consistency by its ``validate`` (contract §8); None otherwise."""
    return spec.get("parameters") if isinstance(spec, dict) else None


def _rejects_whiteness(report: ValidationReport) -> bool:
    return any(f.kind == "whiteness" for f in report.findings)


def _bias_state(report: ValidationReport) -> str:
    kinds = [f.severity for f in report.findings if f.kind == "bias"]
    if "deficiency" in kinds:
        return "biased"
    return "negligible" if kinds else "none"


def compare(
    tau_meas: ArrayLike,
    candidates: Mapping[str, CandidateSpec],
    *,
    criterion: Literal["aic", "bic", "aicc", "aic_neff", "bic_neff", "aicc_neff"] = "aic",
    regressor: ArrayLike | PreparedRegressor | None = None,
    **options: Any,
) -> ComparisonReport:
    """Validate several candidate models on the same data; rank them and give the decision.

    Parameters
    ----------
    tau_meas : array_like, (N,) or (N, m)
        Measured torques of the validation run.
    candidates : mapping
        Name → ``(tau_pred, n_params)``, ``(tau_pred, n_params, regressor)`` or a mapping with
        ``prediction``, ``n_params`` and optionally ``regressor``, ``model_columns`` (the
        columns of the regressor the candidate contains; the others are tested as missing terms)
        and ``parameters`` (the candidate's own parameters, a URDF model or an identification
        result: its physical-consistency findings join its report, contract §8).
    criterion : {"aic", "bic", "aicc", "aic_neff", "bic_neff", "aicc_neff"}
        Criterion of the ranking and of the Akaike weights (the lesson's AIC by default).
    regressor : array_like or PreparedRegressor, optional
        A regressor shared by every candidate that does not bring its own (e.g. the richest
        structure's, so that a term missing from a smaller model can be named). The work on a
        regressor that does not depend on the residual (its Gram matrix, its columns'
        autocorrelations, the excitation section, ...) is done once for all the candidates that
        use it, here and when candidates bring the same array object as their own.
    **options
        Any keyword of :func:`dynval.validate` (profile, level, segments, sample_rate, decimate,
        joint_names, column_names, q, estimation, thresholds, noise_model, backend, ...).

    Returns
    -------
    ComparisonReport

    Examples
    --------
    >>> import numpy as np, dynval
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(2000) / 100.0
    >>> x = np.sin(2 * np.pi * 0.3 * t)
    >>> tau = 3.0 * x + 0.5 * np.sign(x) + rng.normal(0.0, 0.1, t.size)
    >>> cmp = dynval.compare(tau, {"linear": (3.0 * x, 1), "friction": (3.0 * x + 0.5 * np.sign(x), 2)},
    ...                      sample_rate=100.0)
    >>> cmp.ranking, cmp.verdict.decision
    (['friction', 'linear'], 'accept')

    A candidate that reproduces the measurement exactly (SSE = 0) has AIC −inf and ranks first;
    every other is +inf behind it:

    >>> cmp = dynval.compare(tau, {"linear": (3.0 * x, 1), "exact": (tau, 2)}, sample_rate=100.0)
    >>> cmp.ranking, cmp.verdict.reasons[-1]
    (['exact', 'linear'], 'linear: Δaic = +inf')
    """
    if not isinstance(candidates, dict) or not candidates:
        raise v.parameter_error("candidates", "a non-empty mapping of names to (prediction, n_params[, regressor])",
                                candidates)
    if not all(isinstance(k, str) and k for k in candidates):
        raise v.parameter_error("candidates", "a mapping whose keys are non-empty strings", candidates)
    v.check_choice("criterion", criterion, CRITERIA)
    if "n_params" in options:
        raise v.parameter_error("n_params", "given per candidate, not to compare", options["n_params"])
    if "parameters" in options:
        raise v.parameter_error("parameters", "given per candidate, not to compare", options["parameters"])
    reports: dict[str, ValidationReport] = {}
    prepared: dict[int, Any] = {}
    for name, spec in candidates.items():
        pred, p, reg, cols = _candidate(name, spec)
        reg = _shared(reg if reg is not None else regressor, prepared)
        reports[name] = validate(tau_meas, pred, n_params=p, regressor=reg, model_columns=cols,
                                 parameters=_parameters(spec), **options)
    names = list(candidates)
    if any(criterion not in reports[n].information_criteria for n in names):
        raise v.parameter_error("criterion", "one of 'aic', 'bic', 'aicc' when max_lag=0 (no N_eff)", criterion)
    crit = {n: reports[n].information_criteria[criterion] for n in names}
    deficient = {n: len(reports[n].deficiencies) for n in names}

    def key(n: str) -> tuple[bool, float, str]:
        c = crit[n]
        return (deficient[n] > 0, math.inf if math.isnan(c) else c, n)

    ranking = sorted(names, key=key)
    delta = _deltas(crit)
    weights_raw = {n: 0.0 if math.isnan(d) else math.exp(-0.5 * d) for n, d in delta.items()}
    total = sum(weights_raw.values())
    pooled: dict[str, dict[str, Any]] = {}
    per_joint: dict[str, dict[str, FloatArray]] = {}
    for n in names:
        r = reports[n]
        ic = r.information_criteria
        row = {"n_params": ic["n_params"], "rmse": r.pooled["rmse_per_element"], "vaf": r.pooled["vaf"],
               "fit_percent": r.pooled["fit_percent"], "r2": r.pooled["r2"]}
        for c in ("aic", "bic", "aicc"):
            row[c] = ic[c]
            row[f"delta_{c}"] = _deltas({k: reports[k].information_criteria[c] for k in names})[n]
        if criterion not in ("aic", "bic", "aicc"):
            row[criterion] = crit[n]
            row[f"delta_{criterion}"] = delta[n]
        row["akaike_weight"] = weights_raw[n] / total if total > 0 else math.nan
        row["whiteness"] = ("not analysed" if r.whiteness is None
                            else "not white" if _rejects_whiteness(r) else "white")
        row["bias"] = "not analysed" if r.bias is None else _bias_state(r)
        row["n_deficiencies"] = deficient[n]
        pooled[n] = row
        per_joint[n] = {k: np.asarray(r.per_joint[k]) for k in ("rmse", "vaf", "fit_percent", "r2")}
    table = {"pooled": pooled, "per_joint": per_joint}
    matter = _matter(names, reports)
    for n in names:
        pooled[n]["strongest_share"] = next((x.share for f, x, _ in matter[n]
                                             if f.severity == "deficiency" and x.leads and x.share is not None), None)
        pooled[n]["n_shared"] = sum(1 for f, _, sh in matter[n] if sh and f.severity == "deficiency")
    findings, verdict = _verdict(names, ranking, reports, criterion, crit, matter)
    return ComparisonReport(names=names, ranking=ranking, criterion=criterion, table=table, reports=reports,
                            verdict=verdict, findings=findings,
                            reasons=candidate_reasons(ranking, reports, criterion, crit, matter),
                            deciding={n: tuple(_decisive(n, reports[n], f, x, sh) for f, x, sh in matter[n])
                                      for n in ranking})


def _deltas(values: dict[str, float]) -> dict[str, float]:
    """Each criterion minus the smallest that is not NaN; the smallest itself 0, also when it is
    −inf (an exact prediction), so that it takes the whole Akaike weight. NaN stays NaN."""
    known = [x for x in values.values() if not math.isnan(x)]
    if not known:
        return {n: math.nan for n in values}
    lo = min(known)
    return {n: 0.0 if x == lo else x - lo for n, x in values.items()}


def _decisive(model: str, report: ValidationReport, f: Finding, ranked: Ranked | None = None,
              shared: bool = False) -> Decisive:
    share = None if ranked is None else ranked.share
    return Decisive(model=model, kind=f.kind, severity=f.severity,
                    joints=tuple(joint_name(report, j) for j in f.joints),
                    columns=tuple(column_name(report, c) for c in f.columns), message=f.message,
                    share=share, share_basis=None if share is None or ranked is None else ranked.basis,
                    shared=shared)


def _record(f: Finding) -> tuple[str, tuple[int, ...], tuple[int, ...]]:
    """A finding as its record says it (kind, joints, columns): never its words."""
    return f.kind, tuple(f.joints), tuple(f.columns)


def _covers(report: ValidationReport, f: Finding) -> bool:
    """``report`` has a deficiency or design finding of ``f``'s kind on each of ``f``'s joints (on
    the same columns for a finding without joints)."""
    same = [g for g in report.findings if g.kind == f.kind and g.severity in ("deficiency", "design")]
    if f.joints:
        return set(f.joints) <= {j for g in same for j in g.joints}
    return any(not g.joints and set(g.columns) == set(f.columns) for g in same)


def _matter(names: list[str], reports: dict[str, ValidationReport]) -> dict[str, list[tuple[Finding, Ranked, bool]]]:
    """Every candidate's deficiency and design findings: the deficiencies ranked by the share of the
    residual each explains (conventions §5.10), then the design findings; each with whether every
    candidate has it (the same kind on the same joints): a finding all share does not tell them apart."""
    out = {}
    for n in names:
        r = reports[n]
        per_joint = getattr(r, "per_joint", None)
        ranked = rank([f for f in r.findings if f.severity == "deficiency"],
                      None if per_joint is None else per_joint["r2"])
        ranked += [Ranked(f, None, "validation", None) for f in r.findings if f.severity == "design"]
        out[n] = [(x.finding, x, len(names) > 1 and all(_covers(reports[o], x.finding) for o in names if o != n))
                  for x in ranked]
    return out


def _defers(f: Finding, report: ValidationReport) -> bool:
    """A ``low_information`` finding only on joints found deficient with a term below what the run
    can detect (``details["unresolved"]``) does not decide while the candidate has a deficiency the
    run did resolve: fixing that comes first, and the finding is given with it."""
    unresolved = set((f.details or {}).get("unresolved") or ())
    if not unresolved or not set(f.joints) <= unresolved:
        return False
    return any(d.kind != "whiteness" and not set(d.joints) <= unresolved for d in report.deficiencies)


def _verdict(names: list[str], ranking: list[str], reports: dict[str, ValidationReport], criterion: str,
             crit: dict[str, float],
             matter: dict[str, list[tuple[Finding, Ranked, bool]]] | None = None) -> tuple[list[Finding], Verdict]:
    best = ranking[0]
    matter = _matter(names, reports) if matter is None else matter
    findings: list[Finding] = []
    reasons: list[str] = []
    decided: list[Decisive] = []
    first = ""
    seen = set()
    for n in ranking:
        shared = {id(f): sh for f, _, sh in matter[n]}
        for f in reports[n].findings:
            # A run that cannot decide is judged on the candidate the decision is about: how few
            # effective samples the noise leaves depends on what each candidate's residual holds.
            if f.kind == "low_information" and (n != best or _defers(f, reports[n])):
                continue
            rec = _decisive(n, reports[n], f, shared=shared.get(id(f), False))
            if f.severity == "design" and (rec.kind, rec.joints, rec.columns) not in seen:
                seen.add((rec.kind, rec.joints, rec.columns))  # the record, not the words, says it is the same
                reasons.append(f"{f.message} ({f.action})")
                decided.append(rec)
                first = first or f.action
    if reasons:
        return findings, Verdict("redesign", best, tuple(reasons), tuple(decided), first,
                                 "the experiment cannot answer yet: a design finding comes before any model's "
                                 "deficiency")
    deficiencies = [(f, x, sh) for f, x, sh in matter[best] if f.severity == "deficiency"]
    if deficiencies:
        # Ranked by the share of the residual each explains; a whiteness deficiency only follows
        # from another deficiency on its joint (conventions §5): the other decides.
        primary = [t for t in deficiencies if t[0].kind != "whiteness"] or deficiencies
        deferred = [f for f in reports[best].findings if f.kind == "low_information"]
        r = reports[best]
        return findings, Verdict(
            "refine", best, tuple(f"{f.message} → {f.action}" for f, _, _ in deficiencies)
            + tuple(f"{f.message} ({f.action})" for f in deferred),
            tuple(_decisive(best, r, f, x, sh) for f, x, sh in primary), primary[0][0].action,
            first_reason([x for _, x, _ in primary], r.provenance.get("joint_names")))
    analysed = [n for n in names if reports[n].whiteness is not None]
    if len(analysed) >= 2 and all(_rejects_whiteness(reports[n]) for n in analysed):
        # No deficiency explains the best model's colour, and every candidate has it.
        msg = ("whiteness cannot discriminate these models on this data: every candidate's residual is coloured "
               "at the information rate, so the whiteness test says nothing about which is better")
        own = Finding(kind="whiteness", severity="design", action=(
            "log less-filtered torques, or validate at a rate where the noise is white; meanwhile rank on "
            "the criteria and the other findings"), message=msg[0].upper() + msg[1:] + ".")
        findings.append(own)
        return findings, Verdict("redesign", best, (msg + f" (best on {criterion}: {best})",),
                                 (Decisive(model="", kind=own.kind, severity=own.severity, message=own.message),),
                                 own.action)
    r = reports[best]
    reason = (f"{best} has no deficiency finding at α = {1 - r.provenance['conventions']['level']:g} "
              f"(Holm over its report) and the lowest {criterion} among such candidates "
              f"({crit[best]:.2f})")
    extra = []
    for n in ranking[1:]:
        d = len(reports[n].deficiencies)
        top = next((x for f, x, _ in matter[n] if f.severity == "deficiency"), None)
        extra.append(f"{n}: Δ{criterion} = {crit[n] - crit[best]:+.2f}"
                     + (f", {d} deficiency finding{'s' if d != 1 else ''}" if d else "")
                     + (f" (the strongest, {top.finding.kind}, explains {share_text(top.share)} of the residual)"
                        if top is not None and top.share is not None else ""))
    return findings, Verdict("accept", best, tuple([reason] + extra), (), f"nothing to change: use {best}")
