"""dynval.stream: the accumulator's report equals validate on the concatenated data.

Random chunkings (chunks of one row, chunks shorter than max_lag), segment breaks, merge trees in
any association order and nan_policy="omit" are drawn by hypothesis; every quantity the streaming
report shares with ``validate`` (contract §4.1) is compared with the tolerance the backends agree
to (tests/test_backends_agree.py): 1e-14 of the quantity's natural size.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import dynval
from dynval import stream
from dynval.stream import ValidationAccumulator

TOL = 1e-14
PROFILES = ["lesson", "matlab", "statsmodels", "sklearn"]


# --------------------------------------------------------------------------- data


@st.composite
def problems(draw, max_n=600, max_m=4, regressor=None):
    """Robot-like torques (smooth, joint offsets), a partly autocorrelated residual with a mean
    comparable to its spread, and optionally a regressor (N, m, p)."""
    n = draw(st.integers(2, max_n))
    m = draw(st.integers(1, max_m))
    scale = 10.0 ** draw(st.floats(-3, 3))
    offset = scale * draw(st.sampled_from([0.0, 1.0, -30.0, 1e3]))
    noise = draw(st.sampled_from([1e-3, 0.1, 1.0]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    walk = np.cumsum(rng.normal(size=(n, m)), axis=0) / math.sqrt(n)
    tau = offset + scale * (walk + rng.normal(size=(1, m)))
    resid = scale * noise * (0.5 * rng.normal(size=(n, m)) + 0.5 * np.cumsum(rng.normal(size=(n, m)), axis=0) / 10
                             + rng.normal(size=(1, m)))
    y = None
    if regressor if regressor is not None else draw(st.booleans()):
        p = draw(st.integers(1, 3))
        y = tau[:, :, None] * rng.normal(size=(1, 1, p)) + scale * rng.normal(size=(n, m, p)) + 5.0 * scale
        if draw(st.booleans()):
            y[:, 0, 0] = 3.0  # a constant column
    return tau, tau - resid, y


def well_conditioned(*arrays) -> bool:
    """Every column varies by more than 1e-9 of its magnitude or is exactly constant (as the
    backends' agreement test requires)."""
    for a in arrays:
        if a is None:
            continue
        a = a.reshape(a.shape[0], -1)
        spread = a.max(axis=0) - a.min(axis=0)
        if not np.all((spread == 0) | (spread > 1e-9 * np.abs(a).max(axis=0))):
            return False
    return True


def cut_points(draw, n, most=12):
    """Sorted chunk boundaries inside 1..n-1, with runs of one-row chunks now and then."""
    cuts = set(draw(st.lists(st.integers(1, max(1, n - 1)), max_size=most)))
    if n > 3 and draw(st.booleans()):
        start = draw(st.integers(1, n - 2))
        cuts.update(range(start, min(n, start + draw(st.integers(1, 6)))))
    return sorted(c for c in cuts if 0 < c < n)


def feed(acc, tau, pred, y, cuts, breaks=()):
    """Update ``acc`` chunk by chunk, breaking the segment before each row in ``breaks``."""
    bounds = [0] + list(cuts) + [tau.shape[0]]
    for a, b in zip(bounds[:-1], bounds[1:]):
        if a in breaks:
            acc.break_segment()
        acc.update(tau[a:b], pred[a:b], None if y is None else y[a:b])
    return acc


def lengths_of(n, breaks):
    edges = [0] + sorted(breaks) + [n]
    return [b - a for a, b in zip(edges[:-1], edges[1:])]


# --------------------------------------------------------------------------- comparison


def close(got, want, scale, what):
    """|got − want| <= TOL · scale elementwise; nan and ±inf must match exactly."""
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    assert got.shape == want.shape, what
    special = ~np.isfinite(want)
    np.testing.assert_array_equal(got[special], want[special], err_msg=what)
    scale = np.broadcast_to(np.asarray(scale, dtype=np.float64), want.shape)[~special]
    diff = np.abs(got[~special] - want[~special])
    assert np.all(diff <= TOL * scale), f"{what}: max diff/scale = {np.max(diff / scale):.3e}"


def fraction_scale(sse, tss):
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(tss > 0, sse / tss, 0.0)
    return np.maximum(1.0, ratio)


def assert_same_report(got, want, tau, pred, y=None):
    """Every field the streaming report shares with validate's (contract §4.1), to 1e-14 of its size."""
    assert got.provenance["segments"] == want.provenance["segments"]
    assert got.provenance["n_samples"] == want.provenance["n_samples"]
    assert got.provenance["conventions"]["max_lag"] == want.provenance["conventions"]["max_lag"]
    t = tau.reshape(tau.shape[0], -1)
    e = t - pred.reshape(t.shape)
    n = t.shape[0]
    sse_j, tss_j = (e * e).sum(axis=0), ((t - t.mean(axis=0)) ** 2).sum(axis=0)
    ssc_j = ((e - e.mean(axis=0)) ** 2).sum(axis=0)
    sse, tss, ssc = sse_j.sum(), ((t - t.mean()) ** 2).sum(), ((e - e.mean()) ** 2).sum()
    unit = 100.0 if got.provenance["conventions"]["units"] == "percent" else 1.0
    joint = {"r2": fraction_scale(sse_j, tss_j), "fit_percent": unit * fraction_scale(sse_j, tss_j),
             "vaf": unit * fraction_scale(ssc_j, tss_j), "nrmse": fraction_scale(sse_j, tss_j)}
    pooled = {"r2": fraction_scale(sse, tss), "fit_percent": unit * fraction_scale(sse, tss),
              "vaf": unit * fraction_scale(ssc, tss)}
    # RMS sizes from the residual scaled by a power of two: its squares underflow below 1e-154
    big = np.abs(e).max(axis=0)
    k = np.where(big > 0, np.frexp(big)[1], 0)
    rms_j = np.ldexp(np.sqrt((np.ldexp(e, -k) ** 2).sum(axis=0) / n), k) + np.finfo(float).tiny
    top = int(k.max())
    rms = float(np.ldexp(np.sqrt((np.ldexp(e, -top) ** 2).sum() / n), top)) + np.finfo(float).tiny
    for key, scale in joint.items():
        close(got.per_joint[key], want.per_joint[key], scale, f"per_joint {key}")
    close(got.per_joint["sse"], want.per_joint["sse"], sse_j + np.finfo(float).tiny, "per_joint sse")
    close(got.per_joint["rmse"], want.per_joint["rmse"], rms_j, "per_joint rmse")
    np.testing.assert_array_equal(got.per_joint["max_abs_error"], want.per_joint["max_abs_error"])
    for key, scale in pooled.items():
        close(got.pooled[key], want.pooled[key], scale, f"pooled {key}")
    close(got.pooled["sse"], want.pooled["sse"], sse + np.finfo(float).tiny, "pooled sse")
    for key in ("rmse_per_element", "rmse_per_sample"):
        close(got.pooled[key], want.pooled[key], rms, key)
    assert got.pooled["max_abs_error"] == want.pooled["max_abs_error"]
    for agg in ("uniform_average", "variance_weighted"):
        for key in ("vaf", "fit_percent", "r2"):
            scale = max(np.max(joint[key]), np.max(joint["vaf"]), np.max(joint["r2"]) * unit)
            close(got.aggregates[agg][key], want.aggregates[agg][key], scale, f"{agg} {key}")
    close(got.aggregates["rmse_uniform_average"], want.aggregates["rmse_uniform_average"], np.max(rms_j), "rmse avg")
    size = np.abs(e).max(axis=0) + np.finfo(float).tiny
    res_g, res_w = got.residuals, want.residuals
    close(res_g["mean"], res_w["mean"], size, "residual mean")
    close(res_g["variance"], res_w["variance"], size**2, "residual variance")
    assert res_g["ddof"] == res_w["ddof"]
    assert_same_zero_mean_test(res_g["zero_mean_test"], res_w["zero_mean_test"], size, n)
    assert_same_lags(got, want, n)
    assert_same_criteria(got.information_criteria, want.information_criteria, e)
    if y is None:
        assert got.cross_correlation is None and want.cross_correlation is None
    else:
        xg, xw = got.cross_correlation, want.cross_correlation
        np.testing.assert_array_equal(xg["constant_mask"], xw["constant_mask"])
        assert xg["band"] == xw["band"] and xg["max_lag"] == xw["max_lag"]
        close(xg["rho"], xw["rho"], lag_ratio(got, n)[None, None, :], "cross-correlation rho")


def lag_ratio(report, n):
    """Natural size of ρ̂(ℓ): N/n_ℓ for the adjusted estimator, 1 for the biased one."""
    conv = report.provenance["conventions"]
    lags = np.arange(conv["max_lag"] + 1)
    counts = np.array([sum(max(s - lag, 0) for s in report.provenance["segments"]) for lag in lags])
    return n / counts if conv["adjusted"] else np.ones(lags.size)


def assert_same_zero_mean_test(zg, zw, size, n):
    close(zg["mean"], zw["mean"], size, "zmt mean")
    close(zg["std"], zw["std"], size, "zmt std")
    if not np.all(zw["std"] > 1e-6 * size):
        return  # t is ē√N/s: a vanishing s leaves it no natural size
    t_scale = math.sqrt(n) * size / zw["std"] * np.maximum(1.0, np.abs(zw["statistic_iid"]) / math.sqrt(n))
    close(zg["statistic_iid"], zw["statistic_iid"], t_scale, "t iid")
    if zw["n_eff"] is None:
        assert zg["n_eff"] is None
        return
    assert zg["bandwidth"] == zw["bandwidth"]
    close(zg["n_eff"], zw["n_eff"], n, "n_eff")
    close(zg["statistic_eff"], zw["statistic_eff"], 2 * t_scale, "t eff")


def assert_same_lags(got, want, n):
    if want.autocorrelation is None:
        assert got.autocorrelation is None and got.ljung_box is None
        return
    ratio = lag_ratio(want, n)[:, None]
    close(got.autocorrelation["rho"], want.autocorrelation["rho"], ratio, "rho")
    close(got.autocorrelation["band"], want.autocorrelation["band"], 1.0, "band")
    lb_g, lb_w = got.ljung_box, want.ljung_box
    if lb_w is None:
        assert lb_g is None
        return
    np.testing.assert_array_equal(lb_g["lags"], lb_w["lags"])
    np.testing.assert_array_equal(lb_g["df"], lb_w["df"])
    segments = want.provenance["segments"]
    h = int(lb_w["lags"].max())
    rho_b = np.abs(want.autocorrelation["rho"][1: h + 1] / lag_ratio(want, n)[1: h + 1, None]) \
        if h <= want.autocorrelation["max_lag"] else np.ones((h, lb_w["statistic"].shape[1]))
    counts = np.array([sum(max(s - lag, 0) for s in segments) for lag in range(1, h + 1)])
    dq = np.cumsum((n * (n + 2.0) / counts)[:, None] * (2 * np.nan_to_num(rho_b, nan=1.0) + TOL), axis=0)
    q_scale = dq[lb_w["lags"] - 1] + np.abs(np.nan_to_num(lb_w["statistic"]))
    close(lb_g["statistic"], lb_w["statistic"], q_scale, "Ljung-Box Q")
    pdf = scipy.stats.chi2.pdf(lb_w["statistic"], lb_w["df"][:, None].astype(float))
    close(lb_g["pvalue"], lb_w["pvalue"], (1e-12 / TOL) * lb_w["pvalue"] + pdf * q_scale, "Ljung-Box p")


def assert_same_criteria(ic_g, ic_w, e):
    assert ic_g["n_obs"] == ic_w["n_obs"] and ic_g["noise_model"] == ic_w["noise_model"]
    cond = 1.0
    if ic_w["noise_model"] == "full":
        big = np.abs(e).max()
        es = np.ldexp(e, -int(np.frexp(big)[1])) if big > 0 else e  # cond does not see the scale; EᵀE's squares would
        cond = np.linalg.cond(es.T @ es)
    p = ic_w["n_params"]
    fit = abs(ic_w["aic"] - 2 * p) if math.isfinite(ic_w["aic"]) else 0.0
    scale = (ic_w["n_obs"] + fit + 2 * p + p * math.log(ic_w["n_obs"])) * cond
    for key in ("aic", "bic", "aicc"):
        close(ic_g[key], ic_w[key], scale, key)
    n_vec = ic_w["n_obs"] * (e.shape[1] if ic_w["noise_model"] == "pooled" else 1)
    close(ic_g["naic"], ic_w["naic"], scale / n_vec, "naic")
    close(ic_g["fpe"], ic_w["fpe"], abs(ic_w["fpe"]) * e.shape[1] * cond, "fpe")


def reference(tau, pred, y, lengths, **keywords):
    return dynval.validate(tau, pred, regressor=y, segments=lengths, backend="python",
                           cross_correlation_detail="full", allow_wide=True, **keywords)


def draw_settings(data, n, longest):
    profile = data.draw(st.sampled_from(PROFILES))
    max_lag = data.draw(st.one_of(st.none(), st.integers(0, 25)))
    if profile == "statsmodels" and max_lag is None:
        max_lag = data.draw(st.integers(0, 25))
    if max_lag is not None:
        max_lag = min(max_lag, longest - 1)
    return {"n_params": data.draw(st.integers(0, 12)), "profile": profile, "max_lag": max_lag}


def usable(tau, pred, y, keywords):
    e = tau - pred
    if not well_conditioned(tau, pred, e, y):
        return False
    if keywords["profile"] == "matlab":  # the full noise model: a well-conditioned residual covariance
        s = e.T @ e
        return bool(np.all(np.diag(s) > 0) and np.linalg.cond(s) < 1e6)
    return True


# --------------------------------------------------------------------------- equal to validate


@given(problems(), st.data())
def test_random_chunkings_and_segments_equal_validate(backend, problem, data):
    tau, pred, y = problem
    n = tau.shape[0]
    cuts = cut_points(data.draw, n)
    breaks = sorted(set(data.draw(st.lists(st.sampled_from(cuts), max_size=3)))) if cuts else []
    lengths = lengths_of(n, breaks)
    keywords = draw_settings(data, n, max(lengths))
    assume(usable(tau, pred, y, keywords))
    acc = feed(ValidationAccumulator(backend=backend, allow_wide=True, **keywords), tau, pred, y, cuts, breaks)
    assert acc.n_samples == n
    assert_same_report(acc.result(), reference(tau, pred, y, lengths, **keywords), tau, pred, y)


@settings(max_examples=30)
@given(problems(max_n=160), st.data())
def test_one_row_chunks_without_pooling(backend, problem, data):
    """Every chunk summed on its own (no pooling of small chunks): one-row chunks and chunks
    shorter than max_lag join across every boundary."""
    tau, pred, y = problem
    n = tau.shape[0]
    keywords = {"n_params": 2, "profile": data.draw(st.sampled_from(PROFILES)), "max_lag": min(20, n - 1)}
    assume(usable(tau, pred, y, keywords))
    size = data.draw(st.integers(1, 7))
    cuts = list(range(size, n, size))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(stream, "_buffer_rows", lambda layout: 1)
        acc = feed(ValidationAccumulator(backend=backend, allow_wide=True, **keywords), tau, pred, y, cuts)
    assert_same_report(acc.result(), reference(tau, pred, y, None, **keywords), tau, pred, y)


def accumulator_of(tau, pred, y, keywords, data, backend, start_break=False, end_break=False):
    acc = ValidationAccumulator(allow_wide=True, backend=backend, **keywords)
    if start_break:
        acc.break_segment()
    feed(acc, tau, pred, y, cut_points(data.draw, tau.shape[0], most=4))
    if end_break:
        acc.break_segment()
    return acc


def merge_tree(accs, data):
    """Merge consecutive accumulators in a random binary tree (any association order)."""
    if len(accs) == 1:
        return accs[0].copy()
    split = data.draw(st.integers(1, len(accs) - 1))
    return merge_tree(accs[:split], data).merge(merge_tree(accs[split:], data))


@given(problems(max_n=500), st.data())
def test_merge_trees_equal_validate(backend, problem, data):
    tau, pred, y = problem
    n = tau.shape[0]
    assume(n >= 4)
    k = data.draw(st.integers(2, min(5, n)))
    cuts = sorted(data.draw(st.sets(st.integers(1, n - 1), min_size=k - 1, max_size=k - 1)))
    bounds = [0] + cuts + [n]
    # A break between two pieces: the first ends with one, or the second starts with one.
    junction_breaks = [data.draw(st.sampled_from([None, "end", "start"])) for _ in cuts]
    breaks = [c for c, how in zip(cuts, junction_breaks) if how]
    lengths = lengths_of(n, breaks)
    keywords = draw_settings(data, n, max(lengths))
    assume(usable(tau, pred, y, keywords))
    pieces = []
    for i, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        pieces.append(accumulator_of(tau[a:b], pred[a:b], None if y is None else y[a:b], keywords, data, backend,
                                     start_break=i > 0 and junction_breaks[i - 1] == "start",
                                     end_break=i < len(cuts) and junction_breaks[i] == "end"))
    want = reference(tau, pred, y, lengths, **keywords)
    assert_same_report(merge_tree(pieces, data).result(), want, tau, pred, y)
    # Neither merge modified its argument: the pieces still give their own reports.
    assert pieces[-1].n_samples == n - bounds[-2]


@settings(max_examples=40)
@given(problems(max_n=300), st.data())
def test_merge_is_associative(backend, problem, data):
    tau, pred, y = problem
    n = tau.shape[0]
    assume(n >= 3)
    i, j = sorted(data.draw(st.sets(st.integers(1, n - 1), min_size=2, max_size=2))) if n > 3 else (1, 2)
    keywords = {"n_params": 1, "profile": "lesson", "max_lag": min(30, n - 1)}
    assume(usable(tau, pred, y, keywords))
    part = [(0, i), (i, j), (j, n)]
    a, b, c = (accumulator_of(tau[s:t], pred[s:t], None if y is None else y[s:t], keywords, data, backend)
               for s, t in part)
    left = a.copy().merge(b).merge(c)
    right = a.copy().merge(b.copy().merge(c))
    want = reference(tau, pred, y, None, **keywords)
    assert_same_report(left.result(), want, tau, pred, y)
    assert_same_report(right.result(), want, tau, pred, y)


@settings(max_examples=40)
@given(problems(max_n=400), st.data())
def test_omit_equals_validate(backend, problem, data):
    tau, pred, y = problem
    n = tau.shape[0]
    assume(n >= 8)
    tau, pred = tau.copy(), pred.copy()
    rows = data.draw(st.sets(st.integers(0, n - 1), min_size=1, max_size=max(1, n // 4)))
    for r in rows:
        (tau if r % 2 else pred)[r, r % tau.shape[1]] = np.nan
    keep = np.isfinite(tau).all(axis=1) & np.isfinite(pred).all(axis=1)
    assume(keep.sum() >= 4)
    keywords = {"n_params": 1, "profile": data.draw(st.sampled_from(["lesson", "sklearn"])), "max_lag": 0,
                "nan_policy": "omit"}
    assume(usable(tau[keep], pred[keep], None if y is None else y[keep], keywords))
    want = reference(tau, pred, y, None, **keywords)
    longest = max(want.provenance["segments"])
    keywords["max_lag"] = min(10, longest - 1)
    want = reference(tau, pred, y, None, **keywords)
    acc = feed(ValidationAccumulator(backend=backend, allow_wide=True, **keywords), tau, pred, y,
               cut_points(data.draw, n))
    got = acc.result()
    assert got.provenance["omitted_rows"] == want.provenance["omitted_rows"] == n - keep.sum()
    assert_same_report(got, want, tau[keep], pred[keep], None if y is None else y[keep])
    assert [f.kind for f in got.findings if f.kind == "omitted_rows"] == ["omitted_rows"]


@pytest.mark.parametrize("offset", [0.0, 1e3, 1e6])
def test_means_far_from_zero(offset, backend):
    """Sums are kept about the running mean: an offset large against the spread loses nothing."""
    rng = np.random.default_rng(3)
    n, m = 20000, 3
    tau = offset + np.cumsum(rng.normal(size=(n, m)), axis=0) / 30
    pred = tau - (0.2 * rng.normal(size=(n, m)) + 0.1 * np.cumsum(rng.normal(size=(n, m)), axis=0) / 30
                  + offset * 1e-3)
    y = tau[:, :, None] * [1.0, -0.5] + offset
    acc = ValidationAccumulator(backend=backend, n_params=3, max_lag=40)
    feed(acc, tau, pred, y, sorted(set(range(37, n, 997)) | set(range(5000, 5030))))
    want = reference(tau, pred, y, None, n_params=3, max_lag=40)
    assert_same_report(acc.result(), want, tau, pred, y)


# --------------------------------------------------------------------------- sections and state


def test_sections_left_out_and_findings(backend):
    rng = np.random.default_rng(4)
    tau = rng.normal(size=(400, 2)) * [30.0, 2.0]
    pred = tau + rng.normal(size=(400, 2))
    pred[:, 1] = tau[:, 1][::-1]  # joint 2 worse than a constant
    acc = feed(ValidationAccumulator(backend=backend, n_params=2, max_lag=8, joint_names=["shoulder", "elbow"]),
               tau, pred, rng.normal(size=(400, 2, 3)), [100, 200])
    report = acc.result()
    # the bias test runs from the lag sums (contract §4.1); the spectrum and the design do not
    assert report.bias is not None and report.spectrum is None and report.design is None
    assert report.segment_metrics is None and report.provenance["streaming"] is True
    assert [t["test"] for t in report.provenance["not_tested"]] == [
        "information_rate", "spectrum", "prediction_artefact", "regressor_correlation", "excitation"]
    assert report.whiteness["decimation"] == 1 and report.whiteness["pvalue_decimated"] is None
    assert set(report.cross_correlation) == {"max_lag", "adjusted", "constant_mask", "band", "level",
                                             "n_outside_white_band", "rho", "outside"}
    assert "aic_neff" in report.information_criteria  # from the bias test's N_eff, as validate gives it
    kinds = {f.kind for f in report.findings}
    assert "worse_than_constant" in kinds and kinds <= {"worse_than_constant", "pooling", "whiteness", "bias"}
    assert "elbow" in report.summary()
    report.to_json()


def test_max_lag_zero_reads_once(backend):
    rng = np.random.default_rng(5)
    tau = rng.normal(size=(300, 3))
    pred = tau + 0.1 * rng.normal(size=(300, 3))
    acc = feed(ValidationAccumulator(backend=backend, n_params=1, max_lag=0), tau, pred, None, [1, 2, 150])
    got, want = acc.result(), reference(tau, pred, None, None, n_params=1, max_lag=0)
    assert got.autocorrelation is None and got.ljung_box is None
    assert got.residuals["zero_mean_test"]["n_eff"] is None
    assert_same_report(got, want, tau, pred)


def test_a_reused_input_buffer_changes_nothing_already_given(backend):
    """A reader that fills one buffer again for each chunk (np.copyto, readinto) must not change
    rows the accumulator was already given, even rows it has not summed yet (short chunks are
    gathered before they are summed)."""
    rng = np.random.default_rng(8)
    tau = rng.normal(size=(700, 3)).cumsum(axis=0)
    pred = tau + 0.1 * rng.normal(size=(700, 3))
    y = rng.normal(size=(700, 3, 2))
    acc = ValidationAccumulator(backend=backend, n_params=2, max_lag=6)
    buf_t, buf_p, buf_y = np.empty((50, 3)), np.empty((50, 3)), np.empty((50, 3, 2))
    for a in range(0, 700, 50):
        np.copyto(buf_t, tau[a:a + 50]), np.copyto(buf_p, pred[a:a + 50]), np.copyto(buf_y, y[a:a + 50])
        acc.update(buf_t, buf_p, buf_y)
    buf_t[:], buf_p[:], buf_y[:] = np.nan, np.nan, np.nan
    assert_same_report(acc.result(), reference(tau, pred, y, None, n_params=2, max_lag=6), tau, pred, y)


def test_state_does_not_grow_with_n(backend):
    rng = np.random.default_rng(6)
    sizes = []
    for n in (2_000, 200_000):
        acc = ValidationAccumulator(backend=backend, n_params=1, max_lag=20)
        for _ in range(0, n, 1000):
            acc.update(rng.normal(size=(1000, 4)), rng.normal(size=(1000, 4)), rng.normal(size=(1000, 4, 3)))
        acc.break_segment()
        sizes.append(len(pickle.dumps(acc)))
    assert sizes[1] < 1.01 * sizes[0]


def test_profile_default_max_lag_follows_the_longest_segment(backend):
    rng = np.random.default_rng(7)
    tau = rng.normal(size=(30, 1))
    pred = tau + rng.normal(size=(30, 1))
    acc = ValidationAccumulator(backend=backend, n_params=1)
    feed(acc, tau, pred, None, [10, 20], breaks=[10, 20])
    assert acc.result().provenance["conventions"]["max_lag"] == 9
    assert_same_report(acc.result(), reference(tau, pred, None, [10, 10, 10], n_params=1), tau, pred)


# --------------------------------------------------------------------------- errors


def test_chunk_errors_name_the_chunk_and_the_shape(backend):
    acc = ValidationAccumulator(backend=backend, n_params=1, max_lag=2)
    acc.update(np.zeros((5, 3)), np.ones((5, 3)), np.ones((5, 3, 2)))
    cases = [
        ((np.zeros((4, 2)), np.zeros((4, 2)), np.ones((4, 2, 2))), dynval.ShapeMismatch,
         "chunk 1: tau_meas must have m=3 columns like the chunks before it, got shape (4, 2)"),
        ((np.zeros((4, 3)), np.zeros((4, 3)), np.ones((4, 3, 5))), dynval.ShapeMismatch,
         "chunk 1: regressor must have p=2 columns like the chunks before it, got shape (4, 3, 5)"),
        ((np.zeros((4, 3)), np.zeros((4, 3))), dynval.ShapeMismatch,
         "chunk 1: regressor must be given with every chunk or with none; the chunks before it had one"),
        ((np.zeros((4, 3)), np.zeros((3, 3)), np.ones((4, 3, 2))), dynval.ShapeMismatch,
         "chunk 1: tau_meas and tau_pred must have the same shape, got (4, 3) and (3, 3)"),
        ((np.zeros((4, 3, 1)), np.zeros((4, 3, 1))), dynval.InvalidShape,
         "chunk 1: tau_meas must be 1-D (N,) or 2-D (N, m), got shape (4, 3, 1)"),
        ((["a"], ["b"]), dynval.InvalidType, "chunk 1: tau_meas must be an array of real numbers, got <U1"),
    ]
    for args, kind, message in cases:
        with pytest.raises(kind) as info:
            acc.update(*args)
        assert str(info.value) == message
    bad = np.zeros((4, 3))
    bad[2, 1] = np.inf
    with pytest.raises(dynval.NonFiniteInput) as info:
        acc.update(np.zeros((4, 3)), bad, np.ones((4, 3, 2)))
    assert str(info.value) == "chunk 1: tau_pred has a non-finite value (inf) at row 2, column 1 (row 7 of the stream)"
    assert acc.n_samples == 5  # rejected chunks leave the accumulator as it was


def test_unsupported_and_invalid_keywords():
    for name, value in [("decimate", "auto"), ("estimation", {"tau": [1.0]}), ("q", [[1.0]]), ("segments", [2, 2]),
                        ("model_columns", [0]), ("cross_correlation_detail", "full")]:
        with pytest.raises(dynval.InvalidParameter, match=rf"^{name} must be None for ValidationAccumulator \("):
            ValidationAccumulator(n_params=1, **{name: value})
    with pytest.raises(dynval.InvalidParameter, match=r"^max_lag must be an integer with max_lag >= 0 for the "
                                                      r"statsmodels profile"):
        ValidationAccumulator(n_params=1, profile="statsmodels")
    with pytest.raises(dynval.InvalidParameter, match=r"^max_lag must be an integer with max_lag >= 0, got -1$"):
        ValidationAccumulator(n_params=1, max_lag=-1)
    with pytest.raises(dynval.InvalidParameter, match=r"^n_params must be"):
        ValidationAccumulator(n_params=-1, decimate="auto")  # contract order: n_params first
    acc = ValidationAccumulator(n_params=1, max_lag=5)
    acc.update([1.0, 2.0, 3.0], [1.0, 2.5, 2.0])
    with pytest.raises(dynval.InvalidParameter, match=r"^max_lag must be an integer with 0 <= max_lag < 3, got 5$"):
        acc.result()
    with pytest.raises(dynval.TooFewSamples, match=r"needs at least 2 samples, got N=1$"):
        feed(ValidationAccumulator(n_params=1), np.ones(1), np.ones(1), None, []).result()
    with pytest.raises(dynval.InvalidParameter, match=r"^other must be a ValidationAccumulator with the same "
                                                      r"settings, got max_lag=4 where this one has max_lag=5"):
        acc.merge(ValidationAccumulator(n_params=1, max_lag=4))
    other = ValidationAccumulator(n_params=1, max_lag=5)
    other.update(np.ones((4, 2)), np.zeros((4, 2)))
    with pytest.raises(dynval.ShapeMismatch, match=r"^other must hold data of the same shape"):
        acc.merge(other)
    with pytest.raises(dynval.TooFewSamples, match="look transposed"):
        feed(ValidationAccumulator(n_params=1, max_lag=0), np.ones((2, 5)), np.zeros((2, 5)), None, []).result()


def test_backend_keyword_and_default(backend):
    """backend=None takes dynval's default backend; the provenance names the backend that held the
    sums; accumulators of different backends do not merge; pickling keeps the state."""
    rng = np.random.default_rng(8)
    tau = rng.normal(size=(200, 2))
    pred = tau + rng.normal(size=(200, 2))
    default = next(name for name, info in dynval.backends().items() if info["default"])
    assert feed(ValidationAccumulator(n_params=1, max_lag=3), tau, pred, None, [50]).result() \
        .provenance["backend"] == default
    acc = feed(ValidationAccumulator(n_params=1, max_lag=3, backend=backend), tau, pred, None, [50])
    assert acc.result().provenance["backend"] == backend
    assert_same_report(pickle.loads(pickle.dumps(acc)).result(), acc.result(), tau, pred)
    other = "python" if backend == "cpp" else "cpp"
    if dynval.backends()[other]["available"]:
        with pytest.raises(dynval.InvalidParameter, match=rf"got backend='{other}' where this one has "
                                                          rf"backend='{backend}'"):
            acc.merge(ValidationAccumulator(n_params=1, max_lag=3, backend=other))
    with pytest.raises(dynval.InvalidParameter, match=r"^backend must be one of 'python'"):
        ValidationAccumulator(n_params=1, backend="fortran")
