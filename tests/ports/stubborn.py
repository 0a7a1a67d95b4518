"""Hostile port: ignores SIGTERM, SIGHUP and SIGINT, leaves processes behind, may kill its supervisor.

    stubborn.py LOG [--slow-greeting] [--kill-supervisor | --stop-supervisor] [--double-fork] [--answer]

It needs only the standard library (no dynval import), so that it starts fast. Every process
it makes appends ``ROLE PID`` to LOG, and the port appends a state line when it gets there:
``greeting`` (sleeping before its greeting, with --slow-greeting) or ``busy`` (it read a case
and will never answer it, without --answer). The runner's tests read LOG to learn what must
be gone once ``dynval conform`` has exited; every process carries LOG on its command line.

* ``--kill-supervisor``: leaves its session (``setsid()``) and SIGKILLs its parent, the
  supervisor the runner started it under (logged first, as ``supervisor PID``), before greeting.
* ``--stop-supervisor``: the same with SIGSTOP, so that the supervisor can no longer act on the
  runner's SIGTERM and the runner has to kill it.
* ``--double-fork``: starts a child that starts a grandchild in a session of its own and
  exits, so that the grandchild is orphaned; a plain child stays in the port's group too.
* ``--answer``: answers every case with an error instead of hanging, so that the run ends.
"""

import os
import signal
import sys
import time


def log(path: str, line: str) -> None:
    # One write of a short line to a file opened for appending: never interleaved.
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, (line + "\n").encode())
    finally:
        os.close(fd)


def sleep_forever() -> None:
    while True:
        time.sleep(3600)


def spawn(path: str, role: str, *, new_session: bool = False) -> None:
    """A forked process that ignores the polite signals too and sleeps forever."""
    if os.fork() == 0:
        if new_session:
            os.setsid()
        log(path, f"{role} {os.getpid()}")
        sleep_forever()


def double_fork(path: str) -> None:
    pid = os.fork()
    if pid == 0:
        log(path, f"intermediate {os.getpid()}")
        spawn(path, "grandchild", new_session=True)
        time.sleep(0.2)  # let the grandchild log itself before it is orphaned
        os._exit(0)
    os.waitpid(pid, 0)
    spawn(path, "child")


def main(argv: list[str]) -> int:
    path, flags = argv[0], set(argv[1:])
    for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        signal.signal(sig, signal.SIG_IGN)
    log(path, f"supervisor {os.getppid()}")
    if "--kill-supervisor" in flags or "--stop-supervisor" in flags:
        os.setsid()
        os.kill(os.getppid(), signal.SIGKILL if "--kill-supervisor" in flags else signal.SIGSTOP)
    log(path, f"port {os.getpid()}")
    if "--double-fork" in flags:
        double_fork(path)
    if "--slow-greeting" in flags:
        log(path, "greeting")
        sleep_forever()
    sys.stdout.write("dynval-port 1 stubborn\ncapability sse\ncapability rmse\ncapability max_abs_error\nready\n")
    sys.stdout.flush()
    for line in sys.stdin:
        if line.strip() != "end":
            continue
        if "--answer" not in flags:
            log(path, "busy")
            sleep_forever()
        sys.stdout.write("error InvalidParameter stubborn\nend\n")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
