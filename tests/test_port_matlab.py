"""The MATLAB port (matlab/), run by GNU Octave: its own %!test blocks, and the whole corpus.

The tests need ``octave-cli`` (Debian package ``octave``; ``matlab/install-toolchain`` installs
it). Where it is missing they skip, unless the environment variable DYNVAL_REQUIRE_TOOLCHAINS
(comma-separated, e.g. ``java,octave,mathics``) names ``octave``: then a missing toolchain is a
failure, so that CI cannot pass by skipping.
"""

from __future__ import annotations

import pathlib
import re
import shutil
import subprocess
import threading

import pytest

from port_checks import assert_passes_whole_corpus, require_toolchain

ROOT = pathlib.Path(__file__).resolve().parents[1]
MATLAB_DIR = ROOT / "matlab"
RUN_PORT = MATLAB_DIR / "run-port"
RUN_TESTS = MATLAB_DIR / "run-tests"


def _require_octave() -> None:
    require_toolchain("octave", [] if shutil.which("octave-cli") else ["octave-cli"],
                      "matlab/install-toolchain installs GNU Octave")


@pytest.mark.slow
def test_matlab_unit_tests():
    """``matlab/run-tests``: every %!test / %!assert / %!error block passes, and there are many."""
    _require_octave()
    proc = subprocess.run([str(RUN_TESTS)], capture_output=True, text=True, timeout=600)
    tail = proc.stdout[-6000:] + proc.stderr[-2000:]
    assert proc.returncode == 0, f"matlab/run-tests failed:\n{tail}"
    summary = re.findall(r"^(\d+) tests, (\d+) passed, (\d+) failed$", proc.stdout, re.M)
    assert summary, f"no summary line in the Octave output:\n{tail}"
    total, passed, failed = (int(x) for x in summary[-1])
    assert total >= 100 and passed == total and failed == 0, tail


@pytest.mark.slow
def test_matlab_port_answers_in_lock_step():
    """The port answers a case while the runner keeps its stdin open (no read-ahead deadlock).

    The runner sends a case and waits for ``end`` before it sends anything else. A reader that
    needs one character past the newline (Octave 7's ``fgetl(stdin)`` on a pipe) never answers.
    """
    _require_octave()
    with subprocess.Popen([str(RUN_PORT)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                          stderr=subprocess.DEVNULL, text=True) as proc:
        timer = threading.Timer(60, proc.kill)  # a deadlocked port fails the test, never hangs it
        timer.start()
        try:
            greeting = proc.stdout.readline()
            assert greeting.startswith("dynval-port 1 "), greeting
            while (line := proc.stdout.readline()).strip() != "ready":
                assert line.startswith("capability "), line
            replies = []
            for values in ("1.0 2.0", "3.0 5.0"):
                proc.stdin.write('case norms 1 sse multioutput="pooled" nan_policy="raise"\n'
                                 f"array tau_meas real 2 2 1 {values}\n"
                                 "array tau_pred real 2 2 1 0.0 0.0\nend\n")
                proc.stdin.flush()
                replies.append([proc.stdout.readline(), proc.stdout.readline()])
            assert [r[1].strip() for r in replies] == ["end", "end"], replies
            assert [r[0].split()[:4] for r in replies] == [["result", "value", "real", "0"]] * 2, replies
            assert [float(r[0].split()[-1]) for r in replies] == [5.0, 34.0], replies
            proc.stdin.write("quit\n")
            proc.stdin.flush()
            assert proc.wait(timeout=30) == 0
        finally:
            timer.cancel()
            if proc.poll() is None:
                proc.kill()


@pytest.mark.slow
def test_matlab_port_passes_the_whole_corpus(tmp_path):
    """``dynval conform --strict -- matlab/run-port``: exit 0 and every vector of the eight required families passed."""
    _require_octave()
    assert_passes_whole_corpus(RUN_PORT, tmp_path / "matlab-conform.json")
