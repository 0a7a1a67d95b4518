"""The python and cpp backends agree on random data, through every public function.

Shapes (N from 2 to a few thousand, m from 1 to 7), scales (1e-6 to 1e6, with offsets), dtypes
(float64, float32, int) and memory layouts (C, Fortran, strided, reversed) are drawn by
hypothesis. Each quantity is compared with a tolerance of 1e-14 of its *natural* size, never
relative to a value that may be near zero:

* R², fit and VAF: scaled by TSS, i.e. by max(1, SSE/TSS) (R² itself is 1 − SSE/TSS);
* autocorrelation and cross-correlation: by R(0) (ρ is already normalised, so absolute);
* information criteria: by the size of their terms, n + |F| + 2p + p·ln n (F = n·ln σ̂²
  changes by n·δ for a relative change δ of σ̂²);
* sums, means and variances: by the sum of magnitudes they are built from.

Badly conditioned draws (a joint whose spread is below 1e-9 of its offset, a nearly singular
residual covariance for the ``full`` noise model) are rejected with ``assume``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats
from hypothesis import assume, given
from hypothesis import strategies as st

import dynval

if not dynval.backends()["cpp"]["available"]:
    pytest.skip("the compiled backend dynval._core is not available", allow_module_level=True)

TOL = 1e-14


# --------------------------------------------------------------------------- data


@st.composite
def problems(draw, max_n=3000, max_m=7):
    """(tau_meas, tau_pred, info) with a drawn shape, scale, offset, dtype and layout."""
    n = draw(st.integers(2, max_n))
    m = draw(st.integers(1, max_m))
    one_d = m == 1 and draw(st.booleans())
    scale = 10.0 ** draw(st.floats(-6, 6))
    offset = scale * draw(st.sampled_from([0.0, 1.0, -30.0, 1e3]))
    dtype = draw(st.sampled_from(["float64", "float64", "float32", "int64"]))
    layout = draw(st.sampled_from(["C", "F", "strided", "reversed"]))
    noise = draw(st.sampled_from([1e-3, 0.1, 1.0, 10.0]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    # Robot-like torques: smooth trajectories with joint-specific offsets, plus a residual that
    # is partly autocorrelated.
    walk = np.cumsum(rng.normal(size=(n, m)), axis=0) / math.sqrt(max(n, 1))
    tau = offset + scale * (walk + rng.normal(size=(1, m)))
    resid = scale * noise * (0.5 * rng.normal(size=(n, m)) + 0.5 * np.cumsum(rng.normal(size=(n, m)), axis=0) / 10)
    pred = tau - resid
    if dtype == "int64":
        # Integers of a useful size: the scale is that of the integer grid.
        tau = np.round(tau / scale * 1000)
        pred = np.round(pred / scale * 1000)
    if one_d:
        tau, pred = tau[:, 0], pred[:, 0]
    tau = _layout(tau.astype(dtype), layout)
    pred = _layout(pred.astype(dtype), layout)
    return tau, pred, {"n": n, "m": m, "layout": layout, "dtype": dtype}


def _layout(a: np.ndarray, layout: str) -> np.ndarray:
    if layout == "F":
        return np.asfortranarray(a)
    if layout == "strided":
        wide = np.zeros((a.shape[0] * 2,) + a.shape[1:], dtype=a.dtype)
        wide[::2] = a
        return wide[::2]
    if layout == "reversed":
        return np.ascontiguousarray(a[::-1])[::-1]
    return np.ascontiguousarray(a)


def as_float_2d(a) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    return a.reshape(-1, 1) if a.ndim == 1 else a


def well_conditioned(a: np.ndarray) -> bool:
    """Every joint varies by more than 1e-9 of its magnitude (or is exactly constant)."""
    a = as_float_2d(a)
    spread = a.max(axis=0) - a.min(axis=0)
    size = np.abs(a).max(axis=0)
    return bool(np.all((spread == 0) | (spread > 1e-9 * size)))


def segments_for(n: int, data) -> list[int] | None:
    if n < 6 or not data.draw(st.booleans()):
        return None
    cut = data.draw(st.integers(2, n - 2))
    return [cut, n - cut]


# --------------------------------------------------------------------------- comparison


def close(got, want, scale, what):
    """|got − want| <= TOL · scale elementwise; nan and ±inf must match exactly."""
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    assert got.shape == want.shape, what
    special = ~np.isfinite(want)
    np.testing.assert_array_equal(got[special], want[special], err_msg=what)
    scale = np.broadcast_to(np.asarray(scale, dtype=np.float64), want.shape)
    diff = np.abs(got[~special] - want[~special])
    bound = TOL * scale[~special]
    assert np.all(diff <= bound), f"{what}: max diff/scale = {np.max(diff / scale[~special]):.3e}"


def fraction_scale(sse, tss):
    """Natural size of 1 − SSE/TSS: max(1, SSE/TSS) (TSS-normalised)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(tss > 0, sse / tss, 0.0)
    return np.maximum(1.0, ratio)


