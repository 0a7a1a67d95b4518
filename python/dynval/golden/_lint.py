"""Corpus linter: schema, identifiers, counts, flags legend and reproducibility of every value."""

from __future__ import annotations

import importlib.util
import json
import pathlib
import sys
from types import ModuleType
from typing import Sequence

from ._loader import FAMILIES, corpus_dir as default_corpus_dir, golden_root, schema_path


def load_generator(corpus: pathlib.Path | None = None) -> ModuleType:
    """Import ``generate.py`` next to ``corpus`` (or the shipped one) as a module."""
    candidates = []
    if corpus is not None:
        candidates.append(pathlib.Path(corpus).resolve().parent / "generate.py")
    candidates.append(golden_root() / "generate.py")
    for path in candidates:
        if path.is_file():
            spec = importlib.util.spec_from_file_location("dynval_golden_generate", path)
            module = importlib.util.module_from_spec(spec)
            sys.modules.setdefault("dynval_golden_generate", module)
            spec.loader.exec_module(module)
            return module
    msg = "generate.py not found next to the corpus"
    raise FileNotFoundError(msg)


def _structure_problems(family: str, doc: dict) -> list[str]:
    problems = []
    if doc.get("family") != family:
        problems.append(f"{family}: field 'family' is {doc.get('family')!r}")
    tests = [t for g in doc.get("testGroups", []) for t in g.get("tests", [])]
    if doc.get("numberOfTests") != len(tests):
        problems.append(f"{family}: numberOfTests is {doc.get('numberOfTests')}, the file has {len(tests)} tests")
    seen: set[int] = set()
    for t in tests:
        if t["tcId"] in seen:
            problems.append(f"{family}: tcId {t['tcId']} is not unique")
        seen.add(t["tcId"])
    notes = doc.get("notes", {})
    used = {f for t in tests for f in t.get("flags", [])}
    for flag in sorted(used - set(notes)):
        problems.append(f"{family}: flag {flag!r} is used but not explained in notes")
    for flag in sorted(set(notes) - used):
        problems.append(f"{family}: note {flag!r} is never used")
    for t in tests:
        if not t.get("flags"):
            problems.append(f"{family}-{t['tcId']}: no flag (every vector needs a reason)")
    return problems


def _reproduce_problems(family: str, doc: dict, text: str, fresh_text: str) -> list[str]:
    if text == fresh_text:
        return []
    fresh = json.loads(fresh_text)
    if fresh == doc:
        return [f"{family}: values reproduce but the formatting differs (run the generator to rewrite the file)"]
    problems = []
    mine = {t["tcId"]: (g["operation"], g["conventions"], t) for g in doc["testGroups"] for t in g["tests"]}
    theirs = {t["tcId"]: (g["operation"], g["conventions"], t) for g in fresh["testGroups"] for t in g["tests"]}
    for tc in sorted(set(mine) | set(theirs)):
        if tc not in theirs:
            problems.append(f"{family}-{tc}: not produced by the generator")
        elif tc not in mine:
            problems.append(f"{family}-{tc}: produced by the generator but missing from the file")
        elif mine[tc] != theirs[tc]:
            fields = [k for k in ("inputs", "expected", "tolerance", "flags", "comment", "result")
                      if mine[tc][2].get(k) != theirs[tc][2].get(k)]
            if mine[tc][:2] != theirs[tc][:2]:
                fields.insert(0, "operation/conventions")
            problems.append(f"{family}-{tc}: differs from a fresh generation in {', '.join(fields)}")
    for key in ("header", "notes", "schema", "numberOfTests"):
        if doc.get(key) != fresh.get(key):
            problems.append(f"{family}: '{key}' differs from a fresh generation")
    return problems or [f"{family}: differs from a fresh generation"]


def lint(corpus: pathlib.Path | str | None = None, families: Sequence[str] | None = None,
         reproduce: bool = True) -> list[str]:
    """Check the corpus and return the list of problems (empty when clean).

    Checks: strict JSON, schema validity (JSON Schema draft 2020-12), ``family`` field,
    unique ``tcId``, ``numberOfTests``, every flag explained in ``notes`` and every note
    used, and (``reproduce=True``) that a fresh in-memory run of ``generate.py``
    reproduces every file byte for byte. Needs ``jsonschema`` and ``mpmath``.
    """
    import jsonschema

    directory = pathlib.Path(corpus) if corpus is not None else default_corpus_dir()
    selected = tuple(families) if families else FAMILIES
    schema = json.loads(schema_path(directory).read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    problems: list[str] = []
    texts, docs = {}, {}
    for family in selected:
        path = directory / f"{family}.json"
        if not path.is_file():
            problems.append(f"{family}: {path} is missing")
            continue
        text = path.read_text(encoding="utf-8")

        def reject(token: str) -> float:
            raise ValueError(f"non-standard JSON token {token}")

        try:
            doc = json.loads(text, parse_constant=reject)
        except ValueError as exc:
            problems.append(f"{family}: not strict JSON ({exc})")
            continue
        for err in sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))[:20]:
            where = "/".join(str(p) for p in err.absolute_path)
            problems.append(f"{family}: schema: at /{where}: {err.message[:200]}")
        problems.extend(_structure_problems(family, doc))
        texts[family], docs[family] = text, doc
    if reproduce and texts:
        generator = load_generator(directory)
        fresh = generator.build(tuple(texts))
        for family, text in texts.items():
            problems.extend(_reproduce_problems(family, docs[family], text, fresh[family]))
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m dynval.golden lint``: print the problems, exit 1 if there are any."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m dynval.golden lint",
                                     description="Lint the dynval golden corpus.")
    parser.add_argument("--corpus", type=pathlib.Path, default=None,
                        help="directory of <family>.json files (default: the shipped corpus)")
    parser.add_argument("--families", default=None, help="comma-separated families (default: all)")
    parser.add_argument("--no-reproduce", action="store_true",
                        help="skip regenerating the values (schema and structure only)")
    args = parser.parse_args(argv)
    families = [f for f in args.families.split(",") if f] if args.families else None
    try:
        problems = lint(args.corpus, families, reproduce=not args.no_reproduce)
    except ImportError as exc:
        print(f"linting needs the golden extra (pip install 'dynval[golden]'): {exc}", file=sys.stderr)
        return 2
    directory = args.corpus or default_corpus_dir()
    if problems:
        print(f"{len(problems)} problem(s) in {directory}:")
        for p in problems:
            print(f"  - {p}")
        return 1
    print(f"corpus OK: {directory}")
    return 0
