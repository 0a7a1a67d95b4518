"""``python -m dynval.golden lint|generate|operations``: lint or regenerate the golden corpus,
or render the operations reference of PROTOCOL.md.

``generate`` (and ``lint --reproduce``) run dynval's corpus generator, which is not installed
with the package: it is taken from a dynval source tree (the one dynval is imported from, the
current directory or one above it, or ``$DYNVAL_GOLDEN_SOURCE``; ``_lint.generator_dir``)."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    usage = ("usage: python -m dynval.golden lint [--corpus DIR] [--families F,...] [--schema FILE] [--reproduce]\n"
             "       python -m dynval.golden generate [--out DIR] [--check] [--families F,...]\n"
             "       python -m dynval.golden operations [--check | --write]\n"
             "generate and lint --reproduce need dynval's source tree (the generator golden/generate.py is not\n"
             "installed with the package): run them inside a checkout, or set DYNVAL_GOLDEN_SOURCE to one.")
    if not args or args[0] in ("-h", "--help"):
        print(usage)
        return 0 if args else 2
    command, rest = args[0], args[1:]
    if command == "lint":
        from ._lint import main as lint_main

        return lint_main(rest)
    if command == "generate":
        from ._lint import GeneratorNotFoundError, load_generator

        try:
            generator = load_generator()
        except GeneratorNotFoundError as exc:
            print(exc, file=sys.stderr)
            return 2
        except ImportError as exc:
            print(f"generating needs the golden extra (pip install 'dynval[golden]'): {exc}", file=sys.stderr)
            return 2
        return generator.main(rest)
    if command == "operations":
        from ._spec import main as spec_main

        return spec_main(rest)
    print(f"unknown command {command!r}\n{usage}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
