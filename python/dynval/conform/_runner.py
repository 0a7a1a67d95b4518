"""Run the golden corpus through a port and judge every case."""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import protocol
from ..golden import Case, check_case, iter_cases
from . import _orphans
from ._process import PortFailure, PortProcess, PortSet

#: Case statuses, in table order.
STATUSES = ("passed", "failed", "skipped", "partial")

#: Seconds per case, and for start-up and handshake, when neither limit is given.
DEFAULT_TIMEOUT = 30.0
DEFAULT_STARTUP_TIMEOUT = 120.0

#: Base byte budget of one answer; each expected value adds PER_VALUE_BYTES.
BASE_BYTES = 1 << 20
PER_VALUE_BYTES = 64


@dataclass
class CaseOutcome:
    """What happened to one vector.

    ``status`` is ``passed``, ``failed``, ``skipped`` (no capability covers the
    case, or the protocol cannot carry its inputs) or ``partial`` (the covered
    outputs match but some expected outputs are outside the port's capability:
    neither passed nor failed). ``reason`` is a short machine-readable cause.
    """

    id: str
    family: str
    tc_id: int
    operation: str
    conventions: str
    status: str
    reason: str = ""
    detail: str = ""
    seconds: float = 0.0
    flags: tuple[str, ...] = ()
    comment: str = ""
    expected: dict[str, Any] = field(default_factory=dict)
    got: dict[str, Any] = field(default_factory=dict)
    skipped_outputs: tuple[str, ...] = ()


@dataclass
class RunResult:
    """Everything ``dynval conform`` reports."""

    command: list[str]
    corpus: str
    families: list[str]
    port_name: str = ""
    protocol_version: int | None = None
    capabilities: list[str] = field(default_factory=list)
    encoding: str = "decimal"
    outcomes: list[CaseOutcome] = field(default_factory=list)
    restarts: int = 0
    seconds: float = 0.0
    startup_error: str = ""
    #: Optional families (``OPTIONAL_FAMILIES``) left out because the port declares none of their
    #: operations; only when the families were not named explicitly.
    unclaimed: list[str] = field(default_factory=list)

    def counts(self) -> dict[str, dict[str, int]]:
        """Family → status → number of cases (families in corpus order, plus ``total``)."""
        table: dict[str, dict[str, int]] = {f: dict.fromkeys(STATUSES, 0) for f in self.families}
        for o in self.outcomes:
            table.setdefault(o.family, dict.fromkeys(STATUSES, 0))[o.status] += 1
        table["total"] = {s: sum(row[s] for row in table.values()) for s in STATUSES}
        return table

    @property
    def failures(self) -> list[CaseOutcome]:
        return [o for o in self.outcomes if o.status == "failed"]


def _conventions_text(conventions: dict) -> str:
    parts = []
    for key, value in conventions.items():
        try:
            parts.append(f"{key}={protocol.format_value(value)}")
        except TypeError:
            parts.append(f"{key}={value!r}")
    return " ".join(parts)


def _jsonable(value: Any, limit: int = 1000) -> Any:
    """Arrays as nested lists (non-finite numbers as strings), truncated beyond ``limit`` values."""
    arr = np.asarray(value)
    if arr.dtype.kind == "b":
        data: Any = arr.tolist()
    elif arr.dtype.kind in "iu":
        data = arr.tolist()
    elif arr.dtype.kind == "f":
        def conv(x: float) -> Any:
            if np.isnan(x):
                return "NaN"
            if np.isinf(x):
                return "Infinity" if x > 0 else "-Infinity"
            return float(x)

        flat = [conv(x) for x in arr.reshape(-1)[:limit].tolist()]
        if arr.size > limit:
            return {"shape": list(arr.shape), "first_values": flat, "truncated": True}
        data = np.array(flat, dtype=object).reshape(arr.shape).tolist() if arr.ndim else flat[0]
    else:
        return repr(value)
    if arr.size > limit:
        return {"shape": list(arr.shape), "truncated": True}
    return data


