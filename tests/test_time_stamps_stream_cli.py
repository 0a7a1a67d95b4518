"""Time stamps through the streaming accumulator, ``compare`` and the command line (``--time``,
``--bandwidth``): the streamed timing summary equals ``dynval.checks._timing.analyse`` on the whole array,
a gap breaks the segment as ``validate`` splits it, and the report equals ``validate(..., time=t)``
wherever the streamed report equals ``validate``'s (contract §4.1, §7).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dynval
from dynval import cli
from dynval.checks import _timing
from dynval.stream import ValidationAccumulator
from test_stream import assert_same_report, cut_points, merge_tree

STEP = 0.005  # 200 Hz
GAP_1, GAP_2 = 400, 1200  # rows that follow a gap (4 and 10 missing samples)
DUPLICATES = (700, 701)  # rows stamped like row 699: the step into row 702 spans three rows
IRREGULAR = 1000  # stamped 30 % of a step late: the steps into and out of it are 30 % off
REPEATS = (900, 1100)  # rows whose torques repeat the row before exactly
# chunk boundaries right before, at and after every event
EVENT_CUTS = (GAP_1 - 1, GAP_1, GAP_1 + 1, 699, 700, 701, 702, 899, 900, 901, IRREGULAR, IRREGULAR + 1,
              1099, 1100, 1101, GAP_2 - 1, GAP_2, GAP_2 + 1)


def stamped_log(n=1500, m=2, seed=0, t0=0.0, jitter=0.03):
    """Torques and stamps on a 200 Hz grid with uniform jitter (±3 % of a step, so no step of the
    grid is irregular), two gaps, a run of duplicated stamps, an irregular stamp and repeated rows
    (the first ``n`` rows of a 1500-row log at least)."""
    full, n = n, max(n, 1500)
    rng = np.random.default_rng(seed)
    t = t0 + STEP * (np.arange(n) + rng.uniform(-jitter, jitter, n))
    t[GAP_1:] += 4 * STEP
    t[GAP_2:] += 10 * STEP
    t[list(DUPLICATES)] = t[DUPLICATES[0] - 1]
    t[IRREGULAR] += 0.3 * STEP
    walk = np.cumsum(rng.normal(size=(n, m)), axis=0) / 10
    tau = 20.0 * np.sin(np.arange(n)[:, None] / 60.0 + np.arange(m)) + walk
    pred = tau - (0.3 * rng.normal(size=(n, m)) + 0.2 * np.cumsum(rng.normal(size=(n, m)), axis=0) / 30)
    for r in REPEATS:
        tau[r] = tau[r - 1]
    return t[:full], tau[:full], pred[:full]


def assert_same_timing(got, want):
    """Counts and rows exactly; the measured steps to 1e-12 of their size."""
    got = got if isinstance(got, dict) else got.to_dict()
    want = want if isinstance(want, dict) else want.to_dict()
    assert set(got) == set(want)
    for key, value in want.items():
        if isinstance(value, float):
            assert math.isclose(got[key], value, rel_tol=1e-12, abs_tol=1e-15), (key, got[key], value)
        else:
            assert got[key] == value, (key, got[key], value)


def feed_stamped(acc, t, tau, pred, cuts, breaks=()):
    bounds = [0, *sorted(set(cuts)), len(t)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        if a in breaks:
            acc.break_segment()
        acc.update(tau[a:b], pred[a:b], time=t[a:b])
    return acc


# --------------------------------------------------------------------------- the accumulator


def test_the_log_has_every_event():
    t, tau, _ = stamped_log()
    want = _timing.analyse(t, None, tau)
    assert want.gap_rows == (GAP_1, GAP_2) and want.duplicated_stamps == 2 and want.irregular_steps == 2
    assert want.repeated_rows == 2 and want.nominal_step == STEP


@pytest.mark.parametrize("sample_rate", [None, 200.0])
def test_chunks_cut_at_every_event_equal_the_whole_array(backend, sample_rate):
    t, tau, pred = stamped_log()
    acc = feed_stamped(ValidationAccumulator(n_params=2, max_lag=12, sample_rate=sample_rate, backend=backend),
                       t, tau, pred, EVENT_CUTS)
    got = acc.result()
    assert_same_timing(got.timing, _timing.analyse(t, sample_rate, tau))
    want = dynval.validate(tau, pred, n_params=2, max_lag=12, time=t, sample_rate=sample_rate, backend="python")
    assert got.provenance["segments"] == want.provenance["segments"] == [400, 800, 300]
    assert got.provenance["sample_rate"] == want.provenance["sample_rate"] == 200.0
    assert got.provenance["conventions"]["time_grid"] == want.provenance["conventions"]["time_grid"]
    assert_same_report(got, want, tau, pred)
    note, = [f for f in got.findings if f.kind == "time_stamps"]
    assert note.message == next(f.message for f in want.findings if f.kind == "time_stamps")
    assert note.severity == "note"


def test_one_row_chunks_and_a_first_chunk_shorter_than_the_nominal_steps(backend):
    """Rows wait (unsummed) until the stamps hold 100 steps; every step, the junctions included,
    is counted once."""
    t, tau, pred = stamped_log(n=1300)
    cuts = sorted({*range(1, 130), GAP_1, *range(695, 705), GAP_2})
    acc = ValidationAccumulator(n_params=2, max_lag=12, backend=backend)
    bounds = [0, *cuts, len(t)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        acc.update(tau[a:b], pred[a:b], time=t[a:b])
        assert acc.n_samples == b
    assert_same_timing(acc.result().timing, _timing.analyse(t, None, tau))
    assert acc.result().provenance["segments"] == [400, 800, 100]


def test_a_result_before_the_nominal_step_is_known_changes_nothing(backend):
    t, tau, pred = stamped_log()
    early = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    early.update(tau[:50], pred[:50], time=t[:50])
    assert_same_timing(early.result().timing, _timing.analyse(t[:50], None, tau[:50]))
    early.update(tau[50:], pred[50:], time=t[50:])
    whole = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    whole.update(tau, pred, time=t)
    assert early.result().timing == whole.result().timing
    assert early.result().provenance["segments"] == whole.result().provenance["segments"]


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_random_chunkings_equal_validate(backend, data):
    t, tau, pred = stamped_log(n=1300, seed=data.draw(st.integers(0, 2**16)), t0=data.draw(st.sampled_from(
        [0.0, 12.5, 1.7e9])))
    cuts = cut_points(data.draw, len(t), most=20) + data.draw(st.lists(st.sampled_from(EVENT_CUTS), max_size=6))
    rate = data.draw(st.sampled_from([None, 200.0]))
    acc = feed_stamped(ValidationAccumulator(n_params=3, max_lag=10, sample_rate=rate, backend=backend),
                       t, tau, pred, cuts)
    got = acc.result()
    assert_same_timing(got.timing, _timing.analyse(t, rate, tau))
    assert_same_report(got, dynval.validate(tau, pred, n_params=3, max_lag=10, time=t, sample_rate=rate,
                                            backend="python"), tau, pred)


@settings(max_examples=30, deadline=None)
@given(st.data())
def test_merge_trees_equal_the_whole_array(backend, data):
    """The other's stamps continue after this one's: the step across each junction counts (a gap
    there breaks the segment), whichever accumulators still wait for their nominal step."""
    t, tau, pred = stamped_log(n=1300)
    # junctions anywhere but inside the run of duplicated stamps (contract §4.1)
    allowed = [c for c in range(1, len(t)) if c not in DUPLICATES]
    junctions = sorted(data.draw(st.sets(st.sampled_from(allowed + list(EVENT_CUTS[:3]) + [GAP_2]),
                                         min_size=1, max_size=5)) - set(DUPLICATES))
    rate = data.draw(st.sampled_from([None, 200.0]))
    if rate is None:  # without a rate, the pieces settle on their own first 100 steps: make them agree
        junctions = [j for j in junctions if j >= 101 and len(t) - j >= 101] or [GAP_1]
    bounds = [0, *junctions, len(t)]
    pieces = [feed_stamped(ValidationAccumulator(n_params=2, max_lag=8, sample_rate=rate, backend=backend),
                           t[a:b], tau[a:b], pred[a:b], cut_points(data.draw, b - a, most=3))
              for a, b in zip(bounds[:-1], bounds[1:])]
    got = merge_tree(pieces, data).result()
    assert_same_timing(got.timing, _timing.analyse(t, rate, tau))
    want = dynval.validate(tau, pred, n_params=2, max_lag=8, time=t, sample_rate=rate, backend="python")
    assert_same_report(got, want, tau, pred)


def test_merges_of_waiting_accumulators(backend):
    """Pieces shorter than 100 steps queue their rows; the merged stream settles on the first steps."""
    t, tau, pred = stamped_log(n=1300)
    bounds = [0, 30, 60, 90, 130, GAP_1, 1000, 1300]
    pieces = [feed_stamped(ValidationAccumulator(n_params=2, max_lag=8, backend=backend), t[a:b], tau[a:b],
                           pred[a:b], []) for a, b in zip(bounds[:-1], bounds[1:])]
    left = pieces[0].copy()
    for piece in pieces[1:]:
        left.merge(piece)
    assert_same_timing(left.result().timing, _timing.analyse(t, None, tau))
    assert left.result().provenance["segments"] == [400, 800, 100]
    assert pieces[1].n_samples == 30  # merge leaves its argument as it was
    right = pieces[-1].copy()
    for piece in reversed(pieces[:-1]):
        right = piece.copy().merge(right)
    assert_same_timing(right.result().timing, left.result().timing)
    empty = ValidationAccumulator(n_params=2, max_lag=8, backend=backend)
    empty.break_segment()
    empty.update(np.zeros((0, 2)), np.zeros((0, 2)), time=np.zeros(0))  # timed, without a row
    for other in (left, pieces[0]):
        merged = empty.copy().merge(other)
        assert_same_timing(merged.result().timing, other.result().timing)
        assert merged.result().provenance["segments"] == other.result().provenance["segments"]


def test_a_clock_that_changes_rate_after_the_first_steps(backend):
    """The first chunk's nominal step (200 Hz) classifies the steps; the jitter, the largest
    deviation and the rate are those of the whole run (199.05 Hz), as ``_timing`` measures them."""
    n = 3000
    t = np.r_[0.0, np.cumsum(np.r_[np.full(150, 0.005), np.full(n - 151, 1 / 199.0)])]
    tau = np.sin(np.arange(n) / 30.0)[:, None]
    acc = feed_stamped(ValidationAccumulator(n_params=1, max_lag=3, backend=backend), t, tau,
                       tau + 0.01 * np.cos(np.arange(n) * 1.3)[:, None], range(150, n, 150))
    got = acc.result().timing
    assert_same_timing(got, _timing.analyse(t, None, tau))
    assert got["sample_rate"] == 199.0498 and got["jitter_rms"] > 5e-6


def test_the_first_100_steps_set_the_nominal_step(backend):
    """A first chunk of 20 steps at 190 Hz does not decide the nominal step alone: the rows wait
    for 100 steps, whose nominal step (198.3 Hz) finds the 12 % long and short steps irregular, as
    the whole run's (199.7 Hz) does."""
    steps = np.r_[np.full(20, 1 / 190), np.full(100, 0.005), np.tile([0.0056, 0.005, 0.005, 0.0044], 50),
                  np.full(300, 0.005)]
    t = np.r_[0.0, np.cumsum(steps)]
    tau = np.sin(np.arange(t.size) / 30.0)[:, None]
    acc = feed_stamped(ValidationAccumulator(n_params=1, max_lag=3, backend=backend), t, tau,
                       tau + 0.01 * np.cos(np.arange(t.size) * 1.3)[:, None], [20])
    want = _timing.analyse(t, None, tau)
    assert want.irregular_steps == 100
    assert_same_timing(acc.result().timing, want)


