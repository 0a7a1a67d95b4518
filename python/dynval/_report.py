"""``dynval.validate`` and the :class:`ValidationReport` it returns (contract §4).

``validate`` checks its inputs once (contract order: type → shape → size → finiteness →
parameters), makes ONE fused kernel call (``compute_metrics``) for every point metric, residual
statistic and information criterion, then the lag analysis: autocorrelation with bands,
Ljung–Box, and the cross-correlation with the regressor columns when a regressor is given.
The profile (``_profiles.py``) fills every default.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, fields

import numpy as np
import scipy.stats

from . import _validation as v
from ._errors import InputError
from ._profiles import Profile, get_profile
from ._segments import longest_segment, omit_nonfinite, parse_segments, segment_lengths
from ._summary import findings, format_summary

__all__ = ["validate", "ValidationReport", "REPORT_SCHEMA_VERSION", "to_jsonable"]

REPORT_SCHEMA_VERSION = 1
_CONTRACT_VERSION = "1.0"
_LN_2PI_PLUS_1 = math.log(2.0 * math.pi) + 1.0


# --------------------------------------------------------------------------- JSON


def to_jsonable(value):
    """Convert a report value to plain JSON types.

    Arrays become nested lists, numpy scalars Python scalars, tuples lists, and non-finite
    floats the strings ``"NaN"``, ``"Infinity"`` and ``"-Infinity"`` (contract §4).

    Examples
    --------
    >>> to_jsonable({"a": np.array([1.0, np.nan, -np.inf]), "b": (np.int64(2), True)})
    {'a': [1.0, 'NaN', '-Infinity'], 'b': [2, True]}
    """
    if isinstance(value, dict):
        return {str(k): to_jsonable(x) for k, x in value.items()}
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_jsonable(x) for x in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if math.isnan(x):
            return "NaN"
        if math.isinf(x):
            return "Infinity" if x > 0 else "-Infinity"
        return x
    return value


# --------------------------------------------------------------------------- the report


@dataclass
class ValidationReport:
    """Result of :func:`dynval.validate`.

    Every section is a dictionary of floats, integers, strings and numpy arrays; the keys are
    the contract's names (contract §4). Per-joint arrays have shape ``(m,)``; joint, column
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
        The findings, in plain words.
    """

    provenance: dict
    per_joint: dict
    pooled: dict
    aggregates: dict
    residuals: dict
    autocorrelation: dict | None
    ljung_box: dict | None
    cross_correlation: dict | None
    information_criteria: dict
    warnings_text: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready dictionary: nested lists, non-finite numbers as strings.

        Examples
        --------
        >>> import json, dynval
        >>> r = dynval.validate([1.0, 2.0, 3.0, 4.0], [1.1, 1.9, 3.2, 3.9], n_params=1)
        >>> sorted(r.to_dict())[:3]
        ['aggregates', 'autocorrelation', 'cross_correlation']
        >>> _ = json.dumps(r.to_dict(), allow_nan=False)
        """
        return {f.name: to_jsonable(getattr(self, f.name)) for f in fields(self)}

    def to_json(self, *, indent: int | None = 2) -> str:
        """The report as strict JSON (no bare NaN/Infinity tokens)."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def summary(self) -> str:
        """Readable text: per-joint table first, then pooled values, criteria and findings."""
        return format_summary(self)

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        p = self.provenance
        return (f"ValidationReport(profile={p['profile']!r}, n_samples={p['n_samples']}, "
                f"n_joints={p['n_joints']}, n_params={p['n_params']}, "
                f"findings={len(self.warnings_text)})")


# --------------------------------------------------------------------------- validate


def _backend_kernel(backend):
    """Return ``(kernel_module, backend_name)``; unavailable names raise InvalidParameter."""
    from ._backend import resolve

    name, kernel = resolve(backend)
    return kernel, name


def _z(level: float) -> float:
    return float(scipy.stats.norm.ppf(0.5 * (1.0 + level)))


def _force_finite(values, constant):
    """scikit-learn's force_finite: a constant target gives 1.0 if exact (nan) else 0.0 (−inf)."""
    values = np.array(values, dtype=np.float64, copy=True)
    constant = np.asarray(constant, dtype=bool)
    values[constant] = np.where(np.isnan(values[constant]), 1.0, 0.0)
    return values


