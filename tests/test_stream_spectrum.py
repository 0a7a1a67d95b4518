"""The residual spectrum of a streamed report: ``validate``'s Welch windows, summed as they arrive
(contract §4.1, ``dynval.streaming._welch``)."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval import coverage
from dynval.stream import ValidationAccumulator


def _data(n=20000, m=2, scale=1.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    e = 0.1 * rng.standard_normal((n, m))
    tau = rng.standard_normal((n, m))
    pred = tau - e
    # a line at 7 Hz on the last joint, in the measured torque only: an oscillation the model misses (in the
    # prediction it would be the model's own artefact, which a stream cannot tell apart, contract §4.1)
    tau[:, -1] += 0.05 * np.sin(2 * np.pi * 7.0 * t)
    return tau * scale, pred * scale


def _feed(acc, tau, pred, lengths, rng, time=None):
    start = 0
    for length in lengths:
        a = start
        while a < start + length:
            b = min(a + int(rng.integers(1, 900)), start + length)
            acc.update(tau[a:b], pred[a:b], time=None if time is None else time[a:b])
            a = b
        acc.break_segment()
        start += length
    return acc


def _same_spectrum(got, want):
    assert got.spectrum is not None and want.spectrum is not None
    assert got.spectrum["nperseg"] == want.spectrum["nperseg"] and got.spectrum["dof"] == want.spectrum["dof"]
    np.testing.assert_allclose(got.spectrum["frequency"], want.spectrum["frequency"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(got.spectrum["power"], want.spectrum["power"], rtol=1e-12, atol=0)
    assert [(p["joint"], p["bin"]) for p in got.spectrum["peaks"]] == [(p["joint"], p["bin"])
                                                                        for p in want.spectrum["peaks"]]
    assert sorted((f.kind, f.joints) for f in got.findings) == sorted((f.kind, f.joints) for f in want.findings)


@pytest.mark.parametrize("lengths", [[20000], [7000, 13000], [500, 19000, 500]])
def test_equals_validate_over_any_chunking_and_segments(backend, lengths):
    tau, pred = _data()
    acc = _feed(ValidationAccumulator(n_params=2, sample_rate=100.0, max_lag=50, backend=backend), tau, pred, lengths,
                np.random.default_rng(len(lengths)))
    got = acc.result()
    want = dynval.validate(tau, pred, n_params=2, sample_rate=100.0, max_lag=50, segments=lengths)
    _same_spectrum(got, want)
    assert ("oscillation", (1,)) in {(f.kind, f.joints) for f in got.findings}
    assert "spectrum" not in {t["test"] for t in got.provenance["not_tested"]}


@pytest.mark.parametrize("n", [40, 300, 3000])
def test_short_streams_take_validates_window(backend, n):
    tau, pred = _data(n=n, seed=n)
    got = _feed(ValidationAccumulator(n_params=2, max_lag=5, backend=backend), tau, pred, [n],
                np.random.default_rng(1)).result()
    _same_spectrum(got, dynval.validate(tau, pred, n_params=2, max_lag=5))


@pytest.mark.parametrize("scale", [1e-200, 1e140])
def test_any_scale(backend, scale):
    tau, pred = _data(n=5000, scale=scale)
    got = _feed(ValidationAccumulator(n_params=2, max_lag=20, backend=backend), tau, pred, [5000],
                np.random.default_rng(2)).result()
    _same_spectrum(got, dynval.validate(tau, pred, n_params=2, max_lag=20))


def test_omitted_rows_and_time_gaps_break_the_windows(backend):
    tau, pred = _data(n=12000)
    pred[3000:3004] = np.nan
    time = np.arange(12000) / 100.0
    time[8000:] += 5.0  # a gap: a new segment
    acc = _feed(ValidationAccumulator(n_params=2, max_lag=30, nan_policy="omit", backend=backend), tau, pred,
                [12000], np.random.default_rng(3), time=time)
    got = acc.result()
    want = dynval.validate(tau, pred, n_params=2, max_lag=30, nan_policy="omit", time=time)
    assert got.provenance["segments"] == want.provenance["segments"]
    _same_spectrum(got, want)


def test_merges_keep_the_windows_only_across_a_break(backend):
    tau, pred = _data(n=10000)
    whole = dynval.validate(tau, pred, n_params=2, max_lag=30, segments=[4000, 6000])

    def part(a, b, break_before=False):
        acc = ValidationAccumulator(n_params=2, max_lag=30, backend=backend)
        if break_before:
            acc.break_segment()
        acc.update(tau[a:b], pred[a:b])
        return acc

    _same_spectrum(part(0, 4000).merge(part(4000, 10000, break_before=True)).result(), whole)
    joined = part(0, 4000).merge(part(4000, 10000)).result()
    assert joined.spectrum is None
    assert {"test": "spectrum", "kinds": ["oscillation"], "why": coverage.OFF_GRID} in joined.provenance["not_tested"]
    # an empty accumulator, or one that starts the stream, changes nothing
    first = ValidationAccumulator(n_params=2, max_lag=30, backend=backend).merge(part(0, 4000))
    first.break_segment()
    _same_spectrum(first.merge(part(4000, 10000)).result(), whole)


def test_with_a_regressor_it_is_named_as_not_tested(backend):
    tau, pred = _data(n=4000)
    y = np.random.default_rng(4).standard_normal((4000, 2, 3))
    acc = ValidationAccumulator(n_params=2, max_lag=20, backend=backend)
    acc.update(tau, pred, y)
    report = acc.result()
    assert report.spectrum is None
    left_out = {t["test"]: t["why"] for t in report.provenance["not_tested"]}
    assert left_out["spectrum"] == coverage.NOT_RUN_WITH["stream"]["spectrum"][1]
