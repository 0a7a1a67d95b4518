"""``dynval.validate`` and the :class:`ValidationReport` it returns (contract §4).

``validate`` checks its inputs once (contract order: type → shape → size → finiteness →
parameters): the data here (``_prepare``, into a ``_checks.CheckedCall``), the settings into one
frozen ``_options.Options`` (``check_options``, shared with the accumulator, deferred through the
checked call so that a non-finite value still wins), the lags into ``_options.Lags``. It makes ONE
fused kernel call (``compute_metrics``) for every point metric, residual
statistic and information criterion, then the lag analysis: autocorrelation with bands,
Ljung–Box, and the cross-correlation with the regressor columns when a regressor is given.
The profile (``_profiles.py``) fills every default.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np

from ..checks import _validation as v
from ..checks._checks import Array, CheckedCall
from ..checks._json import to_jsonable
from ..checks._segments import parse_segments, segment_lengths
from ..checks._typing import (
    ArrayLike,
    BackendName,
    Decimate,
    Detail,
    FloatArray,
    Integer,
    NamedSegmentsLike,
    NanPolicy,
    NoiseModel,
    ProfileName,
)
from ..kernels._blas import one_blas_thread
from ..statistics import _estimation
from . import _consistency, _motion
from . import _regressor_algebra as algebra
from . import _sections as sec
from ._assembly import REPORT_SCHEMA_VERSION, Sections, ValidationReport, assemble_report, provenance
from ._findings import SEVERITIES, Finding, Thresholds, resolve_thresholds
from ._options import NAMES, Data, Keywords, Lags, Options, check_options, plan_lags, to_setting
from ._prepared import Memo, PreparedRegressor, compute_now, digest, memo_for, scan_for

__all__ = ["validate", "ValidationReport", "REPORT_SCHEMA_VERSION", "to_jsonable"]



# --------------------------------------------------------------------------- validate


class _Prepared(NamedTuple):
    """The data after the checks of :func:`_prepare`: the checked call holding the torques and the
    regressor viewed (N, m*p) (rows with a non-finite value deleted under ``nan_policy="omit"``),
    the regressor's columns and shape as given, and the torques as given (promoted to (N, m))."""

    call: CheckedCall
    p: int | None
    reg_shape: tuple[int, ...] | None
    given_meas: FloatArray
    given_pred: FloatArray


def _prepare(tau_meas: ArrayLike, tau_pred: ArrayLike, regressor: ArrayLike | None, k: Keywords,
             prepared: PreparedRegressor | None = None) -> _Prepared:
    """Type, shape, size and finiteness checks (the data half of the contract's order); a prepared
    regressor is searched for non-finite values once for all its calls."""
    meas, pred, reg0, shape, _ = v.torque_pair(tau_meas, tau_pred, regressor)
    n, m = meas.shape
    p = None
    if reg0 is not None:
        p = v.regressor_shape(reg0, "tau_meas", n, m, k.n_joints)

    v.check_min_samples("validate", n)
    v.check_orientation("validate", "tau_meas", shape, k.allow_wide)

    arrays: list[Array] = [("tau_meas", meas, None), ("tau_pred", pred, None)]
    if reg0 is not None and p is not None:
        arrays.append(("regressor", v.regressor_to_2d(reg0, n, m, p), p))
    call = CheckedCall("validate", arrays, scan=scan_for(prepared))
    if isinstance(k.nan_policy, str) and k.nan_policy == "omit":
        # Omission needs the caller's segments to refine them; a bad value is reported now. The
        # row numbers ride along, so that time stamps can follow the kept rows.
        call.omit(parse_segments(k.segments, n), rows=True)
    elif not (isinstance(k.nan_policy, str) and k.nan_policy == "raise" and reg0 is None):
        call.require_finite()
    # else the fused kernel finds the first non-finite value of tau_meas, then tau_pred, inside
    # its single pass (same message); a separate sweep here would read the data twice.
    return _Prepared(call, p, None if reg0 is None else tuple(reg0.shape), meas, pred)


