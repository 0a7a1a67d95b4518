"""Wrong port: greets with an unknown protocol version (or, with --no-greeting, with junk).

``dynval conform`` must report the handshake failure for every case and exit 1.
"""

import _oracle


def main() -> int:
    args = _oracle.parse_args(extra=lambda p: p.add_argument("--no-greeting", action="store_true"))
    greeting = "hello there\n" if args.no_greeting else "dynval-port 99 from the future\n"
    return _oracle.serve(args.corpus, greeting=greeting)


if __name__ == "__main__":
    raise SystemExit(main())
