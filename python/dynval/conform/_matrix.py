"""``dynval conform --matrix``: every known port over every family, as one Markdown table.

The matrix in README.md is this command's output, never typed by hand: ``--write-readme``
puts it between the marker comments, ``--check-readme`` compares a fresh run with what the
README holds (CI runs the check, so the table cannot go stale).

Built-in ports: ``python`` and ``cpp`` (``python -m dynval.port --backend ...``), and
``java``, ``matlab`` (GNU Octave) and ``wolfram`` (Mathics3), each run through the
``run-port`` script at the root of its folder when the folder and its toolchain exist.
A port that cannot run is listed under the table with the reason.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import os
import pathlib
import shlex
import shutil
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any, TextIO

from .._environ import restored_environ
from ._runner import RunResult, run

#: Marker comments delimiting the generated matrix in README.md.
START_MARKER = "<!-- conformance-matrix:start -->"
END_MARKER = "<!-- conformance-matrix:end -->"

#: Row order of the built-in ports.
BUILTIN_PORTS = ("python", "cpp", "java", "matlab", "wolfram")

#: Folder-based ports: folder, toolchain executables, what the row is called in the table.
_FOLDER_PORTS = {
    "java": ("java", ("java", "javac"), "java"),
    "matlab": ("matlab", ("octave-cli",), "matlab (Octave)"),
    "wolfram": ("wolfram", ("mathics",), "wolfram (Mathics)"),
}


@dataclasses.dataclass
class PortSpec:
    """A row of the matrix: its label and its command, or why it cannot run."""

    name: str
    label: str
    command: list[str] | None
    reason: str = ""
    env: dict[str, str] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class MatrixRow:
    spec: PortSpec
    result: RunResult | None


def builtin_port(name: str, root: pathlib.Path) -> PortSpec:
    """The command of a built-in port, or the reason it cannot run here."""
    if name in ("python", "cpp"):
        from ..kernels._backend import backends

        info = backends().get(name, {})
        command = [sys.executable, "-m", "dynval.port", "--backend", name]
        # A verbose editable install prints its rebuild notice on standard output at import.
        env = {"SKBUILD_EDITABLE_VERBOSE": "0"}
        if not info.get("available", False):
            return PortSpec(name, name, None, f"backend {name} is not available: {info.get('detail', '')}", env)
        return PortSpec(name, name, command, env=env)
    if name not in _FOLDER_PORTS:
        raise ValueError(f"unknown port {name!r}; built-in ports: {', '.join(BUILTIN_PORTS)}")
    folder, tools, label = _FOLDER_PORTS[name]
    script = root / folder / "run-port"
    if not script.is_file():
        return PortSpec(name, label, None,
                        f"no {folder}/run-port under {root} (run from a source checkout or pass --root)")
    if not os.access(script, os.X_OK):
        return PortSpec(name, label, None, f"{script} is not executable")
    missing = [tool for tool in tools if shutil.which(tool) is None]
    if missing:
        return PortSpec(name, label, None, f"toolchain missing: {', '.join(missing)} not on PATH "
                                           f"(see {folder}/README.md)")
    return PortSpec(name, label, [str(script)])


def custom_port(text: str) -> PortSpec:
    """``NAME=COMMAND ARGS...`` (shell-like quoting) from ``--port``."""
    name, sep, command = text.partition("=")
    if not sep or not name.strip() or not command.strip():
        raise ValueError(f"--port needs NAME=COMMAND, got {text!r}")
    return PortSpec(name.strip(), name.strip(), shlex.split(command))


def run_matrix(
    specs: Sequence[PortSpec],
    families: Sequence[str],
    *,
    corpus: str | None = None,
    timeout: float = 30.0,
    startup_timeout: float = 300.0,
    max_restarts: int = 25,
    log: Callable[[str], None] | None = None,
    skip_unclaimed: bool = True,
    jobs: int = 1,
) -> list[MatrixRow]:
    """Run every port that can run over ``families``; keep the others with their reason."""
    rows = []
    for spec in specs:
        if spec.command is None:
            rows.append(MatrixRow(spec, None))
            continue
        if log:
            log(f"conform --matrix: running {spec.name} ({shlex.join(spec.command)})")
        with restored_environ(spec.env):
            os.environ.update(spec.env)
            result = run(spec.command, corpus=corpus, families=families, timeout=timeout,
                         startup_timeout=startup_timeout, max_restarts=max_restarts,
                         skip_unclaimed=skip_unclaimed, jobs=jobs,
                         progress=progress_lines(spec.name, log) if log else None)
        if log:
            total = result.counts()["total"]
            log(f"conform --matrix: {spec.name}: {total['passed']} passed, {total['failed']} failed, "
                f"{total['skipped']} skipped, {total['partial']} partial in {result.seconds:.1f} s")
            for line in failure_lines(result):
                log(line)
        rows.append(MatrixRow(spec, result))
    return rows


PROGRESS_SECONDS = 60.0
"""A long port (Mathics3 takes about a second per case) says how far it is this often."""

SHOWN_FAILURES = 20
"""Failed cases listed after a port's counts; the rest are counted."""


