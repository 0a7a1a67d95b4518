"""dynval.compare: ranking, the decision table and the verdict of the lesson's flowchart."""

from __future__ import annotations

import html
import json
import math
import re

import numpy as np
import pytest

import dynval
from dynval import calibration as C
from dynval import simulate as sim
from dynval.cli import main
from dynval.html import render_report

NAMES = list(sim.PARAMETER_NAMES)
NO_FC = [i for i, n in enumerate(NAMES) if not n.startswith("Fc")]
JOINTS = ["shoulder", "elbow"]


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


def test_cli_compare_gives_each_candidate_its_columns(tmp_path, capsys):
    """--model-columns NAME=COLS (indices or names): the same comparison as the API's model_columns."""
    est, val = _runs(fc=0.6)
    cands = _candidates(est, val)
    np.save(tmp_path / "tau.npy", val[2])
    np.save(tmp_path / "Y.npy", val[1])
    args = ["compare", str(tmp_path / "tau.npy"), "--regressor", str(tmp_path / "Y.npy"),
            "--column-names", ",".join(NAMES), "--sample-rate", "100", "--json"]
    for name, c in cands.items():
        np.save(tmp_path / f"{name}.npy", c["prediction"])
        args += ["--model", f"{name}={tmp_path / name}.npy:{c['n_params']}"]
    by_name = ",".join(NAMES[k] for k in cands["rigid+viscous"]["model_columns"])
    by_index = ",".join(str(k) for k in cands["full"]["model_columns"])
    assert main(args + ["--model-columns", f"rigid+viscous={by_name}", "--model-columns", f"full={by_index}"]) == 0
    got = json.loads(capsys.readouterr().out)
    want = dynval.compare(val[2], cands, regressor=val[1], column_names=NAMES, sample_rate=100.0)
    assert got["ranking"] == want.ranking and got["verdict"] == json.loads(want.to_json())["verdict"]
    assert got["reasons"] == {k: list(v) for k, v in want.reasons.items()}
    # a name that is no candidate, or columns without a regressor, are usage errors
    with pytest.raises(SystemExit) as stop:
        main(args + ["--model-columns", "nobody=0,1"])
    assert stop.value.code == 2 and "'nobody', which is not a --model" in capsys.readouterr().err
    bare = [a for a in args if a not in ("--regressor", str(tmp_path / "Y.npy"))]
    with pytest.raises(SystemExit):
        main(bare + ["--model-columns", "full=0"])
    assert "--model-columns needs --regressor" in capsys.readouterr().err


def _matter(report):
    """The findings a candidate's reasons are made of: its deficiencies and design findings."""
    return [f for f in report.findings if f.severity in ("deficiency", "design")]


def _strict(cmp):
    return json.loads(json.dumps(cmp.to_dict(), allow_nan=False))


