"""A port that answers every case with the corpus's own expected values.

It lets the runner's tests exercise the whole exchange (handshake, encoding,
comparison, process handling) without depending on a backend, and it is the
base of the deliberately wrong ports in this directory: each of them changes
one behaviour through a hook and must then be caught by ``dynval conform`` for
that reason.
"""

from __future__ import annotations

import argparse
import importlib.util
import pathlib
import sys
from collections.abc import Callable, Iterable

import numpy as np


def _load(name: str, relative: str):
    # The protocol codec and the corpus loader need only numpy; loading them by
    # path skips the package's __init__ (and its scipy import), which keeps the
    # start-up of these test ports, and of every restart, short.
    # An editable install lists several search locations (the build tree, the
    # source tree, the folder golden/ is mapped from): take the one holding the file.
    locations = importlib.util.find_spec("dynval").submodule_search_locations
    package = next(pathlib.Path(p) for p in locations if (pathlib.Path(p) / relative).is_file())
    spec = importlib.util.spec_from_file_location(name, package / relative)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


protocol = _load("dynval_protocol", "protocol.py")
_loader = _load("dynval_golden_loader", "golden/_loader.py")
OPERATIONS = _load("dynval_golden_ops", "golden/_ops.py").OPERATIONS
iter_cases = _loader.iter_cases

Hook = Callable[[protocol.CaseMessage, object, int], "list[str] | None"]


def expected_reply(case, encoding: str = "decimal") -> list[str]:
    """The answer a perfect port gives: the expected values, or the expected error."""
    values = {k: v for k, v in case.expected.items() if k != "error"}
    if case.result == "invalid" or not values:
        return protocol.encode_reply(error_kind=case.expected["error"], message="expected error")
    return protocol.encode_reply({k: np.asarray(v) for k, v in values.items()}, encoding=encoding)


def parse_args(argv=None, extra: Callable[[argparse.ArgumentParser], None] | None = None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--corpus", default=None, help="corpus directory (default: the shipped corpus)")
    parser.add_argument("--target", default=None, help="case id FAMILY-TCID the hook acts on")
    if extra is not None:
        extra(parser)
    return parser.parse_args(argv)


def serve(
    corpus: str | None,
    hook: Hook | None = None,
    capabilities: Iterable[str] | None = None,
    greeting: str | None = None,
    encoding: str | None = None,
    answer_encoding: str = "decimal",
) -> int:
    """Run the port. ``hook(message, case, count)`` may return replacement answer lines.

    ``encoding`` sends an ``encoding`` handshake line; ``answer_encoding`` is the
    number form of the answers (``hex`` without ``encoding hex`` is a wrong port).
    """
    cases = {(c.family, c.tc_id): c for c in iter_cases(corpus)}
    out = sys.stdout
    out.write(greeting if greeting is not None else f"{protocol.GREETING} {protocol.PROTOCOL_VERSION} oracle\n")
    if encoding is not None:
        out.write(f"encoding {encoding}\n")
    for line in capabilities if capabilities is not None else (f"capability {op}" for op in OPERATIONS):
        out.write(line + "\n")
    out.write("ready\n")
    out.flush()
    decoder = protocol.CaseDecoder(encoding or "decimal")
    count = 0
    for line in sys.stdin:
        message = decoder.feed(line)
        if message == "quit":
            return 0
        if message is None:
            continue
        count += 1
        case = cases[(message.family, message.tc_id)]
        lines = hook(message, case, count) if hook is not None else None
        if lines is None:
            lines = expected_reply(case, answer_encoding)
        out.write("\n".join(lines) + "\n")
        out.flush()
    return 0


def is_target(args, message) -> bool:
    return args.target == f"{message.family}-{message.tc_id}"


