"""Wrong port: answers the target case with endless output.

Endless comment lines by default, or one endless line with ``--no-newline``.
``dynval conform`` must kill it and fail the case with reason ``flood``.
"""

import sys

import _oracle


def main() -> int:
    args = _oracle.parse_args(extra=lambda p: p.add_argument("--no-newline", action="store_true"))

    def hook(message, case, count):
        if _oracle.is_target(args, message):
            chunk = "1 " * 32768 if args.no_newline else "# still thinking\n" * 4096
            while True:
                sys.stdout.write(chunk)
                sys.stdout.flush()
        return None

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
