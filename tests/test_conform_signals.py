"""``dynval conform`` under attack: signals to the runner and ports that escape their supervisor.

Each test runs ``python -m dynval conform`` in a subprocess with the hostile port
``tests/ports/stubborn.py`` (it ignores SIGTERM, SIGHUP and SIGINT, and may leave children
behind, kill its supervisor or double-fork), waits until the port is where the case needs it,
stops the runner or lets it finish, and then requires that no process of the run is left:
not the supervisor, not the port, not anything they started (their pids are read from the
log the port writes, and checked in /proc).
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

import dynval
from ports.tiny_corpus import write_tiny_corpus

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads /proc; the supervisor is Linux-only")

PORT = pathlib.Path(__file__).resolve().parent / "ports" / "stubborn.py"
PACKAGE_ROOT = str(pathlib.Path(dynval.__file__).resolve().parent.parent)
#: Generous limits for a loaded 2-core machine; a passing test takes about 2 s.
WAIT = 30.0


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return str(write_tiny_corpus(tmp_path_factory.mktemp("corpus")))


@contextlib.contextmanager
def _default_dispositions():
    """The runner starts with the default action for the stop signals, whatever pytest has.

    A signal ignored at start stays ignored in the runner, by design (``nohup`` ignores SIGHUP, a
    shell ignores SIGINT for a background job): pytest run that way must not make these tests fail.
    A handled signal is reset to the default by ``exec``, so one is handled for the moment of the start.
    """
    previous = {sig: signal.signal(sig, lambda signum, frame: None)
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


class Run:
    """``python -m dynval conform`` with the stubborn port, and the processes the port logged."""

    def __init__(self, tmp_path: pathlib.Path, corpus: str, *port_flags: str, jobs: int = 1) -> None:
        self.log = tmp_path / "processes.log"
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [PACKAGE_ROOT, os.environ.get("PYTHONPATH")])))
        command = [sys.executable, "-m", "dynval", "conform", "--quiet", "--corpus", corpus, "--families", "norms",
                   "--timeout", "60", "--jobs", str(jobs), "--", sys.executable, str(PORT), str(self.log), *port_flags]
        with _default_dispositions():
            self.proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, text=True, env=env)

    def lines(self) -> list[str]:
        try:
            return self.log.read_text().splitlines()
        except FileNotFoundError:
            return []

    def wait_for(self, state: str, count: int = 1) -> None:
        """Wait until the port logged ``state`` ``count`` times (and every process it forks)."""
        deadline = time.monotonic() + WAIT
        while self.lines().count(state) < count or not self._forks_logged():
            if self.proc.poll() is not None:
                pytest.fail(f"the runner exited ({self.proc.returncode}) before the port got to {state!r}: "
                            f"{self.proc.communicate()}")
            assert time.monotonic() < deadline, f"the port never got to {state!r}: {self.lines()}"
            time.sleep(0.05)

    def _forks_logged(self) -> bool:
        roles = [line.split()[0] for line in self.lines()]
        return roles.count("intermediate") == roles.count("grandchild") == roles.count("child")

    def finish(self) -> tuple[int, str]:
        """The runner's exit status and standard error, once it has exited."""
        try:
            _, err = self.proc.communicate(timeout=WAIT)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            pytest.fail("the runner did not exit")
        return self.proc.returncode, err

    def pids(self) -> dict[int, str]:
        return {int(pid): role for role, pid in (line.split() for line in self.lines() if " " in line)}

    def survivors(self, within: float = 10.0) -> dict[int, str]:
        """The logged processes still running after ``within`` seconds (zombies count as gone)."""
        deadline = time.monotonic() + within
        while True:
            alive = {pid: role for pid, role in self.pids().items() if self._running(pid)}
            if not alive or time.monotonic() > deadline:
                return alive
            time.sleep(0.05)

    def _running(self, pid: int) -> bool:
        # The log's path is on the command line of every process of the run: a reused pid is not ours.
        try:
            stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
            cmdline = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            return False
        return stat.rpartition(")")[2].split()[0] != "Z" and str(self.log).encode() in cmdline

    def cleanup(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()
        for pid in self.pids():
            if self._running(pid):
                os.kill(pid, signal.SIGKILL)


@pytest.fixture
def runs():
    started: list[Run] = []
    yield started
    for run in started:
        run.cleanup()


def start(runs, *args, **kwargs) -> Run:
    run = Run(*args, **kwargs)
    runs.append(run)
    return run


def assert_stopped_by(run: Run, sig: signal.Signals) -> None:
    """The runner exits 128 + the signal's number with one line on standard error, leaving nothing."""
    code, err = run.finish()
    survivors = run.survivors()
    assert not survivors, f"still running after {sig.name}: {survivors} (log: {run.lines()})"
    assert code == 128 + sig, (code, err)
    assert err.splitlines() == [f"dynval conform: interrupted by {sig.name}"], err


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_a_termination_signal_stops_every_process_of_a_busy_port(tiny, tmp_path, runs, sig):
    # The port ignores the signal, and so do its child and the grandchild it orphaned in a session of its own.
    run = start(runs, tmp_path, tiny, "--double-fork")
    run.wait_for("busy")
    run.proc.send_signal(sig)
    assert_stopped_by(run, sig)
    assert {"port", "child", "grandchild"} <= set(run.pids().values())


def test_ctrl_c_during_the_handshake_stops_the_port(tiny, tmp_path, runs):
    run = start(runs, tmp_path, tiny, "--double-fork", "--slow-greeting")
    run.wait_for("greeting")
    run.proc.send_signal(signal.SIGINT)
    assert_stopped_by(run, signal.SIGINT)


def test_ctrl_c_stops_every_port_process_of_a_parallel_run(tiny, tmp_path, runs):
    run = start(runs, tmp_path, tiny, jobs=2)
    run.wait_for("busy", count=2)
    run.proc.send_signal(signal.SIGINT)
    assert_stopped_by(run, signal.SIGINT)
    assert list(run.pids().values()).count("port") == 2


def test_a_port_that_kills_its_supervisor_is_still_reaped_after_the_run(tiny, tmp_path, runs):
    # setsid() takes the port out of the process group the runner kills; with its supervisor dead,
    # nothing below the runner would adopt it and its orphaned grandchild any more.
    run = start(runs, tmp_path, tiny, "--kill-supervisor", "--double-fork", "--answer")
    code, err = run.finish()
    assert code == 1, err  # every case answered with an error: failed, but the run ended normally
    survivors = run.survivors()
    assert not survivors, f"still running after the run: {survivors} (log: {run.lines()})"
    assert {"supervisor", "port", "child", "grandchild"} <= set(run.pids().values())


def test_a_signal_stops_a_busy_port_that_killed_its_supervisor(tiny, tmp_path, runs):
    run = start(runs, tmp_path, tiny, "--kill-supervisor", "--double-fork")
    run.wait_for("busy")
    run.proc.send_signal(signal.SIGTERM)
    assert_stopped_by(run, signal.SIGTERM)


@pytest.mark.slow
def test_a_signal_stops_a_busy_port_that_stopped_its_supervisor(tiny, tmp_path, runs):
    # The stopped supervisor cannot act on the runner's SIGTERM: after its grace (5 s) the runner kills it
    # with SIGKILL, and then the port, which left the supervisor's process group, as an orphan of its own.
    run = start(runs, tmp_path, tiny, "--stop-supervisor", "--double-fork")
    run.wait_for("busy")
    run.proc.send_signal(signal.SIGTERM)
    assert_stopped_by(run, signal.SIGTERM)


def test_the_supervisor_stops_the_port_when_the_runner_is_killed_outright(tiny, tmp_path, runs):
    # SIGKILL leaves the runner no cleanup at all: the supervisor notices that its parent died.
    run = start(runs, tmp_path, tiny, "--double-fork")
    run.wait_for("busy")
    run.proc.kill()
    code, _ = run.finish()
    assert code == -signal.SIGKILL
    survivors = run.survivors()
    assert not survivors, f"still running after the runner was killed: {survivors} (log: {run.lines()})"


# --------------------------------------------------------------------------- the signal handlers themselves


@pytest.fixture
def default_handlers():
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGHUP)}
    for sig in saved:
        signal.signal(sig, signal.SIG_DFL)
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