def _prepare(tau_meas, tau_pred, regressor, n_joints, segments, nan_policy):
    """Type, shape, size and finiteness checks (the data half of the contract's order)."""
    meas0 = v.to_float_array(tau_meas, "tau_meas")
    pred0 = v.to_float_array(tau_pred, "tau_pred")
    reg0 = None if regressor is None else v.to_float_array(regressor, "regressor")

    meas = v.promote_signal(meas0, "tau_meas")
    pred = v.promote_signal(pred0, "tau_pred")
    v.check_same_shape("tau_meas", meas0.shape, meas, "tau_pred", pred0.shape, pred)
    n, m = meas.shape
    p = None
    if reg0 is not None:
        p = v.regressor_shape(reg0, "tau_meas", n, m, n_joints)

    v.check_min_samples("validate", n)

    reg2 = None if reg0 is None else v.regressor_to_2d(reg0, n, m, p)
    omitted = 0
    if isinstance(nan_policy, str) and nan_policy == "omit":
        # Omission needs the caller's segments to refine them; a bad value is reported now.
        starts = parse_segments(segments, n)
        arrays = [meas, pred] + ([reg2] if reg2 is not None else [])
        kept, starts, omitted = omit_nonfinite(arrays, starts)
        meas, pred = kept[0], kept[1]
        reg2 = kept[2] if reg2 is not None else None
        n = meas.shape[0]
        v.check_min_samples("validate", n)
    elif isinstance(nan_policy, str) and nan_policy == "raise" and reg2 is None:
        # The fused kernel finds the first non-finite value of tau_meas, then tau_pred, inside
        # its single pass (same message); a separate sweep here would read the data twice.
        starts = None
    else:
        check_data_finite(meas, pred, reg2, p)
        starts = None
    return meas, pred, reg2, p, starts, omitted, reg0


def check_data_finite(meas, pred, reg2=None, p=None):
    """The finiteness step of the contract's order, in argument order."""
    v.check_finite(meas, "tau_meas")
    v.check_finite(pred, "tau_pred")
    if reg2 is not None:
        v.check_finite(reg2, "regressor", n_columns=p)



def _iid_zero_mean_test(km, n, ddof):
    """The i.i.d. half of the zero-mean test from the fused kernel's mean and variance.

    With ``max_lag=0`` there is no lag analysis, so the autocorrelation-corrected half (which needs
    the autocorrelation up to the Newey–West bandwidth) is left out: its fields are None.
    """
    mean = np.asarray(km["residual_mean"], dtype=np.float64)
    variance = np.asarray(km["residual_variance"], dtype=np.float64) * ((n - ddof) / (n - 1.0))
    std = np.sqrt(variance)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_iid = mean * math.sqrt(n) / std
    return {
        "mean": mean,
        "std": std,
        "n_samples": int(n),
        "statistic_iid": t_iid,
        "pvalue_iid": 2.0 * scipy.stats.t.sf(np.abs(t_iid), n - 1),
        "df_iid": int(n - 1),
        "statistic_eff": None,
        "pvalue_eff": None,
        "df_eff": None,
        "n_eff": None,
        "bandwidth": None,
    }



def _check_parameters(n_params, reg0, n_joints, n, m, profile, nan_policy, starts, segments,
                      max_lag, level, backend):
    """validate's parameters in the documented order; returns them normalised."""
    n_params = v.check_n_params(n_params)
    if reg0 is not None:
        v.check_n_joints(n_joints, reg0.shape[0], m, reg0.ndim == 3)
    elif n_joints is not None:
        v.check_n_joints(n_joints, n * m, m, False)
    prof: Profile = get_profile(profile)
    v.check_nan_policy(nan_policy)
    if starts is None:
        starts = parse_segments(segments, n)
    longest = longest_segment(starts, n)
    if max_lag is None:
        max_lag = prof.default_max_lag(n, longest)
    else:
        max_lag = v.check_max_lag(max_lag, longest)
    level = prof.level if level is None else v.check_level(level)
    kernel, backend_name = _backend_kernel(backend)
    return n_params, max_lag, level, prof, starts, longest, kernel, backend_name