def test_every_candidate_has_its_reasons_in_summary_json_and_html():
    est, val = _runs(fc=0.6)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         joint_names=JOINTS, sample_rate=100.0)
    assert list(cmp.reasons) == cmp.ranking == ["full", "rigid+viscous"]
    # the winner, with no deficiency: one positive reason with its rank and criterion
    (won,) = cmp.reasons["full"]
    assert won.startswith("no deficiency: rank 1 of 2") and "aic" in won
    # the deficient non-winner: one reason per finding, and each missing term named with its effect
    # and threshold, in the finding's own numbers
    rep = cmp.reports["rigid+viscous"]
    lost = cmp.reasons["rigid+viscous"]
    assert len(lost) == len(_matter(rep)) >= 2
    # the reasons follow the candidate's ranked records: deficiencies by the share of the residual
    # each explains, strongest first (whiteness last), then the design findings
    records = cmp.deciding["rigid+viscous"]
    assert len(records) == len(lost)
    shares = [d.share for d in records if d.severity == "deficiency" and d.kind != "whiteness"
              and d.share is not None]
    assert shares == sorted(shares, reverse=True)
    by_record = {(f.kind, tuple(JOINTS[j] for j in f.joints), tuple(NAMES[c] for c in f.columns)): f
                 for f in _matter(rep)}
    ordered = [by_record[(d.kind, d.joints, d.columns)] for d in records]
    missing = [(f, r) for f, r in zip(ordered, lost) if f.kind == "regressor_correlation"]
    assert missing
    for f, r in missing:
        term = NAMES[f.columns[0]]
        assert term.startswith("Fc")
        assert r.startswith(f"{JOINTS[f.joints[0]]}: missing term {term} ")
        assert f"{100 * f.effect:.3g} %" in r and f"≥ {100 * f.threshold:g} %" in r
    # summary(): after the decision table, every candidate in ranking order with all its reasons
    text = cmp.summary()
    assert text.index("Decision table") < text.index("Reasons per candidate") < text.index("Verdict:")
    block = text.split("Reasons per candidate", 1)[1].split("\nPer joint", 1)[0]
    assert block.index("1. full") < block.index("2. rigid+viscous")
    for n in cmp.ranking:
        for r in cmp.reasons[n]:
            assert f"- {r}" in block
    # to_dict(): the same reasons, ranking order, strict JSON
    d = _strict(cmp)
    assert d["reasons"] == {n: list(r) for n, r in cmp.reasons.items()}
    assert list(d["reasons"]) == cmp.ranking
    # the HTML comparison page shows them too, escaped
    page = render_report(cmp)
    assert "Reasons per candidate" in page
    plain = re.sub(r'<span class="num">(.*?)</span>', r"\1", page)  # numbers are kept whole by a span
    for n in cmp.ranking:
        for r in cmp.reasons[n]:
            assert f"<li>{html.escape(r, quote=False)}</li>" in plain


def test_accept_is_decided_by_no_finding():
    est, val = _runs(fc=0.6)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         joint_names=JOINTS, sample_rate=100.0)
    v = cmp.verdict
    assert v.decision == "accept" and v.decided_by == ()
    assert v.first_step == "nothing to change: use full"
    d = _strict(cmp)["verdict"]
    assert d["decided_by"] == [] and d["first_step"] == v.first_step
    lines = cmp.summary().split("Verdict: ACCEPT — full\n", 1)[1].splitlines()
    assert lines[0].startswith("  decided by: ") and "aic ranks it first" in lines[0]
    assert lines[1] == "  do first: nothing to change: use full"


def test_refine_is_decided_by_the_winners_deficiency():
    est, val = _runs(fc=0.6)
    cands = _candidates(est, val)
    cmp = dynval.compare(val[2], {"rigid+viscous": cands["rigid+viscous"]}, regressor=val[1],
                         column_names=NAMES, joint_names=JOINTS, sample_rate=100.0)
    v = cmp.verdict
    assert v.decision == "refine" and v.model == "rigid+viscous"
    # every deficiency of the winner but the whiteness ones, which only follow from the others
    # ranked by the share of the residual each explains (conventions §5.10), strongest first
    primary = [f for f in cmp.reports["rigid+viscous"].deficiencies if f.kind != "whiteness"]
    assert primary and sorted((d.kind, d.message) for d in v.decided_by) == sorted((f.kind, f.message) for f in primary)
    primary = [next(f for f in primary if f.message == d.message) for d in v.decided_by]
    shares = [d.share for d in v.decided_by]
    assert None not in shares and shares == sorted(shares, reverse=True)
    assert v.first_reason.startswith(f"first because it explains {100 * shares[0]:.0f} %")
    for d, f in zip(v.decided_by, primary):
        assert isinstance(d, dynval.Decisive)
        assert (d.model, d.severity) == ("rigid+viscous", "deficiency")
        assert d.joints == tuple(JOINTS[j] for j in f.joints) and d.columns == tuple(NAMES[c] for c in f.columns)
    assert any(c.startswith("Fc") for d in v.decided_by for c in d.columns)
    assert v.first_step == primary[0].action and "Fc" in v.first_step
    # the verdict's text: decided by, then what to do first, then the reasons
    text = v.summary()
    assert text == str(v)
    assert text.index("decided by:") < text.index(f"do first: {v.first_step}") < text.index(v.reasons[0])
    for d in v.decided_by:
        assert d.label() in text
    # in the comparison's text the verdict does not repeat the findings printed above it: each
    # message stands once, and the verdict counts them
    full = cmp.summary()
    assert text.split("\n  - ")[0] in full
    for f in cmp.reports["rigid+viscous"].findings:
        assert full.count(f.message) == 1, f.message
    repeated = [r for r in v.reasons if any(r.startswith(f.message) for f in cmp.reports["rigid+viscous"].findings)]
    assert repeated and f"(and the {len(repeated)} finding" in full
    got = _strict(cmp)["verdict"]["decided_by"]
    assert got == [{"model": d.model, "kind": d.kind, "severity": d.severity, "joints": list(d.joints),
                    "columns": list(d.columns), "message": d.message, "share": d.share,
                    "share_basis": d.share_basis, "shared": d.shared} for d in v.decided_by]