def test_a_merged_piece_of_duplicated_stamps_only(backend):
    """A piece whose rows all repeat the stamp before it, merged after the rows before it, continues
    their run of duplicates: the step after the run spans every row of it (here three), no gap."""
    t, tau, pred = stamped_log(n=1300)
    rate = 200.0
    bounds = [0, DUPLICATES[0], DUPLICATES[-1] + 1, len(t)]  # the middle piece: rows 700 and 701 only
    pieces = [feed_stamped(ValidationAccumulator(n_params=2, max_lag=8, sample_rate=rate, backend=backend),
                           t[a:b], tau[a:b], pred[a:b], []) for a, b in zip(bounds[:-1], bounds[1:])]
    got = pieces[0].copy().merge(pieces[1]).merge(pieces[2]).result()
    assert_same_timing(got.timing, _timing.analyse(t, rate, tau))
    assert got.provenance["segments"] == [400, 800, 100]


def test_breaks_while_waiting_keep_their_place(backend):
    t, tau, pred = stamped_log(n=600)
    acc = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    acc.break_segment()
    feed_stamped(acc, t, tau, pred, [20, 40, 60], breaks=(40,))
    want = dynval.validate(tau, pred, n_params=2, max_lag=5, time=t, segments=[0, 40], backend="python")
    assert acc.result().provenance["segments"] == want.provenance["segments"] == [40, 360, 200]
    assert_same_report(acc.result(), want, tau, pred)
    # two waiting pieces, the second started with a break: the break stays at the junction
    first = feed_stamped(ValidationAccumulator(n_params=2, max_lag=5, backend=backend), t[:30], tau[:30],
                         pred[:30], [10])
    second = ValidationAccumulator(n_params=2, max_lag=5, backend=backend)
    second.break_segment()
    feed_stamped(second, t[30:90], tau[30:90], pred[30:90], [20, 40])
    third = feed_stamped(ValidationAccumulator(n_params=2, max_lag=5, backend=backend), t[90:], tau[90:],
                         pred[90:], [])
    assert first.merge(second).merge(third).result().provenance["segments"] == [30, 370, 200]