def parts(tau, pred):
    t = as_float_2d(tau)
    e = t - as_float_2d(pred)
    sse_j = np.einsum("ij,ij->j", e, e)
    tss_j = ((t - t.mean(axis=0)) ** 2).sum(axis=0)
    flat = t.ravel()
    tss = ((flat - flat.mean()) ** 2).sum()
    ssc_e_j = ((e - e.mean(axis=0)) ** 2).sum(axis=0)
    ssc_e = ((e.ravel() - e.mean()) ** 2).sum()
    return {"sse_j": sse_j, "tss_j": tss_j, "sse": sse_j.sum(), "tss": tss, "ssc_e_j": ssc_e_j,
            "ssc_e": ssc_e, "e": e, "t": t}


def normalized_scales(q, kind):
    """Natural sizes of vaf / fit_percent / r2 per aggregation."""
    if kind == "vaf":
        joint, pooled = fraction_scale(q["ssc_e_j"], q["tss_j"]), fraction_scale(q["ssc_e"], q["tss"])
    else:
        joint, pooled = fraction_scale(q["sse_j"], q["tss_j"]), fraction_scale(q["sse"], q["tss"])
    factor = 1.0 if kind == "r2" else 100.0
    return factor * joint, factor * pooled


# --------------------------------------------------------------------------- point metrics


@given(problems())
def test_point_metrics_agree(problem):
    tau, pred, _ = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    q = parts(tau, pred)
    for kind in ("vaf", "fit_percent", "r2"):
        joint, pooled = normalized_scales(q, kind)
        f = getattr(dynval, kind)
        for how in ("pooled", "raw_values", "uniform_average", "variance_weighted"):
            got = f(tau, pred, multioutput=how, backend="cpp")
            want = f(tau, pred, multioutput=how, backend="python")
            assert type(got) is type(want)
            scale = pooled if how == "pooled" else (joint if how == "raw_values" else np.max(joint))
            close(got, want, scale, f"{kind} {how}")
    sse_scale = q["sse"] + np.finfo(float).tiny
    for how in ("pooled", "raw_values"):
        close(dynval.sse(tau, pred, multioutput=how, backend="cpp"),
              dynval.sse(tau, pred, multioutput=how, backend="python"), sse_scale, f"sse {how}")
        # max |e| is an exact operation: no tolerance.
        np.testing.assert_array_equal(dynval.max_abs_error(tau, pred, multioutput=how, backend="cpp"),
                                      dynval.max_abs_error(tau, pred, multioutput=how, backend="python"))
    rms = math.sqrt(q["sse"] / q["e"].shape[0]) + np.finfo(float).tiny
    for how, conv in [("pooled", None), ("pooled", "per_sample"), ("pooled", "per_element"),
                      ("raw_values", None), ("uniform_average", None)]:
        close(dynval.rmse(tau, pred, multioutput=how, convention=conv, backend="cpp"),
              dynval.rmse(tau, pred, multioutput=how, convention=conv, backend="python"), rms, f"rmse {how} {conv}")
    np.testing.assert_array_equal(dynval.residuals(tau, pred, backend="cpp"),
                                  dynval.residuals(tau, pred, backend="python"))


@given(problems(), st.integers(0, 1))
def test_residual_statistics_agree(problem, ddof):
    tau, pred, _ = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    e = dynval.residuals(tau, pred, backend="python")
    e2 = as_float_2d(e)
    size = np.abs(e2).max(axis=0) + np.finfo(float).tiny
    close(dynval.residual_mean(e, backend="cpp"), dynval.residual_mean(e, backend="python"), size, "mean")
    var_scale = (e2**2).mean(axis=0) * e2.shape[0] / (e2.shape[0] - ddof) + np.finfo(float).tiny
    close(dynval.residual_variance(e, ddof=ddof, backend="cpp"),
          dynval.residual_variance(e, ddof=ddof, backend="python"), var_scale, "variance")


