"""Section builders of a validation report: each takes what it needs and returns its section's frozen
record (``_records.py``); the parts of a section (``design.excitation``, ``cross_correlation.missing_terms``)
are the contract's mappings.

``validate`` (``_report.py``) checks the inputs once into a :class:`CheckedData`, then runs its phases:
the residual's, the lag analysis and the regressor's are here (:func:`residual_phase`, :func:`lag_phase`,
:func:`regressor_phase`, each returning its typed result), the motion's in ``_motion.py``. The stream
(``stream.py``) calls the builders its sums allow; the assembler (``_assembly.py``) reads the records'
attributes into the evidence the rules read.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ..checks._typing import FloatArray, FusedMetrics, IntArray, Kernels
from ..metrics._profiles import Profile
from ..statistics import _estimation, _stats
from ..statistics._columns import column_norms as _column_norms
from ..statistics._columns import zero_columns
from . import _records as rec
from . import _regressor_algebra as algebra
from ._prepared import Memo, compute_now
from ._regressor_algebra import (
    _RANK_TOL,
    JointGrams,
    _gram_singular_values,
    _leading_base,
    _project_out,
    _r_factor,
    _stacked_r,
    column_largest,
)

if TYPE_CHECKING:
    from ..statistics._estimation import EstimationFit
    from ..statistics._stats import BiasTest, Decimation, Spectrum
    from ._findings import Thresholds
    from ._options import Lags, Options

_LN_2PI_PLUS_1 = math.log(2.0 * math.pi) + 1.0


def _force_finite(values: ArrayLike, constant: ArrayLike) -> FloatArray:
    """scikit-learn's force_finite: a constant target gives 1.0 if exact (nan) else 0.0 (−inf)."""
    values = np.array(values, dtype=np.float64, copy=True)
    constant = np.asarray(constant, dtype=bool)
    values[constant] = np.where(np.isnan(values[constant]), 1.0, 0.0)
    return values


def point_metrics(km: FusedMetrics, prof: Profile) -> tuple[rec.PerJoint, rec.Pooled, rec.Aggregates]:
    """``per_joint``, ``pooled`` and ``aggregates`` from the fused kernel's result."""
    scale = 1.0 if prof.units == "percent" else 0.01
    force = prof.constant_target == "force_finite"
    constant = np.asarray(km["constant_target"], dtype=bool)
    # each fit measure as the kernel gives it: per joint, pooled, uniform and variance-weighted means
    fits = {"vaf": (km["vaf"], km["vaf_pooled"], km["vaf_uniform_average"], km["vaf_variance_weighted"]),
            "fit_percent": (km["fit_percent"], km["fit_percent_pooled"], km["fit_percent_uniform_average"],
                            km["fit_percent_variance_weighted"]),
            "r2": (km["r2"], km["r2_pooled"], km["r2_uniform_average"], km["r2_variance_weighted"])}

    def unit(name: str) -> float:
        return scale if name != "r2" else 1.0

    def per_joint_fit(name: str) -> FloatArray:
        values = np.asarray(fits[name][0], dtype=np.float64) * unit(name)
        return _force_finite(values, constant) if force else values

    def pooled_fit(name: str) -> float:
        value = float(fits[name][1]) * unit(name)
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
    uniform, weighted = {}, {}
    for name in ("vaf", "fit_percent", "r2"):
        if force:
            values = per_joint[name]
            uniform[name] = float(np.mean(values))
            # Constant joints have weight 0 in both conventions, so the kernel's value stands,
            # except when every joint is constant: then the uniform mean of the forced values.
            weighted[name] = (float(np.mean(values)) if constant.all()
                              else float(fits[name][3]) * unit(name))
        else:
            uniform[name] = float(fits[name][2]) * unit(name)
            weighted[name] = float(fits[name][3]) * unit(name)
    aggregates = {"uniform_average": uniform, "variance_weighted": weighted,
                  "rmse_uniform_average": float(km["rmse_uniform_average"])}
    return rec.PerJoint.of(per_joint), rec.Pooled.of(pooled), rec.Aggregates.of(aggregates)


def bias_section(test: BiasTest, rmse: FloatArray) -> rec.Bias:
    """The bias section from the statistics' bias test (:func:`dynval.statistics._stats.bias_t_test`):
    the residual mean against its coloured-noise standard error, Student t with N_eff − 1 degrees of
    freedom (N_eff from the prewhitened Bartlett long-run variance); effect = |ē_j| / RMSE_j."""
    lr = test.long_run
    with np.errstate(invalid="ignore", divide="ignore"):
        effect = np.abs(test.mean) / np.asarray(rmse, dtype=float)
    out: dict[str, Any] = {"method": "student_t_n_eff", "long_run_variance_method": lr.method, "mean": test.mean,
           "std": test.std, "n_eff": lr.n_eff, "phi": lr.phi, "bandwidth": lr.bandwidth, "statistic": test.statistic,
           "pvalue": test.pvalue, "df": lr.n_eff - 1.0, "effect": effect, "effect_unit": "|mean| / RMSE",
           "standard_error": test.standard_error}
    if test.parameter_standard_error is not None:
        out["method"] = "student_t_n_eff_with_parameter_error"
        out["parameter_standard_error"] = test.parameter_standard_error
    return rec.Bias.of(out)