def test_redesign_is_decided_by_the_design_finding_said_once():
    est, val = _runs(repeat=True, fc=0.6)
    cmp = dynval.compare(val[2], _candidates(est, val), regressor=val[1], column_names=NAMES,
                         joint_names=JOINTS, estimation={"regressor": est[1], "q": est[0]}, q=val[0],
                         sample_rate=100.0)
    v = cmp.verdict
    assert v.decision == "redesign"
    design = {(f.kind, f.message) for n in cmp.names for f in cmp.reports[n].findings if f.severity == "design"}
    assert [d.kind for d in v.decided_by].count("repeat_trajectory") == 1   # every report has it: said once
    assert {(d.kind, d.message) for d in v.decided_by} == design and len(v.decided_by) == len(design)
    assert all(d.severity == "design" and d.model in cmp.names for d in v.decided_by)
    assert v.decided_by[0].model == cmp.ranking[0]
    repeat = next(f for f in cmp.reports[cmp.ranking[0]].findings if f.kind == "repeat_trajectory")
    if v.decided_by[0].kind == "repeat_trajectory":
        assert v.first_step == repeat.action
    # each candidate's reasons say it, with the share near the estimation trajectory and its threshold
    for n in cmp.names:
        said = [r for r in cmp.reasons[n] if "repeats the estimation run" in r]
        assert len(said) == 1 and said[0].startswith("design: ") and "100 % of it" in said[0] and "> 50 %" in said[0]
    text = cmp.summary()
    assert "decided by:" in text.split("Verdict: REDESIGN", 1)[1]
    assert [d["kind"] for d in _strict(cmp)["verdict"]["decided_by"]] == [d.kind for d in v.decided_by]


def test_reasons_with_infinite_criteria_stay_strict_json():
    # An exact candidate (SSE = 0) has AIC −inf: its reason and the other's Δ are infinite, the JSON strict.
    rng = np.random.default_rng(0)
    t = np.arange(2000) / 100.0
    x = np.sin(2 * np.pi * 0.3 * t)
    tau = 3.0 * x + 0.5 * np.sign(x) + rng.normal(0.0, 0.1, t.size)
    cmp = dynval.compare(tau, {"linear": (3.0 * x, 1), "exact": (tau, 2)}, sample_rate=100.0)
    assert list(cmp.reasons) == cmp.ranking == ["exact", "linear"]
    assert cmp.reasons["exact"][0].startswith("no deficiency: rank 1 of 2") and "(-inf)" in cmp.reasons["exact"][0]
    assert all(cmp.reasons[n] for n in cmp.names)
    d = _strict(cmp)
    assert set(d["reasons"]) == {"exact", "linear"} and d["verdict"]["decision"] == cmp.verdict.decision