def _classify(case: Case, reply: protocol.Reply, detail: str) -> str:
    expected_error = case.expected.get("error")
    if reply.error_kind is not None:
        return "wrong-error" if expected_error is not None else "unexpected-error"
    if case.result == "invalid":
        return "missing-error"
    if ": missing" in detail:
        return "missing-output"
    return "mismatch"


def judge(case: Case, reply: protocol.Reply, covered: frozenset[str] | None) -> tuple[str, str, str, tuple[str, ...]]:
    """Compare a port's reply with the vector: ``(status, reason, detail, skipped_outputs)``."""
    view = case
    skipped: tuple[str, ...] = ()
    if covered is not None and reply.error_kind is None:
        values = [k for k in case.expected if k != "error"]
        skipped = tuple(k for k in values if k not in covered)
        if skipped:
            kept = {k: v for k, v in case.expected.items() if k == "error" or k in covered}
            view = dataclasses.replace(case, expected=kept)
    try:
        if reply.error_kind is not None:
            ok, detail = check_case(view, error_kind=reply.error_kind)
        else:
            ok, detail = check_case(view, outputs=reply.outputs)
    except Exception as exc:  # the port's output must never crash the runner
        # A vector the comparison cannot handle is a corpus defect, not the port's.
        return "failed", "comparison-error", f"cannot compare the answer: {type(exc).__name__}: {exc}", skipped
    if ok:
        return ("partial" if skipped else "passed"), "", "", skipped
    if reply.error_kind is not None and reply.error_message:
        detail += f" (port message: {reply.error_message})"
    return "failed", _classify(case, reply, detail), detail, skipped


def _answer_budget(case: Case) -> int:
    count = sum(int(np.size(v)) for k, v in case.expected.items() if k != "error")
    return BASE_BYTES + PER_VALUE_BYTES * count


def run(
    command: Sequence[str],
    *,
    corpus: str | None = None,
    families: Sequence[str] | None = None,
    timeout: float | None = None,
    startup_timeout: float | None = None,
    max_restarts: int = 25,
    progress: Callable[[int, int, RunResult], None] | None = None,
    skip_unclaimed: bool | None = None,
    jobs: int = 1,
) -> RunResult:
    """Feed every selected vector to the port ``command`` and judge the answers.

    Parameters
    ----------
    command : sequence of str
        The port's command line.
    corpus : path, optional
        Directory holding ``<family>.json`` (default: the corpus shipped with dynval).
    families : sequence of str, optional
        Families to run (default: all, except an optional family in which the port declares
        no operation: it is listed in ``RunResult.unclaimed`` instead).
    timeout : float, optional
        Seconds allowed per case, from sending the case to reading ``end`` (default 30).
    startup_timeout : float, optional
        Seconds allowed for start-up and handshake (also after a restart); default
        ``timeout`` when that is given, else 120. See :func:`resolve_timeouts`.
    max_restarts : int
        Restarts allowed after crashes, timeouts and protocol errors; once spent,
        the remaining covered cases fail with reason ``not-run``.
    progress : callable, optional
        Called as ``progress(done, total, result)`` after every case.
    skip_unclaimed : bool, optional
        Leave out an optional family in which the port declares no operation (default: when
        ``families`` is not given). A family named on purpose is run, and its cases skipped.
    jobs : int
        Port processes run at once, each on an interleaved share of the cases (for ports that
        are slow per case; each has its own ``max_restarts``). Outcomes keep the corpus order.

    Returns
    -------
    RunResult

    Notes
    -----
    Whatever ends the run, an exception too (``KeyboardInterrupt`` from Ctrl-C, or a
    signal the caller turned into an exception), every port process and everything it
    started is killed before this returns or raises. On Linux the calling process is a
    child subreaper meanwhile, so that processes of a port that killed its supervisor are
    found too (``golden/PROTOCOL.md``, section 1).
    """
    from ..golden import FAMILIES

    timeout, startup_timeout = resolve_timeouts(timeout, startup_timeout)
    selected = list(families) if families else list(FAMILIES)
    started = time.monotonic()
    result = RunResult(command=list(command), corpus=str(corpus or ""), families=selected)
    cases = list(iter_cases(corpus, selected))
    with _orphans.adopting(), PortSet() as ports:
        port, dead_reason = _start_port(command, startup_timeout, result, ports)
        capabilities = port.capabilities if port is not None else []
        if (not families if skip_unclaimed is None else skip_unclaimed) and capabilities:
            cases = _without_unclaimed(cases, capabilities, result)
        feeder = _Feeder(command, timeout, startup_timeout, max_restarts, capabilities, result, progress, len(cases),
                         ports)
        feeder.feed(cases, jobs, port, dead_reason)
    result.seconds = time.monotonic() - started
    return result