@given(problems(max_n=2000), st.data())
def test_zero_mean_test_agrees(problem, data):
    tau, pred, info = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    e = dynval.residuals(tau, pred, backend="python")
    segments = segments_for(info["n"], data)
    got = dynval.zero_mean_test(e, segments=segments, backend="cpp")
    want = dynval.zero_mean_test(e, segments=segments, backend="python")
    e2 = as_float_2d(e)
    n = e2.shape[0]
    size = np.abs(e2).max(axis=0)
    assume(np.all(want.std > 1e-6 * size))
    close(got.mean, want.mean, size, "mean")
    close(got.std, want.std, size, "std")
    # t = ē·√N/s: its natural size follows from those of ē and s.
    t_scale = math.sqrt(n) * size / want.std * np.maximum(1.0, np.abs(want.statistic_iid) / math.sqrt(n))
    close(got.statistic_iid, want.statistic_iid, t_scale, "t iid")
    close(got.n_eff, want.n_eff, n, "n_eff")
    close(got.statistic_eff, want.statistic_eff, t_scale * 2, "t eff")
    # p = 2·sf(|t|): its change is bounded by 2·pdf(t)·Δt.
    close(got.pvalue_iid, want.pvalue_iid, 2 * scipy.stats.t.pdf(want.statistic_iid, n - 1) * t_scale + 1e-2,
          "p iid")


# --------------------------------------------------------------------------- correlation


@given(problems(max_n=2500), st.integers(0, 60), st.booleans(), st.data())
def test_autocorrelation_agrees(problem, max_lag, adjusted, data):
    tau, pred, info = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    e = dynval.residuals(tau, pred, backend="python")
    segments = segments_for(info["n"], data)
    longest = max(segments) if segments else info["n"]
    max_lag = min(max_lag, longest - 1)
    got = dynval.autocorrelation(e, max_lag, adjusted=adjusted, segments=segments, backend="cpp")
    want = dynval.autocorrelation(e, max_lag, adjusted=adjusted, segments=segments, backend="python")
    # ρ is R(ℓ)/R(0): natural size 1 times the ratio of the lag-ℓ denominators (N/n_ℓ).
    n = info["n"]
    counts = np.array([n] + [sum(max(s - lag, 0) for s in (segments or [n])) for lag in range(1, max_lag + 1)])
    ratio = (n / counts) if adjusted else np.ones(max_lag + 1)
    close(got, want, ratio.reshape((-1,) + (1,) * (np.ndim(want) - 1)), "rho")


@given(problems(max_n=2500), st.lists(st.integers(1, 40), min_size=1, max_size=4), st.data())
def test_portmanteau_agrees(problem, lags, data):
    tau, pred, info = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    n = info["n"]
    segments = segments_for(n, data)
    longest = max(segments) if segments else n
    assume(max(lags) < longest)
    e = dynval.residuals(tau, pred, backend="python")
    model_df = data.draw(st.integers(0, min(lags) - 1))
    for name in ("ljung_box", "box_pierce"):
        f = getattr(dynval, name)
        got = f(e, lags, model_df=model_df, segments=segments, backend="cpp")
        want = f(e, lags, model_df=model_df, segments=segments, backend="python")
        np.testing.assert_array_equal(got.df, want.df)
        np.testing.assert_array_equal(got.lags, want.lags)
        rho = np.abs(as_float_2d(dynval.autocorrelation(e, max(lags), adjusted=False, segments=segments,
                                                        backend="python")))
        counts = np.array([sum(max(s - lag, 0) for s in (segments or [n])) for lag in range(1, max(lags) + 1)])
        weight = n * (n + 2.0) / counts if name == "ljung_box" else np.full(len(counts), float(n))
        # ΔQ from a change TOL in every ρ̂_ℓ: Σ weight·(2|ρ̂_ℓ| + TOL), plus Q itself.
        dq = np.cumsum(weight[:, None] * (2 * rho[1:] + TOL), axis=0)[np.asarray(lags) - 1]
        q_scale = dq + np.abs(want.statistic)
        close(got.statistic, want.statistic, q_scale, f"{name} Q")
        df = want.df[:, None].astype(float)
        pdf = scipy.stats.chi2.pdf(want.statistic, df)
        # p: the χ² implementation agrees with scipy to 1e-12 relative (tests/test_cpp_core.py);
        # beyond that, Δp = pdf·ΔQ.
        p_scale = (1e-12 / TOL) * want.pvalue + pdf * q_scale
        close(got.pvalue, want.pvalue, p_scale, f"{name} p")
        hazard = np.where(want.pvalue > 0, pdf / np.maximum(want.pvalue, 1e-300), 0.5)
        lp_scale = (1e-12 / TOL) * np.abs(want.log_pvalue) + hazard * q_scale
        close(got.log_pvalue, want.log_pvalue, lp_scale, f"{name} log p")