def test_a_stop_signal_raises_once_and_the_cleanup_is_not_cut_short(default_handlers):
    from dynval.conform._signals import Stopped, stopping_on_signals

    with stopping_on_signals():
        with pytest.raises(Stopped) as stopped:
            signal.raise_signal(signal.SIGTERM)
        assert stopped.value.signum == signal.SIGTERM and isinstance(stopped.value, KeyboardInterrupt)
        signal.raise_signal(signal.SIGHUP)  # during the cleanup: ignored, not a second exception
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # put back
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_DFL


def test_a_signal_the_caller_ignores_stays_ignored(default_handlers):
    # nohup dynval conform ...: SIGHUP is ignored on entry and must not stop the run.
    from dynval.conform._signals import stopping_on_signals

    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    with stopping_on_signals():
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
        signal.raise_signal(signal.SIGHUP)
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN


# --------------------------------------------------------------------------- the runner's own sweep


def test_the_sweep_kills_the_processes_of_its_port_and_no_other(tmp_path):
    from dynval.conform import _orphans

    token = _orphans.new_token()
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)", str(tmp_path)]
    marked = subprocess.Popen(sleeper, env={**os.environ, _orphans.TOKEN_VARIABLE: token})
    other = subprocess.Popen(sleeper, env={**os.environ, _orphans.TOKEN_VARIABLE: _orphans.new_token()})
    bystander = subprocess.Popen(sleeper)
    try:
        deadline = time.monotonic() + WAIT
        while _orphans.TOKEN_VARIABLE.encode() not in pathlib.Path(f"/proc/{marked.pid}/environ").read_bytes():
            assert time.monotonic() < deadline  # still the forked test process, before exec
            time.sleep(0.01)
        _orphans.kill_adopted([token])
        assert not pathlib.Path(f"/proc/{marked.pid}").exists()  # killed and reaped
        assert other.poll() is None and bystander.poll() is None
    finally:
        for proc in (marked, other, bystander):
            proc.kill()
            proc.wait()
