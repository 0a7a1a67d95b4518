"""Wrong port: never answers the target case (sleeps), or never finishes its handshake with --at-start.

``dynval conform`` must fail the case with reason ``timeout`` within ``--timeout``
seconds, kill the port, restart it and go on.
"""

import sys
import time

import _oracle


def main() -> int:
    args = _oracle.parse_args(extra=lambda p: p.add_argument("--at-start", action="store_true"))
    if args.at_start:
        sys.stdout.write("dynval-port 1 sleepy\n")
        sys.stdout.flush()
        time.sleep(3600)

    def hook(message, case, count):
        if _oracle.is_target(args, message):
            sys.stdout.write("result value real 0 1.0\n")  # half an answer, then silence
            sys.stdout.flush()
            time.sleep(3600)
        return None

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
