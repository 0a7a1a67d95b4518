"""The optional ``streaming`` family: accumulate vectors, the runner's optional-family rule, and
mutations of the accumulator that the family must catch."""

from __future__ import annotations

import io
import json
import pathlib
import shutil
import sys

import pytest

import dynval
from dynval.conform import main
from dynval.golden import OPTIONAL_FAMILIES, check_case, corpus_dir, iter_cases, run_operation
from dynval.stream import ValidationAccumulator
from ports.tiny_corpus import write_tiny_corpus

PORTS = pathlib.Path(__file__).with_name("ports")
STREAMING = list(iter_cases(families=["streaming"]))


def _failures(backend: str = "python") -> list[str]:
    failed = []
    for case in STREAMING:
        try:
            outputs = run_operation(case.operation, case.inputs, case.conventions, backend=backend)
            ok, _ = check_case(case, outputs)
        except dynval.InputError as exc:
            ok, _ = check_case(case, error_kind=exc.kind)
        if not ok:
            failed.append(case.id)
    return failed


def test_streaming_is_the_only_optional_family_and_has_valid_and_invalid_vectors():
    assert OPTIONAL_FAMILIES == ("streaming",)
    results = {c.result for c in STREAMING}
    assert results == {"valid", "invalid"} and len(STREAMING) >= 25
    merges = {c.conventions["merge"] for c in STREAMING if c.result == "valid"}
    assert merges == {"none", "left", "right", "tree"}


def test_both_accumulators_pass_the_streaming_family(backend):  # conftest: python and cpp
    assert _failures(backend) == []


def test_an_accumulator_that_breaks_at_every_merge_is_caught(monkeypatch):
    merge = ValidationAccumulator.merge

    def merge_with_a_break(self, other):
        self.break_segment()  # lags no longer join across the junction
        return merge(self, other)

    monkeypatch.setattr(ValidationAccumulator, "merge", merge_with_a_break)
    failed = _failures()
    merged = {c.id for c in STREAMING if c.result == "valid" and c.conventions["merge"] != "none"
              and len(c.conventions["chunks"]) > 1}
    assert failed and set(failed) <= merged


def test_an_accumulator_that_merges_in_the_wrong_order_is_caught(monkeypatch):
    merge = ValidationAccumulator.merge

    def swapped(self, other):
        joined = merge(other.copy(), self)  # the later rows first
        self.__dict__.update(joined.__dict__)
        return self

    monkeypatch.setattr(ValidationAccumulator, "merge", swapped)
    assert _failures()


def test_an_accumulator_that_ignores_records_is_caught(monkeypatch):
    monkeypatch.setattr(ValidationAccumulator, "break_segment", lambda self: None)
    failed = _failures()
    with_records = {c.id for c in STREAMING if c.result == "valid" and c.conventions["segments"] is not None}
    assert failed and set(failed) <= with_records


def test_the_driver_checks_n_params_before_max_lag():
    # golden/operations.json lists accumulate's parameters in this order (the Java driver follows it)
    case = next(c for c in STREAMING if c.result == "valid")
    inputs = {**case.inputs, "n_params": -1, "max_lag": 10**6}
    with pytest.raises(dynval.InvalidParameter, match="n_params"):
        run_operation("accumulate", inputs, case.conventions)


# --------------------------------------------------------------------------- the runner's rule


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    """The tiny corpus of test_conform plus the real streaming family."""
    directory = write_tiny_corpus(tmp_path_factory.mktemp("corpus"))
    shutil.copy(pathlib.Path(corpus_dir()) / "streaming.json", directory / "streaming.json")
    return str(directory)


def _conform(corpus, tmp_path, *options, without=""):
    # not --strict: the tiny corpus holds one case protocol 1 cannot carry (skipped)
    report = tmp_path / "report.json"
    out, err = io.StringIO(), io.StringIO()
    command = [sys.executable, str(PORTS / "oracle.py"), "--corpus", corpus, "--without", without]
    code = main([*options, "--quiet", "--corpus", corpus, "--report", str(report), "--", *command],
                stdout=out, stderr=err)
    return code, out.getvalue(), json.loads(report.read_text())


def test_a_port_without_accumulate_is_not_asked_for_the_optional_family(corpus, tmp_path):
    code, out, report = _conform(corpus, tmp_path, without="accumulate")
    assert code == 0, out
    assert report["counts"]["total"]["skipped"] == 1  # the one case protocol 1 cannot carry
    assert report["unclaimed_families"] == ["streaming"] and "streaming" not in report["counts"]
    assert not any(c["family"] == "streaming" for c in report["cases"])
    assert "not claimed by the port" in out and "streaming" in out


def test_naming_the_optional_family_makes_it_required(corpus, tmp_path):
    code, _, report = _conform(corpus, tmp_path, "--families", "streaming", "--strict", without="accumulate")
    assert code == 1
    assert report["unclaimed_families"] == [] and report["counts"]["streaming"]["skipped"] == len(STREAMING)


def test_a_port_with_accumulate_runs_the_optional_family(corpus, tmp_path):
    code, out, report = _conform(corpus, tmp_path)
    assert code == 0, out
    assert report["unclaimed_families"] == [] and report["counts"]["streaming"]["passed"] == len(STREAMING)


def test_only_optional_families_may_be_left_out(corpus, tmp_path):
    # a port declaring nothing of norms is still sent the norms vectors: skipped, a --strict failure
    _, _, report = _conform(corpus, tmp_path, without="residuals,sse,rmse,max_abs_error")
    assert report["counts"]["norms"]["skipped"] > 0 and report["unclaimed_families"] == []


def test_the_matrix_marks_an_unclaimed_optional_family(corpus):
    out = io.StringIO()
    oracle = f"{sys.executable} {PORTS / 'oracle.py'} --corpus {corpus}"
    code = main(["--matrix", "--quiet", "--corpus", corpus, "--port", f"full={oracle}",
                 "--port", f"plain={oracle} --without accumulate"], stdout=out, stderr=io.StringIO())
    assert code == 0, out.getvalue()
    rows = {line.split("|")[1].strip(): [cell.strip() for cell in line.split("|")[2:-1]]
            for line in out.getvalue().splitlines() if line.startswith("| full") or line.startswith("| plain")}
    head = [cell.strip(" `") for cell in out.getvalue().splitlines()[0].split("|")[2:-1]]
    column = head.index("streaming")
    assert rows["full"][column] == f"{len(STREAMING)}/{len(STREAMING)}"
    assert rows["plain"][column] == "—"