@given(problems(max_n=1500, max_m=4), st.integers(1, 4), st.integers(0, 20), st.booleans(),
       st.sampled_from(["3d", "stacked"]), st.data())
def test_cross_correlation_agrees(problem, p, max_lag, adjusted, form, data):
    tau, pred, info = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    n, m = info["n"], as_float_2d(tau).shape[1]
    e = dynval.residuals(tau, pred, backend="python")
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    y = as_float_2d(tau)[:, :, None] * rng.normal(size=(1, 1, p)) + rng.normal(size=(n, m, p))
    if data.draw(st.booleans()):
        y[:, 0, 0] = 3.0  # a constant column
    segments = segments_for(n, data)
    longest = max(segments) if segments else n
    max_lag = min(max_lag, longest - 1)
    kwargs = {"n_joints": m} if form == "stacked" else {}
    yy = y.reshape(n * m, p) if form == "stacked" else y
    got = dynval.cross_correlation(e, yy, max_lag, adjusted=adjusted, segments=segments, backend="cpp", **kwargs)
    want = dynval.cross_correlation(e, yy, max_lag, adjusted=adjusted, segments=segments, backend="python", **kwargs)
    np.testing.assert_array_equal(got.constant_mask, want.constant_mask)
    counts = np.array([n] + [sum(max(s - lag, 0) for s in (segments or [n])) for lag in range(1, max_lag + 1)])
    ratio = (n / counts) if adjusted else np.ones(max_lag + 1)
    close(got.rho, want.rho, ratio[None, None, :], "rho")
    assert got.band == want.band


def serial_arm_regressor(n=900, m=4, p=10, seed=5):
    """(e, Y): joint j's first 2j columns zero (the links before it, as on a serial arm), one
    nonzero constant column among the varying ones."""
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n, m)) + np.cumsum(rng.normal(size=(n, m)), axis=0) / 20.0
    y = rng.normal(size=(n, m, p)) + 0.3 * e[:, :, None]
    for j in range(m):
        y[:, j, :2 * j] = 0.0
    y[:, 1, 6] = -2.5
    return e, y


def direct_cross_correlation(e, y, max_lag):
    """ρ_{e_j Y_jc}(ℓ) by direct sums (adjusted: lag ℓ over its N − ℓ products); nan for a constant column."""
    n, m, p = y.shape
    rho = np.full((m, p, max_lag + 1), np.nan)
    for j in range(m):
        de = e[:, j] - e[:, j].mean()
        for c in range(p):
            dy = y[:, j, c] - y[:, j, c].mean()
            if np.ptp(y[:, j, c]) == 0:
                continue
            scale = math.sqrt(de @ de / n) * math.sqrt(dy @ dy / n)
            rho[j, c] = [de[lag:] @ dy[:n - lag] / (n - lag) / scale for lag in range(max_lag + 1)]
    return rho


def test_reference_cross_correlation_multiplies_only_the_varying_columns(monkeypatch):
    """A serial arm's regressor is zero in most joint-column pairs: the reference kernel forms the
    lagged products of the varying columns only (a constant column's ρ is nan whatever its sums),
    and both backends still give nan there and the direct sums' ρ elsewhere."""
    from dynval.kernels._reference import correlation as ref

    e, y = serial_arm_regressor()
    _, m, p = y.shape
    rows = []
    original = ref.row_lagged_products

    def counting(xr, yr, max_lag, starts, method=None):
        rows.append(yr.shape[0])
        return original(xr, yr, max_lag, starts, method)

    monkeypatch.setattr(ref, "row_lagged_products", counting)
    want = direct_cross_correlation(e, y, 6)
    constant = np.isnan(want[:, :, 0])
    assert constant.sum() == sum(2 * j for j in range(m)) + 1
    for backend in ("python", "cpp"):
        got = dynval.cross_correlation(e, y, 6, adjusted=True, backend=backend)
        np.testing.assert_array_equal(got.constant_mask, constant)
        np.testing.assert_array_equal(np.isnan(got.rho), np.broadcast_to(constant[:, :, None], got.rho.shape))
        np.testing.assert_allclose(got.rho[~constant], want[~constant], rtol=0, atol=1e-13)
    assert rows == [p - 2 * j - (j == 1) for j in range(m)]


