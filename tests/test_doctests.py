"""Every example in the installed package's docstrings runs and prints what it says.

The doctests are run against the installed ``dynval`` (with its compiled backend), module by module,
so a stale example fails here; the count guards against examples silently disappearing.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import dynval

MODULES = sorted(m.name for m in pkgutil.walk_packages(dynval.__path__, "dynval.")
                 if not m.name.endswith("__main__") and m.name != "dynval._core")
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _tests(name):
    module = importlib.import_module(name)
    return [t for t in doctest.DocTestFinder().find(module, name) if t.examples]


@pytest.mark.parametrize("name", ["dynval", *MODULES])
def test_docstring_examples_run(name):
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    report = []
    for test in _tests(name):
        runner.run(test, out=report.append)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, "".join(report)


def test_the_examples_are_all_there():
    # About 160 examples across the modules today: losing many of them is a failure too.
    count = sum(len(t.examples) for name in ["dynval", *MODULES] for t in _tests(name))
    assert count >= 150, count
