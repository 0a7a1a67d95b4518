"""Corpus linter: schema, identifiers, counts, flags legend and reproducibility of every value.

The files checked are untrusted input: every defect (unreadable, not UTF-8, not
strict JSON, nested too deeply, a number float64 cannot hold, a schema violation,
a malformed entry) becomes one listed problem naming the file and the place, and
nothing found beside them is used. The schema is dynval's own unless ``--schema``
names another; reproducing the values (``--reproduce``) runs dynval's own
generator, never a ``generate.py`` next to the corpus. The generator is not installed with
the package: it is taken from dynval's source tree (:func:`generator_dir` says where it is
looked for).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import pathlib
import re
import sys
from collections.abc import Iterator, Sequence
from types import ModuleType
from typing import Any

from ._loader import FAMILIES, schema_path
from ._loader import corpus_dir as default_corpus_dir

#: Deepest nesting of arrays and objects accepted. The corpus needs 9 and the schema 20;
#: the limit keeps the parser and the validator far from Python's recursion limit.
MAX_DEPTH = 64

# A JSON string (skipped: brackets inside it do not nest) or one bracket.
_BRACKET = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')

#: Environment variable naming the dynval source checkout (or its ``golden/`` directory) whose
#: generator ``load_generator`` uses; unset, the checkout is looked for (see :func:`generator_dir`).
SOURCE_ENV = "DYNVAL_GOLDEN_SOURCE"

_PROJECT_NAME = re.compile(r'^name\s*=\s*"dynval"\s*$', re.MULTILINE)

SOURCE_EXPLANATION = ("To regenerate or reproduce the corpus, get dynval's source (a git clone of the "
                      "repository, or its sdist unpacked), install its extra (pip install '.[golden]'), and run "
                      f"the command from inside that tree, or set {SOURCE_ENV} to its directory.")


class GeneratorNotFoundError(FileNotFoundError):
    """dynval's corpus generator was not found: it is part of the source tree, not of the package."""


def _holds_generator(golden: pathlib.Path) -> bool:
    return (golden / "generate.py").is_file() and (golden / "corpus_generator" / "__init__.py").is_file()