def test_omitted_rows_leave_their_stamps_out(backend):
    t, tau, pred = stamped_log(n=800)
    tau, pred = tau.copy(), pred.copy()
    tau[[5, 150, 397, 401, 650], 0] = np.nan  # 397: a row omitted before the gap in its chunk
    acc = feed_stamped(ValidationAccumulator(n_params=2, max_lag=6, nan_policy="omit", backend=backend),
                       t, tau, pred, [150, 395, 402])
    want = dynval.validate(tau, pred, n_params=2, max_lag=6, time=t, nan_policy="omit", backend="python")
    got = acc.result()
    assert_same_timing(got.timing, want.timing)
    assert got.provenance["segments"] == want.provenance["segments"]
    keep = np.isfinite(tau).all(axis=1)
    assert_same_report(got, want, tau[keep], pred[keep])


def test_a_regular_grid_gives_no_note(backend):
    t = np.arange(1000) / 250.0
    tau = np.sin(np.arange(1000.0))[:, None] * [1.0, 2.0]
    acc = ValidationAccumulator(n_params=1, max_lag=4, backend=backend)
    feed_stamped(acc, t, tau, tau + 0.01 * np.cos(np.arange(1000.0) * 1.7)[:, None], [333, 666])
    report = acc.result()
    assert report.timing["regular"] and report.timing["sample_rate"] == 250.0
    assert "time_stamps" not in {f.kind for f in report.findings}
    assert report.provenance["conventions"]["max_lag_seconds"] == 4 / 250.0


