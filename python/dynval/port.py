"""dynval itself as a port of the protocol in ``golden/PROTOCOL.md``.

``python -m dynval.port --backend python|cpp`` reads cases on standard input
and answers on standard output, computing every case through the public API
(:func:`dynval.golden.run_operation`). It is what ``dynval conform`` runs to
prove that both backends pass the corpus through the protocol, and a worked
example for authors of ports in other languages::

    dynval conform -- python -m dynval.port --backend cpp
    dynval conform -- python -m dynval.port --backend python --encoding hex

``--encoding hex`` negotiates hexadecimal floats (``encoding hex`` in the
handshake, PROTOCOL.md §2): the runner then sends every float as ``float.hex()``
writes it and this port answers in the same form.

A session, as the port sees it (``<`` from the runner, ``>`` from the port)::

    > dynval-port 1 dynval 0.1.0 (python backend)
    > capability sse
    > ...
    > ready
    < case norms 1 sse multioutput="pooled"
    < array tau_meas real 2 2 1 1.0000000000000000e+00 2.0000000000000000e+00
    < array tau_pred real 2 2 1 0.0000000000000000e+00 0.0000000000000000e+00
    < end
    > result value real 0 5.0000000000000000e+00
    > end
    < quit
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TextIO

from . import protocol

__all__ = ["main", "serve", "answer"]


def answer(case: protocol.CaseMessage, backend: str | None = None, encoding: str = "decimal") -> list[str]:
    """Compute one case with the public API and return the answer lines (``end`` included).

    Contract errors become an ``error`` line with their kind and message. Any
    other exception is a bug of the port; it is answered with the kind
    ``InternalError`` (not a contract kind, so the runner reports the case as
    failed with the exception text). Reals are written in ``encoding``.
    """
    from .golden import run_operation

    contract_error: type[Exception]
    try:
        from .checks._errors import InputError as contract_error
    except ImportError:  # pragma: no cover - the facade is always there in a release
        contract_error = ValueError

    try:
        outputs = run_operation(case.operation, case.inputs, case.conventions, backend=backend)
    except contract_error as exc:
        kind = getattr(exc, "kind", None) or "InternalError"
        return protocol.encode_reply(error_kind=kind, message=str(exc))
    except Exception as exc:
        return protocol.encode_reply(error_kind="InternalError", message=f"{type(exc).__name__}: {exc}")
    try:
        return protocol.encode_reply(outputs, encoding=encoding)
    except (TypeError, ValueError) as exc:
        return protocol.encode_reply(error_kind="InternalError", message=f"cannot write the outputs: {exc}")


def serve(backend: str | None, stdin: TextIO, stdout: TextIO, encoding: str = "decimal") -> int:
    """Speak the protocol on the given streams until ``quit`` or end of input.

    With ``encoding="hex"`` the port asks for hexadecimal floats in the
    handshake and answers in them too.
    """
    from ._version import __version__ as version
    from .golden import OPERATIONS

    stdout.write(f"{protocol.GREETING} {protocol.PROTOCOL_VERSION} dynval {version} ({backend or 'default'} backend)\n")
    if encoding != "decimal":
        stdout.write(f"encoding {encoding}\n")
    for operation in OPERATIONS:
        stdout.write(f"capability {operation}\n")
    stdout.write("ready\n")
    stdout.flush()

    decoder = protocol.CaseDecoder(encoding)
    for line in stdin:
        try:
            message = decoder.feed(line)
        except protocol.ProtocolError as exc:
            sys.stderr.write(f"dynval.port: {exc}\n")
            return 3
        if message == "quit":
            return 0
        if message is None:
            continue
        stdout.write("\n".join(answer(message, backend, encoding)) + "\n")
        stdout.flush()  # the runner waits for 'end' before it sends the next case
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m dynval.port --backend python|cpp [--encoding hex]``."""
    parser = argparse.ArgumentParser(
        prog="python -m dynval.port",
        description="dynval as a port of the conformance protocol (golden/PROTOCOL.md), for dynval conform.",
    )
    parser.add_argument("--backend", choices=("python", "cpp"), default=None,
                        help="backend computing the answers (default: dynval's default)")
    parser.add_argument("--encoding", choices=protocol.ENCODINGS, default="decimal",
                        help="number encoding to negotiate: decimal (default) or hex (C99 hexadecimal floats)")
    args = parser.parse_args(argv)
    from .kernels._backend import backends

    if args.backend is not None:
        available = backends()
        if not available.get(args.backend, {}).get("available", False):
            detail = available.get(args.backend, {}).get("detail", "")
            sys.stderr.write(f"dynval.port: backend {args.backend!r} is not available: {detail}\n")
            return 2
    return serve(args.backend, sys.stdin, sys.stdout, args.encoding)


if __name__ == "__main__":
    raise SystemExit(main())
