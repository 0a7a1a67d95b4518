"""Time stamps (``time=``), the inputs' bandwidth (``bandwidth=``) and the motion's largest lag."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dynval
from dynval.checks import _timing
from dynval.checks._errors import InvalidParameter, NonFiniteInput, ShapeMismatch


def _run(fs=200.0, seconds=20.0, seed=0, m=2, f0=0.3):
    t = np.arange(int(fs * seconds)) / fs
    rng = np.random.default_rng(seed)
    tau = np.column_stack([np.sin(2 * np.pi * f0 * (j + 1) * t + j) for j in range(m)])
    meas = tau + 0.02 * rng.standard_normal(tau.shape)
    return t, meas, tau


def _without(d, *keys):
    return {k: v for k, v in d.items() if k not in keys}


# --------------------------------------------------------------------------- the uniform grid is unchanged


@pytest.mark.parametrize("fs, origin", [(100.0, 0.0), (200.0, 1.46e9), (1000.0, 3.7), (333.0, 0.0)])
def test_uniform_stamps_change_no_number(fs, origin):
    t, meas, pred = _run(fs, 10.0)
    ref = dynval.validate(meas, pred, n_params=2, sample_rate=fs).to_dict()
    got = dynval.validate(meas, pred, n_params=2, time=t + origin).to_dict()
    assert got["timing"]["sample_rate"] == fs
    assert got["timing"]["regular"] is True
    assert _without(got, "timing", "provenance") == _without(ref, "timing", "provenance")
    conv_ref, conv = ref["provenance"]["conventions"], got["provenance"]["conventions"]
    assert _without(conv, "time_grid") == _without(conv_ref, "time_grid")
    assert conv["time_grid"].startswith(f"equally spaced rows at the nominal rate {fs:g} Hz")
    assert ref["timing"] is None and not any(f["kind"] == "time_stamps" for f in got["findings"])


def test_a_given_rate_must_agree_with_the_stamps():
    t, meas, pred = _run(200.0, 5.0)
    r = dynval.validate(meas, pred, n_params=2, time=t, sample_rate=200.0 * 1.009)
    assert r.timing["sample_rate_source"] == "given" and r.provenance["sample_rate"] == 200.0 * 1.009
    with pytest.raises(InvalidParameter, match=r"sample_rate=202.2 Hz disagrees with the time stamps.*200 Hz"):
        dynval.validate(meas, pred, n_params=2, time=t, sample_rate=200.0 * 1.011)
    # stamps in milliseconds are caught by the same check
    with pytest.raises(InvalidParameter, match="time must be in seconds"):
        dynval.validate(meas, pred, n_params=2, time=1e3 * t, sample_rate=200.0)


# --------------------------------------------------------------------------- what the stamps say


def test_duplicates_gaps_and_jitter_are_counted():
    fs = 200.0
    t, meas, pred = _run(fs, 20.0)
    rng = np.random.default_rng(3)
    stamps = t + rng.uniform(-0.05, 0.05, t.size) / fs   # 10 % jitter at most: regular
    stamps[[100, 2000]] += 0.3 / fs                       # two steps 30 % late, then 30 % early
    stamps[501] = stamps[500]                             # a duplicated stamp
    meas[1201] = meas[1200]                               # a repeated row
    keep = np.ones(t.size, dtype=bool)
    keep[3000:3004] = False                               # 4 samples missing: a 25 ms gap
    keep[3500] = False                                    # 1 missing: a 10 ms gap
    r = dynval.validate(meas[keep], pred[keep], n_params=2, time=stamps[keep])
    tm = r.timing
    assert tm["duplicated_stamps"] == 1 and tm["repeated_rows"] == 1
    assert tm["gaps"] == 2
    assert math.isclose(tm["largest_gap"], stamps[3004] - stamps[2999])
    assert math.isclose(tm["largest_gap_time"], stamps[3004] - stamps[0])
    assert tm["irregular_steps"] == 4                     # 100 and 2000 late by 30 %, their next early
    assert tm["sample_rate"] == fs
    # the run is split at both gaps: no lag crosses missing time
    assert r.provenance["segments"] == [3000, 496, 499]
    note = [f for f in r.findings if f.kind == "time_stamps"]
    assert len(note) == 1 and note[0].severity == "note"
    text = note[0].message
    assert "1 duplicated stamp;" in text and "1 row repeating" in text and "4 steps more than 10 %" in text
    assert f"2 gaps (largest {1e3 * tm['largest_gap']:.4g} ms at t = {tm['largest_gap_time']:.4g} s)" in text
    assert "split into 3 segments at the 2 gaps" in text


def test_omitted_rows_become_gaps():
    t, meas, pred = _run(200.0, 10.0)
    meas[700:703] = np.nan
    r = dynval.validate(meas, pred, n_params=2, time=t, nan_policy="omit")
    assert r.timing["gaps"] == 1 and math.isclose(r.timing["largest_gap"], 4 / 200.0)
    assert r.provenance["segments"] == [700, t.size - 703]


def test_gap_threshold_is_one_and_a_half_steps():
    t = np.arange(400) / 100.0
    for late, gaps in ((0.49, 0), (0.51, 1)):
        s = t.copy()
        s[200:] += late / 100.0
        assert _timing.analyse(s).gaps == gaps


def test_irregular_threshold_is_ten_percent():
    t = np.arange(400) / 100.0
    for late, irregular in ((0.099, 0), (0.101, 2)):
        s = t.copy()
        s[200] += late / 100.0
        assert _timing.analyse(s).irregular_steps == irregular


@pytest.mark.parametrize("bad, error, text", [
    (np.arange(10.0), ShapeMismatch, r"time must have one stamp per sample, shape \(1000,\), got \(10,\)"),
    (np.where(np.arange(1000) == 7, np.nan, np.arange(1000.0)), NonFiniteInput, "got nan at row 7"),
    (np.where(np.arange(1000) == 9, 0.0, np.arange(1000.0)), InvalidParameter, "never decrease, got 0.0 at row 9"),
    (np.zeros(1000), InvalidParameter, "time must advance"),
])
def test_bad_stamps_are_refused_by_name(bad, error, text):
    _, meas, pred = _run(100.0, 10.0)
    with pytest.raises(error, match=text):
        dynval.validate(meas, pred, n_params=2, time=bad)


# --------------------------------------------------------------------------- the largest lag follows the motion


def test_default_lag_is_one_period_of_the_band_edge():
    fs = 500.0
    _, meas, pred = _run(fs, 20.0, f0=2.0)
    r = dynval.validate(meas, pred, n_params=2, sample_rate=fs)
    band = r.whiteness["information_band"]
    conv = r.provenance["conventions"]
    assert conv["max_lag"] == math.ceil(fs / band) < 200
    assert conv["max_lag_seconds"] == conv["max_lag"] / fs
    assert conv["max_lag_source"].startswith("motion")
    assert r.autocorrelation["rho"].shape[0] == conv["max_lag"] + 1
    # no rate: the profile's count of samples; a given lag is kept
    assert dynval.validate(meas, pred, n_params=2).provenance["conventions"]["max_lag"] == 50
    given = dynval.validate(meas, pred, n_params=2, sample_rate=fs, max_lag=7).provenance["conventions"]
    assert given["max_lag"] == 7 and given["max_lag_source"] == "given"


def test_default_lag_is_capped_at_four_times_the_profile_count():
    fs = 1000.0
    t = np.arange(20000) / fs
    pred = np.sin(2 * np.pi * 0.2 * t)[:, None]           # band edge near 0.2 Hz: 5 s of lags
    meas = pred + 0.01 * np.random.default_rng(1).standard_normal(pred.shape)
    conv = dynval.validate(meas, pred, n_params=1, sample_rate=fs).provenance["conventions"]
    assert conv["max_lag"] == 200 and conv["max_lag_seconds"] == 0.2
    conv = dynval.validate(meas, pred, n_params=1, sample_rate=fs, profile="matlab").provenance["conventions"]
    assert conv["max_lag"] == 100


# --------------------------------------------------------------------------- the inputs' bandwidth


def _oscillating(fs=200.0, f=30.0):
    t, meas, pred = _run(fs, 30.0, m=1)
    meas = meas + 0.05 * np.sin(2 * np.pi * f * t)[:, None]
    return meas, pred


def test_a_peak_above_the_bandwidth_is_processing():
    meas, pred = _oscillating()
    plain = dynval.validate(meas, pred, n_params=1, sample_rate=200.0)
    assert any(f.kind == "oscillation" and f.severity == "deficiency" for f in plain.findings)
    r = dynval.validate(meas, pred, n_params=1, sample_rate=200.0, bandwidth=12.0)
    assert not any(f.kind == "oscillation" for f in r.findings)
    note = [f for f in r.findings if f.kind == "processing_band" and f.details["evidence"] == "oscillation"]
    assert len(note) == 1 and note[0].severity == "note" and "12 Hz bandwidth" in note[0].message
    # below the peak's frequency it is the model's again
    r = dynval.validate(meas, pred, n_params=1, sample_rate=200.0, bandwidth=40.0)
    assert any(f.kind == "oscillation" and f.severity == "deficiency" for f in r.findings)


def test_whiteness_is_tested_within_the_bandwidth():
    meas, pred = _oscillating()
    r = dynval.validate(meas, pred, n_params=1, sample_rate=200.0, bandwidth=12.0)
    w = r.whiteness
    assert w["bandwidth"] == 12.0 and 200.0 / (2 * w["decimation"]) <= 12.0 and not w["above_bandwidth"]
    r = dynval.validate(meas, pred, n_params=1, sample_rate=200.0, bandwidth=12.0, decimate=None)
    assert r.whiteness["above_bandwidth"]
    assert not any(f.kind == "whiteness" for f in r.findings)
    assert any(f.kind == "processing_band" and f.details["evidence"] == "whiteness" for f in r.findings)


@pytest.mark.parametrize("kwargs, text", [
    ({"bandwidth": 10.0}, "bandwidth must be None without sample_rate or time"),
    ({"bandwidth": -1.0, "sample_rate": 100.0}, r"bandwidth must be None or a finite number > 0 \(Hz\), got -1.0"),
    ({"bandwidth": float("inf"), "sample_rate": 100.0}, "bandwidth must be None or a finite number"),
])
def test_bad_bandwidth_is_refused_by_name(kwargs, text):
    _, meas, pred = _run(100.0, 5.0)
    with pytest.raises(InvalidParameter, match=text):
        dynval.validate(meas, pred, n_params=2, **kwargs)


# --------------------------------------------------------------------------- the KUKA LWR4+ logs


def _kuka():
    from dynval.datasets import load_kuka_lwr4

    est, val = load_kuka_lwr4(1), load_kuka_lwr4(3)

    def columns(run):  # a decoupled per-joint model of the logged motion (no pinocchio needed)
        eye = np.eye(run.q.shape[1])
        terms = [run.ddq, run.dq, np.sign(run.dq), np.sin(run.q), np.cos(run.q)]
        return np.concatenate([x[:, :, None] * eye for x in terms], axis=2)

    fit = dynval.identify(columns(est), est.tau)
    return val, fit.predict(columns(val)), fit.rank


def test_kuka_stamps_uniform_jittered_duplicated_and_gapped():
    val, pred, rank = _kuka()
    n = val.tau.shape[0]
    kw = dict(n_params=rank, max_lag=20)
    # on the uniform grid the stamps change no number
    ref = dynval.validate(val.tau, pred, sample_rate=200.0, **kw).to_dict()
    got = dynval.validate(val.tau, pred, time=np.arange(n) / 200.0 + 1.46e9, **kw).to_dict()
    assert _without(got, "timing", "provenance") == _without(ref, "timing", "provenance")
    # the log's own receive stamps: 200 Hz within their jitter, a few late steps
    own = dynval.validate(val.tau, pred, time=val.time, **kw)
    assert own.timing["sample_rate"] == pytest.approx(200.0, rel=1e-4) and own.timing["gaps"] == 0
    assert own.timing["irregular_steps"] >= 1 and own.timing["duplicated_stamps"] == 0
    # jittered (±20 % of a step), duplicated and gapped stamps built from them
    rng = np.random.default_rng(7)
    t = val.time + rng.uniform(-0.2, 0.2, n) / 200.0
    dup = np.sort(rng.choice(np.arange(10, n - 10), 40, replace=False))
    dup = dup[np.diff(dup, prepend=-10) > 2]                 # isolated: each stamp repeats its predecessor's
    t[dup] = t[dup - 1]
    tau = val.tau.copy()
    keep = np.ones(n, dtype=bool)
    keep[1500:1520] = False                                  # 100 ms lost
    keep[4000:4002] = False                                  # 10 ms lost
    r = dynval.validate(tau[keep], pred[keep], time=t[keep], **kw)
    tm = r.timing
    assert tm["duplicated_stamps"] == np.count_nonzero(keep[dup] & keep[dup - 1])
    assert tm["gaps"] == 2 and tm["largest_gap"] == pytest.approx(0.105, abs=0.003)
    assert tm["irregular_steps"] > 1000 and tm["sample_rate"] == pytest.approx(200.0, rel=1e-4)
    assert len(r.provenance["segments"]) == 3
    assert [f.kind for f in r.findings].count("time_stamps") == 1


def test_a_given_lag_longer_than_the_stretches_between_gaps_is_refused_by_name():
    t = np.cumsum(np.where(np.arange(600) % 20 == 0, 0.05, 0.01))   # a 50 ms gap every 20 samples
    _, meas, pred = _run(100.0, 6.0)
    with pytest.raises(InvalidParameter, match=r"max_lag must be below 20, the longest run of samples between "
                                               r"the 29 gaps of the time stamps, got 50"):
        dynval.validate(meas, pred, n_params=2, time=t, max_lag=50)
    r = dynval.validate(meas, pred, n_params=2, time=t, max_lag=19)
    assert len(r.provenance["segments"]) == 30 and r.provenance["conventions"]["max_lag"] == 19