# --------------------------------------------------------------------------- errors


def test_time_on_every_chunk_once_given(backend):
    t, tau, pred = stamped_log(n=300)
    acc = ValidationAccumulator(n_params=1, max_lag=2, backend=backend)
    acc.update(tau[:100], pred[:100], time=t[:100])
    with pytest.raises(dynval.InvalidParameter) as info:
        acc.update(tau[100:200], pred[100:200])
    assert str(info.value) == ("chunk 1: time must be given with every chunk or with none; the chunks before it "
                               "had time stamps")
    assert acc.n_samples == 100
    acc = ValidationAccumulator(n_params=1, max_lag=2, backend=backend)
    acc.update(tau[:100], pred[:100])
    with pytest.raises(dynval.InvalidParameter) as info:
        acc.update(tau[100:200], pred[100:200], time=t[100:200])
    assert str(info.value) == ("chunk 1: time must be given with every chunk or with none; the chunks before it "
                               "had none")
    assert acc.n_samples == 100 and acc.result().timing is None


def test_decreasing_stamps_name_the_row(backend):
    t, tau, pred = stamped_log(n=300)
    acc = ValidationAccumulator(n_params=1, max_lag=2, sample_rate=200.0, backend=backend)
    acc.update(tau[:100], pred[:100], time=t[:100])
    with pytest.raises(dynval.InvalidParameter) as info:  # across the chunks
        acc.update(tau[100:200], pred[100:200], time=t[100:200] - 0.5)
    assert str(info.value) == (f"chunk 1: time must never decrease, got {float(t[100] - 0.5)!r} at row 0 after "
                               f"{float(t[99])!r}, the last stamp before this chunk (row 100 of the stream)")
    back = t[100:200].copy()
    back[7] = back[5]
    with pytest.raises(dynval.InvalidParameter) as info:  # within the chunk
        acc.update(tau[100:200], pred[100:200], time=back)
    assert str(info.value) == (f"chunk 1: time must never decrease, got {float(back[7])!r} at row 7 after "
                               f"{float(back[6])!r} at row 6 (row 107 of the stream)")
    assert acc.n_samples == 100  # rejected chunks leave the accumulator as it was
    acc.update(tau[100:], pred[100:], time=t[100:])  # a duplicate across the boundary is fine
    later = ValidationAccumulator(n_params=1, max_lag=2, sample_rate=200.0, backend=backend)
    later.update(tau[:50], pred[:50], time=t[:50])
    with pytest.raises(dynval.InvalidParameter, match=r"^other's time stamps must continue after this one's, got "
                                                      r"its first stamp .* before this one's last stamp "):
        acc.merge(later)
    untimed = ValidationAccumulator(n_params=1, max_lag=2, sample_rate=200.0, backend=backend)
    untimed.update(tau[:50], pred[:50])
    with pytest.raises(dynval.InvalidParameter, match=r"^other must be updated with time stamps like this one, "
                                                      r"got other updated without time stamps$"):
        acc.merge(untimed)