def test_low_information_decides_only_for_the_best_candidate():
    """How few effective samples the noise leaves depends on each candidate's residual: a run that
    cannot decide is judged on the candidate the decision is about, never on a worse-ranked one."""
    from types import SimpleNamespace

    from dynval.comparison._compare import _verdict
    from dynval.report._findings import Finding

    def report(*findings):
        defs = [f for f in findings if f.severity == "deficiency"]
        return SimpleNamespace(findings=list(findings), deficiencies=defs, whiteness=None,
                               provenance={"joint_names": ["j1"], "column_names": None,
                                           "conventions": {"level": 0.95}})

    low = Finding(kind="low_information", severity="design", joints=(0,), action="validate on a longer run",
                  message="This run cannot decide.")
    repeat = Finding(kind="repeat_trajectory", severity="design", action="validate on a different trajectory",
                     message="The validation run repeats the estimation run.")
    crit = {"a": 0.0, "b": 1.0}
    # the worse candidate's low_information does not decide: accept the best
    _, v = _verdict(["a", "b"], ["a", "b"], {"a": report(), "b": report(low)}, "aic", crit)
    assert v.decision == "accept" and v.model == "a"
    # the best candidate's does
    _, v = _verdict(["a", "b"], ["a", "b"], {"a": report(low), "b": report()}, "aic", crit)
    assert v.decision == "redesign" and [d.kind for d in v.decided_by] == ["low_information"]
    assert v.decided_by[0].model == "a"
    # any other design finding decides from any candidate
    _, v = _verdict(["a", "b"], ["a", "b"], {"a": report(), "b": report(repeat)}, "aic", crit)
    assert v.decision == "redesign" and v.decided_by[0].model == "b"


def test_low_information_on_unresolved_joints_waits_for_a_resolved_deficiency():
    """A run that finds joint 0 deficient with a term below what it can detect (``unresolved``) cannot
    say which term: that decides (redesign) unless the candidate has a deficiency the run did
    resolve on another joint, which is fixed first (refine), the low_information given with it."""
    from types import SimpleNamespace

    from dynval.comparison._compare import _verdict
    from dynval.report._findings import Finding

    def report(*findings):
        defs = [f for f in findings if f.severity == "deficiency"]
        return SimpleNamespace(findings=list(findings), deficiencies=defs, whiteness=None,
                               provenance={"joint_names": ["j1", "j2", "j3"], "column_names": None,
                                           "conventions": {"level": 0.95}})

    def low(joints, unresolved):
        return Finding(kind="low_information", severity="design", joints=joints, action="validate on a longer run",
                       details={"unresolved": list(unresolved)}, message="This run cannot decide.")

    def deficiency(kind, joint):
        return Finding(kind=kind, severity="deficiency", joints=(joint,), action=f"fix j{joint + 1}",
                       message=f"{kind} on j{joint + 1}.")

    crit = {"a": 0.0}
    physics0, white1 = deficiency("missing_physics", 0), deficiency("whiteness", 1)
    # only the unresolved joint is deficient: the run cannot tell what to add, redesign
    _, v = _verdict(["a"], ["a"], {"a": report(physics0, low((0,), (0,)))}, "aic", crit)
    assert v.decision == "redesign"
    # a whiteness deficiency elsewhere follows from another finding: it resolves nothing
    _, v = _verdict(["a"], ["a"], {"a": report(physics0, white1, low((0,), (0,)))}, "aic", crit)
    assert v.decision == "redesign"
    # a resolved deficiency on joint 1: refine first, the low_information among the reasons
    physics1 = deficiency("missing_physics", 1)
    _, v = _verdict(["a"], ["a"], {"a": report(physics0, physics1, low((0,), (0,)))}, "aic", crit)
    assert v.decision == "refine" and [d.joints for d in v.decided_by] == [("j1",), ("j2",)]
    assert any("This run cannot decide." in r for r in v.reasons)
    # a low_information on a joint where nothing was found (j3) still decides: that joint is untested
    _, v = _verdict(["a"], ["a"], {"a": report(physics0, physics1, low((0, 2), (0,)))}, "aic", crit)
    assert v.decision == "redesign" and v.decided_by[0].joints == ("j1", "j3")


