"""One running port: start, handshake, exchange lines under hard deadlines, kill.

Reads happen in daemon threads that only move bytes into queues, so the runner
never blocks on a port: every wait has a deadline, every read a byte budget,
and a port that misbehaves is killed (with its whole process group on POSIX, so
a shell wrapper cannot leave the real program running).

On Linux the port runs under a small supervisor (``_reaper.py``, a child
subreaper): processes the port leaves behind, even those that left its process
group with ``setsid()``, are killed when the port exits or is killed. A port that
kills the supervisor too leaves its processes to the runner, itself a subreaper
while it runs (``_orphans.py``), which kills them with the port. The runner
never reaps a port before killing its group, so the group id it signals cannot
name an unrelated process.

The ports of one run are enlisted in a :class:`PortSet`, so that a run stopped
by a signal kills every one of them, those being started in other threads too.
"""

from __future__ import annotations

import collections
import os
import pathlib
import queue
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence

from .. import protocol
from . import _orphans

#: Bytes of the port's standard error kept for failure reports.
STDERR_TAIL = 4096

#: Seconds the supervisor gets to kill what the port left behind before the group is killed.
CLEANUP_GRACE = 5.0

_REAPER = pathlib.Path(__file__).with_name("_reaper.py")


def _supervisor_available() -> bool:
    # The supervisor needs prctl and /proc (Linux) and an interpreter to run it with.
    return sys.platform.startswith("linux") and bool(sys.executable) and _REAPER.is_file() \
        and os.path.isdir("/proc")


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
    ports : PortSet, optional
        The run's ports, which this one joins as soon as it is started.
    """

    def __init__(self, command: Sequence[str], startup_timeout: float, *, ports: PortSet | None = None) -> None:
        self.command = list(command)
        self.startup_timeout = startup_timeout
        self.ports = ports
        #: Marks every process of this port, for the runner to find them should the supervisor die.
        self.token = _orphans.new_token()
        self.version: int | None = None
        self.name = ""
        self.capabilities: list[protocol.Capability] = []
        #: Number encoding the port asked for (``encoding hex`` in its handshake).
        self.encoding = "decimal"
        self._proc: subprocess.Popen | None = None
        #: True when the port runs under the supervisor (``_reaper.py``).
        self._supervised = False
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
        deadline = time.monotonic() + self.startup_timeout
        if os.name == "posix" and _supervisor_available():
            self._spawn_supervised(deadline)
        else:
            self._spawn_plain()
        threading.Thread(target=self._pump_stdout, args=(self._proc.stdout,), daemon=True).start()
        self._stderr_reader = threading.Thread(target=self._pump_stderr, args=(self._proc.stderr,), daemon=True)
        self._stderr_reader.start()
        self._handshake(deadline)

    def _popen(self, command: list[str], **kwargs) -> subprocess.Popen:
        if os.name == "posix":
            kwargs["start_new_session"] = True  # own process group, killed as a whole
        else:  # pragma: no cover - Windows
            kwargs["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
        return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                bufsize=0, **kwargs)

    def _spawn_plain(self) -> None:
        try:
            self._proc = self._popen(self.command)
        except OSError as exc:
            raise PortFailure("handshake", f"cannot start the port {self.command[0]!r}: {exc}") from None
        self._enlist()

    def _enlist(self) -> None:
        # At once after the start: a run stopped from now on kills this port too.
        if self.ports is not None and not self.ports.enlist(self):
            self.kill()
            raise PortFailure("handshake", "not started: the run is being stopped")

    def _spawn_supervised(self, deadline: float) -> None:
        # The supervisor starts the port itself and says on a private pipe whether
        # that worked, so a missing program is still reported as such.
        read_end, write_end = os.pipe()
        try:
            command = [sys.executable, "-I", "-S", str(_REAPER), str(write_end), str(os.getpid()), self.token,
                       "--", *self.command]
            try:
                self._proc = self._popen(command, pass_fds=(write_end,))
            except OSError as exc:
                raise PortFailure("handshake", f"cannot start the port supervisor {sys.executable!r}: {exc}") from None
            self._supervised = True
            os.close(write_end)
            write_end = -1
            self._enlist()
            status = self._read_status(read_end, deadline)
        finally:
            os.close(read_end)
            if write_end >= 0:
                os.close(write_end)
        if status != "ok":
            self.kill()
            detail = status[len("error "):] if status.startswith("error ") else "the supervisor failed to start it"
            raise PortFailure("handshake", f"cannot start the port {self.command[0]!r}: {detail}")

    @staticmethod
    def _read_status(fd: int, deadline: float) -> str:
        poller = select.poll()  # not select(): it cannot watch descriptors above 1023
        poller.register(fd, select.POLLIN)
        data = b""
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not poller.poll(remaining * 1000):
                return "error no word from the supervisor within the start-up time"
            chunk = os.read(fd, 4096)
            if not chunk:
                return data.decode("utf-8", "replace")
            data += chunk

    def _handshake(self, deadline: float) -> None:
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
            if exc.reason == "timeout":
                raise PortFailure("handshake", f"handshake failed: timed out after {self.startup_timeout:g} s "
                                               f"(--startup-timeout): {exc}") from None
            raise PortFailure("handshake", f"handshake failed: {exc}") from None

    def alive(self) -> bool:
        return self._proc is not None and self._exit_status(0) is None and not self._eof

    def _exit_status(self, timeout: float) -> int | None:
        """The port's return code once it has exited (within ``timeout`` s), else None.

        Does not reap it where the platform allows (``waitid`` with ``WNOWAIT``): while
        the exited port is not reaped, its pid and process group id cannot be reused.
        """
        proc = self._proc
        deadline = time.monotonic() + timeout
        while True:
            if proc.returncode is not None:
                return proc.returncode
            code = self._peek_exit(proc)
            if code is not None:
                return code
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.02)

    @staticmethod
    def _peek_exit(proc: subprocess.Popen) -> int | None:
        if not hasattr(os, "waitid"):  # pragma: no cover - macOS, Windows
            return proc.poll()
        try:
            info = os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return proc.poll()
        if info is None:
            return None
        return info.si_status if info.si_code == os.CLD_EXITED else -info.si_status

    def kill(self) -> None:
        """Kill the port, everything it started, and reap it."""
        proc = self._proc
        if proc is None:
            return
        self._stopped.set()
        if proc.returncode is None:  # not reaped: proc.pid still names our process and its group
            if os.name == "posix":
                if self._supervised:
                    # The supervisor kills every descendant, those outside the group too.
                    self._signal(lambda: os.kill(proc.pid, signal.SIGTERM))
                    self._exit_status(CLEANUP_GRACE)
                self._signal(lambda: os.killpg(proc.pid, signal.SIGKILL))
            else:  # pragma: no cover - Windows
                self._signal(proc.kill)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:  # pragma: no cover - unkillable process
            pass
        if self._supervised:
            _orphans.kill_adopted([self.token])  # what the port kept after killing its supervisor
        # What the port wrote on stderr before it died is the report's evidence: let the reader
        # reach the end of the pipe before it is closed (a loaded machine schedules it late).
        reader = getattr(self, "_stderr_reader", None)
        if reader is not None:
            reader.join(timeout=1.0)
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass

    @staticmethod
    def _signal(send) -> None:
        try:
            send()
        except (ProcessLookupError, PermissionError, OSError):
            pass  # already gone

    def close(self, grace: float = 2.0) -> None:
        """Send ``quit``, give the port ``grace`` seconds to exit, then kill it."""
        proc = self._proc
        if proc is None:
            return
        if self._exit_status(0) is None:
            try:
                proc.stdin.write(b"quit\n")
                proc.stdin.flush()
                proc.stdin.close()
            except (OSError, ValueError):
                pass
            self._exit_status(grace)
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
                    raise PortFailure("flood", "output flood: the port wrote more than the allowed bytes while "
                                               f"sending {what}")
                try:
                    return raw.decode("ascii").rstrip("\r\n")
                except UnicodeDecodeError:
                    raise PortFailure("garbage", f"garbage from the port: non-ASCII bytes in {raw[:60]!r}") from None
            if len(self._buffer) > budget[0]:
                raise PortFailure("flood",
                                  f"output flood: a line longer than {budget[0] + 1} bytes while reading {what}")
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
        code = self._exit_status(2)
        if code is None:
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


class PortSet:
    """The port processes of one run, for :meth:`kill_all` to stop every one of them.

    Once :meth:`kill_all` has begun, a port that is started (a restart, or another
    ``--jobs`` process in a thread the interruption did not reach) is refused by
    :meth:`enlist` and killed at once, so none slips through.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._ports: list[PortProcess] = []
        self._closed = False

    def enlist(self, port: PortProcess) -> bool:
        """Add a started port; False once the set is being killed (the caller kills the port)."""
        with self._lock:
            if self._closed:
                return False
            self._ports.append(port)
            return True

    def kill_all(self) -> None:
        """Kill every port of the set, with what it started, and refuse ports started from now on."""
        with self._lock:
            self._closed = True
            ports = list(self._ports)
        for port in ports:
            port.kill()
        _orphans.kill_adopted([port.token for port in ports])  # and anything of theirs orphaned since

    def __enter__(self) -> PortSet:
        return self

    def __exit__(self, *exc_info) -> None:
        self.kill_all()


def describe_command(command: Sequence[str]) -> str:
    """The command as one shell-like string, for reports."""
    import shlex

    return " ".join(shlex.quote(c) for c in command)


__all__ = ["PortFailure", "PortProcess", "PortSet", "describe_command", "STDERR_TAIL"]