@pytest.mark.parametrize(("stamps", "kind", "message"), [
    (np.zeros(7), dynval.ShapeMismatch, "chunk 0: time must have one stamp per sample, shape (5,), got (7,)"),
    (np.array([0.0, 1.0, np.nan, 3.0, 4.0]), dynval.NonFiniteInput,
     "chunk 0: time must be finite seconds, got nan at row 2 (row 2 of the stream)"),
    (["a"] * 5, dynval.InvalidType, "chunk 0: time must be an array of real numbers, got <U1"),
])
def test_bad_stamps(stamps, kind, message):
    acc = ValidationAccumulator(n_params=1, max_lag=1)
    with pytest.raises(kind) as info:
        acc.update(np.zeros(5), np.ones(5), time=stamps)
    assert str(info.value) == message
    assert acc.n_samples == 0


def test_stamps_that_never_advance_and_a_disagreeing_rate(backend):
    acc = ValidationAccumulator(n_params=1, max_lag=1, backend=backend)
    acc.update(np.arange(5.0), np.arange(5.0) + 0.1, time=np.full(5, 3.0))
    with pytest.raises(dynval.InvalidParameter, match=r"^time must advance, got every stamp equal to 3.0$"):
        acc.result()
    t, tau, pred = stamped_log(n=500)
    acc = ValidationAccumulator(n_params=1, max_lag=1, sample_rate=150.0, backend=backend)
    acc.update(tau[:60], pred[:60], time=t[:60])  # fewer than 100 steps: not yet checked
    with pytest.raises(dynval.InvalidParameter) as info:  # checked by the update that sets the grid
        acc.update(tau[60:], pred[60:], time=t[60:])
    with pytest.raises(dynval.InvalidParameter) as whole:
        dynval.validate(tau, pred, n_params=1, max_lag=1, sample_rate=150.0, time=t)
    assert str(info.value) == "chunk 1: " + str(whole.value)
    assert acc.n_samples == 60  # the refused chunk is not taken, and is refused again
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 1: sample_rate=150 Hz disagrees"):
        acc.update(tau[60:], pred[60:], time=t[60:])