def information_criteria(km: FusedMetrics, prof: Profile, noise_model: str, n: int, m: int, n_params: int,
                         n_eff: FloatArray | None) -> rec.InformationCriteria:
    """The lesson's criteria of the noise model and, beside them, their N_eff-based variants."""
    n_obs = n * m if noise_model == "pooled" else n
    constant_term = n * m * _LN_2PI_PLUS_1 if prof.ic_constant == "included" else 0.0
    ic: dict[str, Any] = {
        "noise_model": noise_model, "constant": prof.ic_constant, "n_obs": int(n_obs), "n_params": int(n_params),
        "aic": float(km["aic"]) + constant_term, "bic": float(km["bic"]) + constant_term,
        "aicc": float(km["aicc"]) + constant_term, "fpe": float(km["fpe"]), "naic": float(km["naic"]),
    }
    if n_eff is not None:
        # The fit term scaled by N_eff/N: coloured samples carry less information each. A heuristic
        # named as such; the lesson's form above stays the headline.
        fit = float(km["aic"]) - 2.0 * n_params
        ratio = float(np.sum(n_eff)) / (n * m)
        n_eff_obs = n_obs * ratio
        fit_eff = fit * ratio
        p = n_params
        ic["n_eff"] = float(n_eff_obs)
        ic["aic_neff"] = fit_eff + 2.0 * p + constant_term * ratio
        ic["bic_neff"] = fit_eff + p * math.log(n_eff_obs) + constant_term * ratio
        ic["aicc_neff"] = (ic["aic_neff"] + 2.0 * p * (p + 1) / (n_eff_obs - p - 1)
                           if n_eff_obs - p - 1 > 0 else float("nan"))
    return rec.InformationCriteria.of(ic)


def autocorrelation(kernel: Any, e: FloatArray | None, max_lag: int, prof: Profile, level: float, starts: IntArray,
                    n: int) -> rec.Autocorrelation:
    """The ACF with its band (white or Bartlett) and the lags outside it."""
    rho = np.asarray(kernel.autocorrelation(e, max_lag, prof.adjusted, starts), dtype=np.float64)
    z = _stats.z_two_sided(level)
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
    fraction = np.where(np.isnan(rho[0]), np.nan, fraction)
    return rec.Autocorrelation.of({"max_lag": int(max_lag), "adjusted": bool(prof.adjusted), "rho": rho,
                                   "band_type": prof.band, "level": float(level), "band": band, "outside": outside,
                                   "fraction_outside": fraction})


def ljung_box(kernel: Any, e: FloatArray | None, lags: Sequence[int], starts: IntArray) -> rec.LjungBox:
    lb = kernel.portmanteau(e, np.asarray(lags, dtype=np.int64), 0, starts, "ljung_box")
    return rec.LjungBox.of({"test": "ljung_box", "lags": np.asarray(lags, dtype=np.int64), "model_df": 0,
                            "statistic": np.asarray(lb["statistic"], dtype=np.float64),
                            "pvalue": np.asarray(lb["pvalue"], dtype=np.float64),
                            "log_pvalue": np.asarray(lb["log_pvalue"], dtype=np.float64),
                            "df": np.asarray(lb["df"], dtype=np.int64)})


