"""Time stamps in another unit than seconds, a bandwidth above the Nyquist frequency, and finite stamps
that float64 cannot count (contract §4): refused by every door that takes them (``validate``,
``compare``, the accumulator, ``dynval.dask`` and the command line), with the fix in the message."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import dynval
from dynval.checks import _timing
from dynval.checks._errors import InvalidParameter, NonFiniteInput
from dynval.stream import ValidationAccumulator

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(fs=200.0, n=2000, seed=0):
    t = np.arange(n) / fs
    rng = np.random.default_rng(seed)
    pred = np.column_stack([np.sin(2 * np.pi * 0.7 * t), np.cos(2 * np.pi * 1.3 * t)])
    return t, pred + 0.05 * rng.standard_normal(pred.shape), pred


# the unit the message names, and what to divide by, for stamps of a robot's usual rates
UNITS = [(200.0, 1e3, "milliseconds", "1000"), (200.0, 1e6, "microseconds", "1000000"),
         (200.0, 1e9, "nanoseconds", "1000000000"), (1000.0, 1e3, "milliseconds", "1000"),
         (1000.0, 1e6, "microseconds", "1000000"), (1000.0, 1e9, "nanoseconds", "1000000000"),
         (100.0, 1e3, "milliseconds", "1000"), (4000.0, 1e6, "microseconds", "1000000"),
         (4000.0, 1e3, "milliseconds", "1000"), (9000.0, 1e3, "milliseconds", "1000")]


@pytest.mark.parametrize("fs, factor, unit, divide", UNITS)
def test_stamps_in_another_unit_are_refused_with_the_fix(fs, factor, unit, divide):
    t, meas, pred = _run(fs)
    with pytest.raises(InvalidParameter, match=rf"time must be in seconds.*these look like {unit}: pass time / "
                                               rf"{divide}, or time_units_checked=False"):
        dynval.validate(meas, pred, n_params=2, time=t * factor)
    # the fix the message gives is accepted
    report = dynval.validate(meas, pred, n_params=2, time=t * factor / float(divide))
    assert report.timing["sample_rate"] == pytest.approx(fs)


@pytest.mark.parametrize("step, accepted", [(1.0, False), (2.0, False), (10.0, False), (1000.0, False),
                                            (0.0999, True), (1e-5, True), (0.99e-5, False), (0.1001, False),
                                            (0.5, False), (0.25, False), (1 / 3, False), (0.05, True)])
def test_the_plausible_range_and_whole_second_steps(step, accepted):
    n = 400
    rng = np.random.default_rng(1)
    meas = rng.normal(size=(n, 2))
    pred = meas + 0.1 * rng.normal(size=(n, 2))
    t = np.arange(n) * step
    if accepted:
        dynval.validate(meas, pred, n_params=2, time=t, max_lag=5)
    else:
        with pytest.raises(InvalidParameter, match="time must be in seconds"):
            dynval.validate(meas, pred, n_params=2, time=t, max_lag=5)
    # the override keeps any rate float64 can count
    report = dynval.validate(meas, pred, n_params=2, time=t, max_lag=5, time_units_checked=False)
    assert report.timing["nominal_step"] == pytest.approx(step)


def test_the_guess_is_the_unit_nearest_a_robots_rate():
    assert _timing._unit_guess(1.0) == ("milliseconds", 1e3)  # steps of 1: 1 kHz in ms
    assert _timing._unit_guess(4.0) == ("milliseconds", 1e3)  # steps of 0.25: 4 kHz in ms
    assert _timing._unit_guess(0.1) == ("milliseconds", 1e3)  # steps of 10: 100 Hz in ms, not 100 kHz in µs
    assert _timing._unit_guess(1e-3) == ("microseconds", 1e6)  # steps of 1000
    assert _timing._unit_guess(1e-6) == ("nanoseconds", 1e9)  # steps of 1e6
    assert _timing._unit_guess(2e5) is None  # too fast for any smaller unit


def test_epoch_stamps_in_seconds_are_plausible():
    t, meas, pred = _run(200.0)
    report = dynval.validate(meas, pred, n_params=2, time=t + 1.46e9)
    assert report.timing["sample_rate"] == 200.0


def test_the_override_must_be_a_bool():
    t, meas, pred = _run()
    with pytest.raises(InvalidParameter, match=r"time_units_checked must be True or False, got 'no'"):
        dynval.validate(meas, pred, n_params=2, time=t, time_units_checked="no")
    with pytest.raises(InvalidParameter, match=r"time_units_checked must be True or False, got 0"):
        ValidationAccumulator(n_params=2, max_lag=3, time_units_checked=0)


def test_compare_refuses_milliseconds_and_takes_the_override():
    t, meas, pred = _run(1000.0)
    candidates = {"a": (pred, 2), "b": (pred * 1.01, 2)}
    with pytest.raises(InvalidParameter, match="these look like milliseconds"):
        dynval.compare(meas, candidates, time=t * 1e3)
    out = dynval.compare(meas, candidates, time=t * 1e3, time_units_checked=False)
    assert set(out.ranking) == {"a", "b"}


@pytest.mark.parametrize("chunk", [50, 1000])
def test_the_stream_refuses_milliseconds_early(chunk):
    t, meas, pred = _run(1000.0)
    acc = ValidationAccumulator(n_params=2, max_lag=5)
    with pytest.raises(InvalidParameter, match=r"^chunk \d+: time must be in seconds.*these look like "
                                               r"milliseconds: pass time / 1000"):
        for k in range(0, 1000, chunk):  # within the first thousand rows, not at result()
            acc.update(meas[k:k + chunk], pred[k:k + chunk], time=1e3 * t[k:k + chunk])
    assert acc.n_samples == (100 // chunk) * chunk  # the chunk that completes the first 100 steps is refused
    acc = ValidationAccumulator(n_params=2, max_lag=5, time_units_checked=False)
    for k in range(0, t.size, chunk):
        acc.update(meas[k:k + chunk], pred[k:k + chunk], time=1e3 * t[k:k + chunk])
    assert acc.result().timing["sample_rate"] == 1.0


# --------------------------------------------------------------------------- bandwidth and the Nyquist frequency


@pytest.mark.parametrize("rate, bandwidth", [(0.2, 12.0), (200.0, 150.0), (200.0, 100.000001)])
def test_a_bandwidth_above_nyquist_is_refused(rate, bandwidth):
    n = 600
    t, meas, pred = _run(rate, n)
    nyquist = f"{rate / 2:.6g}"
    message = rf"bandwidth must be at most the Nyquist frequency {nyquist} Hz \(half the sample rate"
    with pytest.raises(InvalidParameter, match=message):
        dynval.validate(meas, pred, n_params=2, sample_rate=rate, bandwidth=bandwidth)
    with pytest.raises(InvalidParameter, match=message):  # with the rate from the stamps alone too
        dynval.validate(meas, pred, n_params=2, time=t, bandwidth=bandwidth, time_units_checked=False)
    with pytest.raises(InvalidParameter, match=message):
        ValidationAccumulator(n_params=2, max_lag=3, sample_rate=rate, bandwidth=bandwidth)
    acc = ValidationAccumulator(n_params=2, max_lag=3, bandwidth=bandwidth, time_units_checked=False)
    with pytest.raises(InvalidParameter, match=message):  # when the stamps set the rate
        acc.update(meas, pred, time=t)


def test_a_bandwidth_at_nyquist_is_accepted():
    t, meas, pred = _run(200.0)
    assert dynval.validate(meas, pred, n_params=2, time=t, bandwidth=100.0).whiteness["bandwidth"] == 100.0
    acc = ValidationAccumulator(n_params=2, max_lag=3, bandwidth=100.0)
    acc.update(meas, pred, time=t)
    assert acc.result().provenance["conventions"]["bandwidth"] == 100.0


@pytest.mark.parametrize("bandwidth", [1e-307, 5e-324, 1e-30, 1e-3])
def test_a_bandwidth_far_below_the_rate_gives_a_report(bandwidth):
    # the motion's largest lag (rate / band) and the decimation (rate / 2 band) overflowed int
    _, meas, pred = _run(100.0, 800)
    report = dynval.validate(meas, pred, n_params=1, sample_rate=100.0, bandwidth=bandwidth)
    assert 1 <= report.provenance["conventions"]["max_lag"] < 800
    assert report.whiteness["decimation"] <= 800


# --------------------------------------------------------------------------- stamps float64 cannot count


SPAN = np.r_[-1e308, np.linspace(0.0, 1e308, 599)]


@pytest.mark.parametrize("units_checked", [True, False])
@pytest.mark.parametrize("t, kind, message", [
    (np.arange(600) * 5e-324, InvalidParameter, r"time must advance by steps float64 can count .* got a median "
                                                r"step of 5e-324 s"),
    (np.arange(600) * 1e-150, InvalidParameter, "time must advance by steps float64 can count"),
    (np.r_[np.zeros(599), 1e-320], InvalidParameter, "time must advance by steps float64 can count"),
    (np.r_[np.arange(599) * 1e-3, 1e14], InvalidParameter, "at most 2[*][*]53 of them"),
    (SPAN, NonFiniteInput, r"time has a value out of range \(-1e\+308\) at row 0: \|t\| must be at most 1e\+144 s"),
    (np.r_[np.arange(599) * 1e-3, 2e144], NonFiniteInput, r"time has a value out of range \(2e\+144\) at row 599"),
])
def test_stamps_float64_cannot_count_are_refused(t, kind, message, units_checked):
    rng = np.random.default_rng(0)
    meas = rng.normal(size=(600, 2))
    pred = meas + 0.1 * rng.normal(size=(600, 2))
    with pytest.raises(kind, match=message):
        dynval.validate(meas, pred, n_params=2, time=t, time_units_checked=units_checked)
    acc = ValidationAccumulator(n_params=2, max_lag=3, time_units_checked=units_checked)
    with pytest.raises(kind, match=message if kind is InvalidParameter else "time has a value out of range"):
        for k in range(0, 600, 200):
            acc.update(meas[k:k + 200], pred[k:k + 200], time=t[k:k + 200])
        acc.result()


def test_a_streams_stamp_out_of_range_names_the_chunk_and_row():
    acc = ValidationAccumulator(n_params=1, max_lag=1, time_units_checked=False)
    acc.update(np.zeros(3), np.zeros(3), time=[0.0, 1.0, 2.0])
    with pytest.raises(NonFiniteInput, match=r"chunk 1: time has a value out of range \(1e\+308\) at row 1 "
                                             r"\(row 4 of the stream\)"):
        acc.update(np.zeros(2), np.zeros(2), time=[3.0, 1e308])
    assert acc.n_samples == 3


# --------------------------------------------------------------------------- the command line


def _cli(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "dynval", "validate", "m.npy", "p.npy", "--n-params", "2", *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, PYTHONPATH=os.path.join(ROOT, "python")))


@pytest.fixture
def files(tmp_path):
    t, meas, pred = _run(1000.0, 600)
    np.save(tmp_path / "m.npy", meas)
    np.save(tmp_path / "p.npy", pred)
    np.save(tmp_path / "t.npy", t)
    np.save(tmp_path / "tms.npy", t * 1e3)
    np.save(tmp_path / "t0d.npy", np.float64(1.0))
    np.save(tmp_path / "tspan.npy", SPAN)
    np.save(tmp_path / "tsub.npy", np.arange(600) * 5e-324)
    return tmp_path


@pytest.mark.parametrize("stream", [[], ["--stream"]])
def test_cli_time_units(files, stream):
    p = _cli(files, "--time", "tms.npy", *stream)
    assert p.returncode == 1, p.stderr
    assert "these look like milliseconds: pass time / 1000, or --time-units-unchecked" in p.stderr
    p = _cli(files, "--time", "tms.npy", "--time-units-unchecked", *stream)
    assert p.returncode == 0, p.stderr
    p = _cli(files, "--time", "t.npy", "--bandwidth", "600", *stream)
    assert p.returncode == 1 and "bandwidth must be at most the Nyquist frequency 500 Hz" in p.stderr


@pytest.mark.parametrize("stream", [[], ["--stream"]])
@pytest.mark.parametrize("spec, message", [
    ("t0d.npy", "t0d.npy: holds a single number (an array of shape ()); one column is needed"),
    ("tspan.npy", "time has a value out of range (-1e+308) at row 0"),
    ("tsub.npy", "time must advance by steps float64 can count"),
])
def test_cli_stamps_that_cannot_be_counted_are_input_errors(files, spec, message, stream):
    p = _cli(files, "--time", spec, *stream)
    assert p.returncode == 1, p.stderr
    assert message in p.stderr and "internal error" not in p.stderr


def test_cli_help_names_the_override():
    p = subprocess.run([sys.executable, "-m", "dynval", "validate", "--help"], capture_output=True, text=True,
                       timeout=120, env=dict(os.environ, PYTHONPATH=os.path.join(ROOT, "python")))
    text = " ".join(p.stdout.split())
    assert "--time-units-unchecked" in text and "outside 10 Hz to 100 kHz" in text
    assert "at most their Nyquist frequency" in text