def validate(tau_meas, tau_pred, *, n_params, regressor=None, n_joints=None, max_lag=None,
             level=None, profile="lesson", segments=None, nan_policy="raise", backend=None):
    """Validate predicted joint torques against measured ones: every metric, one report.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, shape (N,) or (N, m)
        Measured and predicted torques (samples in rows, joints in columns).
    n_params : int
        Number of identified parameters p (always given: there is no default).
    regressor : array_like, shape (N, m, p) or (N*m, p), optional
        Regressor Y of the validation data; enables the residual/regressor cross-correlation.
        The stacked 2-D form (row ``k*m + j`` = sample k, joint j) needs `n_joints`.
    n_joints : int, optional
        Number of joints m, for a stacked 2-D regressor.
    max_lag : int, optional
        Largest lag of the autocorrelation and cross-correlation; the profile's default
        otherwise. ``0`` skips the lag analysis (``autocorrelation`` and ``ljung_box`` are None).
    level : float, optional
        Confidence level of the bands and of the findings' tests; the profile's otherwise.
    profile : {"lesson", "matlab", "statsmodels", "sklearn"}
        Convention profile filling every default (see ``docs/conventions.md``).
    segments : sequence of int, optional
        Lengths (``[500, 300]``) or starts (``[0, 500]``) of independent records; no lagged
        product crosses a boundary, means stay overall.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows with a non-finite value in any input and inserts a segment break.
    backend : {"python", "cpp"}, optional
        Computation backend; the package default otherwise.

    Returns
    -------
    ValidationReport

    Raises
    ------
    InvalidType, InvalidShape, ShapeMismatch, TooFewSamples, NonFiniteInput, InvalidParameter
        In that order of precedence (contract §2.1). Parameters are checked in the order
        n_params, n_joints, profile, nan_policy, segments, max_lag, level, backend.

    Notes
    -----
    The point metrics, residual mean and variance and the information criteria come from one
    fused kernel call. The cross-correlation band is z/√N; the autocorrelation band follows the
    profile (white or Bartlett). Findings use α = 1 − level, Bonferroni-corrected over the
    joints for per-joint tests (docs/conventions.md §5). With ``nan_policy="omit"`` the
    segments are parsed (and may raise) before the other parameters, because omission refines
    them.

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
    """
    meas, pred, reg2, p_cols, starts, omitted, reg0 = _prepare(
        tau_meas, tau_pred, regressor, n_joints, segments, nan_policy)
    n, m = meas.shape

    # ---- parameters, in a fixed order; a non-finite value still wins over a bad parameter
    try:
        n_params, max_lag, level, prof, starts, longest, kernel, backend_name = _check_parameters(
            n_params, reg0, n_joints, n, m, profile, nan_policy, starts, segments, max_lag, level,
            backend)
    except InputError:
        check_data_finite(meas, pred, reg2, p_cols)
        raise

    # ---- one fused pass for every point metric, residual statistic and criterion
    km = kernel.compute_metrics(meas, pred, n_params, prof.ddof, prof.noise_model)
    # Only the lag analysis needs the residual array: max_lag=0 without a regressor stays one pass.
    lagged = max_lag > 0
    e = np.ascontiguousarray(meas - pred) if lagged or reg2 is not None else None

    scale = 1.0 if prof.units == "percent" else 0.01
    force = prof.constant_target == "force_finite"
    constant = np.asarray(km["constant_target"], dtype=bool)

    def per_joint_fit(name):
        values = np.asarray(km[name], dtype=np.float64) * (scale if name != "r2" else 1.0)
        return _force_finite(values, constant) if force else values

    def pooled_fit(name):
        value = float(km[f"{name}_pooled"]) * (scale if name != "r2" else 1.0)
        if force and km["constant_target_pooled"]:
            value = 1.0 if math.isnan(value) else 0.0
        return value

    per_joint = {
        "sse": np.asarray(km["sse"], dtype=np.float64),
        "rmse": np.asarray(km["rmse"], dtype=np.float64),
        "max_abs_error": np.asarray(km["max_abs_error"], dtype=np.float64),
        "vaf": per_joint_fit("vaf"),
        "fit_percent": per_joint_fit("fit_percent"),
        "r2": per_joint_fit("r2"),
    }
    # MATLAB goodnessOfFit's NRMSE cost √(SSE_j/TSS_j), always a fraction and IEEE.
    with np.errstate(invalid="ignore"):
        per_joint["nrmse"] = 1.0 - np.asarray(km["fit_percent"], dtype=np.float64) / 100.0

    pooled = {
        "sse": float(km["sse_total"]),
        "rmse_per_element": float(km["rmse_per_element"]),
        "rmse_per_sample": float(km["rmse_per_sample"]),
        "max_abs_error": float(km["max_abs_error_pooled"]),
        "vaf": pooled_fit("vaf"),
        "fit_percent": pooled_fit("fit_percent"),
        "r2": pooled_fit("r2"),
    }

    aggregates = {"rmse_uniform_average": float(km["rmse_uniform_average"])}
    for name in ("vaf", "fit_percent", "r2"):
        if force:
            values = per_joint[name]
            aggregates[f"{name}_uniform_average"] = float(np.mean(values))
            # Constant joints have weight 0 in both conventions, so the kernel's value stands,
            # except when every joint is constant: then the uniform mean of the forced values.
            aggregates[f"{name}_variance_weighted"] = (
                float(np.mean(values)) if constant.all()
                else float(km[f"{name}_variance_weighted"]) * (scale if name != "r2" else 1.0))
        else:
            s = scale if name != "r2" else 1.0
            aggregates[f"{name}_uniform_average"] = float(km[f"{name}_uniform_average"]) * s
            aggregates[f"{name}_variance_weighted"] = float(km[f"{name}_variance_weighted"]) * s
    aggregates = {
        "uniform_average": {k: aggregates[f"{k}_uniform_average"] for k in ("vaf", "fit_percent", "r2")},
        "variance_weighted": {k: aggregates[f"{k}_variance_weighted"] for k in ("vaf", "fit_percent", "r2")},
        "rmse_uniform_average": aggregates["rmse_uniform_average"],
    }

    # ---- residual statistics
    from . import zero_mean_test

    if lagged:
        zmt = _as_dict(zero_mean_test(e, segments=starts, backend=backend_name))
    else:
        zmt = _iid_zero_mean_test(km, n, prof.ddof)
    residuals = {
        "mean": np.asarray(km["residual_mean"], dtype=np.float64),
        "variance": np.asarray(km["residual_variance"], dtype=np.float64),
        "ddof": prof.ddof,
        "zero_mean_test": zmt,
    }

    # ---- information criteria (constants dropped in the kernel; some profiles add them)
    n_obs = n * m if prof.noise_model == "pooled" else n
    constant_term = n * m * _LN_2PI_PLUS_1 if prof.ic_constant == "included" else 0.0
    ic = {
        "noise_model": prof.noise_model,
        "constant": prof.ic_constant,
        "n_obs": int(n_obs),
        "n_params": int(n_params),
        "aic": float(km["aic"]) + constant_term,
        "bic": float(km["bic"]) + constant_term,
        "aicc": float(km["aicc"]) + constant_term,
        "fpe": float(km["fpe"]),
        "naic": float(km["naic"]),
    }

    # ---- lag analysis
    autocorrelation = ljung_box = None
    lb_lags = prof.ljung_box_lags(n, max_lag, longest)
    if lagged:
        autocorrelation = _autocorrelation_section(kernel, e, max_lag, prof, level, starts, n)
        if lb_lags:
            lb = kernel.portmanteau(e, np.asarray(lb_lags, dtype=np.int64), 0, starts, "ljung_box")
            ljung_box = {
                "test": "ljung_box",
                "lags": np.asarray(lb_lags, dtype=np.int64),
                "model_df": 0,
                "statistic": np.asarray(lb["statistic"], dtype=np.float64),
                "pvalue": np.asarray(lb["pvalue"], dtype=np.float64),
                "log_pvalue": np.asarray(lb["log_pvalue"], dtype=np.float64),
                "df": np.asarray(lb["df"], dtype=np.int64),
            }

    cross = None
    if reg2 is not None:
        cross = _cross_correlation_section(kernel, e, reg2, p_cols, max_lag, prof, level, starts, n, m)

    lengths = segment_lengths(starts, n)
    provenance = {
        "profile": prof.name,
        "conventions": {
            **prof.conventions(),
            "max_lag": int(max_lag),
            "level": level,
            "ljung_box_lags": list(lb_lags),
            "model_df": 0,
            "nan_policy": nan_policy,
            "rmse": "both: rmse_per_element = sqrt(SSE/(N*m)), rmse_per_sample = sqrt(SSE/N)",
            "r2": "centred, 1 - SSE/TSS",
            "zero_mean_test": "i.i.d. Student t and Newey-West (Bartlett) effective sample size",
            "cross_correlation_band": "white" if cross is not None else None,
        },
        "units": {
            "vaf": prof.units,
            "fit_percent": prof.units,
            "r2": "fraction",
            "nrmse": "fraction",
            "torque": "as given",
        },
        "n_samples": int(n),
        "n_joints": int(m),
        "n_params": int(n_params),
        "n_regressor_columns": None if p_cols is None else int(p_cols),
        "segments": [int(x) for x in lengths],
        "omitted_rows": int(omitted),
        "backend": backend_name,
        "dynval_version": _version(),
        "contract_version": _CONTRACT_VERSION,
        "report_schema_version": REPORT_SCHEMA_VERSION,
    }

    report = ValidationReport(
        provenance=provenance,
        per_joint=per_joint,
        pooled=pooled,
        aggregates=aggregates,
        residuals=residuals,
        autocorrelation=autocorrelation,
        ljung_box=ljung_box,
        cross_correlation=cross,
        information_criteria=ic,
    )
    report.warnings_text = findings(report)
    return report