def test_bandwidth_needs_a_rate_and_turns_whiteness_above_it_into_a_note(backend):
    with pytest.raises(dynval.InvalidParameter, match=r"^bandwidth must be None or a finite number > 0 \(Hz\)"):
        ValidationAccumulator(n_params=1, bandwidth=-1.0)
    acc = ValidationAccumulator(n_params=1, max_lag=3, bandwidth=5.0, backend=backend)
    with pytest.raises(dynval.InvalidParameter) as info:
        acc.update(np.zeros(5), np.ones(5))
    assert str(info.value) == ("chunk 0: bandwidth must be None without sample_rate or time (it is in Hz), "
                               "got 5.0")
    rng = np.random.default_rng(2)
    n = 4000
    tau = 5.0 * np.sin(np.arange(n) / 80.0)[:, None] + rng.normal(size=(n, 1))
    e = np.convolve(rng.normal(size=n + 3), [1.0, -0.9, 0.5, 0.3], "valid")[:n, None]  # coloured: not white
    t = np.arange(n) / 100.0
    reports = {}
    for bandwidth in (None, 10.0):
        acc = ValidationAccumulator(n_params=1, max_lag=20, bandwidth=bandwidth, backend=backend)
        feed_stamped(acc, t, tau, tau - e, [1000, 2000])
        reports[bandwidth] = acc.result()
    assert "whiteness" in {f.kind for f in reports[None].findings}
    kinds = {f.kind for f in reports[10.0].findings}
    assert "processing_band" in kinds and "whiteness" not in kinds
    assert reports[10.0].whiteness["above_bandwidth"] and reports[10.0].provenance["conventions"]["bandwidth"] == 10.0
    with pytest.raises(dynval.InvalidParameter, match=r"same settings, got bandwidth=None where this one has "
                                                      r"bandwidth=10\.0"):
        ValidationAccumulator(n_params=1, max_lag=20, bandwidth=10.0).merge(ValidationAccumulator(n_params=1,
                                                                                               max_lag=20))


def test_the_accumulator_pickles_while_waiting(backend):
    import pickle

    t, tau, pred = stamped_log(n=600)
    acc = ValidationAccumulator(n_params=1, max_lag=3, backend=backend)
    acc.update(tau[:40], pred[:40], time=t[:40])
    acc = pickle.loads(pickle.dumps(acc))
    acc.update(tau[40:], pred[40:], time=t[40:])
    assert_same_timing(acc.result().timing, _timing.analyse(t, None, tau))


# --------------------------------------------------------------------------- compare