def _start_port(command: Sequence[str], startup_timeout: float, result: RunResult,
                ports: PortSet) -> tuple[PortProcess | None, str]:
    """Start the port and note its handshake in ``result``: ``(port, "")``, or ``(None, why)``."""
    port = PortProcess(command, startup_timeout, ports=ports)
    try:
        port.start()
    except PortFailure as exc:
        result.startup_error = _with_stderr(str(exc), port)
        return None, result.startup_error
    result.port_name = port.name
    result.protocol_version = port.version
    result.capabilities = [protocol.format_capability(c) for c in port.capabilities]
    result.encoding = port.encoding
    return port, ""


def _without_unclaimed(cases: list[Case], capabilities: Sequence[protocol.Capability],
                       result: RunResult) -> list[Case]:
    """The cases less those of the optional families in which the port declares no operation
    (listed in ``result.unclaimed`` and taken out of ``result.families``)."""
    from ..golden import OPTIONAL_FAMILIES

    declared = {c.operation for c in capabilities}
    for family in OPTIONAL_FAMILIES:
        operations = {c.operation for c in cases if c.family == family}
        if family in result.families and not operations & declared:
            result.unclaimed.append(family)
    if not result.unclaimed:
        return cases
    result.families = [f for f in result.families if f not in result.unclaimed]
    return [c for c in cases if c.family not in result.unclaimed]


