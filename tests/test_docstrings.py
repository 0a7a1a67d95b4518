"""Every public function documents itself the way scikit-learn's ``r2_score`` does.

Each docstring has numpydoc ``Parameters``, ``Returns`` and ``Examples`` sections; every argument
of the signature is described under ``Parameters`` (an argument added without a word fails here);
and the examples include a degenerate case (a constant target, an exact fit, one sample, a
rank-deficient regressor, ...), introduced by a sentence that says what is degenerate about it, as
contract §3.2 defines the values. The examples themselves run in tests/test_doctests.py.
"""

from __future__ import annotations

import doctest
import inspect
import re

import pytest

import dynval
import dynval.dask
import dynval.stream

# Words that name a degenerate case in the sentence before an example.
DEGENERATE = re.compile(
    r"constant|exact|perfect|one sample|single|zero|empty|fewer|rank|no default|nan|inf|repeat|"
    r"minimum|unknown|invalid|without|only", re.I)


def _public_functions():
    found = [(f"dynval.{n}", getattr(dynval, n)) for n in dynval.__all__ if inspect.isfunction(getattr(dynval, n))]
    found += [(f"dynval.dask.{n}", getattr(dynval.dask, n)) for n in ("validate", "accumulate")]
    acc = dynval.stream.ValidationAccumulator
    found += [("dynval.stream.ValidationAccumulator", acc)]
    found += [(f"dynval.stream.ValidationAccumulator.{n}", getattr(acc, n))
              for n in ("update", "merge", "break_segment", "result")]
    return found


FUNCTIONS = _public_functions()


def _section(doc: str, title: str) -> str | None:
    match = re.search(rf"^{title}\n-{{{len(title)}}}\n(.*?)(?=^\w[\w ]*\n-{{3,}}\n|\Z)", doc, re.S | re.M)
    return match.group(1) if match else None


def _arguments(obj) -> list[str]:
    target = obj.__init__ if inspect.isclass(obj) else obj
    return [name for name, p in inspect.signature(target).parameters.items()
            if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]


def test_the_public_functions_are_all_checked():
    assert len(FUNCTIONS) >= 30


@pytest.mark.parametrize(("name", "obj"), FUNCTIONS, ids=[n for n, _ in FUNCTIONS])
def test_parameters_returns_and_examples(name, obj):
    doc = inspect.getdoc(obj) or ""
    parameters = _section(doc, "Parameters")
    examples = _section(doc, "Examples")
    assert examples is not None, f"{name}: no Examples section"
    arguments = _arguments(obj)
    if arguments:
        assert parameters is not None, f"{name}: no Parameters section"
        # an entry is an unindented line: "name : type", "a, b : type" or just "a, b, c"
        documented_names = {part.strip() for line in re.findall(r"^(\S[^:\n]*?)(?:\s+:.*)?$", parameters, re.M)
                            for part in line.split(",")}
        missing = [a for a in arguments if a not in documented_names]
        assert not missing, f"{name}: arguments not under Parameters: {missing}"
    if not inspect.isclass(obj):
        assert _section(doc, "Returns") is not None or _section(doc, "Yields") is not None, \
            f"{name}: no Returns section"


@pytest.mark.parametrize(("name", "obj"), [f for f in FUNCTIONS if f[0].startswith("dynval.")
                                           and f[0].count(".") == 1],
                         ids=[n for n, _ in FUNCTIONS if n.count(".") == 1])
def test_a_degenerate_case_is_shown(name, obj):
    examples = _section(inspect.getdoc(obj) or "", "Examples") or ""
    # the prose of the Examples section: lines that are neither code nor output
    blocks = re.split(r"\n\s*\n", examples)
    explained = [b for b in blocks if not b.lstrip().startswith(">>>") and DEGENERATE.search(b)]
    later_code = [i for i, b in enumerate(blocks) if b.lstrip().startswith(">>>")]
    assert explained and later_code and len(doctest.DocTestParser().get_examples(examples)) >= 2, (
        f"{name}: the Examples section needs a degenerate case introduced by a sentence saying what it is")
