"""Generate the dynval golden corpus (``golden/vectors/<family>.json``).

Every expected value is computed here at 50 significant digits with mpmath,
directly from the formulas of ``docs/contract.md`` — this package never imports
dynval. Inputs come from ``random.Random(seed)`` (only ``random()``, whose
sequence Python guarantees across versions, combined with IEEE arithmetic and
correctly rounded decimal formatting), from exact dyadic rationals, or from the
NIST StRD files committed in ``golden/data/``. Inputs are float64 values written
with ``repr``; expected values are rounded once to float64. The JSON layout is
fixed, so running the generator again reproduces the files byte for byte.

Layout: one builder module per family (``norms``, ``normalized_fit``, ...,
``errors``; each has ``build() -> Family``), the exact arithmetic they share in
``_exact``, deterministic inputs in ``_inputs``, the flags legend in ``_notes``,
the JSON layout in ``_json``, and the check of every vector against
``golden/operations.json`` in ``_operations``. New vectors are appended at the end
of their family's ``build()`` so that existing tcIds stay stable.

Usage (``golden/generate.py`` runs this package)::

    python golden/generate.py            # rewrite golden/vectors/*.json
    python golden/generate.py --check    # exit 1 if the files differ from a fresh run

Only the standard library and mpmath (pinned, see ``MPMATH_VERSION``) are used.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
from collections.abc import Callable, Sequence

import mpmath
from mpmath import mp

from . import (
    autocorrelation,
    cross_correlation,
    errors,
    information_criteria,
    normalized_fit,
    norms,
    portmanteau,
    residual_statistics,
    streaming,
)
from ._config import CORPUS_VERSION, DPS, FAMILIES, GOLDEN, MPMATH_VERSION, RTOL, SCHEMA_NAME
from ._family import Family
from ._json import dumps
from ._notes import NOTES
from ._operations import load_operations, operations_problems

__all__ = ["BUILDERS", "CORPUS_VERSION", "DPS", "FAMILIES", "MPMATH_VERSION", "NOTES", "RTOL", "SCHEMA_NAME",
           "Family", "build", "load_operations", "main", "operations_problems"]


BUILDERS: dict[str, Callable[[], Family]] = {
    "norms": norms.build,
    "normalized_fit": normalized_fit.build,
    "residual_statistics": residual_statistics.build,
    "autocorrelation": autocorrelation.build,
    "portmanteau": portmanteau.build,
    "cross_correlation": cross_correlation.build,
    "information_criteria": information_criteria.build,
    "errors": errors.build,
    "streaming": streaming.build,
}


def build(families: Sequence[str] = FAMILIES) -> dict[str, str]:
    """Family -> file text, computed in memory."""
    if mpmath.__version__ != MPMATH_VERSION:
        msg = f"mpmath {MPMATH_VERSION} is required for byte-for-byte regeneration, found {mpmath.__version__}"
        raise RuntimeError(msg)
    mp.dps = DPS
    spec = load_operations()
    texts = {}
    for name in families:
        doc = BUILDERS[name]().document()
        problems = operations_problems(doc, spec)
        if problems:
            raise RuntimeError("the corpus disagrees with golden/operations.json:\n  " + "\n  ".join(problems[:20]))
        texts[name] = dumps(doc)
    return texts


def main(argv: Sequence[str] | None = None) -> int:
    """``python golden/generate.py [--out DIR] [--check] [--families F,...]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=GOLDEN / "vectors", help="output directory")
    parser.add_argument("--check", action="store_true", help="compare with the files instead of writing")
    parser.add_argument("--families", default=",".join(FAMILIES), help="comma-separated families")
    args = parser.parse_args(argv)
    texts = build([f for f in args.families.split(",") if f])
    stale = []
    for name, text in texts.items():
        path = args.out / f"{name}.json"
        if args.check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                stale.append(str(path))
        else:
            args.out.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8", newline="\n")
    if stale:
        print("out of date:\n  " + "\n  ".join(stale), file=sys.stderr)
        return 1
    return 0