def test_compare_takes_time_and_gives_each_report_the_timing():
    t, tau, pred = stamped_log()
    other = pred + 0.5 * np.sin(np.arange(len(t)) / 7.0)[:, None]
    cmp = dynval.compare(tau, {"a": (pred, 4), "b": (other, 6)}, time=t, max_lag=10)
    for name, prediction, p in (("a", pred, 4), ("b", other, 6)):
        report = cmp.reports[name]
        want = dynval.validate(tau, prediction, n_params=p, time=t, max_lag=10)
        assert report.timing == want.timing
        assert report.provenance["segments"] == want.provenance["segments"] == [400, 800, 300]
        assert "time_stamps" in {f.kind for f in report.findings}
    with pytest.raises(dynval.InvalidParameter, match=r"^time must never decrease"):
        dynval.compare(tau, {"a": (pred, 4)}, time=t[::-1], max_lag=10)


# --------------------------------------------------------------------------- command line


@pytest.fixture
def log_files(tmp_path):
    t, tau, pred = stamped_log()
    np.save(tmp_path / "tau.npy", tau)
    np.save(tmp_path / "pred.npy", pred)
    np.save(tmp_path / "t.npy", t)
    np.savetxt(tmp_path / "log.csv", np.column_stack([tau[:, 0], t, tau[:, 1]]), delimiter=",",
               header="tau1,stamp,tau2", comments="", fmt="%.17g")
    np.savetxt(tmp_path / "bare.csv", np.column_stack([t, t]), delimiter=",", fmt="%.17g")
    np.savez(tmp_path / "log.npz", t=t, both=np.column_stack([t, t]))
    np.save(tmp_path / "cols.npy", np.column_stack([tau[:, 0], t]))
    return tmp_path, t, tau, pred


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("spec", ["t.npy", "log.csv:stamp", "log.csv:1", "log.npz:t", "log.npz:both:0",
                                  "bare.csv:1", "cols.npy:1"])
def test_cli_time_from_a_file_or_a_column(log_files, capsys, spec):
    d, t, tau, pred = log_files
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--max-lag", 10,
                         "--time", f"{d / spec}", "--json")
    assert code == 0 and err == ""
    report = json.loads(out)
    want = dynval.validate(tau, pred, n_params=2, max_lag=10, time=t)
    assert report["timing"] == json.loads(want.to_json())["timing"]
    assert report["provenance"]["segments"] == [400, 800, 300]


def test_cli_streamed_time_equals_the_in_memory_one(log_files, capsys):
    d, t, tau, _ = log_files
    common = ["validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--max-lag", 10, "--json"]
    code, out, err = run(capsys, *common, "--time", d / "t.npy")
    assert code == 0, err
    whole = json.loads(out)
    for spec in ("t.npy", "log.csv:stamp", "cols.npy:1", "log.npz:both:1"):
        code, out, err = run(capsys, *common, "--time", d / spec, "--stream", "--chunk-rows", 350)
        assert code == 0, err
        streamed = json.loads(out)
        assert_same_timing(streamed["timing"], whole["timing"])
        assert_same_timing(streamed["timing"], _timing.analyse(t, None, tau))
        assert streamed["provenance"]["segments"] == whole["provenance"]["segments"] == [400, 800, 300]
        assert streamed["provenance"]["streaming"]


def test_cli_bandwidth(log_files, capsys):
    d, *_ = log_files
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--max-lag", 10,
                         "--time", d / "t.npy", "--bandwidth", 20, "--json")
    assert code == 0, err
    assert json.loads(out)["provenance"]["conventions"]["bandwidth"] == 20.0
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--max-lag", 10,
                         "--time", d / "t.npy", "--bandwidth", 20, "--stream", "--json")
    assert code == 0, err
    assert json.loads(out)["provenance"]["conventions"]["bandwidth"] == 20.0
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--bandwidth", 20)
    assert code == 2 and "--bandwidth needs --sample-rate or --time: it is in Hz" in err
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--sample-rate", 200,
                         "--bandwidth", -3)
    assert code == 1 and "InvalidParameter: bandwidth must be None or a finite number > 0 (Hz), got -3.0" in err


