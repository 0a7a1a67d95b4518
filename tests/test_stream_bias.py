"""The coloured-noise bias test of a streamed report (contract §4.1, docs/conventions.md §5.4).

A stream computes ``validate``'s bias test from its lag sums: with one segment it must equal the
whole series' test to rounding, across segments within the stated O(L/N) tolerance, and where it
cannot run (a bandwidth past the lags held) the report must say so rather than read as clean.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.signal

import dynval
from dynval.cli import main
from dynval.stream import ValidationAccumulator


def _streamed(tau, pred, *, backend, chunk=733, segments=None, **kw):
    acc = ValidationAccumulator(backend=backend, **kw)
    start = 0
    for length in segments or [tau.shape[0]]:
        for a in range(start, start + length, chunk):
            b = min(a + chunk, start + length)
            acc.update(tau[a:b], pred[a:b])
        acc.break_segment()
        start += length
    return acc.result()


def _ar1(n, m, rho, seed, offset=0.0):
    rng = np.random.default_rng(seed)
    e = scipy.signal.lfilter([1.0], [1.0, -rho], rng.standard_normal((n, m)), axis=0) + offset
    tau = 3.0 * rng.standard_normal((n, m))
    return tau, tau - e


def _pairs(report):
    return sorted((f.kind, f.joints) for f in report.findings)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.9, 0.99])
def test_one_segment_equals_validate(backend, rho):
    tau, pred = _ar1(3000, 3, rho, seed=int(rho * 100), offset=0.04)
    got = _streamed(tau, pred, backend=backend, n_params=3).bias
    want = dynval.validate(tau, pred, n_params=3).bias
    assert got is not None
    np.testing.assert_array_equal(got["bandwidth"], want["bandwidth"])
    for key in ("mean", "std", "phi", "n_eff", "statistic", "standard_error", "effect"):
        np.testing.assert_allclose(got[key], want[key], rtol=1e-10, atol=0, err_msg=key)
    np.testing.assert_allclose(np.log(got["pvalue"]), np.log(want["pvalue"]), rtol=1e-8, err_msg="pvalue")
    assert got["method"] == want["method"] and got["long_run_variance_method"] == want["long_run_variance_method"]


def test_short_segments_within_the_stated_tolerance(backend):
    """Segments of K = 143 rows or fewer keep no edges: N_eff within 2 % of validate's for 20
    segments of 100 rows and AR(1) ρ = 0.5 (12 % at ρ = 0.9, contract §4.1)."""
    for rho, tolerance in ((0.5, 0.02), (0.9, 0.12)):
        for seed in range(3):
            tau, pred = _ar1(2000, 2, rho, seed, offset=0.05)
            segments = [100] * 20
            got = _streamed(tau, pred, backend=backend, n_params=2, segments=segments).bias
            want = dynval.validate(tau, pred, n_params=2, segments=segments).bias
            np.testing.assert_allclose(got["n_eff"], want["n_eff"], rtol=tolerance)


def test_the_readme_offset_is_a_bias_when_streamed(backend):
    """README "Logs larger than memory": pred = tau + 0.01, an offset of 100 % of the RMSE, gave
    "none: ... nothing to note" streamed and seven bias deficiencies whole."""
    tau = np.random.default_rng(0).standard_normal((20000, 7))
    pred = tau + 0.01
    got = _streamed(tau, pred, backend=backend, n_params=10, chunk=4096)
    want = dynval.validate(tau, pred, n_params=10)
    assert _pairs(got) == _pairs(want) == [("bias", (j,)) for j in range(7)]
    assert all(f.severity == "deficiency" for f in got.findings)
    assert "nothing to note" not in got.summary()


def test_the_readme_example_on_the_command_line(tmp_path, capsys):
    tau = np.random.default_rng(0).standard_normal((20000, 7))
    np.save(tmp_path / "tau.npy", tau)
    np.save(tmp_path / "pred.npy", tau + 0.01)
    files = [str(tmp_path / "tau.npy"), str(tmp_path / "pred.npy"), "--n-params", "10"]
    for extra in ([], ["--stream"]):
        assert main(["validate", *files, *extra, "--json"]) in (0, 1)
        report = json.loads(capsys.readouterr().out)
        assert sorted((f["kind"], f["severity"]) for f in report["findings"]) == [("bias", "deficiency")] * 7
    assert [t["test"] for t in report["provenance"]["not_tested"]] == ["information_rate", "prediction_artefact"]
    main(["validate", *files, "--stream"])
    text = capsys.readouterr().out
    assert "nothing to note" not in text and "not tested (2;" in text and "information_rate (sampling_colour):" in text


def test_a_clean_stream_names_what_it_did_not_test(backend):
    rng = np.random.default_rng(3)
    tau = rng.standard_normal((5000, 2))
    pred = tau - 0.1 * rng.standard_normal((5000, 2))
    report = _streamed(tau, pred, backend=backend, n_params=2)
    assert report.findings == []
    lines = report.summary().splitlines()
    at = lines.index("  - none from the tests this report ran: no deficiency, no design problem at this level.")
    assert lines[at + 1] == "  - not tested (2; a finding of these kinds cannot show here):"
    assert lines[at + 2].startswith("      information_rate (sampling_colour): the decimation filter needs")
    assert lines[at + 3].startswith("      prediction_artefact (prediction_artefact): the measured and the predicted")
    assert not any("nothing to note" in line for line in lines)
    not_tested = json.loads(report.to_json())["provenance"]["not_tested"]
    assert [(t["test"], t["kinds"]) for t in not_tested] == [("information_rate", ["sampling_colour"]),
                                                             ("prediction_artefact", ["prediction_artefact"])]


def test_a_bandwidth_past_the_lags_held_is_named_and_a_larger_max_lag_runs_it(backend):
    """A smooth residual (AR(2), double root 0.95) needs Andrews' bandwidth ≈ 225 > the 143 lags held."""
    rng = np.random.default_rng(7)
    n = 20000
    e = scipy.signal.lfilter([1.0], [1.0, -1.9, 0.9025], rng.standard_normal((n, 1)), axis=0)
    tau = rng.standard_normal((n, 1))
    pred = tau - e
    want = dynval.validate(tau, pred, n_params=1).bias
    needed = int(want["bandwidth"].max()) + 1
    assert needed > 144
    report = _streamed(tau, pred, backend=backend, n_params=1, chunk=5000)
    assert report.bias is None
    left_out = {t["test"]: t["why"] for t in report.provenance["not_tested"]}
    assert left_out["bias"] == (f"its bandwidth needs the residual's autocovariance at {needed} lags and the stream "
                                f"holds 143: pass max_lag={needed} or more")
    assert "bias (bias): its bandwidth needs" in report.summary()
    longer = _streamed(tau, pred, backend=backend, n_params=1, chunk=5000, max_lag=needed).bias
    np.testing.assert_allclose(longer["n_eff"], want["n_eff"], rtol=1e-9)


