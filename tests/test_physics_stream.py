"""The physics test from chunks (dynval.statistics._physics_stream) against the in-memory test.

A stream sums each joint's raw and whitened stacks chunk by chunk and fixes on its first block the
prewhitening filter, the Coulomb shapes' velocity scale and N_eff/N (docs/conventions.md §5.2, "On a
stream"). When the first block is the whole log the stream's test is the in-memory one, to rounding:
the same groups, selection, degrees of freedom, filter order and term, statistics and p-values within
1e-6, shares and N_eff within 1e-7. With a shorter first block (and, past MEAT_ROWS rows, the meat of
the residual under the first block's fit), the same terms and decisions, F within 10 %. On a
1 kHz log of 100,000 rows (validate decimates it, the stream does not), the same missing physics.

Mutations caught: a chunk's whitening without the rows before it, Savitzky–Golay derivatives cut at
a chunk's edge, the drift's map from the row index, the model columns' unit norm, the R update's
formula, derived q̇ of a joint at rest left as rounding noise, a meat weighted by another residual.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dynval import scenarios
from dynval.statistics import _physics, _physics_stream
from dynval.statistics._columns import unit_norm_columns

EXACT_RTOL = 1e-6  # F and p (measured at most 2e-8)
SHARE_RTOL = 1e-7


def _case(key):
    s = next(x for x in scenarios.library() if x.key == key)
    rep = scenarios.simulate(s, 0)
    val = rep.validation
    cols = list(rep.model_columns)
    pi, _ = scenarios.fit(rep)
    reg = val.regressor[:, :, cols]
    pred = reg @ pi
    return s.sample_rate, val.tau - pred, pred, val.q, reg


def _in_memory(e, pred, q, reg, fs):
    d = _physics.derivatives(q, fs)
    nuisance = None if reg is None else [unit_norm_columns(reg[:, j, :]) for j in range(e.shape[1])]
    return _physics.physics_test(e, pred, q, d.dq, d.ddq, sample_rate=fs, nuisance=nuisance), d


def _streamed(e, q, reg, fs, chunk, given=None, **kw):
    acc = _physics_stream.PhysicsSums(e.shape[1], sample_rate=fs, **kw)
    for k in range(0, e.shape[0], chunk):
        sl = slice(k, k + chunk)
        dq, ddq = (None, None) if given is None else (given.dq[sl], given.ddq[sl])
        acc.update(e[sl], q[sl], dq, ddq, None if reg is None else reg[sl])
    return acc.tests(), acc


def _close(a, b, rtol, what):
    assert math.isclose(a, b, rel_tol=rtol, abs_tol=1e-300), f"{what}: {a} streamed, {b} in memory"


@pytest.mark.parametrize("key,chunk", [("no_coulomb:white:anthro3@500", 997), ("no_coulomb:ar0.9:planar2@100", 3)])
@pytest.mark.parametrize("regressor", [False, True])
@pytest.mark.parametrize("derivatives", ["given", "derived"])
def test_a_stream_whose_first_block_is_the_whole_log_is_the_in_memory_test(key, chunk, regressor, derivatives):
    fs, e, pred, q, reg = _case(key)
    reg = reg if regressor else None
    want, d = _in_memory(e, pred, q, reg, fs)
    got, _ = _streamed(e, q, reg, fs, chunk, d if derivatives == "given" else None)
    for a, b in zip(got, want):
        where = f"joint {b.joint}"
        assert (a.selected, a.term, a.df, a.ar_order) == (b.selected, b.term, b.df, b.ar_order), where
        _close(a.statistic, b.statistic, EXACT_RTOL, f"{where} F")
        if b.pvalue > 1e-12:
            _close(a.pvalue, b.pvalue, EXACT_RTOL, f"{where} p")
        for x, y, what in [(a.share, b.share, "share"), (a.term_share, b.term_share, "term share"),
                           (a.selected_share, b.selected_share, "selected share"), (a.n_eff, b.n_eff, "N_eff")]:
            _close(x, y, SHARE_RTOL, f"{where} {what}")
        assert set(a.shares) == set(b.shares), where
        for g in b.shares:
            _close(a.shares[g], b.shares[g], SHARE_RTOL, f"{where} share of {g}")


def test_a_joint_at_rest_has_no_derived_velocity_on_a_stream_either():
    fs, e, pred, q, _ = _case("no_coulomb:white:anthro3@500")
    q = q.copy()
    q[:, 1] = 0.3  # at rest over the whole log: the in-memory derivatives are exactly zero
    want, _ = _in_memory(e, pred, q, None, fs)
    got, acc = _streamed(e, q, None, fs, 1000)
    assert "joint 2 at rest" in acc.derivative_method()[0]
    for a, b in zip(got, want):
        # the resting joint's posture columns are constants, as the offset is: groups that tie enter
        # in an order rounding decides
        assert (sorted(a.selected), a.term, a.df) == (sorted(b.selected), b.term, b.df), f"joint {b.joint}"
        _close(a.statistic, b.statistic, EXACT_RTOL, f"joint {b.joint} F")


@pytest.mark.parametrize("key", ["right:jitter:arm4@500", "no_coulomb:white:anthro3@500"])
@pytest.mark.parametrize("regressor", [False, True])
def test_a_first_block_shorter_than_the_log_names_the_same_terms(key, regressor):
    # a third of the log fixes the filter and the velocity scale, and past a quarter of it the meat
    # weighs the residual of the first block's fit (conventions §5.2, "On a stream")
    fs, e, pred, q, reg = _case(key)
    reg = reg if regressor else None
    want, d = _in_memory(e, pred, q, reg, fs)
    n = e.shape[0]
    got, acc = _streamed(e, q, reg, fs, 1000, d, first_block=n // 3, meat_rows=n // 4)
    assert all(not js.kept for js in acc._joints)  # the meat came from the weighted sums
    for a, b in zip(got, want):
        where = f"joint {b.joint}"
        assert a.term == b.term and a.df == b.df, where
        assert (a.pvalue <= 0.01) == (b.pvalue <= 0.01), where
        _close(a.statistic, b.statistic, 0.1, f"{where} F")
        _close(a.share, b.share, 1e-4, f"{where} share")


def test_what_a_stream_keeps_does_not_grow_with_the_log():
    fs, e, _, q, _ = _case("no_coulomb:ar0.9:planar2@100")
    reps = 5
    e, q = np.tile(e, (reps, 1)), np.tile(q, (reps, 1))  # a log five times as long (q jumps back: fine)
    _, acc = _streamed(e, q, None, fs, 2000, first_block=2000, meat_rows=3000)
    for js in acc._joints:
        width = 1 + sum(js.widths.values())
        assert js.r_raw.shape == js.r_w.shape == js.omega.shape == (width, width)
        assert js.kept == [] and js.n_w == e.shape[0] - js.a.size
    diff = acc._diff
    assert sum(p["q"].shape[0] for p in diff.pending) <= diff.length and diff.context.shape[0] <= diff.length


# --------------------------------------------------------------------------- the accumulator

def _physics_of(report):
    return report.to_dict()["physics"]["tests"]


@pytest.mark.parametrize("timed", [False, True])
def test_the_accumulator_given_q_reports_validates_physics_test(timed):
    # with time stamps and no sample_rate the derivatives take the stamps' rate, as validate does
    import dynval
    from dynval.stream import ValidationAccumulator

    fs, e, pred, q, _ = _case("no_coulomb:white:anthro3@500")
    tau = e + pred
    t = np.arange(e.shape[0]) / fs
    rate = {"time": t} if timed else {"sample_rate": fs}
    # decimate=None: validate's physics test at the logged rate, as a stream's (with "auto" it runs
    # on the log decimated towards the information band: conventions §5.2)
    want = dynval.validate(tau, pred, n_params=5, q=q, max_lag=20, decimate=None, **rate)
    acc = ValidationAccumulator(n_params=5, max_lag=20, **({} if timed else rate))
    for k in range(0, e.shape[0], 1500):
        acc.update(tau[k:k + 1500], pred[k:k + 1500], q=q[k:k + 1500], **({"time": t[k:k + 1500]} if timed else {}))
    got = acc.result()
    for a, b in zip(_physics_of(got), _physics_of(want)):
        assert (a["term"], a["selected"], a["df"]) == (b["term"], b["selected"], b["df"])
        _close(a["statistic"], b["statistic"], EXACT_RTOL, "F")
        assert a["refit_run"] == "stream"
    kinds = {(f.kind, f.joints) for f in got.findings if f.kind == "missing_physics"}
    assert kinds == {(f.kind, f.joints) for f in want.findings if f.kind == "missing_physics"} and kinds
    assert "missing_physics" not in [x["test"] for x in got.provenance["not_tested"]]
    assert "filter" in got.provenance["conventions"]["physics_stream"] and "first 40000 rows" in \
        got.provenance["conventions"]["physics_stream"]
    assert got.design["noise_n_eff"] == pytest.approx(want.design["noise_n_eff"], rel=SHARE_RTOL)


def test_the_accumulator_refuses_q_given_unlike_before_and_merging():
    import dynval
    from dynval.stream import ValidationAccumulator

    rng = np.random.default_rng(0)
    x = rng.normal(size=(100, 2))
    acc = ValidationAccumulator(n_params=1, max_lag=3, sample_rate=100.0)
    acc.update(x, x + 0.1, q=x)
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 1: q must be given with every chunk or with none; "
                                                      r"the chunks before it had it$"):
        acc.update(x, x + 0.1)
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 1: dq must be given with every chunk or with none"):
        acc.update(x, x + 0.1, q=x, dq=x)
    with pytest.raises(dynval.ShapeMismatch, match=r"^chunk 1: tau_meas and q must have the same shape"):
        acc.update(x, x + 0.1, q=x[:, :1])
    assert acc.n_samples == 100  # the refused chunks were not taken
    plain = ValidationAccumulator(n_params=1, max_lag=3, sample_rate=100.0)
    plain.update(x, x + 0.1)
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 1: q must be given with every chunk or with none; "
                                                      r"the chunks before it had none$"):
        plain.update(x, x + 0.1, q=x)
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 0: dq must be None without q"):
        ValidationAccumulator(n_params=1).update(x, x, dq=x)
    with pytest.raises(dynval.InvalidParameter, match=r"^chunk 0: sample_rate must be given \(or time stamps"):
        ValidationAccumulator(n_params=1).update(x, x, q=x)
    with pytest.raises(dynval.InvalidParameter, match=r"^other cannot be merged: an accumulator updated with q"):
        plain.merge(acc)


@pytest.mark.slow
def test_a_long_1khz_stream_names_the_missing_physics_that_validate_names():
    # 100,000 rows at 1 kHz: validate tests the log decimated towards its band (past 40,000 rows it
    # must decimate), a stream every row with the filter of its first block (conventions §5.2). The
    # missing terms are known by construction: viscous and Coulomb friction on every joint.
    import dynval
    from dynval.stream import ValidationAccumulator

    fs, n, m = 1000.0, 100_000, 7
    rng = np.random.default_rng(38)
    t = np.arange(n) / fs
    w = 2 * np.pi * 0.1 * np.arange(1, 6)
    amp, ph = rng.uniform(0.05, 0.25, (5, m)), rng.uniform(0, 2 * np.pi, (5, m))
    arg = t[:, None, None] * w[None, :, None] + ph
    q = np.sum(amp * np.sin(arg), axis=1)
    dq = np.sum(amp * w[:, None] * np.cos(arg), axis=1)
    ddq = -np.sum(amp * (w ** 2)[:, None] * np.sin(arg), axis=1)
    pred = 20.0 * np.sin(q + 0.3) + 2.0 * ddq + np.cumsum(np.sin(q), axis=1)
    rms = np.sqrt(np.mean(pred ** 2, axis=0))
    tau = pred + 0.03 * rms * (dq / np.std(dq, axis=0) + np.sign(dq)) + rng.normal(0.0, 0.02, (n, m)) * rms
    want = dynval.validate(tau, pred, n_params=0, q=q, time=t)
    acc = ValidationAccumulator(n_params=0)
    for k in range(0, n, 10_000):
        acc.update(tau[k:k + 10_000], pred[k:k + 10_000], q=q[k:k + 10_000], time=t[k:k + 10_000])
    got = acc.result()

    def named(report):
        return {f.joints: (f.severity, f.details["term"]) for f in report.findings if f.kind == "missing_physics"}

    assert want.to_dict()["physics"]["decimation"]["factor"] > 1
    assert set(named(want)) == {(j,) for j in range(m)}
    assert {term for _, term in named(want).values()} <= {"viscous", "coulomb"}
    assert named(got) == named(want)