@one_blas_thread
def validate(tau_meas: ArrayLike, tau_pred: ArrayLike, *, n_params: Integer,
             regressor: ArrayLike | PreparedRegressor | None = None,
             n_joints: Integer | None = None, max_lag: Integer | None = None, level: float | None = None,
             profile: ProfileName = "lesson", segments: NamedSegmentsLike = None, nan_policy: NanPolicy = "raise",
             backend: BackendName | None = None, noise_model: NoiseModel | None = None,
             sample_rate: float | None = None, time: ArrayLike | None = None, time_units_checked: bool = True,
             bandwidth: float | None = None, decimate: Decimate = "auto", joint_names: Sequence[str] | None = None,
             column_names: Sequence[str] | None = None, q: ArrayLike | None = None,
             dq: ArrayLike | None = None, ddq: ArrayLike | None = None,
             estimation: dict[str, ArrayLike] | None = None, thresholds: Thresholds | dict[str, float] | None = None,
             cross_correlation_detail: Detail = "top", model_columns: Sequence[Integer | str] | None = None,
             allow_wide: bool = False, parameters: Any = None) -> ValidationReport:
    """Validate predicted joint torques against measured ones: every metric, findings, one report.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, shape (N,) or (N, m)
        Measured and predicted torques (samples in rows, joints in columns).
    n_params : int
        Number of identified parameters p (always given: there is no default).
    regressor : array_like, shape (N, m, p) or (N*m, p), or PreparedRegressor, optional
        Regressor Y of the validation data; enables the residual/regressor cross-correlation and
        the excitation diagnostics. Give the columns of every term you suspect (a superset of the
        model's) to have a missing term named. The stacked 2-D form needs `n_joints`. Validating
        several predictions on one run, pass :func:`dynval.prepare_regressor`'s result: the work
        that does not depend on the residual is then done once (the report is the same).
    n_joints : int, optional
        Number of joints m, for a stacked 2-D regressor.
    max_lag : int, optional
        Largest lag of the autocorrelation and cross-correlation. By default the profile's count
        of samples; with a sample rate, the motion's time scale instead: one period of the
        information band's edge, 1/f_I s (at most four times the profile's count; the report
        states it in seconds). ``0`` skips the lag analysis (and with it whiteness, bias and
        spectrum evidence).
    level : float, optional
        Confidence level of the bands and of the findings (α = 1 − level over the whole report,
        Holm-corrected); the profile's otherwise.
    profile : {"lesson", "matlab", "statsmodels", "sklearn"}
        Convention profile filling every default (see ``docs/conventions.md``).
    segments : sequence of int, or mapping of name to length, optional
        Lengths (``[500, 300]``) or starts (``[0, 500]``) of independent records; no lagged
        product crosses a boundary, means stay overall. Named lengths (``{"transient": 500,
        "steady": 4500}``) also get their own per-segment metrics (``segment_metrics``).
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows with a non-finite value in any input and inserts a segment break.
    backend : {"python", "cpp"}, optional
        Computation backend; the package default otherwise.
    noise_model : {"pooled", "per_joint", "full"}, optional
        Noise model of the information criteria; the profile's otherwise.
    sample_rate : float, optional
        Samples per second; frequencies are then in Hz (else cycles per sample). Inferred from
        ``time`` when not given.
    time : array_like, shape (N,), optional
        Time stamps of the samples, in seconds (any origin). Duplicated stamps, gaps and irregular
        steps are reported (section ``timing``, a ``time_stamps`` note); the lag and spectral
        analyses use the nominal step (median step, or ``sample_rate``) and are split into segments
        at every gap (a step longer than 1.5 nominal steps). Stamps at a rate outside 10 Hz to
        100 kHz (a whole number of seconds apart, say) look like milliseconds, microseconds or
        nanoseconds and are refused with the fix (``pass time / 1000``).
    time_units_checked : bool
        False accepts stamps at any rate (the check above); they must still be finite seconds
        that float64 can count.
    bandwidth : float, optional
        The band, in Hz, in which the inputs are trustworthy (the differentiation or sensor filter,
        e.g. what :func:`dynval.robots.differentiate` returns). Spectral and whiteness evidence above
        it is a note naming the processing, never a deficiency. Needs a sample rate, and is at most
        its Nyquist frequency.
    decimate : "auto", None or int
        Whiteness is also tested at the rate that carries information: "auto" decimates so the
        Nyquist frequency is twice the band holding 99 % of the measured torque's power
        (anti-alias FIR, zero phase); an integer is the factor; None tests the logged rate only.
    joint_names, column_names : sequence of str, optional
        Names used in every table, finding and the JSON.
    q : array_like, (N, m), optional
        Joint positions of the validation run: the repeat check, and the library of physical terms
        (friction, gravity, inertia, offset, drift, delay) the residual is tested against, so that
        a missing term is named without its column (``missing_physics``, ``delay``).
    dq, ddq : array_like, (N, m), optional
        Joint velocities and accelerations of the validation run; derived from ``q`` by zero-phase
        Savitzky–Golay differentiation (0.1 s window) when not given (the report says which).
    estimation : mapping, optional
        The estimation run: any of ``"q"`` (N_e, m), ``"regressor"`` (N_e, m, p) and ``"tau"``
        (N_e, m); the report states how far the validation run is from it and warns on a repeat.
    thresholds : mapping or Thresholds, optional
        Practical effect sizes a deficiency must reach (see :class:`dynval.Thresholds`).
    cross_correlation_detail : {"top", "full"}
        "top" keeps the strongest cells per joint and column; "full" also the whole ρ array.
    model_columns : sequence of int or str, optional
        The regressor columns the model contains (indices, or names from `column_names`). The
        other columns are then tested as candidate missing terms: the residual against the part of
        each that the model's columns cannot represent (added-variable correlation).
    allow_wide : bool
        Accept fewer samples than joints (N < m). Without it such data are taken for a transposed
        array (samples are rows) and refused with TooFewSamples.
    parameters : URDFModel, IdentificationResult or array_like, optional
        The model's own parameters, checked for physical consistency
        (:func:`dynval.robots.physical_consistency`; a vector with as many values as
        ``column_names`` is read with those names): its ``physical_consistency`` findings join the
        report's (contract §8).

    Returns
    -------
    ValidationReport

    Raises
    ------
    InvalidType, InvalidShape, ShapeMismatch, TooFewSamples, NonFiniteInput, InvalidParameter
        In that order of precedence (contract §2.1). Parameters are checked in the order
        n_params, n_joints, profile, nan_policy, segments, max_lag, level, backend, noise_model,
        sample_rate, time_units_checked, time, bandwidth, decimate, joint_names, column_names, q, dq, ddq,
        estimation, thresholds,
        cross_correlation_detail, model_columns, allow_wide, parameters.

    Notes
    -----
    The point metrics, residual mean and variance and the information criteria come from one
    fused kernel call. Findings are statistical detectors with a measured size and power
    (``benchmarks/calibrate_findings.py``, docs/conventions.md §5.5).

    Examples
    --------
    >>> import numpy as np, dynval
    >>> t = np.linspace(0.0, 10.0, 500)
    >>> tau = np.column_stack([20.0 * np.sin(t), 2.0 * np.cos(t)])
    >>> pred = tau + np.column_stack([0.1 * np.sin(7.0 * t), 0.05 * np.cos(5.0 * t)])
    >>> report = dynval.validate(tau, pred, n_params=4, max_lag=10)
    >>> report.per_joint["r2"].shape
    (2,)
    >>> round(report.pooled["rmse_per_sample"] / report.pooled["rmse_per_element"], 6)
    1.414214

    A constant joint gives ``-inf`` (``nan`` when predicted exactly) in the IEEE profiles, and
    0.0 (1.0) with ``profile="sklearn"`` (scikit-learn's ``force_finite``; contract §3.2, §4):

    >>> tau = [[1.0, 2.0], [2.0, 2.0], [3.0, 2.0], [4.0, 2.0]]        # joint 2 is constant
    >>> pred = [[1.1, 1.5], [1.9, 1.5], [3.2, 1.5], [3.9, 1.5]]
    >>> dynval.validate(tau, pred, n_params=1).per_joint["r2"]
    array([0.986, -inf])
    >>> dynval.validate(tau, pred, n_params=1, profile="sklearn").per_joint["r2"]
    array([0.986, 0.   ])
    >>> dynval.validate(tau, tau, n_params=1, profile="sklearn").per_joint["r2"]
    array([1., 1.])
    """
    given = {name: value for name, value in locals().items() if name in NAMES}  # OPTIONS' keywords, as given
    seg_names, segments = v.named_segments(segments)
    k = Keywords(**{**given, "segments": segments})
    prepared = regressor if isinstance(regressor, PreparedRegressor) else None
    d, o = _checked(tau_meas, tau_pred, regressor, k)
    d = replace(d, memo=memo_for(prepared, d.reg2), structure=None if prepared is None else prepared.structure)
    physical = None if parameters is None else _consistency.report_findings(
        parameters, m=d.m, level=o.level, column_names=o.column_names)
    b = Sections()
    _residual_sections(d, o, b)
    _lag_sections(d, o, b)
    _regressor_sections(d, o, b)
    _motion_sections(d, o, b)
    if seg_names is not None:
        b.segment_metrics = sec.segment_metrics(o.kernel, d.given_meas, d.given_pred, seg_names, segments,
                                                o.n_params, o.profile)
    report = _assemble(d, o, b, seg_names)
    return report if not physical else _with_findings(report, physical)


