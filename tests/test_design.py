"""The validation-design evidence (conventions §5.6): repeats found at any time, structure told
from design.

Each test names the mutation it catches: the share's strict threshold, the tolerance's boundary and
its RMS over coordinates, the estimation run's scale, q̇ and q̈ in the state, the regressor route's
agreement with q, structural columns reduced to a note while a column the estimation run excites
and the validation run does not stays a design finding, and the KUKA LWR4+ runs.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval import simulate as sim
from dynval.report import _regressor_algebra, _sections
from dynval.report._findings import Evidence, Thresholds, compute_findings
from dynval.statistics import _repeat
from dynval.statistics._columns import zero_columns

FS = 100.0


def _fourier(t, seed, f0=0.1, m=2, harmonics=5):
    """A finite Fourier series per joint (period 1/f0) and its exact derivatives."""
    rng = np.random.default_rng(seed)
    k = np.arange(1, harmonics + 1)
    amplitudes = rng.uniform(0.3, 0.8, size=(m, harmonics)) / k
    phases = rng.uniform(0.0, 2.0 * math.pi, size=(m, harmonics))
    offsets = rng.uniform(-0.5, 0.5, size=m)
    return sim.fourier_trajectory(t, offsets, amplitudes, phases, f0)


def _share(q_val=None, q_est=None, y_val=None, y_est=None, tolerance=0.1, sample_rate=FS):
    return _repeat.repeat_share(q_val, q_est, y_val, y_est, sample_rate, tolerance)


def _design(q_val=None, q_est=None, y_val=None, y_est=None, thresholds=None, sample_rate=FS):
    est = {k: v for k, v in (("q", q_est), ("regressor", y_est)) if v is not None}
    return _sections.design(y_val, q_val, est, None, thresholds, None, sample_rate=sample_rate)


# ------------------------------------------------------------------ repeats at any time

def test_a_later_period_of_a_periodic_trajectory_is_a_repeat_from_q_alone():
    # Estimation on periods 1-3 of a 10 s periodic excitation, validation on periods 5-6: the rows
    # at equal times are different (the time-aligned distance is large), the states are the same.
    t = np.arange(int(60 * FS)) / FS
    q, _, _ = _fourier(t, seed=1)
    est, val = q[: int(30 * FS)], q[int(40 * FS): int(60 * FS)]
    rep = _design(q_val=val, q_est=est)["repeat"]
    assert rep["share"] > 0.95 and rep["is_repeat"] and rep["state"] == "q"
    assert rep["tolerance"] == Thresholds().repeat_tolerance and rep["threshold"] == Thresholds().repeat_share
    assert rep["q"] < 1e-9  # a whole number of periods apart: here even the aligned rows agree
    shifted = q[int(43.3 * FS): int(60 * FS)]  # a later stretch that starts mid-period
    rep = _design(q_val=shifted, q_est=est)["repeat"]
    assert rep["share"] > 0.95 and rep["is_repeat"] and rep["q"] > 0.5  # aligned rows are far apart


def test_a_time_shifted_retrace_is_a_repeat_and_an_independent_trajectory_is_not():
    # A non-periodic trajectory (incommensurate harmonics) retraced 7.37 s later: no period to
    # align on, a time shift that is not a whole number of blocks.
    t = np.arange(int(40 * FS)) / FS
    rng = np.random.default_rng(2)
    freqs = np.array([0.11, 0.173, 0.29, 0.41])

    def traj(tt):
        return np.column_stack([np.sum(a * np.sin(2 * math.pi * freqs * tt[:, None] + ph), axis=1)
                                for a, ph in zip(amps, phases)])

    amps = rng.uniform(0.2, 0.6, size=(2, freqs.size))
    phases = rng.uniform(0.0, 2 * math.pi, size=(2, freqs.size))
    est = traj(t)
    retrace = traj(t[: int(20 * FS)] + 7.37)
    rep = _design(q_val=retrace, q_est=est)["repeat"]
    assert rep["share"] > 0.95 and rep["is_repeat"]
    other, _, _ = _fourier(t[: int(20 * FS)], seed=3)
    rep = _design(q_val=other, q_est=est)["repeat"]
    assert rep["share"] < 0.05 and not rep["is_repeat"]


def test_q_and_the_regressor_give_the_same_answer():
    # The demo arm: retrace (a later stretch of a periodic run) and an independent run, from q,
    # from the regressor and from both (q decides then). Shares agree within 0.1; the regressor's
    # differentiated columns made noisy (accelerations with noise at 30 % of their SD per sample,
    # 99 % near measured) still agree.
    t = np.arange(int(60 * FS)) / FS
    q, dq, ddq = _fourier(t, seed=4)
    e, v = slice(0, int(30 * FS)), slice(int(36.3 * FS), int(56.3 * FS))
    q2, dq2, ddq2 = _fourier(t[: int(20 * FS)], seed=5)
    y_est = sim.regressor(q[e], dq[e], ddq[e])
    rng = np.random.default_rng(6)
    noisy = ddq[v] + rng.normal(0.0, 0.3, ddq[v].shape) * ddq.std(axis=0)
    cases = {"retrace": (q[v], sim.regressor(q[v], dq[v], ddq[v]), True),
             "noisy regressor": (q[v], sim.regressor(q[v], dq[v], noisy), True),
             "independent": (q2, sim.regressor(q2, dq2, ddq2), False)}
    for name, (q_val, y_val, repeat) in cases.items():
        by_q = _design(q_val=q_val, q_est=q[e])["repeat"]
        by_y = _design(y_val=y_val, y_est=y_est)["repeat"]
        both = _design(q_val=q_val, q_est=q[e], y_val=y_val, y_est=y_est)["repeat"]
        assert by_y["state"] == "regressor" and both["state"] == "q", name
        assert by_q["is_repeat"] is by_y["is_repeat"] is both["is_repeat"] is repeat, name
        assert abs(by_q["share"] - by_y["share"]) <= 0.1 and both["share"] == by_q["share"], name


def test_the_share_threshold_is_strict_and_configurable():
    # Half retrace, half new motion: the share sits near 0.5; the finding follows the threshold
    # on either side of the measured share (and the rule needs share > threshold, not ≥).
    t = np.arange(int(40 * FS)) / FS
    q, _, _ = _fourier(t, seed=7)
    other, _, _ = _fourier(t[: int(10 * FS)], seed=8)
    val = np.vstack([q[int(21 * FS): int(31 * FS)], other])
    tau = np.random.default_rng(9).normal(size=val.shape)
    share = _design(q_val=val, q_est=q[: int(20 * FS)])["repeat"]["share"]
    assert 0.4 < share < 0.6
    for offset, found in ((-0.01, True), (0.01, False)):
        r = dynval.validate(tau, tau + 0.1, n_params=0, q=val, estimation={"q": q[: int(20 * FS)]},
                            sample_rate=FS, thresholds={"repeat_share": share + offset}, max_lag=0)
        assert r.design["repeat"]["share"] == share
        assert r.design["repeat"]["is_repeat"] is found
        rep = [f for f in r.findings if f.kind == "repeat_trajectory"]
        assert len(rep) == int(found)
        if found:
            assert rep[0].severity == "design" and rep[0].effect == share and "share" in rep[0].effect_unit
            assert f"{round(100 * share)} %" in rep[0].message
    ev = Evidence(n_samples=10, level=0.95, joint_names=["j"], r2=np.array([0.9]), pooled_r2=0.9,
                  constant_target=np.array([False]))
    for value, found in ((0.5, False), (np.nextafter(0.5, 1.0), True), (0.0, False), (1.0, True)):
        ev.repeat = {"share": value, "tolerance": 0.1, "state": "q", "is_repeat": not found}  # the rule decides
        assert [f.kind for f in compute_findings(ev)] == (["repeat_trajectory"] if found else [])


def test_near_is_within_the_tolerance_as_an_rms_over_coordinates():
    # A straight estimation trajectory along the first axis in d = 4 coordinates; validation
    # points at a known perpendicular distance D: their RMS distance is D/√d, near iff ≤ tol.
    s = np.linspace(0.0, 10.0, 501)
    ze = np.column_stack([s, np.zeros((s.size, 3))])
    d_rms = np.array([0.0999, 0.1, 0.1001, 0.05, 0.2])
    zv = np.column_stack([np.linspace(1.013, 8.97, d_rms.size), 2.0 * d_rms, np.zeros((d_rms.size, 2))])
    got = _repeat.near_distances(ze, zv, 0.1)
    np.testing.assert_allclose(got[:4], d_rms[:4], rtol=1e-12)  # between vertices: the segment refines
    assert got[4] > 0.1  # beyond reach: inf or the true distance, never near
    assert list(got <= 0.1) == [True, True, False, True, False]


def test_the_tolerance_is_used_at_its_boundary_and_the_scale_is_the_estimation_runs():
    t = np.arange(int(40 * FS)) / FS
    q, _, _ = _fourier(t, seed=10)
    est = q[: int(20 * FS)]
    val = q[int(24.1 * FS): int(34.1 * FS)] + np.array([0.04, -0.03])  # a retrace with an offset
    near = _share(val, est)
    med = near["median_distance"]
    assert 0.005 < med < 0.1
    assert _share(val, est, tolerance=1.05 * med)["share"] >= 0.5 > _share(val, est, tolerance=0.95 * med)["share"]
    # units do not matter (degrees, or each joint its own), the estimation run's spread does
    scaled = _share(val * np.array([57.3, 0.01]), est * np.array([57.3, 0.01]))
    assert scaled["share"] == pytest.approx(near["share"], abs=1e-12)
    # a joint the estimation run holds still and the validation run moves: far (scale floored at
    # 1 % of the validation run's spread), even though the other joint retraces exactly
    still = est.copy()
    still[:, 1] = 0.3
    moving = val.copy()
    moving[:, 0] = q[int(24.1 * FS): int(34.1 * FS), 0]
    assert _share(moving, still)["share"] == 0.0


def test_velocity_and_acceleration_are_part_of_the_state():
    # The same path at half the speed: every position is visited, the motion is new.
    t = np.arange(int(40 * FS)) / FS
    q, _, _ = _fourier(t, seed=11)
    slow, _, _ = _fourier(t / 2.0, seed=11)
    assert _share(slow, q)["share"] < 0.05
    # and a blocked q (a few samples per block) with 1 mrad of noise still retraces
    rng = np.random.default_rng(12)
    noisy = q[int(10.3 * FS): int(30.3 * FS)] + rng.normal(0.0, 1e-3, (int(20 * FS), 2))
    assert _share(noisy, q[: int(20 * FS)] + rng.normal(0.0, 1e-3, (int(20 * FS), 2)))["share"] > 0.9


def test_without_a_state_the_time_aligned_torque_distance_decides():
    rng = np.random.default_rng(13)
    tau = rng.normal(size=(800, 2))
    for est_tau, found in ((tau + 0.01, True), (rng.normal(size=(800, 2)), False)):
        r = dynval.validate(tau, tau + 0.1, n_params=0, estimation={"tau": est_tau}, max_lag=0)
        rep = r.design["repeat"]
        assert rep["share"] is None and rep["measure"] == "tau" and rep["threshold"] == Thresholds().repeat_distance
        assert rep["is_repeat"] is found
        assert ("repeat_trajectory" in [f.kind for f in r.findings]) is found


def test_long_runs_are_fast():
    # 200,000 × 7 positions: blocks keep the KD-tree small (under 0.2 s measured; 0.5 s allowed).
    t = np.arange(200_000) / 1000.0
    q, _, _ = _fourier(t, seed=14, m=7)
    shifted, _, _ = _fourier(t + 3.21, seed=14, m=7)
    best = math.inf
    for _ in range(3):
        start = time.perf_counter()
        out = _share(shifted, q, sample_rate=1000.0)
        best = min(best, time.perf_counter() - start)
    assert out["share"] > 0.95 and out["n_compared"] <= 20_000
    assert best < 0.5


# ------------------------------------------------------------------ structure is not design

def _columns(q, dq, ddq, rng=None):
    """Six columns: four independent, one structurally zero (with roundoff) and one exact
    combination of two others (computed in floating point)."""
    y = sim.regressor(q, dq, ddq)[:, :, :4]
    zero = 1e-17 * np.cos(q)  # cos(π/2)-type roundoff of a column that is zero for every motion
    combo = 0.3 * y[:, :, 0] - 1.7 * y[:, :, 2]
    return np.concatenate([y, zero[:, :, None], combo[:, :, None]], axis=2)


def _two_runs():
    t = np.arange(int(20 * FS)) / FS
    return _fourier(t, seed=20), _fourier(t, seed=21)


def test_structural_columns_are_a_note_and_the_condition_is_on_the_combinations():
    (qe, dqe, ddqe), (qv, dqv, ddqv) = _two_runs()
    ye, yv = _columns(qe, dqe, ddqe), _columns(qv, dqv, ddqv)
    names = ["a", "b", "c", "d", "zero", "combo"]
    tau = np.random.default_rng(22).normal(size=qv.shape)
    r = dynval.validate(tau, tau + 0.1, n_params=4, regressor=yv, column_names=names, max_lag=0,
                        estimation={"regressor": ye})
    x = r.design["excitation"]
    # of the three that depend on each other (5 = 0.3·a − 1.7·c) the last is named
    assert x["unidentifiable"] == [4] and x["structural"] == [4, 5]
    assert x["identifiable_rank"] == 4 and x["validation_rank"] == 4
    assert x["unexcited"] == [] and x["inseparable"] == []
    assert sorted(x["identifiable_columns"] + x["structural"]) == list(range(6))
    assert x["condition_scaled"] < Thresholds().condition_number  # finite: on the combinations
    ex = [f for f in r.findings if f.kind == "excitation"]
    assert [(f.severity, f.columns) for f in ex] == [("note", tuple(x["structural"]))]
    assert "2 of the regressor's 6 columns" in ex[0].message and "4 identifiable combinations" in ex[0].message
    assert r.design["excitation"]["rank_tolerance"] == 1e-9


def test_a_column_the_estimation_run_excites_and_the_validation_run_does_not_is_design():
    (qe, dqe, ddqe), (qv, dqv, ddqv) = _two_runs()
    ye, yv = _columns(qe, dqe, ddqe), _columns(qv, dqv, ddqv)
    names = ["a", "b", "c", "d", "zero", "combo"]
    tau = np.random.default_rng(23).normal(size=qv.shape)
    # column b zero in the validation run only; column d a copy of c in the validation run only
    yv2 = yv.copy()
    yv2[:, :, 1] = 0.0
    yv2[:, :, 3] = 2.0 * yv2[:, :, 2]
    r = dynval.validate(tau, tau + 0.1, n_params=4, regressor=yv2, column_names=names, max_lag=0,
                        estimation={"regressor": ye})
    x = r.design["excitation"]
    assert x["unexcited"] == [1] and x["inseparable"] == [3]  # d = 2c: the later of the two
    assert x["identifiable_rank"] == 4 and x["validation_rank"] == 2 and 1 not in x["structural"]
    design = [f for f in r.findings if f.kind == "excitation" and f.severity == "design"]
    assert len(design) == 1 and design[0].columns == (1, x["inseparable"][0]) and design[0].effect == 2.0
    assert "never excites b" in design[0].message and "cannot separate" in design[0].message
    assert "estimation run excites them apart" in design[0].message
    assert [f.severity for f in r.findings if f.kind == "excitation"].count("note") == 1  # the structure
    cmp = dynval.compare(tau, {"m": (tau + 0.1, 4)}, regressor=yv2, column_names=names, max_lag=0,
                         estimation={"regressor": ye})
    assert cmp.verdict.decision == "redesign"
    assert any("never excites b" in s and "cannot separate" in s for s in cmp.reasons["m"])


def test_without_the_estimation_regressor_zero_and_dependent_columns_stay_design():
    (qe, _, _), (qv, dqv, ddqv) = _two_runs()
    yv = _columns(qv, dqv, ddqv)
    tau = np.random.default_rng(24).normal(size=qv.shape)
    r = dynval.validate(tau, tau + 0.1, n_params=4, regressor=yv, max_lag=0, q=qv, estimation={"q": qe},
                        sample_rate=FS)
    x = r.design["excitation"]
    assert x["structural"] is None and x["identifiable_rank"] is None and x["identifiable_columns"] is None
    assert x["unexcited"] == [4] and len(x["inseparable"]) == 1 and x["validation_rank"] == 4
    ex = [f for f in r.findings if f.kind == "excitation"]
    assert [f.severity for f in ex] == ["design"]
    assert "Without the estimation run's regressor" in ex[0].message


def test_the_rank_tolerance_separates_roundoff_from_weak_columns():
    # A column within 1e-11 of a combination of two others is structural (roundoff of a
    # dependency); one 1e-7 away is a real, if weak, column: it stays and the condition number
    # says how weak. Catches a tolerance moved by orders of magnitude either way.
    (qe, dqe, ddqe), (qv, dqv, ddqv) = _two_runs()
    rng = np.random.default_rng(25)
    for eps, structural in ((1e-11, True), (1e-7, False)):
        runs = []
        for q, dq, ddq in ((qe, dqe, ddqe), (qv, dqv, ddqv)):
            y = sim.regressor(q, dq, ddq)[:, :, :4]
            extra = y[:, :, 0] + y[:, :, 1]
            extra = extra + eps * np.linalg.norm(extra) / math.sqrt(extra.size) * rng.normal(size=extra.shape)
            runs.append(np.concatenate([y, extra[:, :, None]], axis=2))
        x = _sections.design(runs[1], None, {"regressor": runs[0]}, None, None, None)["excitation"]
        assert (len(x["structural"]) == 1) is structural, eps
        assert x["identifiable_rank"] == (4 if structural else 5)
        if not structural:
            assert x["condition_scaled"] > 1e5 and x["inseparable"] == []


def test_dependent_columns_are_the_last_of_their_set_whatever_the_rounding():
    # Columns 5 = 1 + 2 and 7 = 0 − 3, exactly: of each set the last is named dependent, and the
    # same columns and condition numbers come from R factors rounded differently (rows in another
    # order, other blocks). A pivoted QR chooses among the equal norms of scaled columns by
    # rounding (it named three different sets on the KUKA regressor for three blockings).
    rng = np.random.default_rng(31)
    x = rng.normal(size=(3000, 8)) * np.array([1.0, 3.0, 0.5, 2.0, 1.0, 1.0, 7.0, 1.0])
    x[:, 5] = x[:, 1] + x[:, 2]
    x[:, 7] = x[:, 0] - x[:, 3]
    bases, conditions = set(), []
    for rows in (np.arange(3000), rng.permutation(3000), np.arange(3000)[::-1]):
        for block in (64, 1000):
            r = _regressor_algebra._r_factor(x[rows], np.arange(8), block=block)
            bases.add(tuple(_regressor_algebra._leading_base(r, 1e-9)))
        r = dynval.validate(np.zeros(3000), np.zeros(3000), n_params=6, regressor=x[rows][:, None, :], max_lag=0)
        ex = r.design["excitation"]
        assert ex["inseparable"] == [5, 7] and ex["validation_rank"] == 6
        conditions.append((ex["condition_raw"], ex["condition_scaled"]))
    assert bases == {(0, 1, 2, 3, 4, 6)}
    np.testing.assert_allclose(conditions, [conditions[0]] * 3, rtol=1e-12)


def test_a_dependent_columns_roundoff_does_not_enter_the_span():
    # A dependent column leaves a roundoff residual (~1e-16) of no meaning. Taken into the span (a
    # QR in column order) it adds a direction, and where the rows are few (an R factor) it can be
    # the very direction a later column's distance lies along: here column 3 (1e-3 from column
    # 0) would be lost, the rank 2 instead of 3.
    rng = np.random.default_rng(32)
    r = np.linalg.qr(rng.normal(size=(500, 3)), mode="r")  # the R of three independent columns
    x = np.column_stack([r[:, 0], r[:, 1], r[:, 0] + r[:, 1], r[:, 0] + 1e-3 * r[:, 2]])
    assert list(_regressor_algebra._leading_base(x, 1e-9)) == [0, 1, 3]


def test_a_full_rank_regressor_reduces_nothing():
    (qe, dqe, ddqe), (qv, dqv, ddqv) = _two_runs()
    ye, yv = sim.regressor(qe, dqe, ddqe), sim.regressor(qv, dqv, ddqv)
    grams = _regressor_algebra.JointGrams(yv)
    with_est = _sections.design(yv, None, {"regressor": ye}, None, None, grams)["excitation"]
    alone = _sections.design(yv, None, None, None, None, _regressor_algebra.JointGrams(yv))["excitation"]
    assert with_est["structural"] == [] and with_est["identifiable_rank"] == yv.shape[2]
    assert alone["structural"] is None and alone["identifiable_rank"] is None
    assert with_est["condition_scaled"] == alone["condition_scaled"] < 1e3


def test_base_set_is_identifys_reduction():
    (qe, dqe, ddqe), _ = _two_runs()
    y = _columns(qe, dqe, ddqe)
    from dynval.identify import base_set, identify

    tau = y[:, :, :4] @ np.array([1.0, 2.0, -1.0, 0.5])
    fit = identify(y, tau, rcond=1e-9)
    got = base_set(y.reshape(-1, y.shape[2]), 1e-9)
    assert got["rank"] == fit.rank and tuple(got["base"]) == fit.base_columns
    np.testing.assert_allclose(got["combination"], fit.combination, rtol=1e-9, atol=1e-12)
    r = np.linalg.qr(y.reshape(-1, y.shape[2]), mode="r")  # the R factor gives the same set
    from_r = base_set(r, 1e-9)
    assert tuple(from_r["base"]) == fit.base_columns and list(from_r["zero"]) == [4]


# ------------------------------------------------------------------ the KUKA LWR4+ runs

KUKA = Path(__file__).resolve().parents[2] / "shared" / "data" / "robots" / "kuka_lwr4_flobaroid"


@pytest.fixture(scope="module")
def kuka():
    if not (KUKA / "data" / "measurements_1.npz").is_file():
        pytest.skip("the KUKA LWR4+ data are not in ../shared/data/robots")
    pytest.importorskip("pinocchio")
    from dynval.robots import URDFModel

    model = URDFModel(KUKA / "model" / "kuka_lwr4.urdf")
    runs = {}
    for k in (1, 2, 3):
        with np.load(KUKA / "data" / f"measurements_{k}.npz") as f:
            run = {key: np.asarray(f[key], dtype=float) for key in ("positions", "velocities", "accelerations",
                                                                    "torques")}
        run["regressor"] = model.regressor(run["positions"], run["velocities"], run["accelerations"])
        runs[k] = run
    return runs, list(model.column_names())


def test_kuka_run_2_repeats_run_1_and_run_3_does_not_from_q_the_regressor_and_both(kuka):
    threadpoolctl = pytest.importorskip("threadpoolctl")
    runs, _ = kuka
    with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):  # as validate runs it
        _kuka_shares(runs)


def _kuka_shares(runs):
    est = runs[1]
    for k, repeat in ((2, True), (3, False)):
        val = runs[k]
        shares = {}
        for given in ("q", "regressor", "both"):
            rep = _design(q_val=val["positions"] if given != "regressor" else None,
                          q_est=est["positions"] if given != "regressor" else None,
                          y_val=val["regressor"] if given != "q" else None,
                          y_est=est["regressor"] if given != "q" else None, sample_rate=200.0)["repeat"]
            assert rep["is_repeat"] is repeat, (k, given)
            shares[given] = rep["share"]
        assert abs(shares["q"] - shares["regressor"]) <= 0.1 and shares["both"] == shares["q"]
        assert (min(shares.values()) > 0.95) if repeat else (max(shares.values()) < 0.05)


def test_kuka_raw_regressor_is_reduced_not_redesigned(kuka):
    # The raw 91-column URDF regressor: 27 columns are zero or exact combinations for every motion
    # of this fixed-base arm (link 1 turns about its axis only); run 3 against run 1 is then a
    # well-conditioned validation of 64 identifiable combinations, with a note and no design finding.
    runs, names = kuka
    est, val = runs[1], runs[3]
    r = dynval.validate(val["torques"], val["torques"] * 0.95, n_params=64, regressor=val["regressor"],
                        column_names=names, q=val["positions"], sample_rate=200.0, max_lag=0,
                        estimation={"q": est["positions"], "regressor": est["regressor"]})
    x = r.design["excitation"]
    assert len(x["column_norms"]) == 91 and x["identifiable_rank"] == 64 and len(x["structural"]) == 27
    assert x["unidentifiable"] == [0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 12]  # link 1 but Izz, link 2's m, my
    assert x["unexcited"] == [] and x["inseparable"] == [] and x["condition_scaled"] < 1e3
    assert not r.design["repeat"]["is_repeat"]
    assert [f.severity for f in r.findings if f.severity == "design"] == []
    note = [f for f in r.findings if f.kind == "excitation"]
    assert [f.severity for f in note] == ["note"] and "reduced to 64 identifiable combinations" in note[0].message


# ------------------------------------------------------------------ a column's unit (contract §4)

_DECISIONS = ("unexcited", "inseparable", "unidentifiable", "structural", "identifiable_rank",
              "identifiable_columns", "validation_rank")


@pytest.mark.parametrize("column, factor", [(0, 1e10), (0, 1e-10), (3, 1e9), (5, 1e12), (1, 1e-7)])
def test_a_column_in_another_unit_moves_no_other_columns_decision(column, factor):
    # A column 1e10 times larger (another unit) used to make every column below 1e-9 of it "zero":
    # the largest norm was the reference. The median is: the roundoff column (4) stays zero, the
    # others keep their status, with and without the estimation run, and the scaled condition
    # number does not move.
    (qe, dqe, ddqe), (qv, dqv, ddqv) = _two_runs()
    ye, yv = _columns(qe, dqe, ddqe), _columns(qv, dqv, ddqv)
    s = np.ones(6)
    s[column] = factor
    for est in ({"regressor": ye}, None):
        before = _sections.design(yv, None, est, None, None, None)["excitation"]
        after = _sections.design(yv * s, None, None if est is None else {"regressor": ye * s}, None, None,
                                 None)["excitation"]
        assert {k: after[k] for k in _DECISIONS} == {k: before[k] for k in _DECISIONS}, (column, factor, est)
        assert after["condition_scaled"] == pytest.approx(before["condition_scaled"], rel=1e-9)
        assert 4 in (before["unidentifiable"] if est else before["unexcited"])


def test_a_healthy_regressor_with_a_column_in_another_unit_is_accepted():
    # N1: six excited columns, one in a unit 1e10 (or 1e-10) times another's: every column is
    # excited, the validation rank is 6 and compare accepts, as with the columns as they were.
    rng = np.random.default_rng(37)
    n, m, p = 500, 2, 6
    y = rng.normal(size=(n, m, p))
    pred = np.einsum("njp,p->nj", y, rng.normal(size=p))
    meas = pred + 0.1 * rng.normal(size=(n, m))
    for factor in (1.0, 1e10, 1e-10):
        y2 = y.copy()
        y2[:, :, 2] *= factor
        x = dynval.validate(meas, pred, n_params=p, regressor=y2).design["excitation"]
        assert x["unexcited"] == [] and x["inseparable"] == [] and x["validation_rank"] == p, factor
        assert dynval.compare(meas, {"model": (pred, p)}, regressor=y2).verdict.decision == "accept", factor


def test_zero_columns_are_judged_against_the_median_norm():
    # the rule itself (conventions §5.6): exactly zero, or at most 1e-13 of the median nonzero norm
    zero = zero_columns
    assert list(zero(np.array([1.0, 2.0, 3.0, 1e-14, 0.0, 1e9]))) == [False, False, False, True, True, False]
    assert list(zero(np.array([1.0, 3.0, 1.01e-13]))) == [False, False, False]  # the median is 1
    assert list(zero(np.array([1.0, 3.0, 0.99e-13]))) == [False, False, True]
    assert list(zero(np.zeros(3))) == [True, True, True]


def test_kuka_a_column_in_another_unit_keeps_the_64_combinations():
    # The shipped KUKA LWR4+ runs (run 3 against run 1, every fourth sample): one column 1e9 times
    # larger or smaller used to cut the identifiable rank from 64 to 31.
    pytest.importorskip("pinocchio")
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    r1, r3 = load_kuka_lwr4(1), load_kuka_lwr4(3)
    model = URDFModel(r1.urdf)
    ye = model.regressor(r1.q[::4], r1.dq[::4], r1.ddq[::4])
    yv = model.regressor(r3.q[::4], r3.dq[::4], r3.ddq[::4])
    before = _sections.design(yv, None, {"regressor": ye}, None, None, None)["excitation"]
    assert before["identifiable_rank"] == 64 and len(before["structural"]) == 27
    for column, factor in ((0, 1e9), (71, 1e9), (26, 1e-9)):
        s = np.ones(yv.shape[2])
        s[column] = factor
        after = _sections.design(yv * s, None, {"regressor": ye * s}, None, None, None)["excitation"]
        assert {k: after[k] for k in _DECISIONS} == {k: before[k] for k in _DECISIONS}, (column, factor)


def test_a_retrace_with_noisy_positions_is_still_a_repeat():
    """A later period of a periodic trajectory logged at 200 Hz with 20 mrad of white noise on q:
    the blocks' derivatives carry the noise into q̇ and q̈ (before, 57 % near; 42 % at 30 mrad). Its
    part of each distance is taken out (the noise measured from the logged q itself). Kills: no
    correction; a correction from the block means (the motion there passes for noise: independent
    runs then look alike); the noise added to the distance instead of taken out."""
    fs = 200.0
    t = np.arange(int(60 * fs)) / fs
    q, _, _ = _fourier(t, seed=21)
    rng = np.random.default_rng(22)
    noisy = q + rng.normal(0.0, 0.02, q.shape)
    est, val = noisy[: int(30 * fs)], noisy[int(40 * fs):]
    rep = _design(q_val=val, q_est=est, sample_rate=fs)["repeat"]
    assert rep["share"] > 0.9 and rep["is_repeat"] and rep["noise_floor"] > 0.0
    clean = _design(q_val=q[int(40 * fs):], q_est=q[: int(30 * fs)], sample_rate=fs)["repeat"]
    assert clean["share"] > 0.95 and clean["noise_floor"] < 0.1 * rep["noise_floor"]
    shares = []
    for seed in range(30, 45):
        other, _, _ = _fourier(t[: int(20 * fs)], seed=seed)
        other = other + rng.normal(0.0, 0.02, other.shape)
        shares.append(_design(q_val=other, q_est=est, sample_rate=fs)["repeat"]["share"])
    assert max(shares) < 0.2, shares
