"""The missing-physics test on a log decimated towards the information band (conventions §5.2,
"Decimated to the information band").

The rule: the factor D = min(⌊f_s/(2 · 4 · f_I)⌋, ⌊N/4,000⌋) from the report's information band,
none without a rate or a band, or when D < 2; at least the factor that brings a log to 40,000 rows.
The report states it (the physics section's ``decimation`` and the provenance's
``physics_decimation``) and only then. Decimated against the logged rows on 1 kHz calibration
scenarios and the simulated 7-joint 1 kHz log: the same findings, p-values within the stated
tolerance, shares of the logged rate's mean square and N_eff in its units.

Mutations caught: a factor that ignores the margin, the row floor or the 40,000-row limit; a band
taken from elsewhere than the report's; decimation with ``decimate=None``; a statement missing or
present on a log not decimated; shares of the decimated rows' mean square (white noise above the
band removed: each share then grows by up to D); N_eff left in decimated samples (D times too few)
or above the logged rows; a library built at the logged rate for decimated rows (a shape error) or a
filter's edge kept.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval import scenarios
from dynval.statistics import _physics

Z_TOL = 2.5  # |Φ⁻¹(1 − p_D) − Φ⁻¹(1 − p)| for p ≥ 1e-6, both counted from 0.5 (measured at most 1.9)
SMALL_P, SMALL_P_DECIMATED = 1e-6, 1e-4  # p below the first stays below the second (measured 2.8e-7)
SHARE_TOL = 0.025  # of the mean square, on white-noise logs without a sharp delay (measured 0.020)


# --------------------------------------------------------------------------- the rule


@pytest.mark.parametrize("n, fs, band, factor", [
    (20_000, 1000.0, 13.671875, 5),   # the rows decide: ⌊1000/(8·13.67)⌋ = 9, but 20,000/5 = 4,000
    (20_000, 1000.0, 40.0, 3),        # the band decides: ⌊1000/320⌋ = 3
    (20_000, 1000.0, 125.0, 1),       # a band at an eighth of the rate: ⌊1⌋, nothing to gain
    (15_000, 500.0, 1.0, 3),          # 500 Hz × 30 s: at most 3 (5,000 rows)
    (7_999, 1000.0, 1.0, 1),          # fewer than 8,000 rows: never by the band
    (5_027, 200.004, 13.671875, 1),   # the KUKA runs
    (100_000, 1000.0, 1.0, 25),       # the band allows 25 (4,000 rows)
    (100_000, 1000.0, 200.0, 3),      # the band allows 1: the 40,000-row limit decides
    (100_000, None, None, 3),         # no rate: the limit alone
    (20_000, None, 13.0, 1),          # a band without a rate is in cycles per sample: not used
    (20_000, 1000.0, None, 1),
    (20_000, 1000.0, float("nan"), 1),
    (20_000, 1000.0, 0.0, 1),
])
def test_the_factor_follows_the_band_with_its_margin_and_row_floor(n, fs, band, factor):
    d = _physics.decimation(n, fs, band)
    assert d.factor == factor
    if factor == 1:
        assert d.rows == n and d.rule == "none"
        return
    assert d.rows == math.ceil(n / factor) - 20  # the filter's 10 rows at each end dropped
    by_band = "information band" in d.rule
    if by_band:
        assert fs / (2 * factor) >= 4.0 * band  # the margin: the band at most a quarter of the new Nyquist
        assert n / factor >= 4_000  # the row floor
    else:
        assert "longer than 40000 rows" in d.rule and n / factor <= 40_000


def test_the_factor_is_the_largest_the_margin_and_floor_allow():
    for n in (8_000, 12_345, 20_000, 60_000):
        for band in (0.5, 3.0, 13.0, 40.0):
            d = _physics.decimation(n, 1000.0, band).factor
            if d > max(1, math.ceil(n / 40_000)):
                bigger = d + 1
                assert 1000.0 / (2 * bigger) < 4.0 * band or n / bigger < 4_000


# --------------------------------------------------------------------------- in the report


def _scenario(key):
    s = next(x for x in scenarios.library() if x.key == key)
    rep = scenarios.simulate(s, 0)
    return rep, scenarios.fit(rep)


def _logged_rate(monkeypatch, run):
    """``run()`` with the band rule switched off (an infinite margin): the logged rows."""
    with monkeypatch.context() as mp:
        mp.setattr(_physics, "_MARGIN", math.inf)
        return run()


def _key(f):
    return (f.kind, tuple(f.joints or ()), f.severity, (f.details or {}).get("term"))


def _z(p):
    return max(float(scipy.stats.norm.isf(max(p, 1e-300))), 0.0)


def _compare(decimated, logged, white):
    assert "decimation" in decimated.physics and "decimation" not in logged.physics
    assert sorted(map(_key, decimated.findings)) == sorted(map(_key, logged.findings))
    assert "Physical terms tested on the log decimated by" in decimated.summary()
    assert "tested on the log decimated" not in logged.summary()
    for a, b in zip(decimated.physics["tests"], logged.physics["tests"]):
        where = f"joint {b['joint']}"
        assert a["n_eff"] <= decimated.provenance["n_samples"], where  # never more than the logged rows
        pa, pb = float(a["pvalue"]), float(b["pvalue"])
        if pb >= SMALL_P:
            assert abs(_z(pa) - _z(pb)) <= Z_TOL, f"{where}: p {pa:.3g} decimated against {pb:.3g}"
        else:
            assert pa <= SMALL_P_DECIMATED, f"{where}: p {pa:.3g} decimated against {pb:.3g}"
        if white:
            assert abs(a["share"] - b["share"]) <= SHARE_TOL, f"{where}: share {a['share']} against {b['share']}"
            # N_eff in the logged rate's units: white noise gives about N at both rates
            assert 0.8 <= a["n_eff"] / b["n_eff"] <= 1.25, f"{where}: N_eff {a['n_eff']} against {b['n_eff']}"


@pytest.mark.parametrize("key, offered, white", [
    ("right:white:arm4@1000", True, True),
    ("no_gravity:lowpass:anthro3@1000", True, False),
    ("right:lowpass:anthro3@1000", False, False),
    ("delay:white:arm4@1000", True, False),  # white, but the delayed prediction's jump is above the band
])
def test_a_1khz_scenario_decimated_keeps_its_findings_and_pvalues(monkeypatch, key, offered, white):
    rep, pred = _scenario(key)
    decimated = scenarios.validate_replicate(rep, offered, prediction=pred)
    logged = _logged_rate(monkeypatch, lambda: scenarios.validate_replicate(rep, offered, prediction=pred))
    _compare(decimated, logged, white)
    dec = decimated.physics["decimation"]
    fs = decimated.provenance["sample_rate"]
    assert dec["information_band_hz"] == decimated.whiteness["information_band"]  # the report's one band
    assert dec == _physics.decimation(rep.scenario.n_samples, fs, dec["information_band_hz"]).to_dict()
    assert decimated.provenance["conventions"]["physics_decimation"] == dec
    assert "physics_decimation" not in logged.provenance["conventions"]


def test_the_simulated_7_joint_1khz_log_decimated_keeps_its_findings(monkeypatch):
    pytest.importorskip("pinocchio")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    try:
        import bench_physics
    finally:
        sys.path.pop(0)
    _, with_q, _ = bench_physics.simulated_case()
    decimated = dynval.validate(**with_q)
    logged = _logged_rate(monkeypatch, lambda: dynval.validate(**with_q))
    assert decimated.physics["decimation"]["factor"] == 5 and decimated.physics["decimation"]["rows"] == 3980
    _compare(decimated, logged, white=True)
    assert {f.details["term"] for f in decimated.findings if f.kind == "missing_physics"} == {"viscous", "coulomb"}


def test_no_decimation_where_the_rule_does_not_allow_it():
    rep, (pi, _) = _scenario("right:white:arm4@1000")
    val = rep.validation
    pred = val.regressor[:, :, list(rep.model_columns)] @ pi
    kw = dict(n_params=1, sample_rate=rep.scenario.sample_rate, q=val.q)
    assert "decimation" in dynval.validate(val.tau, pred, **kw).physics  # the band allows it here
    short = dynval.validate(val.tau[:7_999], pred[:7_999], **{**kw, "q": val.q[:7_999]})
    assert "decimation" not in short.physics  # fewer than 8,000 rows
    assert "physics_decimation" not in short.provenance["conventions"]
    for decimate in (None, 2):  # the user's choice of the logged rate, or a factor for whiteness only
        r = dynval.validate(val.tau, pred, decimate=decimate, **kw)
        assert "decimation" not in r.physics and "physics_decimation" not in r.provenance["conventions"]
    no_rate = dynval.validate(val.tau, pred, n_params=1, q=val.q)
    assert "decimation" not in no_rate.physics


def test_the_decimated_rows_drop_the_filters_edges():
    # a constant stays constant on the rows kept: the filter's zero padding reached only the dropped ones
    x = np.ones((2_000, 2))
    y = _physics._down(x, 5)
    assert y.shape == (400 - 20, 2)
    assert np.max(np.abs(y - 1.0)) < 1e-3
    assert np.max(np.abs(scipy.signal.decimate(x, 5, ftype="fir", axis=0, zero_phase=True) - 1.0)) > 0.1


def test_the_models_columns_refitted_on_a_decimated_log_keep_the_findings(monkeypatch):
    # a regressor without the estimation run: its columns, nuisance refitted on the run, are decimated too
    rep, (pi, rank) = _scenario("no_gravity:lowpass:anthro3@1000")
    val = rep.validation
    cols = list(rep.model_columns)
    pred = val.regressor[:, :, cols] @ pi
    kw = dict(n_params=rank, regressor=val.regressor, model_columns=cols, sample_rate=rep.scenario.sample_rate,
              q=val.q, column_names=list(rep.column_names))
    decimated = dynval.validate(val.tau, pred, **kw)
    logged = _logged_rate(monkeypatch, lambda: dynval.validate(val.tau, pred, **kw))
    assert decimated.physics["decimation"]["factor"] == 5
    _compare(decimated, logged, white=False)
