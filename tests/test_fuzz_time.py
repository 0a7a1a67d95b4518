"""Fuzzing the time surfaces: time stamps, the inputs' bandwidth and joint positions q.

As in ``tests/test_fuzz.py``, the outcome of any call is a result or a documented
``dynval.InputError``; never another exception or a warning (pytest turns warnings into errors).
``validate`` and the streamed accumulator (in drawn chunks) give the same outcome kind, and an
error of one is an error of the other where both read the same stamps whole (the stream classifies
steps against its first stamps' nominal step, contract §4.1, so its values may differ).

Inputs: time stamps with steps from subnormal to 1e144 s, spans up to float64's limit, origins from
0 to ±1e308, in seconds or in another unit, with duplicated stamps, gaps, a backward step, NaN/inf,
with or without ``time_units_checked`` and a ``sample_rate``; bandwidths from subnormal to huge
(NaN, inf, negative, beyond the Nyquist frequency); and q that dithers by a count with a period of
2-4 samples, is quantised, stands still for most of the run, is constant, or steps like a staircase,
at scales from 1e-300 to 1e10, in the validation and the estimation run.

``DYNVAL_FUZZ_EXAMPLES`` sets the examples per test (scripts/sanitize.sh runs it against an
AddressSanitizer + UndefinedBehaviorSanitizer build of ``_core``).
"""

from __future__ import annotations

import os

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dynval
from dynval.checks import _timing
from dynval.stream import ValidationAccumulator

