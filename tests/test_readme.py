"""The README's Python examples run and say what the README says they say."""

from __future__ import annotations

import pathlib
import re

import pytest

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def _blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_examples_run(capsys):
    blocks = _blocks()
    assert len(blocks) == 4
    namespace: dict = {}
    for code in blocks:
        exec(compile(code, str(README), "exec"), namespace)
    assert namespace["report"].deficiencies == []
    assert [f.kind for f in namespace["report"].findings] == ["pooling"]
    cmp = namespace["cmp"]
    assert (cmp.ranking, cmp.verdict.decision) == (["friction", "rigid"], "accept")
    assert "Verdict: ACCEPT" in capsys.readouterr().out
    assert abs(namespace["streamed"].pooled["r2"] - namespace["report"].pooled["r2"]) < 1e-14
    real = namespace["real"]
    assert real.timing["sample_rate"] == 200.0 and real.timing["irregular_steps"] > 0
    assert real.provenance["conventions"]["max_lag_source"].startswith("motion")
    assert {j for f in real.findings if f.kind == "missing_physics" and f.severity == "deficiency"
            for j in f.joints} >= {0, 1, 2, 3}
    assert any(f.kind == "time_stamps" for f in real.findings)
    # advice relative to the model's columns (issue 34): the decoupled model holds q̇_j and sign q̇_j,
    # so it is never told to add them; joint 0 is told the coupling of its gravity; both runs'
    # derivatives come from one filter, handed to estimation= too
    named = {f.joints[0]: f for f in real.findings if f.kind == "missing_physics" and f.severity == "deficiency"}
    assert named[0].details["relation"] == "coupling" and "coupling" in named[0].action
    for j in (2, 3, 4):
        assert named[j].details["term"] in ("viscous", "coulomb") and not named[j].action.startswith("add"), j
    assert not any(f.action.startswith(("add viscous", "add Coulomb")) for f in real.findings)
    assert real.physics["derivative_source"] == "given"


@pytest.mark.parametrize("scenario, decision", [("friction", "accept"), ("repeat", "redesign")])
def test_demo_verdicts(scenario, decision):
    from dynval.demo import run_demo

    result = run_demo(scenario=scenario, progress=lambda *_: None)
    cmp = getattr(result, "comparison", None)
    assert cmp is not None and cmp.verdict.decision == decision
