"""Parameters checked before anything is allocated (contract §4.1): the streamed state's documented
bound, lag ranges checked by their ends, and ``StreamState.__setstate__`` checking every saved
size against the layout (a longer array used to make ``sums()`` write past its buffers).

The refusals are measured in a child process whose address space is limited to 1 GiB (after its
imports): code that allocated first would fail there with MemoryError instead of the documented
InvalidParameter, and within a few seconds.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import time
import tracemalloc

import numpy as np
import pytest

import dynval
from dynval.stream import ValidationAccumulator
from dynval.streaming._stream import MAX_STATE_CELLS, Layout, State, state_cells

HAS_CPP = dynval.backends()["cpp"]["available"]
if HAS_CPP:
    from dynval import _core

needs_cpp = pytest.mark.skipif(not HAS_CPP, reason="needs the compiled backend")


_CHILD = """
import os, resource, time
import numpy as np
import dynval
from dynval.stream import ValidationAccumulator
with open("/proc/self/statm") as f:
    used = int(f.read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (used + 2**30, used + 2**30))
backends = [b for b in ("python", "cpp") if dynval.backends()[b]["available"]]

def outcome(case, call):
    start = time.perf_counter()
    try:
        call()
        kind = "ok"
    except Exception as error:
        kind = type(error).__name__ + ": " + str(error)
    print(f"{case}|{time.perf_counter() - start:.3f}|{kind}")

tau = np.random.default_rng(0).normal(size=(500, 6))
wide = np.zeros((3, 524_287))  # 3 rows of 524,287 joints: 144 lags each, 7.4 GB streamed
e = tau[:, :2]
for b in backends:
    acc = ValidationAccumulator(n_params=2, max_lag=30_000_000, backend=b)
    outcome(f"max_lag-{b}", lambda: acc.update(tau, tau * 0.9))
    print(f"rows-{b}|0|{acc.n_samples}")
    outcome(f"wide-{b}", lambda: ValidationAccumulator(n_params=2, backend=b).update(wide, wide))
    for lags in (range(1, 10**8), range(1, 10**12), range(10**12, 0, -1), range(0, 5), range(3, 3)):
        outcome(f"lags-{b}", lambda: dynval.ljung_box(e, lags, backend=b))
if "cpp" in backends:
    from dynval import _core
    for layout in ((6, 0, 30_000_000, 0, False), (524_287, 0, 143, 50, False), (2, 3000, 25_000, 25_000, True)):
        outcome("core", lambda: _core.StreamState(*layout))
