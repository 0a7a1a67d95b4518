"""validate_log(identified=...) and validate-log --identified NAME=FILE: the user's own identified
parameter vector of a URDF model, a candidate predicting Y(q, q̇, q̈) π̂ on the log."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import dynval
from csv_logs import kuka_csv
from dynval.datasets import load_kuka_lwr4

pytest.importorskip("pinocchio")

N = 2000


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """Run 3 as a CSV log, and the KUKA URDF's parameters identified on run 1 by dynval.identify
    (full length: the base columns' estimates, zero on the other columns)."""
    from dynval.robots import URDFModel

    folder = tmp_path_factory.mktemp("identified")
    run1, run3 = load_kuka_lwr4(1), load_kuka_lwr4(3)
    path, mapping = kuka_csv(folder / "run3.csv", run3, np.arange(N))
    spec = folder / "kuka.json"
    spec.write_text(json.dumps(mapping), encoding="utf-8")
    model = URDFModel(run1.urdf)
    fit = model.identify(run1.q, run1.dq, run1.ddq, run1.tau)
    pi = np.zeros(len(model.column_names()))
    pi[list(fit.base_columns)] = fit.estimate
    np.save(folder / "pi.npy", pi)
    return {"folder": folder, "log": path, "mapping": spec, "run3": run3, "model": model, "fit": fit, "pi": pi}


def _by_hand(case):
    """The array path: the log's arrays, the URDF's prediction and Y π̂ with the fit's rank."""
    from dynval.robots import differentiate

    run3, model = case["run3"], case["model"]
    ns = np.round(run3.time[:N] * 1000.0 * 1e6)
    t = (ns - ns[0]) / 1e9
    q, tau = run3.q[:N], run3.tau[:N]
    d = differentiate(q, 1.0 / np.median(np.diff(t)))
    y = model.regressor(q, d.dq, d.ddq)
    candidates = {"kuka": {"prediction": model.predict(q, d.dq, d.ddq), "n_params": 0},
                  "kuka identified (pi)": {"prediction": y @ case["pi"], "n_params": case["fit"].rank}}
    return dynval.compare(tau, candidates, time=t, bandwidth=d.input_bandwidth_hz, q=q, dq=d.dq, ddq=d.ddq,
                          joint_names=list(run3.joint_names))


def test_identified_parameters_give_the_array_paths_report(case):
    from dynval.logs import validate_log

    cmp = validate_log(case["log"], {"kuka": case["run3"].urdf}, mapping=case["mapping"],
                       identified={"kuka": case["folder"] / "pi.npy"})
    by_hand = _by_hand(case)
    assert list(cmp.reports) == list(by_hand.reports) == ["kuka", "kuka identified (pi)"]
    assert cmp.verdict.decision == by_hand.verdict.decision and cmp.verdict.model == by_hand.verdict.model
    for name in by_hand.reports:
        got, want = cmp.reports[name], by_hand.reports[name]
        assert [(f.kind, f.joints, f.message) for f in got.findings] == \
            [(f.kind, f.joints, f.message) for f in want.findings]
        np.testing.assert_allclose(got.per_joint.rmse, want.per_joint.rmse, rtol=1e-12)
    assert cmp.reports["kuka identified (pi)"].provenance.n_params == case["fit"].rank


def test_the_vector_as_csv_json_list_and_json_object_predicts_the_same(case):
    from dynval.logs import validate_log

    folder, pi = case["folder"], case["pi"]
    np.savetxt(folder / "pi.csv", pi)
    (folder / "pi_list.json").write_text(json.dumps(pi.tolist()))
    (folder / "pi_named.json").write_text(json.dumps(dict(zip(case["model"].column_names(), pi.tolist()))))
    rmse = []
    for name in ("pi.csv", "pi_list.json", "pi_named.json"):
        cmp = validate_log(case["log"], {"kuka": case["run3"].urdf}, mapping=case["mapping"],
                           identified={"kuka": folder / name})
        rmse.append(cmp.reports[f"kuka identified ({name.rsplit('.', 1)[0]})"].per_joint.rmse)
    want = _by_hand(case).reports["kuka identified (pi)"].per_joint.rmse
    for got in rmse:
        np.testing.assert_allclose(got, want, rtol=1e-12)


def test_a_vector_of_another_length_names_both_counts_and_where_the_columns_come_from(case):
    from dynval.logs import validate_log

    short = case["folder"] / "short.npy"
    np.save(short, case["pi"][:-1])
    with pytest.raises(dynval.InvalidParameter) as err:
        validate_log(case["log"], {"kuka": case["run3"].urdf}, mapping=case["mapping"], identified={"kuka": short})
    text = str(err.value)
    assert "91 columns (URDFModel.column_names(): 10 inertial parameters per link, then Fv_, Fc_ and off_ per " \
           "joint, of 7 joints)" in text and f"{short} holds 90" in text
    with pytest.raises(dynval.InvalidParameter, match="identified must be parameters of one of the models"):
        validate_log(case["log"], {"kuka": case["run3"].urdf}, mapping=case["mapping"], identified={"cad": short})
    named = case["folder"] / "bad_named.json"
    named.write_text(json.dumps({"nope": 1.0}))
    with pytest.raises(dynval.io.FileInputError, match="'nope' is none of them"):
        validate_log(case["log"], {"kuka": case["run3"].urdf}, mapping=case["mapping"], identified={"kuka": named})


def test_the_command_takes_identified_name_equals_file(case):
    base = [sys.executable, "-m", "dynval", "validate-log", str(case["log"]), "--model", f"kuka={case['run3'].urdf}",
            "--mapping", str(case["mapping"]), "--no-progress"]
    out = subprocess.run([*base, "--identified", f"kuka={case['folder'] / 'pi.npy'}"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "kuka identified (pi)" in out.stdout
    out = subprocess.run([*base, "--identified", str(case["folder"] / "pi.npy")], capture_output=True, text=True)
    assert out.returncode == 1 and "expected NAME=FILE" in out.stderr and "Traceback" not in out.stderr
