"""dynval.compare: ranking, the decision table and the verdict of the lesson's flowchart."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dynval
from dynval import calibration as C
from dynval import simulate as sim
from dynval.cli import main

NAMES = list(sim.PARAMETER_NAMES)
NO_FC = [i for i, n in enumerate(NAMES) if not n.startswith("Fc")]


def _runs(seed=0, noise=0.2, fc=None, repeat=False, ar=None):
    rng = np.random.default_rng(seed)
    arm = sim.DEFAULT_ARM if fc is None else sim.ArmParameters(fc1=fc, fc2=fc)
    pi = sim.base_parameters(arm)
    t = np.arange(2000) / 100.0
    out = []
    traj = C._trajectory(rng, t)
    for k in range(2):
        if k == 1 and not repeat:
            traj = C._trajectory(rng, t)
        q, dq, ddq = traj
        Y = sim.regressor(q, dq, ddq)
        e = rng.normal(0, noise, (2000, 2)) if ar is None else C._noise(ar, rng, (2000, 2))
        out.append((q, Y, Y @ pi + e))
    return out


def _fit(Y, tau, cols):
    pi, *_ = np.linalg.lstsq(Y[:, :, cols].reshape(-1, len(cols)), tau.reshape(-1), rcond=None)
    return pi


def _candidates(est, val):
    (_, y_e, tau_e), (_, y_v, _) = est, val
    full = list(range(len(NAMES)))
    return {
        "rigid+viscous": {"prediction": y_v[:, :, NO_FC] @ _fit(y_e, tau_e, NO_FC), "n_params": len(NO_FC),
                          "model_columns": NO_FC},
        "full": {"prediction": y_v @ _fit(y_e, tau_e, full), "n_params": len(full), "model_columns": full},
    }


def test_friction_model_wins_and_is_accepted():
    est, val = _runs(fc=0.6)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         sample_rate=100.0)
    assert cmp.ranking == ["full", "rigid+viscous"]
    assert cmp.verdict.decision == "accept" and cmp.verdict.model == "full"
    assert cmp.reports["full"].deficiencies == []
    missing = [f for f in cmp.reports["rigid+viscous"].deficiencies if f.kind == "regressor_correlation"]
    assert missing and all(NAMES[f.columns[0]].startswith("Fc") for f in missing)
    pooled = cmp.table["pooled"]
    assert pooled["full"]["delta_aic"] == 0.0 and pooled["rigid+viscous"]["delta_aic"] > 0
    assert pooled["full"]["akaike_weight"] + pooled["rigid+viscous"]["akaike_weight"] == pytest.approx(1.0)
    assert pooled["full"]["whiteness"] == "white"
    text = cmp.summary()
    assert "Verdict: ACCEPT — full" in text and "ΔAIC" in text
    json.loads(cmp.to_json())


def test_only_the_reduced_model_gets_refine_with_the_missing_term():
    est, val = _runs(fc=0.6)
    cands = _candidates(est, val)
    cmp = dynval.compare(val[2], {"rigid+viscous": cands["rigid+viscous"]}, regressor=val[1],
                         column_names=NAMES, sample_rate=100.0)
    assert cmp.verdict.decision == "refine"
    assert any("Fc" in r for r in cmp.verdict.reasons)


def test_a_repeated_trajectory_asks_for_a_new_experiment():
    est, val = _runs(repeat=True, fc=0.6)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         estimation={"regressor": est[1], "q": est[0]}, q=val[0], sample_rate=100.0)
    assert cmp.verdict.decision == "redesign"
    assert any("repeats the estimation run" in r for r in cmp.verdict.reasons)


def test_whiteness_that_cannot_discriminate_is_said_once():
    est, val = _runs(ar="ar0.99", noise=0.2)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         sample_rate=100.0)
    assert all(cmp.table["pooled"][n]["whiteness"] == "not white" for n in cmp.names)
    assert cmp.verdict.decision == "redesign"
    assert any("whiteness cannot discriminate" in r for r in cmp.verdict.reasons)
    assert [f.kind for f in cmp.findings] == ["whiteness"]


def test_criteria_print_with_enough_digits_to_differ():
    # AICs of −17327761.7 and −17327737.7 must not read the same.
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(4000, 2))
    a = tau + rng.normal(0, 0.1, tau.shape)
    cmp = dynval.compare(tau, {"a": (a, 3), "b": (a, 15)}, criterion="aic")
    row_a, row_b = cmp.table["pooled"]["a"], cmp.table["pooled"]["b"]
    assert row_b["delta_aic"] == pytest.approx(24.0)
    text = cmp.summary()
    assert f"{row_a['aic']:.1f}" in text and f"{row_b['aic']:.1f}" in text and "24.0" in text


def test_bad_candidates_are_refused():
    with pytest.raises(dynval.InvalidParameter, match="candidates must be a non-empty mapping"):
        dynval.compare([1.0, 2.0, 3.0], {})
    with pytest.raises(dynval.InvalidParameter, match=r"candidates\['x'\]"):
        dynval.compare([1.0, 2.0, 3.0], {"x": [1.0, 2.0, 3.0]})
    with pytest.raises(dynval.InvalidParameter, match="criterion must be one of"):
        dynval.compare([1.0, 2.0, 3.0], {"x": ([1.0, 2.0, 3.5], 1)}, criterion="hqc")


def test_cli_compare(tmp_path, capsys):
    est, val = _runs(fc=0.6)
    cands = _candidates(est, val)
    np.save(tmp_path / "tau.npy", val[2])
    np.save(tmp_path / "Y.npy", val[1])
    args = ["compare", str(tmp_path / "tau.npy"), "--regressor", str(tmp_path / "Y.npy"),
            "--column-names", ",".join(NAMES), "--sample-rate", "100"]
    for name, c in cands.items():
        np.save(tmp_path / f"{name}.npy", c["prediction"])
        args += ["--model", f"{name}={tmp_path / name}.npy:{c['n_params']}"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "Verdict:" in out and "Decision table" in out
    assert main(args + ["--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["ranking"][0] == "full" and d["verdict"]["decision"] in ("accept", "refine", "redesign")
    assert main(["compare", str(tmp_path / "tau.npy"), "--model", "broken"]) == 2
