"""The corpus linter on hostile input: every defect is a listed problem, never a traceback,
and nothing found beside the corpus being checked (code, schema) is trusted."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from dynval.golden import corpus_dir, load_family
from dynval.golden._lint import lint

pytest.importorskip("jsonschema")
pytest.importorskip("mpmath")


def write_corpus(root, content, family="errors"):
    """A corpus directory ``root/vectors`` holding one family file with ``content`` (str or bytes)."""
    vectors = root / "vectors"
    vectors.mkdir(exist_ok=True)
    path = vectors / f"{family}.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return vectors


def errors_doc():
    return load_family("errors")


def without_tcid():
    doc = errors_doc()
    del doc["testGroups"][0]["tests"][0]["tcId"]
    return json.dumps(doc)


def non_object_test():
    doc = errors_doc()
    doc["testGroups"][0]["tests"][0] = 5
    doc["testGroups"].append("group")
    return json.dumps(doc)


def overflowing_literal():
    doc = errors_doc()
    doc["numberOfTests"] = 424242.5  # a stand-in for the literal json.dumps cannot write
    return json.dumps(doc).replace("424242.5", "1e999")


def overflowing_tolerance():
    doc = load_family("norms")
    test = doc["testGroups"][0]["tests"][0]
    key = next(iter(test["tolerance"]))
    test["tolerance"][key] = 424242.5
    return json.dumps(doc).replace("424242.5", "1e999"), f"/testGroups/0/tests/0/tolerance/{key}"


# (name, file content, text every listed problem of the file must show, place)
HOSTILE = [
    ("missing-tcId", without_tcid, "'tcId' is a required property", "/testGroups/0/tests/0"),
    ("non-object-entry", non_object_test, "is not of type 'object'", "/testGroups/0/tests/0"),
    ("top-level-list", lambda: "[1, 2, 3]", "is not of type 'object'", "at /:"),
    ("invalid-utf8", lambda: b'{"family": "errors", "comment": "\xff\xfe"}', "not UTF-8", "byte 33"),
    ("deep-nesting", lambda: "[" * 100000 + "]" * 100000, "nested deeper than", "line 1 column 65"),
    ("overflow", overflowing_literal, "overflows float64", "at /numberOfTests"),
    ("nan-token", lambda: '{"family": "errors", "numberOfTests": NaN}', "non-standard JSON token NaN", "errors"),
    ("truncated", lambda: '{"family": "err', "not strict JSON", "line 1 column"),
]


@pytest.mark.parametrize(("name", "make", "says", "place"), HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_file_is_a_listed_problem(tmp_path, name, make, says, place):
    corpus = write_corpus(tmp_path, make())
    problems = lint(corpus, families=["errors"])
    assert any(says in p and place in p for p in problems), problems
    assert all(p.startswith("errors") for p in problems), problems
    # the command line: the problem listed, exit 1, no traceback
    done = subprocess.run([sys.executable, "-m", "dynval.golden", "lint", "--corpus", str(corpus), "--families",
                           "errors"], check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "Traceback" not in done.stderr and says in done.stdout, done.stdout + done.stderr


def test_a_value_too_large_for_float64_is_a_problem(tmp_path):
    text, place = overflowing_tolerance()
    corpus = write_corpus(tmp_path, text, family="norms")
    problems = lint(corpus, families=["norms"])
    assert any(place in p and "overflows float64" in p for p in problems), problems


def test_a_permissive_schema_beside_the_corpus_is_not_used(tmp_path):
    (tmp_path / "schema").mkdir()
    (tmp_path / "schema" / "corpus_v1.schema.json").write_text("{}", encoding="utf-8")
    doc = errors_doc()
    doc["testGroups"][0]["tests"][0]["inputs"]["bogus"] = "garbage"
    corpus = write_corpus(tmp_path, json.dumps(doc))
    problems = lint(corpus, families=["errors"])
    assert any("schema" in p and "/testGroups/0/tests/0/inputs" in p for p in problems), problems


def test_a_schema_given_explicitly_is_used(tmp_path):
    permissive = tmp_path / "permissive.json"
    permissive.write_text('{"type": "object"}', encoding="utf-8")
    doc = errors_doc()
    doc["testGroups"][0]["tests"][0]["inputs"]["bogus"] = "garbage"
    corpus = write_corpus(tmp_path, json.dumps(doc))
    assert lint(corpus, families=["errors"], schema=permissive) == []


@pytest.mark.parametrize(
    ("content", "says"),
    [
        (None, "cannot read"),
        ('{"type": ', "not strict JSON"),
        (b"\xff{}", "not UTF-8"),
        ('{"type": 5}', "not a valid JSON Schema"),
        ("[" * 100000 + "]" * 100000, "nested deeper than"),
        ('{"$ref": "https://example.invalid/schema.json"}', "points outside the file"),
    ],
    ids=["missing", "not-json", "not-utf8", "invalid-schema", "deep", "unresolvable-ref"],
)
def test_a_bad_schema_file_is_a_listed_problem(tmp_path, content, says):
    schema = tmp_path / "bad.schema.json"
    if isinstance(content, bytes):
        schema.write_bytes(content)
    elif content is not None:
        schema.write_text(content, encoding="utf-8")
    corpus = write_corpus(tmp_path, json.dumps(errors_doc()))
    problems = lint(corpus, families=["errors"], schema=schema)
    assert any(str(schema) in p and says in p for p in problems), problems
    done = subprocess.run([sys.executable, "-m", "dynval.golden", "lint", "--corpus", str(corpus), "--families",
                           "errors", "--schema", str(schema)], check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stdout + done.stderr
    assert says in done.stdout


PLANTED_GENERATOR = """\
import pathlib
pathlib.Path(__file__).with_name("generator-ran").write_text("code beside the corpus was executed")

def build(families=()):
    return {}
"""


@pytest.mark.parametrize("reproduce", [[], ["--reproduce"]], ids=["default", "reproduce"])
def test_code_beside_the_corpus_is_never_run(tmp_path, reproduce):
    (tmp_path / "generate.py").write_text(PLANTED_GENERATOR, encoding="utf-8")
    corpus = write_corpus(tmp_path, (corpus_dir() / "errors.json").read_text(encoding="utf-8"))
    done = subprocess.run([sys.executable, "-m", "dynval.golden", "lint", "--corpus", str(corpus), "--families",
                           "errors", *reproduce], check=False, capture_output=True, text=True, timeout=300)
    assert not (tmp_path / "generator-ran").exists()
    # the copy is current: the project's own generator reproduces it
    assert done.returncode == 0, done.stdout + done.stderr
    assert lint(corpus, families=["errors"], reproduce=True) == []
    assert not (tmp_path / "generator-ran").exists()


def test_reproduce_is_an_explicit_option(tmp_path):
    doc = errors_doc()
    doc["testGroups"][0]["tests"][0]["comment"] += " (edited)"
    corpus = write_corpus(tmp_path, json.dumps(doc, indent=1))
    assert lint(corpus, families=["errors"]) == []  # schema and structure only
    problems = lint(corpus, families=["errors"], reproduce=True)
    assert any("differs from a fresh generation in comment" in p for p in problems), problems
