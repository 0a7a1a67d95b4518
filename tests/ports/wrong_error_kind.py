"""Wrong port: every expected error is answered with a different contract error kind.

``dynval conform`` must fail every invalid case with reason ``wrong-error``.
"""

import _oracle
from _oracle import protocol

KINDS = ("InvalidType", "InvalidShape", "ShapeMismatch", "TooFewSamples", "NonFiniteInput", "InvalidParameter")


def main() -> int:
    args = _oracle.parse_args()

    def hook(message, case, count):
        if case.result != "invalid":
            return None
        wrong = KINDS[(KINDS.index(case.expected["error"]) + 1) % len(KINDS)]
        return protocol.encode_reply(error_kind=wrong, message="deliberately wrong kind")

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