def whiteness(kernel: Any, lb: rec.LjungBox, rate: Decimation | None, sample_rate: float | None, *,
              bandwidth: float | None = None, lag: int | None = None) -> rec.Whiteness:
    """Ljung–Box at the logged rate and, on oversampled data, at the rate that carries information.

    ``rate``: the residual at that rate (:func:`dynval.statistics._stats.information_rate`); None
    tests at the logged rate only. ``bandwidth`` (Hz): ``above_bandwidth`` says when the test still
    sees frequencies above it. ``lag``: the decimated test's largest lag (samples of the decimated
    rate; the logged test's otherwise).
    """
    raw_p = np.asarray(lb.pvalue[0], dtype=float)
    lag = int(lb.lags[0]) if lag is None else int(lag)
    fs = 1.0 if sample_rate is None else float(sample_rate)
    band = None if rate is None else rate.band
    out: dict[str, Any] = {"test": "ljung_box", "lag": lag, "pvalue_raw": raw_p,
           "log_pvalue_raw": np.asarray(lb.log_pvalue[0], dtype=float), "decimation": 1,
           "information_band": band, "information_band_source": "prediction" if band is not None else None,
           "pvalue_decimated": None, "lag_decimated": None,
           "n_decimated": None}
    if rate is not None and rate.residual is not None and rate.starts is not None:
        x, x_starts = rate.residual, rate.starts
        longest = int(np.diff(np.append(x_starts, x.shape[0])).max())
        h = min(lag, x.shape[0] // 5, longest - 1)
        if h >= 1:
            res = kernel.portmanteau(np.ascontiguousarray(x), np.array([h], dtype=np.int64), 0, x_starts,
                                     "ljung_box")
            out.update(decimation=rate.factor, pvalue_decimated=np.asarray(res["pvalue"][0], dtype=float),
                       lag_decimated=int(h), n_decimated=int(x.shape[0]))
    tested_nyquist = fs / (2.0 * int(out["decimation"]))
    out["bandwidth"] = bandwidth
    out["above_bandwidth"] = bool(bandwidth is not None and tested_nyquist > bandwidth * (1 + 1e-9))
    return rec.Whiteness.of(out)


def spectrum_section(spec: Spectrum, sample_rate: float | None, regressor_removed: bool) -> rec.Spectrum:
    """The report's spectrum section from the tested spectrum (:class:`dynval.statistics._stats.Spectrum`)."""
    top = sorted(spec.peaks, key=lambda d: (d["pvalue"], -d["share"]))[:3 * spec.power.shape[1]]
    return rec.Spectrum.of({"frequency": spec.frequency, "frequency_unit": "Hz" if sample_rate else "cycles/sample",
                            "power": spec.power, "dof": spec.dof, "nperseg": spec.nperseg,
                            "regressor_removed": regressor_removed, "peaks": top})


# Up to this many lags the compiled lagged products beat the FFT on the regressor's columns
# (benchmarks/README.md: 0.75 s against 2.7 s for 490 columns of 200,000 rows at 50 lags, about
# 12 ms more per lag, while the FFT's cost hardly depends on the lags).
_DIRECT_ACF_LAGS = 128


def _biased_acf(kernel: Kernels, x: FloatArray, starts: IntArray, big: int,
                live: IntArray | None = None) -> FloatArray:
    """Biased autocorrelation of every column of ``x`` (the residual's, the regressor's) to lag
    ``big`` (acf_fft's definition): the compiled kernel's direct sums when the backend is cpp,
    the lags few and the array contiguous (no copy), else :func:`dynval.statistics._stats.acf_fft`
    (``live``: the columns known not to be all zeros)."""
    if _direct_acf(kernel, x, big):
        return np.asarray(kernel.autocorrelation(x, big, False, np.asarray(starts, dtype=np.int64)))
    return _stats.acf_fft(x, starts, big, live=live)


def _regressor_band(kernel: Kernels, reg2: FloatArray, starts: IntArray, big: int, m: int,
                    memo: Memo[Any]) -> FloatArray | _stats.ColumnPowers:
    """The regressor's half of the colour-aware band to ``big`` lags: the weighted
    autocorrelations of its columns (:func:`dynval.statistics._stats.weighted_column_acf`) where
    the compiled kernel sums the few lags directly, else the columns' transforms
    (:func:`dynval.statistics._stats.column_powers`), whose inverse transforms the band never needs."""
    n, p = reg2.shape[0], reg2.shape[1] // m
    largest = column_largest(reg2.reshape(n, m, p), memo).ravel()
    live = np.flatnonzero(largest > 0)
    if _direct_acf(kernel, reg2, big) or big <= _stats._DIRECT_LAGS:
        return _stats.weighted_column_acf(_biased_acf(kernel, reg2, starts, big, live).reshape(big + 1, m, p))
    return _stats.column_powers(reg2, starts, big, m, live, largest)


def _direct_acf(kernel: Kernels, x: FloatArray, big: int) -> bool:
    """Whether :func:`_biased_acf` takes the compiled kernel's direct sums."""
    from ..kernels import _reference

    return kernel is not _reference and big <= _DIRECT_ACF_LAGS and x.flags.c_contiguous and x.dtype == np.float64


def _kept_moments(kernel: Kernels, reg2: FloatArray, memo: Memo[Any]) -> tuple[Any, ...]:
    """The compiled kernel's moments of the regressor's columns (half of its time on a log of few
    lags), as an extra argument from the call's memo: a prepared regressor keeps them for every call,
    a plain one for this call (the columns' largest values are read from the same moments); none for
    the reference kernel."""
    if not hasattr(kernel, "regressor_moments"):
        return ()
    return (memo(("regressor_moments", reg2.shape), lambda: kernel.regressor_moments(reg2)),)


def cross_correlation(kernel: Kernels, e: FloatArray, reg2: FloatArray, p: int, max_lag: int, prof: Profile,
                      level: float, starts: IntArray, n: int, m: int, n_eff: FloatArray | None, detail: str,
                      memo: Memo[Any] = compute_now) -> tuple[rec.CrossCorrelation, FloatArray, FloatArray]:
    """Residual × regressor-column correlations with a colour-aware standard deviation per cell.

    The band of the lesson (z/√N) is kept for reference; the findings use Bartlett's variance
    (:func:`dynval.statistics._stats.cross_correlation_sd`) with J lags, J ≥ 5 N/N_eff of the residual, so
    a smooth regressor column and a coloured residual are not taken for evidence.
    """
    out = kernel.cross_correlation(e, reg2, p, max_lag, prof.adjusted, starts,
                                   *_kept_moments(kernel, reg2, memo))
    rho = np.asarray(out["rho"], dtype=np.float64).reshape(m, p, max_lag + 1)
    mask = np.asarray(out["constant_mask"], dtype=bool).reshape(m, p)
    band = _stats.z_two_sided(level) / math.sqrt(n)
    lengths = np.diff(np.append(starts, n))
    longest = int(lengths.max())
    tau_int = float(np.fmax.reduce(n / np.asarray(n_eff, dtype=float))) if n_eff is not None else 1.0
    tau_int = tau_int if np.isfinite(tau_int) else 1.0
    big = int(min(longest - 1, max(max_lag, math.ceil(5.0 * tau_int)), max(n // 4, 1)))
    rho_e = _biased_acf(kernel, e, starts, big)
    # the regressor's half of the band: the same for every residual on this regressor
    key = ("columns_acf", getattr(kernel, "__name__", str(kernel)), reg2.shape, tuple(int(s) for s in starts), big)
    weighted_y = memo(key, partial(_regressor_band, kernel, reg2, starts, big, m, memo))
    lags = np.arange(max_lag + 1)
    n_l = np.maximum(lengths[None, :] - lags[:, None], 0).sum(axis=1).astype(float)
    d_l = n_l if prof.adjusted else np.full_like(n_l, float(n))
    sd = _stats.colour_aware_sd(rho_e, weighted_y, n_l, d_l)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.abs(rho) / sd
    zf = np.where(np.isnan(z), -1.0, z)
    lag_max = zf.argmax(axis=2)
    take = np.take_along_axis
    z_max = take(z, lag_max[:, :, None], axis=2)[:, :, 0]
    rho_max = take(rho, lag_max[:, :, None], axis=2)[:, :, 0]
    colour = (sd[:, :, 0] / (math.sqrt(n_l[0]) / d_l[0]))
    with np.errstate(invalid="ignore"):
        white_hits = np.argwhere(np.abs(rho) > band)
    top = _top_cells(lag_max, rho_max, z_max)
    section: dict[str, Any] = {
        "max_lag": int(max_lag), "adjusted": bool(prof.adjusted), "constant_mask": mask, "band": float(band),
        "level": float(level), "n_outside_white_band": len(white_hits),
        "colour_lags": int(big), "colour_factor": colour, "max_abs_rho": np.abs(rho_max), "lag_of_max": lag_max,
        "z_max": z_max, "top_cells": top, "detail": detail,
        # (joint, column, lag, rho, z) of the strongest cells, strongest first
        "outside": top,
    }
    if detail == "full":
        section["rho"] = rho
        section["sd"] = sd
        section["outside"] = sorted(((int(j), int(c), int(lag), float(rho[j, c, lag]), float(z[j, c, lag]))
                                     for j, c, lag in white_hits), key=lambda t: (-t[4], t[0], t[1], t[2]))
    return rec.CrossCorrelation.of(section), rho, sd


def _top_cells(lag_max: IntArray, rho_max: FloatArray, z_max: FloatArray) -> list[tuple[int, int, int, float, float]]:
    """(joint, column, lag, rho, z) of the strongest cells, strongest first (ties by joint, then
    column): the five strongest of each joint and the two strongest of each column, so that a
    report stays small on p = 70 columns."""
    jj, cc = np.nonzero(np.isfinite(z_max))
    order = np.lexsort((cc, jj, -z_max[jj, cc]))  # by −z, then joint, then column
    jj, cc = jj[order], cc[order]
    cells = zip(jj.tolist(), cc.tolist(), lag_max[jj, cc].tolist(), rho_max[jj, cc].tolist(),
                z_max[jj, cc].tolist())
    seen_joint: dict[int, int] = {}
    seen_column: dict[int, int] = {}
    top = []
    for cell in cells:
        j, c = cell[0], cell[1]
        if seen_joint.get(j, 0) < 5 or seen_column.get(c, 0) < 2:
            top.append(cell)
        seen_joint[j] = seen_joint.get(j, 0) + 1
        seen_column[c] = seen_column.get(c, 0) + 1
    return top


def segment_metrics(kernel: Kernels, meas: FloatArray, pred: FloatArray, names: Sequence[str],
                    lengths: Sequence[int], n_params: int, prof: Profile) -> dict[str, rec.Segment]:
    """Per-joint RMSE, VAF, fit, R² and mean of each named segment (e.g. transient and steady)."""
    out: dict[str, rec.Segment] = {}
    start = 0
    for name, length in zip(names, lengths):
        a, b = start, start + int(length)
        start = b
        mt, pr = meas[a:b], pred[a:b]
        rows = np.all(np.isfinite(mt), axis=1) & np.all(np.isfinite(pr), axis=1)
        mt, pr = np.ascontiguousarray(mt[rows]), np.ascontiguousarray(pr[rows])
        if mt.shape[0] < 2:
            out[name] = rec.Segment.of({"n_samples": int(mt.shape[0])})
            continue
        km = kernel.compute_metrics(mt, pr, n_params, prof.ddof, prof.noise_model)
        pj, pooled, _ = point_metrics(km, prof)
        out[name] = rec.Segment.of({
            "n_samples": int(mt.shape[0]), "start": int(a),
            "per_joint": {"rmse": pj.rmse, "max_abs_error": pj.max_abs_error, "vaf": pj.vaf,
                          "fit_percent": pj.fit_percent, "r2": pj.r2},
            "mean": np.asarray(km["residual_mean"], dtype=float),
            "pooled": {"rmse_per_element": pooled.rmse_per_element, "vaf": pooled.vaf,
                       "fit_percent": pooled.fit_percent, "r2": pooled.r2}})
    return out


def _relative_distance(a: FloatArray, b: FloatArray, centre: bool) -> float:
    """‖a − b‖ / ‖b − b̄‖ (centred) or ‖a − b‖ / ‖b‖ on the rows both runs have."""
    rows = min(a.shape[0], b.shape[0])
    a, b = a[:rows], b[:rows]
    ref = b - b.mean(axis=0) if centre else b
    denom = float(np.linalg.norm(ref))
    return float(np.linalg.norm(a - b)) / denom if denom > 0 else float("inf")


def _excitation(r_factor: Callable[[IntArray], FloatArray], n_rows: int, norms: FloatArray, gram: FloatArray | None,
                est: FloatArray | None, structure: FloatArray | None = None) -> dict[str, Any]:
    """The excitation section (contract §4): the columns that are structural (zero or exact
    combinations of others in both runs: reduced to the identifiable combinations), those the
    validation run leaves unexcited or inseparable while the estimation run excites them, and the
    condition number over the combinations the validation run excites. ``r_factor(k)`` is R of the
    stacked validation regressor (``n_rows`` rows) scaled by 2^-k. Without the estimation run's
    regressor, the model's ``structure`` (its regressor at states its structure allows) stands for
    it in telling the structural columns (``structural_source``: "estimation", "model" or None);
    the motion ratios stay the estimation run's only."""
    p = norms.shape[0]
    with_est = est is not None and est.shape[1] == p
    source = "estimation" if with_est else "model" if structure is not None and structure.shape[1] == p else None
    motion_ref = est if with_est else None
    ref = est if with_est else structure if source == "model" else None
    with_est = ref is not None
    est_norms = _column_norms(ref) if ref is not None else None
    fast = _gram_singular_values(gram, norms) if gram is not None else None
    if fast is not None:  # full column rank in the validation run: nothing is structural or unexcited
        sv, sv_s = fast
        everything = list(range(p))
        out: dict[str, Any] = {"unexcited": [], "inseparable": [], "unidentifiable": [],
                               "structural": [] if with_est else None, "identifiable_rank": p if with_est else None,
                               "identifiable_columns": everything if with_est else None, "validation_rank": p}
    else:
        zero_v = zero_columns(norms)
        both = np.hypot(norms, est_norms) if est_norms is not None else norms
        k = np.where(both > 0, np.frexp(both)[1], 0).astype(np.int64)
        every = np.arange(p)
        r_v = r_factor(k)
        structural: list[int] | None = None
        unidentifiable: list[int] = []
        if ref is not None:
            zero_s = zero_columns(both)
            nz = np.flatnonzero(~zero_s)
            base = np.zeros(0, dtype=np.intp)
            if nz.size:
                r_s = np.asarray(np.linalg.qr(np.vstack([_r_factor(ref, nz, k[nz]), r_v[:, nz]]), mode="r"))
                base = nz[_leading_base(r_s, _RANK_TOL)]
            unidentifiable = [int(c) for c in np.flatnonzero(zero_s)]
            structural = [int(c) for c in np.setdiff1d(every, base)]
        else:
            base = every
        candidates = base[~zero_v[base]]
        live = np.zeros(0, dtype=np.intp)
        if candidates.size:
            live = candidates[_leading_base(r_v[:, candidates], _RANK_TOL)]
        out = {"unexcited": [int(c) for c in base[zero_v[base]]],
               "inseparable": [int(c) for c in np.setdiff1d(candidates, live)],
               "unidentifiable": unidentifiable, "structural": structural,
               "identifiable_rank": int(base.size) if with_est else None,
               "identifiable_columns": [int(c) for c in base] if with_est else None,
               "validation_rank": int(live.size)}
        if live.size:
            r_live = r_v[:, live]
            sv = np.linalg.svd(np.ldexp(r_live, k[live]), compute_uv=False)
            sv_s = np.linalg.svd(r_live / np.ldexp(norms[live], -k[live]), compute_uv=False)
        else:
            sv = sv_s = np.zeros(1)
    with np.errstate(divide="ignore"):
        out["condition_raw"] = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
        out["condition_scaled"] = float(sv_s[0] / sv_s[-1]) if sv_s[-1] > 0 else float("inf")
    out["rank_tolerance"] = _RANK_TOL
    out["column_norms"] = norms
    out["structural_source"] = source
    if motion_ref is not None and est_norms is not None:
        # each column's RMS per row on the validation run over the estimation run's
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            out["column_motion_ratio"] = np.where(
                est_norms > 0, (norms / math.sqrt(n_rows)) / (est_norms / math.sqrt(motion_ref.shape[0])), np.nan)
    return out


def design(reg3: FloatArray | None, q_val: FloatArray | None, estimation: Mapping[str, FloatArray] | None,
           meas: FloatArray, thresholds: Thresholds | None = None, grams: JointGrams | None = None,
           sample_rate: float | None = None, memo: Memo[Any] = compute_now, estimation_key: tuple[Any, ...] = (),
           structure: FloatArray | None = None) -> rec.Design | None:
    """Whether the validation run repeats the estimation run, and how well it excites the model.

    Repeat (conventions §5.6): the share of the validation run whose state (q, q̇, q̈ from ``q``,
    else the regressor's leading principal components) lies within ``repeat_tolerance`` of the
    estimation trajectory at any time (``dynval.statistics._repeat``); ``is_repeat`` when the share exceeds
    ``repeat_share``. Without a state in both runs, the time-aligned torque distance decides
    (below ``repeat_distance``). The time-aligned distances are kept beside it: the relative
    regressor distance ‖Y_val − Y_est‖/‖Y_est‖, the joint-space distance ‖q_val − q_est‖/‖q_est −
    q̄_est‖ (and its RMS in the units of q) and the torque distance ‖τ_val − τ_est‖/‖τ_est − τ̄_est‖
    on the rows both runs have; ``measure`` and ``distance`` are the first of them available.
    Excitation: :func:`_excitation` (``structure``: the model's regressor at states its structure
    allows, from a prepared regressor, which tells structural columns without the estimation run).
    """
    from ..statistics import _repeat
    from ._findings import Thresholds

    th = thresholds if thresholds is not None else Thresholds()
    out: dict[str, Any] = {}
    if estimation is not None:
        rep: dict[str, Any] = {}
        if "regressor" in estimation and reg3 is not None:
            est = estimation["regressor"]
            rep["regressor"] = _relative_distance(reg3.reshape(reg3.shape[0], -1), est.reshape(est.shape[0], -1),
                                                  centre=False)
        if "q" in estimation and q_val is not None:
            rep["q"] = _relative_distance(q_val, estimation["q"], centre=True)
            rows = min(q_val.shape[0], estimation["q"].shape[0])
            rep["q_rms"] = float(np.sqrt(np.mean((q_val[:rows] - estimation["q"][:rows]) ** 2)))
        if "tau" in estimation:
            rep["tau"] = _relative_distance(meas, estimation["tau"], centre=True)
        for measure in ("regressor", "q", "tau"):
            if measure in rep:
                rep["measure"] = measure
                rep["distance"] = rep[measure]
                break
        near = _repeat.repeat_share(q_val, estimation.get("q"), reg3,
                                    estimation.get("regressor") if reg3 is not None else None, sample_rate,
                                    th.repeat_tolerance)
        if near is not None:
            rep.update(near)
            rep["threshold"] = th.repeat_share
            rep["is_repeat"] = bool(near["share"] > th.repeat_share)
        elif "distance" in rep:
            rep["share"] = None
            rep["threshold"] = th.repeat_distance
            rep["is_repeat"] = bool(rep["distance"] < th.repeat_distance)
        out["repeat"] = rep or None
    if reg3 is not None:
        # the regressors' alone (``estimation_key`` names the estimation run's)
        out["excitation"] = memo(("excitation", reg3.shape, estimation_key),
                                 lambda: _regressor_excitation(reg3, grams, estimation, memo, structure))
    return rec.Design.of(out) if out else None


def _regressor_excitation(reg3: FloatArray, grams: JointGrams | None, estimation: Mapping[str, FloatArray] | None,
                          memo: Memo[Any] = compute_now, structure: FloatArray | None = None) -> dict[str, Any]:
    """:func:`_excitation` of the stacked validation regressor (and the estimation run's, else the
    model's structure)."""
    stacked = reg3.reshape(-1, reg3.shape[2])
    gram = grams.stacked() if grams is not None and grams.usable else None
    norms = np.sqrt(np.diag(gram).copy()) if gram is not None else _column_norms(stacked)
    est = None
    if estimation is not None and "regressor" in estimation:
        est = estimation["regressor"].reshape(-1, estimation["regressor"].shape[2])
    return _excitation(partial(_stacked_r, reg3, memo=memo), stacked.shape[0], norms, gram, est, structure)


# --------------------------------------------------------------------------- validate's phases


@dataclass(frozen=True)
class CheckedData:
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
    # the estimation run's and the measured torques' parts of a kept result's key (_prepared.kept_keys)
    estimation_key: tuple[Any, ...] = ()
    meas_key: tuple[Any, ...] = ()
    # the named segments as given (names, lengths), which get point metrics of their own
    named: tuple[list[str], list[int]] | None = None

    @property
    def n(self) -> int:
        return int(self.meas.shape[0])

    @property
    def m(self) -> int:
        return int(self.meas.shape[1])


class Residual(NamedTuple):
    """The point metrics, the residual's moments and zero-mean test, the estimation refit, the bias
    test, the criteria, and the regressor's Gram matrices the later phases share."""

    km: FusedMetrics
    per_joint: rec.PerJoint
    pooled: rec.Pooled
    aggregates: rec.Aggregates
    residuals: rec.Residuals
    est_fit: EstimationFit | None
    bias: rec.Bias | None
    ic: rec.InformationCriteria
    grams: JointGrams | None
    est_key: tuple[Any, ...]  # the estimation run's part of a kept result's key (CheckedData.estimation_key)
    segments: dict[str, rec.Segment] | None = None  # each named segment's point metrics

    @property
    def n_eff(self) -> FloatArray | None:
        """Each joint's effective sample size from the bias test (None without lags)."""
        return None if self.bias is None else self.bias.n_eff


def residual_phase(d: CheckedData, o: Options) -> Residual:
    """Point metrics (the named segments' too), then each lower module once: the regressor's Gram
    matrices, the estimation refit, the zero-mean test (the public metric's checked core) and the
    bias test; then the residual's sections and the criteria."""
    from ..metrics._api import checked_zero_mean_test

    prof, lags, memo = o.profile, d.lags, d.memo
    km = o.kernel.compute_metrics(d.meas, d.pred, o.n_params, prof.ddof, o.noise_model)
    per_joint, pooled, aggregates = point_metrics(km, prof)
    segments = None if d.named is None else segment_metrics(o.kernel, d.given_meas, d.given_pred, *d.named,
                                                            o.n_params, prof)
    # One pass over the regressor for both the spectrum's projection and the excitation section.
    reg3 = d.reg3
    grams = None if reg3 is None else memo(
        ("grams", reg3.shape), lambda: algebra.JointGrams(reg3, algebra.column_largest(reg3, memo)))
    # The estimation run, when given with its torques: the parameters' coloured-noise covariance
    # (the bias and regressor tests allow for it) and the refit that names a missing term.
    est = o.estimation or {}
    est_fit = param_var = None
    if reg3 is not None and d.p_cols is not None and d.e is not None and "regressor" in est and "tau" in est:
        cols = tuple(int(c) for c in (o.model_columns if o.model_columns is not None else range(d.p_cols)))
        fit = est_fit = memo(("fit_columns", d.estimation_key, cols),
                             lambda: _estimation.fit_columns(est["regressor"], est["tau"], cols))
        means = memo(("column_means", reg3.shape, fit.columns), lambda: reg3[:, :, list(fit.columns)].mean(axis=0))
        param_var = _estimation.quadratic_forms(fit, means)
    bias_t = None
    if lags.max_lag > 0:
        assert d.e is not None  # a residual whenever lags are analysed
        zero_mean = checked_zero_mean_test(d.e, o.kernel, lags.starts, lags.longest)
        zmt = {name: getattr(zero_mean, name) for name in zero_mean.__dataclass_fields__}
        bias_t = _stats.residual_bias_test(d.e, lags.starts, param_var)
    else:
        zmt = _stats.iid_zero_mean(km["residual_mean"], km["residual_variance"], d.n, prof.ddof)._asdict()
    residuals = rec.Residuals.of({"mean": np.asarray(km["residual_mean"], dtype=np.float64),
                                  "variance": np.asarray(km["residual_variance"], dtype=np.float64),
                                  "ddof": prof.ddof, "zero_mean_test": zmt})
    bias = None if bias_t is None else bias_section(bias_t, per_joint.rmse)
    ic = information_criteria(km, prof, o.noise_model, d.n, d.m, o.n_params, None if bias is None else bias.n_eff)
    return Residual(km, per_joint, pooled, aggregates, residuals, est_fit, bias, ic, grams, d.estimation_key, segments)


class Lagged(NamedTuple):
    """The lag analysis: ACF, Ljung–Box, whiteness at the information rate, the residual's spectrum."""

    lb_lags: list[int]
    acf: rec.Autocorrelation | None = None
    lb: rec.LjungBox | None = None
    white: rec.Whiteness | None = None
    spec: rec.Spectrum | None = None
    spec_tests: Spectrum | None = None
    spec_sides: tuple[FloatArray, FloatArray] | None = None


def lag_phase(d: CheckedData, o: Options, r: Residual) -> Lagged:
    """ACF and Ljung–Box from the kernels; the residual less what the regressor explains; the
    statistics of the information rate and of the spectra; then whiteness and spectrum sections."""
    lags = d.lags
    if lags.max_lag <= 0:
        return Lagged(lags.lb_lags)
    assert d.e is not None  # a residual whenever lags are analysed
    acf = autocorrelation(o.kernel, d.e, lags.max_lag, o.profile, o.level, lags.starts, d.n)
    lb = ljung_box(o.kernel, d.e, lags.lb_lags, lags.starts) if lags.lb_lags else None
    x = _project_out(d.e, d.reg3, r.grams, d.memo) if d.reg3 is not None else d.e
    rate = None if lb is None else _stats.information_rate(d.e, d.pred, lags.starts, o.decimate, o.sample_rate,
                                                           band=lags.band, bandwidth=o.bandwidth)
    spectra = _stats.residual_spectra(x, d.meas, d.pred, lags.starts, sample_rate=o.sample_rate)
    white = None
    if lb is not None:
        white = whiteness(o.kernel, lb, rate, o.sample_rate, bandwidth=o.bandwidth, lag=lags.white_lag)
    spec = spectrum_section(spectra.residual, o.sample_rate, d.reg3 is not None)
    return Lagged(lags.lb_lags, acf, lb, white, spec, spectra.residual, spectra.sides)


class Crossed(NamedTuple):
    """The residual against the regressor's columns, and the columns the model lacks."""

    cross: rec.CrossCorrelation | None = None
    xrho: FloatArray | None = None
    xsd: FloatArray | None = None
    missing: rec.MissingTerms | None = None


def regressor_phase(d: CheckedData, o: Options, r: Residual) -> Crossed:
    """Cross-correlation with the regressor's columns (the kernel's, with the colour-aware sd), then
    the estimation module once: the sd widened by the estimated parameters' error, and the columns
    the model lacks (refit on the estimation run, else the added-variable test)."""
    if d.reg2 is None:
        return Crossed()
    assert d.e is not None and d.p_cols is not None and d.reg3 is not None  # with a regressor
    starts, memo, reg3 = d.lags.starts, d.memo, d.reg3
    cross, xrho, xsd = cross_correlation(o.kernel, d.e, d.reg2, d.p_cols, d.lags.max_lag, o.profile, o.level,
                                         starts, d.n, d.m, r.n_eff, o.detail, memo=memo)
    if r.est_fit is not None:
        xsd = _estimation.parameter_error_sd(xrho, xsd, d.e, reg3, r.est_fit, starts, o.profile.adjusted, o.level,
                                             memo=memo)
    found = None
    if o.model_columns is not None and r.est_fit is not None:
        est = o.estimation or {}
        cols = tuple(int(c) for c in o.model_columns)
        found = memo(("missing_terms", r.est_key, reg3.shape, cols, d.meas_key),
                     lambda: _estimation.missing_terms(est["regressor"], est["tau"], reg3, d.meas, cols))
    elif o.model_columns is not None:
        found = _estimation.added_variable(d.e, reg3, o.model_columns, starts, r.n_eff)
    missing = rec.record_or_none(rec.MissingTerms, found)
    if r.est_fit is not None:
        cross = cross.with_(parameter_error=True)
    if missing is not None:
        cross = cross.with_(missing_terms=dict(missing))
    return Crossed(cross, xrho, xsd, missing)