_SPEC = ("(prediction, n_params[, regressor]) or a mapping with 'prediction', 'n_params' and optionally "
         "'regressor', 'model_columns', 'parameters'")


@pytest.mark.parametrize("candidates, message", [
    ({}, "candidates must be a non-empty mapping of names to (prediction, n_params[, regressor]), got {}"),
    ({"": ([1.0, 2.0, 3.5], 1)},
     "candidates must be a mapping whose keys are non-empty strings, got {'': ([1.0, 2.0, 3.5], 1)}"),
    ({1: ([1.0, 2.0, 3.5], 1)},
     "candidates must be a mapping whose keys are non-empty strings, got {1: ([1.0, 2.0, 3.5], 1)}"),
    ({"x": {"prediction": [1.0, 2.0, 3.5], "n_params": 1, "regresor": None}},
     f"candidates['x'] must be {_SPEC}, got {{'prediction': [1.0, 2.0, 3.5], 'n_params': 1, 'regresor': None}}"),
    ({"x": {"prediction": [1.0, 2.0, 3.5]}}, f"candidates['x'] must be {_SPEC}, got {{'prediction': [1.0, 2.0, 3.5]}}"),
    ({"x": {"n_params": 1}}, f"candidates['x'] must be {_SPEC}, got {{'n_params': 1}}"),
    ({"x": ([1.0, 2.0, 3.5], 1, None, None)}, f"candidates['x'] must be {_SPEC}, got ([1.0, 2.0, 3.5], 1, None, None)"),
    ({"x": ([1.0, 2.0, 3.5], 1.5)}, f"candidates['x'] must be {_SPEC}, got ([1.0, 2.0, 3.5], 1.5)"),
])
def test_bad_candidates_are_refused_by_name_with_the_value(candidates, message):
    """The contract's InvalidParameter: the parameter, what it must be and the value given."""
    with pytest.raises(dynval.InvalidParameter) as info:
        dynval.compare([1.0, 2.0, 3.0], candidates)
    assert str(info.value) == message


def test_compare_refuses_a_shared_n_params_and_a_criterion_it_cannot_compute():
    with pytest.raises(dynval.InvalidParameter) as info:
        dynval.compare([1.0, 2.0, 3.0], {"x": ([1.0, 2.0, 3.5], 1)}, n_params=2)
    assert str(info.value) == "n_params must be given per candidate, not to compare, got 2"
    tau = np.random.default_rng(0).normal(size=200)
    with pytest.raises(dynval.InvalidParameter) as info:
        dynval.compare(tau, {"x": (0.9 * tau, 1)}, criterion="aic_neff", max_lag=0)
    assert str(info.value) == "criterion must be one of 'aic', 'bic', 'aicc' when max_lag=0 (no N_eff), got 'aic_neff'"


def test_a_candidate_brings_its_own_regressor_before_the_shared_one():
    """The third element of a candidate (or its mapping's 'regressor') is the regressor its report
    tests; the shared ``regressor=`` serves only the candidates without one."""
    rng = np.random.default_rng(1)
    y = rng.normal(size=(500, 1, 2))
    tau = y[:, 0, :] @ [1.0, 0.5] + rng.normal(0, 0.1, 500)
    pred = y[:, 0, :1] @ [1.0]
    own = {"tuple": (pred, 1, y), "mapping": {"prediction": pred, "n_params": 1, "regressor": y}}
    for name, spec in own.items():
        r = dynval.compare(tau, {name: spec}).reports[name]
        assert r.cross_correlation is not None and r.provenance["n_regressor_columns"] == 2, name
    shared = y[:, :, :1]
    r = dynval.compare(tau, {"tuple": (pred, 1, y)}, regressor=shared).reports["tuple"]
    assert r.provenance["n_regressor_columns"] == 2
    r = dynval.compare(tau, {"two": (pred, 1)}, regressor=shared).reports["two"]
    assert r.provenance["n_regressor_columns"] == 1