def _is_checkout(root: pathlib.Path) -> bool:
    """``root`` is a dynval source tree: its pyproject.toml names the project dynval, golden/ holds the generator."""
    try:
        pyproject = (root / "pyproject.toml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return _PROJECT_NAME.search(pyproject) is not None and _holds_generator(root / "golden")


def generator_dir(source: pathlib.Path | str | None = None, *, environ: Any = None,
                  cwd: pathlib.Path | None = None, package_root: pathlib.Path | None = None) -> pathlib.Path:
    """The ``golden/`` directory of the dynval source tree whose generator to run.

    The generator (``golden/generate.py`` and ``golden/corpus_generator/``) is not installed
    with the package; it is found, in this order, in

    1. ``source`` or else ``$DYNVAL_GOLDEN_SOURCE``: a source checkout or its ``golden/``
       directory (nothing else is tried when one is given);
    2. the source tree the running dynval is imported from (an editable install, or
       ``PYTHONPATH=python``);
    3. the current directory or the nearest directory above it that is a dynval source tree
       (its ``pyproject.toml`` names the project ``dynval``), e.g. the repository root.

    A directory a corpus is read from is never one of these: the linter runs only the
    project's own generator. ``environ``, ``cwd`` and ``package_root`` replace
    ``os.environ``, the current directory and the tree of the running package (for tests).

    Raises
    ------
    GeneratorNotFoundError
        Nowhere; the message names every place looked in and how to get the generator.
    """
    environ = os.environ if environ is None else environ
    origin = "the directory given"
    if source is None and environ.get(SOURCE_ENV):
        source, origin = environ[SOURCE_ENV], f"${SOURCE_ENV}"
    if source is not None:
        given = pathlib.Path(source).expanduser().resolve()
        for golden in (given / "golden", given):
            if _holds_generator(golden):
                return golden
        msg = (f"dynval's corpus generator not found: {origin} is {given}, which holds neither "
               "golden/generate.py with golden/corpus_generator/ nor generate.py with corpus_generator/. "
               f"{SOURCE_EXPLANATION}")
        raise GeneratorNotFoundError(msg)
    looked = [f"${SOURCE_ENV}: not set"]
    # python/dynval/golden/_lint.py -> the repository root in a source tree.
    package_root = pathlib.Path(__file__).resolve().parents[3] if package_root is None else package_root
    if _is_checkout(package_root):
        return package_root / "golden"
    looked.append(f"{package_root / 'golden'}, where the source tree of the imported dynval "
                  f"({pathlib.Path(__file__).resolve().parents[1]}) would hold it: not a dynval source tree")
    cwd = pathlib.Path.cwd() if cwd is None else pathlib.Path(cwd)
    cwd = cwd.resolve()
    for root in (cwd, *cwd.parents):
        if _is_checkout(root):
            return root / "golden"
    looked.append(f"golden/ in {cwd} and in every directory above it (none is a dynval source tree)")
    msg = ("dynval's corpus generator (golden/generate.py and golden/corpus_generator/) is not installed with "
           "the package: it is part of dynval's source tree. Looked in:\n  - " + "\n  - ".join(looked)
           + f"\n{SOURCE_EXPLANATION}")
    raise GeneratorNotFoundError(msg)


def load_generator(source: pathlib.Path | str | None = None) -> ModuleType:
    """Import dynval's own ``golden/generate.py`` from the source tree as a module.

    ``source`` (default: found by :func:`generator_dir`) is a source checkout or its
    ``golden/`` directory. The generator is not part of the installed package.
    """
    path = generator_dir(source) / "generate.py"
    spec = importlib.util.spec_from_file_location("dynval_golden_generate", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("dynval_golden_generate", module)
    spec.loader.exec_module(module)
    return module


# --------------------------------------------------------------------------- reading untrusted JSON


def _reject_constant(token: str) -> float:
    raise ValueError(f"non-standard JSON token {token}")


def _nesting_problem(text: str) -> str:
    """Where ``text`` nests deeper than MAX_DEPTH ('' if it does not), found before parsing."""
    depth = 0
    for match in _BRACKET.finditer(text):
        char = match.group()
        if char in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                line = text.count("\n", 0, match.start()) + 1
                column = match.start() - (text.rfind("\n", 0, match.start()) + 1) + 1
                return f"nested deeper than {MAX_DEPTH} levels at line {line} column {column}"
        elif char in "]}":
            depth -= 1
    return ""


def _pointer(path: Sequence[Any]) -> str:
    return "/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in path)


def _overflows(doc: Any) -> Iterator[str]:
    """JSON pointers of the numbers that did not fit a float64.

    Python's json reads a literal such as ``1e999`` as infinity; NaN and Infinity
    tokens are rejected while parsing, so every non-finite float here is one of those.
    """
    stack: list[tuple[Any, tuple]] = [(doc, ())]
    while stack:
        value, path = stack.pop()
        if isinstance(value, float) and not math.isfinite(value):
            yield _pointer(path)
        elif isinstance(value, dict):
            stack.extend((v, path + (k,)) for k, v in reversed(list(value.items())))
        elif isinstance(value, list):
            stack.extend((v, path + (i,)) for i, v in reversed(list(enumerate(value))))


def _read_json(path: pathlib.Path, label: str) -> tuple[str | None, Any, list[str]]:
    """``(text, document, problems)``; ``text`` is None when the file cannot be used at all."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        return None, None, [f"{label}: cannot read {path}: {exc.strerror or exc}"]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        return None, None, [f"{label}: not UTF-8: byte {exc.start} (line {line}) is {data[exc.start:exc.start + 1]!r}"]
    deep = _nesting_problem(text)
    if deep:
        return None, None, [f"{label}: {deep}"]
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:
        return None, None, [f"{label}: not strict JSON ({exc})"]
    problems = [f"{label}: at {where}: number overflows float64 (a literal such as 1e999 reads as infinity)"
                for where in _overflows(doc)]
    return text, doc, problems


def _external_refs(schema: Any) -> Iterator[tuple[str, str]]:
    stack: list[tuple[Any, tuple]] = [(schema, ())]
    while stack:
        value, path = stack.pop()
        if isinstance(value, dict):
            for key, item in value.items():
                if key in ("$ref", "$dynamicRef") and isinstance(item, str) and not item.startswith("#"):
                    yield _pointer(path + (key,)), item
                stack.append((item, path + (key,)))
        elif isinstance(value, list):
            stack.extend((v, path + (i,)) for i, v in enumerate(value))


def load_validator(path: pathlib.Path | None = None):
    """``(validator, problems)`` for the schema at ``path`` (default: dynval's own schema).

    A schema given by the user is checked like a corpus file, must be a valid draft
    2020-12 schema and may only refer inside itself: nothing is fetched.
    """
    import jsonschema

    path = pathlib.Path(path) if path is not None else schema_path()
    label = f"schema {path}"
    text, schema, problems = _read_json(path, label)
    if text is None or problems:
        return None, problems
    problems = [f"{label}: at {where}: reference {ref!r} points outside the file (only '#...' references "
                "are followed)" for where, ref in _external_refs(schema)]
    if problems:
        return None, problems
    try:
        jsonschema.Draft202012Validator.check_schema(schema)
    except jsonschema.SchemaError as exc:
        where = _pointer(exc.absolute_path)
        return None, [f"{label}: not a valid JSON Schema (draft 2020-12): at {where}: {exc.message[:200]}"]
    return jsonschema.Draft202012Validator(schema), []


def _schema_problems(family: str, doc: Any, validator, label: str) -> list[str]:
    def place(err) -> list:
        # Indices and keys never meet at one level; the tag keeps the sort total anyway.
        return [(0, p, "") if isinstance(p, int) else (1, 0, str(p)) for p in err.absolute_path]

    try:
        errors = sorted(validator.iter_errors(doc), key=place)[:20]
    except Exception as exc:  # a user's schema may still fail while validating
        return [f"{label}: cannot validate {family}.json: {type(exc).__name__}: {str(exc)[:200]}"]
    return [f"{family}: schema: at {_pointer(err.absolute_path)}: {err.message[:200]}" for err in errors]


# --------------------------------------------------------------------------- structure


def _tests(doc: dict) -> list[dict]:
    """The test objects of the file; malformed entries are the schema's to report."""
    groups = doc.get("testGroups")
    tests: list[dict] = []
    for group in groups if isinstance(groups, list) else []:
        entries = group.get("tests") if isinstance(group, dict) else None
        tests.extend(t for t in (entries if isinstance(entries, list) else []) if isinstance(t, dict))
    return tests


def _flags(test: dict) -> list[str]:
    flags = test.get("flags")
    return [f for f in flags if isinstance(f, str)] if isinstance(flags, list) else []


def _tc_id(test: dict) -> int | None:
    tc = test.get("tcId")
    return tc if isinstance(tc, int) and not isinstance(tc, bool) else None


def _structure_problems(family: str, doc: Any) -> list[str]:
    if not isinstance(doc, dict):
        return [f"{family}: at /: the file holds {type(doc).__name__}, not one JSON object"]
    problems = []
    if doc.get("family") != family:
        problems.append(f"{family}: field 'family' is {doc.get('family')!r}")
    tests = _tests(doc)
    if doc.get("numberOfTests") != len(tests):
        problems.append(f"{family}: numberOfTests is {doc.get('numberOfTests')}, the file has {len(tests)} tests")
    seen: set[int] = set()
    for t in tests:
        tc = _tc_id(t)
        if tc is not None and tc in seen:
            problems.append(f"{family}: tcId {tc} is not unique")
        seen.add(tc)
    notes = doc.get("notes") if isinstance(doc.get("notes"), dict) else {}
    used = {f for t in tests for f in _flags(t)}
    for flag in sorted(used - set(notes)):
        problems.append(f"{family}: flag {flag!r} is used but not explained in notes")
    for flag in sorted(set(notes) - used):
        problems.append(f"{family}: note {flag!r} is never used")
    for t in tests:
        if not _flags(t):
            problems.append(f"{family}-{t.get('tcId', '?')}: no flag (every vector needs a reason)")
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
         reproduce: bool = False, schema: pathlib.Path | str | None = None) -> list[str]:
    """Check the corpus and return the list of problems (empty when clean).

    Checks: readable UTF-8, strict JSON (no NaN/Infinity tokens, no number beyond
    float64, at most MAX_DEPTH levels), validity against dynval's schema (JSON Schema
    draft 2020-12; ``schema`` names another file instead), ``family`` field, unique
    ``tcId``, ``numberOfTests``, every flag explained in ``notes`` and every note
    used, and (``reproduce=True``) that a fresh in-memory run of dynval's own
    generator reproduces every file byte for byte. Needs ``jsonschema`` (and, to
    reproduce, ``mpmath`` and dynval's source tree: :func:`generator_dir`; without it
    :class:`GeneratorNotFoundError` is raised). Nothing found beside ``corpus`` is used.
    """
    directory = pathlib.Path(corpus) if corpus is not None else default_corpus_dir()
    selected = tuple(families) if families else FAMILIES
    validator, problems = load_validator(pathlib.Path(schema) if schema is not None else None)
    if validator is None:
        return problems
    label = f"schema {schema}" if schema is not None else "schema"
    texts, docs = {}, {}
    for family in selected:
        path = directory / f"{family}.json"
        if not path.is_file():
            problems.append(f"{family}: {path} is missing")
            continue
        text, doc, found = _read_json(path, family)
        if text is None:
            problems.extend(found)
            continue
        schema_found = _schema_problems(family, doc, validator, label)
        problems.extend(found + schema_found + _structure_problems(family, doc))
        if not found and not schema_found:
            texts[family], docs[family] = text, doc
    if reproduce and texts:
        problems.extend(_reproduction(texts, docs))
    return problems


def _reproduction(texts: dict[str, str], docs: dict[str, Any]) -> list[str]:
    generator = load_generator()
    try:
        fresh = generator.build(tuple(texts))
    except Exception as exc:  # a generator defect, reported like any other problem
        return [f"dynval's generator failed: {type(exc).__name__}: {exc}"]
    problems = []
    for family, text in texts.items():
        try:
            problems.extend(_reproduce_problems(family, docs[family], text, fresh[family]))
        except (KeyError, TypeError, AttributeError) as exc:  # a file shaped by a permissive --schema
            problems.append(f"{family}: cannot compare with a fresh generation ({type(exc).__name__}: {exc})")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m dynval.golden lint``: print the problems, exit 1 if there are any."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m dynval.golden lint",
                                     description="Lint the dynval golden corpus (or a copy of it).")
    parser.add_argument("--corpus", type=pathlib.Path, default=None,
                        help="directory of <family>.json files (default: the shipped corpus)")
    parser.add_argument("--families", default=None, help="comma-separated families (default: all)")
    parser.add_argument("--schema", type=pathlib.Path, default=None,
                        help="JSON Schema to check against (default: dynval's own; a schema beside the corpus "
                             "is never used)")
    parser.add_argument("--reproduce", action="store_true",
                        help="also regenerate every value with dynval's own generator (from a source checkout: the "
                             f"current directory or above, or ${SOURCE_ENV}) and compare byte for byte")
    parser.add_argument("--no-reproduce", action="store_true",
                        help="schema and structure only (the default; kept for old scripts)")
    args = parser.parse_args(argv)
    families = [f for f in args.families.split(",") if f] if args.families else None
    try:
        problems = lint(args.corpus, families, reproduce=args.reproduce and not args.no_reproduce,
                        schema=args.schema)
    except ImportError as exc:
        print(f"linting needs the golden extra (pip install 'dynval[golden]'): {exc}", file=sys.stderr)
        return 2
    except GeneratorNotFoundError as exc:
        print(f"--reproduce runs dynval's corpus generator: {exc}", file=sys.stderr)
        return 2
    directory = args.corpus or default_corpus_dir()
    if problems:
        print(f"{len(problems)} problem(s) in {directory}:")
        for p in problems:
            print(f"  - {p}")
        return 1
    print(f"corpus OK: {directory}")
    return 0