class _Feeder:
    """Feeds the cases of one run to its port processes and collects the outcomes.

    The outcomes arrive from one thread per port process with ``jobs > 1``: they are recorded
    under a lock, in the order they arrive, and put back in corpus order at the end.
    """

    def __init__(self, command: Sequence[str], timeout: float, startup_timeout: float, max_restarts: int,
                 capabilities: list[protocol.Capability], result: RunResult,
                 progress: Callable[[int, int, RunResult], None] | None, total: int, ports: PortSet) -> None:
        self.command = command
        self.ports = ports
        self.timeout = timeout
        self.startup_timeout = startup_timeout
        self.max_restarts = max_restarts
        self.capabilities = capabilities
        self.result = result
        self.progress = progress
        self.total = total
        self._lock = threading.Lock()
        self._indexed: list[tuple[int, CaseOutcome]] = []
        self._done = 0

    def feed(self, cases: list[Case], jobs: int, port: PortProcess | None, dead_reason: str) -> None:
        """Run every case, on ``jobs`` port processes, each on an interleaved share of the cases."""
        # A slow port's run divided among cores; every process but the first is started here, like
        # a restart.
        numbered = list(enumerate(cases))
        shards = [numbered[k::jobs] for k in range(max(1, min(jobs, len(numbered))))]
        if len(shards) == 1:
            self.result.restarts = self._exchange(shards[0], port, dead_reason)
        else:
            self.result.restarts = self._exchange_in_parallel(shards, port, dead_reason)
        self.result.outcomes = [outcome for _, outcome in sorted(self._indexed, key=lambda pair: pair[0])]

    def _exchange_in_parallel(self, shards: list[list[tuple[int, Case]]], port: PortProcess | None,
                              dead_reason: str) -> int:
        """One thread and one port process per shard (the first on ``port``); returns the restarts."""
        restarts = [0] * len(shards)

        def shard_worker(k: int) -> None:
            own, reason = (port, dead_reason) if k == 0 else self._another_port(dead_reason)
            restarts[k] = self._exchange(shards[k], own, reason)

        threads = [threading.Thread(target=shard_worker, args=(k,), daemon=True) for k in range(len(shards))]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        return sum(restarts)

    def _another_port(self, dead_reason: str) -> tuple[PortProcess | None, str]:
        """A further port process: ``(port, "")``, or ``(None, why)``."""
        if dead_reason:
            return None, dead_reason
        own = PortProcess(self.command, self.startup_timeout, ports=self.ports)
        try:
            own.start()
        except PortFailure as exc:
            return None, "not run: another port process could not be started: " + _with_stderr(str(exc), own)
        return own, dead_reason

    def _exchange(self, shard: list[tuple[int, Case]], port: PortProcess | None, dead_reason: str) -> int:
        """Send the shard's cases to ``port`` (restarted when it breaks); returns the restarts."""
        worker = _PortWorker(self, port, dead_reason)
        try:
            for index, case in shard:
                self._record(index, worker.outcome(case))
        except BaseException:
            if worker.port is not None:
                worker.port.kill()  # stopped (Ctrl-C, a signal) or broken: no grace for a polite quit
            raise
        if worker.port is not None:
            worker.port.close()
        return worker.restarts

    def _record(self, index: int, outcome: CaseOutcome) -> None:
        with self._lock:
            self._indexed.append((index, outcome))
            self.result.outcomes.append(outcome)
            self._done += 1
            _report_progress(self.progress, self._done, self.total, self.result)


class _PortWorker:
    """One port process and its restarts: ``port`` is None once it broke, and ``dead_reason``
    says why no further case can be sent to it."""

    def __init__(self, feeder: _Feeder, port: PortProcess | None, dead_reason: str) -> None:
        self.feeder = feeder
        self.port = port
        self.dead_reason = dead_reason
        self.restarts = 0

    def outcome(self, case: Case) -> CaseOutcome:
        """Send one case, when the port can take it, and judge the answer."""
        capabilities = self.feeder.capabilities
        outcome = CaseOutcome(
            id=case.id, family=case.family, tc_id=case.tc_id, operation=case.operation,
            conventions=_conventions_text(case.conventions), status="failed",
            flags=case.flags, comment=case.comment,
        )
        if self.dead_reason and not capabilities:
            outcome.reason, outcome.detail = "handshake", self.dead_reason
            return outcome
        covered = protocol.covered_outputs(capabilities, case.operation, case.conventions)
        lines = _encode_or_skip(case, covered, outcome)
        if lines is None:
            return outcome
        outcome.expected = {k: (v if k == "error" else _jsonable(v)) for k, v in case.expected.items()}
        port = self._live_port()
        if port is None:
            outcome.reason, outcome.detail = "not-run", self.dead_reason
            return outcome
        self._send(port, case, lines, covered, outcome)
        return outcome

    def _live_port(self) -> PortProcess | None:
        """The port, restarted if it broke and the budget allows; None with ``dead_reason`` otherwise."""
        max_restarts = self.feeder.max_restarts
        if self.port is None and not self.dead_reason:
            if self.restarts >= max_restarts:
                self.dead_reason = f"not run: the port needed more than {max_restarts} restarts"
            else:
                self.restarts += 1
                self.port = PortProcess(self.feeder.command, self.feeder.startup_timeout, ports=self.feeder.ports)
                try:
                    self.port.start()
                except PortFailure as exc:
                    self.dead_reason = "not run: the port could not be restarted: " + _with_stderr(str(exc), self.port)
                    self.port = None
        return self.port

    def _send(self, port: PortProcess, case: Case, lines: list[str], covered: frozenset[str] | None,
              outcome: CaseOutcome) -> None:
        """Exchange the case with ``port`` and judge the reply into ``outcome``; a port that fails is
        killed and dropped."""
        timeout = self.feeder.timeout
        if port.encoding != "decimal":
            lines = protocol.encode_case(case.family, case.tc_id, case.operation, case.conventions,
                                         case.inputs, encoding=port.encoding)
        t0 = time.monotonic()
        try:
            reply = port.exchange(lines, timeout, _answer_budget(case))
        except PortFailure as exc:
            outcome.seconds = time.monotonic() - t0
            message = str(exc)
            if exc.reason == "timeout":
                message = f"timed out after {timeout:g} s: {message}"
            port.kill()
            outcome.reason, outcome.detail = exc.reason, _with_stderr(message, port)
            self.port = None
            return
        outcome.seconds = time.monotonic() - t0
        _judge_into(outcome, case, reply, covered)