def test_holm_counts_the_tests_a_stream_left_out():
    """A stream's family is validate's size: a bias significant only in a family without the
    spectrum's bins is not a finding (it was, when the stream's family held 2m tests)."""
    rng = np.random.default_rng(1)
    n = 20000
    e = scipy.signal.lfilter([1.0], [1.0, -0.8], rng.standard_normal((n, 3)), axis=0) * 0.1
    e[:, 1] += 0.016
    tau = rng.standard_normal((n, 3))
    pred = tau - e
    streamed = _streamed(tau, pred, backend="python", n_params=10, chunk=999)
    whole = dynval.validate(tau, pred, n_params=10)
    assert 1e-4 < streamed.bias["pvalue"][1] < 5e-3  # significant alone, not after validate's Holm
    assert _pairs(streamed) == _pairs(whole)
    assert ("bias", (1,)) not in _pairs(streamed)


@pytest.mark.parametrize("scale", [1e-200, 1e-160, 1e140])
def test_validates_bias_test_does_not_see_the_scale(scale):
    """The squares of a residual near 1e-200 underflowed: variance 0, t = inf, a bias "found" on every
    joint. Scaled by a power of two per joint first (contract §1.3), the test is that of the data at 1."""
    tau, pred = _ar1(3000, 2, 0.5, seed=5, offset=0.01)
    at_one = dynval.validate(tau, pred, n_params=2).bias
    scaled = dynval.validate(tau * scale, pred * scale, n_params=2).bias
    np.testing.assert_allclose(scaled["pvalue"], at_one["pvalue"], rtol=1e-12)
    np.testing.assert_allclose(scaled["n_eff"], at_one["n_eff"], rtol=1e-12)
    np.testing.assert_allclose(scaled["standard_error"], at_one["standard_error"] * scale, rtol=1e-9)
    assert sorted((f.kind, f.joints) for f in dynval.validate(tau * scale, pred * scale, n_params=2).findings) == \
        sorted((f.kind, f.joints) for f in dynval.validate(tau, pred, n_params=2).findings)


