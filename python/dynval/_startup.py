"""Ctrl-C while the command line starts: exit 130 quietly (contract §7).

Importing the package (numpy, scipy, the kernels) takes about a second, before
:func:`dynval.cli.main` can catch ``KeyboardInterrupt``; an interrupt then would print a traceback.
The package imports this module first; it installs a quiet SIGINT handler only when the process
is the ``dynval`` command (``python -m dynval`` or the console script), never in a program that
imports dynval, and :func:`dynval.cli.main` puts Python's own handler back once it runs.
"""

from __future__ import annotations

import os
import signal
import sys

EXIT_INTERRUPTED = 130  # 128 + SIGINT


def _quiet_exit(signum: int, frame: object) -> None:
    os.write(2, b"dynval: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


def _is_the_command_line() -> bool:
    argv = list(getattr(sys, "orig_argv", []))
    if "-m" in argv[:-1] and argv[argv.index("-m") + 1] == "dynval":
        return True
    return os.path.basename(sys.argv[0] if sys.argv else "") in ("dynval", "dynval.exe", "dynval-script.py")


def install() -> None:
    """The quiet handler, when this process is the command line and SIGINT has Python's default."""
    if _is_the_command_line() and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _quiet_exit)


def restore() -> None:
    """Python's handler again (KeyboardInterrupt), once the command line can catch it."""
    if signal.getsignal(signal.SIGINT) is _quiet_exit:
        signal.signal(signal.SIGINT, signal.default_int_handler)


install()