# --------------------------------------------------------------------------- criteria


def ic_scale(n_obs, fit_term, p):
    return n_obs + abs(fit_term) + 2 * p + p * math.log(n_obs)


@given(problems(), st.integers(0, 40), st.sampled_from(["pooled", "per_joint", "full"]))
def test_criteria_agree(problem, n_params, noise_model):
    tau, pred, _ = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    q = parts(tau, pred)
    e = q["e"]
    cond = 1.0
    if noise_model == "full":
        sigma = e.T @ e
        assume(np.all(np.diag(sigma) > 0))
        cond = np.linalg.cond(sigma)
        assume(cond < 1e6)
    got = dynval.criteria(tau, pred, n_params=n_params, noise_model=noise_model, backend="cpp")
    want = dynval.criteria(tau, pred, n_params=n_params, noise_model=noise_model, backend="python")
    assert got.n_obs == want.n_obs
    n_vec = want.n_obs * (e.shape[1] if noise_model == "pooled" else 1)
    fit = abs(want.aic - 2 * n_params)
    # A relative change δ of σ̂² (or of det Σ̂, amplified by its condition number) moves F by n·δ.
    scale = ic_scale(want.n_obs, fit, n_params) * cond
    for field in ("aic", "bic", "aicc"):
        close(getattr(got, field), getattr(want, field), scale, field)
    close(got.naic, want.naic, scale / n_vec, "naic")
    close(got.fpe, want.fpe, np.abs(want.fpe) * e.shape[1] * cond, "fpe")
    for f in ("aic", "bic"):
        close(getattr(dynval, f)(tau, pred, n_params=n_params, noise_model=noise_model, backend="cpp"),
              getattr(want, f), scale, f)


@given(st.floats(0, 1e12), st.integers(1, 10**6), st.data())
def test_information_criteria_agree(rss, n_obs, data):
    assume(n_obs > 2)
    n_params = data.draw(st.integers(0, n_obs - 2))
    got = dynval.information_criteria(rss, n_obs, n_params, backend="cpp")
    want = dynval.information_criteria(rss, n_obs, n_params, backend="python")
    fit = abs(want.aic - 2 * n_params) if math.isfinite(want.aic) else 0.0
    scale = ic_scale(n_obs, fit, n_params)
    for field in ("aic", "bic", "aicc"):
        close(getattr(got, field), getattr(want, field), scale, field)
    close(got.naic, want.naic, scale / n_obs, "naic")
    close(got.fpe, want.fpe, abs(want.fpe), "fpe")


# --------------------------------------------------------------------------- validate


@given(problems(max_n=1500), st.sampled_from(["lesson", "matlab", "statsmodels", "sklearn"]),
       st.integers(0, 30))