def test_the_html_of_a_stream_names_what_it_did_not_test(backend):
    from dynval.html import render_fragment

    rng = np.random.default_rng(3)
    tau = rng.standard_normal((5000, 2))
    report = _streamed(tau, tau - 0.1 * rng.standard_normal((5000, 2)), backend=backend, n_params=2)
    page = render_fragment(report)
    assert "nothing in the residuals calls for a change" not in page
    assert "No findings from the tests this report ran." in page and "Not tested (2;" in page
    assert "information_rate" in page


def _merged(tau, pred, blocks, segment_starts, order, backend):
    """One accumulator per block of rows (a break before a block where a segment starts), merged
    left to right, right to left, or as a tree."""
    parts = []
    for a, b in zip(blocks[:-1], blocks[1:]):
        acc = ValidationAccumulator(n_params=2, backend=backend)
        for s in [s for s in segment_starts if a <= s < b]:
            if s > a:
                acc.update(tau[a:s], pred[a:s])
            acc.break_segment()
            a = s
        acc.update(tau[a:b], pred[a:b])
        parts.append(acc)
    if order == "left":
        out = parts[0]
        for p in parts[1:]:
            out.merge(p)
        return out
    if order == "right":
        out = parts[-1]
        for p in parts[-2::-1]:
            out = p.merge(out)
        return out
    while len(parts) > 1:
        parts = [parts[i].merge(parts[i + 1]) if i + 1 < len(parts) else parts[i] for i in range(0, len(parts), 2)]
    return parts[0]


@pytest.mark.parametrize("order", ["left", "right", "tree"])
def test_segments_equal_validate_over_any_merge_tree(backend, order):
    """Every inner segment junction is kept (streaming/_edges.py): with segments longer than the
    lags held, chunked and merged in any order, the test equals validate's to rounding."""
    for rho in (0.5, 0.9, 0.99):
        tau, pred = _ar1(3000, 2, rho, seed=int(rho * 10), offset=0.03)
        segments = [600, 1000, 400, 1000]
        starts = list(np.cumsum(segments)[:-1])
        whole = dynval.validate(tau, pred, n_params=2, segments=segments).bias
        sequential = _streamed(tau, pred, backend=backend, n_params=2, segments=segments, chunk=97).bias
        np.testing.assert_allclose(sequential["n_eff"], whole["n_eff"], rtol=1e-9)
        blocks = [0, 300, 600, 1200, 1600, 1900, 2300, 3000]  # junctions inside and at segment starts
        merged = _merged(tau, pred, blocks, starts, order, backend).result().bias
        np.testing.assert_allclose(merged["n_eff"], whole["n_eff"], rtol=1e-9)
        np.testing.assert_allclose(merged["statistic"], whole["statistic"], rtol=1e-9)
