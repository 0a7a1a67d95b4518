"""The correct port: answers every case with the vector's expected values (see _oracle.py).

``--without OP,...`` leaves operations out of the handshake.
``--encoding hex`` negotiates hexadecimal floats; ``--answer-encoding`` picks the
form of the answers (hex answers without ``--encoding hex`` make a wrong port).
"""

import _oracle


def main() -> int:
    def extra(parser):
        parser.add_argument("--encoding", choices=("decimal", "hex"), default=None)
        parser.add_argument("--answer-encoding", choices=("decimal", "hex"), default="decimal")
        parser.add_argument("--record", default=None, help="append every received line to this file")
        parser.add_argument("--without", default="", help="comma-separated operations not declared")

    args = _oracle.parse_args(extra=extra)
    if args.record:
        import sys

        sys.stdin = _Recorder(sys.stdin, args.record)
    left_out = {op for op in args.without.split(",") if op}
    capabilities = [f"capability {op}" for op in _oracle.OPERATIONS if op not in left_out]
    return _oracle.serve(args.corpus, capabilities=capabilities, encoding=args.encoding,
                         answer_encoding=args.answer_encoding)


class _Recorder:
    """Standard input that also appends every line it yields to a file (what the runner sent)."""

    def __init__(self, stream, path):
        self.stream, self.path = stream, path

    def __iter__(self):
        with open(self.path, "a", encoding="ascii") as log:
            for line in self.stream:
                log.write(line)
                log.flush()
                yield line


if __name__ == "__main__":
    raise SystemExit(main())