def _with_findings(report: ValidationReport, extra: list[Finding]) -> ValidationReport:
    """The report with ``extra`` findings among its own, deficiencies still first (contract §8)."""
    order = {s: i for i, s in enumerate(SEVERITIES)}
    found = sorted([*report.findings, *extra], key=lambda f: order[f.severity])
    return replace(report, findings=found, warnings_text=[f.message for f in found])


@dataclass(frozen=True)
class _Data:
    """The checked data: measured and predicted torques, residual, regressor (2-D and 3-D), and
    the frame of their lag analysis."""

    meas: FloatArray
    pred: FloatArray
    e: FloatArray | None
    reg2: FloatArray | None
    reg3: FloatArray | None
    p_cols: int | None
    omitted: int
    given_meas: FloatArray  # the torques as given (before nan_policy="omit"), for the segment metrics
    given_pred: FloatArray
    lags: Lags
    # the prepared regressor's store of residual-independent results; compute_now keeps nothing
    memo: Memo[Any] = compute_now
    # the model's regressor at states its structure allows (PreparedRegressor.structure), or None
    structure: FloatArray | None = None

    @property
    def n(self) -> int:
        return int(self.meas.shape[0])

    @property
    def m(self) -> int:
        return int(self.meas.shape[1])


def _checked(tau_meas: ArrayLike, tau_pred: ArrayLike, regressor: ArrayLike | PreparedRegressor | None,
             k: Keywords) -> tuple[_Data, Options]:
    """The data checks, then the settings in the contract's order, deferred (a non-finite value
    still wins over a bad setting), then the lags: with a rate, the motion's time scale."""
    prepared = regressor if isinstance(regressor, PreparedRegressor) else None
    plain = regressor if not isinstance(regressor, PreparedRegressor) else regressor.array
    pr = _prepare(tau_meas, tau_pred, plain, k, prepared)
    call = pr.call
    meas, pred = call.pair
    n, m = meas.shape
    facts = Data(n=n, m=m, p=pr.p, reg_shape=pr.reg_shape, starts=call.starts if call.omitting else None,
                 given_n=pr.given_meas.shape[0], kept_rows=call.kept_rows, meas=meas)
    with call.deferred():
        o = check_options(k, facts)
    assert o.starts is not None  # validate's segments
    lags = plan_lags(o, n, o.starts, pred)
    reg2 = call.arrays[2][1] if pr.p is not None else None
    e = np.ascontiguousarray(meas - pred) if lags.max_lag > 0 or reg2 is not None else None
    reg3 = None if reg2 is None or pr.p is None else reg2.reshape(n, m, pr.p)
    return _Data(meas, pred, e, reg2, reg3, pr.p, call.omitted, pr.given_meas, pr.given_pred, lags), o


