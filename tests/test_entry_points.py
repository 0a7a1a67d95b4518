"""Every door, the same verdict: each entry point on one shared set of cases (contract §4.1).

``dynval.validate`` is the reference. Every other entry point (``compare`` on one candidate, the
stream accumulator, ``dynval validate --stream``, ``dynval.fleet.validate_many``,
``dynval.dask.validate``) must find the same findings, by kind and joints, less exactly the kinds of
the tests its declaration (:mod:`dynval.coverage`) says it does not run; a streamed report's own
``not_tested`` must be that declaration. The table of docs/contract.md §4.1 is the declaration's.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval import coverage
from dynval.cli import main
from dynval.identify import identify
from dynval.simulate import simulate
from dynval.stream import ValidationAccumulator

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Case:
    name: str
    tau: np.ndarray
    pred: np.ndarray
    n_params: int
    regressor: np.ndarray | None = None
    sample_rate: float | None = None
    q: np.ndarray | None = None  # the streams take it with each chunk, dask not at all

    @property
    def given(self) -> set[str]:
        return {"lags"} | ({"regressor"} if self.regressor is not None else set()) | (
            {"q"} if self.q is not None else set())

    def keywords(self) -> dict:
        # with a rate, validate's default max_lag follows the motion's band, which a stream does not
        # know (contract §4.1): every entry point gets the same explicit max_lag
        return {"max_lag": 50} | ({} if self.sample_rate is None else {"sample_rate": self.sample_rate})

    def whole(self) -> dict:
        """The keywords of the entry points that take whole series (q among them)."""
        return self.keywords() | ({} if self.q is None else {"q": self.q})


def _cases() -> list[Case]:
    rng = np.random.default_rng(36)
    tau = rng.standard_normal((4000, 3))
    reversed_joint = tau + 0.3 * rng.standard_normal((4000, 3))
    reversed_joint[:, 2] = tau[::-1, 2]
    demo = []
    for scenario, name in (("friction", "rigid"), ("friction", "friction"), ("flexible", "friction")):
        d = simulate(scenario, seed=1, n_samples=3000)
        est, val = d.estimation, d.validation
        fit = identify(est.regressors[name], est.tau_meas)
        demo.append(Case(f"demo {scenario}, {name} model", val.tau_meas, fit.predict(val.regressors[name]), fit.rank,
                         val.full_regressor, d.sample_rate))
    # the physics test on every door that takes q: the demo's rigid model lacks the friction
    d = simulate("friction", seed=1, n_samples=3000)
    fit = identify(d.estimation.regressors["rigid"], d.estimation.tau_meas)
    val = d.validation
    demo.append(Case("demo friction, rigid model, with q", val.tau_meas, fit.predict(val.regressors["rigid"]),
                     fit.rank, None, d.sample_rate, val.q))
    return [
        Case("README offset (pred = tau + 0.01)", tau, tau + 0.01, 10),
        Case("a good model, white noise", tau, tau + 0.1 * rng.standard_normal((4000, 3)), 3),
        Case("one joint worse than a constant", tau, reversed_joint, 3),
        *demo,
    ]


CASES = _cases()


def _pairs(findings) -> set[tuple[str, tuple[int, ...]]]:
    return {(f.kind, tuple(f.joints)) for f in findings}


def _excused(entry: str, case: Case, reference) -> set[str]:
    decimated = reference.whiteness is not None and reference.whiteness["decimation"] > 1
    return coverage.excused_kinds(entry, case.given, decimated)


def _compared(findings: set, excused: set[str]) -> set[tuple[str, tuple[int, ...]]]:
    return {p for p in findings if p[0] not in excused}


def _streamed(case: Case):
    acc = ValidationAccumulator(n_params=case.n_params, **case.keywords())
    for a in range(0, case.tau.shape[0], 777):
        acc.update(case.tau[a:a + 777], case.pred[a:a + 777],
                   None if case.regressor is None else case.regressor[a:a + 777],
                   q=None if case.q is None else case.q[a:a + 777])
    return acc.result()


def _cli(case: Case, tmp_path: Path, capsys) -> dict:
    files = {"tau": case.tau, "pred": case.pred, "reg": case.regressor, "q": case.q}
    for name, array in files.items():
        if array is not None:
            np.save(tmp_path / f"{name}.npy", array)
    argv = ["validate", str(tmp_path / "tau.npy"), str(tmp_path / "pred.npy"), "--n-params", str(case.n_params),
            "--stream", "--json", "--chunk-rows", "777", "--max-lag", "50"]
    if case.regressor is not None:
        argv += ["--regressor", str(tmp_path / "reg.npy")]
    if case.q is not None:
        argv += ["--q", str(tmp_path / "q.npy")]
    if case.sample_rate is not None:
        argv += ["--sample-rate", str(case.sample_rate)]
    assert main(argv) in (0, 1)
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_every_entry_point_finds_what_validate_finds(case, tmp_path, capsys):
    reference = dynval.validate(case.tau, case.pred, n_params=case.n_params, regressor=case.regressor,
                                **case.whole())
    got: dict[str, set] = {}
    not_tested: dict[str, list] = {}

    cmp = dynval.compare(case.tau, {"m": (case.pred, case.n_params, case.regressor)}, **case.whole())
    got["compare"] = _pairs(cmp.reports["m"].findings)

    streamed = _streamed(case)
    got["stream"] = _pairs(streamed.findings)
    not_tested["stream"] = list(streamed.provenance["not_tested"])

    cli = _cli(case, tmp_path, capsys)
    got["cli_stream"] = {(f["kind"], tuple(f["joints"])) for f in cli["findings"]}
    not_tested["cli_stream"] = cli["provenance"]["not_tested"]

    if "dask" in _available():
        import dask.array as da

        from dynval.dask import validate as dask_validate

        chunked = dask_validate(
            da.from_array(case.tau, chunks=(1000, -1)), da.from_array(case.pred, chunks=(1000, -1)),
            n_params=case.n_params, regressor=None if case.regressor is None else da.from_array(case.regressor),
            **case.keywords())
        got["dask"] = _pairs(chunked.findings)
        not_tested["dask"] = list(chunked.provenance["not_tested"])

    for entry, pairs in got.items():
        excused = _excused(entry, case, reference)
        assert _compared(pairs, excused) == _compared(_pairs(reference.findings), excused), entry
        # a test the entry point does not run gives no finding (whiteness runs, at the logged rate)
        assert not {kind for kind, _ in pairs} & (excused - {"whiteness"}), entry
    for entry, listed in not_tested.items():
        # what the declaration says, and the tests left out for a reason of the data (dynval.coverage.RUNTIME);
        # dask takes no q (its blocks' physics sums do not merge), so its report is of the inputs without it
        runtime = {t["test"]: t["why"] for t in listed if t["test"] in coverage.RUNTIME}
        given = case.given - {"q"} if entry == "dask" else case.given
        assert listed == coverage.not_tested(entry, given, runtime), entry
    if "dask" in not_tested and case.regressor is None:  # blocks of 1000 rows merged without breaks
        assert {"test": "spectrum", "kinds": ["oscillation"], "why": coverage.OFF_GRID} in not_tested["dask"]

    # the fleet's row of a log: the kinds of its deficiency and design findings
    from dynval.fleet import validate_many

    paths = {}
    for name, array in (("tau_meas", case.tau), ("tau_pred", case.pred), ("regressor", case.regressor),
                        ("q", case.q)):
        if array is not None:
            paths[name] = str(tmp_path / f"fleet_{name}.npy")
            np.save(paths[name], array)
    fleet = validate_many([{"robot": "r01", "time": "2026-01-01", "n_params": case.n_params, **paths}],
                          scheduler="single", progress=False, **case.keywords())
    row = fleet.logs[0]
    assert row.error is None
    kinds = {f.kind for f in reference.findings if f.severity in ("deficiency", "design")}
    assert set(row.kinds) == kinds - _excused("fleet", case, reference)


def _available() -> set[str]:
    try:
        import dask.array  # noqa: F401
    except ImportError:
        return set()
    return {"dask"}


def test_the_cases_exercise_what_they_excuse():
    """The shared cases reach findings the streams do not test (so the excuse is used) and findings
    every entry point tests (so the comparison is not empty)."""
    kinds = set()
    for case in CASES:
        kinds |= {f.kind for f in dynval.validate(case.tau, case.pred, n_params=case.n_params,
                                                    regressor=case.regressor, **case.whole()).findings}
    # missing_physics: what the streams now test from q (conventions §5.2, "On a stream")
    assert {"bias", "worse_than_constant", "whiteness", "oscillation", "regressor_correlation",
            "missing_physics"} <= kinds


def test_the_contract_table_is_the_declaration():
    text = (ROOT / "docs" / "contract.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- coverage-table:start -->\n(.*?)\n<!-- coverage-table:end -->", text, re.S)
    assert found is not None, "docs/contract.md §4.1 has no coverage table"
    assert found.group(1) == coverage.table(), "run python -m dynval.coverage and paste its table"


def test_the_declaration_names_known_tests_and_kinds():
    from dynval.report._findings import KINDS

    names = {t.name for t in coverage.TESTS}
    assert len(names) == len(coverage.TESTS)
    assert set(coverage.ENTRY_POINTS) == set(coverage.NOT_RUN)
    for entry, left_out in coverage.NOT_RUN.items():
        assert set(left_out) <= names, entry
    for t in coverage.TESTS:
        assert set(t.kinds) <= set(KINDS), t.name
        assert set(t.needs) <= set(coverage.INPUTS), t.name
    tested = {k for t in coverage.TESTS for k in t.kinds}
    assert set(KINDS) - tested <= {"processing_band", "physical_consistency"}