def _version() -> str:
    try:
        from . import __version__

        return str(__version__)
    except ImportError:  # pragma: no cover - only while the package is half-built
        return "unknown"


def _as_dict(result) -> dict:
    if hasattr(result, "_asdict"):
        return dict(result._asdict())
    if hasattr(result, "__dataclass_fields__"):
        return {f: getattr(result, f) for f in result.__dataclass_fields__}
    return dict(result)


def _autocorrelation_section(kernel, e, max_lag, prof, level, starts, n) -> dict:
    rho = np.asarray(kernel.autocorrelation(e, max_lag, prof.adjusted, starts), dtype=np.float64)
    z = _z(level)
    band = np.full_like(rho, np.nan)
    if prof.band == "white":
        band[1:] = z / math.sqrt(n)
    else:
        # Bartlett: var(ρ̂_ℓ) = (1 + 2 Σ_{j<ℓ} ρ̂_j²)/N, lag 1 gives 1/N.
        cum = np.cumsum(rho[1:-1] ** 2, axis=0) if max_lag > 1 else np.zeros((0, rho.shape[1]))
        var = np.vstack([np.ones((1, rho.shape[1])), 1.0 + 2.0 * cum]) / n
        band[1:] = z * np.sqrt(var)
    with np.errstate(invalid="ignore"):
        is_out = np.abs(rho[1:]) > band[1:]  # nan compares False: a constant residual has none
    outside = [(int(j), int(lag + 1), float(rho[lag + 1, j]))
               for j in range(rho.shape[1]) for lag in np.flatnonzero(is_out[:, j])]
    fraction = is_out.sum(axis=0) / float(max_lag)
    nan_joint = np.isnan(rho[0])
    fraction = np.where(nan_joint, np.nan, fraction)
    return {
        "max_lag": int(max_lag),
        "adjusted": bool(prof.adjusted),
        "rho": rho,
        "band_type": prof.band,
        "level": float(level),
        "band": band,
        "outside": outside,
        "fraction_outside": fraction,
    }


def _cross_correlation_section(kernel, e, reg2, p, max_lag, prof, level, starts, n, m) -> dict:
    out = kernel.cross_correlation(e, reg2, p, max_lag, prof.adjusted, starts)
    rho = np.asarray(out["rho"], dtype=np.float64).reshape(m, p, max_lag + 1)
    mask = np.asarray(out["constant_mask"], dtype=bool).reshape(m, p)
    band = _z(level) / math.sqrt(n)
    with np.errstate(invalid="ignore"):
        cells = np.argwhere(np.abs(rho) > band)
    outside = [(int(j), int(c), int(lag), float(rho[j, c, lag]), float(abs(rho[j, c, lag]) / band))
               for j, c, lag in cells]
    outside.sort(key=lambda t: (-t[4], t[0], t[1], t[2]))
    return {
        "max_lag": int(max_lag),
        "adjusted": bool(prof.adjusted),
        "rho": rho,
        "constant_mask": mask,
        "band": float(band),
        "level": float(level),
        "outside": outside,
    }
