"""Wrong port: claims an operation in full but never sends one of its outputs.

With ``--declare`` the port honestly restricts its capability to the outputs it
computes (``capability OP outputs=...``): the runner must then report those
cases as partial, not as passed and not as failed. Without it, the runner must
fail them with reason ``missing-output`` (or ``not answered`` with ``--silent``,
which sends an empty answer).
"""

import _oracle
from _oracle import OPERATIONS


def main() -> int:
    def extra(p):
        p.add_argument("--operation", required=True)
        p.add_argument("--drop", required=True, help="comma-separated outputs never sent")
        p.add_argument("--keep", default="", help="comma-separated outputs declared with --declare")
        p.add_argument("--declare", action="store_true")
        p.add_argument("--silent", action="store_true", help="answer the operation with 'end' only")

    args = _oracle.parse_args(extra=extra)
    drop = set(args.drop.split(","))
    capabilities = [f"capability {op}" for op in OPERATIONS if op != args.operation]
    if args.declare:
        capabilities.append(f"capability {args.operation} outputs={args.keep}")
    else:
        capabilities.append(f"capability {args.operation}")

    def hook(message, case, count):
        if message.operation != args.operation or case.result == "invalid":
            return None
        if args.silent:
            return ["end"]
        lines = _oracle.expected_reply(case)
        return [ln for ln in lines if not (ln.startswith("result ") and ln.split()[1] in drop)]

    return _oracle.serve(args.corpus, hook, capabilities)


if __name__ == "__main__":
    raise SystemExit(main())