def test_the_table_says_what_was_not_analysed_and_a_negligible_bias():
    rng = np.random.default_rng(2)
    tau = rng.normal(size=(3000, 1))
    row = dynval.compare(tau, {"a": (tau + rng.normal(0, 0.1, tau.shape), 1)}, max_lag=0).table["pooled"]["a"]
    assert (row["whiteness"], row["bias"]) == ("not analysed", "not analysed")
    assert set(row) >= {"n_params", "rmse", "vaf", "fit_percent", "r2", "aic", "bic", "aicc", "akaike_weight"}
    # a bias that is significant but small (0.05 of the RMSE < 0.25) is a note: "negligible"
    e = rng.normal(0, 1.0, tau.shape) + 0.05
    cmp = dynval.compare(tau, {"a": (tau - e, 1)})
    assert [f.severity for f in cmp.reports["a"].findings if f.kind == "bias"] == ["note"]
    assert cmp.table["pooled"]["a"]["bias"] == "negligible"
    # white residuals without a bias: "white", "none"
    cmp = dynval.compare(tau, {"a": (tau - rng.normal(0, 1.0, tau.shape), 1)})
    assert (cmp.table["pooled"]["a"]["whiteness"], cmp.table["pooled"]["a"]["bias"]) == ("white", "none")


def test_akaike_weights_are_nan_when_no_candidate_has_a_criterion():
    """AICc is undefined (nan) when p ≥ n − 1: no weight can be given, rather than a division by zero."""
    tau = np.random.default_rng(3).normal(size=20)
    cmp = dynval.compare(tau, {"a": (0.5 * tau, 19), "b": (0.4 * tau, 25)}, criterion="aicc", max_lag=0)
    assert all(math.isnan(cmp.table["pooled"][n]["akaike_weight"]) for n in ("a", "b"))


def test_decisive_labels_name_the_place_and_the_owner():
    from dynval.comparison._compare import Decisive

    assert Decisive("friction", "oscillation", "deficiency", joints=("shoulder",)).label() == (
        "oscillation on shoulder (deficiency of friction)")
    assert Decisive("rigid", "excitation", "design", joints=("elbow",), columns=("Fv1", "Fc1")).label() == (
        "excitation on elbow, Fv1, Fc1 (design of rigid)")
    assert Decisive("", "whiteness", "design").label() == "whiteness (design of the comparison)"


def test_comparison_serialises_every_part_under_its_documented_key():
    rng = np.random.default_rng(4)
    tau = rng.normal(size=400)
    cmp = dynval.compare(tau, {"a": (0.9 * tau, 1), "b": (0.8 * tau, 2)}, sample_rate=100.0)
    d = cmp.to_dict()
    assert set(d) == {"names", "ranking", "criterion", "table", "verdict", "findings", "reasons", "deciding",
                      "reports"}
    assert (d["names"], d["ranking"], d["criterion"]) == (["a", "b"], cmp.ranking, "aic")
    assert set(d["table"]) == {"pooled", "per_joint"} and set(d["reports"]) == {"a", "b"}
    assert d["reports"]["a"] == json.loads(json.dumps(cmp.reports["a"].to_dict()))
    assert d["findings"] == [f.to_dict() for f in cmp.findings]
    assert set(d["verdict"]) == {"decision", "model", "reasons", "decided_by", "first_step", "first_reason"}
    assert (d["verdict"]["model"], d["verdict"]["reasons"]) == (cmp.verdict.model, list(cmp.verdict.reasons))
    assert "reports" not in cmp.to_dict(reports=False)
    # two-space indentation by default, one line on request; strict JSON throughout
    text = cmp.to_json()
    assert text.startswith('{\n  "names": [\n    "a",') and json.loads(text) == json.loads(cmp.to_json(indent=None))
    assert "\n" not in cmp.to_json(indent=None)
    def bare(token):
        raise AssertionError(f"bare {token} in the JSON")

    json.loads(text, parse_constant=bare)  # non-finite numbers are written as strings, never bare