def test_validate_agrees(problem, profile, n_params):
    tau, pred, info = problem
    assume(well_conditioned(tau) and well_conditioned(pred))
    q = parts(tau, pred)
    e = q["e"]
    if profile == "matlab":  # full noise model
        sigma = e.T @ e
        assume(np.all(np.diag(sigma) > 0) and np.linalg.cond(sigma) < 1e6)
    # Drawn shapes include N < m (a wide array): the backends must agree on those too.
    got = dynval.validate(tau, pred, n_params=n_params, profile=profile, backend="cpp", allow_wide=True)
    want = dynval.validate(tau, pred, n_params=n_params, profile=profile, backend="python", allow_wide=True)
    assert got.provenance["backend"] == "cpp" and want.provenance["backend"] == "python"
    factor = 1.0 if profile == "sklearn" else 100.0
    joint_sse, pooled_sse = fraction_scale(q["sse_j"], q["tss_j"]), fraction_scale(q["sse"], q["tss"])
    joint_vaf, pooled_vaf = fraction_scale(q["ssc_e_j"], q["tss_j"]), fraction_scale(q["ssc_e"], q["tss"])
    close(got.per_joint["r2"], want.per_joint["r2"], joint_sse, "per_joint r2")
    close(got.per_joint["fit_percent"], want.per_joint["fit_percent"], factor * joint_sse, "per_joint fit")
    close(got.per_joint["vaf"], want.per_joint["vaf"], factor * joint_vaf, "per_joint vaf")
    close(got.per_joint["sse"], want.per_joint["sse"], q["sse_j"] + np.finfo(float).tiny, "per_joint sse")
    close(got.pooled["r2"], want.pooled["r2"], pooled_sse, "pooled r2")
    close(got.pooled["fit_percent"], want.pooled["fit_percent"], factor * pooled_sse, "pooled fit")
    close(got.pooled["vaf"], want.pooled["vaf"], factor * pooled_vaf, "pooled vaf")
    rms = math.sqrt(q["sse"] / e.shape[0]) + np.finfo(float).tiny
    for key in ("rmse_per_element", "rmse_per_sample"):
        close(got.pooled[key], want.pooled[key], rms, key)
    for key in ("vaf", "fit_percent", "r2"):
        for agg in ("uniform_average", "variance_weighted"):
            scale = (1.0 if key == "r2" else factor) * max(np.max(joint_sse), np.max(joint_vaf))
            close(got.aggregates[agg][key], want.aggregates[agg][key], scale, f"{agg} {key}")
    acf_got, acf_want = got.autocorrelation, want.autocorrelation
    max_lag = acf_want["max_lag"]
    n = info["n"]
    ratio = n / np.maximum(n - np.arange(max_lag + 1), 1) if acf_want["adjusted"] else np.ones(max_lag + 1)
    close(acf_got["rho"], acf_want["rho"], ratio[:, None], "rho")
    ic_g, ic_w = got.information_criteria, want.information_criteria
    cond = np.linalg.cond(e.T @ e) if profile == "matlab" else 1.0
    fit = abs(ic_w["aic"] - 2 * n_params) if math.isfinite(ic_w["aic"]) else 0.0
    close(ic_g["aic"], ic_w["aic"], ic_scale(ic_w["n_obs"], fit, n_params) * cond, "report aic")


# --------------------------------------------------------------------------- bounds


@pytest.mark.parametrize("adjusted", [True, False])
def test_cross_correlation_never_exceeds_its_cauchy_schwarz_bound(backend, adjusted):
    """|rho(l)| <= N/D_l (1 at lag 0, and at every lag without ``adjusted``), contract §3.6.

    A regressor column that is an affine copy of the residual (perfect correlation, a few samples,
    scales from 1e-80 to 1e80) is where the rounding of the sums stepped one ulp past 1 in the
    cpp backend (1.0000000000000002); the bound holds exactly, in every backend.
    """
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 9))
        e = rng.normal(size=(n, 2)) * 10.0 ** rng.integers(-5, 5)
        y = (e * rng.normal() + rng.normal())[:, :, None] * 10.0 ** rng.integers(-80, 80)
        max_lag = min(n - 1, 3)
        rho = dynval.cross_correlation(e, y, max_lag, adjusted=adjusted, backend=backend).rho
        lags = np.arange(max_lag + 1)
        bound = n / (n - lags) if adjusted else np.ones(max_lag + 1)
        bound[0] = 1.0
        assert np.all(np.abs(np.nan_to_num(rho)) <= bound), (n, rho)


def test_streamed_cross_correlation_never_exceeds_its_bound():
    """The stream normalises its own lag sums (contract §4.1): the same clamp, the same cases
    (without it 96 of 200 exceeded 1 at lag 0)."""
    from dynval.stream import ValidationAccumulator

    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(3, 9))
        e = rng.normal(size=(n, 2)) * 10.0 ** rng.integers(-5, 5)
        y = (e * rng.normal() + rng.normal())[:, :, None] * 10.0 ** rng.integers(-80, 80)
        max_lag = min(n - 1, 3)
        acc = ValidationAccumulator(n_params=1, max_lag=max_lag, allow_wide=True)
        acc.update(e, np.zeros_like(e), y)
        rho = np.asarray(acc.result().cross_correlation["rho"])
        adjusted = acc.result().cross_correlation["adjusted"]
        lags = np.arange(max_lag + 1)
        bound = n / (n - lags) if adjusted else np.ones(max_lag + 1)
        assert np.all(np.abs(np.nan_to_num(rho)) <= bound), (n, rho)