def _assemble(d: _Data, o: Options, b: Sections, seg_names: list[str] | None) -> ValidationReport:
    s = to_setting(o, d.lags, d.m, sample_rate=o.sample_rate, timing=o.timing)
    prov = provenance(s, b, n=d.n, m=d.m, p_cols=d.p_cols, lengths=segment_lengths(d.lags.starts, d.n),
                      seg_names=seg_names, omitted=d.omitted)
    return assemble_report(s, b, prov, n=d.n, m=d.m, omitted=d.omitted)


def _residual_sections(d: _Data, o: Options, b: Sections) -> None:
    """Point metrics, residual statistics, the estimation refit, the bias test and the criteria."""
    from ..metrics._api import checked_zero_mean_test

    prof = o.profile
    b.km = o.kernel.compute_metrics(d.meas, d.pred, o.n_params, prof.ddof, o.noise_model)
    b.per_joint, b.pooled, b.aggregates = sec.point_metrics(b.km, prof)
    lagged = d.lags.max_lag > 0
    zmt = (_as_dict(checked_zero_mean_test(d.e, o.kernel, d.lags.starts, d.lags.longest)) if lagged and d.e is not None
           else sec.iid_zero_mean_test(b.km, d.n, prof.ddof))
    b.residuals = {"mean": np.asarray(b.km["residual_mean"], dtype=np.float64),
                   "variance": np.asarray(b.km["residual_variance"], dtype=np.float64),
                   "ddof": prof.ddof, "zero_mean_test": zmt}
    # The estimation run, when given with its torques: the parameters' coloured-noise covariance
    # (the bias and regressor tests allow for it) and the refit that names a missing term.
    est = o.estimation or {}
    if d.reg3 is not None and d.p_cols is not None and d.e is not None and "regressor" in est and "tau" in est:
        cols = tuple(int(c) for c in (o.model_columns if o.model_columns is not None else range(d.p_cols)))
        b.est_fit = d.memo(("fit_columns", _estimation_key(d, est), cols),
                           lambda: _estimation.fit_columns(est["regressor"], est["tau"], cols))
    param_var = None
    if b.est_fit is not None and d.reg3 is not None:
        fit, val_reg = b.est_fit, d.reg3
        means = d.memo(("column_means", val_reg.shape, fit.columns),
                       lambda: val_reg[:, :, list(fit.columns)].mean(axis=0))
        param_var = _estimation.quadratic_forms(fit, means)
    b.bias = sec.bias_test(d.e, d.lags.starts, b.per_joint["rmse"], param_var) if lagged else None
    b.n_eff = None if b.bias is None else b.bias["n_eff"]
    b.ic = sec.information_criteria(b.km, prof, o.noise_model, d.n, d.m, o.n_params, b.n_eff)
    # One pass over the regressor for both the spectrum's projection and the excitation section.
    reg3 = d.reg3
    b.grams = None if reg3 is None else d.memo(
        ("grams", reg3.shape), lambda: algebra.JointGrams(reg3, algebra.column_largest(reg3, d.memo)))


