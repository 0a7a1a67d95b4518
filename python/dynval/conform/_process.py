"""One running port: start, handshake, exchange lines under hard deadlines, kill.

Reads happen in daemon threads that only move bytes into queues, so the runner
never blocks on a port: every wait has a deadline, every read a byte budget,
and a port that misbehaves is killed (with its whole process group on POSIX, so
a shell wrapper cannot leave the real program running).
"""

from __future__ import annotations

import collections
import os
import queue
import signal
import subprocess
import threading
import time
from typing import Sequence

from .. import protocol

#: Bytes of the port's standard error kept for failure reports.
STDERR_TAIL = 4096


class PortFailure(Exception):
    """The port broke the exchange: crashed, hung, flooded or wrote garbage.

    ``reason`` is one of ``crash``, ``timeout``, ``flood``, ``garbage``,
    ``handshake``; the message says what happened.
    """

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


class PortProcess:
    """A port started from ``command`` and spoken to in protocol lines.

    Parameters
    ----------
    command : sequence of str
        The port's command line.
    startup_timeout : float
        Seconds allowed between start and the ``ready`` line.
    """

    def __init__(self, command: Sequence[str], startup_timeout: float) -> None:
        self.command = list(command)
        self.startup_timeout = startup_timeout
        self.version: int | None = None
        self.name = ""
        self.capabilities: list[protocol.Capability] = []
        #: Number encoding the port asked for (``encoding hex`` in its handshake).
        self.encoding = "decimal"
        self._proc: subprocess.Popen | None = None
        # Bounded, so a flooding port is slowed down by the pipe instead of
        # filling the runner's memory before the budget check sees it.
        self._chunks: queue.Queue = queue.Queue(maxsize=64)
        self._stopped = threading.Event()
        self._buffer = bytearray()
        self._eof = False
        self._stderr: collections.deque = collections.deque()
        self._stderr_size = 0
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ life cycle

    def start(self) -> None:
        """Start the port and read its handshake (raises :class:`PortFailure`)."""
        kwargs: dict = {}
        if os.name == "posix":
            kwargs["start_new_session"] = True  # own process group, killed as a whole
        else:  # pragma: no cover - Windows
            kwargs["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
        try:
            self._proc = subprocess.Popen(
                self.command,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                bufsize=0,
                **kwargs,
            )
        except OSError as exc:
            raise PortFailure("handshake", f"cannot start the port {self.command[0]!r}: {exc}") from None
        threading.Thread(target=self._pump_stdout, args=(self._proc.stdout,), daemon=True).start()
        threading.Thread(target=self._pump_stderr, args=(self._proc.stderr,), daemon=True).start()
        self._handshake()

    def _handshake(self) -> None:
        deadline = time.monotonic() + self.startup_timeout
        budget = [1 << 20]
        try:
            line = self._next_line(deadline, budget, "the greeting")
            version, name = protocol.parse_greeting(line)
            if version != protocol.PROTOCOL_VERSION:
                raise PortFailure(
                    "handshake",
                    f"the port speaks protocol {version}; this runner speaks protocol {protocol.PROTOCOL_VERSION}",
                )
            self.version, self.name = version, name
            lines, encodings = [], []
            while True:
                line = self._next_line(deadline, budget, "the capability lines")
                tokens = protocol.split_line(line)
                if tokens == ["ready"]:
                    break
                if tokens and tokens[0] == "encoding":
                    encodings.append(protocol.parse_encoding(line))
                else:
                    lines.append(line)
            if len(encodings) > 1:
                raise protocol.ProtocolError(f"the encoding line was sent {len(encodings)} times")
            self.encoding = encodings[0] if encodings else "decimal"
            # Filters may hold float values, which a hex port may write in hex.
            hex_ok = self.encoding == "hex"
            self.capabilities = [protocol.parse_capability(line, hex_ok=hex_ok) for line in lines]
        except protocol.ProtocolError as exc:
            self.kill()
            raise PortFailure("handshake", f"bad handshake: {exc}") from None
        except PortFailure as exc:
            self.kill()
            raise PortFailure("handshake", f"handshake failed: {exc}") from None

    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None and not self._eof

    def kill(self) -> None:
        """Kill the port (and its process group) and reap it."""
        proc = self._proc
        if proc is None:
            return
        self._stopped.set()
        if proc.poll() is None:
            try:
                if os.name == "posix":
                    os.killpg(proc.pid, signal.SIGKILL)
                else:  # pragma: no cover - Windows
                    proc.kill()
            except (ProcessLookupError, PermissionError, OSError):
                pass
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:  # pragma: no cover - unkillable process
            pass
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass

    def close(self, grace: float = 2.0) -> None:
        """Send ``quit``, give the port ``grace`` seconds to exit, then kill it."""
        proc = self._proc
        if proc is None:
            return
        if proc.poll() is None:
            try:
                proc.stdin.write(b"quit\n")
                proc.stdin.flush()
                proc.stdin.close()
            except (OSError, ValueError):
                pass
            try:
                proc.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                pass
        self.kill()

    # ------------------------------------------------------------------ exchange

    def exchange(self, lines: Sequence[str], timeout: float, max_bytes: int) -> protocol.Reply:
        """Send one case and read the answer.

        Raises
        ------
        PortFailure
            ``timeout`` when no ``end`` arrives within ``timeout`` seconds,
            ``flood`` when the answer exceeds ``max_bytes``, ``garbage`` for a
            line outside the grammar, ``crash`` when the port exits. The caller
            kills the port after any of these.
        """
        payload = ("\n".join(lines) + "\n").encode("ascii")
        # A port that stops reading its input must not block the runner: the
        # write goes through a thread, and killing the port ends that thread.
        threading.Thread(target=self._write, args=(payload,), daemon=True).start()
        deadline = time.monotonic() + timeout
        budget = [max_bytes]
        decoder = protocol.ReplyDecoder(self.encoding)
        while True:
            line = self._next_line(deadline, budget, "the answer")
            try:
                reply = decoder.feed(line)
            except protocol.ProtocolError as exc:
                raise PortFailure("garbage", f"garbage from the port: {exc}") from None
            if reply is not None:
                return reply

    def _write(self, payload: bytes) -> None:
        proc = self._proc
        try:
            proc.stdin.write(payload)
            proc.stdin.flush()
        except (OSError, ValueError):
            pass  # the port died; the reader reports it

    def _next_line(self, deadline: float, budget: list[int], what: str) -> str:
        while True:
            newline = self._buffer.find(b"\n")
            if newline >= 0:
                raw = bytes(self._buffer[: newline + 1])
                del self._buffer[: newline + 1]
                budget[0] -= len(raw)
                if budget[0] < 0:
                    raise PortFailure("flood", f"output flood: the port wrote more than the allowed bytes while sending {what}")
                try:
                    return raw.decode("ascii").rstrip("\r\n")
                except UnicodeDecodeError:
                    raise PortFailure("garbage", f"garbage from the port: non-ASCII bytes in {raw[:60]!r}") from None
            if len(self._buffer) > budget[0]:
                raise PortFailure("flood", f"output flood: a line longer than {budget[0] + 1} bytes while reading {what}")
            if self._eof:
                raise PortFailure("crash", self._exit_message(what))
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise PortFailure("timeout", f"no complete answer within the time limit while waiting for {what}")
            try:
                chunk = self._chunks.get(timeout=min(remaining, 0.5))
            except queue.Empty:
                continue
            if chunk is None:
                self._eof = True
            else:
                self._buffer += chunk

    def _exit_message(self, what: str) -> str:
        proc = self._proc
        try:
            code = proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            return f"the port closed its output without exiting while sending {what}"
        if code < 0:
            try:
                sig = signal.Signals(-code).name
            except ValueError:
                sig = str(-code)
            return f"the port was killed by signal {sig} while sending {what}"
        return f"the port exited with code {code} while sending {what}"

    # ------------------------------------------------------------------ pumps

    def _pump_stdout(self, stream) -> None:
        try:
            while True:
                chunk = os.read(stream.fileno(), 65536)
                if not chunk:
                    break
                if not self._put(chunk):
                    return
        except (OSError, ValueError):
            pass
        self._put(None)

    def _put(self, item) -> bool:
        while not self._stopped.is_set():
            try:
                self._chunks.put(item, timeout=0.2)
                return True
            except queue.Full:
                continue
        return False

    def _pump_stderr(self, stream) -> None:
        try:
            while True:
                chunk = os.read(stream.fileno(), 65536)
                if not chunk:
                    break
                with self._lock:
                    self._stderr.append(chunk)
                    self._stderr_size += len(chunk)
                    while self._stderr_size - len(self._stderr[0]) >= STDERR_TAIL and len(self._stderr) > 1:
                        self._stderr_size -= len(self._stderr.popleft())
        except (OSError, ValueError):
            pass

    def stderr_tail(self) -> str:
        """The last few kilobytes the port wrote on standard error."""
        with self._lock:
            data = b"".join(self._stderr)[-STDERR_TAIL:]
        return data.decode("utf-8", errors="replace").strip()


def describe_command(command: Sequence[str]) -> str:
    """The command as one shell-like string, for reports."""
    import shlex

    return " ".join(shlex.quote(c) for c in command)


__all__ = ["PortFailure", "PortProcess", "describe_command", "STDERR_TAIL"]