def _encode_or_skip(case: Case, covered: frozenset[str] | bool | None, outcome: CaseOutcome) -> list[str] | None:
    """The case's lines (decimal), or None with ``outcome`` skipped when the port cannot take the case."""
    if covered is False:
        outcome.status, outcome.reason = "skipped", "not-covered"
        outcome.detail = "no capability of the port covers this operation and these conventions"
        return None
    values = [k for k in case.expected if k != "error"]
    if covered is not None and case.result == "valid" and not any(k in covered for k in values):
        outcome.status, outcome.reason = "skipped", "not-covered"
        outcome.detail = "the port computes none of this case's outputs"
        outcome.skipped_outputs = tuple(values)
        return None
    try:
        return protocol.encode_case(case.family, case.tc_id, case.operation, case.conventions, case.inputs)
    except (TypeError, ValueError) as exc:
        outcome.status, outcome.reason = "skipped", "not-expressible"
        outcome.detail = f"protocol {protocol.PROTOCOL_VERSION} cannot carry this case: {exc}"
        return None


def _judge_into(outcome: CaseOutcome, case: Case, reply: protocol.Reply, covered: frozenset[str] | None) -> None:
    """The verdict on ``reply`` and what the port answered, into ``outcome``."""
    outcome.status, outcome.reason, outcome.detail, outcome.skipped_outputs = judge(case, reply, covered)
    if reply.error_kind is not None:
        outcome.got = {"error": reply.error_kind}
    else:
        outcome.got = {k: _jsonable(v) for k, v in reply.outputs.items()}
    if outcome.status != "failed":
        outcome.expected, outcome.got = {}, {}  # keep the report small


def resolve_timeouts(timeout: float | None, startup_timeout: float | None) -> tuple[float, float]:
    """``(per-case, start-up)`` seconds from the limits given (None: not given).

    A limit the user sets bounds the whole run, the handshake included: with only
    ``timeout`` given, a port that never greets is given up after ``timeout``
    seconds, not after the default start-up allowance. ``startup_timeout`` is
    there for ports that need a long start (a JVM, Mathics3) but answer fast.
    """
    if startup_timeout is None:
        startup_timeout = DEFAULT_STARTUP_TIMEOUT if timeout is None else timeout
    return (DEFAULT_TIMEOUT if timeout is None else timeout), startup_timeout


def _with_stderr(message: str, port: PortProcess | None) -> str:
    tail = port.stderr_tail() if port is not None else ""
    if tail:
        last = tail.splitlines()[-5:]
        message += " | port stderr: " + " / ".join(line.strip() for line in last)
    return message


def _report_progress(progress, done: int, total: int, result: RunResult) -> None:
    if progress is not None:
        progress(done, total, result)