def _estimation_key(d: _Data, est: dict[str, Any]) -> tuple[Any, ...]:
    """The estimation run's part of a kept result's key: a hash of its arrays (none without a
    prepared regressor, where nothing is kept)."""
    if d.memo is compute_now:
        return ()
    return digest(est.get("regressor"), est.get("tau"), est.get("q"), est.get("dq"), est.get("ddq"))


def _lag_sections(d: _Data, o: Options, b: Sections) -> None:
    """ACF, Ljung–Box, whiteness at the information rate, spectrum."""
    lags = d.lags
    b.lb_lags = o.profile.ljung_box_lags(d.n, lags.max_lag, lags.longest)
    if lags.max_lag <= 0:
        return
    b.acf = sec.autocorrelation(o.kernel, d.e, lags.max_lag, o.profile, o.level, lags.starts, d.n)
    if b.lb_lags:
        b.lb = sec.ljung_box(o.kernel, d.e, b.lb_lags, lags.starts)
        b.white = sec.whiteness(o.kernel, d.e, d.pred, lags.starts, b.lb, o.decimate, o.sample_rate, band=lags.band,
                                bandwidth=o.bandwidth, lag=lags.white_lag)
    b.spec, b.spec_tests = sec.spectrum(d.e, lags.starts, d.reg3, o.sample_rate, b.grams, memo=d.memo)
    b.spec_sides = sec.spectrum_sides(d.meas, d.pred, lags.starts, o.sample_rate, b.spec)