@pytest.mark.parametrize(("spec", "message"), [
    ("log.csv:stamps", "log.csv: no column named 'stamps'; the file holds 'tau1', 'stamp', 'tau2'"),
    ("log.csv:3", "log.csv: no column 3; it holds 3 columns (indices count from 0: 0 to 2)"),
    ("log.csv", "log.csv: holds 3 columns (shape (1500, 3)); name one as {d}/log.csv:COLUMN (a header name, or an "
                "index counted from 0)"),
    ("bare.csv:stamp", "bare.csv: no column named 'stamp': its columns have no names (a CSV header line names "
                       "them); give an index from 0 to 1"),
    ("missing.csv:t", "missing.csv: no such file"),
])
@pytest.mark.parametrize("stream", [False, True])
def test_cli_bad_time_column_is_an_input_error(log_files, capsys, spec, message, stream):
    d, *_ = log_files
    code, out, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--time", d / spec,
                         *(["--stream"] if stream else []))
    assert code == 1 and out == ""
    assert err == f"dynval validate: error: {d}/{message.format(d=d)}\n"


def test_cli_time_errors_name_the_file_and_line(log_files, capsys):
    d, t, tau, _ = log_files
    bad = t.copy()
    bad[700] = bad[699] - 1.0
    np.savetxt(d / "bad.csv", np.column_stack([tau[:, 0], bad]), delimiter=";", header="x;when", comments="",
               fmt="%.17g")
    code, _, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--time",
                       f"{d / 'bad.csv'}:when")
    assert code == 1
    assert err.startswith("dynval validate: error: InvalidParameter: time must never decrease, got ")
    assert err.endswith(f"at row 700 after {float(bad[699])!r} at row 699 "
                        f"(rows and columns from 0; {d / 'bad.csv'} line 702, column 2)\n")
    code, _, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--time",
                       f"{d / 'bad.csv'}:when", "--stream", "--chunk-rows", 500)
    assert code == 1 and err.startswith("dynval validate: error: InvalidParameter: chunk 1: time must never decrease")
    assert err.endswith(f"(row 700 of the stream) (time from {d / 'bad.csv'}:when)\n")
    np.save(d / "short.npy", t[:-1])
    for extra in ([], ["--stream"]):
        code, _, err = run(capsys, "validate", d / "tau.npy", d / "pred.npy", "--n-params", 2, "--time",
                           d / "short.npy", *extra)
        assert code == 1
        assert err == ("dynval validate: error: ShapeMismatch: time must have one stamp per sample, shape (1500,), "
                       f"got (1499,) (time from {d / 'short.npy'})\n")


def test_cli_compare_with_time(log_files, capsys):
    d, t, tau, pred = log_files
    code, out, err = run(capsys, "compare", d / "tau.npy", "--model", f"a={d / 'pred.npy'}:3", "--max-lag", 10,
                         "--time", f"{d / 'log.csv'}:stamp", "--json")
    assert code == 0, err
    report = json.loads(out)["reports"]["a"]
    assert report["timing"] == json.loads(dynval.validate(tau, pred, n_params=3, max_lag=10, time=t).to_json())[
        "timing"]
    code, out, err = run(capsys, "compare", d / "tau.npy", "--model", f"a={d / 'pred.npy'}:3", "--time",
                         f"{d / 'log.csv'}:nope")
    assert code == 1 and "log.csv: no column named 'nope'" in err


def test_cli_help_names_the_options(capsys):
    for command in ("validate", "compare"):
        assert cli.main([command, "--help"]) == 0
        out = capsys.readouterr().out
        assert "--time FILE[:COLUMN]" in out and "--bandwidth HZ" in out
