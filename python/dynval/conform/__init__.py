"""``dynval conform``: prove a port of dynval right against the golden corpus.

A *port* is any program that speaks the line protocol of ``golden/PROTOCOL.md``
on its standard input and output. The runner starts it once, reads its
handshake (protocol version and capabilities), sends it every vector it claims
to handle, compares the answers with each vector's tolerance and prints a table
per family::

    dynval conform --families norms,errors --report out.json -- ./my_port --flag

Exit status: 0 when no case failed, 1 when any case failed, when no case
was run at all (every case skipped: the port declared nothing the corpus
covers) or, with ``--strict``, when any case was skipped or partial; 2 for a
usage error; 128 + the signal's number (130, 143, 129) when SIGINT (Ctrl-C), SIGTERM
or SIGHUP stopped the run, after every port process was killed.

``dynval conform --matrix`` runs the known ports (python, cpp, java, matlab,
wolfram; ``--ports`` picks some, ``--port NAME=COMMAND`` adds others) over every
family and prints the conformance matrix as Markdown; ``--write-readme`` puts it
into README.md between its marker comments and ``--check-readme`` exits 1 when
README.md's matrix differs from the fresh run.

Examples
--------
>>> from dynval.conform import main
>>> main(["--families", "norms", "--quiet", "--", "false"])  # doctest: +SKIP
1
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import signal
import sys
import time
from collections.abc import Sequence
from typing import TextIO

from .. import protocol
from ._matrix import BUILTIN_PORTS
from ._process import PortFailure, PortProcess, describe_command
from ._runner import STATUSES, CaseOutcome, RunResult, judge, run
from ._signals import exit_status, stopping_on_signals

__all__ = ["main", "run", "RunResult", "CaseOutcome", "PortProcess", "PortFailure", "judge", "write_report"]

REPORT_SCHEMA_VERSION = 1


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dynval conform",
        description=(
            "Run dynval's golden corpus through a port (any command speaking golden/PROTOCOL.md) "
            "and report passed / failed / skipped cases per family."
        ),
        epilog="Example: dynval conform --families norms,errors --report out.json -- ./my_port",
    )
    parser.add_argument("--families", metavar="F,...", help="comma-separated corpus families (default: all)")
    parser.add_argument("--timeout", type=float, default=None, metavar="S",
                        help="seconds allowed per case, and for the handshake unless --startup-timeout is given "
                             "(default 30)")
    parser.add_argument(
        "--startup-timeout", type=float, default=None, metavar="S",
        help="seconds allowed for start-up and handshake (default: --timeout if given, else 120)",
    )
    parser.add_argument("--report", metavar="FILE", help="write a JSON report to FILE")
    parser.add_argument("--corpus", metavar="DIR",
                        help="corpus directory holding <family>.json (default: the shipped corpus)")
    parser.add_argument("--max-failures", type=int, default=10, metavar="K",
                        help="failures shown in detail (default 10)")
    parser.add_argument("--max-restarts", type=int, default=25, metavar="R", help="port restarts allowed (default 25)")
    parser.add_argument("--jobs", type=int, default=1, metavar="J",
                        help="port processes run at once, each on an interleaved share of the cases (default 1; "
                             "for ports that are slow per case)")
    parser.add_argument("--strict", action="store_true", help="also fail when a case is skipped or partial")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    matrix = parser.add_argument_group("conformance matrix (no command after --)")
    matrix.add_argument("--matrix", action="store_true",
                        help="run the known ports over the families and print the passed/total matrix (Markdown)")
    matrix.add_argument("--ports", metavar="P,...",
                        help=f"built-in ports to run (default: all of {','.join(BUILTIN_PORTS)}, or none with --port)")
    matrix.add_argument("--port", action="append", default=[], metavar="NAME=COMMAND",
                        help="an extra row: a port command (shell-like quoting); repeatable")
    matrix.add_argument("--root", metavar="DIR", default=".",
                        help="source checkout holding java/, matlab/, wolfram/ and README.md (default: .)")
    matrix.add_argument("--write-readme", nargs="?", const="", default=None, metavar="FILE",
                        help="write the matrix between the marker comments of FILE (default: ROOT/README.md)")
    matrix.add_argument("--check-readme", nargs="?", const="", default=None, metavar="FILE",
                        help="exit 1 when the matrix in FILE (default: ROOT/README.md) differs from the fresh run")
    return parser


def _split_command(argv: list[str]) -> tuple[list[str], list[str]]:
    if "--" in argv:
        i = argv.index("--")
        return argv[:i], argv[i + 1 :]
    return argv, []


def _resolve_corpus(path: str | None, families: list[str], explicit: bool) -> pathlib.Path | None:
    """The corpus directory; an optional family not named on purpose may be missing from it
    (it is then removed from ``families``)."""
    from ..golden import OPTIONAL_FAMILIES

    if path is None:
        return None
    directory = pathlib.Path(path)
    if not (directory / f"{families[0]}.json").is_file() and (directory / "vectors").is_dir():
        directory = directory / "vectors"  # the golden/ root was given
    for family in list(families):
        if not (directory / f"{family}.json").is_file():
            if not explicit and family in OPTIONAL_FAMILIES:
                families.remove(family)
                continue
            raise FileNotFoundError(f"--corpus {path}: no {family}.json in {directory}")
    return directory


class _Progress:
    """Progress on standard error: one rewritten line on a terminal, a line every 10 s otherwise."""

    def __init__(self, stream: TextIO, enabled: bool) -> None:
        self.stream = stream
        self.enabled = enabled
        self.tty = enabled and hasattr(stream, "isatty") and stream.isatty()
        self.start = time.monotonic()
        self.last = self.start
        self.shown = False

    def __call__(self, done: int, total: int, result: RunResult) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        interval = 0.2 if self.tty else 10.0
        if now - self.last < interval and done != total:
            return
        if not self.tty and done == total and not self.shown:
            return  # short run: no progress lines at all
        self.last = now
        failed = sum(1 for o in result.outcomes if o.status == "failed")
        current = result.outcomes[-1].id if result.outcomes else ""
        text = f"conform: {done}/{total} cases, {failed} failed, {now - self.start:.0f} s  {current}"
        if self.tty:
            self.stream.write("\r" + text[:100].ljust(100))
            if done == total:
                self.stream.write("\n")
        else:
            self.stream.write(text + "\n")
        self.stream.flush()
        self.shown = True


def format_table(result: RunResult) -> str:
    """The per-family table of passed / failed / skipped / partial cases."""
    counts = result.counts()
    width = max(len(name) for name in counts)
    head = f"{'family':<{width}}  " + "  ".join(f"{s:>7}" for s in STATUSES)
    lines = [head, "-" * len(head)]
    for name, row in counts.items():
        if name == "total":
            lines.append("-" * len(head))
        lines.append(f"{name:<{width}}  " + "  ".join(f"{row[s]:>7}" for s in STATUSES))
    return "\n".join(lines)


def format_failure(o: CaseOutcome) -> str:
    """A failed case: id, operation, conventions, flags, comment and expected vs got."""
    lines = [f"FAILED {o.id}  [{o.reason}]  {o.operation} {o.conventions}".rstrip()]
    if o.comment:
        lines.append(f"    comment:  {o.comment}")
    if o.flags:
        lines.append(f"    flags:    {', '.join(o.flags)}")
    lines.append(f"    detail:   {o.detail}")
    if o.expected:
        lines.append(f"    expected: {_short(o.expected)}")
    if o.got:
        lines.append(f"    got:      {_short(o.got)}")
    return "\n".join(lines)


def _short(mapping: dict, limit: int = 300) -> str:
    text = json.dumps(mapping, allow_nan=False)
    return text if len(text) <= limit else text[:limit] + " ..."


def _report_dict(result: RunResult, exit_code: int) -> dict:
    import dynval.golden as golden

    try:
        from .._version import __version__ as version
    except ImportError:  # the package facade is optional for the runner
        version = None
    return {
        "report": "dynval-conform",
        "report_schema_version": REPORT_SCHEMA_VERSION,
        "protocol_version": protocol.PROTOCOL_VERSION,
        "dynval_version": version,
        "command": result.command,
        "corpus": result.corpus or str(golden.corpus_dir()),
        "families": result.families,
        "unclaimed_families": result.unclaimed,
        "port": {
            "name": result.port_name,
            "protocol_version": result.protocol_version,
            "capabilities": result.capabilities,
            "encoding": result.encoding,
            "startup_error": result.startup_error,
        },
        "restarts": result.restarts,
        "seconds": round(result.seconds, 3),
        "exit_code": exit_code,
        "counts": result.counts(),
        "cases": [
            {
                "id": o.id,
                "family": o.family,
                "tcId": o.tc_id,
                "operation": o.operation,
                "conventions": o.conventions,
                "status": o.status,
                "reason": o.reason,
                "detail": o.detail,
                "seconds": round(o.seconds, 6),
                "flags": list(o.flags),
                "comment": o.comment,
                "skipped_outputs": list(o.skipped_outputs),
                **({"expected": o.expected, "got": o.got} if o.status == "failed" else {}),
            }
            for o in result.outcomes
        ],
    }


def write_report(result: RunResult, path: str | os.PathLike, exit_code: int) -> None:
    """Write the JSON report (strict JSON: non-finite numbers are strings)."""
    data = _report_dict(result, exit_code)
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(data, handle, indent=1, allow_nan=False)
        handle.write("\n")


def _check_numbers(args) -> str:
    for name, value in (("--timeout", args.timeout), ("--startup-timeout", args.startup_timeout)):
        if value is not None and not (value > 0 and math.isfinite(value)):
            return f"dynval conform: {name} must be a positive number of seconds, got {value!r}\n"
    if args.max_failures < 0 or args.max_restarts < 0:
        return "dynval conform: --max-failures and --max-restarts must be >= 0\n"
    if args.jobs < 1:
        return f"dynval conform: --jobs must be a positive integer, got {args.jobs}\n"
    return ""


def _families(args, err: TextIO) -> list[str] | None:
    from ..golden import FAMILIES

    if not args.families:
        return list(FAMILIES)
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown or not families:
        err.write(f"dynval conform: --families must be among {', '.join(FAMILIES)}, got {args.families!r}\n")
        return None
    return families


def _matrix_main(args, out: TextIO, err: TextIO) -> int:
    """``dynval conform --matrix [...]``: 0 when every port that ran passed (and README matches)."""
    from . import _matrix

    families = _families(args, err)
    if families is None:
        return 2
    problem = _check_numbers(args)
    if problem:
        err.write(problem)
        return 2
    if args.write_readme is not None and args.check_readme is not None:
        err.write("dynval conform: --write-readme and --check-readme exclude each other\n")
        return 2
    root = pathlib.Path(args.root)
    try:
        corpus = _resolve_corpus(args.corpus, families, bool(args.families))
        if args.ports is not None:
            names = [p.strip() for p in args.ports.split(",") if p.strip()]
        else:
            names = [] if args.port else list(BUILTIN_PORTS)
        specs = [_matrix.builtin_port(name, root) for name in names]
        specs += [_matrix.custom_port(text) for text in args.port]
    except (FileNotFoundError, ValueError) as exc:
        err.write(f"dynval conform: {exc}\n")
        return 2
    if not specs:
        err.write("dynval conform --matrix: no port selected\n")
        return 2
    readme = None
    for option in (args.write_readme, args.check_readme):
        if option is not None:
            readme = pathlib.Path(option) if option else root / "README.md"
            try:
                _matrix.readme_block(readme.read_text(encoding="utf-8"), readme)
            except (OSError, ValueError) as exc:
                err.write(f"dynval conform: {exc}\n")
                return 2

    def log(text: str) -> None:
        if not args.quiet:
            err.write(text + "\n")
            err.flush()

    rows = _matrix.run_matrix(specs, families, corpus=str(corpus) if corpus else None, timeout=args.timeout,
                              startup_timeout=args.startup_timeout, max_restarts=args.max_restarts, log=log,
                              skip_unclaimed=not args.families, jobs=args.jobs)
    table = _matrix.format_matrix(rows, families)
    out.write(table + "\n")
    for row in rows:
        if row.result is not None and row.result.startup_error:
            out.write(f"\n{row.spec.label} did not start: {row.result.startup_error}\n")
    code = 0 if _matrix.matrix_ok(rows) else 1
    if args.write_readme is not None:
        changed = _matrix.write_readme(readme, table)
        out.write(f"\n{readme}: matrix {'updated' if changed else 'already current'}\n")
    if args.check_readme is not None:
        if _matrix.check_readme(readme, table, out):
            out.write(f"\n{readme}: matrix is current\n")
        else:
            code = 1
    out.flush()
    return code


def _warn_nothing_tested(result: RunResult, err: TextIO) -> None:
    # An all-skipped run is not a pass: it proves nothing about the port, even without --strict.
    declared = ", ".join(result.capabilities) or "none"
    err.write(
        f"dynval conform: error: nothing was tested: the port's capabilities cover none of the {len(result.outcomes)} "
        f"selected vectors (declared capabilities: {declared}); exit status 1\n"
    )
    err.flush()


def main(argv: Sequence[str] | None = None, *, stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    """Command-line entry point of ``dynval conform`` (``argv`` after the word ``conform``).

    Returns
    -------
    int
        0 (no failure), 1 (a case failed, no case ran, or skipped/partial with
        ``--strict``), 2 (usage error), 128 + the signal's number when SIGINT, SIGTERM
        or SIGHUP stopped the run (the ports are killed first; one line on ``stderr``).
    """
    err = stderr or sys.stderr
    try:
        with stopping_on_signals():
            return _main(argv, stdout or sys.stdout, err)
    except KeyboardInterrupt as exc:  # the run has killed its ports on the way out
        signum = getattr(exc, "signum", signal.SIGINT)
        err.write(f"dynval conform: interrupted by {signal.Signals(signum).name}\n")
        err.flush()
        return exit_status(signum)


def _main(argv: Sequence[str] | None, out: TextIO, err: TextIO) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    options, command = _split_command(argv)
    parser = _build_parser()
    try:
        args = parser.parse_args(options)
    except SystemExit as exc:
        return int(exc.code or 0) if exc.code in (0, None) else 2
    if args.matrix:
        if command:
            err.write("dynval conform --matrix runs the known ports: give no command after '--' "
                      "(use --port NAME=CMD)\n")
            return 2
        return _matrix_main(args, out, err)
    if args.write_readme is not None or args.check_readme is not None or args.ports or args.port:
        err.write("dynval conform: --ports, --port, --write-readme and --check-readme need --matrix\n")
        return 2
    if not command:
        err.write("dynval conform: give the port command after '--', e.g. dynval conform -- ./my_port\n")
        return 2
    families = _families(args, err)
    if families is None:
        return 2
    problem = _check_numbers(args)
    if problem:
        err.write(problem)
        return 2
    try:
        corpus = _resolve_corpus(args.corpus, families, bool(args.families))
    except FileNotFoundError as exc:
        err.write(f"dynval conform: {exc}\n")
        return 2

    progress = _Progress(err, enabled=not args.quiet)
    result = run(
        command,
        corpus=str(corpus) if corpus else None,
        families=families,
        timeout=args.timeout,
        startup_timeout=args.startup_timeout,
        max_restarts=args.max_restarts,
        progress=progress,
        skip_unclaimed=not args.families,
        jobs=args.jobs,
    )
    counts = result.counts()["total"]
    failed = counts["failed"] > 0
    incomplete = counts["skipped"] + counts["partial"] > 0
    nothing_ran = counts["passed"] + counts["failed"] + counts["partial"] == 0
    exit_code = 1 if failed or nothing_ran or (args.strict and incomplete) else 0
    if nothing_ran:
        _warn_nothing_tested(result, err)

    port = result.port_name or describe_command(command)
    numbers = ", hexadecimal floats" if result.encoding == "hex" else ""
    out.write(f"dynval conform: protocol {protocol.PROTOCOL_VERSION}{numbers}, port {port}\n")
    if result.startup_error:
        out.write(f"port did not start: {result.startup_error}\n")
    out.write(format_table(result) + "\n")
    if result.unclaimed:
        out.write(f"optional families not claimed by the port (it declares none of their operations), not run: "
                  f"{', '.join(result.unclaimed)}\n")
    if result.restarts:
        out.write(f"port restarts: {result.restarts}\n")
    failures = result.failures
    if failures and args.max_failures:
        shown = failures[: args.max_failures]
        out.write(f"\nfirst {len(shown)} of {len(failures)} failures:\n")
        for o in shown:
            out.write(format_failure(o) + "\n")
    if counts["skipped"] or counts["partial"]:
        out.write(
            f"\n{counts['skipped']} skipped and {counts['partial']} partial cases were not checked in full "
            "(outside the port's declared capabilities, or not expressible in the protocol).\n"
        )
    verdict = "FAILED" if exit_code else "OK"
    out.write(
        f"{verdict}: {counts['passed']} passed, {counts['failed']} failed, {counts['skipped']} skipped, "
        f"{counts['partial']} partial in {result.seconds:.1f} s\n"
    )
    if args.report:
        write_report(result, args.report, exit_code)
        out.write(f"report written to {args.report}\n")
    out.flush()
    return exit_code
