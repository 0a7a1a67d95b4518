"""Wrong port: answers the target case with a line outside the grammar.

``--what`` picks the garbage: a decimal comma, a Wolfram-style number, a C
hexadecimal float, a stray word, or non-ASCII bytes. ``dynval conform`` must
fail the case with reason ``garbage``, restart the port and go on.
"""

import sys

import _oracle

GARBAGE = {
    "comma": "result value real 0 1,5",
    "wolfram": "result value real 0 1.5*^-3",
    "hexfloat": "result value real 0 0x1.8p+0",
    "word": "hello world",
    "binary": "result value real 0 \u00e9\u00e8",
}


def main() -> int:
    args = _oracle.parse_args(extra=lambda p: p.add_argument("--what", choices=sorted(GARBAGE), default="comma"))

    def hook(message, case, count):
        if _oracle.is_target(args, message):
            if args.what == "binary":
                sys.stdout.flush()
                sys.stdout.buffer.write(GARBAGE["binary"].encode("latin-1") + b"\nend\n")
                sys.stdout.buffer.flush()
                return []
            return [GARBAGE[args.what], "end"]
        return None

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
