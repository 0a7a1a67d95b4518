"""The README's Python examples each run when pasted alone, and say what the README says they say;
its two commands are the ones the project's scripts run."""

from __future__ import annotations

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def _blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def _run_alone(code: str) -> dict:
    namespace: dict = {"__name__": "__main__"}  # a fresh interpreter's globals: nothing from another block
    exec(compile(code, str(README), "exec"), namespace)
    return namespace


def test_the_readme_is_a_landing_page():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 150
    assert "bash scripts/test.sh" in text and 'python3 -m pip install ".[plot]" && python3 -m dynval demo' in text
    assert "docs/_build/html/index.html" in text
    assert "bash scripts/test.sh" in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_the_first_example_runs_alone(capsys):
    first = _blocks()[0]
    ns = _run_alone(first)
    assert ns["report"].deficiencies == []
    assert [f.kind for f in ns["report"].findings] == ["pooling"]
    out = capsys.readouterr().out
    assert "dynval validation report" in out


def test_the_real_robot_example_runs_alone(capsys):
    pytest.importorskip("scipy")
    blocks = _blocks()
    assert len(blocks) == 2
    ns = _run_alone(blocks[1])
    real = ns["real"]
    assert real.timing["sample_rate"] == 200.0 and real.timing["irregular_steps"] > 0
    assert real.provenance["conventions"]["max_lag_source"].startswith("motion")
    assert any(f.kind == "time_stamps" for f in real.findings)
    assert {j for f in real.findings if f.kind == "missing_physics" and f.severity == "deficiency"
            for j in f.joints} >= {0, 1, 2, 3}
    # advice relative to the model's columns (issue 34): the decoupled model holds q̇_j and sign q̇_j,
    # so it is never told to add them; joint 0 is told the coupling of its gravity; both runs'
    # derivatives come from one filter, handed to estimation= too
    named = {f.joints[0]: f for f in real.findings if f.kind == "missing_physics" and f.severity == "deficiency"}
    assert named[0].details["relation"] == "coupling" and "coupling" in named[0].action
    # the model's own q̇_j refitted again adds nothing (the naming refit carries each column in the
    # estimation run's units: a run-by-run scaling made it look like a 23–84 % gain on joints 2–4)
    for t in real.physics["tests"]:
        if t["refit_run"] == "estimation":
            assert abs(t["refit_shares"]["viscous"]) < 1e-6, t["joint"]
    for f in named.values():
        if f.details["term"] in ("viscous", "coulomb", "inertia"):
            assert not f.action.startswith("add ") or f.details["relation"] in ("coupling", "local"), f.action
    assert not any(f.action.startswith(("add viscous", "add Coulomb")) for f in real.findings)
    assert real.physics["derivative_source"] == "given"
    out = capsys.readouterr().out
    assert "Identification: least squares" in out and "P>|t|" in out


@pytest.mark.parametrize("scenario, decision", [("friction", "accept"), ("repeat", "redesign")])
def test_demo_verdicts(scenario, decision):
    from dynval.demo import run_demo

    result = run_demo(scenario=scenario, progress=lambda *_: None)
    cmp = getattr(result, "comparison", None)
    assert cmp is not None and cmp.verdict.decision == decision


def test_every_page_the_readme_links_exists():
    text = README.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if "://" not in target:
            assert (ROOT / target).exists(), target
