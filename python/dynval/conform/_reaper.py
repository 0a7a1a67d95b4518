"""Supervisor between ``dynval conform`` and a port (Linux): no process of the port outlives it.

Run as a script, not imported (only the standard library, so that it starts fast)::

    python -I -S _reaper.py STATUS_FD RUNNER_PID TOKEN -- COMMAND ARGS...

It makes itself a *child subreaper* (``prctl(PR_SET_CHILD_SUBREAPER)``), so every
process the port leaves behind, even one that left the process group with
``setsid()``, is reparented to it instead of to init. It starts the port with its
own standard streams and ``DYNVAL_CONFORM_PORT=TOKEN`` in its environment (by which
the runner knows the port's processes should the port kill this supervisor), reports
on ``STATUS_FD`` (``ok`` or ``error MESSAGE``) and drops its copies of the streams, so
end of output still means the port closed it.

When the port exits, or when the runner sends SIGTERM, it kills every remaining
descendant and exits the way the port did (same exit code or signal). It only
ever signals its own children, whose process ids cannot be reused before it reaps
them, so it cannot hit an unrelated process. It also asks for SIGTERM when the
runner dies (``prctl(PR_SET_PDEATHSIG)``), so that a runner killed outright, with
no chance to clean up, still leaves nothing of the port behind. (The kernel sends it
when the runner's *thread* that started the supervisor ends; the runner stops every
port before the thread that started it ends, so that is never early.)
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

PR_SET_PDEATHSIG = 1
PR_SET_CHILD_SUBREAPER = 36
#: Environment variable carrying the runner's token for this port (see conform/_orphans.py).
TOKEN_VARIABLE = "DYNVAL_CONFORM_PORT"
#: Seconds spent killing descendants before giving up on one that will not die.
CLEANUP_LIMIT = 10.0


class _Stop(Exception):
    """Raised by the SIGTERM handler to interrupt the wait for the port."""


def _on_term(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # one stop is enough; the cleanup must not be interrupted
    raise _Stop


def _prctl(option: int, value: int) -> None:
    # On failure (no ctypes, no such prctl) the port still runs: the runner's kill of
    # the process group is then the only cleanup left.
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(option, value, 0, 0, 0)
    except (ImportError, OSError, AttributeError):
        pass


def _follow_runner(runner: int) -> None:
    """SIGTERM when the runner dies; exit now if it already has (we were reparented)."""
    _prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != runner:
        os._exit(1)


def children() -> list[int]:
    """Our children right now, from /proc/<pid>/stat (orphans adopted as subreaper included).

    Also the runner's list of its adopted processes (conform/_orphans.py): one parser of /proc."""
    me, found = os.getpid(), []
    try:
        entries = os.listdir("/proc")
    except OSError:
        return found
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as handle:
                stat = handle.read()
        except OSError:
            continue  # exited meanwhile
        # "pid (comm) state ppid ...": comm may hold blanks and parentheses.
        fields = stat[stat.rfind(b")") + 2 :].split()
        if len(fields) > 1 and int(fields[1]) == me:
            found.append(int(entry))
    return found


def _reap() -> bool:
    """Reap every exited child; False once we have no child at all."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return False
        if pid == 0:
            return True


def _kill_descendants() -> None:
    # Killing a child hands its own children to us (we are their subreaper), so
    # kill our children round after round until none is left.
    deadline = time.monotonic() + CLEANUP_LIMIT
    while _reap() and time.monotonic() < deadline:
        for pid in children():
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        time.sleep(0.01)


def _wait_for(port: subprocess.Popen) -> int:
    """Wait for the port (reaping adopted orphans meanwhile); its wait status."""
    while True:
        pid, status = os.waitpid(-1, 0)
        if pid == port.pid:
            return status


def _exit_like(status: int) -> None:
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        try:
            import resource

            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # the port's crash, not ours to dump
            signal.signal(sig, signal.SIG_DFL)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, [sig])
            os.kill(os.getpid(), sig)
        except (OSError, ValueError):
            pass
        os._exit(128 + sig)
    os._exit(os.WEXITSTATUS(status) if os.WIFEXITED(status) else 1)


def _drop_streams() -> None:
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(null, fd)
    os.close(null)


def main(argv: list[str]) -> None:
    status_fd, runner, token, command = int(argv[0]), int(argv[1]), argv[2], argv[4:]
    signal.signal(signal.SIGTERM, _on_term)
    _follow_runner(runner)
    _prctl(PR_SET_CHILD_SUBREAPER, 1)
    status = signal.SIGKILL  # a wait status: what the runner sees when it stops the port
    try:
        try:
            port = subprocess.Popen(command, env={**os.environ, TOKEN_VARIABLE: token})
        except (OSError, ValueError) as exc:
            os.write(status_fd, f"error {exc}".encode("utf-8", "replace"))
            os._exit(127)
        os.write(status_fd, b"ok")
        os.close(status_fd)
        _drop_streams()
        status = _wait_for(port)
    except _Stop:
        pass
    _kill_descendants()
    _exit_like(status)


if __name__ == "__main__":
    main(sys.argv[1:])