"""


@pytest.fixture(scope="module")
def limited_child() -> dict[str, list[tuple[float, str]]]:
    """The refusals of ``_CHILD``, run after its imports with RLIMIT_AS = 1 GiB above what they took:
    {case: [(seconds, outcome), ...]}."""
    env = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
           "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run([sys.executable, "-c", _CHILD], capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    cases: dict[str, list[tuple[float, str]]] = {}
    for line in done.stdout.strip().splitlines():
        case, seconds, kind = line.split("|", 2)
        cases.setdefault(case, []).append((float(seconds), kind))
    return cases


# --------------------------------------------------------------------------- the streamed state's bound


def test_state_cells_is_the_numbers_a_state_holds():
    """The documented formula against the arrays of a reference state whose boundary rows are full."""
    layout = Layout(m=3, p=2, acf_lags=7, xcorr_lags=4, gram=True)
    st = State(layout)
    rng = np.random.default_rng(0)
    st.merge(State.from_block(layout, rng.normal(size=(20, 3)), rng.normal(size=(20, 3)),
                              rng.normal(size=(20, 3, 2))))
    plain = ("k_e", "min_e", "max_e", "exp_e", "k_t", "min_t", "max_t", "exp_t", "k_y", "min_y", "max_y", "exp_y",
             "pairs", "head_e", "tail_e", "tail_y")
    held = sum(np.asarray(getattr(st, name)).size for name in plain)
    held += sum(2 * getattr(st, name).hi.size for name in ("prod_e", "cur_e", "lag_e", "gram", "sum_t", "sq_t", "sq_y",
                                                           "lag_y", "prod_ey"))
    # the formula bounds the boundary rows by L + 1 (Lx + 1) rows; a state holds L (Lx) of them
    assert state_cells(layout) - held == 2 * 3 + 3 * 2  # head_e, tail_e: one row of m; tail_y: one row of mp


def test_reference_state_refuses_a_layout_over_the_bound():
    with pytest.raises(MemoryError, match=r"would hold \d+ numbers .* more than the limit of 134217728"):
        State(Layout(m=6, p=0, acf_lags=30_000_000, xcorr_lags=30_000_000, gram=False))
    State(Layout(m=6, p=0, acf_lags=1000, xcorr_lags=1000, gram=False))  # well below: fine
    assert MAX_STATE_CELLS == 2**27


def test_accumulator_refuses_a_huge_max_lag_before_allocating(backend, limited_child):
    """--stream --max-lag 30000000 on a 500-row file allocated 5.5 GB before refusing; 3 rows of
    524,287 joints 7.4 GB (144 lags per joint whatever the rows)."""
    assert limited_child[f"rows-{backend}"] == [(0.0, "0")]  # the refused chunk left the accumulator unchanged
    for seconds, kind in limited_child[f"max_lag-{backend}"] + limited_child[f"wide-{backend}"]:
        assert kind.startswith("InvalidParameter: max_lag=") and "more than the limit of 134217728" in kind, kind
        assert seconds < 2.0


@needs_cpp
def test_core_state_refuses_a_layout_over_the_bound_before_allocating(limited_child):
    assert len(limited_child["core"]) == 3
    for seconds, kind in limited_child["core"]:
        assert kind.startswith("ValueError: stream_state: the layout") and "more than 134217728 numbers" in kind, kind
        assert seconds < 1.0


# --------------------------------------------------------------------------- lag ranges


def test_lag_ranges_are_checked_by_their_ends(backend, limited_child):
    """ljung_box(e, range(1, 10**8)) took 8.5 s and 3.9 GB before refusing; range(1, 10**12) a MemoryError."""
    assert len(limited_child[f"lags-{backend}"]) == 5
    for seconds, kind in limited_child[f"lags-{backend}"]:
        assert kind.startswith("InvalidParameter: lags must be a positive integer or a non-empty sequence"), kind
        assert seconds < 0.5
    # a valid range is the same lags as its list, in its order
    e = np.random.default_rng(1).normal(size=(200, 2))
    for lags in (range(1, 30), range(20, 0, -3), np.arange(1, 11, dtype=np.uint16)):
        got = dynval.ljung_box(e, lags, backend=backend)
        want = dynval.ljung_box(e, [int(x) for x in lags], backend=backend)
        np.testing.assert_array_equal(got.lags, want.lags)
        np.testing.assert_array_equal(got.statistic, want.statistic)


def test_a_refused_lag_range_allocates_nothing():
    e = np.random.default_rng(0).normal(size=(500, 2))
    tracemalloc.start()
    start = time.perf_counter()
    with pytest.raises(dynval.InvalidParameter, match=r"got range\(1, 2000000\)"):
        dynval.ljung_box(e, range(1, 2_000_000), backend="python")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 1_000_000 and time.perf_counter() - start < 0.5  # a list of its items: 70 MB


# --------------------------------------------------------------------------- StreamState.__setstate__


def _core_state():
    st = _core.StreamState(2, 3, 5, 4, True)
    rng = np.random.default_rng(3)
    st.append(rng.normal(size=(30, 2)), rng.normal(size=(30, 2)), rng.normal(size=(30, 6)))
    return st


def _restore(state):
    fresh = _core.StreamState.__new__(_core.StreamState)
    fresh.__setstate__(state)
    return fresh


ARRAY_NAMES = [f"{name}.{part}" for name in ("prod_e", "cur_e", "lag_e", "gram", "sum_t", "sq_t", "sq_y", "lag_y",
                                             "prod_ey") for part in ("hi", "lo")] + [
    "k_e", "min_e", "max_e", "k_t", "min_t", "max_t", "k_y", "min_y", "max_y", "head_e", "tail_e", "tail_y"]


@needs_cpp
def test_pickled_core_state_round_trips():
    st = _core_state()
    back = pickle.loads(pickle.dumps(st))
    for key, value in st.sums().items():
        np.testing.assert_array_equal(back.sums()[key], value, err_msg=key)
    assert (back.n, back.lengths) == (st.n, st.lengths)


@needs_cpp
@pytest.mark.parametrize("index", range(len(ARRAY_NAMES)), ids=ARRAY_NAMES)
def test_setstate_refuses_an_array_of_another_size(index):
    state = _core_state().__getstate__()
    arrays = list(state[6])
    size = arrays[index].size
    arrays[index] = np.zeros(size + 1)
    name = ARRAY_NAMES[index]
    if name in ("head_e", "tail_e", "tail_y"):
        pattern = rf"^StreamState.__setstate__: {name} must be whole rows of \d+ values, at most \d+ rows"
    else:
        pattern = rf"^StreamState.__setstate__: {name} must be {size} values, got {size + 1} values$"
    with pytest.raises(dynval.InvalidParameter, match=pattern):
        _restore((*state[:6], arrays, *state[7:]))


@needs_cpp
@pytest.mark.parametrize(("item", "value", "message"), [
    (1, -1, r"n must be an integer in \[0, "),
    (2, [10, 10], r"lengths must be segment lengths summing to n=30, got a sum of 20"),
    (2, [], r"lengths must be segment lengths summing to n=30, got a sum of 0"),
    (2, [30, 1], r"a segment length must be an integer in \[1, 0\], got 1"),
    (5, np.zeros(3, dtype=np.int64), r"pairs must be 6 values, got 3 values"),
    (5, np.full(6, 31, dtype=np.int64), r"pairs must be integers in \[0, 30\], got 31"),
    (7, (np.zeros(3, dtype=np.int64), np.zeros(2, dtype=np.int64), np.zeros(6, dtype=np.int64)),
     r"exp_e must be 2 values, got 3 values"),
    (7, (np.zeros(2, dtype=np.int64), np.zeros(2, dtype=np.int64), np.full(6, 5000, dtype=np.int64)),
     r"exp_y must be integers in \[-1073, 1024\], got 5000"),
    (0, (2, 3, 5, 6, True), r"layout xcorr_lags must be an integer in \[0, 5\], got 6"),
    (0, (0, 3, 5, 4, True), r"layout m must be an integer in \[1, "),
])
def test_setstate_refuses_counts_that_do_not_match(item, value, message):
    state = list(_core_state().__getstate__())
    state[item] = value
    with pytest.raises(dynval.InvalidParameter, match="^StreamState.__setstate__: " + message):
        _restore(tuple(state))


@needs_cpp
def test_setstate_refuses_a_tuple_of_another_length_and_a_huge_layout():
    state = _core_state().__getstate__()
    with pytest.raises(dynval.InvalidParameter, match=r"the state must be a tuple of 8 items, got 7 items"):
        _restore(state[:7])
    with pytest.raises(ValueError, match=r"more than 134217728 numbers"):
        _restore(((2, 3, 10**12, 4, True), *state[1:]))


# --------------------------------------------------------------------------- a clock that does not advance


def _frozen_then_running(n_frozen, n_running, m=3, seed=0):
    rng = np.random.default_rng(seed)
    n = n_frozen + n_running
    tau = rng.normal(size=(n, m))
    pred = tau + 0.1 * rng.normal(size=(n, m))
    t = np.r_[np.full(n_frozen, 7.0), 7.0 + np.arange(1, n_running + 1) / 250.0]
    return tau, pred, t


def test_a_frozen_clock_keeps_no_rows(backend):
    # the rows waited, copied, for the first positive step: memory grew with the stream (472 MB for 4e6 rows)
    chunk, chunks = 2000, 60
    tau, pred, _ = _frozen_then_running(chunk, 0)
    acc = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    acc.update(tau, pred, time=np.zeros(chunk))
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for _ in range(chunks):
            acc.update(tau, pred, time=np.zeros(chunk))
        held = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    fed = chunks * 2 * tau.nbytes  # 5.8 MB of torques
    assert held < fed / 10, (held, fed)
    assert acc.n_samples == (chunks + 1) * chunk
    with pytest.raises(dynval.InvalidParameter, match=r"time must advance, got every stamp equal to 0.0"):
        acc.result()


@pytest.mark.parametrize("chunk", [1, 7, 64, 1000])
def test_a_frozen_start_gives_validates_report(chunk, backend):
    tau, pred, t = _frozen_then_running(700, 2300)
    acc = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    for k in range(0, t.size, chunk):
        acc.update(tau[k:k + chunk], pred[k:k + chunk], time=t[k:k + chunk])
    got = acc.result()
    want = dynval.validate(tau, pred, n_params=2, max_lag=5, backend=backend, time=t)
    assert got.timing["duplicated_stamps"] == want.timing["duplicated_stamps"] == 699
    for key in ("sample_rate", "gaps", "irregular_steps", "repeated_rows", "n_steps", "gap_rows", "duration"):
        assert got.timing[key] == want.timing[key], key
    np.testing.assert_allclose(got.autocorrelation["rho"], want.autocorrelation["rho"], rtol=0, atol=1e-14)
    assert got.provenance["segments"] == want.provenance["segments"]


# junctions outside the run of one stamp (one inside it sees the run in part, contract §4.1)
@pytest.mark.parametrize("cuts", [(50,), (50, 560), (30, 60, 900), (60, 700), (10,), (59, 60)])
def test_a_frozen_start_merged_after_a_stream_still_settling(cuts, backend):
    # the later operand's frozen start (more than 100 rows of one stamp) is summed before its grid is
    # known; the earlier one still waits for its first 100 steps (a merge refused it, so dynval.dask
    # failed on such logs)
    rng = np.random.default_rng(4)
    n = 1500
    tau = rng.normal(size=(n, 2))
    pred = tau + 0.1 * rng.normal(size=(n, 2))
    t = np.arange(n) / 250.0
    t[60:560] = t[60]  # 500 rows of one stamp
    parts = []
    for a, b in zip((0, *cuts), (*cuts, n)):
        acc = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
        acc.update(tau[a:b], pred[a:b], time=t[a:b])
        parts.append(acc)
    merged = parts[0]
    for later in parts[1:]:
        merged.merge(later)
    got = merged.result()
    want = dynval.validate(tau, pred, n_params=2, max_lag=5, backend=backend, time=t)
    for key in ("duplicated_stamps", "gaps", "gap_rows", "sample_rate", "irregular_steps", "n_steps"):
        assert got.timing[key] == want.timing[key], key
    np.testing.assert_allclose(got.autocorrelation["rho"], want.autocorrelation["rho"], rtol=0, atol=1e-13)


def test_two_frozen_operands_merge_as_one_frozen_start(backend):
    rng = np.random.default_rng(5)
    tau = rng.normal(size=(700, 2))
    pred = tau + 0.1 * rng.normal(size=(700, 2))
    t = np.r_[np.full(400, 2.0), 2.0 + np.arange(1, 301) / 250.0]
    early = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    early.update(tau[:80], pred[:80], time=t[:80])  # waits: 80 rows, no positive step
    later = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    later.update(tau[80:400], pred[80:400], time=t[80:400])  # 320 rows of one stamp: summed
    rest = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    rest.update(tau[400:], pred[400:], time=t[400:])
    got = early.merge(later).merge(rest).result()
    want = dynval.validate(tau, pred, n_params=2, max_lag=5, backend=backend, time=t)
    assert got.timing["duplicated_stamps"] == want.timing["duplicated_stamps"] == 399
    assert got.timing["sample_rate"] == want.timing["sample_rate"] == 250.0
    np.testing.assert_allclose(got.autocorrelation["rho"], want.autocorrelation["rho"], rtol=0, atol=1e-13)
