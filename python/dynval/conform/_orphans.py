"""Processes a port left behind after killing its supervisor: the runner adopts and kills them (Linux).

The supervisor (``_reaper.py``) adopts whatever the port orphans, but a port can kill the
supervisor itself (after ``setsid()``, so that the kill of its process group misses it too).
While a run lasts, the runner is therefore a child subreaper as well
(``prctl(PR_SET_CHILD_SUBREAPER)``): a process orphaned anywhere below it is reparented to
it instead of to init. It tells a port's processes from any other child by a token in their
environment (``DYNVAL_CONFORM_PORT``, inherited by everything the port starts), kills them
(SIGKILL) and reaps them. A process that is our child cannot be replaced by another under the
same pid before we reap it, so no unrelated process is ever signalled.

Limits: elsewhere than on Linux, and where prctl is refused, orphans go to init and are not
found; a process that replaced its environment (``execve`` with a fresh one) or made itself
undumpable (its environment is then unreadable) is not recognised; and nothing helps when
the runner itself is killed with SIGKILL (the supervisor then still stops the port: it gets
SIGTERM when the runner dies, see ``_reaper.py``).
"""

from __future__ import annotations

import os
import secrets
import signal
import sys
import threading
import time
from collections.abc import Collection, Iterator
from contextlib import contextmanager

# the supervisor's module is standard library only and imports nothing of dynval
from ._reaper import PR_SET_CHILD_SUBREAPER, TOKEN_VARIABLE, children

#: Seconds spent killing adopted processes before giving up on one that will not die.
KILL_LIMIT = 5.0

_lock = threading.Lock()
_adopters = 0  # runs under way in this process: the last one to end turns adoption off


def new_token() -> str:
    """A token no other port process, of this run or another, carries."""
    return f"{os.getpid()}-{secrets.token_hex(8)}"


def _set_subreaper(on: bool) -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0) == 0
    except (ImportError, OSError, AttributeError):
        return False


@contextmanager
def adopting() -> Iterator[None]:
    """Make this process a child subreaper for the duration (nested and concurrent runs share it)."""
    global _adopters
    with _lock:
        _adopters += 1
        if _adopters == 1:
            _set_subreaper(True)
    try:
        yield
    finally:
        with _lock:
            _adopters -= 1
            if _adopters == 0:
                _set_subreaper(False)


def _carries(pid: int, wanted: set[bytes]) -> bool:
    try:
        with open(f"/proc/{pid}/environ", "rb") as handle:
            environ = handle.read()
    except OSError:
        return False  # exited, or unreadable
    return any(entry in wanted for entry in environ.split(b"\0"))


def _reaped(pid: int) -> bool:
    try:
        return os.waitpid(pid, os.WNOHANG)[0] == pid
    except ChildProcessError:
        return True


def kill_adopted(tokens: Collection[str]) -> None:
    """Kill and reap every child of ours that carries one of ``tokens`` (and what it started).

    Killing one hands its own children to us, so this goes round after round until no child
    carries a token, or ``KILL_LIMIT`` seconds have passed.
    """
    if not tokens or not sys.platform.startswith("linux"):
        return
    wanted = {f"{TOKEN_VARIABLE}={token}".encode() for token in tokens}
    killed: set[int] = set()  # killed, not yet reaped: a zombie's environment reads empty
    deadline = time.monotonic() + KILL_LIMIT
    while time.monotonic() < deadline:
        found = [pid for pid in children() if pid not in killed and _carries(pid, wanted)]
        for pid in found:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        killed.update(found)
        killed = {pid for pid in killed if not _reaped(pid)}
        if not found and not killed:
            return
        time.sleep(0.01)
