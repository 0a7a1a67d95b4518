"""The one assembler of a validation report: sections in, provenance, evidence, findings, report out.

``validate`` (:mod:`dynval.report._report`) computes the sections from the whole series; the stream
accumulator (:mod:`dynval.stream`) computes the ones mergeable sums allow and leaves the others
None. Both then call :func:`provenance` and :func:`assemble_report`, so a report's provenance, its
evidence and its findings are built one way.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from .._version import CONTRACT_VERSION, __version__
from ..checks._json import to_frame, to_jsonable
from ..checks._timing import Timing
from ..checks._typing import FloatArray, FusedMetrics
from ..metrics._profiles import Profile
from ..statistics._stats import Spectrum
from . import _records as rec
from ._findings import SEVERITIES, Evidence, Finding, Thresholds, cell_pvalue_adjusted, compute_findings, holm_family
from ._ranking import Ranked, deciding, first_reason
from ._summary import format_summary
from ._text import source_text

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


@dataclass(frozen=True)
class Sections:
    """The report's sections, each its builder's typed record (None: not computed by this route), and
    the arrays beside them that the findings read (``spec_tests``, ``xrho``, ``xsd``, ``missing``,
    ``spec_sides``, ``model_kinds``); built once, when every section is computed."""

    km: FusedMetrics  # the fused kernel's result (contract §5.1)
    per_joint: rec.PerJoint
    pooled: rec.Pooled
    aggregates: rec.Aggregates
    residuals: rec.Residuals
    ic: rec.InformationCriteria
    bias: rec.Bias | None = None
    acf: rec.Autocorrelation | None = None
    lb: rec.LjungBox | None = None
    lb_lags: list[int] = field(default_factory=list)
    white: rec.Whiteness | None = None
    spec: rec.Spectrum | None = None
    spec_tests: Spectrum | None = None  # every bin's peak test (dynval.statistics._stats.residual_spectrum)
    spec_sides: tuple[FloatArray, FloatArray] | None = None  # the measured torque's and the prediction's power
    cross: rec.CrossCorrelation | None = None
    xrho: FloatArray | None = None  # (m, p, L+1): every cell's correlation, whatever the section's detail
    xsd: FloatArray | None = None  # (m, p, L+1): its colour-aware standard deviation
    missing: rec.MissingTerms | None = None  # the cross-correlation's ``missing_terms``, as a record
    design: rec.Design | None = None
    physics: rec.Physics | None = None
    predictive: rec.Predictive | None = None
    periodic: rec.Periodic | None = None
    model_kinds: list[dict[str, bool]] | None = None  # without q: which of offset, drift the model spans
    segment_metrics: dict[str, rec.Segment] | None = None
    untested: int = 0  # tests validate would run that this route did not (Holm's family, _findings.holm_family)


def evidence(s: Setting, b: Sections, *, n: int, omitted: int, timing: dict[str, Any] | None) -> Evidence:
    """What the findings' rules read, from the sections' records (``b.untested``: tests the entry point
    left out, which count in Holm's family, docs/conventions.md §5)."""
    ev = Evidence(n_samples=n, level=s.level, joint_names=list(s.joint_names),
                  r2=np.asarray(b.per_joint.r2, dtype=float), pooled_r2=float(b.pooled.r2),
                  constant_target=np.asarray(b.km["constant_target"], dtype=bool), column_names=s.column_names,
                  omitted_rows=omitted, force_finite=s.prof.constant_target == "force_finite",
                  n_params=int(b.ic.n_params), criteria_n_obs=int(b.ic.n_obs), noise_model=str(b.ic.noise_model))
    if b.bias is not None:
        ev.mean, ev.rmse = b.bias.mean, b.per_joint.rmse
        ev.bias_statistic, ev.bias_pvalue, ev.n_eff = b.bias.statistic, b.bias.pvalue, b.bias.n_eff
    if b.white is not None:
        _whiteness_evidence(ev, b.white)
    if b.acf is not None:
        rho = b.acf.rho
        ev.max_abs_acf = np.fmax.reduce(np.abs(rho[1:]), axis=0) if rho.shape[0] > 1 else None
    if b.spec is not None and b.spec_tests is not None:
        _spectrum_evidence(ev, b.spec, b.spec_tests, b.spec_sides)
    if b.xrho is not None:
        ev.xcorr_rho, ev.xcorr_sd = b.xrho, b.xsd
        ev.xcorr_mask = None if b.cross is None else b.cross.constant_mask
    if b.design is not None:
        ev.repeat, ev.excitation = rec.present(b.design.repeat), rec.present(b.design.excitation)
        ev.joint_motion_ratio = rec.present(b.design.joint_motion_ratio)
        ev.detectable_share = rec.present(b.design.detectable_share)
        ev.noise_n_eff = rec.present(b.design.noise_n_eff)
    ev.physics, ev.predictive, ev.sample_rate, ev.periodic = b.physics, b.predictive, s.sample_rate, b.periodic
    ev.timing, ev.bandwidth, ev.untested = timing, s.bandwidth, int(b.untested)
    ev.model_kinds = rec.present(b.physics.model_kinds) if b.physics is not None else b.model_kinds
    if b.missing is not None:
        _missing_evidence(ev, b.missing)
    return ev


def _whiteness_evidence(ev: Evidence, white: rec.Whiteness) -> None:
    """Ljung–Box at the logged rate and, when decimated, at the information rate."""
    ev.whiteness_lag = white.lag
    ev.whiteness_pvalue_raw, ev.whiteness_log_pvalue_raw = white.pvalue_raw, white.log_pvalue_raw
    ev.whiteness_pvalue_decimated = white.pvalue_decimated
    if white.pvalue_decimated is not None:
        ev.whiteness_lag = white.lag_decimated
    ev.decimation, ev.information_band = white.decimation, white.information_band
    ev.whiteness_above_bandwidth = bool(white.above_bandwidth)


def _spectrum_evidence(ev: Evidence, spec: rec.Spectrum, tests: Spectrum,
                       sides: tuple[FloatArray, FloatArray] | None) -> None:
    """Every bin's peak test, and the two sides' power when they are on the residual's grid."""
    ev.spectrum_frequency, ev.frequency_unit = spec.frequency, spec.frequency_unit
    ev.spectrum_pvalue, ev.spectrum_ratio = tests.pvalue, tests.ratio
    ev.spectrum_share, ev.spectrum_is_peak = tests.share, tests.is_peak
    if sides is not None and sides[0].shape == spec.power.shape:
        ev.spectrum_power = spec.power
        ev.spectrum_power_measured, ev.spectrum_power_prediction = sides


def _missing_evidence(ev: Evidence, missing: rec.MissingTerms) -> None:
    """The columns the model lacks: the added-variable correlations or the refit's tests."""
    ev.missing_columns, ev.missing_method = missing.columns, missing.method
    ev.missing_statistic, ev.missing_pvalue = missing.statistic, missing.pvalue
    ev.missing_share, ev.missing_explains_bias = missing.share, missing.explains_bias
    ev.missing_enters, ev.missing_alone = rec.present(missing.enters), rec.present(missing.alone)


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


def _derivatives(physics: rec.Physics | None) -> dict[str, Any] | None:
    """Where the physics library's q̇, q̈ came from: the validation test's, and the one source both
    runs' naming refits share (contract §4)."""
    if physics is None:
        return None
    return {"validation": physics.get("derivatives"), "both_runs": source_text(physics.get("derivative_source",
                                                                                                "savgol")),
            "estimation_bandwidth_hz": physics.get("estimation_bandwidth_hz")}


def assemble_report(s: Setting, b: Sections, prov: dict[str, Any], *, n: int, m: int, omitted: int) -> ValidationReport:
    """The evidence of every section, the findings, and the :class:`~dynval.ValidationReport`."""
    timing = None if s.timing is None else s.timing.to_dict()
    ev = evidence(s, b, n=n, omitted=omitted, timing=timing)
    family = holm_family(ev)
    found = compute_findings(ev, s.thresholds, family=family)
    cross = b.cross
    cells = cell_pvalue_adjusted(family)
    if cross is not None and cells is not None:
        cross = cross.with_(pvalue_adjusted=cells)  # for the heatmap: the cells the findings call significant
    return ValidationReport(
        provenance=rec.Provenance.of(prov), per_joint=b.per_joint, pooled=b.pooled, aggregates=b.aggregates,
        residuals=b.residuals, autocorrelation=b.acf, ljung_box=b.lb, cross_correlation=cross,
        information_criteria=b.ic, warnings_text=[f.message for f in found], findings=found, bias=b.bias,
        whiteness=b.white, spectrum=b.spec, design=b.design, segment_metrics=b.segment_metrics,
        physics=b.physics, predictive=b.predictive, periodic=b.periodic, timing=rec.record_or_none(rec.Timing, timing))


def with_findings(report: ValidationReport, extra: list[Finding]) -> ValidationReport:
    """The report with ``extra`` findings among its own, deficiencies still first (contract §8)."""
    order = {s: i for i, s in enumerate(SEVERITIES)}
    found = sorted([*report.findings, *extra], key=lambda f: order[f.severity])
    return replace(report, findings=found, warnings_text=[f.message for f in found])
