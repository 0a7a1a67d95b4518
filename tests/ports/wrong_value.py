"""Wrong port: every finite real output of the target operation is off by 1e-6 (relative) + 1e-9.

``dynval conform`` must fail exactly those cases, with reason ``mismatch``.
"""

import _oracle
import numpy as np
from _oracle import protocol


def main() -> int:
    args = _oracle.parse_args(extra=lambda p: p.add_argument("--operation", required=True))

    def hook(message, case, count):
        if message.operation != args.operation or case.result == "invalid":
            return None
        outputs = {}
        for name, value in case.expected.items():
            if name == "error":
                continue
            arr = np.asarray(value)
            if arr.dtype.kind == "f":
                with np.errstate(invalid="ignore", over="ignore"):
                    arr = np.where(np.isfinite(arr), arr * (1 + 1e-6) + 1e-9, arr)
            outputs[name] = arr
        return protocol.encode_reply(outputs)

    return _oracle.serve(args.corpus, hook)


if __name__ == "__main__":
    raise SystemExit(main())
