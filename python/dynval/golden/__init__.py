"""The dynval golden corpus: loader, comparison, linter and generator entry points.

The corpus is language-neutral JSON (``golden/vectors/<family>.json``, schema
``golden/schema/corpus_v1.schema.json``); this package reads it, runs a vector
through the public API and compares results with the vector's tolerance. Only
numpy and the standard library are needed here; linting and regenerating also
need ``jsonschema`` and ``mpmath`` (``pip install dynval[golden]``), and regenerating
(``generate``, ``lint --reproduce``) needs dynval's source tree: the generator
``golden/generate.py`` is not installed with the package (``_lint.generator_dir``).

Examples
--------
>>> from dynval.golden import FAMILIES, iter_cases
>>> FAMILIES[0]
'norms'
>>> sum(1 for _ in iter_cases(families=["information_criteria"])) > 0
True
"""

from ._compare import check_case
from ._loader import (
    FAMILIES,
    OPTIONAL_FAMILIES,
    SCHEMA_NAME,
    Case,
    corpus_dir,
    golden_root,
    iter_cases,
    load_family,
    schema_path,
)
from ._ops import OPERATIONS, run_operation

__all__ = [
    "FAMILIES",
    "OPERATIONS",
    "OPTIONAL_FAMILIES",
    "SCHEMA_NAME",
    "Case",
    "check_case",
    "corpus_dir",
    "golden_root",
    "iter_cases",
    "load_family",
    "run_operation",
    "schema_path",
]
