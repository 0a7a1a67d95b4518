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
from dataclasses import replace
from typing import Any, NamedTuple, cast

import numpy as np

from ..checks import _validation as v
from ..checks._checks import Array, CheckedCall
from ..checks._json import to_jsonable
from ..checks._segments import parse_segments
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
from . import _consistency, _motion
from . import _sections as sec
from ._assembly import REPORT_SCHEMA_VERSION, Sections, ValidationReport, assemble_report, provenance, with_findings
from ._findings import Finding, Thresholds
from ._options import NAMES, Data, Keywords, Options, check_options, plan_lags, to_setting
from ._prepared import PreparedRegressor, kept_keys, memo_for, scan_for

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
    memo = memo_for(prepared, d.reg2)
    estimation_key, meas_key = kept_keys(memo, o.estimation, d.meas)
    named = None if seg_names is None else (seg_names, cast(list[int], segments))  # named: lengths, as a list
    d = replace(d, memo=memo, structure=None if prepared is None else prepared.structure,
                estimation_key=estimation_key, meas_key=meas_key, named=named)
    physical = None if parameters is None else _consistency.report_findings(
        parameters, m=d.m, level=o.level, column_names=o.column_names)
    r = sec.residual_phase(d, o)
    lagged = sec.lag_phase(d, o, r)
    crossed = sec.regressor_phase(d, o, r)
    motion = _motion.motion_phase(d, o, r, lagged)
    b = Sections(km=r.km, per_joint=r.per_joint, pooled=r.pooled, aggregates=r.aggregates, residuals=r.residuals,
                 ic=r.ic, bias=r.bias, acf=lagged.acf, lb=lagged.lb, lb_lags=lagged.lb_lags, white=lagged.white,
                 spec=lagged.spec, spec_tests=lagged.spec_tests, spec_sides=lagged.spec_sides, cross=crossed.cross,
                 xrho=crossed.xrho, xsd=crossed.xsd, missing=crossed.missing, design=motion.design,
                 physics=motion.physics, predictive=motion.predictive, periodic=motion.periodic,
                 model_kinds=motion.model_kinds, segment_metrics=r.segments)
    return _assemble(d, o, b, seg_names, physical or [])


def _checked(tau_meas: ArrayLike, tau_pred: ArrayLike, regressor: ArrayLike | PreparedRegressor | None,
             k: Keywords) -> tuple[sec.CheckedData, Options]:
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
    return sec.CheckedData(meas, pred, e, reg2, reg3, pr.p, call.omitted, pr.given_meas, pr.given_pred, lags), o


def _assemble(d: sec.CheckedData, o: Options, b: Sections, seg_names: list[str] | None,
              physical: list[Finding]) -> ValidationReport:
    """The setting, the provenance and the report, the model's own ``physical`` findings among its own."""
    s = to_setting(o, d.lags, d.m, sample_rate=o.sample_rate, timing=o.timing)
    prov = provenance(s, b, n=d.n, m=d.m, p_cols=d.p_cols, lengths=d.lags.lengths,
                      seg_names=seg_names, omitted=d.omitted)
    report = assemble_report(s, b, prov, n=d.n, m=d.m, omitted=d.omitted)
    return with_findings(report, physical) if physical else report