def progress_lines(name: str, log: Callable[[str], None], *, every: float = PROGRESS_SECONDS,
                   clock: Callable[[], float] = time.monotonic) -> Callable[[int, int, RunResult], None]:
    """A ``progress`` callback for :func:`run` that logs one line per ``every`` seconds: cases done
    of all, the failures so far, the time spent."""
    start = clock()
    last = [start]

    def progress(done: int, total: int, result: RunResult) -> None:
        now = clock()
        if done < total and now - last[0] >= every:
            last[0] = now
            failed = sum(o.status == "failed" for o in result.outcomes)
            log(f"conform --matrix: {name}: {done}/{total} cases, {failed} failed so far, {now - start:.0f} s")

    return progress


def _short(value: Any, most: int = 160) -> str:
    text = json.dumps(value, ensure_ascii=False, default=str)
    return text if len(text) <= most else text[:most - 1] + "…"


def failure_lines(result: RunResult, most: int = SHOWN_FAILURES) -> list[str]:
    """Each failed case (up to ``most``): its id, operation, conventions, why, and expected against
    got, so that a failure needs no rerun to be read."""
    failed = [o for o in result.outcomes if o.status == "failed"]
    lines = []
    for o in failed[:most]:
        line = f"  FAILED {o.id} ({o.operation}; {o.conventions}): {o.reason}" + (f": {o.detail}" if o.detail else "")
        if o.expected or o.got:
            line += f"; expected {_short(o.expected)}, got {_short(o.got)}"
        lines.append(line)
    if len(failed) > most:
        lines.append(f"  ... and {len(failed) - most} more failed cases (dynval conform -- COMMAND lists them all)")
    return lines


def format_matrix(rows: Sequence[MatrixRow], families: Sequence[str]) -> str:
    """The Markdown table (rows: ports that ran; cells: passed/total), then the ports not run.

    Only facts that a fresh run reproduces go in: no timings, no paths. An optional family the
    port does not claim is ``—``.
    """
    head = "| port | " + " | ".join(f"`{f}`" for f in families) + " | all |"
    rule = "|---|" + "---:|" * (len(families) + 1)
    lines = [head, rule]
    for row in rows:
        if row.result is None:
            continue
        counts = row.result.counts()
        cells = []
        for family in [*families, "total"]:
            if family in row.result.unclaimed:
                cells.append("—")
                continue
            c = counts.get(family, {})
            total = sum(c.values())
            cells.append(f"{c.get('passed', 0)}/{total}")
        if row.result.startup_error:
            cells = ["did not start"] * (len(families) + 1)
        lines.append(f"| {row.spec.label} | " + " | ".join(cells) + " |")
    not_run = [row for row in rows if row.result is None]
    if not_run:
        lines.append("")
        for row in not_run:
            lines.append(f"Not run: {row.spec.label}: {_portable_reason(row.spec.reason)}.")
    return "\n".join(lines)


def _portable_reason(reason: str) -> str:
    # The README is compared across machines: no absolute paths of this one.
    cwd = str(pathlib.Path.cwd())
    return reason.replace(cwd + os.sep, "").replace(f" under {cwd} ", " ").replace(" under . ", " ")


def matrix_ok(rows: Sequence[MatrixRow]) -> bool:
    """True when every port that ran passed every vector it was sent (none failed)."""
    return all(row.result is None or (not row.result.startup_error and row.result.counts()["total"]["failed"] == 0)
               for row in rows)


def readme_block(text: str, path: pathlib.Path) -> tuple[int, int]:
    """Character offsets of the text between the two markers of ``text``."""
    start = text.find(START_MARKER)
    end = text.find(END_MARKER)
    if start < 0 or end < 0 or end < start:
        raise ValueError(f"{path}: the markers {START_MARKER} and {END_MARKER} were not found (in that order)")
    if text.count(START_MARKER) != 1 or text.count(END_MARKER) != 1:
        raise ValueError(f"{path}: each matrix marker must appear exactly once")
    return start + len(START_MARKER), end


def write_readme(path: pathlib.Path, table: str) -> bool:
    """Put ``table`` between the markers of ``path``; True when the file changed."""
    text = path.read_text(encoding="utf-8")
    a, b = readme_block(text, path)
    new = text[:a] + "\n" + table + "\n" + text[b:]
    if new == text:
        return False
    path.write_text(new, encoding="utf-8")
    return True


def check_readme(path: pathlib.Path, table: str, out: TextIO) -> bool:
    """True when the README's matrix equals ``table``; otherwise print a diff."""
    text = path.read_text(encoding="utf-8")
    a, b = readme_block(text, path)
    current = text[a:b].strip("\n")
    if current == table:
        return True
    out.write(f"{path}: the conformance matrix differs from a fresh run "
              "(regenerate it with: dynval conform --matrix --write-readme):\n")
    out.writelines(difflib.unified_diff((current + "\n").splitlines(True), (table + "\n").splitlines(True),
                                        "README (current)", "fresh run"))
    return False


__all__ = [
    "START_MARKER", "END_MARKER", "BUILTIN_PORTS", "PortSpec", "MatrixRow", "builtin_port", "custom_port",
    "run_matrix", "format_matrix", "matrix_ok", "write_readme", "check_readme", "progress_lines", "failure_lines",
]
