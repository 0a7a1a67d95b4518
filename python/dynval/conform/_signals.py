"""SIGTERM and SIGHUP stop ``dynval conform`` the way Ctrl-C does: ports killed first.

Python's default for SIGTERM and SIGHUP is to die on the spot, which would leave the
supervisors and the ports running. While :func:`stopping_on_signals` is in force, SIGINT,
SIGTERM and SIGHUP raise :class:`Stopped` in the main thread instead, so that the run's
cleanup (``conform._runner.run``) kills every port before the runner exits. Further
signals are ignored until the cleanup is over: a second Ctrl-C must not cut it short.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: The signals that stop a run (Windows has no SIGHUP).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class Stopped(KeyboardInterrupt):
    """The run was stopped by the signal ``signum``.

    A :class:`KeyboardInterrupt`, so that code which cleans up after Ctrl-C does so after
    SIGTERM and SIGHUP as well.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextmanager
def stopping_on_signals() -> Iterator[None]:
    """Turn the stop signals into :class:`Stopped` for the duration (main thread only).

    A signal whose handling the caller already changed (``nohup`` ignores SIGHUP, a host
    program may have its own SIGTERM handler) is left alone; the previous handlers are put
    back on exit.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can only be set in the main thread
        return
    stopping = False

    def stop(signum, frame):
        nonlocal stopping
        if stopping:
            return  # the cleanup is under way: let it finish
        stopping = True
        raise Stopped(signum)

    previous = {}
    for sig in STOP_SIGNALS:
        if signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler):
            previous[sig] = signal.signal(sig, stop)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def exit_status(signum: int) -> int:
    """The shell's convention for a program ended by the signal: 128 + its number."""
    return 128 + signum
