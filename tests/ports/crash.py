"""Wrong port: dies with exit code 3 (after a word on stderr) when it receives the target case.

``dynval conform`` must fail that case with reason ``crash``, restart the port
and pass every other case.
"""

import os
import sys

import _oracle


def main() -> int:
    args = _oracle.parse_args()

    def hook(message, case, count):
        if _oracle.is_target(args, message):
            sys.stderr.write("segmentation fault (simulated)\n")
            sys.stderr.flush()
            os._exit(3)
        return None

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
