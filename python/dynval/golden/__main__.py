"""``python -m dynval.golden lint|generate|operations``: lint or regenerate the golden corpus,
or render the operations reference of PROTOCOL.md."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    usage = ("usage: python -m dynval.golden lint [--corpus DIR] [--families F,...] [--schema FILE] [--reproduce]\n"
             "       python -m dynval.golden generate [--out DIR] [--check] [--families F,...]\n"
             "       python -m dynval.golden operations [--check | --write]")
    if not args or args[0] in ("-h", "--help"):
        print(usage)
        return 0 if args else 2
    command, rest = args[0], args[1:]
    if command == "lint":
        from ._lint import main as lint_main

        return lint_main(rest)
    if command == "generate":
        from ._lint import load_generator

        try:
            generator = load_generator()
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