BACKENDS = ["python", "cpp"] if dynval.backends()["cpp"]["available"] else ["python"]
EXAMPLES = int(os.environ.get("DYNVAL_FUZZ_EXAMPLES", "40"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=list(HealthCheck),
)

STEPS = [5e-324, 2.2250738585072014e-308, 1e-300, 1e-150, 1e-144, 1e-12, 1e-6, 1e-5, 1e-4, 1e-3, 4e-3,
         0.01, 0.3, 1.0, 2.0, 10.0, 1e3, 1e6, 1e9, 1e100, 1e144]
ORIGINS = [0.0, -0.0, 3.7, -50.0, 1.46e9, 1e12, 1e144, -1e144, 1e300, -1e308, 1.7976931348623157e308]
RATES = [None, 1e-300, 0.5, 1.0, 100.0, 200.0, 1e3, 1e5, 1e300]
BANDWIDTHS = [5e-324, 1e-307, 1e-30, 1e-3, 0.5, 10.0, 49.999, 50.0, 50.000001, 150.0, 1e300, 0.0, -1.0,
              float("nan"), float("inf")]
Q_SCALES = [1e-300, 1e-12, 1e-6, 2 * np.pi / 2**17, 1e-3, 1.0, 1e3, 1e10]


def _data(n, m=2, seed=0):
    rng = np.random.default_rng(seed)
    meas = rng.normal(size=(n, m)) * 3.0 + 1.0
    return meas, meas + 0.2 * rng.normal(size=(n, m))


@st.composite
def stamps(draw):
    """Time stamps: a drawn step and origin, then duplicates, gaps, jitter, a backward step, NaN."""
    n = draw(st.integers(2, 300))
    step = draw(st.sampled_from(STEPS))
    origin = draw(st.sampled_from(ORIGINS))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    with np.errstate(all="ignore"):  # building the stamps may overflow on purpose
        steps = np.full(n - 1, step)
        if draw(st.booleans()):
            steps *= 1.0 + draw(st.sampled_from([1e-9, 1e-3, 0.05, 0.3])) * rng.uniform(-1, 1, n - 1)
        for _ in range(draw(st.integers(0, 3))):  # duplicated stamps, runs of them
            k = int(rng.integers(0, n - 1))
            steps[k:k + int(rng.integers(1, 40))] = 0.0
        for _ in range(draw(st.integers(0, 2))):  # gaps, up to absurd ones
            steps[int(rng.integers(0, n - 1))] *= draw(st.sampled_from([2.0, 10.0, 1e6, 1e300]))
        t = origin + np.concatenate(([0.0], np.cumsum(steps)))
        defect = draw(st.sampled_from(["none"] * 6 + ["backward", "nan", "inf", "frozen", "2-D"]))
        if defect == "backward" and n > 2:
            t[n // 2] = t[n // 2 - 1] - abs(step)
        elif defect == "nan":
            t[int(rng.integers(0, n))] = np.nan
        elif defect == "inf":
            t[-1] = np.inf
        elif defect == "frozen":
            t[:] = origin
        elif defect == "2-D":
            t = t[:, None]
    return t


def _validate(meas, pred, backend, **kw):
    try:
        report = dynval.validate(meas, pred, n_params=2, backend=backend, **kw)
    except dynval.InputError as error:
        return ("error", error.kind)
    report.summary()
    report.to_json()
    return ("ok", report)


def _streamed(meas, pred, t, chunks, backend, **kw):
    try:
        acc = ValidationAccumulator(n_params=2, backend=backend, **kw)
        for a, b in zip(chunks[:-1], chunks[1:]):
            acc.update(meas[a:b], pred[a:b], time=None if t is None else t[a:b])
        report = acc.result()
    except dynval.InputError as error:
        return ("error", error.kind)
    report.summary()
    report.to_json()
    return ("ok", report)


def _chunks(draw, n):
    cuts = sorted(set(draw(st.lists(st.integers(0, n), max_size=6))))
    return [0, *[c for c in cuts if 0 < c < n], n]


# --------------------------------------------------------------------------- time stamps


@FUZZ
@given(t=stamps(), data=st.data())
def test_time_stamps(t, data):
    n = t.shape[0]
    meas, pred = _data(n)
    backend = data.draw(st.sampled_from(BACKENDS))
    kw = dict(max_lag=data.draw(st.sampled_from([None, 0, 1, 5])),
              time_units_checked=data.draw(st.booleans()),
              sample_rate=data.draw(st.sampled_from(RATES)))
    whole = _validate(meas, pred, backend, time=t, **kw)
    if kw["max_lag"] is None:
        kw["max_lag"] = 3  # the stream's default needs the profile's cap; keep it small
    streamed = _streamed(meas, pred, t, _chunks(data.draw, n), backend, **kw)
    for outcome in (whole, streamed):
        assert outcome[0] in ("ok", "error")


@FUZZ
@given(t=stamps(), data=st.data())
def test_time_stamps_in_merged_accumulators(t, data):
    # one accumulator per drawn block, merged in order (as dynval.dask does), some of them copies
    n = t.shape[0]
    meas, pred = _data(n, seed=5)
    backend = data.draw(st.sampled_from(BACKENDS))
    units = data.draw(st.booleans())
    chunks = _chunks(data.draw, n)
    try:
        parts = []
        for a, b in zip(chunks[:-1], chunks[1:]):
            acc = ValidationAccumulator(n_params=2, max_lag=3, backend=backend, time_units_checked=units)
            acc.update(meas[a:b], pred[a:b], time=t[a:b])
            parts.append(acc)
        merged = parts[0]
        for later in parts[1:]:
            merged = merged.merge(later.copy() if data.draw(st.booleans()) else later)
        merged.result().summary()
    except dynval.InputError:
        pass


@FUZZ
@given(t=stamps(), data=st.data())
def test_time_stamps_in_one_chunk_agree_with_validate(t, data):
    # one chunk: the stream sees every stamp at once, as validate does
    n = t.shape[0]
    meas, pred = _data(n, seed=1)
    backend = data.draw(st.sampled_from(BACKENDS))
    kw = dict(max_lag=2, time_units_checked=data.draw(st.booleans()))
    whole = _validate(meas, pred, backend, time=t, **kw)
    streamed = _streamed(meas, pred, t, [0, n], backend, **kw)
    if n > 101 and t.ndim == 1:  # a stream settles its grid on more than 100 steps
        assert whole[0] == streamed[0], (whole, streamed)
        if whole[0] == "ok":
            assert whole[1].timing["sample_rate"] == streamed[1].timing["sample_rate"]


@FUZZ
@given(data=st.data())
def test_stamps_in_another_unit(data):
    fs = data.draw(st.sampled_from([1.0, 5.0, 10.0, 50.0, 100.0, 250.0, 1000.0, 4000.0, 1e4, 2e4, 1e5]))
    factor = data.draw(st.sampled_from([1.0, 1e3, 1e6, 1e9]))
    n = data.draw(st.integers(20, 400))
    meas, pred = _data(n, seed=2)
    t = np.arange(n) / fs * factor + data.draw(st.sampled_from([0.0, 1.46e9]))
    outcome = _validate(meas, pred, "python", time=t, max_lag=2)
    lo, hi = _timing.PLAUSIBLE_RATE
    if factor == 1.0:
        assert outcome[0] == ("ok" if lo <= fs <= hi else "error"), outcome
    elif fs < 1e4 or factor > 1e3:  # ms of a logger at 10 kHz or more are 10 Hz or more in seconds
        assert outcome == ("error", "InvalidParameter")


# --------------------------------------------------------------------------- bandwidth


@FUZZ
@given(data=st.data())
def test_bandwidth(data):
    n = data.draw(st.integers(2, 400))
    meas, pred = _data(n, seed=3)
    backend = data.draw(st.sampled_from(BACKENDS))
    bandwidth = data.draw(st.one_of(st.sampled_from(BANDWIDTHS), st.floats(allow_nan=True, allow_infinity=True)))
    rate = data.draw(st.sampled_from(RATES))
    timed = data.draw(st.booleans())
    t = np.arange(n) / 100.0 if timed else None
    whole = _validate(meas, pred, backend, sample_rate=rate, time=t, bandwidth=bandwidth,
                      max_lag=data.draw(st.sampled_from([None, 0, 3])))
    streamed = _streamed(meas, pred, t, _chunks(data.draw, n), backend, sample_rate=rate, bandwidth=bandwidth,
                         max_lag=3)
    nyquist = (rate if rate is not None else 100.0 if timed else np.nan) / 2.0
    if np.isfinite(bandwidth) and bandwidth > nyquist * (1 + 1e-12):
        assert whole == ("error", "InvalidParameter")
        assert streamed == ("error", "InvalidParameter")


# --------------------------------------------------------------------------- joint positions


@st.composite
def positions(draw, n):
    """q that dithers, is quantised, stands still, is constant or steps, at a drawn scale."""
    k = np.arange(n)
    scale = draw(st.sampled_from(Q_SCALES))
    kind = draw(st.sampled_from(["dither", "quantised", "standstill", "constant", "staircase", "mixed"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    wave = np.sin(2 * np.pi * k / max(n / draw(st.integers(1, 6)), 2.0))
    with np.errstate(all="ignore"):
        if kind == "dither":
            period = draw(st.integers(2, 4))
            joint = scale * (k % period)
        elif kind == "quantised":
            joint = np.round(wave * draw(st.sampled_from([1, 4, 100, 2**17]))) * scale
        elif kind == "standstill":
            moving = draw(st.integers(0, max(n // 10, 1)))
            joint = np.r_[np.zeros(n - moving), np.linspace(0.0, 1.0, moving)] * scale
        elif kind == "constant":
            joint = np.full(n, scale)
        elif kind == "staircase":
            joint = np.repeat(np.arange(n // 4 + 1), 4)[:n] * scale
        else:
            joint = scale * np.where(k < n // 2, k % 2, wave)
        q = np.column_stack([joint, draw(st.sampled_from([joint, np.zeros(n), wave * scale,
                                                          rng.integers(0, 2, n) * scale]))])
    return q


@FUZZ
@given(data=st.data())
def test_joint_positions(data):
    n = data.draw(st.integers(2, 600))
    meas, pred = _data(n, seed=4)
    q = data.draw(positions(n))
    backend = data.draw(st.sampled_from(BACKENDS))
    kw = dict(q=q, sample_rate=data.draw(st.sampled_from([None, 100.0, 1000.0])))
    if data.draw(st.booleans()):
        rng = np.random.default_rng(n)
        kw.update(regressor=rng.normal(size=(n, 2, 3)),
                  estimation={"q": data.draw(positions(n)), "regressor": rng.normal(size=(n, 2, 3)), "tau": meas})
    outcome = _validate(meas, pred, backend, **kw)
    # an ordinary q never loses the report: only N < 2 is refused
    assert outcome[0] == "ok" or n < 2, outcome
    if outcome[0] == "ok" and outcome[1].periodic is not None and not outcome[1].periodic["used"]:
        assert outcome[1].periodic["note"]