def _regressor_sections(d: _Data, o: Options, b: Sections) -> None:
    """Cross-correlation with the regressor's columns, and the columns the model lacks."""
    if d.reg2 is None:
        return
    b.cross, b.xrho, b.xsd = sec.cross_correlation(o.kernel, d.e, d.reg2, d.p_cols, d.lags.max_lag, o.profile,
                                                   o.level, d.lags.starts, d.n, d.m, b.n_eff, o.detail, memo=d.memo)
    if b.est_fit is not None:
        b.xsd = sec.parameter_error_sd(b.xrho, b.xsd, d.e, d.reg3, b.est_fit, d.lags.starts, o.profile, o.level,
                                       memo=d.memo)
        b.cross["parameter_error"] = True
    if o.model_columns is not None and d.e is not None:
        est = o.estimation or {}
        if b.est_fit is not None:
            cols = tuple(int(c) for c in o.model_columns)
            reg3 = d.reg3
            assert reg3 is not None  # with reg2
            b.missing = d.memo(("missing_terms", _estimation_key(d, est), reg3.shape, cols,
                                digest(d.meas) if d.memo is not compute_now else ()),
                               lambda: _estimation.missing_terms(est["regressor"], est["tau"], reg3, d.meas, cols))
        else:
            b.missing = sec.added_variable(d.e, d.reg3, o.model_columns, d.lags.starts, b.n_eff)
        if b.missing is not None:
            b.cross["missing_terms"] = dict(b.missing)


def _motion_sections(d: _Data, o: Options, b: Sections) -> None:
    """The validation design, and what the motion says: physics library, delay, periodic noise,
    predictive test, each joint's motion and the smallest detectable effect."""
    b.design = sec.design(d.reg3, o.q, o.estimation, d.meas, o.thresholds, b.grams, sample_rate=o.sample_rate,
                          memo=d.memo, estimation_key=_estimation_key(d, o.estimation or {}), structure=d.structure)
    if o.q is not None and d.e is not None and not d.omitted:
        b.physics = _motion.physics(d.e, d.pred, o.q, o.dq, o.ddq, o.sample_rate, d.reg3, o.model_columns,
                                    b.est_fit, o.level, o.estimation, d.meas,
                                    practical=resolve_thresholds(o.thresholds).missing_physics,
                                    column_names=o.column_names,
                                    band=d.lags.band if o.decimate == "auto" else None)
        b.physics["delay"] = _motion.delay(d.meas, d.pred, o.sample_rate)
        band = None if b.white is None else b.white["information_band"]
        b.periodic = _motion.periodic(d.e, o.q, o.sample_rate, band, b.est_fit, d.reg3, o.model_columns)
    elif d.reg3 is not None and d.e is not None:
        # without q the model's columns still tell whether it has an offset (the bias rule's words)
        cols = (list(b.est_fit.columns) if b.est_fit is not None else
                list(range(d.reg3.shape[2])) if o.model_columns is None else list(o.model_columns))
        declared = _motion.declared_groups(d.reg3, cols, o.column_names)
        # the regressor's work alone (each joint's span of the model's columns, an SVD of N × k):
        # kept by a prepared regressor, so compare's candidates with the same columns do it once
        key = ("model_kinds", d.reg3.shape, tuple(int(c) for c in cols),
               None if declared is None else tuple(frozenset(x) for x in declared))
        kinds = d.memo(key, lambda: _motion.model_kinds(d.e, None, None, o.sample_rate, d.reg3, cols, declared))
        b.model_kinds = None if kinds is None else [dict(x) for x in kinds]
    if b.est_fit is not None and b.n_eff is not None:
        b.predictive = _motion.predictive(d.e, b.est_fit, d.reg3, b.n_eff, memo=d.memo)
    b.design = _motion_design(b.design, o, b.physics, d.m)


def _motion_design(design: dict[str, Any] | None, o: Options, phys: dict[str, Any] | None,
                   m: int) -> dict[str, Any] | None:
    """The design section completed with what the motion says: each joint's motion against the
    estimation run's, and the smallest effect this run can detect per joint."""
    est_q = (o.estimation or {}).get("q")
    ratio = _motion.joint_excitation(o.q, est_q)
    # the noise's N_eff: what the physical terms leave (the residual's own N_eff counts a missing
    # term's slow structure as colour); without q it is not known
    noise_n_eff = phys["n_eff"] if phys is not None else None
    if ratio is None and noise_n_eff is None:
        return design
    design = dict(design or {})
    if ratio is not None:
        design["joint_motion_ratio"] = ratio
    if noise_n_eff is not None:
        design["noise_n_eff"] = np.asarray(noise_n_eff, dtype=float)
        design["detectable_share"] = _motion.detectable_share(noise_n_eff, m, o.level)
    return design


def _as_dict(result: Any) -> dict[str, Any]:
    if hasattr(result, "_asdict"):
        return dict(result._asdict())
    if hasattr(result, "__dataclass_fields__"):
        return {f: getattr(result, f) for f in result.__dataclass_fields__}
    return dict(result)
