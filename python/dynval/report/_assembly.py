"""The one assembler of a validation report: sections in, provenance, evidence, findings, report out.

``validate`` (:mod:`dynval.report._report`) computes the sections from the whole series; the stream
accumulator (:mod:`dynval.stream`) computes the ones mergeable sums allow and leaves the others
None. Both then call :func:`provenance` and :func:`assemble_report`, so a report's provenance, its
evidence and its findings are built one way.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .._version import CONTRACT_VERSION, __version__
from ..checks._json import to_frame, to_jsonable
from ..checks._timing import Timing
from ..metrics._profiles import Profile
from . import _records as rec
from . import _sections as sec
from ._findings import Finding, Thresholds, cell_pvalue_adjusted, compute_findings, holm_family
from ._ranking import Ranked, deciding, first_reason
from ._summary import format_summary

REPORT_SCHEMA_VERSION = 1


@dataclass
class ValidationReport:
    """Result of :func:`dynval.validate`.

    Every section is a typed, read-only record (:mod:`dynval.report._records`) of floats, integers,
    strings and numpy arrays, read as attributes (``report.per_joint.r2``) or as a mapping of the
    contract's names (``report.per_joint["r2"]``, contract §4). Per-joint arrays have shape ``(m,)``; joint, column
    and lag indices are 0-based (the text of :meth:`summary` numbers joints and columns from 1).

    Attributes
    ----------
    provenance : dict
        Profile, every convention used, units, N, m, p, segments, omitted rows, backend,
        versions.
    per_joint : dict
        ``sse``, ``rmse``, ``max_abs_error``, ``vaf``, ``fit_percent``, ``r2``, ``nrmse``.
    pooled : dict
        All N·m values flattened with one mean (the lesson's form): ``sse``,
        ``rmse_per_element``, ``rmse_per_sample``, ``max_abs_error``, ``vaf``,
        ``fit_percent``, ``r2``.
    aggregates : dict
        ``uniform_average`` and ``variance_weighted`` of ``vaf``, ``fit_percent``, ``r2``, and
        ``rmse_uniform_average``.
    residuals : dict
        ``mean``, ``variance``, ``ddof``, ``zero_mean_test``.
    autocorrelation : dict or None
        ``None`` when ``max_lag = 0``.
    ljung_box : dict or None
        ``None`` when ``max_lag = 0`` (a portmanteau statistic needs at least one lag).
    cross_correlation : dict or None
        ``None`` without a regressor.
    information_criteria : dict
        ``noise_model``, ``constant``, ``n_obs``, ``n_params``, ``aic``, ``bic``, ``aicc``,
        ``fpe``, ``naic``.
    warnings_text : list of str
        The findings' messages, in plain words.
    findings : list of Finding
        The findings as records (kind, severity, joints, columns, statistic, p-values, effect,
        threshold, action, message); deficiencies first (docs/conventions.md §5).
    bias : dict or None
        The residual mean tested against its coloured-noise standard error (automatic N_eff).
    whiteness : dict or None
        Ljung–Box at the logged rate and at the information rate (decimated), when lags are analysed.
    spectrum : dict or None
        Welch spectrum of the residual less what the regressor explains, and its peaks.
    design : dict or None
        Distance to the estimation run (``estimation=``) and excitation of the regressor.
    segment_metrics : dict or None
        Per-joint metrics of each named segment (``segments={"name": length, ...}``).
    physics : dict or None
        With ``q``: each joint's residual tested against the library of physical terms (per joint
        ``tests``: statistic, p-value, the share of the mean square the library removes, the term
        named and its share, a delay in seconds, the noise's N_eff).
    predictive : dict or None
        With the estimation run: the validation mean square against what the estimation run's noise
        and Cov(π̂) allow (Chow-type F test; ``ratio`` per joint).
    periodic : dict or None
        With ``q`` holding at least two whole periods: the period, the noise measured from the
        period-to-period variation (any colour) and per joint the test of what every period shares.
    timing : dict or None
        With ``time``: the nominal step and rate, duplicated stamps, repeated rows, gaps (count,
        largest, when), irregular steps, jitter, and the grid the lag and spectral analyses use.
    """

    provenance: rec.Provenance
    per_joint: rec.PerJoint
    pooled: rec.Pooled
    aggregates: rec.Aggregates
    residuals: rec.Residuals
    autocorrelation: rec.Autocorrelation | None
    ljung_box: rec.LjungBox | None
    cross_correlation: rec.CrossCorrelation | None
    information_criteria: rec.InformationCriteria
    warnings_text: list[str] = field(default_factory=list)
    findings: list[Finding] = field(default_factory=list)
    bias: rec.Bias | None = None
    whiteness: rec.Whiteness | None = None
    spectrum: rec.Spectrum | None = None
    design: rec.Design | None = None
    segment_metrics: dict[str, rec.Segment] | None = None
    physics: rec.Physics | None = None
    predictive: rec.Predictive | None = None
    periodic: rec.Periodic | None = None
    timing: rec.Timing | None = None

    @property
    def deficiencies(self) -> list[Finding]:
        """The findings that say the model should change."""
        return [f for f in self.findings if f.severity == "deficiency"]

    @property
    def deciding(self) -> list[Ranked]:
        """The deficiencies ranked by the share of the residual each explains, strongest first
        (whiteness only when it is all there is; docs/conventions.md §5.10)."""
        return deciding(self.findings, self.per_joint["r2"])

    @property
    def first_step(self) -> str:
        """The action of the strongest deciding finding; ``""`` without a deficiency."""
        ranked = self.deciding
        return ranked[0].finding.action if ranked else ""

    @property
    def first_reason(self) -> str:
        """Why the first step is first: its share of the residual against the other deciding findings'."""
        return first_reason(self.deciding, self.provenance.get("joint_names"))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary: nested lists, non-finite numbers as strings.

        Returns
        -------
        dict
            One key per section (contract §4); arrays become nested lists and nan, inf, -inf
            the strings ``"NaN"``, ``"Infinity"``, ``"-Infinity"``.

        Examples
        --------
        >>> import json, dynval
        >>> r = dynval.validate([1.0, 2.0, 3.0, 4.0], [1.1, 1.9, 3.2, 3.9], n_params=1)
        >>> sorted(r.to_dict())[:3]
        ['aggregates', 'autocorrelation', 'bias']
        >>> _ = json.dumps(r.to_dict(), allow_nan=False)

        A constant target predicted exactly: R² is nan and the AIC -inf, written as strings:

        >>> d = dynval.validate([2.0, 2.0, 2.0], [2.0, 2.0, 2.0], n_params=1).to_dict()
        >>> d["pooled"]["r2"], d["information_criteria"]["aic"]
        ('NaN', '-Infinity')
        """
        out = {f.name: to_jsonable(getattr(self, f.name)) for f in fields(self) if f.name != "findings"}
        out["findings"] = [f.to_dict() for f in self.findings]
        names = self.provenance.get("joint_names")
        out["deciding"] = to_jsonable([r.to_dict(names) for r in self.deciding])
        out["first_step"], out["first_reason"] = self.first_step, self.first_reason
        return out

    def to_json(self, *, indent: int | None = 2) -> str:
        """The report as strict JSON (no bare NaN/Infinity tokens).

        Parameters
        ----------
        indent : int or None
            Indentation of :func:`json.dumps`; ``None`` writes one line.

        Returns
        -------
        str
            :meth:`to_dict` serialised with ``allow_nan=False``.

        Examples
        --------
        >>> import json, dynval
        >>> r = dynval.validate([2.0, 2.0, 2.0], [1.0, 2.0, 3.0], n_params=1)   # constant target
        >>> json.loads(r.to_json(indent=None))["per_joint"]["r2"]
        ['-Infinity']
        """
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def to_frame(self) -> Any:
        """The per-joint table as a pandas DataFrame (pandas is optional).

        Returns
        -------
        pandas.DataFrame
            One row per joint (index ``joint``: the joint names, or ``joint 1``, ...), the columns of
            ``per_joint`` and the residual's ``mean`` and ``variance``.

        Examples
        --------
        >>> import dynval
        >>> r = dynval.validate([[1.0, 2.0], [2.0, 1.0], [3.0, 5.0], [4.0, 3.0]],
        ...                     [[1.1, 2.2], [1.9, 1.1], [3.2, 4.7], [3.9, 3.1]], n_params=1,
        ...                     joint_names=["shoulder", "elbow"])
        >>> r.to_frame().loc["elbow", ["rmse", "r2"]].round(3).tolist()   # √(0.15/4), 1 − 0.15/8.75
        [0.194, 0.983]
        """
        names = self.provenance.get("joint_names") or [f"joint {j + 1}" for j in range(self.provenance["n_joints"])]
        columns = {**dict(self.per_joint), "mean": self.residuals["mean"], "variance": self.residuals["variance"]}
        return to_frame(columns, list(names), "joint", "ValidationReport.to_frame")

    def _repr_html_(self) -> str | None:
        """The report as a notebook shows it: the HTML page's tables and findings (dynval.html)."""
        from . import _display

        return _display.render(self)

    def summary(self) -> str:
        """Readable text: per-joint table first, then pooled values, criteria and findings.

        Returns
        -------
        str
            Joints and regressor columns counted from 1 unless named (contract §2.3).

        Examples
        --------
        >>> import dynval
        >>> r = dynval.validate([2.0, 2.0, 2.0], [2.0, 2.0, 2.0], n_params=1)   # constant target
        >>> print(r.summary())
        dynval validation report — profile 'lesson'
        ...
          - [note] joint 1: the measured torque is constant, so R², fit and VAF compare against nothing ...
        """
        return format_summary(self)

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        p = self.provenance
        return (f"ValidationReport(profile={p['profile']!r}, n_samples={p['n_samples']}, "
                f"n_joints={p['n_joints']}, n_params={p['n_params']}, "
                f"findings={len(self.findings)}, deficiencies={len(self.deficiencies)})")


@dataclass
class Sections:
    """The report's sections as they are computed (None: not computed by this route)."""

    km: dict[str, Any] = field(default_factory=dict)
    per_joint: dict[str, Any] = field(default_factory=dict)
    pooled: dict[str, Any] = field(default_factory=dict)
    aggregates: dict[str, Any] = field(default_factory=dict)
    residuals: dict[str, Any] = field(default_factory=dict)
    est_fit: Any = None
    bias: dict[str, Any] | None = None
    n_eff: Any = None
    ic: dict[str, Any] = field(default_factory=dict)
    grams: Any = None
    acf: dict[str, Any] | None = None
    lb: dict[str, Any] | None = None
    lb_lags: list[int] = field(default_factory=list)
    white: dict[str, Any] | None = None
    spec: dict[str, Any] | None = None
    spec_tests: Any = None  # every bin's peak test (dynval.statistics._stats.residual_spectrum), for the findings
    spec_sides: Any = None  # the measured torque's and the prediction's power on the spectrum's grid
    cross: dict[str, Any] | None = None
    xrho: Any = None
    xsd: Any = None
    missing: dict[str, Any] | None = None
    design: dict[str, Any] | None = None
    physics: dict[str, Any] | None = None
    predictive: dict[str, Any] | None = None
    periodic: dict[str, Any] | None = None
    model_kinds: list[dict[str, bool]] | None = None  # without q: which of offset, drift the model spans
    segment_metrics: dict[str, Any] | None = None
    untested: int = 0  # tests validate would run that this route did not (Holm's family, _findings.holm_family)


@dataclass(frozen=True)
class Setting:
    """What a report was computed with (the checked options of either route)."""

    prof: Profile
    noise_model: str
    level: float
    max_lag: int
    lag_source: str
    sample_rate: float | None
    timing: Timing | None
    bandwidth: float | None
    nan_policy: str
    n_params: int
    joint_names: list[str]
    column_names: list[str] | None
    model_columns: list[int] | None
    thresholds: Thresholds
    backend: str
    decimate: str | int | None
    streaming: bool = False
    not_tested: list[dict[str, Any]] = field(default_factory=list)  # dynval.coverage.not_tested


def provenance(s: Setting, sections: Sections, *, n: int, m: int, p_cols: int | None,
               lengths: Sequence[int] | np.ndarray, seg_names: list[str] | None, omitted: int) -> dict[str, Any]:
    """What the report was computed from and with: every convention, unit, size and version.

    A streamed report has no colour-aware correlation band (it needs the whole series, contract
    §4.1): its convention is None, ``streaming`` is True and ``not_tested`` lists every test the
    stream left out (:mod:`dynval.coverage`).
    """
    prof = s.prof
    crossed = sections.cross is not None
    out = {
        "profile": prof.name,
        "conventions": {
            **prof.conventions(),
            "noise_model": s.noise_model,
            "max_lag": int(s.max_lag),
            "max_lag_seconds": None if s.sample_rate is None else float(s.max_lag / s.sample_rate),
            "max_lag_source": s.lag_source,
            "time_grid": None if s.timing is None else s.timing.grid,
            "bandwidth": s.bandwidth,
            "level": s.level,
            "ljung_box_lags": list(sections.lb_lags),
            "model_df": 0,
            "nan_policy": s.nan_policy,
            "rmse": "both: rmse_per_element = sqrt(SSE/(N*m)), rmse_per_sample = sqrt(SSE/N)",
            "r2": "centred, 1 - SSE/TSS",
            "zero_mean_test": "i.i.d. Student t and Newey-West (Bartlett) effective sample size",
            "bias_test": (None if sections.bias is None
                          else "Student t with N_eff from the Andrews-Monahan prewhitened Bartlett long-run variance"
                          + (" (autocovariances from the streamed lag sums)" if s.streaming else "")),
            "multiple_testing": "Holm over every test of the report",
            "cross_correlation_band": "white" if crossed else None,
            "cross_correlation_findings": ("Bartlett variance for two coloured series" if crossed and not s.streaming
                                           else None),
            "decimate": s.decimate,
            "derivatives": _derivatives(sections.physics),
            # only where the physics test decimated the log (conventions §5.2): the others stay as they were
            **({"physics_decimation": dict(sections.physics["decimation"])}
               if sections.physics is not None and "decimation" in sections.physics else {}),
        },
        "units": {"vaf": prof.units, "fit_percent": prof.units, "r2": "fraction", "nrmse": "fraction",
                  "torque": "as given", "frequency": "Hz" if s.sample_rate else "cycles/sample"},
        "n_samples": int(n),
        "n_joints": int(m),
        "n_params": int(s.n_params),
        "n_regressor_columns": None if not p_cols else int(p_cols),
        "segments": [int(x) for x in lengths],
        "segment_names": seg_names,
        "omitted_rows": int(omitted),
        "joint_names": s.joint_names,
        "column_names": s.column_names,
        "model_columns": s.model_columns,
        "sample_rate": s.sample_rate,
        "thresholds": s.thresholds.as_dict() if isinstance(s.thresholds, Thresholds) else None,
        "backend": s.backend,
    }
    if s.streaming:
        out["streaming"] = True
        out["not_tested"] = [dict(t) for t in s.not_tested]
    out.update(dynval_version=__version__, contract_version=CONTRACT_VERSION,
               report_schema_version=REPORT_SCHEMA_VERSION)
    return out


def _derivatives(physics: dict[str, Any] | None) -> dict[str, Any] | None:
    """Where the physics library's q̇, q̈ came from: the validation test's, and the one source both
    runs' naming refits share (contract §4)."""
    if physics is None:
        return None
    from ._motion import source_text

    return {"validation": physics.get("derivatives"), "both_runs": source_text(physics.get("derivative_source",
                                                                                                "savgol")),
            "estimation_bandwidth_hz": physics.get("estimation_bandwidth_hz")}


def assemble_report(s: Setting, b: Sections, prov: dict[str, Any], *, n: int, m: int, omitted: int) -> ValidationReport:
    """The evidence of every section, the findings, and the :class:`~dynval.ValidationReport`."""
    timing = None if s.timing is None else s.timing.to_dict()
    ev = sec.evidence(n=n, m=m, level=s.level, names=s.joint_names, per_joint=b.per_joint, pooled=b.pooled,
                      constant=np.asarray(b.km["constant_target"], dtype=bool), omitted=omitted,
                      force=s.prof.constant_target == "force_finite", bias=b.bias, white=b.white, spec=b.spec,
                      spec_tests=b.spec_tests,
                      xcorr_rho=b.xrho, xcorr_sd=b.xsd,
                      xcorr_mask=None if b.cross is None or b.xrho is None else b.cross["constant_mask"],
                      design=b.design, column_names=s.column_names, acf=b.acf, missing=b.missing, physics=b.physics,
                      predictive=b.predictive, sample_rate=s.sample_rate, periodic=b.periodic, timing=timing,
                      bandwidth=s.bandwidth, criteria=b.ic, untested=b.untested, model_kinds=b.model_kinds,
                      spec_sides=b.spec_sides)
    family = holm_family(ev)
    found = compute_findings(ev, s.thresholds, family=family)
    cross = b.cross
    cells = cell_pvalue_adjusted(family)
    if cross is not None and cells is not None:
        cross = {**cross, "pvalue_adjusted": cells}  # for the heatmap: the cells the findings call significant
    return ValidationReport(
        provenance=rec.Provenance.of(prov), per_joint=rec.PerJoint.of(b.per_joint), pooled=rec.Pooled.of(b.pooled),
        aggregates=rec.Aggregates.of(b.aggregates), residuals=rec.Residuals.of(b.residuals),
        autocorrelation=rec.record_or_none(rec.Autocorrelation, b.acf),
        ljung_box=rec.record_or_none(rec.LjungBox, b.lb),
        cross_correlation=rec.record_or_none(rec.CrossCorrelation, cross),
        information_criteria=rec.InformationCriteria.of(b.ic), warnings_text=[f.message for f in found],
        findings=found, bias=rec.record_or_none(rec.Bias, b.bias), whiteness=rec.record_or_none(rec.Whiteness, b.white),
        spectrum=rec.record_or_none(rec.Spectrum, b.spec), design=rec.record_or_none(rec.Design, b.design),
        segment_metrics=None if b.segment_metrics is None else {
            name: rec.Segment.of(seg) for name, seg in b.segment_metrics.items()},
        physics=rec.record_or_none(rec.Physics, b.physics), predictive=rec.record_or_none(rec.Predictive, b.predictive),
        periodic=rec.record_or_none(rec.Periodic, b.periodic), timing=rec.record_or_none(rec.Timing, timing))
